//! `sssingle` (Marengo's `ssIntegSingle`): single scattering at every
//! cloud point, for one eye, `ssS` (colour), as `docs/DESIGN.md#sssingle`
//! writes it. Along the view ray refracted into the surface, `samples`
//! depths (stratified, from the point's own random stream: the same bits
//! on any thread count); from each, a ray towards every light sample finds
//! where that light enters the mesh, and a shadow ray from there on to
//! the light what lies in the way ([`crate::lights::shadow`], illum's
//! rules; the physical model's mesh holds its medium, which lets through
//! what crosses it); the light is carried to the depth
//! along the refracted path, scattered towards the eye by a
//! Henyey-Greenstein phase function and refracted out, with Fresnel at
//! both crossings.
//!
//! Two models ([`Model`]): Marengo's (`seed`: the smooth falloff over the
//! refracted path, Rd and sd as ssmulti's, samples with density
//! following the falloff) and the physical one (Jensen et al. 2001:
//! albedo, mean free path, exponential attenuation, a truncated
//! exponential over the depth; three different mean free paths share one
//! set of rays through the balance heuristic).
//!
//! Work skipped: a point the eye does not see (`dot(N, eye - P) <= 0`)
//! costs nothing; a light sample that sends nothing to a depth (outside a
//! spot's cone, a one-sided emitter facing away) costs no ray, nor a
//! shadow ray a pair that brings nothing (the seed falloff past `lu1`); one
//! channel's distances or mean free paths equal: one density.

pub mod interior;
pub mod optics;
mod params;

use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::error::{Error, Result};
use crate::geom::columns::Columns;
use crate::geom::mesh::TriMesh;
use crate::lights::shadow::{Passage, Shadows};
use crate::lights::{Arrival, Light, Shape};
use crate::maths::uniform24;
use crate::progress::Progress;

use self::interior::{Entry, Interior, Stretch};
use self::optics::*;

/// Which estimator: Marengo's (`Seed`: Rd, sd, the smooth falloff over
/// the refracted path, HG scaled to peak 1) or the physical one (Jensen
/// et al. 2001: albedo and mean free path per channel, exponential
/// attenuation, HG normalised).
pub use crate::medium::Model;
pub use params::{validate, Given, Params, MAX_SAMPLES};

/// What `sssingle` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub points: usize,
    /// Points whose `ssS` was computed (seen from the eye, and wanted).
    pub computed: usize,
    /// Points the eye does not see (nothing computed).
    pub unseen: usize,
    /// Points whose view ray is totally reflected (eta below 1).
    pub reflected: usize,
    /// Rays cast towards lights.
    pub rays: u64,
    /// Of those, rays that found where their light enters.
    pub entered: u64,
    /// Shadow rays traced from where light enters towards the light, and
    /// of them those the mesh blocked.
    pub shadow_rays: u64,
    pub shadowed: u64,
    /// Points seen from the eye where no light entered: `ssS` 0.
    pub dark: usize,
    /// The eye is inside the mesh.
    pub eye_inside: bool,
    /// Points checked against the mesh (a sample, at most
    /// [`DIAGNOSIS_SAMPLE`]), of them those farther from it than
    /// [`OFF_MESH`] of its size, and those whose normal faces against
    /// the mesh's face there.
    pub sampled: usize,
    pub off_mesh: usize,
    pub against: usize,
    /// Lights (by name) whose place is inside the mesh.
    pub lights_inside: Vec<String>,
}

/// At most this many points are checked against the mesh.
pub const DIAGNOSIS_SAMPLE: usize = 1024;
/// A point farther than this part of the mesh's size from it is off it.
pub const OFF_MESH: f64 = 1e-3;

impl Report {
    /// Where the run computed nothing it was asked for, or what it
    /// computed cannot be right, each as a line with its counts: points
    /// off the mesh, a mesh wound against its points' normals, lights
    /// inside it, the eye inside it, points no light entered.
    pub fn warnings(&self) -> Vec<String> {
        let mut w = Vec::new();
        if self.off_mesh > 0 {
            w.push(format!(
                "{} of {} points checked lie off the mesh (farther than {OFF_MESH} of its size): ssS needs the mesh the points lie on",
                self.off_mesh, self.sampled
            ));
        }
        if self.against * 2 > self.sampled {
            w.push(format!(
                "{} of {} points checked face against the mesh (its faces wound inwards, or the normals flipped): light is found entering the wrong side",
                self.against, self.sampled
            ));
        }
        for l in &self.lights_inside {
            w.push(format!(
                "light '{l}' is inside the mesh: its light enters nowhere"
            ));
        }
        let dark = self.points - self.computed - self.reflected;
        if self.eye_inside {
            w.push(format!(
                "the eye is inside the mesh: {dark} of {} points saw nothing",
                self.points
            ));
        } else if self.computed == 0 && self.points > 0 {
            w.push("no point is seen from the eye: ssS is 0 everywhere".into());
        }
        if self.dark * 2 > self.computed && self.computed > 0 {
            w.push(format!(
                "{} of {} points seen from the eye had no light enter the mesh: ssS is 0 there",
                self.dark, self.computed
            ));
        }
        w
    }
}

/// Adds `ssS` to `cloud`'s points (which need `P` and `N`) for the eye
/// `p.eye`, with light from `lights` entering through `mesh`.
pub fn sssingle(
    cloud: &mut Cloud,
    mesh: &TriMesh,
    lights: &[Light],
    p: &Params,
    progress: &Progress,
) -> Result<Report> {
    // On a tile, the tile's own points: a point's ssS needs only the
    // mesh and the lights, so any halo will do; halo points get 0.
    let own = crate::halo::halo_mask(cloud, Some(0.0), "sssingle")?;
    let (out, report) = sssingle_values(cloud, mesh, lights, p, own.as_deref(), progress)?;
    cloud.points_mut().set_vec3("ssS", Role::Color, &out)?;
    let mut details = p.details();
    let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
    details.push(("sssingle_lights", DetailValue::Str(names.join(","))));
    details.push((
        "sssingle_lights_digest",
        DetailValue::Str(crate::lights::digest(lights)),
    ));
    details.push(("sssingle_mesh_digest", DetailValue::Str(mesh.digest())));
    cloud.record("sssingle_", details);
    Ok(report)
}

/// Bytes a mesh's triangle takes at sssingle's peak (its BVH, its
/// normals, the grids down distant lights, the mesh itself), with a
/// margin: peaks measured on the Stanford dragon and a mesh of 1e7
/// triangles (benches/results/HISTORY.md, "Memory a triangle").
pub const MESH_BYTES: u64 = 800;

/// Checks that the machine holds sssingle's structures over `mesh`
/// ([`MESH_BYTES`] a triangle).
pub fn check_mesh(mesh: &TriMesh) -> Result<()> {
    crate::memory::check_mesh(mesh.tris.len(), MESH_BYTES)
}

/// `ssS` of `cloud`'s points without changing the cloud: of every point,
/// or (`want`, one flag a point) only of the wanted ones (others get 0;
/// `Report::computed` counts the wanted points the eye sees).
pub fn sssingle_values(
    cloud: &Cloud,
    mesh: &TriMesh,
    lights: &[Light],
    p: &Params,
    want: Option<&[bool]>,
    progress: &Progress,
) -> Result<(Vec<[f32; 3]>, Report)> {
    validate(p)?;
    check_mesh(mesh)?;
    let pts = cloud.points();
    if !pts.has("N") {
        return Err(pts.missing("N"));
    }
    let pos = pts.vec3_f64("P")?;
    let nrm = pts.vec3_f64("N")?;
    if let Some(w) = want {
        if w.len() != pos.len() {
            return Err(Error::invalid(format!(
                "{} flags for {} points",
                w.len(),
                pos.len()
            )));
        }
    }
    for i in 0..pos.len() {
        let (x, n) = (DVec3::from_array(pos[i]), DVec3::from_array(nrm[i]));
        if !x.is_finite() {
            return Err(Error::invalid(format!(
                "point {i}: P is {:?}, not finite",
                pos[i]
            )));
        }
        if !(n.is_finite() && n.length_squared() > 0.0) {
            return Err(Error::invalid(format!(
                "point {i}: N is {:?}, which has no direction",
                nrm[i]
            )));
        }
    }
    let interior = Interior::new(mesh, p.cusp);
    let wanted = want.map_or(pos.len(), |w| w.iter().filter(|&&x| x).count());
    let run = Run::new(p, lights, &interior, wanted);
    progress.start("single scattering", pos.len() as u64);
    let per_point: Vec<([f64; 3], Outcome)> = (0..pos.len())
        .into_par_iter()
        .map_init(Scratch::default, |scratch, i| {
            progress.inc(1);
            if want.is_some_and(|w| !w[i]) {
                return ([0.0; 3], Outcome::Skipped);
            }
            let xo = DVec3::from_array(pos[i]);
            let no = DVec3::from_array(nrm[i]).normalize();
            run.point(i as u64, xo, no, scratch)
        })
        .collect();
    progress.finish();
    let mut report = Report {
        points: pos.len(),
        eye_inside: interior.contains(p.eye),
        ..Report::default()
    };
    diagnose(&interior, &pos, &nrm, lights, want, &mut report);
    let mut out = Vec::with_capacity(per_point.len());
    for (i, (v, o)) in per_point.into_iter().enumerate() {
        // Never a non-finite value it did not read: too much light for a
        // float attribute is refused.
        if !v
            .iter()
            .all(|x| x.is_finite() && x.abs() <= f32::MAX as f64)
        {
            return Err(Error::invalid(format!(
                "point {i}: ssS would be {:e}, {:e}, {:e}, beyond the range of a float attribute (are the lights' intensities right?)",
                v[0], v[1], v[2]
            )));
        }
        out.push(v.map(|x| x as f32));
        match o {
            Outcome::Skipped => {}
            Outcome::Unseen => report.unseen += 1,
            Outcome::Reflected => report.reflected += 1,
            Outcome::Lit {
                rays,
                entered,
                shadow_rays,
                shadowed,
            } => {
                report.computed += 1;
                report.rays += rays;
                report.entered += entered;
                report.shadow_rays += shadow_rays;
                report.shadowed += shadowed;
                report.dark += (entered == 0) as usize;
            }
        }
    }
    Ok((out, report))
}

/// Checks a sample of the (wanted) points against the mesh, and the
/// lights' places: the counts [`Report::warnings`] speaks of.
fn diagnose(
    interior: &Interior,
    pos: &[[f64; 3]],
    nrm: &[[f64; 3]],
    lights: &[Light],
    want: Option<&[bool]>,
    report: &mut Report,
) {
    let ids: Vec<usize> = (0..pos.len())
        .filter(|&i| want.is_none_or(|w| w[i]))
        .collect();
    let step = ids.len().div_ceil(DIAGNOSIS_SAMPLE).max(1);
    let far = OFF_MESH * interior.size();
    let checked: Vec<(bool, bool)> = ids
        .par_iter()
        .step_by(step)
        .filter_map(|&i| {
            let (d, face) = interior.closest(DVec3::from_array(pos[i]))?;
            Some((d > far, face.dot(DVec3::from_array(nrm[i])) < 0.0))
        })
        .collect();
    report.sampled = checked.len();
    report.off_mesh = checked.iter().filter(|c| c.0).count();
    report.against = checked.iter().filter(|c| !c.0 && c.1).count();
    report.lights_inside = lights
        .iter()
        .filter(|l| {
            let place = match l.shape {
                Shape::Distant { .. } | Shape::Dome(_) => None,
                Shape::Point { position } | Shape::Spot { position, .. } => Some(position),
                Shape::Rect { centre, .. }
                | Shape::Disk { centre, .. }
                | Shape::Sphere { centre, .. } => Some(centre),
            };
            place.is_some_and(|p| interior.contains(p))
        })
        .map(|l| l.name.clone())
        .collect();
}

/// A thread's reusable buffers.
#[derive(Default)]
struct Scratch {
    emissions: Vec<Arrival>,
    /// Per light: the sum over its pairs and the pairs with a hit.
    sums: Vec<([f64; 3], u64)>,
    /// The view ray's stretches inside the medium.
    path: Vec<Stretch>,
}

/// The point at length `s` inside the medium along the view ray `dir`
/// through the stretches `path` (the last one's end when `s` is past
/// them all), and the Fresnel transmittance of the faces crossed to get
/// there.
fn along(path: &[Stretch], dir: DVec3, mut s: f64) -> (DVec3, f64) {
    for (k, st) in path.iter().enumerate() {
        if s <= st.len || k + 1 == path.len() {
            return (st.at + dir * s.min(st.len), st.kt);
        }
        s -= st.len;
    }
    (DVec3::ZERO, 0.0)
}

/// What happened at a point.
enum Outcome {
    /// Not wanted.
    Skipped,
    Unseen,
    Reflected,
    Lit {
        rays: u64,
        entered: u64,
        shadow_rays: u64,
        shadowed: u64,
    },
}

/// What every point of a run shares.
struct Run<'a> {
    p: &'a Params,
    lights: &'a [Light],
    interior: &'a Interior<'a>,
    /// Seed model: the channels' distances and the largest.
    lu: [f64; 3],
    lu1: f64,
    /// Their reciprocals (0 for a distance of 0), and `1 / eta^2`: the
    /// pair loop multiplies.
    inv_lu: [f64; 3],
    inv_lu1: f64,
    inv_eta2: f64,
    /// Physical model: extinction per channel.
    sigma_t: [f64; 3],
    /// One kernel or density serves every channel.
    single: bool,
    /// Per light: a grid for its parallel rays (a distant light's).
    columns: Vec<Option<Columns>>,
    /// The mesh's shadows (the physical model's: through its medium).
    shadows: Shadows<'a>,
}

impl<'a> Run<'a> {
    /// `points`: how many points the run computes (a light's rays are at
    /// most these times the samples).
    fn new(
        p: &'a Params,
        lights: &'a [Light],
        interior: &'a Interior<'a>,
        points: usize,
    ) -> Run<'a> {
        let rays = points as u64 * p.samples as u64;
        let lu = p.rd.map(|r| r * p.sd);
        let lu1 = lu.iter().copied().fold(0.0, f64::max);
        let inv = |d: f64| if d > 0.0 { 1.0 / d } else { 0.0 };
        let sigma_t = p.mfp.map(|m| 1.0 / m);
        let single = match p.model {
            Model::Seed => !p.rgb || (lu[0] == lu[1] && lu[1] == lu[2]),
            Model::Physical => sigma_t[0] == sigma_t[1] && sigma_t[1] == sigma_t[2],
        };
        let columns = lights
            .par_iter()
            .map(|l| match l.shape {
                Shape::Distant { to_light } if interior.columns_worth_it(rays) => {
                    interior.columns(to_light)
                }
                _ => None,
            })
            .collect();
        Run {
            p,
            lights,
            interior,
            lu,
            lu1,
            inv_lu: lu.map(inv),
            inv_lu1: inv(lu1),
            inv_eta2: 1.0 / (p.eta * p.eta),
            sigma_t,
            single,
            columns,
            shadows: interior.shadows(match p.model {
                Model::Seed => None,
                Model::Physical => Some(Passage {
                    sigma_t: DVec3::from_array(sigma_t),
                    eta: p.eta,
                }),
            }),
        }
    }

    /// `ssS` at point `i` (`xo`, unit `no`).
    fn point(&self, i: u64, xo: DVec3, no: DVec3, scratch: &mut Scratch) -> ([f64; 3], Outcome) {
        let p = self.p;
        let wo = (p.eye - xo).normalize_or_zero();
        let cos_o = no.dot(wo);
        // (Also an eye at the point itself: `wo` is zero.)
        if cos_o.is_nan() || cos_o <= 0.0 {
            return ([0.0; 3], Outcome::Unseen);
        }
        let Some(to) = refract(-wo, no, 1.0 / p.eta) else {
            return ([0.0; 3], Outcome::Reflected);
        };
        let view = View {
            wpo: -to,
            kto: 1.0 - fresnel(cos_o, p.eta),
        };
        let Scratch {
            emissions,
            sums,
            path,
        } = scratch;
        // The depths' range along the view ray. Seed: up to the longest
        // distance, so the exit farther away need not be found. Physical:
        // every stretch of the medium the ray crosses, end to end (the
        // exponential runs over the length inside).
        match p.model {
            Model::Seed => {
                let (x0, d) = self.interior.view_within(xo, to, self.lu1);
                path.clear();
                path.push(Stretch {
                    at: x0,
                    len: d,
                    kt: 1.0,
                });
            }
            Model::Physical => self.interior.view_path(xo, to, p.eta, path),
        }
        let d: f64 = path.iter().map(|s| s.len).sum();
        let mut rng = Pcg32::new(p.seed, i);
        let k = p.samples as usize;
        sums.clear();
        sums.resize(self.lights.len(), ([0.0; 3], 0));
        let (mut rays, mut entered) = (0u64, 0u64);
        let (mut shadow_rays, mut shadowed) = (0u64, 0u64);
        for j in 0..k {
            let (s, weight) = self.depth(j, uniform24(&mut rng), d);
            let (ps, kt) = along(path, to, s);
            let weight = weight.map(|w| w * kt);
            for (l, light) in self.lights.iter().enumerate() {
                let (r1, r2) = if light.samples > 1 {
                    (uniform24(&mut rng), uniform24(&mut rng))
                } else {
                    (0.5, 0.5)
                };
                light.emissions(ps, r1, r2, emissions);
                for e in emissions.iter() {
                    rays += 1;
                    let cols = self.columns[l].as_ref();
                    let Some(hit) = self.interior.entry_with(cols, ps, e.dir, e.dist) else {
                        continue;
                    };
                    let ci = e.dir.dot(hit.normal);
                    if ci.is_nan() || ci <= 0.0 {
                        continue;
                    }
                    entered += 1;
                    let f = self.pair(&view, e, &hit, ci, weight);
                    // A shadowed pair still counts (it entered, and
                    // brings nothing); one that adds nothing needs no
                    // shadow ray.
                    let through = if !p.shadows || f == [0.0; 3] {
                        DVec3::ONE
                    } else {
                        shadow_rays += 1;
                        let from = ps + e.dir * hit.dist;
                        let rest = e.dist - hit.dist;
                        let reach = self.shadows.from_triangle(cols, from, hit.tri, e.dir, rest);
                        shadowed += reach.blocked as u64;
                        reach.through
                    };
                    let (sum, n) = &mut sums[l];
                    for c in 0..3 {
                        sum[c] += f[c] * through[c];
                    }
                    *n += 1;
                }
            }
        }
        let mut v = [0.0f64; 3];
        for (l, (sum, hits)) in sums.iter().enumerate() {
            // Seed: over the pairs with a hit (Marengo's); physical: the
            // mean over every pair a light has.
            let n = match p.model {
                Model::Seed => *hits as f64,
                Model::Physical => (k as u64 * self.lights[l].samples as u64) as f64,
            };
            if n > 0.0 {
                for c in 0..3 {
                    v[c] += sum[c] / n;
                }
            }
        }
        let scale = match p.model {
            Model::Seed => [2.0; 3],
            Model::Physical => p.albedo.map(|a| a * view.kto / (p.eta * p.eta)),
        };
        let out = [0, 1, 2].map(|c| v[c] * scale[c]);
        (
            out,
            Outcome::Lit {
                rays,
                entered,
                shadow_rays,
                shadowed,
            },
        )
    }

    /// The depth of sample `j` (of `samples`, jittered by `xi` in its
    /// stratum) along the view ray, and each channel's weight for it.
    /// Seed: the falloff's own density on [0, min(d, lu1)], weight 1.
    /// Physical: the truncated exponential on [0, d], weight its mass;
    /// with three densities, their even mixture `q` (stratified along its
    /// own distribution), and channel c weighs `mass_c p_c(s) / q(s)` (the
    /// balance heuristic).
    fn depth(&self, j: usize, xi: f64, d: f64) -> (f64, [f64; 3]) {
        let k = self.p.samples as usize;
        match self.p.model {
            Model::Seed => {
                let lu1 = self.lu1;
                if lu1 <= 0.0 {
                    return (0.0, [1.0; 3]);
                }
                let u = (j as f64 + xi) / k as f64;
                let smax = d.min(lu1);
                let s = lu1 * cdf_single_inv(u * cdf_single(smax / lu1));
                (s.min(smax), [1.0; 3])
            }
            Model::Physical => {
                let st = self.sigma_t;
                let mass = st.map(|s| trunc_mass(s, d));
                if self.single {
                    let u = (j as f64 + xi) / k as f64;
                    return (trunc_exp_inv(u, st[0], mass[0], d), mass);
                }
                let u = (j as f64 + xi) / k as f64;
                let s = mixture_inv(u, st, mass, d);
                let pdf = [0, 1, 2].map(|c| trunc_exp_pdf(s, st[c], mass[c]));
                let q = (pdf[0] + pdf[1] + pdf[2]) / 3.0;
                let w = [0, 1, 2].map(|c| {
                    let r = mass[c] * pdf[c] / q;
                    if r.is_finite() {
                        r
                    } else {
                        0.0
                    }
                });
                (s, w)
            }
        }
    }

    /// One pair's contribution per channel (before the per-light mean and
    /// the model's scale): light sample `e` entering at `hit` (`ci =
    /// dot(Wi, Ni) > 0`), the channels weighted by `w`; 0 when the light is
    /// totally reflected there (a pair all the same).
    fn pair(&self, v: &View, e: &Arrival, hit: &Entry, ci: f64, w: [f64; 3]) -> [f64; 3] {
        let p = self.p;
        // The refracted cosine inside; none: the light is totally reflected.
        let cos_t2 = 1.0 - (1.0 - ci * ci) * self.inv_eta2;
        if cos_t2.is_nan() || cos_t2 <= 0.0 {
            return [0.0; 3];
        }
        let cos_ti = cos_t2.sqrt();
        let si = hit.dist * ci / cos_ti;
        // Seed: beyond the longest distance every channel's falloff is 0
        // (about half the pairs of a bake: light entering across the
        // object); the pair still counts in the mean.
        if p.model == Model::Seed && si >= self.lu1 {
            return [0.0; 3];
        }
        // (`fresnel(ci, eta)`, its refracted cosine `cos_ti` already
        // known: the same bits for `ci <= 1`.)
        let kti = if ci <= 1.0 {
            1.0 - fresnel_at(ci, cos_ti, p.eta)
        } else {
            1.0 - fresnel(ci, p.eta)
        };
        let cl = e.e.to_array();
        match p.model {
            Model::Seed => {
                let ph = hg_peak1(p.g, (-e.dir).dot(v.wpo));
                let common = ci * kti * v.kto * ph;
                // The smooth falloff at `si`: ssmulti's `falloff`, with
                // the distance's reciprocal multiplied in.
                let wf = |d: f64, inv: f64| {
                    if si > d || d <= 0.0 {
                        return 0.0;
                    }
                    let t = (si * inv).clamp(0.0, 1.0);
                    1.0 - t * t * (3.0 - 2.0 * t)
                };
                if !self.single {
                    [0, 1, 2].map(|c| cl[c] * common * wf(self.lu[c], self.inv_lu[c]))
                } else {
                    // One kernel: t_rgb with equal distances (no Rd), or
                    // Rd times the kernel at lu1.
                    let w1 = common * wf(self.lu1, self.inv_lu1);
                    let k = if p.rgb { [1.0; 3] } else { p.rd };
                    [0, 1, 2].map(|c| cl[c] * k[c] * w1)
                }
            }
            Model::Physical => {
                let Some(ti) = refract(-e.dir, hit.normal, 1.0 / p.eta) else {
                    return [0.0; 3];
                };
                let ph = hg(p.g, ti.dot(v.wpo));
                let common = kti * ph * ci / cos_ti;
                [0, 1, 2].map(|c| w[c] * cl[c] * common * (-self.sigma_t[c] * si).exp())
            }
        }
    }
}

/// The view side of a point: the direction back up the refracted view
/// ray, and the Fresnel transmittance out towards the eye.
struct View {
    wpo: DVec3,
    kto: f64,
}
