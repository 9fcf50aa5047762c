//! `facet` (Houdini's Facet SOP): normals `N` from a mesh.
//!
//! - Points with `sourceprim` (from `scatter`) take their face's normal
//!   (`flat`), or the face's corner normals interpolated at `sourceuv` and
//!   renormalised (`smooth`). Points without it are first put on the mesh
//!   by a closest-point query.
//! - A corner normal averages the normals of the faces around its vertex
//!   whose normal is within the cusp angle of the corner's own face
//!   (so edges sharper than the cusp stay sharp), weighted by the face's
//!   angle at the vertex (`angle`) or the face's area (`area`).
//! - On a mesh's own vertices (no point cloud given) every vertex gets the
//!   weighted average of all its faces (no cusp: a shared vertex has one
//!   normal).
//! - Vertices at the same position are welded first (`weld`): a mesh with
//!   UVs has its vertices split along the UV seams, and the copies would
//!   otherwise each average only the faces on their side of the seam.
//!   Edges meant to be hard stay hard through the cusp angle.
//!
//! Face normals are Newell's (exact for planar polygons). A normal that
//! comes out zero (a point on a degenerate face, a vertex whose faces
//! cancel) is left zero and counted in the report: `illum` refuses it.

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::error::{Error, Result};
use crate::geom::bvh::ClosestPoint;
use crate::geom::mesh::TriMesh;
use crate::geom::unit_or_zero;

/// Flat or smooth.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Mode {
    /// The face's normal.
    Flat,
    /// The corner normals interpolated (not across edges sharper than
    /// the cusp angle).
    Smooth,
}

/// How faces around a vertex are weighted.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Weight {
    /// By the face's angle at the vertex.
    Angle,
    /// By the face's area.
    Area,
}

/// Parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    pub mode: Mode,
    pub weight: Weight,
    /// Cusp angle in degrees: faces meeting at a sharper angle do not blend.
    pub cusp: f64,
    /// Vertices at the same position share their faces (UV seams).
    pub weld: bool,
}

/// What `facet` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// Points placed by a closest-point query (no `sourceprim`).
    pub projected: usize,
    /// Points whose normal came out zero.
    pub zero_normals: usize,
}

/// Per-corner weights: the polygon's interior angle at each corner, or the
/// face's area.
fn corner_weights(m: &TriMesh, weight: Weight) -> Vec<f64> {
    let mut w = vec![0.0; m.polys.indices.len()];
    let areas = m.tri_areas();
    for f in 0..m.face_count() {
        let r = m.polys.offsets[f]..m.polys.offsets[f + 1];
        let n = r.len();
        let fa: f64 = areas[m.face_tris[f] as usize..m.face_tris[f + 1] as usize]
            .iter()
            .sum();
        for (i, c) in r.clone().enumerate() {
            w[c] = match weight {
                Weight::Area => fa,
                Weight::Angle => {
                    let p = m.positions[m.polys.indices[c] as usize];
                    let a = m.positions[m.polys.indices[r.start + (i + n - 1) % n] as usize] - p;
                    let b = m.positions[m.polys.indices[r.start + (i + 1) % n] as usize] - p;
                    a.angle_between(b)
                }
            };
            if !w[c].is_finite() {
                w[c] = 0.0;
            }
        }
    }
    w
}

/// For every vertex, the vertex that stands for all those at its
/// position (the first in file order) when `weld`, else itself. Positions
/// are compared bit for bit (with -0 as 0): a seam's copies are written
/// from one value.
pub fn weld_ids(m: &TriMesh, weld: bool) -> Vec<u32> {
    if !weld {
        return (0..m.positions.len() as u32).collect();
    }
    let mut first: std::collections::HashMap<[u64; 3], u32> =
        std::collections::HashMap::with_capacity(m.positions.len());
    m.positions
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let key = (*p + DVec3::ZERO).to_array().map(f64::to_bits);
            *first.entry(key).or_insert(i as u32)
        })
        .collect()
}

/// For every (welded) vertex, the (face, corner) pairs around it.
fn vertex_corners(m: &TriMesh, weld: &[u32]) -> (Vec<usize>, Vec<(u32, u32)>) {
    let nv = m.positions.len();
    let mut count = vec![0usize; nv + 1];
    for &v in &m.polys.indices {
        count[weld[v as usize] as usize + 1] += 1;
    }
    for i in 0..nv {
        count[i + 1] += count[i];
    }
    let mut fill = count.clone();
    let mut out = vec![(0u32, 0u32); m.polys.indices.len()];
    for f in 0..m.face_count() {
        for c in m.polys.offsets[f]..m.polys.offsets[f + 1] {
            let v = weld[m.polys.indices[c] as usize] as usize;
            out[fill[v]] = (f as u32, c as u32);
            fill[v] += 1;
        }
    }
    (count, out)
}

/// Smooth normals at every corner of every face, split at the cusp angle,
/// vertices at one position welded when `weld`.
pub fn corner_normals(
    m: &TriMesh,
    face_n: &[DVec3],
    weight: Weight,
    cusp_deg: f64,
    weld: bool,
) -> Vec<DVec3> {
    let w = corner_weights(m, weight);
    let ids = weld_ids(m, weld);
    let (start, around) = vertex_corners(m, &ids);
    let cos_cusp = cusp_deg.to_radians().cos();
    (0..m.face_count())
        .into_par_iter()
        .flat_map_iter(|f| {
            let nf = face_n[f];
            let (w, start, around, ids) = (&w, &start, &around, &ids);
            (m.polys.offsets[f]..m.polys.offsets[f + 1]).map(move |c| {
                let v = ids[m.polys.indices[c] as usize] as usize;
                let mut n = DVec3::ZERO;
                for &(g, cg) in &around[start[v]..start[v + 1]] {
                    let ng = face_n[g as usize];
                    if g as usize == f || nf.dot(ng) >= cos_cusp {
                        n += ng * w[cg as usize];
                    }
                }
                let n = unit_or_zero(n);
                if n == DVec3::ZERO {
                    nf
                } else {
                    n
                }
            })
        })
        .collect()
}

/// Adds `N` to the points of `cloud` from `mesh`.
pub fn facet_points(cloud: &mut Cloud, mesh: &TriMesh, p: &Params) -> Result<Report> {
    if !(p.cusp.is_finite() && (0.0..=180.0).contains(&p.cusp)) {
        return Err(Error::param(
            "cusp",
            format!("{:?} is not an angle in [0, 180] degrees", p.cusp),
        ));
    }
    let pts = cloud.points();
    let pos = pts.vec3_f64("P")?;
    if mesh.tris.is_empty() && !pos.is_empty() {
        return Err(Error::invalid(
            "the mesh has no triangles to take normals from",
        ));
    }
    let face_n = mesh.face_normals();
    let corner_n = match p.mode {
        Mode::Smooth => corner_normals(mesh, &face_n, p.weight, p.cusp, p.weld),
        Mode::Flat => Vec::new(),
    };
    let source = if pts.has("sourceprim") {
        let prim = pts.scalar_f64("sourceprim")?;
        mesh.source_faces_at(&prim, &pos)?;
        let uv = match (p.mode, pts.has("sourceuv")) {
            (Mode::Smooth, true) => Some(pts.vec3_f64("sourceuv")?),
            (Mode::Smooth, false) => {
                return Err(pts.missing("sourceuv"));
            }
            (Mode::Flat, _) => None,
        };
        Some((prim, uv))
    } else {
        None
    };
    let closest = match source {
        None => {
            // The closest point of a non-finite position is no point.
            if let Some(i) = pos.iter().position(|p| !DVec3::from_array(*p).is_finite()) {
                return Err(Error::invalid(format!(
                    "point {i}: P is {:?}, not finite (and it has no sourceprim to place it)",
                    pos[i]
                )));
            }
            ClosestPoint::new(mesh)
        }
        Some(_) => None,
    };
    let normals: Vec<[f32; 3]> = (0..pos.len())
        .into_par_iter()
        .map(|i| {
            let p3 = DVec3::from_array(pos[i]);
            // The triangle and barycentric weights the point sits at.
            let (f, tri, w) = match (&source, &closest) {
                (Some((prim, uv)), _) => {
                    let f = prim[i] as usize;
                    match uv {
                        None => (f, None, [1.0, 0.0, 0.0]),
                        Some(uv) => {
                            let w = [1.0 - uv[i][0] - uv[i][1], uv[i][0], uv[i][1]];
                            (f, mesh.triangle_at(f, w, p3), w)
                        }
                    }
                }
                (None, Some(cp)) => {
                    let hit = cp.query(p3);
                    let f = mesh.face_tris.partition_point(|&s| s as usize <= hit.tri) - 1;
                    (f, Some(hit.tri), hit.bary)
                }
                (None, None) => (0, None, [1.0, 0.0, 0.0]),
            };
            let n = match (p.mode, tri) {
                (Mode::Smooth, Some(t)) => {
                    let k = mesh.tris[t];
                    let n = corner_n[k[0] as usize] * w[0]
                        + corner_n[k[1] as usize] * w[1]
                        + corner_n[k[2] as usize] * w[2];
                    let n = unit_or_zero(n);
                    if n == DVec3::ZERO {
                        face_n[f]
                    } else {
                        n
                    }
                }
                _ => face_n.get(f).copied().unwrap_or(DVec3::ZERO),
            };
            n.as_vec3().to_array()
        })
        .collect();
    let report = Report {
        projected: if source.is_none() { pos.len() } else { 0 },
        zero_normals: normals.iter().filter(|n| **n == [0.0; 3]).count(),
    };
    cloud.points_mut().set_vec3("N", Role::Normal, &normals)?;
    cloud.record(
        "facet_",
        vec![
            (
                "facet_mode",
                DetailValue::Str(format!("{:?}", p.mode).to_lowercase()),
            ),
            (
                "facet_weight",
                DetailValue::Str(format!("{:?}", p.weight).to_lowercase()),
            ),
            ("facet_cusp", DetailValue::F64(p.cusp)),
            ("facet_weld", DetailValue::I32(p.weld as i32)),
            ("facet_mesh_digest", DetailValue::Str(mesh.digest())),
        ],
    );
    Ok(report)
}

/// Adds `N` to a mesh's own vertices (weighted average of all their faces,
/// and of the faces of the vertices at the same position when `weld`).
pub fn facet_mesh(cloud: &mut Cloud, weight: Weight, weld: bool) -> Result<Report> {
    let m = TriMesh::from_cloud(cloud)?;
    let face_n = m.face_normals();
    let w = corner_weights(&m, weight);
    let ids = weld_ids(&m, weld);
    let mut acc = vec![DVec3::ZERO; m.positions.len()];
    for (f, nf) in face_n.iter().enumerate() {
        for c in m.polys.offsets[f]..m.polys.offsets[f + 1] {
            acc[ids[m.polys.indices[c] as usize] as usize] += *nf * w[c];
        }
    }
    let normals: Vec<[f32; 3]> = ids
        .iter()
        .map(|&v| unit_or_zero(acc[v as usize]).as_vec3().to_array())
        .collect();
    let report = Report {
        projected: 0,
        zero_normals: normals.iter().filter(|n| **n == [0.0; 3]).count(),
    };
    cloud.points_mut().set_vec3("N", Role::Normal, &normals)?;
    let weight = DetailValue::Str(format!("{weight:?}").to_lowercase());
    cloud.record(
        "facet_",
        vec![
            ("facet_weight", weight),
            ("facet_weld", DetailValue::I32(weld as i32)),
        ],
    );
    Ok(report)
}
