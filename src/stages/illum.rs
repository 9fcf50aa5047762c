//! `illum` (Houdini's `pcIllum`, an `illuminance()` loop): the light
//! arriving at every point,
//! `illum = sum over lights in the mask of Cl * max(0, dot(N, L)) * visibility`,
//! as the colour attribute `illum` (f32), and beside it `illum_cos`, the
//! mean cosine of the light's arrival with `N` weighted by the irradiance
//! each arrival brings (the sum of its channels; 1 where no light
//! arrives): the physical model of `ssmulti` reflects oblique light more
//! than light along the normal (`docs/DESIGN.md#incidence`).
//!
//! - Visibility: a shadow ray against the mesh ([`crate::lights::shadow`],
//!   the rules sssingle's share: off the point's own triangle, the
//!   terminator, a medium's passage), up to the light (or to infinity for
//!   a distant light). A light sample that the normal faces away from, or
//!   that falls outside a spot's cone, brings nothing and casts no ray.
//!   Without a mesh every ray is clear.
//! - `N` is normalised here; a zero-length or non-finite `N` or `P` is an
//!   error naming the point (facet leaves zero normals on degenerate
//!   faces).
//! - Area lights take `samples` points each, on a rank-1 lattice shifted by
//!   a random offset per point and light (`Pcg32`, from the seed, the
//!   light's place in the file and the point's index): the same output
//!   bits for any thread count and any light mask.
//! - Shadow terminator: with smooth normals a point on the lit side of its
//!   smooth normal but behind its flat facet is lit as the smooth surface
//!   would be, unless its ray crosses the solid beyond the facets around
//!   its own (`lights::shadow`).
//!
//! Positions may be f64: light directions and distances are computed in
//! f64, rays in the mesh's unit frame (see `crate::bvh`).

use crate::maths::uniform24;
use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::error::{Error, Result};
use crate::geom::bvh::{Facing, Occluder};
use crate::geom::columns::{self, Columns};
use crate::geom::mesh::TriMesh;
use crate::lights::{Arrival, Light, Shape};
use crate::medium::Medium;
use crate::progress::Progress;

/// What `illum` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub points: usize,
    /// Shadow rays cast.
    pub rays: u64,
    /// Of them, blocked.
    pub blocked: u64,
    /// Points that no light reaches (all facing away or in shadow).
    pub dark: usize,
}

/// Points per unit of parallel work (and of progress).
const CHUNK: usize = 4096;

/// A chunk's irradiance and mean cosine a point, its rays, blocked rays
/// and unlit points.
type Chunk = (Vec<(DVec3, DVec3, f64)>, u64, u64, usize);

/// Bytes a mesh's triangle takes at illum's peak (its BVH and the build's
/// work, the mesh itself, a distant light's grid), with a margin: peaks
/// measured on the Stanford dragon and a mesh of 1e7 triangles
/// (benches/results/HISTORY.md, "Memory a triangle").
pub const MESH_BYTES: u64 = 500;

/// The shadow-ray BVH over `mesh`, after checking that the machine holds
/// it ([`MESH_BYTES`] a triangle).
pub fn occluder(mesh: &TriMesh) -> Result<Occluder> {
    crate::memory::check_mesh(mesh.tris.len(), MESH_BYTES)?;
    Ok(Occluder::new(mesh))
}

/// Shadows of a medium (the light a shadow ray carries through the
/// mesh's inside): the shadow rays' own type.
pub use crate::lights::shadow::{Passage, Point, Shadows};

/// Adds `illum` to `cloud` from `lights` (already masked), with the
/// shadows of `shadows`' mesh (and the light through its medium) when
/// given.
pub fn illum(
    cloud: &mut Cloud,
    lights: &[Light],
    shadows: Option<&Shadows>,
    seed: u64,
    progress: &Progress,
) -> Result<Report> {
    let occluder = shadows.map(|s| s.occluder());
    let pts = cloud.points();
    if !pts.has("N") {
        return Err(pts.missing("N"));
    }
    let pos = pts.vec3_f64("P")?;
    let nrm = pts.vec3_f64("N")?;
    // The faces points were scattered on: where a shadow ray that needs
    // its point's triangle looks first.
    let faces = match (shadows, pts.has("sourceprim")) {
        (Some(_), true) => Some(pts.scalar_f64("sourceprim")?),
        _ => None,
    };
    for i in 0..pos.len() {
        if !DVec3::from_array(pos[i]).is_finite() {
            return Err(Error::invalid(format!(
                "point {i} has a non-finite position P {:?}",
                pos[i]
            )));
        }
        let n = DVec3::from_array(nrm[i]);
        if !n.is_finite() || n.normalize_or_zero() == DVec3::ZERO {
            return Err(Error::invalid(format!(
                "point {i} has normal N {:?}, which has no direction (facet gives zero normals to points on degenerate faces)",
                nrm[i]
            )));
        }
    }
    // A distant light's shadow rays are parallel: a grid down its
    // direction answers them as the BVH would, faster, when there are
    // enough of them to repay its building (geom::columns).
    let columns: Vec<Option<Columns>> = lights
        .par_iter()
        .map(|l| match (occluder, &l.shape) {
            (Some(occ), Shape::Distant { to_light })
                if columns::worth_it(occ, pos.len() as u64, columns::SHADOW_RAYS_PER_TRIANGLE) =>
            {
                Columns::new(occ, *to_light)
            }
            _ => None,
        })
        .collect();
    progress.start("shading", pos.len() as u64);
    let chunks: Vec<Chunk> = pos
        .par_chunks(CHUNK)
        .zip(nrm.par_chunks(CHUNK))
        .enumerate()
        .map(|(c, (pc, nc))| {
            let mut out = Vec::with_capacity(pc.len());
            let (mut rays, mut blocked, mut dark) = (0u64, 0u64, 0usize);
            let mut arrivals: Vec<Arrival> = Vec::new();
            for (k, (p, n)) in pc.iter().zip(nc).enumerate() {
                let i = c * CHUNK + k;
                let p = DVec3::from_array(*p);
                let n = DVec3::from_array(*n).normalize();
                let mut at = Point::new(p, n);
                if let Some(f) = faces.as_ref().and_then(|f| f.get(i)) {
                    if *f >= 0.0 && *f < u32::MAX as f64 {
                        at = at.on_face(*f as usize);
                    }
                }
                let mut e = DVec3::ZERO;
                // What a constant dome brings: spread over the hemisphere
                // (diffuse incidence), not one direction.
                let mut spread = DVec3::ZERO;
                // The other arrivals' irradiance summed over channels, and
                // with their cosines.
                let (mut w, mut wc) = (0.0f64, 0.0f64);
                for (light, cols) in lights.iter().zip(&columns) {
                    if light.cl == DVec3::ZERO {
                        continue;
                    }
                    let diffuse = matches!(&light.shape, Shape::Dome(d) if d.map.is_none());
                    let (r1, r2) = if light.samples > 1 {
                        // A stream per point and light: which other
                        // lights the mask keeps changes nothing.
                        let key = (light.id as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
                        let mut rng = Pcg32::new(seed ^ key, i as u64);
                        (uniform24(&mut rng), uniform24(&mut rng))
                    } else {
                        (0.5, 0.5)
                    };
                    light.arrivals(p, n, r1, r2, &mut arrivals);
                    for a in &arrivals {
                        if a.e == DVec3::ZERO {
                            continue;
                        }
                        // What of it gets here: all, none, or (a medium's
                        // shadow) what crosses the medium.
                        let mut got = a.e;
                        if let Some(sh) = shadows {
                            rays += 1;
                            let reach = sh.from_point(cols.as_ref(), &mut at, a.dir, a.dist);
                            blocked += reach.blocked as u64;
                            got *= reach.through;
                        }
                        if got == DVec3::ZERO {
                            continue;
                        }
                        e += got;
                        if diffuse {
                            spread += got;
                            continue;
                        }
                        let s = got.element_sum();
                        w += s;
                        wc += s * n.dot(a.dir).clamp(0.0, 1.0);
                    }
                }
                if e == DVec3::ZERO {
                    dark += 1;
                }
                let cos = if w > 0.0 {
                    (wc / w).clamp(0.0, 1.0)
                } else {
                    1.0
                };
                out.push((e, spread, cos));
            }
            progress.inc(pc.len() as u64);
            (out, rays, blocked, dark)
        })
        .collect();
    progress.finish();
    let mut report = Report {
        points: pos.len(),
        ..Report::default()
    };
    let mut illum: Vec<[f32; 3]> = Vec::with_capacity(pos.len());
    let mut spread: Vec<[f32; 3]> = Vec::with_capacity(pos.len());
    let mut cosines: Vec<f32> = Vec::with_capacity(pos.len());
    for (out, rays, blocked, dark) in chunks {
        for (e, d, cos) in out {
            // Never a value beyond a float attribute: too much light is
            // refused, with the point.
            if !(e.is_finite() && e.abs().max_element() <= f32::MAX as f64) {
                return Err(Error::invalid(format!(
                    "point {}: illum would be {:e}, {:e}, {:e}, beyond the range of a float attribute (are the lights' intensities right?)",
                    illum.len(),
                    e.x,
                    e.y,
                    e.z
                )));
            }
            illum.push(e.as_vec3().to_array());
            spread.push(d.as_vec3().to_array().map(|x| x.min(f32::MAX)));
            cosines.push(cos as f32);
        }
        report.rays += rays;
        report.blocked += blocked;
        report.dark += dark;
    }
    let points = points_digest(cloud)?;
    cloud.points_mut().set_vec3("illum", Role::Color, &illum)?;
    cloud.points_mut().set_scalar("illum_cos", cosines)?;
    // The part of illum that arrived spread over the hemisphere, where a
    // light sends such (`docs/DESIGN.md#incidence`).
    let domes = lights
        .iter()
        .any(|l| matches!(&l.shape, Shape::Dome(d) if d.map.is_none()));
    if domes {
        cloud
            .points_mut()
            .set_vec3("illum_diffuse", Role::Color, &spread)?;
    } else {
        cloud.points_mut().remove("illum_diffuse");
    }
    // An earlier run's light between surfaces is not in this illum
    // (`indirect` adds it again).
    cloud.points_mut().remove("illum_indirect");
    // What the run was: the lights (their names, and all they are), the
    // mesh that shadowed them, the area lights' seed.
    let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
    let shadow_mesh = occluder.map_or("none".to_string(), |o| o.mesh_digest.clone());
    let mut details = vec![
        ("illum_lights", DetailValue::Str(names.join(","))),
        (
            "illum_lights_digest",
            DetailValue::Str(crate::lights::digest(lights)),
        ),
        ("illum_shadows", DetailValue::Str(shadow_mesh)),
        ("illum_seed", DetailValue::Str(seed.to_string())),
        ("illum_points", DetailValue::Str(points)),
    ];
    // A medium's shadows let light through: what it was.
    if let Some(m) = shadows.and_then(|s| s.medium()) {
        details.push(("illum_mfp", DetailValue::V3D((1.0 / m.sigma_t).to_array())));
        details.push(("illum_eta", DetailValue::F64(m.eta)));
    }
    cloud.record("illum_", details);
    Ok(report)
}

/// The fingerprint of what a point's light depends on in the cloud:
/// XXH3-128 of its `P`, `N` and `sourceprim` (the face a shadow ray looks
/// in first), in 32 hex digits.
fn points_digest(cloud: &Cloud) -> Result<String> {
    let pts = cloud.points();
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    for name in ["P", "N"] {
        for v in pts.vec3_f64(name)? {
            v.iter().for_each(|x| h.update(&x.to_le_bytes()));
        }
    }
    if pts.has("sourceprim") {
        for x in pts.scalar_f64("sourceprim")? {
            h.update(&x.to_le_bytes());
        }
    }
    Ok(format!("{:032x}", h.digest128()))
}

/// Whether `cloud` already holds the direct light [`illum`] would give it
/// from `lights` with `shadows` and `seed` (its record says so: the same
/// lights, shadow mesh, medium, seed and points, and no light between
/// surfaces added since), so that `illum --indirect` on a cloud `ssmulti`
/// passed through (the light between surfaces' second run) need not cast
/// its shadow rays again: the values are the same bits.
pub fn holds_direct(
    cloud: &Cloud,
    lights: &[Light],
    shadows: Option<&Shadows>,
    seed: u64,
) -> Result<bool> {
    let pts = cloud.points();
    if !(pts.has("illum") && pts.has("illum_cos")) || pts.has("illum_indirect") {
        return Ok(false);
    }
    let domes = lights
        .iter()
        .any(|l| matches!(&l.shape, Shape::Dome(d) if d.map.is_none()));
    if domes != pts.has("illum_diffuse") {
        return Ok(false);
    }
    let is = |name: &str, want: &str| matches!(cloud.detail(name), Some(DetailValue::Str(s)) if s == want);
    let shadow_mesh = shadows.map_or("none".to_string(), |s| s.occluder().mesh_digest.clone());
    if !(is("illum_lights_digest", &crate::lights::digest(lights))
        && is("illum_shadows", &shadow_mesh)
        && is("illum_seed", &seed.to_string()))
    {
        return Ok(false);
    }
    let medium = shadows.and_then(|s| s.medium());
    let same_medium = match (medium, cloud.detail("illum_mfp"), cloud.detail("illum_eta")) {
        (None, None, None) => true,
        (Some(m), Some(DetailValue::V3D(mfp)), Some(DetailValue::F64(eta))) => {
            *mfp == (1.0 / m.sigma_t).to_array() && *eta == m.eta
        }
        _ => false,
    };
    Ok(same_medium && is("illum_points", &points_digest(cloud)?))
}

/// Whether `cloud` holds the [`thickness`] `mesh` gives it (its record
/// names the mesh, which `illum` clears when it runs again).
pub fn holds_thickness(cloud: &Cloud, mesh: &TriMesh) -> bool {
    cloud.points().has("thickness")
        && matches!(cloud.detail("illum_thickness"), Some(DetailValue::Str(s)) if *s == mesh.digest())
}

/// Adds `thickness` to `cloud`: how far the mesh goes on behind each point
/// along `-N`, from the surface the point lies on to where the ray leaves
/// the mesh ([`f32::MAX`] where it never does: an open mesh). The
/// physical model of `ssmulti` returns less light from thin parts
/// (`docs/DESIGN.md#thickness`). Returns the points whose ray never left.
pub fn thickness(cloud: &mut Cloud, mesh: &TriMesh, progress: &Progress) -> Result<usize> {
    let pts = cloud.points();
    if !pts.has("N") {
        return Err(pts.missing("N"));
    }
    let pos = pts.vec3_f64("P")?;
    let nrm = pts.vec3_f64("N")?;
    crate::memory::check_mesh(mesh.tris.len(), MESH_BYTES)?;
    let interior = crate::stages::sssingle::interior::Interior::new(mesh, 180.0);
    progress.start("thickness", pos.len() as u64);
    let out: Vec<f32> = pos
        .par_chunks(CHUNK)
        .zip(nrm.par_chunks(CHUNK))
        .flat_map_iter(|(pc, nc)| {
            let v: Vec<f32> = pc
                .iter()
                .zip(nc)
                .map(|(p, n)| {
                    let n = DVec3::from_array(*n).normalize_or_zero();
                    let p = DVec3::from_array(*p);
                    if n == DVec3::ZERO || !p.is_finite() {
                        return f32::MAX;
                    }
                    let (_, d) = interior.view(p, -n);
                    if d.is_finite() {
                        (d as f32).min(f32::MAX)
                    } else {
                        f32::MAX
                    }
                })
                .collect();
            progress.inc(pc.len() as u64);
            v
        })
        .collect();
    progress.finish();
    let open = out.iter().filter(|&&d| d == f32::MAX).count();
    cloud.points_mut().set_scalar("thickness", out)?;
    cloud.record(
        "illum_thickness",
        vec![("illum_thickness", DetailValue::Str(mesh.digest()))],
    );
    Ok(open)
}

/// `--indirect` gathers the light of the medium ssmulti ran with: a
/// different one given to illum is an error naming both.
fn same_medium(cloud: &Cloud, m: &Medium) -> Result<()> {
    let recorded = crate::stages::ssmulti::Record::of(cloud).medium;
    match recorded.and_then(|r| r.mismatch(m)) {
        None => Ok(()),
        Some(what) => Err(Error::param(
            "indirect",
            format!(
                "the cloud's ssM was made with another medium: {what} given (give illum the medium ssmulti ran with)"
            ),
        )),
    }
}

/// What [`indirect`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct IndirectReport {
    /// Rays cast (`rays` a point).
    pub rays: u64,
    /// Of them, those that met the surface from outside (the others left
    /// the scene, or met a face from behind).
    pub hits: u64,
}

/// The key of the indirect rays' random streams (apart from the area
/// lights').
const INDIRECT_KEY: u64 = 0xD1B5_4A32_D192_ED03;

/// Adds to `illum` the light the rest of the surface sends each point
/// (one bounce of light between surfaces), gathered by `rays`
/// cosine-weighted rays a point about its `N` against `mesh` (`occluder`
/// its BVH). A ray that meets the mesh from outside brings the radiance
/// `M / pi` of the cloud point nearest where it meets it, its exitance
/// `M = ssM + rs(illum_cos) illum`: the physical model's last `ssM` (run
/// with `medium`, which the cloud's record must agree with) and the single
/// scattering of its direct light, taken as leaving evenly. A ray that
/// leaves the scene, meets a face from behind, or starts below the plane
/// of the mesh's triangle under the point (smooth normals tilt the
/// hemisphere into the facets beside it, as a path tracer's shading
/// normals do) brings nothing. With cosine-weighted rays the irradiance is
/// `pi` times the mean radiance: the mean `M` met. `illum_indirect` holds
/// the indirect part, which `illum_diffuse` (light spread over the
/// hemisphere) takes too; `illum_cos` stays the direct light's (`docs/DESIGN.md#light-between-surfaces`). The rays a point takes
/// are a rank-1 lattice shifted by a random offset from `seed` and the
/// point's index: the same bits for any thread count.
pub fn indirect(
    cloud: &mut Cloud,
    occluder: &Occluder,
    mesh: &TriMesh,
    medium: &Medium,
    rays: u32,
    seed: u64,
    progress: &Progress,
) -> Result<IndirectReport> {
    indirect_from(
        cloud, None, false, occluder, mesh, medium, rays, seed, progress,
    )
}

/// Checks that `cloud` holds an exitance `--indirect` can gather: the
/// `ssM` of ssmulti's physical model. An error says what it lacks (the
/// caller names the file).
pub fn check_exitance(cloud: &Cloud) -> Result<()> {
    let pts = cloud.points();
    if !pts.has("ssM") {
        return Err(pts.missing("ssM"));
    }
    if physical_ssm(cloud) {
        Ok(())
    } else {
        Err(Error::invalid(
            "its ssM is not the physical model's exitance (no ssmulti_radiance record): run ssmulti --model physical on it",
        ))
    }
}

/// Whether `cloud`'s record says its `ssM` is the physical model's
/// exitance.
fn physical_ssm(cloud: &Cloud) -> bool {
    matches!(
        cloud.detail("ssmulti_radiance"),
        Some(DetailValue::Str(s)) if s == crate::stages::ssmulti::RADIANCE
    )
}

/// [`indirect`], the exitance taken from `from`'s points when given (a
/// coarser cloud on the same mesh, lit by the same lights: its `ssM`,
/// `illum` and `illum_cos`), rather than from `cloud`'s own, which then
/// needs no `ssM`. The light between surfaces is smooth and each point
/// averages it over its rays, so a cloud of a quarter of the points
/// gives it at a quarter of the first ssmulti pass's cost
/// (`docs/DESIGN.md#light-between-surfaces`).
///
/// With `at_exitance` (and `from`), the rays are cast at `from`'s points
/// and the light they gather is carried to `cloud`'s by [`carry`]: the
/// rays of `from`'s points alone, and each point's light the average of
/// several points' rays (`docs/DESIGN.md#light-between-surfaces`).
#[allow(clippy::too_many_arguments)]
pub fn indirect_from(
    cloud: &mut Cloud,
    from: Option<&Cloud>,
    at_exitance: bool,
    occluder: &Occluder,
    mesh: &TriMesh,
    medium: &Medium,
    rays: u32,
    seed: u64,
    progress: &Progress,
) -> Result<IndirectReport> {
    let source = from.unwrap_or(cloud);
    let spts = source.points();
    if !spts.has("ssM") {
        return Err(spts.missing("ssM"));
    }
    if !physical_ssm(source) {
        return Err(Error::param(
            "indirect",
            "needs the ssM of ssmulti's physical model (an exitance; the cloud does not record ssmulti_radiance)",
        ));
    }
    if rays == 0 {
        return Err(Error::param("indirect", "0 rays a point gather nothing"));
    }
    same_medium(source, medium)?;
    if let Some(f) = from {
        let lit = |c: &Cloud| match c.detail("illum_lights_digest") {
            Some(DetailValue::Str(s)) => Some(s.clone()),
            _ => None,
        };
        if lit(f) != lit(cloud) {
            return Err(Error::param(
                "indirect",
                "the exitance cloud was lit by other lights than this cloud (illum_lights_digest differs)",
            ));
        }
    }
    // What the record says the light came from.
    let at_exitance = at_exitance && from.is_some();
    let from_what = match from {
        None => format!("{rays} rays, from ssM"),
        Some(f) => format!(
            "{rays} rays{}, from the ssM of another cloud of {} points (illum_points {}){}",
            if at_exitance { " at each point" } else { "" },
            f.len(),
            match f.detail("illum_points") {
                Some(DetailValue::Str(s)) => s.as_str(),
                _ => "not recorded",
            },
            if at_exitance {
                format!(", carried to these by their nearest {CARRY_NEAR} facing the same way")
            } else {
                String::new()
            }
        ),
    };
    let spos = spts.vec3_f64("P")?;
    let ssm = spts.vec3_f64("ssM")?;
    let sdirect = spts.vec3_f64("illum")?;
    let direct_cos = spts.scalar_f64("illum_cos")?;
    let pts = cloud.points();
    let pos = pts.vec3_f64("P")?;
    let nrm = pts.vec3_f64("N")?;
    let direct = pts.vec3_f64("illum")?;
    if let Some(i) = ssm
        .iter()
        .position(|c| !c.iter().all(|v| v.is_finite() && *v >= 0.0))
    {
        return Err(Error::invalid(format!(
            "point {i} has ssM {:?}: an exitance is finite and not negative",
            ssm[i]
        )));
    }
    // What each point sends: its multiple scattering, and the single
    // scattering of its direct light, taken as leaving evenly (sssingle's
    // ssS is for the camera's eye alone).
    let single = medium.single_by_cosine();
    let exitance: Vec<DVec3> = (0..spos.len())
        .into_par_iter()
        .map(|i| {
            let rs = DVec3::from_array(single.factor(direct_cos[i]));
            DVec3::from_array(ssm[i]) + rs * DVec3::from_array(sdirect[i])
        })
        .collect();
    let origin = spos.first().map_or(DVec3::ZERO, |p| DVec3::from_array(*p));
    let tree =
        crate::geom::kdtree::PointTree::new(spos.iter().map(|p| DVec3::from_array(*p)), origin);
    let gathered = |at: &[[f64; 3]], at_n: &[[f64; 3]]| {
        gather(
            at, at_n, occluder, mesh, &exitance, &tree, rays, seed, progress,
        )
    };
    let (light, hits) = if at_exitance {
        let snrm = spts.vec3_f64("N")?;
        let (light, hits) = gathered(&spos, &snrm);
        (carry(&tree, &snrm, &light, &pos, &nrm), hits)
    } else {
        gathered(&pos, &nrm)
    };
    let report = IndirectReport {
        rays: if at_exitance { spos.len() } else { pos.len() } as u64 * rays as u64,
        hits,
    };
    // The light arrives from the whole hemisphere: spread, as a constant
    // dome's (`docs/DESIGN.md#incidence`).
    let spread_before = if pts.has("illum_diffuse") {
        pts.vec3_f64("illum_diffuse")?
    } else {
        vec![[0.0; 3]; pos.len()]
    };
    let mut illum: Vec<[f32; 3]> = Vec::with_capacity(pos.len());
    let mut extra: Vec<[f32; 3]> = Vec::with_capacity(pos.len());
    let mut spread: Vec<[f32; 3]> = Vec::with_capacity(pos.len());
    for (i, e) in light.into_iter().enumerate() {
        let all = DVec3::from_array(direct[i]) + e;
        if !(all.is_finite() && all.max_element() <= f32::MAX as f64) {
            return Err(Error::invalid(format!(
                "point {i}: illum with the indirect light would be {:e}, {:e}, {:e}, beyond the range of a float attribute",
                all.x, all.y, all.z
            )));
        }
        illum.push(all.as_vec3().to_array());
        extra.push(e.as_vec3().to_array());
        let d = DVec3::from_array(spread_before[i]) + e;
        spread.push(d.as_vec3().to_array().map(|x| x.min(f32::MAX)));
    }
    cloud.points_mut().set_vec3("illum", Role::Color, &illum)?;
    cloud
        .points_mut()
        .set_vec3("illum_indirect", Role::Color, &extra)?;
    cloud
        .points_mut()
        .set_vec3("illum_diffuse", Role::Color, &spread)?;
    cloud.record(
        "illum_indirect",
        vec![
            ("illum_indirect_rays", DetailValue::Str(from_what)),
            ("illum_indirect_seed", DetailValue::Str(seed.to_string())),
        ],
    );
    Ok(report)
}

/// Each point's light carried from the points it was gathered at (see
/// [`carry`]): its nearest this many of them.
pub const CARRY_NEAR: usize = 8;
/// ... and where none of those faces its side, the wider ask.
const CARRY_MORE: usize = 64;

/// The light gathered by `rays` cosine-weighted rays at each of the
/// points `pos` (normals `nrm`), each ray bringing the `exitance` of the
/// point of `tree` nearest where it meets the mesh from outside (see
/// [`indirect`]); and the rays that met it.
#[allow(clippy::too_many_arguments)]
fn gather(
    pos: &[[f64; 3]],
    nrm: &[[f64; 3]],
    occluder: &Occluder,
    mesh: &TriMesh,
    exitance: &[DVec3],
    tree: &crate::geom::kdtree::PointTree,
    rays: u32,
    seed: u64,
    progress: &Progress,
) -> (Vec<DVec3>, u64) {
    progress.start("indirect", pos.len() as u64);
    let chunks: Vec<(Vec<DVec3>, u64)> = pos
        .par_chunks(CHUNK)
        .zip(nrm.par_chunks(CHUNK))
        .enumerate()
        .map(|(c, (pc, nc))| {
            let mut out = Vec::with_capacity(pc.len());
            let mut hits = 0u64;
            for (k, (p, n)) in pc.iter().zip(nc).enumerate() {
                let i = c * CHUNK + k;
                let p = DVec3::from_array(*p);
                let n = DVec3::from_array(*n).normalize();
                let (u, v) = n.any_orthonormal_pair();
                // The plane of the triangle under the point.
                let flat = occluder
                    .closest_point(mesh, p)
                    .map(|(t, _, _)| {
                        let [a, b, c] = mesh.tri(t);
                        (b - a).cross(c - a).normalize_or_zero()
                    })
                    .filter(|g| *g != DVec3::ZERO)
                    .unwrap_or(n);
                let mut rng = Pcg32::new(seed ^ INDIRECT_KEY, i as u64);
                let (r1, r2) = (uniform24(&mut rng), uniform24(&mut rng));
                let mut e = DVec3::ZERO;
                for k in 0..rays {
                    let (a, b) = crate::lights::lattice(k, rays, r1, r2);
                    // Cosine-weighted: the disc's point lifted to the
                    // hemisphere.
                    let (s, phi) = (a.sqrt(), std::f64::consts::TAU * b);
                    let cos = (1.0 - a).max(0.0).sqrt();
                    let dir = (u * (s * phi.cos()) + v * (s * phi.sin()) + n * cos).normalize();
                    if dir.dot(flat) <= 0.0 {
                        continue;
                    }
                    // (Off the plane it leaves: lights::shadow's origin.)
                    let mut ray = occluder.shadow_ray(p, flat, dir, f64::INFINITY);
                    let Some(j) = occluder.nearest_ray(&mut ray, Facing::Any) else {
                        continue;
                    };
                    if occluder.leaf_normal(j).dot(dir) >= 0.0 {
                        continue;
                    }
                    let hit = p + dir * occluder.mesh_dist(ray.tmax);
                    let l = exitance[tree.nearest_one(hit).item as usize];
                    hits += 1;
                    e += l;
                }
                out.push(e / rays as f64);
            }
            progress.inc(pc.len() as u64);
            (out, hits)
        })
        .collect();
    progress.finish();
    let mut light = Vec::with_capacity(pos.len());
    let mut hits = 0;
    for (out, h) in chunks {
        light.extend(out);
        hits += h;
    }
    (light, hits)
}

/// The light `light` gathered at the points of `tree` (normals `at_n`)
/// carried to the points `pos` (normals `nrm`): each takes the mean of its
/// [`CARRY_NEAR`] nearest that face its side (`N . N' > 0`), weighed by a
/// Gaussian of their distance (half the farthest's) and `(N . N')^4`, so
/// light does not cross a thin part or a crease; one with none of them
/// facing its side takes the nearest that does among [`CARRY_MORE`], or
/// nothing.
fn carry(
    tree: &crate::geom::kdtree::PointTree,
    at_n: &[[f64; 3]],
    light: &[DVec3],
    pos: &[[f64; 3]],
    nrm: &[[f64; 3]],
) -> Vec<DVec3> {
    let unit = |v: [f64; 3]| DVec3::from_array(v).normalize_or_zero();
    pos.par_iter()
        .zip(nrm.par_iter())
        .map(|(p, n)| {
            let (p, n) = (DVec3::from_array(*p), unit(*n));
            let near = tree.nearest(p, CARRY_NEAR);
            let h2 = near
                .last()
                .map_or(0.0, |q| q.distance)
                .max(f64::MIN_POSITIVE);
            let (mut sum, mut wsum) = (DVec3::ZERO, 0.0);
            for q in &near {
                let j = q.item as usize;
                let c = n.dot(unit(at_n[j]));
                if c > 0.0 {
                    let w = (-2.0 * q.distance / h2).exp() * c.powi(4);
                    sum += light[j] * w;
                    wsum += w;
                }
            }
            if wsum > 0.0 {
                return sum / wsum;
            }
            tree.nearest(p, CARRY_MORE)
                .iter()
                .map(|q| q.item as usize)
                .find(|&j| n.dot(unit(at_n[j])) > 0.0)
                .map_or(DVec3::ZERO, |j| light[j])
        })
        .collect()
}
