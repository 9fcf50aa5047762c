//! `follow`: a cloud scattered on a rest mesh moved onto another frame of
//! the same mesh (same vertices, same faces), so that the points of an
//! animation are the same points on every frame: no popping.
//!
//! A point lies at `sourceuv` of a triangle of its face `sourceprim` (the
//! rest mesh's triangulation; for a polygon, the triangle `facet` would
//! pick: the one whose point at `sourceuv` is nearest `P`). On the frame
//! it goes to the same barycentric point of the same corners, so it lies
//! on the frame's surface to rounding, whatever the frame's own
//! triangulation would be. `ptarea` is scaled by the triangle's area on
//! the frame over its area at rest (a stretched surface carries more
//! area a point), `Tarea` becomes the frame's area, and `N`, when the
//! cloud has it, is taken again from the frame as `facet` recorded it.
//! Every other attribute passes through.

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::column::ScalarType;
use crate::error::{Error, Result};
use crate::geom::mesh::TriMesh;
use crate::geom::{self, tri_area};
use crate::stages::facet;

/// What `follow` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub points: usize,
    /// Whether `N` was taken again from the frame.
    pub normals: bool,
    /// The frame's area over the rest mesh's.
    pub area_ratio: f64,
}

/// The frame's mesh with the rest mesh's triangulation: the same corners,
/// the frame's positions. Errors unless the frame has the rest mesh's
/// vertices and faces.
pub fn on_frame(rest: &TriMesh, frame: &TriMesh) -> Result<TriMesh> {
    if frame.positions.len() != rest.positions.len() {
        return Err(Error::invalid(format!(
            "the frame has {} vertices, the rest mesh {}: not the same mesh",
            frame.positions.len(),
            rest.positions.len()
        )));
    }
    if frame.polys != rest.polys {
        let f = (0..rest.face_count().min(frame.face_count()))
            .find(|&f| rest.polys.polygon(f) != frame.polys.polygon(f))
            .unwrap_or(rest.face_count().min(frame.face_count()));
        return Err(Error::invalid(format!(
            "the frame's faces differ from the rest mesh's (first at face {f}): not the same mesh"
        )));
    }
    Ok(TriMesh {
        positions: frame.positions.clone(),
        polys: rest.polys.clone(),
        tris: rest.tris.clone(),
        face_tris: rest.face_tris.clone(),
    })
}

/// Moves `cloud` (scattered on `rest`) onto `frame`.
pub fn follow(cloud: &mut Cloud, rest: &TriMesh, frame: &TriMesh) -> Result<Report> {
    let moved = on_frame(rest, frame)?;
    let pts = cloud.points();
    for name in ["P", "sourceprim", "sourceuv"] {
        if !pts.has(name) {
            return Err(pts.missing(name));
        }
    }
    let pos = pts.vec3_f64("P")?;
    let prim = pts.scalar_f64("sourceprim")?;
    let uv = pts.vec3_f64("sourceuv")?;
    rest.source_faces(&prim)?;
    if let Some(i) = uv
        .iter()
        .position(|w| !(w[0].is_finite() && w[1].is_finite()))
    {
        return Err(Error::invalid(format!(
            "point {i}: sourceuv is {:?}, not finite",
            uv[i]
        )));
    }
    // Each point's triangle on the rest mesh, its new place, and its
    // area's stretch.
    let moved_pts: Vec<(DVec3, f64)> = (0..pos.len())
        .into_par_iter()
        .map(|i| {
            let f = prim[i] as usize;
            let w = [1.0 - uv[i][0] - uv[i][1], uv[i][0], uv[i][1]];
            let p = DVec3::from_array(pos[i]);
            match rest.triangle_at(f, w, p) {
                Some(t) => {
                    let [a, b, c] = moved.tri(t);
                    let [ra, rb, rc] = rest.tri(t);
                    let (before, after) = (tri_area(ra, rb, rc), tri_area(a, b, c));
                    let stretch = if before > 0.0 { after / before } else { 1.0 };
                    (geom::blend(w, a, b, c), stretch)
                }
                // A face with no triangle (degenerate): the point stays
                // where its face's first corner goes.
                None => (moved.positions[moved.polys.polygon(f)[0] as usize], 1.0),
            }
        })
        .collect();
    let area = |m: &TriMesh| -> f64 { m.tri_areas().iter().sum() };
    let (rest_area, frame_area) = (area(rest), area(&moved));
    let p64 = cloud.points().vec3_columns("P")?[0].column().ty() == ScalarType::F64;
    let role = Role::Point;
    if p64 {
        let v: Vec<[f64; 3]> = moved_pts.iter().map(|m| m.0.to_array()).collect();
        cloud.points_mut().set_vec3("P", role, &v)?;
    } else {
        let v: Vec<[f32; 3]> = moved_pts.iter().map(|m| m.0.as_vec3().to_array()).collect();
        cloud.points_mut().set_vec3("P", role, &v)?;
    }
    if cloud.points().has("ptarea") {
        let a = cloud.points().scalar_f64("ptarea")?;
        let scaled: Vec<f32> = a
            .iter()
            .zip(&moved_pts)
            .map(|(a, m)| (a * m.1) as f32)
            .collect();
        cloud.points_mut().set_scalar("ptarea", scaled)?;
    }
    if cloud.detail("Tarea").is_some() {
        cloud.set_detail("Tarea", DetailValue::F64(frame_area));
    }
    let normals = cloud.points().has("N");
    if normals {
        let mode = match cloud.detail("facet_mode") {
            Some(DetailValue::Str(s)) if s == "flat" => facet::Mode::Flat,
            _ => facet::Mode::Smooth,
        };
        let weight = match cloud.detail("facet_weight") {
            Some(DetailValue::Str(s)) if s == "area" => facet::Weight::Area,
            _ => facet::Weight::Angle,
        };
        let cusp = cloud
            .detail("facet_cusp")
            .and_then(|d| d.as_f64())
            .unwrap_or(60.0);
        let weld = cloud
            .detail("facet_weld")
            .and_then(|d| d.as_f64())
            .is_none_or(|w| w != 0.0);
        facet::facet_points(
            cloud,
            &moved,
            &facet::Params {
                mode,
                weight,
                cusp,
                weld,
            },
        )?;
    }
    cloud.record(
        "follow_",
        vec![
            ("follow_rest_digest", DetailValue::Str(rest.digest())),
            ("follow_mesh_digest", DetailValue::Str(moved.digest())),
        ],
    );
    Ok(Report {
        points: pos.len(),
        normals,
        area_ratio: if rest_area > 0.0 {
            frame_area / rest_area
        } else {
            1.0
        },
    })
}
