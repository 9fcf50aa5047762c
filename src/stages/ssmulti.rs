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
//! `LEAF` points (a binary tree over them from the same splits), each
//! leaf's points stored as f32 columns relative to the leaf's own origin
//! (an f64), sources first, in groups of eight with a bounding sphere per
//! group. A receiver leaf walks the tree once for the source leaves whose
//! boxes come within `ld1` of its box; every receiver point then runs
//! through those leaves (culled by box, then by group sphere) in groups of
//! eight lanes that the compiler vectorises (AVX2 and FMA when the CPU has
//! them, chosen at run time, one compiled loop per kernel and switch).
//! Pair differences are taken between two small local coordinates plus
//! the leaves' offset, so a cloud 1e6 from the origin loses nothing when
//! its positions are f64. The f32 lanes are added into f64 every `FLUSH`
//! groups: the rounding does not grow with the neighbour count. Points
//! with zero `illum` are not sources (except for `Local`, which needs
//! their area); a receiver's sums run in a fixed order, so the output bits
//! do not depend on the thread count. The approximate method
//! (`tolerance > 0`, see `approx_plan`) replaces far enough clusters of
//! the tree by one pseudo-source each and runs the same loop.

// Numeric kernels index lanes and channels side by side.
#![allow(clippy::needless_range_loop)]

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::column::Column;
use crate::error::{Error, Result};
use crate::progress::Progress;

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
                format!("channel {c} is {x}: not a finite number >= 0"),
            ));
        }
    }
    if !(p.sd.is_finite() && p.sd >= 0.0) {
        return Err(Error::param(
            "--sd",
            format!("{} is not a finite number >= 0", p.sd),
        ));
    }
    if !(p.bounce.is_finite() && (0.0..=1.0).contains(&p.bounce)) {
        return Err(Error::param(
            "--bounce",
            format!("{} is not in [0, 1]", p.bounce),
        ));
    }
    match p.falloff {
        Falloff::Exp { sigma } if !(sigma.is_finite() && sigma > 0.0 && sigma <= 1e6) => {
            return Err(Error::param(
                "--sigma",
                format!("{sigma} is not in (0, 1e6]"),
            ));
        }
        Falloff::Burley { kappa } if !(kappa.is_finite() && kappa > 0.0 && kappa <= 1e6) => {
            return Err(Error::param(
                "--sigma",
                format!("{kappa} is not in (0, 1e6]"),
            ));
        }
        _ => {}
    }
    if !(p.tolerance.is_finite() && p.tolerance >= 0.0) {
        return Err(Error::param(
            "--tolerance",
            format!("{} is not a finite number >= 0", p.tolerance),
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
}

/// What the pair loop reads of a group of `LANES` sources, together (one
/// base pointer and one bounds check a group): positions relative to the
/// leaf origin, `illum[c] * ptarea`, and the group's bounding sphere
/// (leaf-local centre and radius).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
struct Hot {
    x: Lanes,
    y: Lanes,
    z: Lanes,
    q: [Lanes; 3],
    sphere: [f32; 4],
}

impl Hot {
    const ZERO: Hot = Hot {
        x: [0.0; LANES],
        y: [0.0; LANES],
        z: [0.0; LANES],
        q: [[0.0; LANES]; 3],
        sphere: [0.0; 4],
    };
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

/// Interleaves the low 21 bits of `v` with two zero bits between each.
fn spread(v: u64) -> u64 {
    let mut x = v & 0x1f_ffff;
    x = (x | x << 32) & 0x1f00000000ffff;
    x = (x | x << 16) & 0x1f0000ff0000ff;
    x = (x | x << 8) & 0x100f00f00f00f00f;
    x = (x | x << 4) & 0x10c30c30c30c30c3;
    x = (x | x << 2) & 0x1249249249249249;
    x
}

/// A point as the pair loop's columns are built from it.
#[derive(Clone, Copy, Default)]
struct Pt {
    pos: [f64; 3],
    nrm: [f32; 3],
    area: f32,
    illum: [f32; 3],
}

struct Inputs {
    pts: Vec<Pt>,
}

/// Sorts the points along a Morton curve and cuts them into leaves of at
/// most `LEAF` points that share a prefix (equal codes are cut in runs).
fn build(inp: &Inputs, is_source: &[bool], want_rmin: bool) -> (Vec<Leaf>, Columns, Vec<TNode>) {
    let n = inp.pts.len();
    let (lo, hi) = inp
        .pts
        .par_iter()
        .fold(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| {
                let p = DVec3::from_array(p.pos);
                (lo.min(p), hi.max(p))
            },
        )
        .reduce(
            || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |a, b| (a.0.min(b.0), a.1.max(b.1)),
        );
    let extent = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    // One u64 a point: the Morton code above, the point's index below (so
    // every key is distinct and the order is the same on any thread
    // count). 14 bits an axis for 4M points: points that share a code are
    // cut into leaves in index order.
    let idx_bits = (usize::BITS - n.max(2).saturating_sub(1).leading_zeros()).max(1);
    let axis_bits = ((64 - idx_bits) / 3).min(21);
    let scale = ((1u64 << axis_bits) - 1) as f64 / extent;
    let mut order: Vec<u64> = inp
        .pts
        .par_iter()
        .enumerate()
        .map(|(i, p)| {
            let q = (DVec3::from_array(p.pos) - lo) * scale;
            let code = spread(q.x as u64) | spread(q.y as u64) << 1 | spread(q.z as u64) << 2;
            code << idx_bits | i as u64
        })
        .collect();
    // (A radix sort, rdst, took 51-78 ms against 45 ms for (code, index)
    // pairs; one u64 sorts faster still.)
    order.par_sort_unstable();
    let idx_mask = (1u64 << idx_bits) - 1;
    let mut ranges = Vec::new();
    let mut nodes = Vec::new();
    let top = (idx_bits + 3 * axis_bits) as i32 - 1;
    split(&order, 0, n, top, idx_bits as i32, &mut ranges, &mut nodes);
    // Every leaf's columns written in parallel, in place (fresh zeroed
    // pages are first touched by the thread that fills them).
    let lens: Vec<usize> = ranges.iter().map(|&(s, e)| padded(e - s)).collect();
    let glens: Vec<usize> = lens.iter().map(|l| l / LANES).collect();
    let total: usize = lens.iter().sum();
    let mut cols = Columns::zeroed(total);
    let mut leaves: Vec<Leaf> = {
        let Columns {
            hot,
            nx,
            ny,
            nz,
            a,
            rmin,
            id,
        } = &mut cols;
        let mut phot = pieces(hot, &glens);
        let (mut pnx, mut pny, mut pnz) = (pieces(nx, &lens), pieces(ny, &lens), pieces(nz, &lens));
        let (mut pa, mut prm, mut pid) = (pieces(a, &lens), pieces(rmin, &lens), pieces(id, &lens));
        let mut shares = Vec::with_capacity(ranges.len());
        for _ in 0..ranges.len() {
            shares.push(ColsMut {
                hot: phot.next().expect("one piece a leaf"),
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
                leaf_columns(cm, &order[start..end], idx_mask, inp, is_source, want_rmin)
            })
            .collect()
    };
    let mut col = 0;
    for (leaf, len) in leaves.iter_mut().zip(&lens) {
        leaf.col = col;
        col += len;
    }
    aggregate(&mut nodes, &leaves, &cols);
    (leaves, cols, nodes)
}

/// One leaf's share of the columns, written in place.
struct ColsMut<'a> {
    hot: &'a mut [Hot],
    nx: &'a mut [f32],
    ny: &'a mut [f32],
    nz: &'a mut [f32],
    a: &'a mut [f32],
    rmin: &'a mut [f32],
    id: &'a mut [u32],
}

/// `v` cut into consecutive pieces of the given sizes.
fn pieces<'a, T>(v: &'a mut [T], sizes: &[usize]) -> std::vec::IntoIter<&'a mut [T]> {
    let mut out = Vec::with_capacity(sizes.len());
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
    cm: ColsMut,
    run: &[u64],
    idx_mask: u64,
    inp: &Inputs,
    is_source: &[bool],
    want_rmin: bool,
) -> Leaf {
    let mut ids: Vec<u32> = run.iter().map(|&k| (k & idx_mask) as u32).collect();
    // Sources first, each group in Morton order.
    ids.sort_by_key(|&i| !is_source[i as usize]);
    let src = ids.iter().filter(|&&i| is_source[i as usize]).count();
    let mut llo = DVec3::splat(f64::INFINITY);
    let mut lhi = DVec3::splat(f64::NEG_INFINITY);
    for &i in &ids {
        let p = DVec3::from_array(inp.pts[i as usize].pos);
        llo = llo.min(p);
        lhi = lhi.max(p);
    }
    let origin = (llo + lhi) * 0.5;
    for k in 0..cm.a.len() {
        let (h, l) = (&mut cm.hot[k / LANES], k % LANES);
        match ids.get(k) {
            Some(&i) => {
                let pt = &inp.pts[i as usize];
                let p = DVec3::from_array(pt.pos) - origin;
                (h.x[l], h.y[l], h.z[l]) = (p.x as f32, p.y as f32, p.z as f32);
                let nn = pt.nrm;
                (cm.nx[k], cm.ny[k], cm.nz[k]) = (nn[0], nn[1], nn[2]);
                let a = pt.area as f64;
                let e = pt.illum;
                for c in 0..3 {
                    h.q[c][l] = (e[c] as f64 * a) as f32;
                }
                cm.a[k] = pt.area;
                cm.rmin[k] = if want_rmin {
                    burley::rmin(a) as f32
                } else {
                    0.0
                };
                cm.id[k] = i;
            }
            None => {
                (h.x[l], h.y[l], h.z[l]) = (FAR, FAR, FAR);
                (cm.nx[k], cm.ny[k], cm.nz[k]) = (0.0, 0.0, 0.0);
                (h.q[0][l], h.q[1][l], h.q[2][l]) = (0.0, 0.0, 0.0);
                (cm.a[k], cm.rmin[k]) = (0.0, 0.0);
                cm.id[k] = u32::MAX;
            }
        }
    }
    // Bounding spheres of the groups of LANES (sources and receivers
    // alike; padding lanes left out).
    for (gi, g) in (0..cm.a.len()).step_by(LANES).enumerate() {
        let m = (ids.len() - g).min(LANES);
        let h = &mut cm.hot[gi];
        let (mut glo, mut ghi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for l in 0..m {
            for (a, v) in [h.x[l], h.y[l], h.z[l]].into_iter().enumerate() {
                glo[a] = glo[a].min(v);
                ghi[a] = ghi[a].max(v);
            }
        }
        let c = [0, 1, 2].map(|a| 0.5 * (glo[a] + ghi[a]));
        let mut r: f32 = 0.0;
        for l in 0..m {
            let d = [h.x[l] - c[0], h.y[l] - c[1], h.z[l] - c[2]];
            r = r.max((d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt());
        }
        // Rounding of the receiver's offset and of this sum: a margin.
        let r = r * (1.0 + 1e-5) + 1e-6 * (c[0].abs() + c[1].abs() + c[2].abs());
        h.sphere = [c[0], c[1], c[2], r];
    }
    Leaf {
        col: 0,
        len: ids.len(),
        src,
        origin,
        lo: llo,
        hi: lhi,
    }
}

impl Columns {
    /// `n` zeroed lanes (`n` a multiple of `LANES`).
    fn zeroed(n: usize) -> Columns {
        let f = || vec![0f32; n];
        Columns {
            hot: vec![Hot::ZERO; n / LANES],
            nx: f(),
            ny: f(),
            nz: f(),
            a: f(),
            rmin: f(),
            id: vec![0u32; n],
        }
    }

    /// Lane `c`'s position (leaf-local).
    #[inline(always)]
    fn p(&self, c: usize) -> [f32; 3] {
        let (h, l) = (&self.hot[c / LANES], c % LANES);
        [h.x[l], h.y[l], h.z[l]]
    }

    /// Lane `c`'s `illum[k] * ptarea`.
    #[inline(always)]
    fn q(&self, c: usize, k: usize) -> f32 {
        self.hot[c / LANES].q[k][c % LANES]
    }

    /// Pseudo-sources as columns: the given lanes padded to whole groups,
    /// every group's sphere infinite (nothing is culled).
    fn of_points(pts: &[Pseudo]) -> Columns {
        let n = padded(pts.len());
        let mut c = Columns::zeroed(n);
        for k in 0..n {
            let (h, l) = (&mut c.hot[k / LANES], k % LANES);
            match pts.get(k) {
                Some(&(p, nrm, q, a, rmin)) => {
                    (h.x[l], h.y[l], h.z[l]) = (p[0], p[1], p[2]);
                    for j in 0..3 {
                        h.q[j][l] = q[j];
                    }
                    (c.nx[k], c.ny[k], c.nz[k]) = (nrm[0], nrm[1], nrm[2]);
                    (c.a[k], c.rmin[k]) = (a, rmin);
                    c.id[k] = u32::MAX;
                }
                None => {
                    (h.x[l], h.y[l], h.z[l]) = (FAR, FAR, FAR);
                    c.id[k] = u32::MAX;
                }
            }
        }
        for h in &mut c.hot {
            h.sphere = [0.0, 0.0, 0.0, f32::INFINITY];
        }
        c
    }
}

/// A node of the binary tree the Morton splits make over the leaves: its
/// first leaf (the leaf itself when it has no children), its children, and (after `aggregate`)
/// what its sources add up to.
#[derive(Clone, Debug, Default)]
struct TNode {
    first: usize,
    kids: Vec<usize>,
    /// Box of its sources.
    lo: DVec3,
    hi: DVec3,
    /// Sum of the sources' areas, `illum * ptarea`, area-weighted normals.
    a: f64,
    q: [f64; 3],
    n: DVec3,
    /// Area-weighted centroid and the largest distance from it to a
    /// source.
    centre: DVec3,
    radius: f64,
    sources: usize,
}

/// Cuts the sorted `order[start..end]` at Morton bit `bit` and below into
/// leaf ranges (`out`) and tree nodes (`nodes`, children before parents);
/// returns the node's index.
fn split(
    order: &[u64],
    start: usize,
    end: usize,
    bit: i32,
    lowest: i32,
    out: &mut Vec<(usize, usize)>,
    nodes: &mut Vec<TNode>,
) -> usize {
    let first = out.len();
    let mut kids = Vec::new();
    if end - start <= LEAF {
        out.push((start, end));
    } else if bit < lowest {
        // Equal codes (duplicate or very close points): runs of LEAF.
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
            return split(order, start, end, bit - 1, lowest, out, nodes);
        }
        kids.push(split(order, start, mid, bit - 1, lowest, out, nodes));
        kids.push(split(order, mid, end, bit - 1, lowest, out, nodes));
    }
    nodes.push(TNode {
        first,
        kids,
        ..TNode::default()
    });
    nodes.len() - 1
}

/// Fills the nodes' sums, bottom-up (children come before parents).
fn aggregate(nodes: &mut [TNode], leaves: &[Leaf], cols: &Columns) {
    for t in 0..nodes.len() {
        if nodes[t].kids.is_empty() {
            let l = &leaves[nodes[t].first];
            let (mut a, mut q, mut n, mut ax) = (0.0, [0.0; 3], DVec3::ZERO, DVec3::ZERO);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for c in l.col..l.col + l.src {
                let x = l.origin + DVec3::from_array(cols.p(c).map(f64::from));
                let w = cols.a[c] as f64;
                a += w;
                ax += x * w;
                for k in 0..3 {
                    q[k] += cols.q(c, k) as f64;
                }
                n += DVec3::new(cols.nx[c] as f64, cols.ny[c] as f64, cols.nz[c] as f64) * w;
                lo = lo.min(x);
                hi = hi.max(x);
            }
            let centre = if a > 0.0 { ax / a } else { (lo + hi) * 0.5 };
            let mut radius: f64 = 0.0;
            for c in l.col..l.col + l.src {
                let x = l.origin + DVec3::from_array(cols.p(c).map(f64::from));
                radius = radius.max((x - centre).length());
            }
            let node = &mut nodes[t];
            (node.a, node.q, node.n, node.centre, node.radius) = (a, q, n, centre, radius);
            (node.lo, node.hi, node.sources) = (lo, hi, l.src);
        } else {
            let kids = nodes[t].kids.clone();
            let (mut a, mut q, mut n, mut ax, mut sources) =
                (0.0, [0.0; 3], DVec3::ZERO, DVec3::ZERO, 0);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &k in &kids {
                let c = &nodes[k];
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
            for &k in &kids {
                let c = &nodes[k];
                if c.sources > 0 {
                    radius = radius.max(c.radius + (c.centre - centre).length());
                }
            }
            let node = &mut nodes[t];
            (node.a, node.q, node.n, node.centre, node.radius) = (a, q, n, centre, radius);
            (node.lo, node.hi, node.sources) = (lo, hi, sources);
        }
    }
}

/// Distance between two boxes.
fn box_gap(alo: DVec3, ahi: DVec3, blo: DVec3, bhi: DVec3) -> f64 {
    let d = (blo - ahi).max(alo - bhi).max(DVec3::ZERO);
    d.length()
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
    bounce: f32,
    /// One kernel for all channels (not t_rgb, or equal distances).
    single: bool,
    local: bool,
}

/// A receiver, relative to the source leaf's origin.
#[derive(Clone, Copy)]
struct Receiver {
    x: f32,
    y: f32,
    z: f32,
    nx: f32,
    ny: f32,
    nz: f32,
}

/// A falloff in f32 for the pair loop, at `r <= D` (the caller masks
/// what lies beyond).
trait Kern: Copy {
    fn w(&self, r: f32, rmin: f32) -> f32;
}

#[derive(Clone, Copy)]
struct SmoothK {
    inv: f32,
}

impl Kern for SmoothK {
    #[inline(always)]
    fn w(&self, r: f32, _: f32) -> f32 {
        // 1 - 3t^2 + 2t^3 = (1 - t)^2 (1 + 2t): no cancellation near the
        // edge, where W is small.
        let t = (r * self.inv).min(1.0);
        let u = 1.0 - t;
        u * u * (1.0 + 2.0 * t)
    }
}

#[derive(Clone, Copy)]
struct ExpK {
    c: f32,
}

impl Kern for ExpK {
    #[inline(always)]
    fn w(&self, r: f32, _: f32) -> f32 {
        exp_approx(self.c * r)
    }
}

#[derive(Clone, Copy)]
struct BurleyK {
    a: f32,
    b: f32,
}

impl Kern for BurleyK {
    #[inline(always)]
    fn w(&self, r: f32, rmin: f32) -> f32 {
        // A zero-area source (rmin 0) at r 0 carries nothing: a finite
        // huge weight times 0.
        let rr = r.max(rmin).max(1e-30);
        (exp_approx(self.a * rr) + exp_approx(self.b * rr)) / rr
    }
}

/// `e^x` for `x <= 0` to about 2 ulp, branch-free so that it vectorises
/// (Cephes' `expf`: `x = n ln 2 + g`, a degree-5 polynomial for `e^g`,
/// times `2^n` built in the exponent bits).
#[inline(always)]
pub fn exp_approx(x: f32) -> f32 {
    let x = x.clamp(-87.0, 0.0);
    let n = (x * std::f32::consts::LOG2_E + 0.5).floor();
    let g = x - n * 0.693_359_4 - n * -2.121_944_4e-4;
    let p = 1.987_569_1e-4_f32;
    let p = p * g + 1.398_199_9e-3;
    let p = p * g + 8.333_452e-3;
    let p = p * g + 4.166_579_6e-2;
    let p = p * g + 0.166_666_66;
    let p = p * g + 0.5;
    let e = p * g * g + g + 1.0;
    let bits = ((n as i32 + 127) as u32) << 23;
    e * f32::from_bits(bits)
}

/// A receiver block's sums: lanes of f32, added into f64 per block.
type Lanes = [f32; LANES];

/// A receiver's sums: lanes of f32, flushed into f64 every `FLUSH`
/// groups, so no lane ever holds more than `FLUSH` terms and the rounding
/// does not grow with the neighbour count.
struct Acc {
    s: [Lanes; 6],
    groups: u32,
    total: [f64; 6],
}

/// Groups of `LANES` summed in f32 before a flush into f64.
const FLUSH: u32 = 64;

impl Acc {
    fn new() -> Acc {
        Acc {
            s: [[0.0; LANES]; 6],
            groups: 0,
            total: [0.0; 6],
        }
    }

    /// Adds a block's lanes (`groups` groups of terms each).
    #[inline(always)]
    fn spill(&mut self, lanes: [&Lanes; 6], groups: u32) {
        for c in 0..6 {
            for k in 0..LANES {
                self.s[c][k] += lanes[c][k];
            }
        }
        self.groups += groups;
        if self.groups >= FLUSH {
            self.flush();
        }
    }

    #[inline(always)]
    fn flush(&mut self) {
        for c in 0..6 {
            self.total[c] += self.s[c].iter().map(|&v| v as f64).sum::<f64>();
            self.s[c] = [0.0; LANES];
        }
        self.groups = 0;
    }
}

/// Sums, for two receivers at once, the source groups `groups` yields:
/// (first column of the group, offset from the receivers' frame to the
/// group's). Each group's columns are loaded once for both receivers (the
/// pair loop is load-bound at small neighbourhoods); a group whose
/// bounding sphere lies beyond reach of both is skipped, and a receiver
/// beyond reach of a source gets a zero term from it. `s[0..3]` of the
/// sums are the channels, `s[3..6]` the local areas. `K` is the kernel at
/// `ld1` (`SINGLE`) or per channel. Returns the pairs evaluated.
#[inline(always)]
fn block2_g<K: Kern, const SINGLE: bool, const BOUNCE: bool, const LOCAL: bool>(
    s: &Setup,
    ks: &[K; 3],
    cols: &Columns,
    groups: impl Iterator<Item = (usize, [f32; 3])>,
    [ra, rb]: [&Receiver; 2],
    acc: &mut [Acc; 2],
) -> u64 {
    let r2max = s.ld1 * s.ld1;
    let d2 = [s.ld[0] * s.ld[0], s.ld[1] * s.ld[1], s.ld[2] * s.ld[2]];
    let mut visited = 0u64;
    let z8: Lanes = [0.0; LANES];
    // Local lanes (registers), spilled into `acc` every FLUSH groups and
    // at the end.
    let (mut s0a, mut s1a, mut s2a, mut a0a, mut a1a, mut a2a) = (z8, z8, z8, z8, z8, z8);
    let (mut s0b, mut s1b, mut s2b, mut a0b, mut a1b, mut a2b) = (z8, z8, z8, z8, z8, z8);
    let mut count = 0u32;
    let len = cols.a.len();
    let (ca, crm) = (&cols.a[..len], &cols.rmin[..len]);
    let (cnx, cny, cnz) = (&cols.nx[..len], &cols.ny[..len], &cols.nz[..len]);
    let shift = |r: &Receiver, off: [f32; 3]| Receiver {
        x: r.x + off[0],
        y: r.y + off[1],
        z: r.z + off[2],
        ..*r
    };
    for (g, off) in groups {
        let h = &cols.hot[g / LANES];
        let [gx, gy, gz, gr] = h.sphere;
        let reach = s.ld1 + gr;
        let (oa, ob) = (shift(ra, off), shift(rb, off));
        let near = |o: &Receiver| {
            let (cx, cy, cz) = (gx - o.x, gy - o.y, gz - o.z);
            cx * cx + cy * cy + cz * cz <= reach * reach
        };
        if !near(&oa) && !near(&ob) {
            continue;
        }
        visited += 2 * LANES as u64;
        // One bounds check for the group: every column has length `len`.
        assert!(g + LANES <= len);
        let lanes = |v: &[f32]| -> Lanes { v[g..g + LANES].try_into().expect("a group") };
        let (x, y, z) = (&h.x, &h.y, &h.z);
        let (q0, q1, q2) = (&h.q[0], &h.q[1], &h.q[2]);
        let (ar, rm) = (lanes(ca), lanes(crm));
        let (nx, ny, nz) = (lanes(cnx), lanes(cny), lanes(cnz));
        // The eight lanes for one receiver: a macro, not a function, so
        // that the lanes vectorise together (a per-lane function or sums
        // through `&mut` measured 2-4x slower).
        macro_rules! lanes {
            ($o:expr, $s0:ident, $s1:ident, $s2:ident, $a0:ident, $a1:ident, $a2:ident) => {
                for k in 0..LANES {
                    let o = $o;
                    let dx = o.x - x[k];
                    let dy = o.y - y[k];
                    let dz = o.z - z[k];
                    let r2 = dx * dx + dy * dy + dz * dz;
                    let m = if r2 <= r2max { 1.0f32 } else { 0.0 };
                    // (A plain select: `f32::min`'s NaN rule costs two
                    // more instructions; r2 is never NaN here.)
                    let r = if r2 < r2max { r2 } else { r2max }.sqrt();
                    let kb = if BOUNCE {
                        let nn = o.nx * nx[k] + o.ny * ny[k] + o.nz * nz[k];
                        let nl = (o.nx * dx + o.ny * dy + o.nz * dz) * s.inv_ld1;
                        let b = 1.0 - (1.0 - nn) * (1.0 - nl) * 0.5;
                        (1.0 + s.bounce * (b - 1.0)).max(0.0) * m
                    } else {
                        m
                    };
                    if SINGLE {
                        let w = ks[0].w(r, rm[k]);
                        let kw = kb * w;
                        $s0[k] += q0[k] * kw;
                        $s1[k] += q1[k] * kw;
                        $s2[k] += q2[k] * kw;
                        if LOCAL {
                            $a0[k] += ar[k] * m * w;
                        }
                    } else {
                        // Per channel: inside its own distance (0 costs
                        // nothing: its kernel is never used, its mask is 0).
                        let m0 = if r2 <= d2[0] { 1.0f32 } else { 0.0 };
                        let m1 = if r2 <= d2[1] { 1.0f32 } else { 0.0 };
                        let m2 = if r2 <= d2[2] { 1.0f32 } else { 0.0 };
                        let w0 = if s.ld[0] > 0.0 {
                            ks[0].w(r, rm[k]) * m0
                        } else {
                            0.0
                        };
                        let w1 = if s.ld[1] > 0.0 {
                            ks[1].w(r, rm[k]) * m1
                        } else {
                            0.0
                        };
                        let w2 = if s.ld[2] > 0.0 {
                            ks[2].w(r, rm[k]) * m2
                        } else {
                            0.0
                        };
                        $s0[k] += q0[k] * kb * w0;
                        $s1[k] += q1[k] * kb * w1;
                        $s2[k] += q2[k] * kb * w2;
                        if LOCAL {
                            $a0[k] += ar[k] * w0;
                            $a1[k] += ar[k] * w1;
                            $a2[k] += ar[k] * w2;
                        }
                    }
                }
            };
        }
        lanes!(&oa, s0a, s1a, s2a, a0a, a1a, a2a);
        lanes!(&ob, s0b, s1b, s2b, a0b, a1b, a2b);
        count += 1;
        if count >= FLUSH {
            acc[0].spill([&s0a, &s1a, &s2a, &a0a, &a1a, &a2a], count);
            acc[1].spill([&s0b, &s1b, &s2b, &a0b, &a1b, &a2b], count);
            (s0a, s1a, s2a, a0a, a1a, a2a) = (z8, z8, z8, z8, z8, z8);
            (s0b, s1b, s2b, a0b, a1b, a2b) = (z8, z8, z8, z8, z8, z8);
            count = 0;
        }
    }
    acc[0].spill([&s0a, &s1a, &s2a, &a0a, &a1a, &a2a], count);
    acc[1].spill([&s0b, &s1b, &s2b, &a0b, &a1b, &a2b], count);
    visited
}

/// Sums every receiver of leaf `rl`: the source leaves `near` (each in its
/// own frame) and the pseudo-sources `ps` (in `rl`'s frame). Each group of
/// eight receivers first gathers the source groups within reach of its
/// bounding sphere (its interaction list); its receivers then run through
/// that list two at a time. Pushes (point, sums) to `res`; returns the
/// pairs evaluated.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn leaf_g<K: Kern, const SINGLE: bool, const BOUNCE: bool, const LOCAL: bool>(
    s: &Setup,
    ks: &[K; 3],
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Columns>,
    res: &mut Vec<(u32, [f64; 6])>,
) -> u64 {
    let mut pairs = 0u64;
    let mut list: Vec<(usize, [f32; 3])> = Vec::new();
    let end = rl.col + rl.len;
    let recv = |c: usize| Receiver {
        x: cols.p(c)[0],
        y: cols.p(c)[1],
        z: cols.p(c)[2],
        nx: cols.nx[c],
        ny: cols.ny[c],
        nz: cols.nz[c],
    };
    for gs in (rl.col..end).step_by(LANES) {
        let gi = gs / LANES;
        let [cx, cy, cz, cr] = cols.hot[gi].sphere;
        let reach = s.ld1 * (1.0 + 1e-6) + cr;
        list.clear();
        for nb in near {
            // The receiver group's centre in `nb`'s frame.
            let (ox, oy, oz) = (cx + nb.off[0], cy + nb.off[1], cz + nb.off[2]);
            let gx = (nb.lo[0] - ox).max(ox - nb.hi[0]).max(0.0);
            let gy = (nb.lo[1] - oy).max(oy - nb.hi[1]).max(0.0);
            let gz = (nb.lo[2] - oz).max(oz - nb.hi[2]).max(0.0);
            if gx * gx + gy * gy + gz * gz > reach * reach {
                continue;
            }
            for g in (nb.col..nb.col + nb.n).step_by(LANES) {
                let sg = g / LANES;
                let [sx, sy, sz, sr] = cols.hot[sg].sphere;
                let (dx, dy, dz) = (sx - ox, sy - oy, sz - oz);
                let rr = reach + sr;
                if dx * dx + dy * dy + dz * dz <= rr * rr {
                    list.push((g, nb.off));
                }
            }
        }
        let gend = (gs + LANES).min(end);
        // Two receivers at a time (the last one of an odd group twice);
        // the pairs are fixed by the leaf's order, so the sums do not
        // depend on the thread count.
        for c in (gs..gend).step_by(2) {
            let (oa, ob) = (recv(c), recv((c + 1).min(gend - 1)));
            let mut acc = [Acc::new(), Acc::new()];
            pairs += block2_g::<K, SINGLE, BOUNCE, LOCAL>(
                s,
                ks,
                cols,
                list.iter().copied(),
                [&oa, &ob],
                &mut acc,
            );
            if let Some(ps) = ps {
                pairs += block2_g::<K, SINGLE, BOUNCE, LOCAL>(
                    s,
                    ks,
                    ps,
                    (0..ps.a.len()).step_by(LANES).map(|g| (g, [0.0; 3])),
                    [&oa, &ob],
                    &mut acc,
                );
            }
            for (k, a) in acc.iter_mut().enumerate().take(gend - c) {
                a.flush();
                res.push((cols.id[c + k], a.total));
            }
        }
    }
    pairs
}

/// The kernels of a run, monomorphised.
#[derive(Clone, Copy)]
enum Kernels {
    Smooth([SmoothK; 3]),
    Exp([ExpK; 3]),
    Burley([BurleyK; 3]),
}

impl Kernels {
    fn new(f: Falloff, ld: [f32; 3], ld1: f32, single: bool) -> Kernels {
        let d = |c: usize| if single { ld1 } else { ld[c] };
        let safe = |d: f32| if d > 0.0 { d } else { 1.0 };
        match f {
            Falloff::Smooth => Kernels::Smooth([0, 1, 2].map(|c| SmoothK {
                inv: 1.0 / safe(d(c)),
            })),
            Falloff::Exp { sigma } => Kernels::Exp([0, 1, 2].map(|c| ExpK {
                c: -(sigma as f32) / safe(d(c)),
            })),
            Falloff::Burley { kappa } => Kernels::Burley([0, 1, 2].map(|c| {
                let a = -(kappa as f32) / safe(d(c));
                BurleyK { a, b: a / 3.0 }
            })),
        }
    }
}

/// One receiver leaf with the run's kernel and switches.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn leaf(
    s: &Setup,
    kern: &Kernels,
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Columns>,
    res: &mut Vec<(u32, [f64; 6])>,
) -> u64 {
    macro_rules! go {
        ($ks:expr) => {
            match (s.single, s.bounce > 0.0, s.local) {
                (true, false, false) => {
                    leaf_g::<_, true, false, false>(s, $ks, cols, rl, near, ps, res)
                }
                (true, false, true) => {
                    leaf_g::<_, true, false, true>(s, $ks, cols, rl, near, ps, res)
                }
                (true, true, false) => {
                    leaf_g::<_, true, true, false>(s, $ks, cols, rl, near, ps, res)
                }
                (true, true, true) => {
                    leaf_g::<_, true, true, true>(s, $ks, cols, rl, near, ps, res)
                }
                (false, false, false) => {
                    leaf_g::<_, false, false, false>(s, $ks, cols, rl, near, ps, res)
                }
                (false, false, true) => {
                    leaf_g::<_, false, false, true>(s, $ks, cols, rl, near, ps, res)
                }
                (false, true, false) => {
                    leaf_g::<_, false, true, false>(s, $ks, cols, rl, near, ps, res)
                }
                (false, true, true) => {
                    leaf_g::<_, false, true, true>(s, $ks, cols, rl, near, ps, res)
                }
            }
        };
    }
    match kern {
        Kernels::Smooth(k) => go!(k),
        Kernels::Exp(k) => go!(k),
        Kernels::Burley(k) => go!(k),
    }
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[allow(clippy::too_many_arguments)]
unsafe fn leaf_avx2(
    s: &Setup,
    kern: &Kernels,
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Columns>,
    res: &mut Vec<(u32, [f64; 6])>,
) -> u64 {
    leaf(s, kern, cols, rl, near, ps, res)
}

/// `leaf`, with AVX2 and FMA when the CPU has them.
#[allow(clippy::too_many_arguments)]
fn run_leaf(
    avx2: bool,
    s: &Setup,
    kern: &Kernels,
    cols: &Columns,
    rl: &Leaf,
    near: &[Near],
    ps: Option<&Columns>,
    res: &mut Vec<(u32, [f64; 6])>,
) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if avx2 {
        // SAFETY: `avx2` is true only when the CPU reports AVX2 and FMA.
        return unsafe { leaf_avx2(s, kern, cols, rl, near, ps, res) };
    }
    let _ = avx2;
    leaf(s, kern, cols, rl, near, ps, res)
}

fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::env::var_os("PCSSS_NO_AVX2").is_none()
            && is_x86_feature_detected!("avx2")
            && is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
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
}

/// Reads and checks the inputs, in parallel, into one record a point
/// (the Morton ordering gathers them at random: one cache line a point).
/// The first bad point (lowest index) is reported.
fn inputs(cloud: &Cloud) -> Result<Inputs> {
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
    let read = |i: usize| -> Result<Pt> {
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
        let u = if v.is_finite() {
            v.normalize_or_zero()
        } else {
            DVec3::ZERO
        };
        if u == DVec3::ZERO {
            return Err(Error::invalid(format!(
                "point {i}: N is {n32:?}, which has no direction"
            )));
        }
        Ok(Pt {
            pos,
            nrm: u.as_vec3().to_array(),
            area: a,
            illum,
        })
    };
    // Filled in place in parallel; the first bad point (lowest index) is
    // then read again for its message.
    let first_bad = std::sync::atomic::AtomicUsize::new(usize::MAX);
    let mut all = Vec::new();
    (0..pts.len())
        .into_par_iter()
        .map(|i| {
            read(i).unwrap_or_else(|_| {
                first_bad.fetch_min(i, std::sync::atomic::Ordering::Relaxed);
                Pt::default()
            })
        })
        .collect_into_vec(&mut all);
    let bad = first_bad.into_inner();
    if bad != usize::MAX {
        read(bad)?;
    }
    Ok(Inputs { pts: all })
}

/// Adds `ssM` to `cloud`.
pub fn ssmulti(cloud: &mut Cloud, p: &Params, progress: &Progress) -> Result<Report> {
    let (out, report) = ssmulti_values(cloud, p, None, progress)?;
    cloud.points_mut().set_vec3("ssM", Role::Color, &out)?;
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
    validate(p)?;
    let inp = inputs(cloud)?;
    let n = inp.pts.len();
    if let Some(w) = want {
        if w.len() != n {
            return Err(Error::invalid(format!("{} flags for {n} points", w.len())));
        }
    }
    let ld = p.rd.map(|r| r * p.sd);
    let ld1 = ld.iter().copied().fold(0.0, f64::max);
    let mut out = vec![[0f32; 3]; n];
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

/// A receiver leaf's results: (point, ssM) and the pairs it evaluated.
type LeafSums = (Vec<(u32, [f32; 3])>, u64);

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
    fn new(p: &Params, ld: [f64; 3], ld1: f64) -> Normaliser {
        let i1 = disk_integral(p.falloff, ld1);
        let factor = [0, 1, 2].map(|c| match (p.norm, p.rgb) {
            (Norm::Seed, false) | (Norm::Channel, false) => p.rd[c] / i1,
            (Norm::Seed, true) => 1.0 / i1,
            (Norm::Channel, true) if ld[c] > 0.0 => p.rd[c] / disk_integral(p.falloff, ld[c]),
            _ => 0.0,
        });
        Normaliser {
            factor,
            rd: p.rd,
            local: p.norm == Norm::Local,
            single: !p.rgb || (ld[0] == ld[1] && ld[1] == ld[2]),
        }
    }

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
    inp: &Inputs,
    p: &Params,
    ld: [f64; 3],
    ld1: f64,
    want: Option<&[bool]>,
    progress: &Progress,
    report: &mut Report,
    out: &mut [[f32; 3]],
) {
    let local = p.norm == Norm::Local;
    let is_source: Vec<bool> = inp
        .pts
        .par_iter()
        .map(|q| local || q.illum.iter().any(|&x| x != 0.0))
        .collect();
    report.sources = is_source.iter().filter(|&&s| s).count();
    let want_rmin = matches!(p.falloff, Falloff::Burley { .. });
    let (leaves, cols, nodes) = build(inp, &is_source, want_rmin);
    let single = !p.rgb || (ld[0] == ld[1] && ld[1] == ld[2]);
    let setup = Setup {
        ld: ld.map(|x| x as f32),
        ld1: ld1 as f32,
        inv_ld1: (1.0 / ld1) as f32,
        bounce: p.bounce as f32,
        single,
        local,
    };
    let avx2 = has_avx2();
    let norm = Normaliser::new(p, ld, ld1);
    let kern = Kernels::new(p.falloff, setup.ld, setup.ld1, single);
    progress.start("summing", inp.pts.len() as u64);
    let per_leaf: Vec<LeafSums> = leaves
        .par_iter()
        .map(|rl| {
            if let Some(w) = want {
                if !cols.id[rl.col..rl.col + rl.len]
                    .iter()
                    .any(|&i| w[i as usize])
                {
                    progress.inc(rl.len as u64);
                    return (Vec::new(), 0);
                }
            }
            // The source leaves in reach of this leaf, each with the
            // offset between the two origins and its box in its own frame
            // (f32, grown a little for rounding); with a tolerance, far
            // enough clusters of them become single pseudo-sources.
            let (exact_leaves, pseudo) = if p.tolerance > 0.0 {
                let (ex, ps) = approx_plan(&nodes, rl, p, ld, ld1);
                (ex, Some(ps))
            } else {
                (near_leaves(&nodes, rl, ld1), None)
            };
            let near: Vec<Near> = exact_leaves
                .into_iter()
                .map(|sl| {
                    let s = &leaves[sl];
                    let grow = 1e-5 * (s.hi - s.lo).max_element() + 1e-6 * ld1;
                    Near {
                        col: s.col,
                        n: padded(s.src),
                        off: (rl.origin - s.origin).as_vec3().to_array(),
                        lo: (s.lo - s.origin - grow).as_vec3().to_array(),
                        hi: (s.hi - s.origin + grow).as_vec3().to_array(),
                    }
                })
                .collect();
            let mut res = Vec::with_capacity(rl.len);
            let pairs = run_leaf(
                avx2,
                &setup,
                &kern,
                &cols,
                rl,
                &near,
                pseudo.as_ref(),
                &mut res,
            );
            progress.inc(rl.len as u64);
            // Normalised here: a leaf's results are 16 bytes a point.
            let res: Vec<(u32, [f32; 3])> = res
                .into_iter()
                .map(|(i, acc)| (i, norm.apply(&acc)))
                .collect();
            (res, pairs)
        })
        .collect();
    progress.finish();
    for (res, pairs) in per_leaf {
        report.pairs += pairs;
        report.computed += res.len();
        for (i, v) in res {
            out[i as usize] = v;
        }
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
/// Burley), when it does not straddle a channel's reach. A cluster is
/// summed as one source at its centroid with the sums of `illum * ptarea`
/// and `ptarea`, and its mean normal (for `bounce`). Relative error
/// against the exact method, measured in `benches/ssmulti.rs`, grows like
/// `tolerance^2`.
fn approx_plan(
    nodes: &[TNode],
    rl: &Leaf,
    p: &Params,
    ld: [f64; 3],
    ld1: f64,
) -> (Vec<usize>, Columns) {
    let dmin = ld.iter().copied().filter(|&d| d > 0.0).fold(ld1, f64::min);
    let dmin = if p.rgb { dmin } else { ld1 };
    let jumps = !matches!(p.falloff, Falloff::Smooth);
    let mut exact = Vec::new();
    let mut ps = Vec::new();
    let mut stack = vec![nodes.len() - 1];
    while let Some(t) = stack.pop() {
        let node = &nodes[t];
        if node.sources == 0 {
            continue;
        }
        let gap = box_gap(rl.lo, rl.hi, node.lo, node.hi);
        if gap > ld1 {
            continue;
        }
        let far = (node.hi - rl.lo)
            .abs()
            .max((rl.hi - node.lo).abs())
            .length();
        let scale = match p.falloff {
            Falloff::Smooth => dmin,
            Falloff::Exp { sigma } => dmin / sigma.max(1.0),
            Falloff::Burley { kappa } => (dmin / kappa).min(gap),
        };
        let straddles = jumps
            && (0..3).any(|c| {
                let d = if p.rgb { ld[c] } else { ld1 };
                d > 0.0 && gap <= d && far > d
            });
        if scale > 0.0 && node.radius <= p.tolerance * scale && !straddles {
            let x = (node.centre - rl.origin).as_vec3();
            let nn = node.n.normalize_or_zero().as_vec3();
            // Burley's regularisation for the cluster's whole area (a
            // single-source cluster gets exactly its source's).
            ps.push((
                x.to_array(),
                nn.to_array(),
                node.q.map(|v| v as f32),
                node.a as f32,
                burley::rmin(node.a) as f32,
            ));
        } else if node.kids.is_empty() {
            exact.push(node.first);
        } else {
            stack.extend(node.kids.iter().copied());
        }
    }
    exact.sort_unstable();
    // Whole groups; no culling spheres (every pseudo-source counts).
    let ps = Columns::of_points(&ps);
    (exact, ps)
}

/// A source leaf as a receiver leaf sees it.
struct Near {
    col: usize,
    n: usize,
    off: [f32; 3],
    lo: [f32; 3],
    hi: [f32; 3],
}

/// The leaves with sources whose boxes come within `ld1` of `rl`'s box,
/// in order: the Morton tree walked from the root, skipping subtrees out
/// of reach (their sources' box is farther than `ld1`).
fn near_leaves(nodes: &[TNode], rl: &Leaf, ld1: f64) -> Vec<usize> {
    let mut out = Vec::new();
    let mut stack = vec![nodes.len() - 1];
    while let Some(t) = stack.pop() {
        let node = &nodes[t];
        if node.sources == 0 || box_gap(rl.lo, rl.hi, node.lo, node.hi) > ld1 {
            continue;
        }
        if node.kids.is_empty() {
            out.push(node.first);
        } else {
            stack.extend(node.kids.iter().copied());
        }
    }
    out.sort_unstable();
    out
}
