//! USD in: every `UsdGeomMesh` of a stage (or of a subtree) as one mesh,
//! in world space and the stage's frame (formats/USD.md#usd-in).
//!
//! Points go through each prim's composed transform; normals through its
//! inverse transpose. Polygons stay polygons (the `face` element, as OBJ's
//! do), their corners reversed for a `leftHanded` mesh or a mirroring
//! transform so that the right-hand rule gives the outside. `normals` and
//! `primvars:st` are read with their interpolation (`constant`,
//! `uniform`, `vertex`, `varying`, `faceVarying`, and `:indices`): when
//! one varies by corner, each distinct (point, normal, st) of a corner
//! becomes a vertex, as OBJ's `v/vt/vn` triples do.

use std::collections::HashMap;
use std::path::Path;

use glam::DVec3;
use openusd::{sdf, usd};

use super::primvars;
use super::stage::{self, at, value};
use crate::cloud::{Attribute, Cloud, DetailValue, ListColumn};
use crate::column::{Column, ScalarType};
use crate::error::{Error, Result};
use crate::names;

/// A mesh read from a stage, and what the reader chose to say about it
/// (the callers print these as warnings).
pub struct StageMesh {
    pub cloud: Cloud,
    pub warnings: Vec<String>,
}

/// Per-corner or per-point values of a primvar, by interpolation.
enum Interp {
    Point,
    Corner,
    Face,
    Constant,
}

/// A primvar's values and where each corner finds its own.
struct Primvar<T> {
    values: Vec<T>,
    interp: Interp,
    indices: Option<Vec<i32>>,
}

impl<T: Copy> Primvar<T> {
    /// The value at corner `c` of face `f`, whose point is `pt`.
    fn at(&self, pt: usize, c: usize, f: usize) -> Option<T> {
        let k = match self.interp {
            Interp::Point => pt,
            Interp::Corner => c,
            Interp::Face => f,
            Interp::Constant => 0,
        };
        let k = match &self.indices {
            Some(ix) => usize::try_from(*ix.get(k)?).ok()?,
            None => k,
        };
        self.values.get(k).copied()
    }

    fn by_corner(&self) -> bool {
        matches!(self.interp, Interp::Corner | Interp::Face)
    }
}

fn interp(stage: &usd::Stage, p: &sdf::Path, name: &str) -> Result<Interp> {
    let ap = p
        .append_property(name)
        .map_err(|e| at(p.as_str(), format!("{name}: {e}")))?;
    let t = stage
        .attribute(ap)
        .get_metadata::<sdf::Value>("interpolation")
        .map_err(stage::usd_err)?;
    Ok(match t.as_ref().and_then(stage::token).as_deref() {
        None | Some("vertex") | Some("varying") => Interp::Point,
        Some("faceVarying") => Interp::Corner,
        Some("uniform") => Interp::Face,
        Some("constant") => Interp::Constant,
        Some(other) => return Err(at(p.as_str(), format!("{name}: interpolation '{other}'"))),
    })
}

fn ints(stage: &usd::Stage, p: &sdf::Path, name: &str) -> Result<Option<Vec<i32>>> {
    match value(stage, p, name)? {
        None => Ok(None),
        Some(sdf::Value::IntVec(v)) => Ok(Some(v)),
        Some(_) => Err(at(p.as_str(), format!("{name} is not an int[]"))),
    }
}

fn primvar<T>(
    stage: &usd::Stage,
    p: &sdf::Path,
    name: &str,
    decode: impl Fn(&sdf::Value) -> Option<Vec<T>>,
) -> Result<Option<Primvar<T>>> {
    let Some(v) = value(stage, p, name)? else {
        return Ok(None);
    };
    let values = decode(&v).ok_or_else(|| at(p.as_str(), format!("{name} has the wrong type")))?;
    Ok(Some(Primvar {
        values,
        interp: interp(stage, p, name)?,
        indices: ints(stage, p, &format!("{name}:indices"))?,
    }))
}

/// One mesh prim, in world space.
struct Prim {
    path: String,
    points: Vec<DVec3>,
    /// Each face's corner count and its place among the prim's faces.
    faces: Vec<(usize, usize)>,
    /// Each face's corners, in the right-handed order: the point and the
    /// corner's place in `faceVertexIndices` (for faceVarying values).
    corners: Vec<(u32, usize)>,
    normals: Option<Primvar<DVec3>>,
    st: Option<Primvar<[f64; 2]>>,
    /// Its other vertex primvars, one value a point (in world space).
    primvars: Vec<(String, primvars::Values)>,
    details: Vec<(String, DetailValue)>,
}

/// A `Mesh` prim (or, `mesh` false, a `Points` prim: its points alone).
fn read_prim(
    stage: &usd::Stage,
    p: &sdf::Path,
    mesh: bool,
    text: bool,
    warnings: &mut Vec<String>,
) -> Result<Prim> {
    let name = p.as_str();
    let points = value(stage, p, "points")?
        .map(|v| stage::vec3s(&v).ok_or_else(|| at(name, "points is not a point3f[]")))
        .transpose()?
        .unwrap_or_default();
    let counts = ints(stage, p, "faceVertexCounts")?.unwrap_or_default();
    let indices = ints(stage, p, "faceVertexIndices")?.unwrap_or_default();
    let scheme = value(stage, p, "subdivisionScheme")?
        .as_ref()
        .and_then(stage::token)
        .unwrap_or_else(|| "catmullClark".into());
    if mesh && scheme != "none" {
        warnings.push(format!(
            "prim {name}: subdivisionScheme is {scheme}; its control cage is read, not the \
             subdivided surface (author subdivisionScheme = \"none\" to silence this)"
        ));
    }
    let left = value(stage, p, "orientation")?
        .as_ref()
        .and_then(stage::token)
        .is_some_and(|o| o == "leftHanded");
    let holes: std::collections::HashSet<i32> = ints(stage, p, "holeIndices")?
        .unwrap_or_default()
        .into_iter()
        .collect();
    let m = stage::world(stage, p)?;
    let flip = left ^ (m.determinant() < 0.0);
    let n = points.len();
    let mut out_counts = Vec::with_capacity(counts.len());
    let mut corners = Vec::with_capacity(indices.len());
    let mut k = 0usize;
    for (f, &c) in counts.iter().enumerate() {
        let c =
            usize::try_from(c).map_err(|_| at(name, format!("faceVertexCounts[{f}] is {c}")))?;
        let face = indices.get(k..k + c).ok_or_else(|| {
            at(
                name,
                format!(
                    "faceVertexCounts asks for more than the {} faceVertexIndices",
                    indices.len()
                ),
            )
        })?;
        for &i in face {
            if i < 0 || i as usize >= n {
                return Err(at(
                    name,
                    format!("faceVertexIndices has {i}, not one of its {n} points"),
                ));
            }
        }
        let first = k;
        k += c;
        if holes.contains(&(f as i32)) {
            continue;
        }
        out_counts.push((c, f));
        let face = face.iter().enumerate().map(|(j, &i)| (i as u32, first + j));
        if flip {
            corners.extend(face.rev());
        } else {
            corners.extend(face);
        }
    }
    if k != indices.len() {
        return Err(at(
            name,
            format!(
                "faceVertexCounts sums to {k}, faceVertexIndices has {}",
                indices.len()
            ),
        ));
    }
    // `primvars:normals` stands in only where `normals` is not authored.
    let normals = match primvar(stage, p, "normals", stage::vec3s)? {
        Some(n) => Some(n),
        None => primvar(stage, p, "primvars:normals", stage::vec3s)?,
    };
    let st = primvar(stage, p, "primvars:st", stage::vec2s)?;
    let nm = stage::normal_matrix(&m).ok_or_else(|| at(name, "its transform is singular"))?;
    let primvars = primvars::vertex_primvars(stage, p, points.len(), &m)?;
    let details = primvars::details(stage, p, text)?;
    let points = points.iter().map(|&q| m.transform_point3(q)).collect();
    let normals = normals.map(|mut pv| {
        for v in &mut pv.values {
            *v = (nm * *v).normalize_or_zero();
        }
        pv
    });
    Ok(Prim {
        path: name.to_string(),
        points,
        faces: out_counts,
        corners,
        normals,
        st,
        primvars,
        details,
    })
}

/// Reads every `UsdGeomMesh` at or under `root` (all of the stage's when
/// `None`) into one mesh with the stage's frame recorded. Other geometry,
/// instances and point instancers are errors or warnings naming the prim;
/// a stage without a mesh is an error.
pub fn read_mesh(path: &Path, root: Option<&str>) -> Result<StageMesh> {
    stage::guarded(|| read_mesh_unguarded(path, root))
}

fn read_mesh_unguarded(path: &Path, root: Option<&str>) -> Result<StageMesh> {
    let stage = stage::open(path)?;
    let text = stage::is_text(path);
    let mut warnings = Vec::new();
    let mut prims = Vec::new();
    let mut points = Vec::new();
    for p in stage::prims_under(&stage, root)? {
        let prim = stage.prim(p.clone());
        let ty = stage::type_name(&stage, &p)?;
        if prim.is_instance().map_err(stage::usd_err)? {
            return Err(at(
                p.as_str(),
                "is an instance: instancing is not read (make it uninstanceable)",
            ));
        }
        match ty.as_str() {
            "Mesh" => {
                let vis = value(&stage, &p, "visibility")?
                    .as_ref()
                    .and_then(stage::token)
                    .is_some_and(|v| v == "invisible");
                let purpose = value(&stage, &p, "purpose")?
                    .as_ref()
                    .and_then(stage::token)
                    .unwrap_or_default();
                if vis || purpose == "guide" || purpose == "proxy" {
                    warnings.push(format!(
                        "prim {}: skipped ({})",
                        p.as_str(),
                        if vis { "invisible" } else { purpose.as_str() }
                    ));
                    continue;
                }
                prims.push(read_prim(&stage, &p, true, text, &mut warnings)?);
            }
            "Points" => points.push(p.clone()),
            "PointInstancer" => {
                return Err(at(p.as_str(), "a PointInstancer: instancing is not read"))
            }
            "BasisCurves" | "NurbsCurves" | "HermiteCurves" | "NurbsPatch" | "TetMesh" | "Cube"
            | "Sphere" | "Cylinder" | "Cone" | "Capsule" | "Plane" => {
                warnings.push(format!("prim {}: a {ty}, not a Mesh: not read", p.as_str()));
            }
            _ => {}
        }
    }
    // A stage of points alone (a cloud the toolkit wrote): the points,
    // in the frame the stage states.
    let mesh = !prims.is_empty();
    if mesh {
        for p in &points {
            warnings.push(format!(
                "prim {}: a Points, not a Mesh: not read",
                p.as_str()
            ));
        }
    } else {
        for p in &points {
            prims.push(read_prim(&stage, p, false, text, &mut warnings)?);
        }
    }
    if prims.is_empty() {
        return Err(Error::invalid(match root {
            Some(r) => format!("no UsdGeomMesh at or under {r}"),
            None => "no UsdGeomMesh on the stage".to_string(),
        }));
    }
    let mut cloud = merge(&prims, mesh)?;
    cloud.set_frame(&stage::frame(&stage, mesh)?);
    stage::finish(&stage)?;
    Ok(StageMesh { cloud, warnings })
}

/// The prims as one mesh (or, `mesh` false, one cloud of points):
/// vertices per point, or per distinct corner when a primvar varies by
/// corner.
fn merge(prims: &[Prim], mesh: bool) -> Result<Cloud> {
    let all_n = prims.iter().all(|p| p.normals.is_some());
    let all_st = prims.iter().all(|p| p.st.is_some());
    let mut pos: Vec<[f32; 3]> = Vec::new();
    let mut nrm: Vec<[f32; 3]> = Vec::new();
    let mut uv: Vec<[f32; 2]> = Vec::new();
    let mut faces = ListColumn::new(ScalarType::U8, ScalarType::I32);
    let mut idx: Vec<i32> = Vec::new();
    // Where each vertex comes from: the prim and its point.
    let (mut from_prim, mut from_point): (Vec<u32>, Vec<u32>) = (Vec::new(), Vec::new());
    for (k, prim) in prims.iter().enumerate() {
        let split = (all_n && prim.normals.as_ref().is_some_and(Primvar::by_corner))
            || (all_st && prim.st.as_ref().is_some_and(Primvar::by_corner));
        let base = pos.len();
        let mut seen: HashMap<(u32, [u32; 3], [u32; 2]), u32> = HashMap::new();
        if !split {
            for (i, q) in prim.points.iter().enumerate() {
                pos.push(q.as_vec3().to_array());
                from_prim.push(k as u32);
                from_point.push(i as u32);
                if all_n {
                    let v = prim.normals.as_ref().and_then(|pv| pv.at(i, 0, 0));
                    nrm.push(v.unwrap_or(DVec3::ZERO).as_vec3().to_array());
                }
                if all_st {
                    let v = prim.st.as_ref().and_then(|pv| pv.at(i, 0, 0));
                    let v = v.unwrap_or([0.0; 2]);
                    uv.push([v[0] as f32, v[1] as f32]);
                }
            }
        }
        let mut at = 0usize;
        for &(count, f) in &prim.faces {
            if count > 255 {
                faces.count_ty = ScalarType::I32;
            }
            for &(pt, c) in &prim.corners[at..at + count] {
                if !split {
                    idx.push(i32::try_from(base + pt as usize).map_err(|_| too_many())?);
                    continue;
                }
                let pt = pt as usize;
                let n = all_n
                    .then(|| prim.normals.as_ref().and_then(|pv| pv.at(pt, c, f)))
                    .flatten()
                    .map(|v| v.as_vec3().to_array())
                    .unwrap_or([0.0; 3]);
                let t = all_st
                    .then(|| prim.st.as_ref().and_then(|pv| pv.at(pt, c, f)))
                    .flatten()
                    .map(|v| [v[0] as f32, v[1] as f32])
                    .unwrap_or([0.0; 2]);
                let key = (pt as u32, n.map(f32::to_bits), t.map(f32::to_bits));
                let v = *seen.entry(key).or_insert_with(|| {
                    pos.push(prim.points[pt].as_vec3().to_array());
                    from_prim.push(k as u32);
                    from_point.push(pt as u32);
                    nrm.push(n);
                    uv.push(t);
                    (pos.len() - 1) as u32
                });
                idx.push(i32::try_from(v).map_err(|_| too_many())?);
            }
            at += count;
            faces.offsets.push(idx.len());
        }
    }
    faces.items = Column::I32(idx);
    let mut cloud = crate::formats::obj::polygon_mesh(
        &pos,
        all_n.then_some(&nrm[..]),
        all_st.then_some(&uv[..]),
        mesh.then_some(faces),
    )?;
    let pts = cloud.points_mut();
    // Every other vertex primvar all the prims have, of one role and
    // type, each vertex taking its point's value (a primvar named as an
    // attribute read above, P or N, stands for it: its type and bits).
    let idx: Vec<(u32, u32)> = from_prim
        .iter()
        .copied()
        .zip(from_point.iter().copied())
        .collect();
    for (name, first) in &prims[0].primvars {
        let all: Option<Vec<&primvars::Values>> = prims
            .iter()
            .map(|p| {
                p.primvars
                    .iter()
                    .find(|(n, v)| n == name && v.same_kind(first))
                    .map(|(_, v)| v)
            })
            .collect();
        let Some(all) = all else { continue };
        let attr = match first {
            primvars::Values::Scalar(_) => {
                let cols: Vec<&Column> = all
                    .iter()
                    .map(|v| match v {
                        primvars::Values::Scalar(c) => c,
                        primvars::Values::Vec3(_, c) => &c[0],
                    })
                    .collect();
                Attribute::scalar(name, Column::gather_from(&cols, &idx))
            }
            primvars::Values::Vec3(role, _) => {
                let comp = |k: usize| {
                    let cols: Vec<&Column> = all
                        .iter()
                        .map(|v| match v {
                            primvars::Values::Vec3(_, c) => &c[k],
                            primvars::Values::Scalar(c) => c,
                        })
                        .collect();
                    Column::gather_from(&cols, &idx)
                };
                Attribute::vec3(name, *role, [comp(0), comp(1), comp(2)])
            }
        };
        pts.set(attr)?;
    }
    if !mesh {
        for (name, d) in &prims[0].details {
            cloud.set_detail(name, d.clone());
        }
        if let Some(t) = stage::time() {
            cloud.set_detail(names::D_USD_TIME, DetailValue::F64(t));
        }
        return Ok(cloud);
    }
    pts.set_scalar(names::USD_PRIM, from_prim)?;
    pts.set_scalar(names::USD_POINT, from_point)?;
    let list: Vec<String> = prims
        .iter()
        .map(|p| format!("{} {}", p.path, p.points.len()))
        .collect();
    for (name, d) in &prims[0].details {
        cloud.set_detail(name, d.clone());
    }
    cloud.set_detail(names::D_USD_PRIMS, DetailValue::Str(list.join("\n")));
    if let Some(t) = stage::time() {
        cloud.set_detail(names::D_USD_TIME, DetailValue::F64(t));
    }
    Ok(cloud)
}

fn too_many() -> Error {
    Error::unsupported("more than 2^31 vertices")
}
