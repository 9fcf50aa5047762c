//! USD in: a prim's vertex primvars as attributes, and its
//! `pcsss:detail:` custom attributes as the cloud's detail, so that a
//! cloud or mesh the toolkit wrote to `.usda` reads back as it was (bit
//! for bit where USD holds the type: formats/USD.md).

use glam::{DMat4, DVec3};
use openusd::{sdf, usd};

use super::stage::{self, at, value};
use crate::cloud::{DetailValue, Role};
use crate::column::Column;
use crate::error::Result;

/// One primvar's values, one a point.
#[derive(Clone, Debug)]
pub(super) enum Values {
    Scalar(Column),
    Vec3(Role, [Column; 3]),
}

impl Values {
    fn kind(&self) -> (Option<Role>, crate::column::ScalarType) {
        match self {
            Values::Scalar(c) => (None, c.ty()),
            Values::Vec3(r, c) => (Some(*r), c[0].ty()),
        }
    }

    /// True when `other` is of the same role and type (so that the
    /// primvar of several prims is one attribute).
    pub(super) fn same_kind(&self, other: &Values) -> bool {
        self.kind() == other.kind()
    }
}

fn vec3_columns<T: Copy>(rows: &[[T; 3]], wrap: fn(Vec<T>) -> Column) -> [Column; 3] {
    [0, 1, 2].map(|k| wrap(rows.iter().map(|r| r[k]).collect()))
}

/// The values of a USD array, by its type name, or `None` for a type the
/// toolkit's attributes do not hold.
fn decode(ty: &str, v: &sdf::Value) -> Option<Values> {
    let role = |t: &str| match t {
        t if t.starts_with("point3") => Role::Point,
        t if t.starts_with("normal3") => Role::Normal,
        t if t.starts_with("color3") => Role::Color,
        _ => Role::Vector,
    };
    Some(match v {
        sdf::Value::UcharVec(x) => Values::Scalar(Column::U8(x.clone())),
        sdf::Value::IntVec(x) => Values::Scalar(Column::I32(x.clone())),
        sdf::Value::UintVec(x) => Values::Scalar(Column::U32(x.clone())),
        // The toolkit has no 64-bit integers: the narrowest column that
        // holds every value exactly (uint, as the writer's `uint`, when
        // none is negative), else the primvar is not read.
        sdf::Value::Int64Vec(x) => {
            if let Ok(v) = x
                .iter()
                .map(|&i| u32::try_from(i))
                .collect::<Result<Vec<_>, _>>()
            {
                Values::Scalar(Column::U32(v))
            } else if let Ok(v) = x
                .iter()
                .map(|&i| i32::try_from(i))
                .collect::<Result<Vec<_>, _>>()
            {
                Values::Scalar(Column::I32(v))
            } else {
                return None;
            }
        }
        sdf::Value::FloatVec(x) => Values::Scalar(Column::F32(x.clone())),
        sdf::Value::DoubleVec(x) => Values::Scalar(Column::F64(x.clone())),
        sdf::Value::Vec3fVec(x) => {
            let rows: Vec<[f32; 3]> = x.iter().map(|a| [a.x, a.y, a.z]).collect();
            Values::Vec3(role(ty), vec3_columns(&rows, Column::F32))
        }
        sdf::Value::Vec3dVec(x) => {
            let rows: Vec<[f64; 3]> = x.iter().map(|a| [a.x, a.y, a.z]).collect();
            Values::Vec3(role(ty), vec3_columns(&rows, Column::F64))
        }
        sdf::Value::Vec3iVec(x) => {
            let rows: Vec<[i32; 3]> = x.iter().map(|a| [a.x, a.y, a.z]).collect();
            Values::Vec3(Role::Vector, vec3_columns(&rows, Column::I32))
        }
        _ => return None,
    })
}

/// A 3-vector primvar moved by the prim's transform as its role says
/// (points by the whole transform, normals by its inverse transpose,
/// vectors by its linear part, colours not at all); under the identity
/// the values are kept as they are, bit for bit.
fn transformed(v: Values, m: &DMat4) -> Values {
    let Values::Vec3(role, cols) = v else {
        return v;
    };
    if *m == DMat4::IDENTITY || role == Role::Color {
        return Values::Vec3(role, cols);
    }
    let f = |c: &Column, i: usize| c.get_f64(i);
    let n = cols[0].len();
    let nm = stage::normal_matrix(m).unwrap_or(glam::DMat3::IDENTITY);
    let rows: Vec<DVec3> = (0..n)
        .map(|i| {
            let p = DVec3::new(f(&cols[0], i), f(&cols[1], i), f(&cols[2], i));
            match role {
                Role::Point => m.transform_point3(p),
                Role::Normal => (nm * p).normalize_or_zero(),
                _ => m.transform_vector3(p),
            }
        })
        .collect();
    let out = match cols[0].ty() {
        crate::column::ScalarType::F64 => vec3_columns(
            &rows.iter().map(|r| r.to_array()).collect::<Vec<_>>(),
            Column::F64,
        ),
        _ => vec3_columns(
            &rows
                .iter()
                .map(|r| r.as_vec3().to_array())
                .collect::<Vec<_>>(),
            Column::F32,
        ),
    };
    Values::Vec3(role, out)
}

/// The prim's `primvars:NAME` of vertex (or varying, or unstated)
/// interpolation with one value a point, as attributes named NAME (an
/// indexed one resolved through its indices). Names with a namespace
/// (`primvars:skel:...`), and `st` and `normals` (read as the mesh's), are
/// not taken; nor `displayColor` when the prim has the `red`, `green` and
/// `blue` it was made from.
pub(super) fn vertex_primvars(
    stage: &usd::Stage,
    p: &sdf::Path,
    points: usize,
    m: &DMat4,
) -> Result<Vec<(String, Values)>> {
    let prim = stage.prim(p.clone());
    let names = prim.property_names().map_err(stage::usd_err)?;
    let names: Vec<String> = names.iter().map(|t| t.as_str().to_string()).collect();
    let has = |n: &str| names.iter().any(|x| x == &format!("primvars:{n}"));
    let mut out = Vec::new();
    for full in &names {
        let Some(name) = full.strip_prefix("primvars:") else {
            continue;
        };
        if name.contains(':') || name == "st" || name == "normals" {
            continue;
        }
        if name == "displayColor" && has("red") && has("green") && has("blue") {
            continue;
        }
        let bytes =
            name == "displayColor" && names.iter().any(|n| n == crate::names::USD_COLOUR_BYTES);
        let ap = p
            .append_property(full.as_str())
            .map_err(|e| at(p.as_str(), format!("{full}: {e}")))?;
        let attr = stage.attribute(ap);
        let interp = attr
            .get_metadata::<sdf::Value>("interpolation")
            .map_err(stage::usd_err)?
            .as_ref()
            .and_then(stage::token);
        if !matches!(interp.as_deref(), None | Some("vertex") | Some("varying")) {
            continue;
        }
        let ty = attr
            .type_name()
            .map_err(stage::usd_err)?
            .map(|t| t.as_str().to_string())
            .unwrap_or_default();
        let Some(v) = value(stage, p, full)? else {
            continue;
        };
        let Some(mut vals) = decode(&ty, &v) else {
            continue;
        };
        if let Some(sdf::Value::IntVec(ix)) = value(stage, p, &format!("{full}:indices"))? {
            let len = match &vals {
                Values::Scalar(c) => c.len(),
                Values::Vec3(_, c) => c[0].len(),
            };
            let idx: Vec<usize> = ix
                .iter()
                .map(|&i| usize::try_from(i).ok().filter(|&i| i < len))
                .collect::<Option<_>>()
                .ok_or_else(|| at(p.as_str(), format!("{full}:indices past its values")))?;
            vals = match vals {
                Values::Scalar(c) => Values::Scalar(c.gather(&idx)),
                Values::Vec3(r, c) => Values::Vec3(r, c.map(|c| c.gather(&idx))),
            };
        }
        let len = match &vals {
            Values::Scalar(c) => c.len(),
            Values::Vec3(_, c) => c[0].len(),
        };
        if len != points {
            continue;
        }
        if bytes {
            if let Values::Vec3(_, c) = &vals {
                for (k, channel) in ["red", "green", "blue"].iter().enumerate() {
                    out.push((channel.to_string(), Values::Scalar(to_bytes(&c[k]))));
                }
                continue;
            }
        }
        out.push((name.to_string(), transformed(vals, m)));
    }
    Ok(out)
}

/// Linear colours back to the sRGB bytes the writer made them from: each
/// the byte whose linear value (as the writer rounds it, to f32) is the
/// nearest.
fn to_bytes(c: &Column) -> Column {
    let table: Vec<f32> = (0..=255u32)
        .map(|k| crate::formats::texture::srgb_to_linear((k as f64 / 255.0) as f32))
        .collect();
    Column::U8(
        (0..c.len())
            .map(|i| {
                let v = c.get_f64(i) as f32;
                let k = table.partition_point(|&t| t < v).min(255);
                if k > 0 && (v - table[k - 1]).abs() <= (table[k] - v).abs() {
                    (k - 1) as u8
                } else {
                    k as u8
                }
            })
            .collect(),
    )
}

/// A text layer's string literal's escapes, undone. openusd 0.6 hands a
/// `.usda` string over with its escapes as written (`\"`, `\n`), where
/// Pixar's library undoes them; the toolkit reads what Pixar's does.
pub(super) fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut it = s.chars();
    while let Some(c) = it.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match it.next() {
            Some('n') => out.push('\n'),
            Some('t') => out.push('\t'),
            Some('r') => out.push('\r'),
            Some(o) => out.push(o),
            None => out.push('\\'),
        }
    }
    out
}

/// The prim's `pcsss:detail:NAME` custom attributes, as the toolkit's
/// writer makes them; `text` when the stage is a text layer (its strings
/// come with their escapes).
pub(super) fn details(
    stage: &usd::Stage,
    p: &sdf::Path,
    text: bool,
) -> Result<Vec<(String, DetailValue)>> {
    let prim = stage.prim(p.clone());
    let mut out = Vec::new();
    for t in prim.property_names().map_err(stage::usd_err)? {
        let Some(name) = t.as_str().strip_prefix("pcsss:detail:") else {
            continue;
        };
        let Some(v) = value(stage, p, t.as_str())? else {
            continue;
        };
        let d = match v {
            sdf::Value::Int(x) => DetailValue::I32(x),
            sdf::Value::Float(x) => DetailValue::F32(x),
            sdf::Value::Double(x) => DetailValue::F64(x),
            sdf::Value::Vec3f(a) => DetailValue::V3F([a.x, a.y, a.z]),
            sdf::Value::Vec3d(a) => DetailValue::V3D([a.x, a.y, a.z]),
            sdf::Value::String(s) if text => DetailValue::Str(unescape(&s)),
            sdf::Value::String(s) => DetailValue::Str(s),
            sdf::Value::Token(s) => DetailValue::Str(s.as_str().to_string()),
            _ => continue,
        };
        out.push((name.to_string(), d));
    }
    Ok(out)
}
