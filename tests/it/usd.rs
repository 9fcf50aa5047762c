//! USD out (formats/USD.md): a cloud written as `.usda` is opened by
//! Pixar's own library (usd-core), which reads back every attribute as a
//! vertex primvar with its values and type, the detail as custom
//! attributes, the frame as the stage's up axis and units, and finds no
//! validation error.

use crate::bad_input_table::lit_cloud;
use crate::util::*;
use pcsss::cloud::{Attribute, Cloud, DetailValue, Role};
use pcsss::column::Column;

/// A lit cloud with every scalar type USD output holds, an f64 vector,
/// odd floats (`f32::MAX`, `1e-30`), a detail of every type and a frame.
pub fn every_usd_type_cloud() -> pcsss::Cloud {
    let mut c = lit_cloud();
    let n = c.len();
    let pts = c.points_mut();
    pts.set(Attribute::scalar(
        "k_u8",
        Column::U8((0..n).map(|i| (i % 251) as u8).collect()),
    ))
    .unwrap();
    pts.set(Attribute::scalar(
        "k_i16",
        Column::I16((0..n).map(|i| -(i as i16)).collect()),
    ))
    .unwrap();
    pts.set(Attribute::scalar(
        "k_u32",
        Column::U32((0..n).map(|i| 4_000_000_000 - i as u32).collect()),
    ))
    .unwrap();
    pts.set(Attribute::scalar(
        "k_f64",
        Column::F64((0..n).map(|i| 1.0 / (i as f64 + 3.0)).collect()),
    ))
    .unwrap();
    pts.set(Attribute::scalar(
        "k_big",
        Column::F32(
            (0..n)
                .map(|i| if i % 2 == 0 { f32::MAX } else { 1e-30 })
                .collect(),
        ),
    ))
    .unwrap();
    let v: Vec<[f64; 3]> = (0..n).map(|i| [i as f64 / 7.0, -1.0 / 3.0, 1e20]).collect();
    pts.set_vec3("k_vec", Role::Vector, &v).unwrap();
    c.set_detail("d_i", DetailValue::I32(-7));
    c.set_detail("d_f", DetailValue::F64(std::f64::consts::PI));
    c.set_detail("d_s", DetailValue::Str("a \"quoted\"\nline".into()));
    c.set_detail("d_v", DetailValue::V3D([1.0, 2.5, -1e-9]));
    c.set_frame(&pcsss::frame::Frame {
        up: Some(pcsss::frame::UpAxis::Z),
        meters_per_unit: Some(0.01),
    });
    c
}

#[test]
#[ignore = "interop: needs Pixar's usd-core; `make test` runs it"]
fn pixar_s_library_reads_what_we_write_as_usda() {
    let py = python_with(&["pxr", "numpy"]);
    let d = tempdir();
    let c = every_usd_type_cloud();
    let n = c.len();
    let v = c.points().vec3_f64("k_vec").unwrap();
    let ply = d.path().join("c.ply");
    std::fs::write(&ply, to_bytes(&c, pcsss::formats::Format::DEFAULT)).unwrap();
    let o = run_in(Some(d.path()), "pcconvert", &["c.ply", "-o", "c.usda"], b"");
    assert!(o.status.success(), "{}", stderr(&o));
    // What Pixar's library reads, as JSON: every primvar's type,
    // interpolation and values, the custom attributes, the stage's frame,
    // and the validators' errors.
    let script = r#"
import json, sys, math
from pxr import Usd, UsdGeom
st = Usd.Stage.Open(sys.argv[1])
prim = st.GetDefaultPrim()
out = {"type": prim.GetTypeName(), "up": UsdGeom.GetStageUpAxis(st),
       "mpu": UsdGeom.GetStageMetersPerUnit(st), "primvars": {}, "detail": {}}
def plain(x):
    try:
        return [plain(y) for y in x]
    except TypeError:
        if isinstance(x, float) and math.isinf(x): return "inf" if x > 0 else "-inf"
        return x
for pv in UsdGeom.PrimvarsAPI(prim).GetAuthoredPrimvars():
    out["primvars"][pv.GetPrimvarName()] = [str(pv.GetTypeName()), pv.GetInterpolation(), plain(list(pv.Get()))]
for a in prim.GetAttributes():
    if a.GetName().startswith("pcsss:detail:"):
        v = a.Get()
        out["detail"][a.GetName()[13:]] = [str(a.GetTypeName()), plain(v) if not isinstance(v, str) else v]
out["points"] = len(UsdGeom.Points(prim).GetPointsAttr().Get())
out["widths"] = len(UsdGeom.Points(prim).GetWidthsAttr().Get())
errors = []
try:
    from pxr import UsdValidation
    reg = UsdValidation.ValidationRegistry()
    ctx = UsdValidation.ValidationContext(reg.GetOrLoadAllValidators())
    errors = [str(e.GetMessage()) for e in ctx.Validate(st) if e.GetType() == UsdValidation.ValidationErrorType.Error]
except ImportError as e:
    errors = ["no UsdValidation: " + str(e)]
out["errors"] = errors
print(json.dumps(out))
"#;
    let o = std::process::Command::new(&py)
        .args(["-c", script, d.path().join("c.usda").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(got["type"], "Points");
    assert_eq!(got["up"], "Z");
    assert_eq!(got["mpu"], 0.01);
    assert_eq!(got["points"], n);
    assert_eq!(got["widths"], n);
    assert_eq!(got["errors"], serde_json::json!([]), "{}", got["errors"]);
    let pv = &got["primvars"];
    let types = [
        ("P", "point3f[]"),
        ("N", "normal3f[]"),
        ("illum", "color3f[]"),
        ("ptarea", "float[]"),
        ("k_u8", "uchar[]"),
        ("k_i16", "int[]"),
        ("k_u32", "int64[]"),
        ("k_f64", "double[]"),
        ("k_vec", "vector3d[]"),
    ];
    for (name, ty) in types {
        assert_eq!(pv[name][0], ty, "{name}");
        assert_eq!(pv[name][1], "vertex", "{name}");
    }
    // Values: bit for bit where the types allow.
    let back = |name: &str, i: usize| pv[name][2][i].clone();
    let cl = c.points();
    for i in [0, 1, n / 2, n - 1] {
        assert_eq!(back("k_u8", i), cl.scalar_f64("k_u8").unwrap()[i] as u64);
        assert_eq!(back("k_i16", i), cl.scalar_f64("k_i16").unwrap()[i] as i64);
        assert_eq!(back("k_u32", i), cl.scalar_f64("k_u32").unwrap()[i] as u64);
        assert_eq!(
            back("k_f64", i).as_f64().unwrap(),
            cl.scalar_f64("k_f64").unwrap()[i]
        );
        let big = back("k_big", i).as_f64().unwrap() as f32;
        assert_eq!(big, cl.scalar_f64("k_big").unwrap()[i] as f32);
        let p = cl.vec3_f64("P").unwrap()[i];
        for k in 0..3 {
            assert_eq!(back("P", i)[k].as_f64().unwrap() as f32, p[k] as f32);
            assert_eq!(back("k_vec", i)[k].as_f64().unwrap(), v[i][k]);
        }
    }
    let det = &got["detail"];
    assert_eq!(det["d_i"], serde_json::json!(["int", -7]));
    assert_eq!(det["d_f"][1].as_f64().unwrap(), std::f64::consts::PI);
    assert_eq!(
        det["d_s"],
        serde_json::json!(["string", "a \"quoted\"\nline"])
    );
    assert_eq!(
        det["d_v"],
        serde_json::json!(["double3", [1.0, 2.5, -1e-9]])
    );
}

#[test]
fn what_usd_output_cannot_hold_is_refused_naming_it() {
    let d = tempdir();
    // An element USD output has no place for, an attribute name USD
    // cannot spell.
    std::fs::write(
        d.path().join("m.ply"),
        "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n\
         property float z\nelement edge 1\nproperty int vertex1\nend_header\n0 0 0\n1 0 0\n0\n",
    )
    .unwrap();
    let o = run_in(Some(d.path()), "pcconvert", &["m.ply", "-o", "m.usda"], b"");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("'edge'"), "{}", stderr(&o));
    assert!(!d.path().join("m.usda").exists());
    let mut c = lit_cloud();
    let n = c.len();
    c.points_mut()
        .set(Attribute::scalar("a-b", Column::F32(vec![0.0; n])))
        .unwrap();
    std::fs::write(
        d.path().join("c.ply"),
        to_bytes(&c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let o = run_in(Some(d.path()), "pcconvert", &["c.ply", "-o", "c.usda"], b"");
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("'a-b'"), "{}", stderr(&o));
}

/// A mesh (filter's output onto a mesh's own vertices) goes out as a
/// `UsdGeomMesh`: Pixar's library reads its faces back and its vertex
/// colours as a linear `displayColor`.
#[test]
#[ignore = "interop: needs Pixar's usd-core; `make test` runs it"]
fn a_mesh_with_vertex_colours_goes_out_as_a_usd_mesh() {
    let py = python_with(&["pxr"]);
    let d = tempdir();
    let mut m = cube();
    let n = m.len();
    for (k, c) in ["red", "green", "blue"].iter().enumerate() {
        let v: Vec<u8> = (0..n).map(|i| ((i * 37 + k * 80) % 256) as u8).collect();
        m.points_mut()
            .set(Attribute::scalar(c, Column::U8(v)))
            .unwrap();
    }
    std::fs::write(
        d.path().join("m.ply"),
        to_bytes(&m, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let o = run_in(Some(d.path()), "pcconvert", &["m.ply", "-o", "m.usda"], b"");
    assert!(o.status.success(), "{}", stderr(&o));
    let script = r#"
import json, sys
from pxr import Usd, UsdGeom
st = Usd.Stage.Open(sys.argv[1])
mesh = UsdGeom.Mesh(st.GetDefaultPrim())
dc = UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar("displayColor")
print(json.dumps({"type": st.GetDefaultPrim().GetTypeName(),
  "counts": list(mesh.GetFaceVertexCountsAttr().Get()),
  "indices": list(mesh.GetFaceVertexIndicesAttr().Get()),
  "points": len(mesh.GetPointsAttr().Get()),
  "dc": [list(c) for c in dc.Get()], "dc_interp": dc.GetInterpolation(),
  "uchar": [pv.GetPrimvarName() for pv in UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetAuthoredPrimvars()
            if str(pv.GetTypeName()).startswith("uchar")]}))
"#;
    let o = std::process::Command::new(&py)
        .args(["-c", script, d.path().join("m.usda").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(got["type"], "Mesh");
    assert_eq!(got["points"], n);
    let polys = pcsss::geom::mesh::Polygons::of(&m).unwrap();
    let counts: Vec<usize> = (0..polys.len()).map(|f| polys.polygon(f).len()).collect();
    let indices: Vec<u32> = (0..polys.len())
        .flat_map(|f| polys.polygon(f).to_vec())
        .collect();
    assert_eq!(got["counts"], serde_json::json!(counts));
    assert_eq!(got["indices"], serde_json::json!(indices));
    assert_eq!(got["dc_interp"], "vertex");
    // sRGB bytes decoded to linear (IEC 61966-2-1).
    let lin = |b: f64| {
        let c = b / 255.0;
        if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        }
    };
    for i in 0..n {
        for k in 0..3 {
            let byte = ((i * 37 + k * 80) % 256) as f64;
            let v = got["dc"][i][k].as_f64().unwrap();
            assert!((v - lin(byte)).abs() < 1e-6, "{i} {k}: {v}");
        }
    }
    // The bytes go out as the float colour alone (Blender reads a uchar
    // primvar as a signed byte), and come back as the same bytes.
    assert_eq!(got["uchar"], serde_json::json!([]), "{got}");
    let back =
        pcsss::formats::read_cloud_file(&d.path().join("m.usda"), &pcsss::formats::Select::All)
            .unwrap();
    for c in ["red", "green", "blue"] {
        assert_eq!(
            back.points().scalar_f64(c).unwrap(),
            m.points().scalar_f64(c).unwrap(),
            "{c}"
        );
    }
    assert!(!back.points().has("displayColor"));
}

/// Every colour byte goes out as `displayColor` and comes back as itself,
/// through text, crate and package; a cloud whose colours are not bytes
/// keeps them as its own primvars.
#[test]
fn colour_bytes_go_out_as_a_float_colour_and_come_back_as_bytes() {
    let d = tempdir();
    let mut c = Cloud::with_points(256);
    let p: Vec<[f64; 3]> = (0..256).map(|i| [i as f64, 0.0, 0.0]).collect();
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    for (k, name) in ["red", "green", "blue"].iter().enumerate() {
        let v: Vec<u8> = (0..256).map(|i| ((i + 85 * k) % 256) as u8).collect();
        c.points_mut()
            .set(Attribute::scalar(name, Column::U8(v)))
            .unwrap();
    }
    for ext in ["usda", "usdc", "usdz"] {
        let f = d.path().join(format!("c.{ext}"));
        let mut bytes = Vec::new();
        let format: pcsss::formats::Format = ext.parse().unwrap();
        pcsss::formats::write_cloud(&mut bytes, &c, format).unwrap();
        std::fs::write(&f, &bytes).unwrap();
        if ext == "usda" {
            let text = String::from_utf8(bytes).unwrap();
            assert!(!text.contains("uchar"), "{}", &text[..text.len().min(2000)]);
            assert!(text.contains("primvars:displayColor"));
        }
        let back = pcsss::formats::read_cloud_file(&f, &pcsss::formats::Select::All).unwrap();
        for name in ["red", "green", "blue"] {
            assert_eq!(
                back.points().scalar_f64(name).unwrap(),
                c.points().scalar_f64(name).unwrap(),
                "{ext} {name}"
            );
        }
    }
    // Colours that are not bytes stay primvars of their own type.
    let mut f = c.clone();
    f.points_mut()
        .set(Attribute::scalar("red", Column::F32(vec![0.5; 256])))
        .unwrap();
    let mut bytes = Vec::new();
    pcsss::formats::write_cloud(&mut bytes, &f, pcsss::formats::Format::Usda).unwrap();
    let text = String::from_utf8(bytes).unwrap();
    assert!(text.contains("float[] primvars:red") && text.contains("uchar[] primvars:green"));
    assert!(!text.contains("colourBytes"));
}

/// filter onto a mesh read from a USD stage writes a layer of `over`s
/// that Pixar's library composes over the stage: `primvars:ssM` and the
/// rest on the stage's own prim, one value a point of its `points`.
#[test]
#[ignore = "interop: needs Pixar's usd-core; `make test` runs it"]
fn filter_onto_a_usd_mesh_writes_a_layer_to_sublayer_over_the_stage() {
    let py = python_with(&["pxr"]);
    let d = tempdir();
    let dir = d.path();
    let stage = fixtures().join("usd/box.usda");
    let stage = stage.to_str().unwrap();
    std::fs::write(
        dir.join("l.json"),
        r#"{"lights":[{"name":"k","type":"distant","direction":[0.2,-1,-0.3]}]}"#,
    )
    .unwrap();
    let steps: [&[&str]; 6] = [
        &["scatter", stage, "--count", "3000", "-o", "s.ply"],
        &["facet", "s.ply", "--mesh", stage, "-o", "f.ply"],
        &[
            "illum",
            "f.ply",
            "--lights",
            "l.json",
            "--no-shadows",
            "-o",
            "i.ply",
        ],
        &["ssmulti", "i.ply", "--sd", "0.5", "-o", "m.ply"],
        &["filter", stage, "--cloud", "m.ply", "-o", "over.usda"],
        &["filter", stage, "--cloud", "m.ply", "-o", "v.ply"],
    ];
    for s in steps {
        let o = run_in(Some(dir), s[0], &s[1..], b"");
        assert!(o.status.success(), "{s:?}: {}", stderr(&o));
    }
    let script = r#"
import json, sys
from pxr import Sdf, Usd, UsdGeom
# A shot's layer, as a TD writes it: the asset's frame, the bake over it.
root = Sdf.Layer.CreateAnonymous(".usda")
root.subLayerPaths.append(sys.argv[1])
root.subLayerPaths.append(sys.argv[2])
st = Usd.Stage.Open(root)
st.SetDefaultPrim(st.GetPrimAtPath("/World"))
UsdGeom.SetStageUpAxis(st, UsdGeom.Tokens.y)
UsdGeom.SetStageMetersPerUnit(st, 0.01)
prim = st.GetPrimAtPath("/World/Box")
pv = UsdGeom.PrimvarsAPI(prim).GetPrimvar("ssM")
out = {"type": str(pv.GetTypeName()), "interp": pv.GetInterpolation(),
       "ssM": [list(v) for v in pv.Get()],
       "points": len(UsdGeom.Mesh(prim).GetPointsAttr().Get()),
       "display": len(UsdGeom.PrimvarsAPI(prim).GetPrimvar("displayColor").Get())}
from pxr import UsdValidation
reg = UsdValidation.ValidationRegistry()
ctx = UsdValidation.ValidationContext(reg.GetOrLoadAllValidators())
out["errors"] = [str(e.GetMessage()) for e in ctx.Validate(st) if e.GetType() == UsdValidation.ValidationErrorType.Error]
print(json.dumps(out))
"#;
    let o = std::process::Command::new(&py)
        .args(["-c", script, dir.join("over.usda").to_str().unwrap(), stage])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(got["type"], "color3f[]");
    assert_eq!(got["interp"], "vertex");
    assert_eq!(got["points"], 8);
    assert_eq!(got["display"], 8);
    assert_eq!(got["errors"], serde_json::json!([]), "{}", got["errors"]);
    // Each point's value is filter's at the first vertex that is it (the
    // box's faceVarying normals split each point into three corners).
    let v = from_bytes(&std::fs::read(dir.join("v.ply")).unwrap());
    assert_eq!(v.len(), 24);
    let point = v.points().scalar_f64("usd_point").unwrap();
    let ssm = v.points().vec3_f64("ssM").unwrap();
    let lit = ssm.iter().filter(|c| c[0] > 0.0).count();
    assert!(lit > 4, "{lit} lit vertices");
    for i in 0..8 {
        let first = point.iter().position(|&p| p == i as f64).unwrap();
        for k in 0..3 {
            let want = ssm[first][k] as f32;
            let back = got["ssM"][i][k].as_f64().unwrap() as f32;
            assert_eq!(back, want, "point {i}");
        }
    }
}

/// `.usdc` and `.usdz` out: Pixar's library opens them and finds what it
/// finds in the `.usda`, every attribute's type and value to the bit, and
/// the stage's metadata; the toolkit reads them back to the same cloud.
#[test]
#[ignore = "interop: needs Pixar's usd-core; `make test` runs it"]
fn pixar_s_library_reads_usdc_and_usdz_as_the_usda() {
    let py = python_with(&["pxr", "numpy"]);
    let d = tempdir();
    let c = every_usd_type_cloud();
    std::fs::write(
        d.path().join("c.ply"),
        to_bytes(&c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    for ext in ["usda", "usdc", "usdz"] {
        let out = format!("c.{ext}");
        let o = run_in(Some(d.path()), "pcconvert", &["c.ply", "-o", &out], b"");
        assert!(o.status.success(), "{ext}: {}", stderr(&o));
    }
    let script = r#"
import json, sys
import numpy as np
from pxr import Usd, Sdf
def dump(f):
    st = Usd.Stage.Open(f)
    out = {"meta": {k: str(st.GetMetadata(k)) for k in ("upAxis", "metersPerUnit", "defaultPrim", "documentation")}}
    for prim in st.Traverse():
        out[str(prim.GetPath())] = prim.GetTypeName()
        for a in prim.GetAttributes():
            v = a.Get()
            try:
                arr = np.asarray(v)
                val = arr.dtype.str + ":" + arr.tobytes().hex() if arr.dtype.kind in "fiub" else repr(v)
            except Exception:
                val = repr(v)
            out[str(a.GetPath())] = [str(a.GetTypeName()), val, a.GetMetadata("interpolation") or ""]
    return out
t, c, z = (dump(f) for f in sys.argv[1:])
def diff(a, b):
    return sorted(k for k in set(a) | set(b) if a.get(k) != b.get(k))
print(json.dumps({"keys": len(t), "usdc": diff(t, c), "usdz": diff(t, z),
                  "first": [[k, t.get(k), c.get(k)] for k in diff(t, c)[:3]]}))
"#;
    let files: Vec<String> = ["usda", "usdc", "usdz"]
        .iter()
        .map(|e| d.path().join(format!("c.{e}")).display().to_string())
        .collect();
    let o = std::process::Command::new(&py)
        .args(["-c", script])
        .args(&files)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(got["keys"].as_u64().unwrap() > 10, "{got}");
    assert_eq!(got["usdc"], serde_json::json!([]), "{}", got["first"]);
    assert_eq!(got["usdz"], serde_json::json!([]), "{}", got["usdz"]);
    // A bake's crate layer is at most a quarter of its text.
    let bunny = fixtures().join("mesh/bunny.obj");
    let o = run_in(
        Some(d.path()),
        "scatter",
        &[bunny.to_str().unwrap(), "-n", "50000", "-o", "b.ply"],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for ext in ["usda", "usdc"] {
        let o = run_in(
            Some(d.path()),
            "pcconvert",
            &["b.ply", "-o", &format!("b.{ext}")],
            b"",
        );
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let size = |f: &str| std::fs::metadata(d.path().join(f)).unwrap().len();
    assert!(
        size("b.usdc") * 4 <= size("b.usda"),
        "{} {}",
        size("b.usdc"),
        size("b.usda")
    );
    // The toolkit reads them back as it reads the text.
    let read = |e: &str| {
        pcsss::formats::read_cloud_file(
            &d.path().join(format!("c.{e}")),
            &pcsss::formats::Select::All,
        )
        .unwrap()
    };
    let t = read("usda");
    assert_same_values(&read("usdc"), &t);
    assert_same_values(&read("usdz"), &t);
}
