//! Meshes: a cloud's `face` element as polygons, and their triangulation.

use crate::cloud::{Cloud, ListColumn};
use crate::error::{Error, Result};

/// A cloud's faces as polygons over its points.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygons {
    /// Polygon `f` is `indices[offsets[f]..offsets[f + 1]]`.
    pub offsets: Vec<usize>,
    /// Point indices, all checked to be in range.
    pub indices: Vec<u32>,
}

/// The names PLY writers use for a face's vertex list.
pub const FACE_LIST_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

impl Polygons {
    /// The polygons of `cloud`; an error when it has no faces or a face
    /// points at a missing vertex.
    pub fn of(cloud: &Cloud) -> Result<Polygons> {
        let faces = cloud.faces().filter(|f| !f.is_empty()).ok_or_else(|| {
            Error::invalid("no faces: a mesh is needed (a PLY 'face' element or OBJ 'f' lines)")
        })?;
        let list: &ListColumn = FACE_LIST_NAMES
            .iter()
            .find_map(|n| faces.list(n).ok())
            .ok_or_else(|| Error::invalid("the 'face' element has no 'vertex_indices' list"))?;
        let n = cloud.len();
        let mut indices = Vec::with_capacity(list.items.len());
        for k in 0..list.items.len() {
            let v = list.items.get_f64(k);
            if !(v >= 0.0 && v < n as f64) || v.fract() != 0.0 {
                let face = list.offsets.partition_point(|&o| o <= k) - 1;
                return Err(Error::invalid(format!(
                    "face {face} refers to vertex {v}, but the mesh has {n} vertices"
                )));
            }
            indices.push(v as u32);
        }
        Ok(Polygons {
            offsets: list.offsets.clone(),
            indices,
        })
    }

    /// Number of polygons.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True when there are no polygons.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The vertex indices of polygon `f`.
    pub fn polygon(&self, f: usize) -> &[u32] {
        &self.indices[self.offsets[f]..self.offsets[f + 1]]
    }

    /// Fan triangulation: triangle `t` of the result comes from polygon
    /// `source[t]`. Polygons of fewer than three vertices give no triangle.
    pub fn triangles(&self) -> (Vec<[u32; 3]>, Vec<u32>) {
        let mut tris = Vec::with_capacity(self.indices.len());
        let mut source = Vec::with_capacity(self.indices.len());
        for f in 0..self.len() {
            let p = self.polygon(f);
            for k in 1..p.len().saturating_sub(1) {
                tris.push([p[0], p[k], p[k + 1]]);
                source.push(f as u32);
            }
        }
        (tris, source)
    }
}
