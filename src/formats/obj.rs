//! Wavefront OBJ mesh input (through `tobj`).
//!
//! All objects and groups are merged into one mesh: positions become `P`,
//! per-vertex normals `N`, texture coordinates the scalars `u` and `v`,
//! vertex colours the colour `Cd`. Polygons are kept as polygons (PLY's
//! `face` element with `vertex_indices`); [`crate::geom::mesh`] triangulates on
//! demand. Materials are ignored.

use std::io::BufRead;

fn load(text: &[u8], single_index: bool) -> Result<Vec<tobj::Model>> {
    let opts = tobj::LoadOptions {
        single_index,
        triangulate: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj_buf(&mut &text[..], &opts, |_| {
        Ok((Vec::new(), Default::default()))
    })
    .map_err(|e| Error::invalid(format!("OBJ: {e}")))?;
    Ok(models)
}

use crate::cloud::{Attribute, Cloud, Element, ListColumn, Role, FACES};
use crate::column::{Column, ScalarType};
use crate::error::{Error, Result};

/// Reads an OBJ mesh from `r`.
pub fn read_obj<R: BufRead>(mut r: R) -> Result<Cloud> {
    let mut text = Vec::new();
    r.read_to_end(&mut text)?;
    // Vertices stay in file order unless normals or texture coordinates are
    // indexed apart from positions: then each distinct corner becomes a
    // vertex (tobj's single index), since attributes here are per vertex.
    let mut models = load(&text, false)?;
    let split = models.iter().any(|m| {
        let m = &m.mesh;
        (!m.normal_indices.is_empty() && m.normal_indices != m.indices)
            || (!m.texcoord_indices.is_empty() && m.texcoord_indices != m.indices)
    });
    if split {
        models = load(&text, true)?;
    }
    let mut p: Vec<[f32; 3]> = Vec::new();
    let mut n: Vec<[f32; 3]> = Vec::new();
    let mut uv: Vec<[f32; 2]> = Vec::new();
    let mut cd: Vec<[f32; 3]> = Vec::new();
    let (mut all_n, mut all_uv, mut all_cd) = (true, true, true);
    let mut faces = ListColumn::new(ScalarType::U8, ScalarType::I32);
    let mut idx = Vec::new();
    for m in &models {
        let mesh = &m.mesh;
        let base = p.len();
        let nv = mesh.positions.len() / 3;
        p.extend(mesh.positions.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        all_n &= mesh.normals.len() == nv * 3;
        all_uv &= mesh.texcoords.len() == nv * 2;
        all_cd &= mesh.vertex_color.len() == nv * 3;
        n.extend(mesh.normals.chunks_exact(3).map(|c| [c[0], c[1], c[2]]));
        uv.extend(mesh.texcoords.chunks_exact(2).map(|c| [c[0], c[1]]));
        cd.extend(
            mesh.vertex_color
                .chunks_exact(3)
                .map(|c| [c[0], c[1], c[2]]),
        );
        let arities: Vec<u32> = if mesh.face_arities.is_empty() {
            vec![3; mesh.indices.len() / 3]
        } else {
            mesh.face_arities.clone()
        };
        let mut k = 0usize;
        for a in arities {
            let a = a as usize;
            if a > 255 {
                faces.count_ty = ScalarType::I32;
            }
            for &i in &mesh.indices[k..k + a] {
                idx.push((base + i as usize) as i32);
            }
            k += a;
            faces.offsets.push(idx.len());
        }
    }
    faces.items = Column::I32(idx);
    let n = (all_n && !n.is_empty()).then_some(&n[..]);
    let uv = (all_uv && !uv.is_empty()).then_some(&uv[..]);
    let mut cloud = polygon_mesh(&p, n, uv, Some(faces))?;
    if all_cd && !cd.is_empty() {
        cloud.points_mut().set_vec3("Cd", Role::Color, &cd)?;
    }
    Ok(cloud)
}

/// A mesh as the readers give it: `P`, and `N`, `u`, `v` when given, on
/// the vertices, and the polygons as the `face` element's
/// `vertex_indices` (none: points alone).
pub(crate) fn polygon_mesh(
    p: &[[f32; 3]],
    n: Option<&[[f32; 3]]>,
    uv: Option<&[[f32; 2]]>,
    faces: Option<ListColumn>,
) -> Result<Cloud> {
    let mut cloud = Cloud::with_points(p.len());
    let pts = cloud.points_mut();
    pts.set_vec3("P", Role::Point, p)?;
    if let Some(n) = n {
        pts.set_vec3("N", Role::Normal, n)?;
    }
    if let Some(uv) = uv {
        pts.set_scalar("u", uv.iter().map(|t| t[0]).collect())?;
        pts.set_scalar("v", uv.iter().map(|t| t[1]).collect())?;
    }
    if let Some(faces) = faces {
        let mut f = Element::new(FACES, faces.len());
        f.set(Attribute {
            name: "vertex_indices".into(),
            data: crate::cloud::AttrData::List(faces),
        })?;
        cloud.elements.push(f);
    }
    Ok(cloud)
}
