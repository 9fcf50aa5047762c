//! `ssmulti` (Marengo's `ssIntegMulti`): multiple scattering at every
//! cloud point, `ssM` (colour), as `docs/DESIGN.md#ssmulti` writes it:
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
//! Normalisations ([`Norm`], `docs/DESIGN.md#normalisations`): `Seed` is
//! the above (Houdini's: in t_rgb mode every channel by the largest
//! distance's integral, no `Rd`); `Channel`: in t_rgb mode channel c by its
//! own `I(ld[c])`, times `Rd[c]`; `Local`: by the kernel-weighted area
//! present within reach, `A[c] = sum_i ptarea_i W(r, ld[c])` (no `kb`),
//! times `Rd[c]`: an open edge or a thin part no longer goes dark.
//! Falloffs ([`Falloff`], all zero beyond `D`) and their disk integrals
//! are in [`kernel`].
//!
//! The method, a file a concern:
//! - `inputs`: the columns read, checked, into one record
//!   a point.
//! - `tree`: the points sorted along a Morton curve and cut into leaves of
//!   at most [`LEAF`] points, a binary tree over them.
//! - `columns`: each leaf's points as f32 columns relative to the leaf's
//!   own f64 origin, sources first, in groups of eight.
//! - `gather`, `pairs`: a receiver leaf gathers the source groups within
//!   its reach once; each group of eight receivers (one a vector lane)
//!   sums the sources within reach of its bounding sphere.
//! - `lanes`: the falloffs in f32 for the lanes; `simd`: the instruction
//!   set, chosen at run time, and every `unsafe` of the pair loop.
//! - `approx`: the approximate method (`tolerance > 0`), clusters of the
//!   tree summed as one pseudo-source.
//! - `normalise`: a receiver's sums into `ssM`.
//!
//! A receiver's sums run in a fixed order, so the output bits do not
//! depend on the thread count.

// Numeric kernels index lanes and channels side by side.
#![allow(clippy::needless_range_loop)]

mod approx;
mod columns;
mod gather;
mod inputs;
pub mod kernel;
mod lanes;
mod nee;
mod normalise;
mod pairs;
mod params;
pub mod per_point;
mod record;
mod simd;
mod tree;
pub mod walk;

use rayon::prelude::*;

use crate::cloud::{Attribute, Cloud, DetailValue, Role};
use crate::column::Scalar;
use crate::disjoint::Disjoint;
use crate::error::{Error, Result};
use crate::progress::Progress;

use self::columns::build;
use self::gather::Gathered;
use self::inputs::{inputs, weigh_light, Inputs};
use self::lanes::Kernels;
use self::normalise::Normaliser;
use self::pairs::{LeafTask, Near, Run, Setup};
use self::tree::{near_leaves, walk_order};

pub use self::kernel::{
    burley, disk_integral, exp_disk_factor, falloff, reach, Falloff, FalloffKind, BURLEY_KAPPA,
    EXP_CUT, EXP_SIGMA,
};
pub use self::lanes::{exp_approx, exp_weight};
use self::params::{physical_kappa, Distances};
pub use self::params::{
    validate, Method, Norm, Params, LEAF, MAX_TOLERANCE, PHYSICAL_KAPPA, RADIANCE,
};
pub use self::record::{Given, Plan, Record};
pub use self::simd::Simd;

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
    /// Source normalisation: points whose kernel is too narrow to weigh
    /// even their own disk; they return their own light times the gain.
    pub isolated: usize,
    /// The physical model weighed each point's light by the cosine of its
    /// arrival (`illum_cos`); `false`: taken along the normal.
    pub by_incidence: bool,
    /// The physical model weighed each point's light by the thickness
    /// behind it (`thickness`); `false`: every part taken as thick.
    pub by_thickness: bool,
    /// The light between surfaces (`illum_indirect`) brought its single
    /// scattering into ssM.
    pub indirect: bool,
}

/// Adds `ssM` to `cloud`.
///
/// On a tile of `pctile split` (points with `pctile_halo`), only the
/// tile's own points are computed: halo points are sources, and get 0.
pub fn ssmulti(cloud: &mut Cloud, p: &Params, progress: &Progress) -> Result<Report> {
    validate(p)?;
    let own = crate::halo::halo_mask(cloud, Some(p.reach()), "ssmulti's reach")?;
    let (mut out, report) = ssmulti_columns(cloud, p, own.as_deref(), progress)?;
    if let Some(own) = &own {
        for c in out.iter_mut() {
            for (x, &o) in c.iter_mut().zip(own) {
                if !o {
                    *x = 0.0;
                }
            }
        }
    }
    let ssm = Attribute::vec3("ssM", Role::Color, out.map(f32::wrap));
    cloud.points_mut().set(ssm)?;
    cloud.record("ssmulti_", record(p, &report));
    Ok(report)
}

/// What a run records: its parameters, and with the physical model how
/// it weighed each point's light.
fn record(p: &Params, report: &Report) -> Vec<(&'static str, DetailValue)> {
    let mut details = p.details();
    if p.medium.is_some() {
        let how = if report.by_incidence {
            "illum_cos"
        } else {
            "normal"
        };
        details.push(("ssmulti_incidence", DetailValue::Str(how.into())));
        let how = if report.by_thickness {
            "thickness"
        } else {
            "thick"
        };
        details.push(("ssmulti_thickness", DetailValue::Str(how.into())));
        if report.indirect {
            let how = "illum_indirect: its single scattering in ssM";
            details.push(("ssmulti_indirect", DetailValue::Str(how.into())));
        }
    }
    details
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
    let p = &p.resolved();
    let mut ph = progress.phases("ssmulti");
    let mut inp = inputs(cloud, p.bounce > 0.0)?;
    let (by_incidence, by_thickness, indirect) = match &p.medium {
        Some(m) => weigh_light(cloud, m, (physical_kappa(p), p.distances()), &mut inp)?,
        None => (false, false, false),
    };
    ph.mark("inputs");
    let n = inp.pts.len();
    if let Some(w) = want {
        if w.len() != n {
            return Err(Error::invalid(format!("{} flags for {n} points", w.len())));
        }
    }
    let mut out = [vec![0f32; n], vec![0f32; n], vec![0f32; n]];
    let mut report = Report {
        points: n,
        by_incidence,
        by_thickness,
        indirect,
        ..Report::default()
    };
    if n > 0 && Distances::of(p).ld1 > 0.0 {
        let own = if p.norm == Norm::Source {
            spread_by_source(&mut inp, p, progress, &mut out)
        } else {
            Vec::new()
        };
        sum_all(&inp, p, want, progress, &mut report, &mut out);
        // A point whose own kernel gives it no weight (the kernel far
        // narrower than the point's disk) returns its own light: the
        // sum's limit as the kernel shrinks to a point.
        let gains = p.gains();
        for &(i, c, e) in &own {
            out[c as usize][i as usize] = (gains[c as usize] * e as f64) as f32;
        }
        // (In point order: a point's channels side by side.)
        report.isolated = own.chunk_by(|a, b| a.0 == b.0).count();
    } else {
        report.computed = n;
    }
    // Never a non-finite value from finite inputs: sums beyond a float are
    // refused, with the point.
    for c in 0..3 {
        if let Some(i) = out[c].iter().position(|x| !x.is_finite()) {
            return Err(Error::invalid(format!(
                "point {i}: ssM would be {} (channel {c}), beyond the range of a float attribute: illum * ptarea too large for Rd * sd = {:e}",
                out[c][i],
                Distances::of(p).ld1
            )));
        }
    }
    Ok((out, report))
}

/// [`Norm::Source`]'s first pass: every point's kernel-weighted area
/// within reach, `A_i = sum_o ptarea_o W(r, ld[c])` over `I(ld[c])` (1 on
/// an even plane), summed by the same loop with a white light everywhere;
/// each source's `illum` is then divided by it, so the second pass, a
/// `Channel` sum, spreads each source's light over the area it reaches.
/// Only a lit point's area is used, so only the leaves holding a lit
/// point are summed (the dark side of an object costs nothing here);
/// for a lazy run that wants a few points too, since a wanted point's
/// sources are any lit points within reach. `scratch` is the output columns,
/// reused. Returns the points and channels whose area came out 0 (their
/// kernel too narrow to weigh even themselves), with their light.
fn spread_by_source(
    inp: &mut Inputs<'_>,
    p: &Params,
    progress: &Progress,
    scratch: &mut [Vec<f32>; 3],
) -> Vec<(u32, u8, f32)> {
    let lit: Vec<[f32; 3]> = inp.pts.iter().map(|q| q.illum).collect();
    let is_lit: Vec<bool> = lit.iter().map(|e| e.iter().any(|&x| x != 0.0)).collect();
    let grey = inp.grey;
    for q in inp.pts.iter_mut() {
        q.illum = [1.0; 3];
    }
    inp.grey = true;
    let areas = Params {
        norm: Norm::Channel,
        bounce: 0.0,
        ..*p
    };
    sum_all(
        inp,
        &areas,
        Some(&is_lit),
        progress,
        &mut Report::default(),
        scratch,
    );
    let gains = p.gains();
    let mut own = Vec::new();
    for (i, q) in inp.pts.iter_mut().enumerate() {
        if !is_lit[i] {
            // (Its area may not have been summed: it has no light to spread.)
            q.illum = [0.0; 3];
            continue;
        }
        q.illum = [0, 1, 2].map(|c| {
            // (The pass multiplied by the gain: divided out.)
            let a = scratch[c][i] as f64 / gains[c];
            if a > 0.0 && a.is_finite() {
                (lit[i][c] as f64 / a) as f32
            } else {
                if gains[c] > 0.0 && q.area > 0.0 {
                    own.push((i as u32, c as u8, lit[i][c]));
                }
                0.0
            }
        });
    }
    // Still grey when one kernel served every channel.
    inp.grey = grey && Distances::of(p).single(p.rgb);
    for c in scratch.iter_mut() {
        c.fill(0.0);
    }
    own
}

/// The exact method (`tolerance == 0`) or the approximate one, for the
/// leaves holding a wanted point (all without `want`).
fn sum_all(
    inp: &Inputs<'_>,
    p: &Params,
    want: Option<&[bool]>,
    progress: &Progress,
    report: &mut Report,
    out: &mut [Vec<f32>; 3],
) {
    let mut ph = progress.phases("ssmulti");
    let dist = Distances::of(p);
    let local = p.norm == Norm::Local;
    let columns = [
        p.bounce > 0.0,
        local,
        matches!(p.falloff, Falloff::Burley { .. }),
    ];
    let (leaves, cols, nodes) = build(inp, local, columns, progress);
    report.sources = leaves.iter().map(|l| l.src).sum();
    ph.mark("build");
    let single = dist.single(p.rgb);
    report.grey = single && inp.grey;
    // How far a source can add anything (see `reach`).
    let far = reach(p.falloff, dist.ld1);
    let setup = Setup {
        ld: dist.ld.map(|x| x as f32),
        ld1: dist.ld1 as f32,
        inv_ld1: (1.0 / dist.ld1) as f32,
        reach: far as f32,
        reaches: dist.ld.map(|l| reach(p.falloff, l) as f32),
        by_reach: {
            let mut ord = [0, 1, 2];
            // (Stable: equal distances keep the channels' order.)
            ord.sort_by(|&a, &b| dist.ld[b].total_cmp(&dist.ld[a]));
            ord
        },
        bounce: p.bounce as f32,
        single,
        grey: inp.grey,
        local,
    };
    // The cloud's size for the kernels' cap: its diagonal, and for Burley
    // the largest `r_min` either side (one position, several points: a
    // size of 0, where Burley's self weight still depends on D).
    let mut size = (inp.hi - inp.lo).length();
    if let Falloff::Burley { .. } = p.falloff {
        let amax = inp.pts.par_iter().map(|q| q.area).reduce(|| 0.0, f32::max);
        size += 2.0 * burley::rmin(amax as f64);
    }
    let run = Run {
        setup,
        kernels: Kernels::new(p.falloff, dist.ld, dist.ld1, single, size),
        cols: &cols,
        norm: Normaliser::new(p, dist, inp.area_scale),
        isa: simd::detect(p.simd),
    };
    progress.start("summing", inp.pts.len() as u64);
    let walk = walk_order(&nodes);
    let plan = (p.tolerance > 0.0).then(|| approx::Planner::new(&walk, &nodes, inp, p));
    // Each leaf writes its points' results in place: the ids are a
    // permutation of the points, so no two leaves write one position.
    let n = inp.pts.len();
    let [x, y, z] = out;
    // SAFETY: each position is written by the one leaf holding that point.
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
            |(scratch, pseudo, found, near), rl| {
                let ids = &cols.id[rl.col..rl.col + rl.len];
                if want.is_some_and(|w| !ids.iter().any(|&i| w[i as usize])) {
                    progress.inc(rl.len as u64);
                    return (0, 0);
                }
                // The source leaves in reach of this leaf, each with the
                // offset between the two origins; with a tolerance, far
                // enough clusters of them become single pseudo-sources.
                let pseudo = match &plan {
                    Some(plan) => {
                        plan.plan(rl, found, pseudo);
                        Some(&*pseudo)
                    }
                    None => {
                        near_leaves(&walk, rl, far, found);
                        None
                    }
                };
                near.clear();
                near.extend(found.iter().map(|&sl| Near::of(&leaves[sl], rl)));
                let mut res = [[0f32; 3]; LEAF];
                let pairs = run.isa.sum_leaf(LeafTask {
                    run: &run,
                    leaf: rl,
                    near,
                    pseudo,
                    scratch,
                    out: &mut res,
                });
                for (&i, v) in ids.iter().zip(&res) {
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
