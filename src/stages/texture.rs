//! `texture`: an image sampled at every point into an attribute, through
//! the point's place on the mesh (`sourceprim`, `sourceuv`) and the mesh's
//! texture coordinates: a colour map becomes a per-point colour that a
//! material's `per_point` reads.
//!
//! The point lies at barycentric `sourceuv` of a triangle of its face (for
//! a polygon, the one whose point there is nearest `P`, as `facet`
//! takes it); its texture coordinate is the same blend of that
//! triangle's corners' coordinates. Coordinates are per vertex (`u v`,
//! `s t`, `texture_u texture_v`); a mesh with coordinates per corner
//! arrives with its vertices split where they differ (the OBJ reader
//! splits them, exporters write PLY that way), so each face's corners
//! carry their own.

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::error::{Error, Result};
use crate::formats::texture::Texture;
use crate::geom::mesh::TriMesh;

/// The names a mesh's texture coordinates go by, in the order tried.
pub const UV_NAMES: [(&str, &str); 4] = [
    ("u", "v"),
    ("s", "t"),
    ("texture_u", "texture_v"),
    ("texture_s", "texture_t"),
];

/// Wrapping past [0, 1].
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Wrap {
    Repeat,
    Clamp,
}

/// The mesh's texture coordinates per vertex, or an error naming what it
/// lacks.
pub fn mesh_uvs(mesh: &Cloud) -> Result<Vec<[f64; 2]>> {
    let pts = mesh.points();
    for (a, b) in UV_NAMES {
        if pts.has(a) && pts.has(b) {
            let (u, v) = (pts.scalar_f64(a)?, pts.scalar_f64(b)?);
            return Ok(u.into_iter().zip(v).map(|(u, v)| [u, v]).collect());
        }
    }
    Err(Error::invalid(
        "the mesh has no texture coordinates (u v, s t, texture_u texture_v: OBJ vt lines, or a PLY exported with UVs)",
    ))
}

/// Adds attribute `name` (a colour) to `cloud`: `tex` at each point's
/// texture coordinate on `mesh` (whose vertices `uvs` are).
pub fn texture(
    cloud: &mut Cloud,
    mesh: &TriMesh,
    uvs: &[[f64; 2]],
    tex: &Texture,
    name: &str,
    wrap: Wrap,
) -> Result<()> {
    if name.is_empty() || name.contains(char::is_whitespace) {
        return Err(Error::param(
            "name",
            format!("'{name}' is not an attribute name"),
        ));
    }
    // A colour written over what another stage made (positions, normals,
    // areas, light) would pass on as that, wrong.
    if let Some(maker) = crate::names::made_by(name) {
        return Err(Error::param(
            "name",
            format!("'{name}' is {maker}'s attribute, not a texture's: name another (Cd)"),
        ));
    }
    if uvs.len() != mesh.positions.len() {
        return Err(Error::invalid(format!(
            "{} texture coordinates for {} vertices",
            uvs.len(),
            mesh.positions.len()
        )));
    }
    let pts = cloud.points();
    for need in ["P", "sourceprim", "sourceuv"] {
        if !pts.has(need) {
            return Err(pts.missing(need));
        }
    }
    let pos = pts.vec3_f64("P")?;
    let prim = pts.scalar_f64("sourceprim")?;
    let uv = pts.vec3_f64("sourceuv")?;
    mesh.source_faces_at(&prim, &pos)?;
    let repeat = wrap == Wrap::Repeat;
    // A coordinate that is not a number has no colour: refused, naming
    // the point or the mesh's vertex (as `follow` refuses them).
    let rows: Vec<[f32; 3]> = (0..pos.len())
        .into_par_iter()
        .map(|i| {
            if !(uv[i][0].is_finite() && uv[i][1].is_finite()) {
                return Err(Error::invalid(format!(
                    "point {i}: sourceuv is {:?}, not finite",
                    &uv[i][..2]
                )));
            }
            let f = prim[i] as usize;
            let w = [1.0 - uv[i][0] - uv[i][1], uv[i][0], uv[i][1]];
            let p = DVec3::from_array(pos[i]);
            let Some(t) = mesh.triangle_at(f, w, p) else {
                return Ok([0.0; 3]);
            };
            let k = mesh.tris[t];
            let v = k.map(|corner| mesh.vertex(corner));
            let c = v.map(|v| uvs[v]);
            if let Some(j) = (0..3).find(|&j| !(c[j][0].is_finite() && c[j][1].is_finite())) {
                return Err(Error::invalid(format!(
                    "the mesh's vertex {}: texture coordinate {:?}, not finite",
                    v[j], c[j]
                )));
            }
            let s = w[0] * c[0][0] + w[1] * c[1][0] + w[2] * c[2][0];
            let q = w[0] * c[0][1] + w[1] * c[1][1] + w[2] * c[2][1];
            if !(s.is_finite() && q.is_finite()) {
                return Err(Error::invalid(format!(
                    "point {i}: its texture coordinate ({s}, {q}) is not finite"
                )));
            }
            Ok(tex.sample(s, q, repeat))
        })
        .collect::<Result<_>>()?;
    cloud.points_mut().set_vec3(name, Role::Color, &rows)?;
    let prefix = format!("texture_{name}_");
    let key = |k: &str| format!("{prefix}{k}");
    let (size, wrap_key, digest) = (key("size"), key("wrap"), key("mesh_digest"));
    cloud.record(
        &prefix,
        vec![
            (
                size.as_str(),
                DetailValue::Str(format!("{} x {}", tex.width, tex.height)),
            ),
            (
                wrap_key.as_str(),
                DetailValue::Str(format!("{wrap:?}").to_lowercase()),
            ),
            (digest.as_str(), DetailValue::Str(mesh.digest())),
        ],
    );
    Ok(())
}
