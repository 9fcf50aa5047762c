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

/// Adds face attributes `area` and `perimeter` to `mesh`: float, or double
/// when a value is beyond float's range (a mesh with coordinates of 1e20
/// has areas of 1e40: written as they are, never as infinity).
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
        area.push(a);
        perim.push(geom::perimeter(&pts));
    }
    if !total.value().is_finite() {
        return Err(Error::invalid(format!(
            "the mesh's total area is {:e}: beyond a double (coordinates too large to square)",
            total.value()
        )));
    }
    let column = |v: Vec<f64>| {
        if v.iter().all(|x| x.abs() <= f32::MAX as f64) {
            crate::column::Column::F32(v.into_iter().map(|x| x as f32).collect())
        } else {
            crate::column::Column::F64(v)
        }
    };
    let faces = mesh.faces_mut().ok_or_else(|| Error::invalid("no faces"))?;
    faces.set(crate::cloud::Attribute::scalar("area", column(area)))?;
    faces.set(crate::cloud::Attribute::scalar("perimeter", column(perim)))?;
    Ok(Report {
        faces: m.face_count(),
        total_area: total.value(),
        degenerate,
    })
}
