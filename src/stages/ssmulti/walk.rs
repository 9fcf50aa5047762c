//! The walk method (`ssmulti --method walk`, `docs/DESIGN.md#the-walk-method`):
//! each point's `ssM` a Monte Carlo estimate of the multiple scattering of
//! the medium the mesh bounds, from random walks through the mesh
//! ([`crate::medium::mesh_walk`]) that start at the point.
//!
//! A walk that leaves the mesh at `x_i` takes the light of the cloud point
//! nearest `x_i` on the same side (its normal within 90 degrees of the
//! face's): `illum` for a walk of two or more events (single scattering is
//! sssingle's), weighed by its cosine of arrival as the slab weighs it,
//! `rm(mu) / rm_diffuse` per channel (a walk enters evenly, by
//! reciprocity: on a flat slab the mean is then exactly `rm(mu) E`, the
//! diffusion method's; `illum --indirect` adds the light between surfaces
//! into `illum`); and for a walk of one event `illum_indirect` alone: it
//! arrives from every side, and sssingle, which follows the lights, does
//! not give its single scattering.
//!
//! Each point's walks draw from their own random stream (the seed and the
//! point's index, on a tile its index in the untiled cloud): the bits do
//! not depend on the thread count, and a tile's point walks as it does
//! untiled.

use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use super::nee::Sampled;
use super::params::Params;
use crate::cloud::{Attribute, Cloud, DetailValue, Role};
use crate::column::Scalar;
use crate::error::{Error, Result};
use crate::geom::bvh::Occluder;
use crate::geom::kdtree::PointTree;
use crate::geom::mesh::TriMesh;
use crate::lights::Light;
use crate::medium::mesh_walk::{End, Walker};
use crate::medium::Medium;
use crate::progress::Progress;

/// The most walks a point may take.
pub const MAX_WALKS: u32 = 1 << 20;

/// Cloud points asked for at an exit, among which the nearest on the
/// exit's side gives the light; where none of them is on that side, the
/// wider ask.
const NEAR: usize = 8;
const NEAR_MORE: usize = 64;

/// The walk method's own parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WalkParams {
    /// Walks a point.
    pub walks: u32,
    /// The random streams' seed.
    pub seed: u64,
    /// Filter the walks' noise on the cloud ([`denoise`]).
    pub denoise: bool,
    /// Walks that start from the direction of this eye, not evenly over
    /// the hemisphere: `ssM` is then `pi` times the radiance towards the
    /// eye, not the exitance (`docs/DESIGN.md#the-exit`).
    pub eye: Option<DVec3>,
}

impl Default for WalkParams {
    fn default() -> Self {
        WalkParams {
            walks: 64,
            seed: 0,
            denoise: false,
            eye: None,
        }
    }
}

/// Neighbours a point's filtered `ssM` averages over.
pub const DENOISE_NEAR: usize = 16;

/// Two points' estimates mix while they differ by less than about this
/// many standard deviations of their noise.
pub const DENOISE_RANGE: f64 = 2.0;

/// What the walks did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct WalkReport {
    pub points: usize,
    /// Points whose `ssM` was computed (a tile's own points).
    pub computed: usize,
    pub walks: u64,
    /// Scattering events of all walks.
    pub events: u64,
    /// Walks that left the mesh and found light there.
    pub exits: u64,
    /// Walks that left where no cloud point faces the exit's side.
    pub unlit: u64,
    /// Walks that left the mesh's box (an open mesh), and walks cut at
    /// [`crate::medium::mesh_walk::MAX_EVENTS`].
    pub lost: u64,
    pub cut: u64,
    /// The cloud had `illum_cos` / `illum_indirect`.
    pub by_incidence: bool,
    pub indirect: bool,
    /// The cloud had `illum_indirect`, which walks that sample the lights
    /// do not take: they follow the light between surfaces themselves.
    pub indirect_ignored: bool,
}

impl WalkReport {
    /// What a run must say, each as a line with its counts: walks lost
    /// through holes, cut, or leaving where no point faces their side.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if self.lost > 0 {
            out.push(format!(
                "{} of {} walks left the mesh's box (the mesh has holes?): they return no light",
                self.lost, self.walks
            ));
        }
        if self.cut > 0 {
            out.push(format!(
                "{} of {} walks were still inside after {} events: cut",
                self.cut,
                self.walks,
                crate::medium::mesh_walk::MAX_EVENTS
            ));
        }
        if self.indirect_ignored {
            out.push(
                "the cloud's illum_indirect is not taken: walks that sample the lights follow the light \
                 between surfaces themselves (illum --indirect is not needed)"
                    .to_string(),
            );
        }
        if self.unlit * 100 > self.walks {
            out.push(format!(
                "{} of {} walks left where no cloud point faces their side: give more points",
                self.unlit, self.walks
            ));
        }
        out
    }
}

/// Checks that `plan` (ssmulti's decided run) can take walks `w`: the
/// physical model's medium, and walks in range; an error names the
/// parameter at fault.
pub fn check(plan: &super::Plan, w: &WalkParams) -> Result<()> {
    validate(w)?;
    medium_of(&plan.params)?;
    Ok(())
}

/// The physical model's medium the walks take; an error for the seed
/// model. (A medium that absorbs nothing is the walk's: a walk ends by
/// leaving the mesh, where the diffusion kernel would reach without end.
/// Its reach, which a tile's halo must hold, is then unbounded.)
fn medium_of(p: &Params) -> Result<&Medium> {
    p.medium.as_ref().ok_or_else(|| {
        let why = "walk needs the physical model's medium (--material, or --model physical)";
        Error::param("method", why)
    })
}

/// Checks the walk parameters; an error names the one at fault.
pub fn validate(w: &WalkParams) -> Result<()> {
    if !(1..=MAX_WALKS).contains(&w.walks) {
        return Err(Error::param(
            "walks",
            format!("{} is not in 1..={MAX_WALKS}", w.walks),
        ));
    }
    Ok(())
}

/// The light each cloud point gives a walk that leaves beside it.
struct ExitLight {
    illum: Vec<[f64; 3]>,
    /// `illum_cos`, where the cloud has it.
    cos: Option<Vec<f64>>,
    /// `illum_diffuse`, where the cloud has it: the part of `illum` spread
    /// over the hemisphere, which a walk takes as it is (its incidence is
    /// the walk's own, even).
    spread: Option<Vec<[f64; 3]>>,
    /// What a walk of one event takes: `illum_indirect`, or nothing.
    single: Vec<[f64; 3]>,
    /// The lights are sampled at the walk's events: a walk of two or
    /// more events takes the spread light alone where it leaves.
    sampled: bool,
}

/// How a medium weighs `illum` for a walk of two or more events: its
/// incidence factor at `illum_cos`, times `rm / rm_diffuse` a channel.
struct Weigh {
    inc: crate::medium::Incidence,
    k: [f64; 3],
}

impl Weigh {
    fn of(m: &Medium) -> Weigh {
        let rm_d = m.rm_diffuse();
        let k = [0, 1, 2].map(|c| {
            if rm_d[c] > 0.0 {
                m.rm[c] / rm_d[c]
            } else {
                0.0
            }
        });
        Weigh {
            inc: m.incidence(),
            k,
        }
    }
}

impl ExitLight {
    /// What a walk of `events` events that leaves beside point `j` takes,
    /// in a medium weighing it by `w`.
    fn at(&self, j: usize, events: u32, w: &Weigh) -> [f64; 3] {
        match events {
            0 => [0.0; 3],
            1 => self.single[j],
            _ if self.sampled => match &self.spread {
                Some(d) => [0, 1, 2].map(|c| d[j][c].min(self.illum[j][c])),
                None => [0.0; 3],
            },
            _ => {
                let f = match &self.cos {
                    Some(c) => w.inc.factor(c[j]),
                    None => [1.0; 3],
                };
                match &self.spread {
                    None => [0, 1, 2].map(|c| self.illum[j][c] * f[c] * w.k[c]),
                    Some(d) => [0, 1, 2].map(|c| {
                        let s = d[j][c].min(self.illum[j][c]);
                        (self.illum[j][c] - s) * f[c] * w.k[c] + s
                    }),
                }
            }
        }
    }
}

/// The cloud's light (see the module's doc).
fn light(cloud: &Cloud, rep: &mut WalkReport) -> Result<ExitLight> {
    let pts = cloud.points();
    let illum = pts.vec3_f64("illum")?;
    let n = illum.len();
    let check = |name: &str, v: &[[f64; 3]]| -> Result<()> {
        match v
            .iter()
            .position(|c| !c.iter().all(|x| x.is_finite() && *x >= 0.0))
        {
            Some(i) => Err(Error::invalid(format!(
                "point {i} has {name} {:?}: light is finite and not negative",
                v[i]
            ))),
            None => Ok(()),
        }
    };
    check("illum", &illum)?;
    let cos = if pts.has("illum_cos") {
        let c = pts.scalar_f64("illum_cos")?;
        if let Some(i) = c.iter().position(|x| x.is_nan()) {
            return Err(Error::invalid(format!("point {i}: illum_cos is NaN")));
        }
        Some(c)
    } else {
        None
    };
    rep.by_incidence = cos.is_some();
    let single = if pts.has("illum_indirect") {
        let ind = pts.vec3_f64("illum_indirect")?;
        check("illum_indirect", &ind)?;
        rep.indirect = true;
        ind
    } else {
        vec![[0.0; 3]; n]
    };
    let spread = super::inputs::spread_light(cloud)?;
    Ok(ExitLight {
        illum,
        cos,
        spread,
        single,
        sampled: false,
    })
}

/// The media a run's points walk in: one, or a per-point material's
/// groups (`which` a point's group).
struct Media {
    list: Vec<Medium>,
    which: Option<Vec<u32>>,
    /// What a per-point run records (formats/PLY.md): what came from where.
    per_point: Option<String>,
    /// The longest of the groups' reaches (a tile's halo).
    reach: f64,
}

/// Adds `ssM` to `cloud` by the walk method through `mesh` (the mesh the
/// points lie on, closed), with the physical medium of `p`.
///
/// On a tile of `pctile split`, only the tile's own points walk; the halo
/// points give light where walks leave. A walk that leaves beyond the
/// halo takes the light of the nearest point there: the halo should hold
/// the diffusion method's reach, beyond which a walk leaves in a share
/// under `e^-4` of cases. (Walks that sample the lights take no light
/// from the cloud: [`ssmulti_walk_lit`].)
pub fn ssmulti_walk(
    cloud: &mut Cloud,
    mesh: &TriMesh,
    p: &Params,
    w: &WalkParams,
    progress: &Progress,
) -> Result<WalkReport> {
    ssmulti_walk_lit(cloud, mesh, p, w, None, progress)
}

/// [`ssmulti_walk`], sampling `lights` at the walks' events when given
/// (the lights `illum` lit the cloud with: [`super::nee`]) rather than
/// taking their light from `illum` where a walk leaves. Such walks follow
/// the light between surfaces too ([`Walker::reentering`]): one that
/// leaves flies on through the air and walks on where it comes back in,
/// and one that leaves under the sky takes the constant domes' light;
/// the cloud's `illum_indirect` is not taken.
pub fn ssmulti_walk_lit(
    cloud: &mut Cloud,
    mesh: &TriMesh,
    p: &Params,
    w: &WalkParams,
    lights: Option<&[Light]>,
    progress: &Progress,
) -> Result<WalkReport> {
    let media = Media {
        list: vec![*medium_of(p)?],
        which: None,
        per_point: None,
        reach: p.reach(),
    };
    walks(cloud, mesh, p, &media, w, lights, progress)
}

/// [`ssmulti_walk`] with `plan`'s per-point material: each point's walks
/// take its own medium throughout (its group's, formats/MATERIAL.md#per-point).
/// Returns the report and the number of groups.
pub fn ssmulti_walk_per_point(
    cloud: &mut Cloud,
    mesh: &TriMesh,
    plan: &super::Plan,
    w: &WalkParams,
    lights: Option<&[Light]>,
    progress: &Progress,
) -> Result<(WalkReport, usize)> {
    let p = &plan.params;
    medium_of(p)?;
    let groups = if plan.per_point.attrs.is_empty() {
        None
    } else {
        super::per_point::groups(cloud, p, &plan.base, &plan.per_point)?
    };
    let Some(g) = groups else {
        return Ok((ssmulti_walk_lit(cloud, mesh, p, w, lights, progress)?, 1));
    };
    let mut which = vec![0u32; cloud.len()];
    for (k, m) in g.members.iter().enumerate() {
        for &i in m {
            which[i] = k as u32;
        }
    }
    let list = g
        .params
        .iter()
        .map(|q| medium_of(q).cloned())
        .collect::<Result<Vec<_>>>()?;
    let media = Media {
        list,
        which: Some(which),
        per_point: Some(g.detail),
        reach: g.params.iter().map(|q| q.reach()).fold(0.0, f64::max),
    };
    let rep = walks(cloud, mesh, p, &media, w, lights, progress)?;
    Ok((rep, g.members.len()))
}

/// The walks of every point, each in its medium of `media`; `p` the run's
/// parameters (its medium the constant material's), recorded.
fn walks(
    cloud: &mut Cloud,
    mesh: &TriMesh,
    p: &Params,
    media: &Media,
    w: &WalkParams,
    lights: Option<&[Light]>,
    progress: &Progress,
) -> Result<WalkReport> {
    let (value, err, rep) = walk_rows(cloud, mesh, media, w, lights, None, progress)?;
    let cols = [0, 1, 2].map(|c| value.iter().map(|r| r[c]).collect::<Vec<f32>>());
    let ssm = Attribute::vec3("ssM", Role::Color, cols.map(f32::wrap));
    cloud.points_mut().set(ssm)?;
    cloud.points_mut().set_vec3("ssM_err", Role::Vector, &err)?;
    let mut details = record(p, w, mesh, &rep);
    if let Some(l) = lights {
        let d = crate::lights::digest(l);
        details.push(("ssmulti_lights_digest", DetailValue::Str(d)));
    }
    if let Some(d) = &media.per_point {
        details.push(("ssmulti_per_point", DetailValue::Str(d.clone())));
    }
    cloud.record("ssmulti_", details);
    Ok(rep)
}

/// `ssM` by the walk method for the points of `cloud` that `want` marks
/// (all without it; the others get 0), with the medium of `p`: what
/// `filter` and `render` compute lazily. A point's value is the one a
/// whole run gives it, bit for bit (with `--denoise` its nearest
/// neighbours walk too).
pub fn walk_values(
    cloud: &Cloud,
    mesh: &TriMesh,
    p: &Params,
    w: &WalkParams,
    lights: Option<&[Light]>,
    want: Option<&[bool]>,
    progress: &Progress,
) -> Result<(Vec<[f32; 3]>, WalkReport)> {
    let media = Media {
        list: vec![*medium_of(p)?],
        which: None,
        per_point: None,
        reach: p.reach(),
    };
    let (value, _, rep) = walk_rows(cloud, mesh, &media, w, lights, want, progress)?;
    Ok((value, rep))
}

/// A value a point, per channel.
type Rows = Vec<[f32; 3]>;

/// Each point's `ssM` and standard error (`ssM_err`) by the walk method,
/// for the points `want` marks (all without it), and the report.
fn walk_rows(
    cloud: &Cloud,
    mesh: &TriMesh,
    media: &Media,
    w: &WalkParams,
    lights: Option<&[Light]>,
    want: Option<&[bool]>,
    progress: &Progress,
) -> Result<(Rows, Rows, WalkReport)> {
    validate(w)?;
    mesh.require_area()?;
    let own = crate::halo::halo_mask(cloud, Some(media.reach), "ssmulti's reach")?;
    let mut rep = WalkReport::default();
    let pos = cloud.points().vec3_f64("P")?;
    let nrm = cloud.points().vec3_f64("N")?;
    let n = pos.len();
    rep.points = n;
    if let Some(i) = (0..n).find(|&i| {
        !(pos[i].iter().all(|x| x.is_finite()) && DVec3::from_array(nrm[i]).length() > 0.0)
    }) {
        return Err(Error::invalid(format!(
            "point {i}: P {:?} and N {:?} must be finite, N not zero",
            pos[i], nrm[i]
        )));
    }
    let mut light = light(cloud, &mut rep)?;
    light.sampled = lights.is_some();
    let weigh: Vec<Weigh> = media.list.iter().map(Weigh::of).collect();
    // A tile's point walks the stream of its index in the untiled cloud:
    // the tiled bake draws the untiled one's walks.
    let stream: Vec<u64> = if cloud.points().has(crate::names::INDEX) {
        let ix = cloud.points().scalar_f64(crate::names::INDEX)?;
        ix.into_iter().map(|x| x as u64).collect()
    } else {
        (0..n as u64).collect()
    };
    let origin = pos.first().map_or(DVec3::ZERO, |&q| DVec3::from_array(q));
    let tree = PointTree::new(pos.iter().map(|&q| DVec3::from_array(q)), origin);
    let unit: Vec<DVec3> = nrm
        .iter()
        .map(|&q| DVec3::from_array(q).normalize())
        .collect();
    let occ = Occluder::new(mesh);
    // Walks that sample the lights follow the light between surfaces
    // themselves (they take none from the cloud where they leave), and
    // end under the sky: a constant dome's radiance, pi L as the spread
    // light's irradiance is.
    let walker = match lights {
        Some(_) => Walker::new(mesh, &occ).reentering(),
        None => Walker::new(mesh, &occ),
    };
    let sky: [f64; 3] = lights.map_or([0.0; 3], |l| {
        let mut sum = DVec3::ZERO;
        for light in l {
            if matches!(&light.shape, crate::lights::Shape::Dome(d) if d.map.is_none()) {
                sum += light.cl;
            }
        }
        (sum * std::f64::consts::PI).to_array()
    });
    if lights.is_some() && rep.indirect {
        rep.indirect = false;
        rep.indirect_ignored = true;
    }
    let walk_media: Vec<_> = media.list.iter().map(|m| walker.medium(m)).collect();
    // The lights sampled at the events, with each medium's shadows.
    let sampled: Option<Vec<Sampled>> = match lights {
        Some(l) => Some(
            media
                .list
                .iter()
                .map(|m| Sampled::new(l, cloud, mesh, &occ, m))
                .collect::<Result<_>>()?,
        ),
        None => None,
    };
    // The points that walk: those wanted (with the filter, their
    // neighbours too), and of a tile its own (and with the filter its
    // halo: its own points near the tile's edge average them as untiled).
    let walks_at: Vec<bool> = {
        let mut at: Vec<bool> = (0..n)
            .map(|i| want.is_none_or(|m| m[i]) && (w.denoise || own.as_ref().is_none_or(|o| o[i])))
            .collect();
        if w.denoise && want.is_some() {
            for i in 0..n {
                if want.is_some_and(|m| m[i]) {
                    for q in tree.nearest(DVec3::from_array(pos[i]), DENOISE_NEAR) {
                        at[q.item as usize] = true;
                    }
                }
            }
        }
        at
    };
    progress.start("ssmulti: walks", n as u64);
    let per_point: Vec<([f64; 3], [f64; 3], [u64; 6])> = (0..n)
        .into_par_iter()
        .map(|i| {
            progress.inc(1);
            if !walks_at[i] {
                return ([0.0; 3], [0.0; 3], [0; 6]);
            }
            let mut r = Pcg32::new(w.seed, stream[i]);
            let (mut sum, mut sq) = ([0.0f64; 3], [0.0f64; 3]);
            // (walks, events, exits, unlit, lost, cut)
            let mut counts = [0u64; 6];
            let start = DVec3::from_array(pos[i]);
            let k = media.which.as_ref().map_or(0, |g| g[i] as usize);
            let medium = &walk_media[k];
            let mut buf = Vec::new();
            // From the eye's direction, or evenly; a point facing away
            // from the eye does not walk (nor count as computed).
            let towards = w.eye.map(|e| (e - start).normalize_or_zero());
            if towards.is_some_and(|v| v.dot(unit[i]) <= 0.0) {
                return ([0.0; 3], [0.0; 3], [0; 6]);
            }
            for _ in 0..w.walks {
                counts[0] += 1;
                // The lights sampled at the walk's events of two or more.
                let mut got = [0.0f64; 3];
                let end = match &sampled {
                    Some(s) => walker.walk_with(medium, start, unit[i], towards, &mut r, |e, r| {
                        // (A first event along the view's refracted line,
                        // through every part it crosses, is sssingle's.)
                        if e.events >= 2 || !e.straight {
                            let x = s[k].at(e, &media.list[k], &walker, r, &mut buf);
                            (0..3).for_each(|c| got[c] += x[c]);
                        }
                    }),
                    None => walker.walk_with(medium, start, unit[i], towards, &mut r, |_, _| {}),
                };
                let mut left = [0.0f64; 3];
                match end {
                    End::Exit {
                        events,
                        weight,
                        first_straight,
                        ..
                    } if walker.reenters() => {
                        // Out under the sky.
                        counts[1] += events as u64;
                        counts[2] += 1;
                        if events >= 2 || (events == 1 && !first_straight) {
                            left = [0, 1, 2].map(|c| weight[c] * sky[c]);
                        }
                    }
                    End::Exit {
                        pos: x,
                        normal,
                        events,
                        weight,
                        ..
                    } => {
                        counts[1] += events as u64;
                        // The nearest few, then more where they all
                        // face another way (at an edge of a sparse cloud).
                        let facing = |k: usize| {
                            tree.nearest(x, k)
                                .iter()
                                .map(|q| q.item as usize)
                                .find(|&j| unit[j].dot(normal) > 0.0)
                        };
                        let Some(j) = facing(NEAR).or_else(|| facing(NEAR_MORE)) else {
                            counts[3] += 1;
                            continue;
                        };
                        counts[2] += 1;
                        // (illum holds illum_indirect too: its
                        // multiple scattering is in the first term.)
                        let e = light.at(j, events, &weigh[k]);
                        left = [0, 1, 2].map(|c| weight[c] * e[c]);
                    }
                    End::Absorbed => {}
                    End::Lost => counts[4] += 1,
                    End::Cut => counts[5] += 1,
                }
                for c in 0..3 {
                    let x = got[c] + left[c];
                    sum[c] += x;
                    sq[c] += x * x;
                }
            }
            // The mean and its variance (the walks' sample variance over
            // their count).
            let m = w.walks as f64;
            let mean = sum.map(|s| s / m);
            let var = [0, 1, 2].map(|c| {
                if m > 1.0 {
                    ((sq[c] - sum[c] * mean[c]) / (m - 1.0)).max(0.0) / m
                } else {
                    0.0
                }
            });
            (mean, var, counts)
        })
        .collect();
    progress.finish();
    let mean: Vec<[f64; 3]> = per_point.iter().map(|p| p.0).collect();
    let var: Vec<[f64; 3]> = per_point.iter().map(|p| p.1).collect();
    // The points whose value is given: a tile's own, of those wanted.
    let given: Vec<bool> = (0..n)
        .map(|i| own.as_ref().is_none_or(|o| o[i]) && want.is_none_or(|m| m[i]))
        .collect();
    let value = if w.denoise {
        // (A point that did not walk, facing away from the eye, has no
        // estimate to lend.)
        let walked: Vec<bool> = per_point.iter().map(|p| p.2[0] > 0).collect();
        denoise(&tree, &pos, &unit, &mean, &var, &given, &walked)
    } else {
        mean
    };
    let mut out = vec![[0f32; 3]; n];
    for (i, (_, _, c)) in per_point.iter().enumerate() {
        // A tile's halo points get 0, as the diffusion method gives them.
        if !given[i] {
            continue;
        }
        out[i] = value[i].map(|x| x as f32);
        if c[0] > 0 {
            rep.computed += 1;
        }
        rep.walks += c[0];
        rep.events += c[1];
        rep.exits += c[2];
        rep.unlit += c[3];
        rep.lost += c[4];
        rep.cut += c[5];
    }
    // The walks' noise, as a standard error a channel (before any filter).
    let err: Vec<[f32; 3]> = var.iter().map(|v| v.map(|x| x.sqrt() as f32)).collect();
    Ok((out, err, rep))
}

/// `ssM` filtered on the cloud (`docs/DESIGN.md#the-walk-method`): each
/// point (of those `own`) takes the weighted mean of its
/// [`DENOISE_NEAR`] nearest points' estimates `mean`, weighed by their
/// distance (a Gaussian of half the farthest's), their normals' agreement
/// (`max(0, N_i . N_j)^8`: not across a crease) and, channel by channel,
/// how far apart the two estimates are against their noise `var`
/// (`e^(-d^2 / 2 k^2 (v_i + v_j))`, `k` [`DENOISE_RANGE`]: not across a
/// shadow's edge the walks resolve); the neighbours that did not walk
/// (not `walked`) lend nothing.
fn denoise(
    tree: &PointTree,
    pos: &[[f64; 3]],
    unit: &[DVec3],
    mean: &[[f64; 3]],
    var: &[[f64; 3]],
    own: &[bool],
    walked: &[bool],
) -> Vec<[f64; 3]> {
    let k2 = DENOISE_RANGE * DENOISE_RANGE;
    (0..mean.len())
        .into_par_iter()
        .map(|i| {
            if !own[i] {
                return mean[i];
            }
            let near = tree.nearest(DVec3::from_array(pos[i]), DENOISE_NEAR);
            let h2 = near.last().map_or(0.0, |q| q.distance);
            if h2 <= 0.0 {
                return mean[i];
            }
            let (mut acc, mut wsum) = ([0.0f64; 3], [0.0f64; 3]);
            for q in &near {
                let j = q.item as usize;
                if !walked[j] {
                    continue;
                }
                let ws = (-2.0 * q.distance / h2).exp();
                let wn = unit[i].dot(unit[j]).max(0.0).powi(8);
                if ws * wn <= 0.0 {
                    continue;
                }
                for c in 0..3 {
                    let d = mean[i][c] - mean[j][c];
                    let v = var[i][c] + var[j][c];
                    let wr = if v > 0.0 {
                        (-d * d / (2.0 * k2 * v)).exp()
                    } else if d == 0.0 {
                        1.0
                    } else {
                        0.0
                    };
                    acc[c] += ws * wn * wr * mean[j][c];
                    wsum[c] += ws * wn * wr;
                }
            }
            [0, 1, 2].map(|c| {
                if wsum[c] > 0.0 {
                    acc[c] / wsum[c]
                } else {
                    mean[i][c]
                }
            })
        })
        .collect()
}

/// What a walk run records: the medium's keys as the diffusion method
/// records them, the method, its walks, seed and mesh.
fn record(
    p: &Params,
    w: &WalkParams,
    mesh: &TriMesh,
    rep: &WalkReport,
) -> Vec<(&'static str, DetailValue)> {
    let mut d: Vec<(&'static str, DetailValue)> = p
        .details()
        .into_iter()
        .filter(|(k, _)| {
            !matches!(
                *k,
                "ssmulti_distances"
                    | "ssmulti_falloff"
                    | "ssmulti_norm"
                    | "ssmulti_tolerance"
                    | "ssmulti_bounce"
            )
        })
        .collect();
    d.extend([
        ("ssmulti_method", DetailValue::Str("walk".into())),
        ("ssmulti_walks", DetailValue::I32(w.walks as i32)),
        ("ssmulti_seed", DetailValue::Str(w.seed.to_string())),
        ("ssmulti_mesh", DetailValue::Str(mesh.digest())),
        ("ssmulti_denoise", DetailValue::I32(w.denoise as i32)),
    ]);
    if let Some(e) = w.eye {
        d.push(("ssmulti_eye", DetailValue::V3D(e.to_array())));
    }
    let how = if rep.by_incidence {
        "illum_cos"
    } else {
        "normal"
    };
    d.push(("ssmulti_incidence", DetailValue::Str(how.into())));
    if rep.indirect {
        let how = "illum_indirect: its single scattering in ssM";
        d.push(("ssmulti_indirect", DetailValue::Str(how.into())));
    }
    d
}
