//! USD in (formats/USD.md#usd-in): stages written by Pixar's own library
//! (`fixtures/usd/make_usd.py`) are read by the toolkit, and what it reads
//! is checked against what Pixar's library computed for the same stages
//! (`fixtures/usd/world.json`: world-space points and transforms).

use std::path::Path;

use glam::DVec3;
use pcsss::formats::usd;
use serde_json::{json, Value};

use crate::util::*;

fn world() -> Value {
    let t = std::fs::read_to_string(fixtures().join("usd/world.json")).unwrap();
    serde_json::from_str(&t).unwrap()
}

fn v3(v: &Value) -> DVec3 {
    DVec3::new(
        v[0].as_f64().unwrap(),
        v[1].as_f64().unwrap(),
        v[2].as_f64().unwrap(),
    )
}

/// Pixar's local-to-world matrix of a prim: rows, acting on row vectors.
struct Rows([DVec3; 4]);

impl Rows {
    fn of(v: &Value) -> Rows {
        Rows([v3(&v[0]), v3(&v[1]), v3(&v[2]), v3(&v[3])])
    }
    fn point(&self) -> DVec3 {
        self.0[3]
    }
    fn vector(&self, v: DVec3) -> DVec3 {
        self.0[0] * v.x + self.0[1] * v.y + self.0[2] * v.z
    }
    /// formats/USD.md's scale of a light's size: the cube root of the
    /// determinant of the upper 3 x 3.
    fn scale(&self) -> f64 {
        glam::DMat3::from_cols(self.0[0], self.0[1], self.0[2])
            .determinant()
            .abs()
            .cbrt()
    }
}

fn close(a: DVec3, b: DVec3, tol: f64) -> bool {
    (a - b).length() <= tol * (1.0 + b.length())
}

/// Every copy of a point of the box read from the stage is one of
/// Pixar's world-space points rounded to float, bit for bit, and every
/// one of those is read.
fn check_box(points: &[DVec3], truth: &Value, what: &str) {
    let f = |v: DVec3| v.as_vec3().as_dvec3();
    let truth: Vec<DVec3> = truth.as_array().unwrap().iter().map(|t| f(v3(t))).collect();
    for p in points {
        assert!(truth.contains(p), "{what}: {p} is none of Pixar's points");
    }
    for t in &truth {
        assert!(points.contains(t), "{what}: Pixar's {t} not read");
    }
}

#[test]
fn meshes_from_usda_usdc_and_usdz_are_in_world_space_and_the_stage_s_frame() {
    let w = world();
    for ext in ["usda", "usdc", "usdz"] {
        let path = fixtures().join(format!("usd/box.{ext}"));
        let m = usd::read_mesh(&path, None).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        let c = &m.cloud;
        let f = c.frame().unwrap();
        assert_eq!(f.up, Some(pcsss::frame::UpAxis::Y), "{ext}");
        assert_eq!(f.meters_per_unit, Some(0.01), "{ext}");
        let p = positions(c);
        // faceVarying normals and st: each corner its own vertex.
        assert_eq!(p.len(), 24, "{ext}");
        check_box(&p, &w["box"], ext);
        // The faces wind outwards (right-handed), and the normals read
        // through the transform are each face's.
        let mesh = pcsss::geom::mesh::TriMesh::from_cloud(c).unwrap();
        let centre = p.iter().sum::<DVec3>() / p.len() as f64;
        let n = c.points().vec3_f64("N").unwrap();
        for (t, tri) in mesh.tris.iter().enumerate() {
            let [a, b, cc] = mesh.tri(t);
            let face_n = (b - a).cross(cc - a).normalize();
            assert!(
                face_n.dot((a + b + cc) / 3.0 - centre) > 0.0,
                "{ext}: face {t} winds inwards"
            );
            for &v in tri {
                let nv = DVec3::from_array(n[v as usize]);
                assert!(
                    close(nv, face_n, 1e-5),
                    "{ext}: normal {nv} of a face {face_n}"
                );
            }
        }
        // The indexed faceVarying st: every face carries the whole square.
        let u = c.points().scalar_f64("u").unwrap();
        let v = c.points().scalar_f64("v").unwrap();
        for f in 0..6 {
            let mut uv: Vec<(i32, i32)> = mesh
                .polys
                .polygon(f)
                .iter()
                .map(|&k| (u[k as usize] as i32, v[k as usize] as i32))
                .collect();
            uv.sort();
            assert_eq!(uv, vec![(0, 0), (0, 1), (1, 0), (1, 1)], "{ext}: face {f}");
        }
    }
}

#[test]
fn a_prim_path_reads_the_meshes_under_it_alone() {
    let w = world();
    let scene = fixtures().join("usd/scene.usda");
    let all = usd::read_mesh(&scene, None).unwrap().cloud;
    // The pentagon has no normals nor st: the box is read by its points.
    assert_eq!(all.len(), 8 + 5);
    let floor = usd::read_mesh(&scene, Some("/World/Floor")).unwrap().cloud;
    let p = positions(&floor);
    check_box(&p, &w["scene_pentagon"], "pentagon");
    // It faces the side its points wind about in Pixar's world space.
    let t: Vec<DVec3> = w["scene_pentagon"]
        .as_array()
        .unwrap()
        .iter()
        .map(v3)
        .collect();
    let want = (t[1] - t[0]).cross(t[2] - t[0]).normalize();
    let mesh = pcsss::geom::mesh::TriMesh::from_cloud(&floor).unwrap();
    for n in mesh.face_normals() {
        assert!(close(n, want, 1e-6), "{n} {want}");
    }
    // The same through a binary, with the prim after the file's name.
    let d = tempdir();
    let arg = format!("{}:/World/Floor", scene.display());
    let o = run(
        "measure",
        &[&arg, "-o", d.path().join("m.ply").to_str().unwrap()],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let m = from_bytes(&std::fs::read(d.path().join("m.ply")).unwrap());
    assert_eq!(m.len(), 5);
    let o = run(
        "measure",
        &[&format!("{}:/World/Nothing", scene.display())],
        b"",
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("/World/Nothing"), "{}", stderr(&o));
}

/// The lights file the conversion table of formats/LIGHTS.md gives for
/// the scene's UsdLux lights, from Pixar's world transforms.
/// The scene's lights as a lights file written from Pixar's world
/// transforms by formats/USD.md's table, with the stage's values as the
/// stage holds them (its `float`s, widened), as an exporter would.
fn lights_by_hand(w: &Value) -> Value {
    let m = |n: &str| Rows::of(&w[format!("light_{n}")]);
    let a = |v: DVec3| json!([v.x, v.y, v.z]);
    let f = |x: f32| x as f64;
    let pi = std::f64::consts::PI;
    let (key, bulb, ball, panel, disk, spot) = (
        m("key"),
        m("bulb"),
        m("ball"),
        m("panel"),
        m("disk"),
        m("spot"),
    );
    let (pu, pv) = (panel.vector(DVec3::Y * 20.0), panel.vector(DVec3::X * 30.0));
    let disk_r = 8.0 * disk.scale();
    // A point light's radius is the sphere's fallback, 0.5.
    let (bulb_r, spot_r) = (0.5 * bulb.scale(), 0.5 * spot.scale());
    json!({
        "up_axis": "y", "meters_per_unit": 0.01,
        "lights": [
            { "name": "key", "type": "distant", "color": [1.0, f(0.95), f(0.9)],
              "intensity": 2.0 * 2.0 * pi * (f(0.53).to_radians() / 2.0).sin().powi(2),
              "direction": a(key.vector(-DVec3::Z)) },
            { "name": "bulb", "type": "point", "position": a(bulb.point()),
              "intensity": 3000.0 * pi * bulb_r * bulb_r },
            { "name": "ball", "type": "sphere", "position": a(ball.point()),
              "radius": 5.0 * ball.scale(), "intensity": 40.0 / 4.0 },
            { "name": "panel", "type": "rect", "position": a(panel.point()), "u": a(pu), "v": a(pv),
              "intensity": 5.0 * pu.cross(pv).length() },
            { "name": "disk", "type": "disk", "color": [f(0.6), f(0.7), 1.0], "position": a(disk.point()),
              "normal": a(disk.vector(-DVec3::Z)), "radius": disk_r,
              "intensity": 4.0 * pi * disk_r * disk_r },
            { "name": "spot", "type": "spot", "position": a(spot.point()),
              "direction": a(spot.vector(-DVec3::Z)), "cone_angle": 35.0, "cone_delta": f(0.2) * 35.0,
              "intensity": 20000.0 * pi * spot_r * spot_r },
            { "name": "sky", "type": "dome", "intensity": f(0.05) }
        ]
    })
}

fn camera_by_hand(w: &Value) -> Value {
    let c = Rows::of(&w["camera"]);
    let eye = c.point();
    let ahead = c.vector(-DVec3::Z).normalize();
    let up = c.vector(DVec3::Y);
    let a = |v: DVec3| json!([v.x, v.y, v.z]);
    json!({
        "up_axis": "y", "meters_per_unit": 0.01,
        "position": a(eye), "look_at": a(eye + ahead), "up": a(up),
        "fov": 2.0 * (24.0f64 / (2.0 * 50.0)).atan().to_degrees(), "width": 768, "height": 512
    })
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs() / scale)
        .fold(0.0, f64::max)
}

fn run_ok(dir: &Path, name: &str, args: &[&str]) {
    let o = run_in(Some(dir), name, args, b"");
    assert!(o.status.success(), "{name} {args:?}: {}", stderr(&o));
}

#[test]
fn usd_lights_and_camera_bake_as_the_same_scene_written_in_json() {
    let w = world();
    let d = tempdir();
    let dir = d.path();
    let scene = fixtures().join("usd/scene.usda");
    let scene = scene.to_str().unwrap();
    std::fs::write(dir.join("lights.json"), lights_by_hand(&w).to_string()).unwrap();
    std::fs::write(dir.join("cam.json"), camera_by_hand(&w).to_string()).unwrap();
    run_ok(dir, "scatter", &[scene, "--count", "3000", "-o", "s.ply"]);
    run_ok(dir, "facet", &["s.ply", "--mesh", scene, "-o", "f.ply"]);
    for (lights, out) in [(scene, "usd.ply"), ("lights.json", "json.ply")] {
        run_ok(
            dir,
            "illum",
            &["f.ply", "--lights", lights, "--mesh", scene, "-o", out],
        );
    }
    let a = from_bytes(&std::fs::read(dir.join("usd.ply")).unwrap());
    let b = from_bytes(&std::fs::read(dir.join("json.ply")).unwrap());
    let x: Vec<f64> = a
        .points()
        .vec3_f64("illum")
        .unwrap()
        .into_iter()
        .flatten()
        .collect();
    let y: Vec<f64> = b
        .points()
        .vec3_f64("illum")
        .unwrap()
        .into_iter()
        .flatten()
        .collect();
    assert!(y.iter().filter(|v| **v > 0.1).count() > y.len() / 2);
    // The same bits: the reader composes transforms as Pixar does.
    assert_eq!(max_rel(&x, &y), 0.0, "illum");
    assert_eq!(x, y);
    assert_eq!(a.detail("illum_lights"), b.detail("illum_lights"));
    // The camera: the same pinhole, 768 x 512 by the apertures.
    let a = pcsss::cli::read_camera(Path::new(scene)).unwrap();
    let b = pcsss::cli::read_camera(&dir.join("cam.json")).unwrap();
    assert_eq!((a.width, a.height), (768, 512));
    assert_eq!((a.width, a.height), (b.width, b.height));
    assert_eq!(a.fov, b.fov);
    assert_eq!((a.position, a.look_at, a.up), (b.position, b.look_at, b.up));
}

/// A stage of text, written to `dir`.
fn stage(dir: &Path, name: &str, body: &str) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, format!("#usda 1.0\n{body}")).unwrap();
    p
}

const QUAD: &str = r#"point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]"#;

#[test]
fn what_the_reader_does_not_read_is_named_never_silently_wrong() {
    let d = tempdir();
    let dir = d.path();
    let err = |p: &Path| match usd::read_mesh(p, None) {
        Ok(_) => panic!("{} read", p.display()),
        Err(e) => e.to_string(),
    };
    // Animated points: one frame is not chosen for the user.
    let p = stage(
        dir,
        "anim.usda",
        &format!(
            r#"def Mesh "M" {{
        {QUAD}
        point3f[] points.timeSamples = {{ 1: [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], 2: [(0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1)] }}
    }}"#
        ),
    );
    let e = err(&p);
    assert!(e.contains("/M") && e.contains("2 time samples"), "{e}");
    // An xformOp kind this reader does not compose.
    let p = stage(
        dir,
        "op.usda",
        &format!(
            r#"def Mesh "M" {{
        {QUAD}
        float3 xformOp:shear = (1, 0, 0)
        uniform token[] xformOpOrder = ["xformOp:shear"]
    }}"#
        ),
    );
    let e = err(&p);
    assert!(e.contains("/M") && e.contains("shear"), "{e}");
    // Instancing.
    let p = stage(
        dir,
        "inst.usda",
        r#"def PointInstancer "I" {
    }"#,
    );
    let e = err(&p);
    assert!(e.contains("/I") && e.contains("PointInstancer"), "{e}");
    // Indices past the points.
    let p = stage(
        dir,
        "idx.usda",
        r#"def Mesh "M" {
        point3f[] points = [(0, 0, 0), (1, 0, 0), (1, 1, 0)]
        int[] faceVertexCounts = [3]
        int[] faceVertexIndices = [0, 1, 7]
    }"#,
    );
    let e = err(&p);
    assert!(e.contains("/M") && e.contains("7"), "{e}");
    // A stage with no mesh.
    let p = stage(
        dir,
        "none.usda",
        r#"def Xform "X" {
    }"#,
    );
    assert!(err(&p).contains("no UsdGeomMesh"));
    // Subdivision (USD's fallback when unauthored): the cage, with a
    // warning naming the prim; a left-handed mesh winds the other way.
    let p = stage(
        dir,
        "subdiv.usda",
        &format!(
            r#"def Mesh "M" {{
        {QUAD}
        uniform token orientation = "leftHanded"
    }}"#
        ),
    );
    let m = usd::read_mesh(&p, None).unwrap();
    assert!(
        m.warnings
            .iter()
            .any(|w| w.contains("/M") && w.contains("catmullClark")),
        "{:?}",
        m.warnings
    );
    let mesh = pcsss::geom::mesh::TriMesh::from_cloud(&m.cloud).unwrap();
    assert!(close(mesh.face_normals()[0], -DVec3::Z, 1e-9));
    // Through a binary: the warning on stderr, the file named; an error
    // is exit 1 naming the prim; a stage is not read from a pipe.
    let o = run(
        "measure",
        &[
            p.to_str().unwrap(),
            "-o",
            dir.join("m.ply").to_str().unwrap(),
        ],
        b"",
    );
    assert!(o.status.success());
    assert!(
        stderr(&o).contains("subdiv.usda: warning: prim /M"),
        "{}",
        stderr(&o)
    );
    let o = run("measure", &[dir.join("anim.usda").to_str().unwrap()], b"");
    assert_eq!(o.status.code(), Some(1));
    assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
    let o = run("measure", &[], &std::fs::read(&p).unwrap());
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("read from a file"), "{}", stderr(&o));
}

/// What the toolkit writes to `.usda` it reads back: every attribute with
/// its values (bit for bit in the types USD holds; 8- and 16-bit signed
/// integers come back widened to int), role, the detail and the frame.
#[test]
fn a_cloud_written_as_usda_reads_back_as_it_was() {
    use pcsss::cloud::Attribute;
    use pcsss::column::Column;
    let mut c = crate::usd::every_usd_type_cloud();
    let n = c.len();
    let odd: Vec<f32> = (0..n)
        .map(|i| [f32::MAX, 1e-30, f32::INFINITY, -0.0, 1.0 / 3.0][i % 5])
        .collect();
    c.points_mut()
        .set(Attribute::scalar("k_f32", Column::F32(odd)))
        .unwrap();
    let d = tempdir();
    let path = d.path().join("c.usda");
    std::fs::write(&path, to_bytes(&c, pcsss::formats::Format::Usda)).unwrap();
    let back = pcsss::formats::read_cloud_file(&path, &pcsss::formats::Select::All).unwrap();
    assert_eq!(back.len(), n);
    let names = |c: &pcsss::Cloud| -> Vec<String> {
        c.points().attrs().iter().map(|a| a.name.clone()).collect()
    };
    let mut a = names(&c);
    let mut b = names(&back);
    a.sort();
    b.sort();
    assert_eq!(a, b);
    for attr in c.points().attrs() {
        let got = back.points().attr(&attr.name).unwrap();
        assert_eq!(got.role(), attr.role(), "{}", attr.name);
        for (x, y) in attr.components().iter().zip(got.components()) {
            let (x, y) = (x.column(), y.column());
            match x {
                Column::I8(_) | Column::I16(_) | Column::U16(_) => {
                    assert_eq!(y.ty(), pcsss::column::ScalarType::I32, "{}", attr.name);
                    for i in 0..n {
                        assert_eq!(x.get_f64(i), y.get_f64(i), "{}", attr.name);
                    }
                }
                _ => {
                    assert_eq!(x.ty(), y.ty(), "{}", attr.name);
                    for i in 0..n {
                        assert_eq!(
                            x.get_f64(i).to_bits(),
                            y.get_f64(i).to_bits(),
                            "{} row {i}",
                            attr.name
                        );
                    }
                }
            }
        }
    }
    for det in &c.detail {
        assert_eq!(back.detail(&det.name), Some(&det.value), "{}", det.name);
    }
    assert_eq!(back.frame().unwrap(), c.frame().unwrap());
    // A cloud that states no frame reads back stating none (USD's
    // fallbacks are a scene's, not a cloud's).
    let mut plain = crate::bad_input_table::lit_cloud();
    plain
        .detail
        .retain(|d| d.name != "up_axis" && d.name != "meters_per_unit");
    std::fs::write(&path, to_bytes(&plain, pcsss::formats::Format::Usda)).unwrap();
    let back = pcsss::formats::read_cloud_file(&path, &pcsss::formats::Select::All).unwrap();
    assert_eq!(back.frame().unwrap(), pcsss::frame::Frame::default());
}

/// An output that is the stage a `FILE:/prim` input reads is refused
/// before any work, as any output that is an input is.
#[test]
fn an_output_over_the_stage_named_with_a_prim_is_refused() {
    let d = tempdir();
    let stage = d.path().join("scene.usda");
    std::fs::copy(fixtures().join("usd/scene.usda"), &stage).unwrap();
    let before = std::fs::read(&stage).unwrap();
    let arg = format!("{}:/World/Floor", stage.display());
    let o = run("measure", &[&arg, "-o", stage.to_str().unwrap()], b"");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("scene.usda: is also an input"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&stage).unwrap(), before);
}

/// Every world transform the reader composes is Pixar's, bit for bit
/// (`ComputeLocalToWorldTransform` on 60 random chains of every op kind,
/// inverted ops among them: `fixtures/usd/make_usd.py`), from text and
/// from the binary crate format alike.
#[test]
fn world_transforms_are_pixar_s_to_the_bit() {
    let w = world();
    let chains = w["xforms"].as_object().unwrap();
    assert_eq!(chains.len(), 60);
    for ext in ["usda", "usdc"] {
        let file = fixtures().join(format!("usd/xforms.{ext}"));
        for (prim, rows) in chains {
            let m = usd::stage::world_transform(&file, prim).unwrap();
            // Pixar's rows are glam's columns.
            let got = m.to_cols_array_2d();
            for (r, row) in rows.as_array().unwrap().iter().enumerate() {
                for (c, v) in row.as_array().unwrap().iter().enumerate() {
                    let want = v.as_f64().unwrap();
                    assert!(
                        got[r][c].to_bits() == want.to_bits() || (got[r][c] == 0.0 && want == 0.0),
                        "{ext} {prim} [{r}][{c}]: {} against Pixar's {want}",
                        got[r][c]
                    );
                }
            }
        }
    }
}
