//! `ssmulti` (the seed's `ssIntegMulti`): multiple scattering at every
//! cloud point, `ssM` (colour), exactly as `../shared/DESIGN.md` writes
//! it:
//!
//! ```text
//! ld = Rd * sd (per channel), ld1 = max(ld)
//! for every point i with r = |Xo - Xi| <= ld1 (o itself included):
//!     Li = (Xo - Xi) / ld1
//!     kb = lerp(1, 1 - (1 - No.Ni) (1 - No.Li) / 2, bounce)
//!     if kb > 0:
//!         t_rgb: ssm[c] += kb illum_i[c] ptarea_i W(r, ld[c])
//!         else:  ssm    += kb illum_i    ptarea_i W(r, ld1)
//! not t_rgb: ssm *= Rd
//! ssM = ssm / I(ld1), I(D) = the disk integral of W(., D)
//! ```
//!
//! Normalisations (`Norm`): `Seed` is the above (Houdini's semantics: in
//! t_rgb mode every channel by the largest distance's integral, no `Rd`);
//! `Channel`: in t_rgb mode channel c by its own `I(ld[c])`, times
//! `Rd[c]`; `Local`: by the kernel-weighted area present within reach,
//! `A[c] = sum_i ptarea_i W(r, ld[c])` (no `kb`), times `Rd[c]`: an open
//! edge or a thin part no longer goes dark.
//!
//! Falloffs (`Falloff`), all zero beyond `D`:
//! - `Smooth`: `1 - smooth(0, D, r)`, `I = 3 pi D^2 / 10`.
//! - `Exp { sigma }`: `exp(-sigma r / D)`,
//!   `I = 2 pi D^2 (1 - e^-sigma (1 + sigma)) / sigma^2`, evaluated by its
//!   series below sigma = 0.5 (the closed form cancels) and with
//!   `expm1` above (never overflows: only `e^-sigma` appears).
//! - `Burley { kappa }`: Christensen and Burley's normalised diffusion
//!   profile, truncated at `D` and renormalised over the disk; see
//!   [`burley`] for the derivation.
//!
//! The method: points sorted along a Morton curve into leaves of at most
//! `LEAF` points (a binary tree over them from the same splits; a cell
//! that still holds more than a leaf is coded again within its own box,
//! so that an outlier far away or a small part of a large scene does not
//! make its leaves wide), each leaf's points stored as f32 columns relative to the leaf's own origin
//! (an f64), sources first, in groups of eight with a bounding sphere per
//! group. A receiver leaf scans the tree once for the source leaves whose
//! boxes come within `ld1` of its box and copies their source groups
//! within reach into one scratch, in its own frame (`Gathered`); each
//! group of eight receivers, one a vector lane, then lists the scratch's
//! sources within reach of its bounding sphere and sums them, one source
//! broadcast to the eight lanes at a time (AVX2 and FMA when the CPU has
//! them, chosen at run time, one compiled loop per kernel and switch).
//! Pair differences are taken between two small local coordinates plus
//! the leaves' offset, so a cloud 1e6 from the origin loses nothing when
//! its positions are f64. The f32 lanes are added into f64 every `FLUSH`
//! sources: the rounding does not grow with the neighbour count. Points
//! with zero `illum` are not sources (except for `Local`, which needs
//! their area); white light (every `illum` with three equal channels)
//! under one kernel is summed in one channel, the others copied (the
//! same numbers); a receiver's sums run in a fixed order, so the output bits
//! do not depend on the thread count. The approximate method
//! (`tolerance > 0`, see `approx_plan`) replaces far enough clusters of
//! the tree by one pseudo-source each and runs the same loop.

// Numeric kernels index lanes and channels side by side.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::PI;
use std::mem::MaybeUninit;

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Attribute, Cloud, DetailValue, Role};
use crate::column::{Column, Scalar};
use crate::disjoint::Disjoint;
use crate::error::{Error, Result};
use crate::progress::{Phases, Progress};

/// The falloff kernel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Falloff {
    /// `1 - smooth(0, D, r)` (the seed's).
    Smooth,
    /// `exp(-sigma r / D)` (the seed's alternative).
    Exp { sigma: f64 },
    /// Christensen-Burley, shape `d = D / kappa`, truncated at `D`.
    Burley { kappa: f64 },
}

/// The default `kappa` of the Burley falloff, `d = D / kappa`: the
/// profile's mean radius `2.5 d` equals the smooth falloff's `4 D / 9`
/// (`kappa = 2.5 * 9 / 4`), so switching falloffs keeps the look's scale;
/// 88% of the untruncated profile's energy lies within `D`. Larger values
/// keep more of the tail but need denser clouds: the profile's core is
/// `d` wide and wants many points across it.
pub const BURLEY_KAPPA: f64 = 5.625;

/// How the sum is normalised.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Norm {
    Seed,
    Channel,
    Local,
}

/// Parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Diffuse reflectance per channel.
    pub rd: [f64; 3],
    /// Scattering distance.
    pub sd: f64,
    /// Bounce attenuation, 0 (off) to 1.
    pub bounce: f64,
    /// Per-channel distances (`t_rgb`).
    pub rgb: bool,
    pub falloff: Falloff,
    pub norm: Norm,
    /// 0: exact. Above: the approximate method's tolerance.
    pub tolerance: f64,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            rd: [1.0; 3],
            sd: 1.0,
            bounce: 0.0,
            rgb: false,
            falloff: Falloff::Smooth,
            norm: Norm::Seed,
            tolerance: 0.0,
        }
    }
}

/// What `ssmulti` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub points: usize,
    /// Points that were sources.
    pub sources: usize,
    /// Point pairs evaluated (including those beyond reach in a block).
    pub pairs: u64,
    /// Points whose `ssM` was computed (all of them, or with a subset the
    /// leaves of 64 that hold a wanted point).
    pub computed: usize,
    /// Every `illum` had three equal channels (white light) and one kernel
    /// served all channels: one channel was summed, the others copied.
    pub grey: bool,
}

/// Points per leaf (a multiple of the lane count).
pub const LEAF: usize = 64;
const LANES: usize = 8;

/// Checks the parameters; errors name the option.
pub fn validate(p: &Params) -> Result<()> {
    for (c, &x) in p.rd.iter().enumerate() {
        if !(x.is_finite() && x >= 0.0) {
            return Err(Error::param(
                "--rd",
                format!("channel {c} is {x:?}: not a finite number >= 0"),
            ));
        }
    }
    if !(p.sd.is_finite() && p.sd >= 0.0) {
        return Err(Error::param(
            "--sd",
            format!("{:?} is not a finite number >= 0", p.sd),
        ));
    }
    if !(p.bounce.is_finite() && (0.0..=1.0).contains(&p.bounce)) {
        return Err(Error::param(
            "--bounce",
            format!("{:?} is not in [0, 1]", p.bounce),
        ));
    }
    match p.falloff {
        Falloff::Exp { sigma } if !(sigma.is_finite() && sigma > 0.0 && sigma <= 1e6) => {
            return Err(Error::param(
                "--sigma",
                format!("{sigma:?} is not in (0, 1e6]"),
            ));
        }
        Falloff::Burley { kappa } if !(kappa.is_finite() && kappa > 0.0 && kappa <= 1e6) => {
            return Err(Error::param(
                "--sigma",
                format!("{kappa:?} is not in (0, 1e6]"),
            ));
        }
        _ => {}
    }
    if !(p.tolerance.is_finite() && p.tolerance >= 0.0) {
        return Err(Error::param(
            "--tolerance",
            format!("{:?} is not a finite number >= 0", p.tolerance),
        ));
    }
    Ok(())
}

/// `(1 - e^-s (1 + s)) / s^2`, stable for every `s > 0`.
pub fn exp_disk_factor(s: f64) -> f64 {
    if s < 0.5 {
        // sum_{k >= 2} (-1)^k (k - 1) / k! s^(k - 2)
        let mut term: f64 = 0.5; // k = 2: 1 / 2!
        let mut sum: f64 = 0.0;
        let mut k: f64 = 2.0;
        while term.abs() > 1e-18 * sum.abs().max(1e-300) || k < 4.0 {
            sum += term;
            // term_{k+1} / term_k = -s k / ((k + 1) (k - 1))
            term *= -s * k / ((k + 1.0) * (k - 1.0));
            k += 1.0;
            if k > 60.0 {
                break;
            }
        }
        sum
    } else {
        (-(-s).exp_m1() - s * (-s).exp()) / (s * s)
    }
}

/// The disk integral `I(D) = int_0^D W(r, D) 2 pi r dr` of a falloff.
pub fn disk_integral(f: Falloff, d: f64) -> f64 {
    match f {
        Falloff::Smooth => 3.0 * PI * d * d / 10.0,
        Falloff::Exp { sigma } => 2.0 * PI * d * d * exp_disk_factor(sigma),
        Falloff::Burley { kappa } => burley::disk_integral(kappa, d),
    }
}

/// The falloff at distance `r` in f64 (the reference the tests and the
/// approximate method use); `rmin` is the Burley regularisation radius of
/// the source point (see [`burley`]).
pub fn falloff(f: Falloff, r: f64, d: f64, rmin: f64) -> f64 {
    if r > d || d <= 0.0 {
        return 0.0;
    }
    match f {
        Falloff::Smooth => {
            let t = r / d;
            (1.0 - t) * (1.0 - t) * (1.0 + 2.0 * t)
        }
        Falloff::Exp { sigma } => (-sigma * r / d).exp(),
        Falloff::Burley { kappa } => burley::profile(kappa, r, d, rmin),
    }
}

/// The Christensen-Burley falloff.
///
/// Christensen and Burley ("Approximate Reflectance Profiles for Efficient
/// Subsurface Scattering", 2015) fit the diffuse reflectance profile of
/// a semi-infinite medium with
///
/// ```text
/// R(r) = (e^(-r/d) + e^(-r/(3d))) / (8 pi d r)
/// ```
///
/// normalised over the plane: `int_0^inf R 2 pi r dr = (d + 3d) / (4d) =
/// 1`. Here its reach is the seed's scattering distance `D`: with shape
/// `d = D / kappa` we keep `r <= D` and renormalise over that disk. The
/// unnormalised kernel is `W(r) = e^(-r/d) + e^(-r/(3d))) / r` (constant
/// factors cancel in `ssm / I`), and
///
/// ```text
/// I(D) = int_0^D W(r) 2 pi r dr = 2 pi int_0^D (e^(-r/d) + e^(-r/(3d))) dr
///      = 2 pi d ((1 - e^-kappa) + 3 (1 - e^(-kappa/3)))
///      = -2 pi (D / kappa) (expm1(-kappa) + 3 expm1(-kappa/3))
/// ```
///
/// so the truncated, renormalised profile integrates to exactly 1 over the
/// disk. The fraction of the untruncated energy kept is
/// `1 - e^-kappa / 4 - 3 e^(-kappa/3) / 4`: 88% at the default
/// `kappa = 5.625` (see [`BURLEY_KAPPA`]).
///
/// Point sums and the `1/r` singularity: `int R dA` is finite, but a
/// point at distance `r` contributes `ptarea R(r)`, unbounded as `r -> 0`
/// (the receiver itself is at `r = 0`). A source point stands for a disk
/// of area `a = ptarea`, radius `rho = sqrt(a / pi)`; for small `rho`,
/// `int_disk W dA = 2 pi (rho + rho) = 4 pi rho` to first order, and
/// `a W(r_min) = 2 pi rho^2 / r_min` equals it at `r_min = rho / 2`. So the
/// kernel is evaluated at `max(r, r_min)`, `r_min = sqrt(ptarea / pi) / 2`:
/// the self term is right to first order and near neighbours stay
/// bounded; beyond `r_min` it is the exact profile.
pub mod burley {
    use std::f64::consts::PI;

    /// `I(D)` for shape `d = D / kappa`.
    pub fn disk_integral(kappa: f64, d: f64) -> f64 {
        -2.0 * PI * (d / kappa) * ((-kappa).exp_m1() + 3.0 * (-kappa / 3.0).exp_m1())
    }

    /// `W(max(r, rmin))` for `r <= D`.
    pub fn profile(kappa: f64, r: f64, d: f64, rmin: f64) -> f64 {
        let s = d / kappa;
        let r = r.max(rmin);
        if r <= 0.0 {
            return 0.0;
        }
        ((-r / s).exp() + (-r / (3.0 * s)).exp()) / r
    }

    /// The regularisation radius of a source of area `ptarea`.
    pub fn rmin(ptarea: f64) -> f64 {
        0.5 * (ptarea.max(0.0) / PI).sqrt()
    }
}

// ---------------------------------------------------------------------
// The cloud as leaves of Morton-ordered columns.

/// A leaf: points `start..start + len` of the sorted order, sources first
/// (`src` of them), columns padded to a multiple of `LANES` from
/// `col..col + padded(len)`.
#[derive(Clone, Copy, Debug)]
struct Leaf {
    col: usize,
    len: usize,
    src: usize,
    origin: DVec3,
    lo: DVec3,
    hi: DVec3,
    /// What its sources add up to (the tree's leaf node).
    sum: SrcSum,
}

/// What a set of sources adds up to: their box, areas, `illum *
/// ptarea`, area-weighted normals, area-weighted centroid and the largest
/// distance from it to a source.
#[derive(Clone, Copy, Debug, Default)]
struct SrcSum {
    lo: DVec3,
    hi: DVec3,
    a: f64,
    q: [f64; 3],
    n: DVec3,
    centre: DVec3,
    radius: f64,
    sources: usize,
}

/// What the gather reads of a group of `LANES` points, together:
/// positions relative to the leaf origin and `illum[c] * ptarea`. The
/// same groups are the receivers' lanes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Hot {
    x: Lanes,
    y: Lanes,
    z: Lanes,
    q: [Lanes; 3],
}

/// A cluster standing in for its sources: position (receiver leaf's
/// frame), mean normal, `sum illum * ptarea`, `sum ptarea`, Burley's
/// `r_min` for that area.
type Pseudo = ([f32; 3], [f32; 3], [f32; 3], f32, f32);

/// Source columns (f32, relative to the leaf origin), padded per leaf:
/// the hot part a group at a time, the rest a column each.
#[derive(Default)]
struct Columns {
    hot: Vec<Hot>,
    /// The groups' bounding spheres, a column each (centre in the leaf's
    /// frame, radius), one entry a group and `LANES` far away after the
    /// last (a leaf's groups are read eight at a time).
    sph: [Vec<f32>; 4],
    nx: Vec<f32>,
    ny: Vec<f32>,
    nz: Vec<f32>,
    /// `ptarea`.
    a: Vec<f32>,
    /// Burley's `r_min`.
    rmin: Vec<f32>,
    /// Original point index (u32::MAX for padding).
    id: Vec<u32>,
}

/// A padding lane: far away, carrying nothing.
const FAR: f32 = 1e18;

fn padded(n: usize) -> usize {
    n.div_ceil(LANES) * LANES
}

/// Interleaves the low 21 bits of `v` with two zero bits between each,
/// a byte at a time from a table (the shift-and-mask form is a chain of
/// fifteen dependent steps: three times slower here).
#[inline(always)]
fn spread(v: u64) -> u64 {
    const BYTE: [u64; 256] = {
        let mut t = [0u64; 256];
        let mut b = 0;
        while b < 256 {
            let mut k = 0;
            while k < 8 {
                t[b] |= ((b as u64 >> k) & 1) << (3 * k);
                k += 1;
            }
            b += 1;
        }
        t
    };
    let v = v & 0x1f_ffff;
    BYTE[(v & 0xff) as usize]
        | BYTE[(v >> 8 & 0xff) as usize] << 24
        | BYTE[(v >> 16) as usize] << 48
}

/// A point as the pair loop's columns are built from it (40 bytes: its
/// normal is kept apart, and only when `bounce` reads it).
#[derive(Clone, Copy, Default)]
struct Pt {
    pos: [f64; 3],
    area: f32,
    illum: [f32; 3],
}

impl Pt {
    #[inline(always)]
    fn pos_v(&self) -> DVec3 {
        DVec3::from_array(self.pos)
    }
}

struct Inputs<'a> {
    pts: Vec<Pt>,
    /// Unit normals, or nothing (no `bounce`).
    nrm: Vec<[f32; 3]>,
    /// The positions as read (the Morton codes come from these).
    p: [Src<'a>; 3],
    /// The positions' box.
    lo: DVec3,
    hi: DVec3,
    /// Every point's `illum` has three equal channels.
    grey: bool,
    /// What `ptarea` is multiplied by in the sums: the power of two that
    /// brings the cloud's total area into [0.5, 1). A cloud scaled by
    /// 1e-4 then sums numbers of the same size as the unscaled one
    /// (by a power of two: the same bits). Before, its
    /// `illum * ptarea` (~1e-13 at 1M points) times a weight near
    /// `e^-60` was subnormal (30-40% slower for exp sigma 100 and 1000,
    /// `BENCH_SCALE=1e-4` in benches/ssmulti.rs). Exact (a power of two),
    /// undone in the normaliser (`Local` divides it out); `r_min` is taken
    /// from the areas as read.
    area_scale: f64,
}

/// Sorts the points along a Morton curve and cuts them into leaves of at
/// most `LEAF` points that share a prefix (equal codes are cut in runs).
/// A point is a source when it has light, or (`all_sources`) always.
/// `want`: the normals, areas and `r_min` columns (others left empty).
fn build(inp: &Inputs<'_>, all_sources: bool, want: [bool; 3]) -> (Vec<Leaf>, Columns, Vec<TNode>) {
    let mut pb = Phases::new("ssmulti build");
    let n = inp.pts.len();
    let (lo, hi) = (inp.lo, inp.hi);
    let extent = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    // One u64 a point: the Morton code above, the point's index below (so
    // every key is distinct and the order is the same on any thread
    // count). 14 bits an axis (as 4M points leave room for) at every
    // size: points that share a code are cut into leaves in index order,
    // and 42 code bits sort in four radix passes.
    let idx_bits = (usize::BITS - n.max(2).saturating_sub(1).leading_zeros()).max(1);
    let axis_bits = ((64 - idx_bits) / 3).min(14);
    let scale = ((1u64 << axis_bits) - 1) as f64 / extent;
    let cut = Cut {
        pts: &inp.pts,
        idx_bits,
        axis_bits,
    };
    // (From the columns as read: the records are wider.)
    let ps = &inp.p;
    let mut order: Vec<u64> = (0..n)
        .into_par_iter()
        .map(|i| {
            cut.key(
                i,
                DVec3::new(ps[0].get(i), ps[1].get(i), ps[2].get(i)),
                lo,
                scale,
            )
        })
        .collect();
    pb.mark("codes");
    // The keys are in index order: only the code's bits need sorting;
    // the top 33 in three radix passes (11 levels: a cell 1/2048 of the
    // box wide, which mostly holds one point or none), then the points
    // that share a cell by their whole codes.
    let top = idx_bits + 3 * axis_bits;
    let rest = top - top.saturating_sub(idx_bits).min(33);
    crate::radix::sort_bits(&mut order, rest, top);
    crate::radix::sort_runs(&mut order, rest);
    pb.mark("sort");
    let idx_mask = (1u64 << idx_bits) - 1;
    // At most one leaf a point, fewer than two nodes a leaf.
    let mut ranges = Vec::with_capacity(2 * n / LEAF + 1);
    let mut nodes = Vec::with_capacity(4 * n / LEAF + 1);
    split(
        &cut,
        &mut order,
        0,
        n,
        cut.top(),
        0,
        &mut ranges,
        &mut nodes,
    );
    pb.mark("split");
    // Every leaf's columns written in parallel, in place.
    let lens: Vec<usize> = ranges.iter().map(|&(s, e)| padded(e - s)).collect();
    let glens: Vec<usize> = lens.iter().map(|l| l / LANES).collect();
    let total: usize = lens.iter().sum();
    let ng = total / LANES;
    // Allocated, not written: every leaf writes every slot of its pieces
    // (fresh pages are first touched by the thread that fills them).
    let [normals, area, rmin] = want;
    let on = |w: bool| if w { total } else { 0 };
    let mut cols = Columns {
        hot: Vec::with_capacity(ng),
        sph: std::array::from_fn(|_| Vec::with_capacity(ng + LANES)),
        nx: Vec::with_capacity(on(normals)),
        ny: Vec::with_capacity(on(normals)),
        nz: Vec::with_capacity(on(normals)),
        a: Vec::with_capacity(on(area)),
        rmin: Vec::with_capacity(on(rmin)),
        id: Vec::with_capacity(total),
    };
    pb.mark("alloc");
    let mut leaves: Vec<Leaf> = {
        let Columns {
            hot,
            sph,
            nx,
            ny,
            nz,
            a,
            rmin: rm,
            id,
        } = &mut cols;
        let mut phot = pieces(&mut hot.spare_capacity_mut()[..ng], &glens);
        let mut psph = sph
            .each_mut()
            .map(|v| pieces(&mut v.spare_capacity_mut()[..ng], &glens));
        fn col<'a>(
            v: &'a mut Vec<f32>,
            len: usize,
            lens: &[usize],
        ) -> std::vec::IntoIter<&'a mut [MaybeUninit<f32>]> {
            pieces(&mut v.spare_capacity_mut()[..len], lens)
        }
        let (mut pnx, mut pny) = (col(nx, on(normals), &lens), col(ny, on(normals), &lens));
        let mut pnz = col(nz, on(normals), &lens);
        let (mut pa, mut prm) = (col(a, on(area), &lens), col(rm, on(rmin), &lens));
        let mut pid = pieces(&mut id.spare_capacity_mut()[..total], &lens);
        let mut shares = Vec::with_capacity(ranges.len());
        for _ in 0..ranges.len() {
            shares.push(ColsMut {
                hot: phot.next().expect("one piece a leaf"),
                sph: [0, 1, 2, 3].map(|a| psph[a].next().expect("one piece a leaf")),
                nx: pnx.next().expect("one piece a leaf"),
                ny: pny.next().expect("one piece a leaf"),
                nz: pnz.next().expect("one piece a leaf"),
                a: pa.next().expect("one piece a leaf"),
                rmin: prm.next().expect("one piece a leaf"),
                id: pid.next().expect("one piece a leaf"),
            });
        }
        shares
            .into_par_iter()
            .zip(ranges.par_iter())
            .map(|(cm, &(start, end))| {
                leaf_columns(cm, &order[start..end], idx_mask, inp, all_sources)
            })
            .collect()
    };
    // SAFETY: the pieces above cover the first `ng` groups and `total`
    // lanes of each column (`on` of the unused ones: none), and
    // `leaf_columns` wrote every slot of its pieces.
    unsafe {
        cols.hot.set_len(ng);
        for v in &mut cols.sph {
            v.set_len(ng);
        }
        for (v, w) in [
            (&mut cols.nx, normals),
            (&mut cols.ny, normals),
            (&mut cols.nz, normals),
            (&mut cols.a, area),
            (&mut cols.rmin, rmin),
        ] {
            v.set_len(on(w));
        }
        cols.id.set_len(total);
    }
    // The spheres after the last group: far away, radius 0.
    for (a, v) in cols.sph.iter_mut().enumerate() {
        v.resize(ng + LANES, if a < 3 { FAR } else { 0.0 });
    }
    pb.mark("cols");
    let mut col = 0;
    for (leaf, len) in leaves.iter_mut().zip(&lens) {
        leaf.col = col;
        col += len;
    }
    aggregate(&mut nodes, &leaves);
    pb.mark("aggregate");
    (leaves, cols, nodes)
}

/// One leaf's share of the columns, written in place: every slot (the
/// normals, areas and `r_min` when not empty).
struct ColsMut<'a> {
    hot: &'a mut [MaybeUninit<Hot>],
    sph: [&'a mut [MaybeUninit<f32>]; 4],
    nx: &'a mut [MaybeUninit<f32>],
    ny: &'a mut [MaybeUninit<f32>],
    nz: &'a mut [MaybeUninit<f32>],
    a: &'a mut [MaybeUninit<f32>],
    rmin: &'a mut [MaybeUninit<f32>],
    id: &'a mut [MaybeUninit<u32>],
}

/// `v` cut into consecutive pieces of the given sizes (empty pieces when
/// `v` is empty: a column not in use).
fn pieces<'a, T>(v: &'a mut [T], sizes: &[usize]) -> std::vec::IntoIter<&'a mut [T]> {
    let mut out = Vec::with_capacity(sizes.len());
    if v.is_empty() {
        out.resize_with(sizes.len(), Default::default);
        return out.into_iter();
    }
    let mut rest = v;
    for &n in sizes {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(n);
        out.push(head);
        rest = tail;
    }
    out.into_iter()
}

/// One leaf's points (a run of the Morton order) into its columns:
/// sources first, f32 relative to the leaf's origin, padded to whole
/// groups, with the groups' bounding spheres.
fn leaf_columns(
    mut cm: ColsMut,
    run: &[u64],
    idx_mask: u64,
    inp: &Inputs<'_>,
    all_sources: bool,
) -> Leaf {
    // Sources first, each part in Morton order (a leaf holds at most
    // LEAF points: `split`).
    assert!(run.len() <= LEAF);
    let (mut all, mut unlit) = ([0u32; LEAF], [0u32; LEAF]);
    let (mut src, mut m) = (0, 0);
    for &k in run {
        let i = (k & idx_mask) as u32;
        if all_sources || inp.pts[i as usize].illum.iter().any(|&x| x != 0.0) {
            all[src] = i;
            src += 1;
        } else {
            unlit[m] = i;
            m += 1;
        }
    }
    all[src..src + m].copy_from_slice(&unlit[..m]);
    let ids = &all[..run.len()];
    // The leaf's box, and its sources' sums.
    let mut llo = DVec3::splat(f64::INFINITY);
    let mut lhi = DVec3::splat(f64::NEG_INFINITY);
    let mut sum = SrcSum {
        lo: llo,
        hi: lhi,
        sources: src,
        ..SrcSum::default()
    };
    let mut ax = DVec3::ZERO;
    for (k, &i) in ids.iter().enumerate() {
        let pt = &inp.pts[i as usize];
        let p = DVec3::from_array(pt.pos);
        llo = llo.min(p);
        lhi = lhi.max(p);
        if k < src {
            let w = pt.area as f64 * inp.area_scale;
            sum.a += w;
            ax += p * w;
            for c in 0..3 {
                sum.q[c] += (pt.illum[c] as f64 * w) as f32 as f64;
            }
            if let Some(nn) = inp.nrm.get(i as usize) {
                sum.n += DVec3::from_array(nn.map(f64::from)) * w;
            }
            sum.lo = sum.lo.min(p);
            sum.hi = sum.hi.max(p);
        }
    }
    sum.centre = if sum.a > 0.0 {
        ax / sum.a
    } else {
        (sum.lo + sum.hi) * 0.5
    };
    let origin = (llo + lhi) * 0.5;
    // The columns, and the sources' farthest distance from their centre.
    let (normals, area, rmin) = (!cm.nx.is_empty(), !cm.a.is_empty(), !cm.rmin.is_empty());
    let mut far2: f64 = 0.0;
    // A group at a time: its lanes, then its bounding sphere (sources and
    // receivers alike; padding lanes left out).
    for (gi, g) in (0..cm.id.len()).step_by(LANES).enumerate() {
        let m = (ids.len() - g).min(LANES);
        // Padding lanes: far away, carrying nothing.
        let mut h = Hot {
            x: [FAR; LANES],
            y: [FAR; LANES],
            z: [FAR; LANES],
            q: [[0.0; LANES]; 3],
        };
        for l in 0..LANES {
            let k = g + l;
            let Some(&i) = ids.get(k) else {
                for v in [&mut cm.nx, &mut cm.ny, &mut cm.nz, &mut cm.a, &mut cm.rmin] {
                    if !v.is_empty() {
                        v[k].write(0.0);
                    }
                }
                cm.id[k].write(u32::MAX);
                continue;
            };
            let pt = &inp.pts[i as usize];
            let q = DVec3::from_array(pt.pos);
            if k < src {
                far2 = far2.max((q - sum.centre).length_squared());
            }
            let p = q - origin;
            (h.x[l], h.y[l], h.z[l]) = (p.x as f32, p.y as f32, p.z as f32);
            let a = pt.area as f64 * inp.area_scale;
            let e = pt.illum;
            for c in 0..3 {
                h.q[c][l] = (e[c] as f64 * a) as f32;
            }
            if normals {
                let nn = inp.nrm[i as usize];
                cm.nx[k].write(nn[0]);
                cm.ny[k].write(nn[1]);
                cm.nz[k].write(nn[2]);
            }
            if area {
                cm.a[k].write(a as f32);
            }
            if rmin {
                cm.rmin[k].write(burley::rmin(pt.area as f64) as f32);
            }
            cm.id[k].write(i);
        }
        let (mut glo, mut ghi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for l in 0..m {
            for (a, v) in [h.x[l], h.y[l], h.z[l]].into_iter().enumerate() {
                glo[a] = glo[a].min(v);
                ghi[a] = ghi[a].max(v);
            }
        }
        let c = [0, 1, 2].map(|a| 0.5 * (glo[a] + ghi[a]));
        let mut r2: f32 = 0.0;
        for l in 0..m {
            let d = [h.x[l] - c[0], h.y[l] - c[1], h.z[l] - c[2]];
            r2 = r2.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        }
        // Rounding of the receiver's offset and of this sum: a margin.
        let r = r2.sqrt() * (1.0 + 1e-5) + 1e-6 * (c[0].abs() + c[1].abs() + c[2].abs());
        for (a, v) in [c[0], c[1], c[2], r].into_iter().enumerate() {
            cm.sph[a][gi].write(v);
        }
        cm.hot[gi].write(h);
    }
    sum.radius = far2.sqrt();
    Leaf {
        col: 0,
        len: ids.len(),
        src,
        origin,
        lo: llo,
        hi: lhi,
        sum,
    }
}

/// A node of the binary tree the Morton splits make over the leaves: its
/// first leaf (the leaf itself when it has no children), its children,
/// and (after `aggregate`) what its sources add up to.
#[derive(Clone, Debug, Default)]
struct TNode {
    first: usize,
    /// (Two but for a run of equal codes: inline, no allocation a node.)
    kids: smallvec::SmallVec<[usize; 2]>,
    sum: SrcSum,
}

/// What the Morton keys are made of: `code << idx_bits | index`, codes
/// of `axis_bits` an axis.
struct Cut<'a> {
    pts: &'a [Pt],
    idx_bits: u32,
    axis_bits: u32,
}

/// How many times a cell that holds more than a leaf of distinct points
/// is coded again within its own box (each time `axis_bits` more bits an
/// axis: four give about 100 bits, a range of 1e29).
const MAX_RECODE: u32 = 4;

impl Cut<'_> {
    /// The highest code bit of a key.
    fn top(&self) -> i32 {
        (self.idx_bits + 3 * self.axis_bits) as i32 - 1
    }

    /// The Morton key of point `i` at `pos` within the cube from `lo`
    /// that `scale` maps onto the codes.
    #[inline(always)]
    fn key(&self, i: usize, pos: DVec3, lo: DVec3, scale: f64) -> u64 {
        let q = (pos - lo) * scale;
        // (Through i64: x86 converts f64 to u64 in many steps. A point of
        // the box codes within `axis_bits`; NaN, from a box too small for
        // a finite `scale`, as 0.)
        let c = |v: f64| spread(v as i64 as u64);
        let code = c(q.x) | c(q.y) << 1 | c(q.z) << 2;
        code << self.idx_bits | i as u64
    }

    /// Codes the points of `keys` (which share a code) again within
    /// their own box and sorts them by the new keys; false when they are
    /// all at one position (nothing to cut by) or within a box too small
    /// to scale (1e-304).
    fn recode(&self, keys: &mut [u64]) -> bool {
        let mask = (1u64 << self.idx_bits) - 1;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &k in keys.iter() {
            let p = self.pts[(k & mask) as usize].pos_v();
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let extent = (hi - lo).max_element();
        let scale = ((1u64 << self.axis_bits) - 1) as f64 / extent;
        if !(extent > 0.0 && scale.is_finite()) {
            return false;
        }
        for k in keys.iter_mut() {
            let i = (*k & mask) as usize;
            *k = self.key(i, self.pts[i].pos_v(), lo, scale);
        }
        keys.sort_unstable();
        true
    }
}

/// Cuts the sorted `order[start..end]` at Morton bit `bit` and below into
/// leaf ranges (`out`) and tree nodes (`nodes`, children before parents);
/// returns the node's index. A cell that holds more than a leaf when the
/// code bits run out (a cloud whose points are far apart in scale: an
/// outlier far away, a small detailed part in a large scene) is coded
/// again within its own box (`depth` times so far), so that its leaves
/// stay small in space; points at one position are cut in runs of
/// `LEAF`.
#[allow(clippy::too_many_arguments)]
fn split(
    cut: &Cut<'_>,
    order: &mut [u64],
    start: usize,
    end: usize,
    bit: i32,
    depth: u32,
    out: &mut Vec<(usize, usize)>,
    nodes: &mut Vec<TNode>,
) -> usize {
    let first = out.len();
    let mut kids = smallvec::SmallVec::new();
    if end - start <= LEAF {
        out.push((start, end));
    } else if bit < cut.idx_bits as i32 {
        if depth < MAX_RECODE && cut.recode(&mut order[start..end]) {
            return split(cut, order, start, end, cut.top(), depth + 1, out, nodes);
        }
        // Equal positions (duplicate points): runs of LEAF.
        let mut s = start;
        while s < end {
            let e = (s + LEAF).min(end);
            nodes.push(TNode {
                first: out.len(),
                ..TNode::default()
            });
            kids.push(nodes.len() - 1);
            out.push((s, e));
            s = e;
        }
    } else {
        let mask = 1u64 << bit;
        let mid = start + order[start..end].partition_point(|&o| o & mask == 0);
        if mid == start || mid == end {
            // One side empty: no node for this bit.
            return split(cut, order, start, end, bit - 1, depth, out, nodes);
        }
        kids.push(split(cut, order, start, mid, bit - 1, depth, out, nodes));
        kids.push(split(cut, order, mid, end, bit - 1, depth, out, nodes));
    }
    nodes.push(TNode {
        first,
        kids,
        ..TNode::default()
    });
    nodes.len() - 1
}

/// Fills the nodes' sums, bottom-up (children come before parents).
fn aggregate(nodes: &mut [TNode], leaves: &[Leaf]) {
    for t in 0..nodes.len() {
        // Children come before their parent.
        let (done, rest) = nodes.split_at_mut(t);
        let node = &mut rest[0];
        if node.kids.is_empty() {
            node.sum = leaves[node.first].sum;
        } else {
            let kids = &node.kids;
            let (mut a, mut q, mut n, mut ax, mut sources) =
                (0.0, [0.0; 3], DVec3::ZERO, DVec3::ZERO, 0);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &k in kids {
                let c = &done[k].sum;
                if c.sources == 0 {
                    continue;
                }
                a += c.a;
                ax += c.centre * c.a;
                for j in 0..3 {
                    q[j] += c.q[j];
                }
                n += c.n;
                lo = lo.min(c.lo);
                hi = hi.max(c.hi);
                sources += c.sources;
            }
            let centre = if a > 0.0 { ax / a } else { (lo + hi) * 0.5 };
            let mut radius: f64 = 0.0;
            for &k in kids {
                let c = &done[k].sum;
                if c.sources > 0 {
                    radius = radius.max(c.radius + (c.centre - centre).length());
                }
            }
            node.sum = SrcSum {
                lo,
                hi,
                a,
                q,
                n,
                centre,
                radius,
                sources,
            };
        }
    }
}

/// Squared distance between a node's box and a leaf's.
#[inline]
fn gap2(w: &WalkNode, rl: &Leaf) -> f64 {
    (w.lo - rl.hi)
        .max(rl.lo - w.hi)
        .max(DVec3::ZERO)
        .length_squared()
}

// ---------------------------------------------------------------------
// The pair loop.

/// What the pair loop needs to know about the run.
#[derive(Clone, Copy)]
struct Setup {
    /// Channel distances (0: the channel gets nothing).
    ld: [f32; 3],
    ld1: f32,
    inv_ld1: f32,
    /// How far a source can add anything: `reach(falloff, ld1)`.
    reach: f32,
    bounce: f32,
    /// One kernel for all channels (not t_rgb, or equal distances).
    single: bool,
    /// Every source's `illum` has three equal channels (summed once).
    grey: bool,
    local: bool,
}

/// A falloff in f32 for the pair loop, at `r <= D` (the caller masks
/// what lies beyond).
trait Kern: Copy {
    /// The weight is exactly 0 at `r >= D` without a mask (`r` beyond
    /// `D` included): the pair loop then needs no reach mask.
    const CLIPS: bool;
    /// Reads Burley's `r_min`.
    const RMIN: bool;
    /// The weight at distance `r`.
    fn w<const F: bool>(&self, r: f32, rmin: f32) -> f32;
    /// The weight at squared distance `r2` (`w` at its square root).
    #[inline(always)]
    fn w2<const F: bool>(&self, r2: f32, rmin: f32) -> f32 {
        self.w::<F>(r2.sqrt(), rmin)
    }
}

/// `a * b + c`, fused when `F` (only where the CPU has FMA: elsewhere
/// `mul_add` is a library call).
#[inline(always)]
fn madd<const F: bool>(a: f32, b: f32, c: f32) -> f32 {
    if F {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

#[derive(Clone, Copy)]
struct SmoothK {
    inv: f32,
    /// `inv^2`.
    inv2: f32,
}

/// `1 - 3t^2 + 2t^3 = 1 + s (2t - 3)` from `s = t^2` and `t`: two
/// multiply-adds, the last rounded once, so its error is that of `s` and
/// `t` (about 1e-7, where the f32 distances already put ~1e-7 of error on
/// `t`; tested against an f64 double loop). `t` clamped to 1 gives
/// exactly 0.
#[inline(always)]
fn smooth_st<const F: bool>(s: f32, t: f32) -> f32 {
    madd::<F>(s, madd::<F>(2.0, t, -3.0), 1.0)
}

impl Kern for SmoothK {
    const CLIPS: bool = true;
    const RMIN: bool = false;
    #[inline(always)]
    fn w<const F: bool>(&self, r: f32, _: f32) -> f32 {
        let t = (r * self.inv).min(1.0);
        smooth_st::<F>(t * t, t)
    }
    #[inline(always)]
    fn w2<const F: bool>(&self, r2: f32, _: f32) -> f32 {
        // (Clamped before the square root: one multiply fewer than `w`.)
        let s = (r2 * self.inv2).min(1.0);
        smooth_st::<F>(s, s.sqrt())
    }
}

#[derive(Clone, Copy)]
struct ExpK {
    c: f32,
}

impl Kern for ExpK {
    const CLIPS: bool = false;
    const RMIN: bool = false;
    #[inline(always)]
    fn w<const F: bool>(&self, r: f32, _: f32) -> f32 {
        exp_weight(self.c * r)
    }
}

/// `e^(EXP_CUT / 3)`: below it, Burley's `e^(-r/d)`, the cube of its
/// `e^(-r/3d)`, is under `e^EXP_CUT` and 0.
const CUBE_CUT: f32 = 2.061_153_6e-9;

#[derive(Clone, Copy)]
struct BurleyK {
    /// `-1 / 3d`.
    b: f32,
}

impl Kern for BurleyK {
    const CLIPS: bool = false;
    const RMIN: bool = true;
    #[inline(always)]
    fn w<const F: bool>(&self, r: f32, rmin: f32) -> f32 {
        // A zero-area source (rmin 0) at r 0 carries nothing: a finite
        // huge weight times 0.
        let rr = r.max(rmin).max(1e-30);
        // e^(-r/d) = (e^(-r/3d))^3: one exponential, not two. The cube
        // of a value clamped to e^-20 (so never subnormal: e^-60), kept
        // only where e^(-r/d) is above `EXP_CUT` (as `exp_weight` does).
        let x = exp_weight(self.b * rr);
        let xc = x.max(CUBE_CUT);
        let x3 = if x >= CUBE_CUT { xc * xc * xc } else { 0.0 };
        (x3 + x) / rr
    }
}

/// `e^x` for `x <= 0` to about 2 ulp, branch-free so that it vectorises
/// (Cephes' `expf`: `x = n ln 2 + g`, a degree-5 polynomial for `e^g`,
/// times `2^n` built in the exponent bits). `x` is first brought into
/// `[-87, 0]` by plain selects that also send NaN to -87 (`e^-87`,
/// 1.6e-38: nothing): a NaN argument is then a zero weight, not a NaN
/// sum. `x` above -1e-8 is taken as 0
/// (`e^x` rounds to 1 there anyway; a tiny `g` would make `g * g`
/// subnormal, which costs ~100 cycles a lane). `n` is read out of the
/// float's bits (`n + 1.5 * 2^23` holds `n` in its low mantissa bits),
/// not by `as i32`, whose saturation rule kept the pair loop from
/// vectorising.
#[inline(always)]
pub fn exp_approx(x: f32) -> f32 {
    let x = if x > -87.0 { x } else { -87.0 };
    let x = if x < -1e-8 { x } else { 0.0 };
    let n = (x * std::f32::consts::LOG2_E + 0.5).floor();
    let g = x - n * 0.693_359_4 - n * -2.121_944_4e-4;
    let p = 1.987_569_1e-4_f32;
    let p = p * g + 1.398_199_9e-3;
    let p = p * g + 8.333_452e-3;
    let p = p * g + 4.166_579_6e-2;
    let p = p * g + 0.166_666_66;
    let p = p * g + 0.5;
    let e = p * g * g + g + 1.0;
    // n in [-126, 0]: its bits as an integer, then the exponent 2^n.
    const MAGIC: f32 = 12_582_912.0;
    let ni = (n + MAGIC).to_bits().wrapping_sub(MAGIC.to_bits());
    e * f32::from_bits(ni.wrapping_add(127) << 23)
}

/// Below this exponent a kernel's `e^x` is 0: weights under `e^-60`
/// (8.8e-27) of a point's own weight are nothing beside it, and their
/// products with `illum * ptarea` would be subnormal (~100 cycles each:
/// in the variants benchmark, sigma 1000 took 0.53 s against 0.19 for
/// sigma 4 before this cut, 0.085 s for both after).
pub const EXP_CUT: f32 = -60.0;

/// A kernel's `e^x`: `exp_approx`, 0 below `EXP_CUT`.
#[inline(always)]
pub fn exp_weight(x: f32) -> f32 {
    let e = exp_approx(x);
    if x >= EXP_CUT {
        e
    } else {
        0.0
    }
}

/// Lanes of f32: eight receivers, one a lane.
type Lanes = [f32; LANES];

// A leaf's groups fit one `Lanes` (the gather tests them at once).
const _: () = assert!(LEAF <= LANES * LANES);

/// The larger of `a` and `b` (`b` when either is NaN: one instruction,
/// where `f32::max`'s NaN rule costs three).
#[inline(always)]
fn maxf(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The sources a receiver leaf sums, gathered from the source groups
/// within its reach into its frame, one column a value: the pair loop
/// broadcasts each source to the eight receivers in the lanes. Whole
/// groups are copied (`n` lanes), each with its bounding sphere (in the
/// leaf's frame) and its source lanes (a bit a lane); each group of
/// receivers then lists in `idx` the lanes it sums (those within reach
/// of its bounding sphere). Columns a run does not use are not written.
#[derive(Default)]
struct Gathered {
    n: usize,
    x: Vec<f32>,
    y: Vec<f32>,
    z: Vec<f32>,
    q: [Vec<f32>; 3],
    nx: Vec<f32>,
    ny: Vec<f32>,
    nz: Vec<f32>,
    a: Vec<f32>,
    rmin: Vec<f32>,
    /// Per copied group: sphere (centre, radius; padded to whole lanes
    /// with spheres far away) and source lanes.
    sx: Vec<f32>,
    sy: Vec<f32>,
    sz: Vec<f32>,
    sr: Vec<f32>,
    valid: Vec<u32>,
    /// The lanes summed, `m` of them.
    idx: Vec<u32>,
    m: usize,
}

impl Gathered {
    fn clear(&mut self) {
        self.n = 0;
        self.m = 0;
    }

    /// Room for `more` lanes after the first `n`.
    fn room(&mut self, more: usize) {
        let want = self.n + more;
        if self.x.len() < want {
            let len = want.max(2 * self.x.len());
            for v in [&mut self.x, &mut self.y, &mut self.z] {
                v.resize(len, 0.0);
            }
            for v in &mut self.q {
                v.resize(len, 0.0);
            }
            for v in [
                &mut self.nx,
                &mut self.ny,
                &mut self.nz,
                &mut self.a,
                &mut self.rmin,
            ] {
                v.resize(len, 0.0);
            }
            // (`select` writes eight at a time.)
            self.idx.resize(len + LANES, 0);
            // A sphere a group, padded to whole lanes (`seal`).
            let groups = len / LANES + LANES;
            for v in [&mut self.sx, &mut self.sy, &mut self.sz, &mut self.sr] {
                v.resize(groups, 0.0);
            }
            self.valid.resize(groups, 0);
        }
    }

    /// Copies a whole group of sources (lanes `c..c + LANES` of `cols`,
    /// `valid` the source lanes), moved by `-off`; the second and third
    /// channels of `illum * ptarea` (`with_q12`: not when grey), the normals
    /// (`with_n`), areas (`with_a`) and Burley's `r_min` (`with_rm`) when
    /// the run reads them.
    #[inline(always)]
    fn group(
        &mut self,
        cols: &Columns,
        c: usize,
        off: [f32; 3],
        valid: u32,
        [with_q12, with_n, with_a, with_rm]: [bool; 4],
    ) {
        self.room(LANES);
        let (n, h) = (self.n, &cols.hot[c / LANES]);
        let put = |v: &mut Vec<f32>, src: &Lanes, d: f32| {
            let dst: &mut [f32; LANES] = (&mut v[n..n + LANES]).try_into().expect("room");
            for k in 0..LANES {
                dst[k] = src[k] - d;
            }
        };
        put(&mut self.x, &h.x, off[0]);
        put(&mut self.y, &h.y, off[1]);
        put(&mut self.z, &h.z, off[2]);
        put(&mut self.q[0], &h.q[0], 0.0);
        if with_q12 {
            put(&mut self.q[1], &h.q[1], 0.0);
            put(&mut self.q[2], &h.q[2], 0.0);
        }
        let lanes = |v: &[f32]| -> Lanes { v[c..c + LANES].try_into().expect("a group") };
        if with_n {
            put(&mut self.nx, &lanes(&cols.nx), 0.0);
            put(&mut self.ny, &lanes(&cols.ny), 0.0);
            put(&mut self.nz, &lanes(&cols.nz), 0.0);
        }
        if with_a {
            put(&mut self.a, &lanes(&cols.a), 0.0);
        }
        if with_rm {
            put(&mut self.rmin, &lanes(&cols.rmin), 0.0);
        }
        let [sx, sy, sz, sr] = [0, 1, 2, 3].map(|a| cols.sph[a][c / LANES]);
        let j = n / LANES;
        (self.sx[j], self.sy[j], self.sz[j], self.sr[j]) =
            (sx - off[0], sy - off[1], sz - off[2], sr);
        self.valid[j] = valid;
        self.n += LANES;
    }

    /// Pads the spheres to whole lanes (far away: never within reach).
    fn seal(&mut self) {
        let g = self.n / LANES;
        for j in g..padded(g).min(self.sx.len()) {
            (self.sx[j], self.sy[j], self.sz[j], self.sr[j]) = (FAR, FAR, FAR, 0.0);
            self.valid[j] = 0;
        }
    }

    /// Lists in `idx` the lanes within `reach` of `centre` (leaf frame):
    /// the groups whose spheres come within reach, then their lanes that
    /// do. `F`: vector masks (AVX2).
    #[inline(always)]
    fn select<const F: bool>(&mut self, centre: [f32; 3], reach: f32) {
        let [cx, cy, cz] = centre;
        self.m = 0;
        if self.n == 0 {
            return;
        }
        let n = self.n;
        let (x, y, z) = (&self.x[..n], &self.y[..n], &self.z[..n]);
        let idx = &mut self.idx[..n + LANES];
        let reach2 = [reach * reach; LANES];
        let mut m = 0;
        let ng = padded(n / LANES);
        for j0 in (0..ng).step_by(LANES) {
            let g = |v: &[f32]| -> Lanes { v[j0..j0 + LANES].try_into().expect("sealed") };
            let (sx, sy, sz, sr) = (g(&self.sx), g(&self.sy), g(&self.sz), g(&self.sr));
            let (mut d2, mut rr) = ([0.0; LANES], [0.0; LANES]);
            for k in 0..LANES {
                let (dx, dy, dz) = (sx[k] - cx, sy[k] - cy, sz[k] - cz);
                d2[k] = dx * dx + dy * dy + dz * dz;
                rr[k] = (reach + sr[k]) * (reach + sr[k]);
            }
            // (Not the padding spheres: a reach beyond f32's range, or
            // beyond `FAR`, would take them in.)
            let live = (n.div_ceil(LANES) - j0).min(LANES);
            let mut near = le_bits::<F>(&d2, &rr) & ((1u32 << live) - 1);
            while near != 0 {
                let k = near.trailing_zeros() as usize;
                near &= near - 1;
                let (j, valid) = (j0 + k, self.valid[j0 + k]);
                let base = j * LANES;
                let l = |v: &[f32]| -> Lanes { v[base..base + LANES].try_into().expect("a group") };
                let (gx, gy, gz) = (l(x), l(y), l(z));
                let mut e2 = [0.0; LANES];
                for i in 0..LANES {
                    let (ex, ey, ez) = (gx[i] - cx, gy[i] - cy, gz[i] - cz);
                    e2[i] = ex * ex + ey * ey + ez * ez;
                }
                // The lanes within reach, packed to the front (branch
                // free: eight written, as many kept as there are bits).
                let bits = le_bits::<F>(&e2, &reach2) & valid;
                let (to, from) = (&mut idx[m..m + LANES], &PACK[bits as usize]);
                for i in 0..LANES {
                    to[i] = (base + from[i] as usize) as u32;
                }
                m += bits.count_ones() as usize;
            }
        }
        self.m = m;
    }

    /// Adds a pseudo-source, every column filled, summed by every
    /// receiver (no spheres: `select` is not used on these).
    fn point(&mut self, (p, n, q, a, rmin): Pseudo) {
        self.room(1);
        let i = self.n;
        (self.x[i], self.y[i], self.z[i]) = (p[0], p[1], p[2]);
        for c in 0..3 {
            self.q[c][i] = q[c];
        }
        (self.nx[i], self.ny[i], self.nz[i]) = (n[0], n[1], n[2]);
        (self.a[i], self.rmin[i]) = (a, rmin);
        self.idx[i] = i as u32;
        self.n += 1;
        self.m += 1;
    }
}

/// For each 8-bit mask, its set bits' positions in order (then zeros).
const PACK: [[u8; LANES]; 256] = {
    let mut t = [[0u8; LANES]; 256];
    let mut bits = 0;
    while bits < 256 {
        let (mut k, mut m) = (0, 0);
        while k < LANES {
            if bits >> k & 1 == 1 {
                t[bits][m] = k as u8;
                m += 1;
            }
            k += 1;
        }
        bits += 1;
    }
    t
};

/// Bit `k` set where `a[k] <= b[k]`; `F`: one AVX compare and mask.
#[inline(always)]
fn le_bits<const F: bool>(a: &Lanes, b: &Lanes) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if F {
        use std::arch::x86_64::{_mm256_cmp_ps, _mm256_loadu_ps, _mm256_movemask_ps, _CMP_LE_OQ};
        // SAFETY: `F` is set only in the loop compiled for AVX2 and run
        // on a CPU that has it (`Isa::detect`); the loads read 8 lanes.
        return unsafe {
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(
                _mm256_loadu_ps(a.as_ptr()),
                _mm256_loadu_ps(b.as_ptr()),
            )) as u32
        };
    }
    let mut bits = 0;
    for k in 0..LANES {
        bits |= ((a[k] <= b[k]) as u32) << k;
    }
    bits
}

/// A group of receivers in the lanes (leaf frame); padding lanes sit far
/// away and their sums are dropped.
struct Recv8 {
    x: Lanes,
    y: Lanes,
    z: Lanes,
    nx: Lanes,
    ny: Lanes,
    nz: Lanes,
}

/// The receivers' sums: f32 lanes flushed into f64 every `FLUSH`
/// sources, so no lane ever holds more than `FLUSH` terms and the
/// rounding does not grow with the neighbour count. `[0..3]` are the
/// channels, `[3..6]` the local areas.
struct Sums8 {
    total: [[f64; LANES]; 6],
}

/// Sources summed in f32 before a flush into f64.
const FLUSH: usize = 64;

/// Adds, for the eight receivers `r`, every source of `g`: a receiver
/// beyond reach of a source gets a zero term from it (the kernel clips
/// itself or is masked). `K` is the kernel at `ld1` (`SINGLE`) or per
/// channel; `F` fuses multiply-adds. Returns the pairs evaluated.
#[inline(always)]
fn sum8<
    K: Kern,
    const SINGLE: bool,
    const GREY: bool,
    const BOUNCE: bool,
    const LOCAL: bool,
    const F: bool,
>(
    s: &Setup,
    ks: &[K; 3],
    g: &Gathered,
    r: &Recv8,
    acc: &mut Sums8,
) -> u64 {
    let n = g.n;
    let r2max = s.ld1 * s.ld1;
    let d2 = [s.ld[0] * s.ld[0], s.ld[1] * s.ld[1], s.ld[2] * s.ld[2]];
    let (x, y, z) = (&g.x[..n], &g.y[..n], &g.z[..n]);
    // (Grey: only the first channel is gathered and summed.)
    let q0 = &g.q[0][..n];
    let (q1, q2) = (&g.q[1][..n * !GREY as usize], &g.q[2][..n * !GREY as usize]);
    // Columns a run does not use are empty: sliced only when used.
    let used = |v: &'_ [f32], on: bool| -> usize {
        if on {
            n.min(v.len())
        } else {
            0
        }
    };
    let (nx, ny, nz) = (
        &g.nx[..used(&g.nx, BOUNCE)],
        &g.ny[..used(&g.ny, BOUNCE)],
        &g.nz[..used(&g.nz, BOUNCE)],
    );
    let ar = &g.a[..used(&g.a, LOCAL)];
    let rm = &g.rmin[..used(&g.rmin, K::RMIN)];
    let z8: Lanes = [0.0; LANES];
    for chunk in g.idx[..g.m].chunks(FLUSH) {
        let (mut s0, mut s1, mut s2, mut a0, mut a1, mut a2) = (z8, z8, z8, z8, z8, z8);
        for &i in chunk {
            let i = i as usize;
            // (One check: every column is `n` long.)
            assert!(i < n);
            let (sx, sy, sz) = (x[i], y[i], z[i]);
            let rmi = if K::RMIN { rm[i] } else { 0.0 };
            // (The kernel weights and reach masks for the area sums.)
            let (mut wl, mut wl1, mut wl2, mut ml) = (z8, z8, z8, z8);
            for k in 0..LANES {
                let dx = r.x[k] - sx;
                let dy = r.y[k] - sy;
                let dz = r.z[k] - sz;
                let r2 = madd::<F>(dz, dz, madd::<F>(dy, dy, dx * dx));
                // A kernel that clips itself needs no reach mask (m is
                // then the constant 1, folded away).
                let m = if K::CLIPS || r2 <= r2max { 1.0f32 } else { 0.0 };
                // (A plain select: `f32::min`'s NaN rule costs two more
                // instructions; r2 is never NaN here.)
                let r2c = if K::CLIPS || r2 < r2max { r2 } else { r2max };
                // (Not computed where unused: one kernel takes `r2c`.)
                let d = r2c.sqrt();
                let kb = if BOUNCE {
                    let nn = madd::<F>(r.nz[k], nz[i], madd::<F>(r.ny[k], ny[i], r.nx[k] * nx[i]));
                    let nl =
                        madd::<F>(r.nz[k], dz, madd::<F>(r.ny[k], dy, r.nx[k] * dx)) * s.inv_ld1;
                    let b = 1.0 - (1.0 - nn) * (1.0 - nl) * 0.5;
                    madd::<F>(s.bounce, b - 1.0, 1.0).max(0.0) * m
                } else {
                    m
                };
                if SINGLE {
                    let w = ks[0].w2::<F>(r2c, rmi);
                    wl[k] = w;
                    let kw = kb * w;
                    s0[k] = madd::<F>(q0[i], kw, s0[k]);
                    if !GREY {
                        s1[k] = madd::<F>(q1[i], kw, s1[k]);
                        s2[k] = madd::<F>(q2[i], kw, s2[k]);
                    }
                    if LOCAL {
                        ml[k] = m;
                    }
                } else {
                    // Per channel: inside its own distance (0 costs
                    // nothing: its kernel is never used, its mask is 0).
                    let mc = |c: usize| if K::CLIPS || r2 <= d2[c] { 1.0f32 } else { 0.0 };
                    let wc = |c: usize| {
                        if s.ld[c] > 0.0 {
                            ks[c].w::<F>(d, rmi) * mc(c)
                        } else {
                            0.0
                        }
                    };
                    let (w0, w1, w2) = (wc(0), wc(1), wc(2));
                    s0[k] = madd::<F>(q0[i], kb * w0, s0[k]);
                    s1[k] = madd::<F>(q1[i], kb * w1, s1[k]);
                    s2[k] = madd::<F>(q2[i], kb * w2, s2[k]);
                    if LOCAL {
                        (wl[k], wl1[k], wl2[k]) = (w0, w1, w2);
                    }
                }
            }
            // The area sums in a loop of their own: in the one above
            // they kept the compiler from vectorising it with exp and
            // Burley (variants benchmark, exp sigma 4, local: 1.15 s
            // before, 0.17 after).
            if LOCAL {
                for k in 0..LANES {
                    if SINGLE {
                        a0[k] = madd::<F>(ar[i], ml[k] * wl[k], a0[k]);
                    } else {
                        a0[k] = madd::<F>(ar[i], wl[k], a0[k]);
                        a1[k] = madd::<F>(ar[i], wl1[k], a1[k]);
                        a2[k] = madd::<F>(ar[i], wl2[k], a2[k]);
                    }
                }
            }
        }
        // (Through a black box: otherwise the compiler matches the f32
        // lanes to the f64 sums' four-wide vectors and runs the whole
        // loop four lanes at a time.)
        let lanes = std::hint::black_box([s0, s1, s2, a0, a1, a2]);
        for (t, v) in acc.total.iter_mut().zip(lanes) {
            for k in 0..LANES {
                t[k] += v[k] as f64;
            }
        }
    }
    (g.m * LANES) as u64
}

/// Sums every receiver of leaf `rl`: the source leaves `near` (each in its
/// own frame) and the pseudo-sources `ps` (in `rl`'s frame). The source
/// groups within reach of the leaf are gathered into `gat` once; each
/// group of eight receivers then sums those within reach of its bounding
/// sphere, the receivers in the lanes. Writes the receivers' `ssM`
/// (`norm` of their sums) to `out` (the leaf's lanes); returns the pairs
/// evaluated. The order of the sums is fixed by the
/// leaves, so they do not depend on the thread count.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn leaf_g<
    K: Kern,
    const SINGLE: bool,
    const GREY: bool,
    const BOUNCE: bool,
    const LOCAL: bool,
    const F: bool,
>(
    s: &Setup,
    ks: &[K; 3],
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Gathered>,
    gat: &mut Gathered,
    norm: &Normaliser,
    out: &mut [[f32; 3]],
) -> u64 {
    let mut pairs = 0u64;
    let end = rl.col + rl.len;
    let len = cols.id.len();
    // The leaf's box in its own frame, grown by the reach (and a little
    // for rounding).
    let grow = 1e-5 * (rl.hi - rl.lo).max_element() + 1e-6 * s.ld1 as f64;
    let blo = (rl.lo - rl.origin - grow).as_vec3().to_array();
    let bhi = (rl.hi - rl.origin + grow).as_vec3().to_array();
    let reach = s.reach * (1.0 + 1e-6);
    gat.clear();
    for nb in near {
        let src_end = nb.col + nb.src;
        // The source leaf's groups' spheres, all at once (a leaf has at
        // most `LANES` groups; the columns are padded after the last),
        // their centres in this leaf's frame, against its box.
        let g0 = nb.col / LANES;
        let l = |v: &[f32]| -> Lanes { v[g0..g0 + LANES].try_into().expect("padded") };
        let [sx, sy, sz, sr] = [0, 1, 2, 3].map(|a| l(&cols.sph[a]));
        let (mut d2, mut rr) = ([0.0; LANES], [0.0; LANES]);
        for k in 0..LANES {
            let (ox, oy, oz) = (sx[k] - nb.off[0], sy[k] - nb.off[1], sz[k] - nb.off[2]);
            let gx = maxf(maxf(blo[0] - ox, ox - bhi[0]), 0.0);
            let gy = maxf(maxf(blo[1] - oy, oy - bhi[1]), 0.0);
            let gz = maxf(maxf(blo[2] - oz, oz - bhi[2]), 0.0);
            d2[k] = gx * gx + gy * gy + gz * gz;
            rr[k] = (reach + sr[k]) * (reach + sr[k]);
        }
        let mut near = le_bits::<F>(&d2, &rr) & ((1u32 << nb.src.div_ceil(LANES)) - 1);
        while near != 0 {
            let g = nb.col + near.trailing_zeros() as usize * LANES;
            near &= near - 1;
            let valid = (1u32 << (src_end - g).min(LANES)) - 1;
            gat.group(cols, g, nb.off, valid, [!GREY, BOUNCE, LOCAL, K::RMIN]);
        }
    }
    gat.seal();
    for gs in (rl.col..end).step_by(LANES) {
        let h = &cols.hot[gs / LANES];
        let [cx, cy, cz, cr] = [0, 1, 2, 3].map(|a| cols.sph[a][gs / LANES]);
        gat.select::<F>([cx, cy, cz], reach + cr);
        assert!(gs + LANES <= len);
        let lanes = |v: &[f32]| -> Lanes { v[gs..gs + LANES].try_into().expect("a group") };
        let zero = [0.0; LANES];
        let r = Recv8 {
            x: h.x,
            y: h.y,
            z: h.z,
            nx: if BOUNCE { lanes(&cols.nx) } else { zero },
            ny: if BOUNCE { lanes(&cols.ny) } else { zero },
            nz: if BOUNCE { lanes(&cols.nz) } else { zero },
        };
        let mut acc = Sums8 {
            total: [[0.0; LANES]; 6],
        };
        pairs += sum8::<K, SINGLE, GREY, BOUNCE, LOCAL, F>(s, ks, gat, &r, &mut acc);
        if let Some(ps) = ps {
            pairs += sum8::<K, SINGLE, GREY, BOUNCE, LOCAL, F>(s, ks, ps, &r, &mut acc);
        }
        if GREY {
            // (The other channels' sums would be the same numbers.)
            acc.total[1] = acc.total[0];
            acc.total[2] = acc.total[0];
        }
        for k in 0..(end - gs).min(LANES) {
            out[gs - rl.col + k] = norm.apply(&acc.total.map(|t| t[k]));
        }
    }
    pairs
}

/// How much longer than the cloud's size a kernel's distance is taken in
/// the pair loop (smooth; exp and Burley, times sigma or kappa). Beyond
/// it, every pair's weight is exactly what it is at the cap: smooth's
/// `1 - 3t^2 + 2t^3` rounds to 1 in f32 below `t = 1e-5`, and
/// `exp_approx` is 1 above -1e-8 (for Burley, the size counts the
/// largest `r_min` too: its weight reads `max(r, r_min)`). Without it,
/// `1 / D^2` is subnormal in f32 past `D = 1.8e19` (in the variants
/// benchmark, sd 1e20 ran at 141 M pairs/s against 4,000 at sd 0.28) and
/// `sigma / D` is 0 past f32's range.
const KERNEL_CAP: (f64, f64) = (1e5, 1e8);

/// The kernels of a run, monomorphised.
#[derive(Clone, Copy)]
enum Kernels {
    Smooth([SmoothK; 3]),
    Exp([ExpK; 3]),
    Burley([BurleyK; 3]),
}

impl Kernels {
    /// The kernels at distances `ld` (`ld1` when `single`), each taken
    /// no longer than `size` (the cloud's diagonal) times `KERNEL_CAP`.
    fn new(f: Falloff, ld: [f64; 3], ld1: f64, single: bool, size: f64) -> Kernels {
        let cap = size
            * match f {
                Falloff::Smooth => KERNEL_CAP.0,
                Falloff::Exp { sigma: k } | Falloff::Burley { kappa: k } => {
                    KERNEL_CAP.1 * k.max(1.0)
                }
            };
        // (A cap of 0, a cloud of one position, only shortens kernels
        // whose every pair is at r = 0.)
        let d =
            |c: usize| (if single { ld1 } else { ld[c] }).min(cap.max(f64::MIN_POSITIVE)) as f32;
        let safe = |d: f32| if d > 0.0 { d } else { 1.0 };
        match f {
            Falloff::Smooth => Kernels::Smooth([0, 1, 2].map(|c| {
                let inv = 1.0 / safe(d(c));
                SmoothK {
                    inv,
                    inv2: inv * inv,
                }
            })),
            Falloff::Exp { sigma } => Kernels::Exp([0, 1, 2].map(|c| ExpK {
                c: -(sigma as f32) / safe(d(c)),
            })),
            Falloff::Burley { kappa } => Kernels::Burley([0, 1, 2].map(|c| BurleyK {
                b: -(kappa as f32) / safe(d(c)) / 3.0,
            })),
        }
    }
}

/// One receiver leaf with the run's kernel and switches (`F`: fused
/// multiply-adds).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn leaf<const F: bool>(
    s: &Setup,
    kern: &Kernels,
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Gathered>,
    gat: &mut Gathered,
    norm: &Normaliser,
    out: &mut [[f32; 3]],
) -> u64 {
    // Grey light is summed in one channel, and only with one kernel.
    let grey = s.single && s.grey;
    macro_rules! go {
        ($ks:expr; $(($si:literal, $g:literal, $b:literal, $l:literal)),*) => {
            match (s.single, grey, s.bounce > 0.0, s.local) {
                $(($si, $g, $b, $l) => leaf_g::<_, $si, $g, $b, $l, F>(
                    s, $ks, cols, rl, near, ps, gat, norm, out,
                ),)*
                (false, true, _, _) => unreachable!("grey is single"),
            }
        };
        ($ks:expr) => {
            go!($ks;
                (true, true, false, false), (true, true, false, true),
                (true, true, true, false), (true, true, true, true),
                (true, false, false, false), (true, false, false, true),
                (true, false, true, false), (true, false, true, true),
                (false, false, false, false), (false, false, false, true),
                (false, false, true, false), (false, false, true, true))
        };
    }
    match kern {
        Kernels::Smooth(k) => go!(k),
        Kernels::Exp(k) => go!(k),
        Kernels::Burley(k) => go!(k),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1")]
#[allow(clippy::too_many_arguments)]
unsafe fn leaf_avx2(
    s: &Setup,
    kern: &Kernels,
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Gathered>,
    gat: &mut Gathered,
    norm: &Normaliser,
    out: &mut [[f32; 3]],
) -> u64 {
    leaf::<true>(s, kern, cols, rl, near, ps, gat, norm, out)
}

/// The instruction sets the pair loop is compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Isa {
    Base,
    Avx2,
}

/// `leaf`, compiled for `isa`.
#[allow(clippy::too_many_arguments)]
fn run_leaf(
    isa: Isa,
    s: &Setup,
    kern: &Kernels,
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Gathered>,
    gat: &mut Gathered,
    norm: &Normaliser,
    out: &mut [[f32; 3]],
) -> u64 {
    #[cfg(target_arch = "x86_64")]
    match isa {
        // SAFETY: `isa` is what `Isa::detect` found the CPU to have.
        Isa::Avx2 => return unsafe { leaf_avx2(s, kern, cols, rl, near, ps, gat, norm, out) },
        Isa::Base => {}
    }
    let _ = isa;
    leaf::<false>(s, kern, cols, rl, near, ps, gat, norm, out)
}

impl Isa {
    /// What this CPU has; `PCSSS_NO_AVX2=1` forces the baseline loop.
    /// (AVX-512: sixteen lanes evaluate more pairs past the reach, and
    /// eight lanes with its 32 registers came out slower: 14 ms against
    /// 12 at 100k x 200, the compiler merging lanes into 512-bit
    /// vectors.)
    fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            let off = |v: &str| std::env::var_os(v).is_some();
            if off("PCSSS_NO_AVX2")
                || !(is_x86_feature_detected!("avx2")
                    && is_x86_feature_detected!("fma")
                    && is_x86_feature_detected!("popcnt")
                    && is_x86_feature_detected!("bmi1"))
            {
                Isa::Base
            } else {
                Isa::Avx2
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            Isa::Base
        }
    }
}

// ---------------------------------------------------------------------

/// A column read as f64, with the common types read directly.
#[derive(Clone, Copy)]
enum Src<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
    Other(&'a Column),
}

impl<'a> Src<'a> {
    fn of(c: &'a Column) -> Src<'a> {
        if let Some(v) = c.as_slice::<f32>() {
            Src::F32(v)
        } else if let Some(v) = c.as_slice::<f64>() {
            Src::F64(v)
        } else {
            Src::Other(c)
        }
    }

    #[inline(always)]
    fn get(self, i: usize) -> f64 {
        match self {
            Src::F32(v) => v[i] as f64,
            Src::F64(v) => v[i],
            Src::Other(c) => c.get_f64(i),
        }
    }

    /// Values `start..start + out.len()` as f64 (one type dispatch a
    /// block, not a value).
    fn f64s(self, start: usize, out: &mut [f64]) {
        let end = start + out.len();
        match self {
            Src::F32(v) => {
                for (o, &x) in out.iter_mut().zip(&v[start..end]) {
                    *o = x as f64;
                }
            }
            Src::F64(v) => out.copy_from_slice(&v[start..end]),
            Src::Other(c) => {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = c.get_f64(start + k);
                }
            }
        }
    }

    /// `f64s` as f32 (a value beyond f32's range becomes infinite).
    fn f32s(self, start: usize, out: &mut [f32]) {
        let end = start + out.len();
        match self {
            Src::F32(v) => out.copy_from_slice(&v[start..end]),
            Src::F64(v) => {
                for (o, &x) in out.iter_mut().zip(&v[start..end]) {
                    *o = x as f32;
                }
            }
            Src::Other(c) => {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = c.get_f64(start + k) as f32;
                }
            }
        }
    }
}

/// Reads and checks the inputs, in parallel, into one record a point
/// (the Morton ordering gathers them at random: one cache line a point).
/// The first bad point (lowest index) is reported.
/// The normals are checked always, kept only when `normals`.
fn inputs(cloud: &Cloud, normals: bool) -> Result<Inputs<'_>> {
    let pts = cloud.points();
    for (name, stage) in [("N", "facet"), ("ptarea", "scatter"), ("illum", "illum")] {
        if !pts.has(name) {
            return Err(Error::missing("point", name, Some(stage)));
        }
    }
    let v3 = |name: &str| -> Result<[Src; 3]> {
        let c = pts.vec3_columns(name)?;
        Ok([0, 1, 2].map(|k| Src::of(c[k].column())))
    };
    let (p, nm, e) = (v3("P")?, v3("N")?, v3("illum")?);
    let area = Src::of(pts.scalar_column("ptarea")?.column());
    // Positions in f64 (leaf origins keep their precision); the rest as
    // the f32 the pair loop uses (an f64 value beyond f32's range is
    // reported as not finite).
    let read = |i: usize| -> Result<(Pt, [f32; 3])> {
        let pos = [p[0].get(i), p[1].get(i), p[2].get(i)];
        if !pos.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid(format!(
                "point {i}: P is {pos:?}, not finite"
            )));
        }
        let illum = [e[0].get(i), e[1].get(i), e[2].get(i)].map(|x| x as f32);
        if !illum.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid(format!(
                "point {i}: illum is {illum:?}, not finite"
            )));
        }
        let a = area.get(i) as f32;
        if !(a.is_finite() && a >= 0.0) {
            return Err(Error::invalid(format!(
                "point {i}: ptarea is {a}, not a finite number >= 0"
            )));
        }
        let n32 = [nm[0].get(i), nm[1].get(i), nm[2].get(i)].map(|x| x as f32);
        let v = DVec3::new(n32[0] as f64, n32[1] as f64, n32[2] as f64);
        // (Squares of f32 values do not overflow or underflow in f64: a
        // finite, non-zero N has a direction. Normalised only when kept.)
        let u = if !(v.is_finite() && v.length_squared() > 0.0) {
            DVec3::ZERO
        } else if normals {
            v.normalize()
        } else {
            v
        };
        if u == DVec3::ZERO {
            return Err(Error::invalid(format!(
                "point {i}: N is {n32:?}, which has no direction"
            )));
        }
        Ok((
            Pt {
                pos,
                area: a,
                illum,
            },
            u.as_vec3().to_array(),
        ))
    };
    // Filled in place in parallel, chunk by chunk, with the positions'
    // box; the first bad point (lowest index) is then read again for its
    // message.
    let n = pts.len();
    let first_bad = std::sync::atomic::AtomicUsize::new(usize::MAX);
    let (mut all, mut nrm) = (Vec::<Pt>::with_capacity(n), Vec::<[f32; 3]>::new());
    if normals {
        nrm.reserve_exact(n);
    }
    const CHUNK: usize = 4096;
    // The normals' chunks beside the records' (none without normals).
    let nrm_chunks: Vec<Option<&mut [std::mem::MaybeUninit<[f32; 3]>]>> = if normals {
        nrm.spare_capacity_mut()[..n]
            .chunks_mut(CHUNK)
            .map(Some)
            .collect()
    } else {
        (0..n.div_ceil(CHUNK)).map(|_| None).collect()
    };
    // (The zip below must not cut the records' chunks short: every slot
    // is then written, as `set_len` needs.)
    assert_eq!(nrm_chunks.len(), n.div_ceil(CHUNK));
    let empty = (
        DVec3::splat(f64::INFINITY),
        DVec3::splat(f64::NEG_INFINITY),
        true,
        0.0f64,
    );
    let boxes = all.spare_capacity_mut()[..n]
        .par_chunks_mut(CHUNK)
        .zip(nrm_chunks)
        .enumerate()
        .map(|(ci, (slots, mut nslots))| {
            let (mut lo, mut hi, mut grey, mut atot) = empty;
            // The columns a block at a time, checked as `read` does (a
            // bad point gets a default record and is read again below).
            const BLOCK: usize = 256;
            let (mut pb, mut nb, mut eb) =
                ([[0f64; BLOCK]; 3], [[0f32; BLOCK]; 3], [[0f32; BLOCK]; 3]);
            let mut ab = [0f32; BLOCK];
            for (bi, bslots) in slots.chunks_mut(BLOCK).enumerate() {
                let (start, m) = (ci * CHUNK + bi * BLOCK, bslots.len());
                for k in 0..3 {
                    p[k].f64s(start, &mut pb[k][..m]);
                    nm[k].f32s(start, &mut nb[k][..m]);
                    e[k].f32s(start, &mut eb[k][..m]);
                }
                area.f32s(start, &mut ab[..m]);
                for (j, slot) in bslots.iter_mut().enumerate() {
                    let pos = [pb[0][j], pb[1][j], pb[2][j]];
                    let illum = [eb[0][j], eb[1][j], eb[2][j]];
                    let a = ab[j];
                    let v = DVec3::new(nb[0][j] as f64, nb[1][j] as f64, nb[2][j] as f64);
                    let ok = pos.iter().all(|x| x.is_finite())
                        && illum.iter().all(|x| x.is_finite())
                        && a.is_finite()
                        && a >= 0.0
                        && v.is_finite()
                        && v.length_squared() > 0.0;
                    let (pt, nn) = if ok {
                        let u = if normals { v.normalize() } else { v };
                        (
                            Pt {
                                pos,
                                area: a,
                                illum,
                            },
                            u.as_vec3().to_array(),
                        )
                    } else {
                        first_bad.fetch_min(start + j, std::sync::atomic::Ordering::Relaxed);
                        Default::default()
                    };
                    let q = DVec3::from_array(pt.pos);
                    (lo, hi) = (lo.min(q), hi.max(q));
                    grey &= pt.illum[0] == pt.illum[1] && pt.illum[1] == pt.illum[2];
                    atot += pt.area as f64;
                    slot.write(pt);
                    if let Some(ns) = nslots.as_deref_mut() {
                        ns[bi * BLOCK + j].write(nn);
                    }
                }
            }
            (lo, hi, grey, atot)
        })
        .reduce(
            || empty,
            |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 && b.2, a.3 + b.3),
        );
    // SAFETY: every slot of the first `n` was written above (bad points
    // with a default record).
    unsafe {
        all.set_len(n);
        if normals {
            nrm.set_len(n);
        }
    }
    let bad = first_bad.into_inner();
    if bad != usize::MAX {
        read(bad)?;
    }
    Ok(Inputs {
        pts: all,
        nrm,
        p,
        lo: boxes.0,
        hi: boxes.1,
        grey: boxes.2,
        area_scale: area_scale(boxes.3),
    })
}

/// The power of two that brings a total area `atot` into [0.5, 1) (1
/// for 0), within 2^+-100 (beyond, tiny areas would flush to 0). Read
/// from `atot`'s exponent bits: `atot = m 2^e`, `m` in [0.5, 1) (a sum of
/// f32 areas is a normal f64).
fn area_scale(atot: f64) -> f64 {
    if !(atot >= f64::MIN_POSITIVE && atot.is_finite()) {
        return 1.0;
    }
    let e = ((atot.to_bits() >> 52) & 0x7ff) as i32 - 1022;
    2f64.powi((-e).clamp(-100, 100))
}

/// Adds `ssM` to `cloud`.
pub fn ssmulti(cloud: &mut Cloud, p: &Params, progress: &Progress) -> Result<Report> {
    let (out, report) = ssmulti_columns(cloud, p, None, progress)?;
    let ssm = Attribute::vec3("ssM", Role::Color, out.map(f32::wrap));
    cloud.points_mut().set(ssm)?;
    cloud.set_detail("ssmulti_sd", DetailValue::F64(p.sd));
    cloud.set_detail("ssmulti_rd", DetailValue::V3D(p.rd));
    Ok(report)
}

/// `ssM` of `cloud`'s points, without changing the cloud: of every point,
/// or (`want`, one flag a point) of at least the wanted ones. The work is
/// skipped leaf by leaf (64 points in a Morton run): a point outside the
/// computed leaves gets 0, a computed point the same bits as in a full
/// run. `Report::computed` counts the computed points.
pub fn ssmulti_values(
    cloud: &Cloud,
    p: &Params,
    want: Option<&[bool]>,
    progress: &Progress,
) -> Result<(Vec<[f32; 3]>, Report)> {
    let ([x, y, z], report) = ssmulti_columns(cloud, p, want, progress)?;
    let rows = (0..x.len()).map(|i| [x[i], y[i], z[i]]).collect();
    Ok((rows, report))
}

/// `ssmulti_values` as the three columns of `ssM`.
fn ssmulti_columns(
    cloud: &Cloud,
    p: &Params,
    want: Option<&[bool]>,
    progress: &Progress,
) -> Result<([Vec<f32>; 3], Report)> {
    validate(p)?;
    let mut ph = Phases::new("ssmulti");
    let inp = inputs(cloud, p.bounce > 0.0)?;
    ph.mark("inputs");
    let n = inp.pts.len();
    if let Some(w) = want {
        if w.len() != n {
            return Err(Error::invalid(format!("{} flags for {n} points", w.len())));
        }
    }
    let ld = p.rd.map(|r| r * p.sd);
    let ld1 = ld.iter().copied().fold(0.0, f64::max);
    let mut out = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    let mut report = Report {
        points: n,
        ..Report::default()
    };
    if n > 0 && ld1 > 0.0 {
        sum_all(&inp, p, ld, ld1, want, progress, &mut report, &mut out);
    } else {
        report.computed = n;
    }
    Ok((out, report))
}

/// Turns a receiver's sums into `ssM`: the normalisation, worked out once
/// per run.
struct Normaliser {
    /// Per channel, what the sum is multiplied by (not `Local`).
    factor: [f64; 3],
    rd: [f64; 3],
    local: bool,
    /// `Local` with one kernel: the area sum is `s[3]` for every channel.
    single: bool,
}

impl Normaliser {
    /// (`area_scale`: what the sums' areas were multiplied by.)
    fn new(p: &Params, ld: [f64; 3], ld1: f64, area_scale: f64) -> Normaliser {
        let i1 = disk_integral(p.falloff, ld1);
        let factor = [0, 1, 2].map(|c| {
            let f = match (p.norm, p.rgb) {
                (Norm::Seed, false) | (Norm::Channel, false) => p.rd[c] / i1,
                (Norm::Seed, true) => 1.0 / i1,
                (Norm::Channel, true) if ld[c] > 0.0 => p.rd[c] / disk_integral(p.falloff, ld[c]),
                _ => 0.0,
            };
            f / area_scale
        });
        Normaliser {
            factor,
            rd: p.rd,
            local: p.norm == Norm::Local,
            single: !p.rgb || (ld[0] == ld[1] && ld[1] == ld[2]),
        }
    }

    #[inline(always)]
    fn apply(&self, s: &[f64; 6]) -> [f32; 3] {
        [0, 1, 2].map(|c| {
            let v = if self.local {
                let a = if self.single { s[3] } else { s[3 + c] };
                if a > 0.0 {
                    self.rd[c] * s[c] / a
                } else {
                    0.0
                }
            } else {
                s[c] * self.factor[c]
            };
            v as f32
        })
    }
}

/// The exact method (`tolerance == 0`) or the approximate one, for the
/// leaves holding a wanted point (all without `want`).
#[allow(clippy::too_many_arguments)]
fn sum_all(
    inp: &Inputs<'_>,
    p: &Params,
    ld: [f64; 3],
    ld1: f64,
    want: Option<&[bool]>,
    progress: &Progress,
    report: &mut Report,
    out: &mut [Vec<f32>; 3],
) {
    let mut ph = Phases::new("ssmulti");
    let local = p.norm == Norm::Local;
    let columns = [
        p.bounce > 0.0,
        local,
        matches!(p.falloff, Falloff::Burley { .. }),
    ];
    let (leaves, cols, nodes) = build(inp, local, columns);
    report.sources = leaves.iter().map(|l| l.src).sum();
    ph.mark("build");
    let single = !p.rgb || (ld[0] == ld[1] && ld[1] == ld[2]);
    report.grey = single && inp.grey;
    // How far a source can add anything (see `reach`).
    let far = reach(p.falloff, ld1);
    let setup = Setup {
        ld: ld.map(|x| x as f32),
        ld1: ld1 as f32,
        inv_ld1: (1.0 / ld1) as f32,
        reach: far as f32,
        bounce: p.bounce as f32,
        single,
        grey: inp.grey,
        local,
    };
    let isa = Isa::detect();
    let norm = Normaliser::new(p, ld, ld1, inp.area_scale);
    // The cloud's size for the kernels' cap: its diagonal, and for Burley
    // the largest `r_min` either side (one position, several points: a
    // size of 0, where Burley's self weight still depends on D).
    let mut size = (inp.hi - inp.lo).length();
    if let Falloff::Burley { .. } = p.falloff {
        let amax = inp.pts.par_iter().map(|q| q.area).reduce(|| 0.0, f32::max);
        size += 2.0 * burley::rmin(amax as f64);
    }
    let kern = Kernels::new(p.falloff, ld, ld1, single, size);
    progress.start("summing", inp.pts.len() as u64);
    let walk = walk_order(&nodes);
    let clusters = if p.tolerance > 0.0 {
        walk_clusters(&walk, &nodes, inp.area_scale)
    } else {
        Vec::new()
    };
    // Each leaf writes its points' results in place: the ids are a
    // permutation of the points, so no two leaves write one position.
    let n = inp.pts.len();
    let [x, y, z] = out;
    // SAFETY: the columns are only written below, each position by the
    // one leaf holding that point, until the leaves are joined.
    let put = unsafe {
        [
            Disjoint::new(x, n),
            Disjoint::new(y, n),
            Disjoint::new(z, n),
        ]
    };
    let per_leaf: Vec<(u64, usize)> = leaves
        .par_iter()
        .map_init(
            || {
                (
                    Gathered::default(),
                    Gathered::default(),
                    Vec::new(),
                    Vec::new(),
                )
            },
            |(gat, pseudo, found, near), rl| {
                if let Some(w) = want {
                    if !cols.id[rl.col..rl.col + rl.len]
                        .iter()
                        .any(|&i| w[i as usize])
                    {
                        progress.inc(rl.len as u64);
                        return (0, 0);
                    }
                }
                // The source leaves in reach of this leaf, each with the
                // offset between the two origins; with a tolerance, far
                // enough clusters of them become single pseudo-sources.
                let pseudo = if p.tolerance > 0.0 {
                    approx_plan(&walk, &clusters, rl, p, ld, ld1, found, pseudo);
                    Some(&*pseudo)
                } else {
                    near_leaves(&walk, rl, far, found);
                    None
                };
                near.clear();
                near.extend(found.iter().map(|&sl| {
                    let s = &leaves[sl];
                    Near {
                        col: s.col,
                        src: s.src,
                        off: (rl.origin - s.origin).as_vec3().to_array(),
                    }
                }));
                let mut res = [[0f32; 3]; LEAF];
                let pairs = run_leaf(
                    isa, &setup, &kern, &cols, rl, near, pseudo, gat, &norm, &mut res,
                );
                for (&i, v) in cols.id[rl.col..rl.col + rl.len].iter().zip(&res) {
                    for c in 0..3 {
                        put[c].write(i as usize, v[c]);
                    }
                }
                progress.inc(rl.len as u64);
                (pairs, rl.len)
            },
        )
        .collect();
    progress.finish();
    ph.mark("sums");
    for (pairs, computed) in per_leaf {
        report.pairs += pairs;
        report.computed += computed;
    }
}

/// The share of the mean weight a straddling cluster may misplace, see
/// [`jump_scale`]. Measured at 1M points x 20,000 neighbours on the unit
/// sphere (`BENCH_CASE=1000000,20000,T BENCH_FALLOFF=exp BENCH_SIGMA=S`),
/// RMS relative error against the exact method and time: exp sigma 4 at
/// tolerance 0.3, 0.88 s at 1.0e-3 (exact 6.5-6.7 s); at 0.6, 0.20 s at
/// 3.8e-3. With no straddling cluster taken (commit 04ce04d, or
/// `JUMP_K = 0`): 2.5 s at 8.8e-4 and 1.84-2.0 s at 3.5e-3. Sigma 1 is
/// unchanged up to `JUMP_K = 0.1` (1.9 s at 3.7e-3, tolerance 0.3); at
/// 0.15 its straddling ring opens (0.95 s at 4.6e-3) and at 0.5 it gives
/// 1.4e-2: 0.05 keeps a factor 3 from that edge. (Rerun by editing this
/// constant.)
const JUMP_K: f64 = 0.05;

/// The largest radius, divided by the tolerance, of a cluster that may be
/// summed at its centroid although it straddles the reach `d` of a
/// falloff that jumps to zero there (exp, Burley): `JUMP_K d mean / W(d)`,
/// `mean = I(d) / (pi d^2)` the falloff's mean over the disk.
///
/// Why: such a cluster of radius `s` misplaces (counts on the wrong side
/// of `r = d`) at most its area within `s` of that circle, each unit of it
/// weighing the jump `W(d)`. The clusters straddling the circle cover a
/// ring of area about `2 pi d * 2 s`, so they misplace at most `4 pi d s
/// W(d)` of weight (with signs that mostly cancel), against the whole
/// disk's `I(d) = pi d^2 mean`: relative `4 s W(d) / (d mean)`. A cluster
/// radius of at most `T JUMP_K d mean / W(d)` bounds it by `4 JUMP_K T`
/// (6% at `T = 0.3`, the worst case; measured, the cancellation leaves
/// about 1e-4, see [`JUMP_K`]). The ratio depends only on the falloff's
/// shape (sigma, kappa), not on `d`. Where the falloff is 0 at `d` (a
/// steep exp) there is no jump: infinity.
fn jump_scale(f: Falloff, d: f64) -> f64 {
    let mean = disk_integral(f, d) / (PI * d * d);
    let edge = falloff(f, d, d, 0.0);
    if edge > 0.0 && d > 0.0 {
        JUMP_K * d * mean / edge
    } else {
        f64::INFINITY
    }
}

/// For receiver leaf `rl`: the source leaves to sum exactly, and the
/// clusters (tree nodes) that stand in for the rest as pseudo-sources in
/// `rl`'s frame. A cluster is used when its radius `s` (from its
/// area-weighted centroid to its farthest source) is at most `tolerance`
/// times the kernel's length scale where it lies: `D` for smooth, `D /
/// max(sigma, 1)` for exp, `min(d, gap)` for Burley (`D` the smallest
/// channel distance in use, `gap` the distance from `rl`'s box to the
/// cluster's); and, for the falloffs that jump to zero at `D` (exp,
/// Burley), when it does not straddle a channel's reach or is small
/// enough beside the jump there ([`jump_scale`]). A cluster is
/// summed as one source at its centroid with the sums of `illum * ptarea`
/// and `ptarea`, and its mean normal (for `bounce`). Relative error
/// against the exact method, measured in `benches/ssmulti.rs`, grows like
/// `tolerance^2`.
#[allow(clippy::too_many_arguments)]
fn approx_plan(
    walk: &[WalkNode],
    clusters: &[Cluster],
    rl: &Leaf,
    p: &Params,
    ld: [f64; 3],
    ld1: f64,
    exact: &mut Vec<usize>,
    ps: &mut Gathered,
) {
    let dmin = ld.iter().copied().filter(|&d| d > 0.0).fold(ld1, f64::min);
    let dmin = if p.rgb { dmin } else { ld1 };
    let jumps = !matches!(p.falloff, Falloff::Smooth);
    let far = reach(p.falloff, ld1);
    let jump_ok = p.tolerance * jump_scale(p.falloff, dmin);
    exact.clear();
    ps.clear();
    // The tree in pre-order: a subtree out of reach or taken as one
    // cluster is skipped whole (the exact leaves come out in order).
    let mut i = 0;
    while i < walk.len() {
        let w = &walk[i];
        let gap2 = gap2(w, rl);
        if gap2 > far * far {
            i = w.skip as usize;
            continue;
        }
        let scale = match p.falloff {
            Falloff::Smooth => dmin,
            Falloff::Exp { sigma } => dmin / sigma.max(1.0),
            Falloff::Burley { kappa } => (dmin / kappa).min(gap2.sqrt()),
        };
        let straddles = jumps && {
            let gap = gap2.sqrt();
            let far = (w.hi - rl.lo).abs().max((rl.hi - w.lo).abs()).length();
            (0..3).any(|c| {
                let d = if p.rgb { ld[c] } else { ld1 };
                d > 0.0 && gap <= d && far > d
            })
        };
        if scale > 0.0 && w.radius <= p.tolerance * scale && (!straddles || w.radius <= jump_ok) {
            let c = &clusters[i];
            let x = (c.centre - rl.origin).as_vec3();
            ps.point((x.to_array(), c.n, c.q, c.a, c.rmin));
            i = w.skip as usize;
        } else {
            if w.leaf != u32::MAX {
                exact.push(w.leaf as usize);
            }
            i += 1;
        }
    }
}

/// A source leaf as a receiver leaf sees it: its first column, its
/// sources (the first `src` lanes), and the offset from its origin to the
/// receiver leaf's.
struct Near {
    col: usize,
    src: usize,
    off: [f32; 3],
}

/// The tree in pre-order for the searches: each node's sources' box and
/// radius, where its subtree ends, its leaf (`u32::MAX` for an inner
/// node) and its index in the tree (the rest of its sums). Subtrees
/// without sources are left out.
struct WalkNode {
    lo: DVec3,
    hi: DVec3,
    radius: f64,
    skip: u32,
    leaf: u32,
    node: u32,
}

/// A node as a pseudo-source (beside the walk, in its order): its sources'
/// area-weighted centroid and mean normal, `sum illum * ptarea`, `sum
/// ptarea`, and Burley's `r_min` for that whole area (a single-source
/// cluster gets exactly its source's).
struct Cluster {
    centre: DVec3,
    n: [f32; 3],
    q: [f32; 3],
    a: f32,
    rmin: f32,
}

/// Each walk node's `Cluster`, made once (not at every receiver leaf that
/// takes it).
/// (`area_scale`: what the nodes' areas were multiplied by; `r_min` is
/// taken from the areas as read.)
fn walk_clusters(walk: &[WalkNode], nodes: &[TNode], area_scale: f64) -> Vec<Cluster> {
    walk.par_iter()
        .map(|w| {
            let node = &nodes[w.node as usize].sum;
            Cluster {
                centre: node.centre,
                n: node.n.normalize_or_zero().as_vec3().to_array(),
                q: node.q.map(|v| v as f32),
                a: node.a as f32,
                rmin: burley::rmin(node.a / area_scale) as f32,
            }
        })
        .collect()
}

fn walk_order(nodes: &[TNode]) -> Vec<WalkNode> {
    fn add(nodes: &[TNode], t: usize, out: &mut Vec<WalkNode>) {
        let node = &nodes[t];
        if node.sum.sources == 0 {
            return;
        }
        let at = out.len();
        out.push(WalkNode {
            lo: node.sum.lo,
            hi: node.sum.hi,
            radius: node.sum.radius,
            node: t as u32,
            skip: 0,
            leaf: if node.kids.is_empty() {
                node.first as u32
            } else {
                u32::MAX
            },
        });
        for &k in &node.kids {
            add(nodes, k, out);
        }
        out[at].skip = out.len() as u32;
    }
    let mut out = Vec::with_capacity(nodes.len());
    if let Some(root) = nodes.len().checked_sub(1) {
        add(nodes, root, &mut out);
    }
    out
}

/// How far from a source its weight can be above 0, at largest distance
/// `ld1`: `ld1`, or less for a steep exp (sigma above 60: its weights are
/// 0 beyond `60 ld1 / sigma`, `EXP_CUT`) or a Burley profile with kappa
/// above 180 (both its exponentials are cut beyond `180 ld1 / kappa`).
/// Sources farther away are not visited: they would add exact zeros.
/// (With a margin over the f32 rounding of the weights' exponents.)
fn reach(f: Falloff, ld1: f64) -> f64 {
    let cut = -EXP_CUT as f64 * (1.0 + 1e-5);
    match f {
        Falloff::Smooth => ld1,
        Falloff::Exp { sigma } => ld1.min(cut * ld1 / sigma),
        Falloff::Burley { kappa } => ld1.min(3.0 * cut * ld1 / kappa),
    }
}

/// The leaves with sources whose boxes come within `reach` of `rl`'s box,
/// in order (into `out`): the tree scanned in pre-order, skipping the
/// subtrees out of reach.
fn near_leaves(walk: &[WalkNode], rl: &Leaf, reach: f64, out: &mut Vec<usize>) {
    out.clear();
    // (A margin for the f32 rounding of the pair loop's distances.)
    let reach = reach * (1.0 + 1e-6);
    let mut i = 0;
    while i < walk.len() {
        let w = &walk[i];
        if gap2(w, rl) > reach * reach {
            i = w.skip as usize;
            continue;
        }
        if w.leaf != u32::MAX {
            out.push(w.leaf as usize);
        }
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit `j` of the input lands on bit `3 j`, nothing else is set.
    #[test]
    fn spread_puts_bit_j_at_3j() {
        let slow = |v: u64| (0..21).fold(0u64, |acc, j| acc | ((v >> j) & 1) << (3 * j));
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for v in [0, 1, 0x1f_ffff, 0x15_5555, 0x0a_aaaa, 1 << 20, u64::MAX] {
            assert_eq!(spread(v), slow(v), "{v:#x}");
        }
        for _ in 0..10_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            assert_eq!(spread(x), slow(x), "{x:#x}");
        }
    }

    /// Each mask's set bits, in order, at the front.
    #[test]
    fn pack_lists_the_set_bits() {
        for bits in 0..256usize {
            let want: Vec<u8> = (0..LANES as u8).filter(|&k| bits >> k & 1 == 1).collect();
            assert_eq!(&PACK[bits][..want.len()], &want[..], "{bits:#b}");
        }
    }

    /// The vector mask agrees with the plain one, NaN included (false).
    #[test]
    fn le_bits_matches_lane_by_lane() {
        let a = [0.0, 1.0, -1.0, f32::NAN, 2.0, 3.0, f32::INFINITY, -0.0];
        let b = [0.0, 0.5, -0.5, 1.0, f32::NAN, 3.0, 1e30, 0.0];
        let plain = le_bits::<false>(&a, &b);
        assert_eq!(plain, 0b1010_0101);
        #[cfg(target_arch = "x86_64")]
        if Isa::detect() == Isa::Avx2 {
            assert_eq!(le_bits::<true>(&a, &b), plain);
        }
    }
}
