//! `illum` (Houdini's `pcIllum`, an `illuminance()` loop): the light
//! arriving at every point,
//! `illum = sum over lights in the mask of Cl * max(0, dot(N, L)) * visibility`,
//! as the colour attribute `illum` (f32), and beside it `illum_cos`, the
//! mean cosine of the light's arrival with `N` weighted by the irradiance
//! each arrival brings (the sum of its channels; 1 where no light
//! arrives): the physical model of `ssmulti` reflects oblique light more
//! than light along the normal (`docs/DESIGN.md#incidence`).
//!
//! - Visibility: an any-hit shadow ray against the mesh (`crate::bvh`),
//!   from the point moved off its surface by a few ulps along `N`, up to
//!   the light (or to infinity for a distant light). A light sample that
//!   the normal faces away from, or that falls outside a spot's cone,
//!   brings nothing and casts no ray. Without a mesh every ray is clear.
//! - `N` is normalised here; a zero-length or non-finite `N` or `P` is an
//!   error naming the point (facet leaves zero normals on degenerate
//!   faces).
//! - Area lights take `samples` points each, on a rank-1 lattice shifted by
//!   a random offset per point and light (`Pcg32`, from the seed, the
//!   light's place in the file and the point's index): the same output
//!   bits for any thread count and any light mask.
//! - Shadow terminator: with smooth normals a point just on the lit side
//!   of its smooth normal but behind its flat facet sees the facet's own
//!   mesh in the way, as a ray tracer would; its `dot(N, L)` is near zero
//!   there, so the light it loses is small.
//!
//! Positions may be f64: light directions and distances are computed in
//! f64, rays in the mesh's unit frame (see `crate::bvh`).

use crate::maths::uniform24;
use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::error::{Error, Result};
use crate::geom::bvh::Occluder;
use crate::geom::columns::{self, Columns};
use crate::geom::mesh::TriMesh;
use crate::lights::{Arrival, Light, Shape};
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
type Chunk = (Vec<(DVec3, f64)>, u64, u64, usize);

/// Adds `illum` to `cloud` from `lights` (already masked), with shadows
/// from `occluder` when given.
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

pub fn illum(
    cloud: &mut Cloud,
    lights: &[Light],
    occluder: Option<&Occluder>,
    seed: u64,
    progress: &Progress,
) -> Result<Report> {
    let pts = cloud.points();
    if !pts.has("N") {
        return Err(pts.missing("N"));
    }
    let pos = pts.vec3_f64("P")?;
    let nrm = pts.vec3_f64("N")?;
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
                let mut e = DVec3::ZERO;
                // The arrivals' irradiance summed over channels, and with
                // their cosines.
                let (mut w, mut wc) = (0.0f64, 0.0f64);
                for (light, cols) in lights.iter().zip(&columns) {
                    if light.cl == DVec3::ZERO {
                        continue;
                    }
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
                        if let Some(occ) = occluder {
                            rays += 1;
                            let blocked_here = match cols {
                                Some(c) => c.occluded(occ, p, n, a.dir, a.dist),
                                None => occ.occluded(p, n, a.dir, a.dist),
                            };
                            if blocked_here {
                                blocked += 1;
                                continue;
                            }
                        }
                        e += a.e;
                        let s = a.e.element_sum();
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
                out.push((e, cos));
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
    let mut cosines: Vec<f32> = Vec::with_capacity(pos.len());
    for (out, rays, blocked, dark) in chunks {
        for (e, cos) in out {
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
            cosines.push(cos as f32);
        }
        report.rays += rays;
        report.blocked += blocked;
        report.dark += dark;
    }
    cloud.points_mut().set_vec3("illum", Role::Color, &illum)?;
    cloud.points_mut().set_scalar("illum_cos", cosines)?;
    // What the run was: the lights (their names, and all they are), the
    // mesh that shadowed them, the area lights' seed.
    let names: Vec<&str> = lights.iter().map(|l| l.name.as_str()).collect();
    let shadows = occluder.map_or("none".to_string(), |o| o.mesh_digest.clone());
    cloud.record(
        "illum_",
        vec![
            ("illum_lights", DetailValue::Str(names.join(","))),
            (
                "illum_lights_digest",
                DetailValue::Str(crate::lights::digest(lights)),
            ),
            ("illum_shadows", DetailValue::Str(shadows)),
            ("illum_seed", DetailValue::Str(seed.to_string())),
        ],
    );
    Ok(report)
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
