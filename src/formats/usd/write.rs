//! USD out (`-o cloud.usda`, formats/USD.md): a point cloud as a
//! `UsdGeomPoints` prim in a text layer that Pixar's library opens.
//!
//! `P` becomes `points` (`point3f[]`; an f64 `P` also `primvars:P` as
//! `point3d[]`, so nothing is rounded away), `N` `normals`, `ptarea` also
//! `widths` (the diameter of a disk of that area), and every attribute a
//! vertex-interpolated primvar of its own type: scalars `uchar`, `int`,
//! `uint`, `float` or `double`; 3-vectors by role `point3f`, `normal3f`,
//! `vector3f`, `color3f` (or their `d` forms for f64; `float3`, `int3`
//! without a role). The cloud's detail attributes become custom
//! attributes `pcsss:detail:NAME`, and its frame the layer's `upAxis` and
//! `metersPerUnit`. Text is written with the shortest digits that read
//! back to the same value.

use std::fmt::Write as _;
use std::io::Write;

use crate::cloud::{AttrData, Cloud, DetailValue, Role};
use crate::column::{Column, ScalarType};
use crate::error::{Error, Result};

/// A USD identifier: letters, digits and `_`, not starting with a digit.
fn identifier(name: &str) -> bool {
    let mut c = name.chars();
    c.next()
        .is_some_and(|f| f.is_ascii_alphabetic() || f == '_')
        && c.all(|x| x.is_ascii_alphanumeric() || x == '_')
}

/// A scalar type's USD name (small integers widen: USD has no int8 or
/// int16).
fn scalar_type(t: ScalarType) -> &'static str {
    match t {
        ScalarType::U8 => "uchar",
        ScalarType::I8 | ScalarType::I16 | ScalarType::I32 => "int",
        ScalarType::U16 | ScalarType::U32 => "uint",
        ScalarType::F32 => "float",
        ScalarType::F64 => "double",
    }
}

/// A 3-vector's USD type by role and component type.
fn vec3_type(role: Role, t: ScalarType) -> &'static str {
    let double = t == ScalarType::F64;
    match (role, t.is_float(), double) {
        (_, false, _) => "int3",
        (Role::Point, _, false) => "point3f",
        (Role::Point, _, true) => "point3d",
        (Role::Normal, _, false) => "normal3f",
        (Role::Normal, _, true) => "normal3d",
        (Role::Vector, _, false) => "vector3f",
        (Role::Vector, _, true) => "vector3d",
        (Role::Color, _, false) => "color3f",
        (Role::Color, _, true) => "color3d",
    }
}

/// A float in USD's text: shortest round-trip digits, `inf`, `-inf`,
/// `nan`.
fn float(out: &mut String, x: f64, single: bool) {
    if x.is_nan() {
        out.push_str("nan");
    } else if x.is_infinite() {
        out.push_str(if x > 0.0 { "inf" } else { "-inf" });
    } else {
        // Exponents for the very large and very small: USD's parser
        // takes a long run of digits without a point for an integer.
        let a = x.abs();
        let exp = a != 0.0 && !(1e-4..1e15).contains(&a);
        let _ = match (single, exp) {
            (true, false) => write!(out, "{}", x as f32),
            (true, true) => write!(out, "{:e}", x as f32),
            (false, false) => write!(out, "{x}"),
            (false, true) => write!(out, "{x:e}"),
        };
    }
}

/// Value `i` of `col`.
fn value(out: &mut String, col: &Column, i: usize) {
    match col {
        Column::I8(v) => write!(out, "{}", v[i]),
        Column::U8(v) => write!(out, "{}", v[i]),
        Column::I16(v) => write!(out, "{}", v[i]),
        Column::U16(v) => write!(out, "{}", v[i]),
        Column::I32(v) => write!(out, "{}", v[i]),
        Column::U32(v) => write!(out, "{}", v[i]),
        Column::F32(v) => {
            float(out, v[i] as f64, true);
            Ok(())
        }
        Column::F64(v) => {
            float(out, v[i], false);
            Ok(())
        }
    }
    .expect("a String takes every write");
}

/// A USD string literal.
fn string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// A row of three columns as `(x, y, z)`; `single` rounds to f32 (the
/// `float3` forms).
fn vec3_row(cols: [&Column; 3], single: bool) -> impl FnMut(&mut String, usize) + '_ {
    move |s: &mut String, i: usize| {
        s.push('(');
        for (k, c) in cols.iter().enumerate() {
            if k > 0 {
                s.push_str(", ");
            }
            if single {
                float(s, c.get_f64(i), true);
            } else {
                value(s, c, i);
            }
        }
        s.push(')');
    }
}

/// Writes `rows` values as an array attribute, one row a line.
fn array<W: Write + ?Sized>(
    w: &mut W,
    decl: &str,
    n: usize,
    mut row: impl FnMut(&mut String, usize),
    meta: &str,
) -> Result<()> {
    writeln!(w, "        {decl} = [")?;
    let mut line = String::new();
    for i in 0..n {
        line.clear();
        line.push_str("            ");
        row(&mut line, i);
        if i + 1 < n {
            line.push(',');
        }
        line.push('\n');
        w.write_all(line.as_bytes())?;
    }
    writeln!(w, "        ]{meta}")?;
    Ok(())
}

/// Writes `attr` (`n` rows) as a primvar with interpolation `meta`;
/// a list attribute (a mesh's vertex lists) is not one.
fn primvar<W: Write + ?Sized>(
    w: &mut W,
    attr: &crate::cloud::Attribute,
    n: usize,
    meta: &str,
) -> Result<()> {
    match &attr.data {
        AttrData::Scalar(v) => {
            let col = v.column();
            let decl = format!("{}[] primvars:{}", scalar_type(v.ty()), attr.name);
            array(w, &decl, n, |s, i| value(s, col, i), meta)
        }
        AttrData::Vec3(role, cols) => {
            let c = [cols[0].column(), cols[1].column(), cols[2].column()];
            // Components of one type (the widest, if a file mixed them).
            let t = if c.iter().any(|c| c.ty() == ScalarType::F64) {
                ScalarType::F64
            } else if c.iter().all(|c| !c.ty().is_float()) {
                ScalarType::I32
            } else {
                ScalarType::F32
            };
            let decl = format!("{}[] primvars:{}", vec3_type(*role, t), attr.name);
            array(w, &decl, n, vec3_row(c, t == ScalarType::F32), meta)
        }
        AttrData::List(_) => Ok(()),
    }
}

/// Writes `cloud` as a `.usda` layer with one `Points` prim, `/cloud`.
pub fn write_usda<W: Write + ?Sized>(w: &mut W, cloud: &Cloud) -> Result<()> {
    use crate::cloud::{FACES, POINTS};
    if let Some(e) = cloud
        .elements
        .iter()
        .find(|e| e.name != POINTS && e.name != FACES && !e.is_empty())
    {
        return Err(Error::unsupported(format!(
            "USD output holds points and faces; the element '{}' ({} rows) would be lost (write PLY)",
            e.name,
            e.len()
        )));
    }
    // A mesh: its faces' vertex lists, and their other attributes (one
    // value a face).
    const LISTS: [&str; 2] = ["vertex_indices", "vertex_index"];
    let polys = match cloud.faces().filter(|f| !f.is_empty()) {
        None => None,
        Some(f) => {
            let mut list = None;
            for a in f.attrs() {
                match &a.data {
                    AttrData::List(l) if LISTS.contains(&a.name.as_str()) && list.is_none() => {
                        list = Some(l)
                    }
                    AttrData::List(_) => {
                        return Err(Error::unsupported(format!(
                            "face attribute '{}' is a list: USD output holds one value a face",
                            a.name
                        )))
                    }
                    _ if !identifier(&a.name) => {
                        return Err(Error::unsupported(format!(
                            "face attribute '{}': not a USD identifier",
                            a.name
                        )))
                    }
                    _ => {}
                }
            }
            let list = list.ok_or_else(|| Error::invalid("faces without vertex_indices"))?;
            Some((f, list))
        }
    };
    let pts = cloud.points();
    if !pts.has("P") {
        return Err(pts.missing("P"));
    }
    for a in pts.attrs() {
        if !identifier(&a.name) {
            return Err(Error::unsupported(format!(
                "attribute '{}': not a USD identifier (letters, digits and _), so not a primvar",
                a.name
            )));
        }
        if matches!(a.data, AttrData::List(_)) {
            return Err(Error::unsupported(format!(
                "attribute '{}' is a list per point: USD output holds scalars and 3-vectors",
                a.name
            )));
        }
    }
    for d in &cloud.detail {
        if !identifier(&d.name) {
            return Err(Error::unsupported(format!(
                "detail attribute '{}': not a USD identifier",
                d.name
            )));
        }
    }
    let frame = cloud.frame()?;
    writeln!(w, "#usda 1.0\n(")?;
    writeln!(w, "    defaultPrim = \"cloud\"")?;
    writeln!(
        w,
        "    doc = \"A point cloud written by pcsss (formats/USD.md)\""
    )?;
    if let Some(m) = frame.meters_per_unit {
        let mut s = String::new();
        float(&mut s, m, false);
        writeln!(w, "    metersPerUnit = {s}")?;
    }
    if let Some(up) = frame.up {
        writeln!(w, "    upAxis = \"{}\"", up.name().to_ascii_uppercase())?;
    }
    match polys {
        None => writeln!(w, ")\n\ndef Points \"cloud\"\n{{")?,
        Some(_) => writeln!(
            w,
            ")\n\ndef Mesh \"cloud\"\n{{\n        uniform token subdivisionScheme = \"none\""
        )?,
    }
    let n = pts.len();
    let vertex = " (\n            interpolation = \"vertex\"\n        )";
    let p = pts.vec3_columns("P")?;
    let pc = [p[0].column(), p[1].column(), p[2].column()];
    array(w, "point3f[] points", n, vec3_row(pc, true), "")?;
    if let Some((f, list)) = polys {
        let nf = list.len();
        array(
            w,
            "int[] faceVertexCounts",
            nf,
            |s, i| {
                let _ = write!(s, "{}", list.range(i).len());
            },
            "",
        )?;
        array(
            w,
            "int[] faceVertexIndices",
            list.items.len(),
            |s, i| value(s, &list.items, i),
            "",
        )?;
        let uniform = " (\n            interpolation = \"uniform\"\n        )";
        for attr in f.attrs() {
            primvar(w, attr, nf, uniform)?;
        }
    }
    // The vertex colours (filter's sRGB bytes) as USD's displayColor,
    // linear.
    if ["red", "green", "blue"].iter().all(|c| pts.has(c)) {
        let c = ["red", "green", "blue"].map(|c| pts.scalar_f64(c));
        if let [Ok(r), Ok(g), Ok(b)] = c {
            let lin = |x: f64| crate::formats::texture::srgb_to_linear((x / 255.0) as f32) as f64;
            array(
                w,
                "color3f[] primvars:displayColor",
                n,
                |s, i| {
                    s.push('(');
                    float(s, lin(r[i]), true);
                    s.push_str(", ");
                    float(s, lin(g[i]), true);
                    s.push_str(", ");
                    float(s, lin(b[i]), true);
                    s.push(')');
                },
                vertex,
            )?;
        }
    }
    if pts.has("N") {
        let nn = pts.vec3_columns("N")?;
        let nc = [nn[0].column(), nn[1].column(), nn[2].column()];
        array(w, "normal3f[] normals", n, vec3_row(nc, true), vertex)?;
    }
    if pts.has("ptarea") {
        let a = pts.scalar_column("ptarea")?.column();
        array(
            w,
            "float[] widths",
            n,
            |s, i| {
                let d = 2.0 * (a.get_f64(i).max(0.0) / std::f64::consts::PI).sqrt();
                float(s, d, true)
            },
            vertex,
        )?;
    }
    for attr in pts.attrs() {
        primvar(w, attr, n, vertex)?;
    }
    for d in &cloud.detail {
        let (ty, val) = match &d.value {
            DetailValue::I32(x) => ("int", x.to_string()),
            DetailValue::F32(x) => ("float", {
                let mut s = String::new();
                float(&mut s, *x as f64, true);
                s
            }),
            DetailValue::F64(x) => ("double", {
                let mut s = String::new();
                float(&mut s, *x, false);
                s
            }),
            DetailValue::V3F(v) => ("float3", {
                let mut s = String::from("(");
                for (k, x) in v.iter().enumerate() {
                    if k > 0 {
                        s.push_str(", ");
                    }
                    float(&mut s, *x as f64, true);
                }
                s + ")"
            }),
            DetailValue::V3D(v) => ("double3", {
                let mut s = String::from("(");
                for (k, x) in v.iter().enumerate() {
                    if k > 0 {
                        s.push_str(", ");
                    }
                    float(&mut s, *x, false);
                }
                s + ")"
            }),
            DetailValue::Str(x) => ("string", string(x)),
        };
        writeln!(w, "        custom {ty} pcsss:detail:{} = {val}", d.name)?;
    }
    writeln!(w, "}}")?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identifiers_and_literals() {
        assert!(identifier("ssM") && identifier("_x1") && identifier("illum_cos"));
        assert!(!identifier("1x") && !identifier("a-b") && !identifier("") && !identifier("a.b"));
        assert_eq!(string("a\"b\\c\nd"), r#""a\"b\\c\nd""#);
        let mut s = String::new();
        float(&mut s, 0.1f32 as f64, true);
        assert_eq!(s, "0.1");
        s.clear();
        float(&mut s, f64::NEG_INFINITY, false);
        assert_eq!(s, "-inf");
        s.clear();
        float(&mut s, f32::MAX as f64, true);
        assert_eq!(s, "3.4028235e38");
    }
}
