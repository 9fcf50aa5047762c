//! `measure` (Houdini's Measure SOP): face attributes `area` and
//! `perimeter` on a mesh.
//!
//! A face's area is the sum of its triangles' areas (ear-clipping
//! triangulation, see [`crate::geom::triangulate`]): Newell's area for a
//! planar polygon, and exactly what `scatter` distributes points over.
//! Degenerate faces (repeated or collinear vertices, fewer than three)
//! measure 0; non-finite positions are an error, so no area is NaN.

use crate::cloud::Cloud;
use crate::error::{Error, Result};
use crate::geom::mesh::TriMesh;
use crate::geom::{self, Sum};

/// What `measure` found.
#[derive(Clone, Debug, PartialEq)]
pub struct Report {
    pub faces: usize,
    pub total_area: f64,
    pub degenerate: usize,
}

/// Adds face attributes `area` and `perimeter` (float) to `mesh`.
pub fn measure(mesh: &mut Cloud) -> Result<Report> {
    let m = TriMesh::from_cloud(mesh)?;
    let tri_area = m.tri_areas();
    let mut area = Vec::with_capacity(m.face_count());
    let mut perim = Vec::with_capacity(m.face_count());
    let mut pts = Vec::new();
    let mut total = Sum::default();
    let mut degenerate = 0;
    for f in 0..m.face_count() {
        let r = m.face_tris[f] as usize..m.face_tris[f + 1] as usize;
        let a: f64 = tri_area[r].iter().copied().collect::<Sum>().value();
        pts.clear();
        pts.extend(m.polys.polygon(f).iter().map(|&v| m.positions[v as usize]));
        degenerate += usize::from(a == 0.0);
        total.add(a);
        area.push(a as f32);
        perim.push(geom::perimeter(&pts) as f32);
    }
    let faces = mesh.faces_mut().ok_or_else(|| Error::invalid("no faces"))?;
    faces.set_scalar("area", area)?;
    faces.set_scalar("perimeter", perim)?;
    Ok(Report {
        faces: m.face_count(),
        total_area: total.value(),
        degenerate,
    })
}
