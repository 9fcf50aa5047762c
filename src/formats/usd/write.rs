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
use crate::names;

/// A USD identifier: letters, digits and `_`, not starting with a digit.
fn identifier(name: &str) -> bool {
    let mut c = name.chars();
    c.next()
        .is_some_and(|f| f.is_ascii_alphabetic() || f == '_')
        && c.all(|x| x.is_ascii_alphanumeric() || x == '_')
}

/// A scalar type's USD name. Small integers widen (USD has no int8 or
/// int16), and `uint` is written as `int64`, which holds every value of
/// it: openusd 0.6 (the reader the toolkit can build with rustc 1.95)
/// does not parse `uint[]` arrays, and a layer of ours must read back.
fn scalar_type(t: ScalarType) -> &'static str {
    match t {
        ScalarType::U8 => "uchar",
        ScalarType::I8 | ScalarType::I16 | ScalarType::U16 | ScalarType::I32 => "int",
        ScalarType::U32 => "int64",
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

/// Writes `cloud` as a `.usdc` layer, Pixar's binary crate format: the
/// layer [`write_usda`] writes, parsed and written again by the `openusd`
/// crate's own reader and crate writer, so both files hold the same specs
/// and the same values (the text's shortest digits read back to the same
/// floats).
pub fn write_usdc<W: Write + ?Sized>(w: &mut W, cloud: &Cloud) -> Result<()> {
    w.write_all(&crate_bytes(cloud)?)?;
    Ok(())
}

/// Writes `cloud` as a `.usdz` package: the [`write_usdc`] layer, stored
/// (uncompressed, 64-byte aligned) as the package's one layer,
/// `cloud.usdc`.
pub fn write_usdz<W: Write + ?Sized>(w: &mut W, cloud: &Cloud) -> Result<()> {
    let layer = crate_bytes(cloud)?;
    let mut zip = openusd::usdz::ArchiveWriter::new(std::io::Cursor::new(Vec::new()));
    zip.add_layer("cloud.usdc", &layer)
        .map_err(super::stage::usd_err)?;
    let bytes = zip.finish().map_err(super::stage::usd_err)?.into_inner();
    w.write_all(&bytes)?;
    Ok(())
}

/// The crate-format bytes of the layer [`write_usda`] writes.
fn crate_bytes(cloud: &Cloud) -> Result<Vec<u8>> {
    let mut text = Vec::new();
    write_usda(&mut text, cloud)?;
    let text =
        String::from_utf8(text).map_err(|_| Error::invalid("USD: the layer is not UTF-8"))?;
    let mut data = openusd::usda::parse(&text).map_err(super::stage::usd_err)?;
    // The text parser hands strings over with their escapes (`\"`, `\n`)
    // as written; a crate layer holds the strings themselves, as Pixar's
    // library reads the text.
    use openusd::sdf::{AbstractData, Value};
    for path in data.spec_paths() {
        for field in data.list_fields(&path).unwrap_or_default() {
            let fixed = match data.get_field(&path, &field).map(|v| v.into_owned()) {
                Ok(Value::String(s)) if s.contains('\\') => {
                    Value::String(super::primvars::unescape(&s))
                }
                Ok(Value::StringVec(v)) if v.iter().any(|s| s.contains('\\')) => {
                    Value::StringVec(v.iter().map(|s| super::primvars::unescape(s)).collect())
                }
                _ => continue,
            };
            data.set_field(&path, &field, fixed);
        }
    }
    let mut out = std::io::Cursor::new(Vec::new());
    openusd::usdc::CrateWriter::write(&data, &mut out).map_err(super::stage::usd_err)?;
    Ok(out.into_inner())
}

/// Writes `cloud` as a `.usda` layer with one `Points` prim, `/cloud`.
pub fn write_usda<W: Write + ?Sized>(w: &mut W, cloud: &Cloud) -> Result<()> {
    use crate::cloud::{FACES, POINTS};
    if let Some(prims) = stage_prims(cloud)? {
        return write_over(w, cloud, &prims);
    }
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
    display_color(w, pts, vertex)?;
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
        if own_primvar(pts, &attr.name) {
            primvar(w, attr, n, vertex)?;
        }
    }
    details(w, cloud)?;
    writeln!(w, "}}")?;
    Ok(())
}

/// True when the points' colours are filter's bytes: `red`, `green` and
/// `blue`, each an 8-bit scalar.
fn colour_bytes(pts: &crate::cloud::Element) -> bool {
    ["red", "green", "blue"].iter().all(|c| {
        pts.scalar_column(c)
            .is_ok_and(|col| col.column().ty() == ScalarType::U8)
    })
}

/// Whether attribute `name` of the points goes out as a primvar of its
/// own (the colour bytes go out in `displayColor`).
fn own_primvar(pts: &crate::cloud::Element, name: &str) -> bool {
    !(["red", "green", "blue"].contains(&name) && colour_bytes(pts))
}

/// The vertex colours (filter's sRGB bytes) as USD's displayColor,
/// linear; bytes that are the cloud's own `red`, `green`, `blue` are
/// marked ([`names::USD_COLOUR_BYTES`]) so that they read back as the same bytes.
fn display_color<W: Write + ?Sized>(
    w: &mut W,
    pts: &crate::cloud::Element,
    vertex: &str,
) -> Result<()> {
    let n = pts.len();
    if colour_bytes(pts) {
        writeln!(
            w,
            "        custom string {} = \"red green blue\"",
            names::USD_COLOUR_BYTES
        )?;
    }
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
    Ok(())
}

/// The cloud's detail as custom attributes.
fn details<W: Write + ?Sized>(w: &mut W, cloud: &Cloud) -> Result<()> {
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
    Ok(())
}

/// The mesh prims a cloud read from a USD stage came from (the detail
/// `usd_prims`, with `usd_prim` and `usd_point` on every vertex), or
/// `None` for any other cloud.
fn stage_prims(cloud: &Cloud) -> Result<Option<Vec<(String, usize)>>> {
    let pts = cloud.points();
    let Some(DetailValue::Str(list)) = cloud.detail(names::D_USD_PRIMS) else {
        return Ok(None);
    };
    if !(pts.has(names::USD_PRIM) && pts.has(names::USD_POINT)) || cloud.faces().is_none() {
        return Ok(None);
    }
    let bad = || {
        Error::invalid(format!(
            "detail attribute '{}' is not 'path count' lines",
            names::D_USD_PRIMS
        ))
    };
    let mut out = Vec::new();
    for line in list.lines() {
        let (path, count) = line.rsplit_once(' ').ok_or_else(bad)?;
        let count: usize = count.parse().map_err(|_| bad())?;
        if !path.starts_with('/') || path[1..].split('/').any(|c| !identifier(c)) {
            return Err(bad());
        }
        out.push((path.to_string(), count));
    }
    Ok(Some(out))
}

/// What the stage's own mesh already has, and where a vertex came from:
/// not written over it.
const FROM_STAGE: [&str; 6] = ["P", "N", "u", "v", names::USD_PRIM, names::USD_POINT];

/// A layer to sublayer over the stage a mesh was read from: an `over` of
/// each mesh prim with the cloud's attributes as vertex primvars (one
/// value a point of the prim's own `points`: a point split into corners
/// by faceVarying normals or st takes its first corner's values, and a
/// point no face uses its prim's first point's).
fn write_over<W: Write + ?Sized>(
    w: &mut W,
    cloud: &Cloud,
    prims: &[(String, usize)],
) -> Result<()> {
    let pts = cloud.points();
    let prim_of = pts.scalar_f64(names::USD_PRIM)?;
    let point_of = pts.scalar_f64(names::USD_POINT)?;
    for a in pts.attrs() {
        if FROM_STAGE.contains(&a.name.as_str()) {
            continue;
        }
        if !identifier(&a.name) || matches!(a.data, AttrData::List(_)) {
            return Err(Error::unsupported(format!(
                "attribute '{}': not a USD identifier or a list, so not a primvar",
                a.name
            )));
        }
    }
    // Each prim's points, by the first vertex that is each.
    let mut first: Vec<Vec<Option<usize>>> = prims.iter().map(|(_, n)| vec![None; *n]).collect();
    for (v, (&k, &i)) in prim_of.iter().zip(&point_of).enumerate() {
        let slot = first
            .get_mut(k as usize)
            .and_then(|f| f.get_mut(i as usize))
            .ok_or_else(|| {
                Error::invalid(format!(
                    "vertex {v} names prim {k}, point {i}: not in usd_prims"
                ))
            })?;
        slot.get_or_insert(v);
    }
    writeln!(w, "#usda 1.0\n(")?;
    writeln!(
        w,
        "    doc = \"Attributes written by pcsss over the meshes of a stage: sublayer it over the stage (formats/USD.md)\""
    )?;
    writeln!(w, ")")?;
    // The prims as a tree of `over`s: a layer holds one spec a path.
    let mut order: Vec<Vec<&str>> = prims
        .iter()
        .map(|(p, _)| p[1..].split('/').collect())
        .collect();
    let mut k_of: std::collections::HashMap<Vec<&str>, usize> = std::collections::HashMap::new();
    for (k, parts) in order.iter().enumerate() {
        k_of.insert(parts.clone(), k);
    }
    order.sort();
    let mut open: Vec<&str> = Vec::new();
    for parts in &order {
        let common = open.iter().zip(parts).take_while(|(a, b)| a == b).count();
        while open.len() > common {
            open.pop();
            writeln!(w, "{}}}", "    ".repeat(open.len()))?;
        }
        for name in &parts[common..] {
            let pad = "    ".repeat(open.len());
            writeln!(w, "{pad}over \"{name}\"\n{pad}{{")?;
            open.push(name);
        }
        let k = k_of[parts];
        let fallback = first[k].iter().flatten().next().copied().unwrap_or(0);
        let idx: Vec<usize> = first[k].iter().map(|v| v.unwrap_or(fallback)).collect();
        let el = pts.gather(&idx);
        let mut body = Vec::new();
        over_body(&mut body, &el, cloud)?;
        // The body is indented for a prim at the top: one level deeper
        // a level.
        let pad = "    ".repeat(open.len() - 1);
        for line in String::from_utf8_lossy(&body).lines() {
            writeln!(w, "{pad}{}", line.strip_prefix("    ").unwrap_or(line))?;
        }
    }
    while open.pop().is_some() {
        writeln!(w, "{}}}", "    ".repeat(open.len()))?;
    }
    Ok(())
}

/// The primvars of one prim's `over` (at the indentation of a prim's
/// body in [`write_usda`]).
fn over_body(w: &mut Vec<u8>, el: &crate::cloud::Element, cloud: &Cloud) -> Result<()> {
    let n = el.len();
    let vertex = " (\n            interpolation = \"vertex\"\n        )";
    display_color(w, el, vertex)?;
    for attr in el.attrs() {
        if !FROM_STAGE.contains(&attr.name.as_str()) && own_primvar(el, &attr.name) {
            primvar(w, attr, n, vertex)?;
        }
    }
    details(w, cloud)
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
