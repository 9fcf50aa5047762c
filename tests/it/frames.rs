//! Frames (`formats/LIGHTS.md#frames`): a scene whose mesh is Y-up in
//! centimetres, baked with lights and a camera written Z-up in metres,
//! gives the picture of the same scene written all Z-up in metres.

use crate::util::*;

/// The torus's OBJ with every vertex moved by `f`.
fn moved_obj(f: impl Fn([f64; 3]) -> [f64; 3]) -> String {
    let text = std::fs::read_to_string(fixtures().join("mesh/torus.obj")).unwrap();
    text.lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(rest) => {
                let v: Vec<f64> = rest
                    .split_whitespace()
                    .map(|x| x.parse().unwrap())
                    .collect();
                let q = f([v[0], v[1], v[2]]);
                format!("v {:?} {:?} {:?}", q[0], q[1], q[2])
            }
            None => l.to_string(),
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Lights of every kind that falls off with distance, and a distant one,
/// Z-up in metres; `frame` is spliced in as top-level keys.
fn lights(frame: &str) -> String {
    format!(
        r#"{{ {frame} "lights": [
        {{ "name": "key", "type": "distant", "intensity": 1.5, "direction": [0.3, 0.2, -1.0] }},
        {{ "name": "bulb", "type": "point", "intensity": 2.0, "position": [1.5, -1.0, 1.2] }},
        {{ "name": "spot", "type": "spot", "intensity": 3.0, "position": [-1.5, -1.5, 1.5],
           "direction": [1.0, 1.0, -1.0], "cone_angle": 40 }},
        {{ "name": "panel", "type": "rect", "intensity": 2.0, "position": [0.0, -2.0, 0.5],
           "u": [1.0, 0.0, 0.0], "v": [0.0, 0.0, 0.6], "samples": 4 }}
    ] }}"#
    )
}

fn camera(frame: &str) -> String {
    format!(
        r#"{{ {frame} "position": [0.0, -3.4, 2.0], "look_at": [0.0, 0.0, -0.1],
        "fov": 35, "width": 48, "height": 36 }}"#
    )
}

/// Bakes `mesh.obj` in `dir` (ssmulti's `sd` in the mesh's units) and
/// returns the lit cloud and the render.
fn bake(dir: &std::path::Path, scatter_frame: &str, sd: f64) -> (pcsss::Cloud, pcsss::Cloud) {
    let b = |n: &str| bin(n).display().to_string();
    let cmd = format!(
        "{m} mesh.obj | {p} --class face --attr area --method sum --as Tarea > mesh.ply && \
         {s} mesh.ply -n 4000 --seed 3 {scatter_frame} | {f} --mesh mesh.ply | {p} --normalize -o cloud.ply && \
         {i} cloud.ply --lights lights.json --mesh mesh.ply -o lit.ply && \
         {ss} lit.ply --sd {sd} --rd 0.9,0.5,0.3 --rgb -o multi.ply && \
         {r} --mesh mesh.ply --camera camera.json --cloud multi.ply -o picture.exr",
        m = b("measure"),
        p = b("promote"),
        s = b("scatter"),
        f = b("facet"),
        i = b("illum"),
        ss = b("ssmulti"),
        r = b("render"),
    );
    shell(dir, &cmd);
    let read = |n: &str| {
        pcsss::formats::read_cloud_file(&dir.join(n), &pcsss::formats::Select::All).unwrap()
    };
    (read("lit.ply"), read("picture.exr"))
}

#[test]
fn a_y_up_centimetre_mesh_with_z_up_metre_lights_bakes_the_z_up_picture() {
    // The scene as written: Z-up, metres, no frame stated anywhere.
    let a = tempdir();
    std::fs::write(a.path().join("mesh.obj"), moved_obj(|v| v)).unwrap();
    std::fs::write(a.path().join("lights.json"), lights("")).unwrap();
    std::fs::write(a.path().join("camera.json"), camera("")).unwrap();
    let (lit_a, pic_a) = bake(a.path(), "", 0.1);

    // The mesh exported Y-up in centimetres (as Blender's OBJ exporter
    // turns it), the lights and camera files as they were, stating their
    // frame.
    let b = tempdir();
    let to_y_cm = |v: [f64; 3]| [v[0] * 100.0, v[2] * 100.0, -v[1] * 100.0];
    std::fs::write(b.path().join("mesh.obj"), moved_obj(to_y_cm)).unwrap();
    let stated = r#""up_axis": "z", "meters_per_unit": 1,"#;
    std::fs::write(b.path().join("lights.json"), lights(stated)).unwrap();
    std::fs::write(b.path().join("camera.json"), camera(stated)).unwrap();
    let (lit_b, pic_b) = bake(b.path(), "--up-axis y --meters-per-unit 0.01", 10.0);
    assert_eq!(
        lit_b.detail("up_axis"),
        Some(&pcsss::cloud::DetailValue::Str("y".into()))
    );

    // The same points (moved), the same light at each.
    let (pa, pb) = (
        lit_a.points().vec3_f64("P").unwrap(),
        lit_b.points().vec3_f64("P").unwrap(),
    );
    assert_eq!(pa.len(), pb.len());
    for (p, q) in pa.iter().zip(&pb) {
        let moved = to_y_cm(*p);
        for k in 0..3 {
            assert!((moved[k] - q[k]).abs() < 1e-3, "{p:?} {q:?}");
        }
    }
    let (ea, eb) = (
        lit_a.points().vec3_f64("illum").unwrap(),
        lit_b.points().vec3_f64("illum").unwrap(),
    );
    let lit_points = ea.iter().filter(|e| e[0] > 0.0).count();
    assert!(lit_points > pa.len() / 3, "{lit_points}");
    let mut worst = 0.0f64;
    for (x, y) in ea.iter().zip(&eb) {
        for k in 0..3 {
            worst = worst.max((x[k] - y[k]).abs() / x[k].max(1e-3));
        }
    }
    assert!(worst < 1e-3, "illum differs by {worst}");

    // The same picture.
    let (ba, bb) = (
        pic_a.points().vec3_f64("beauty").unwrap(),
        pic_b.points().vec3_f64("beauty").unwrap(),
    );
    assert_eq!(ba.len(), bb.len());
    let top = ba.iter().map(|v| v[0]).fold(0.0, f64::max);
    assert!(top > 0.0);
    let worst = ba
        .iter()
        .zip(&bb)
        .map(|(x, y)| (0..3).map(|k| (x[k] - y[k]).abs()).fold(0.0, f64::max))
        .fold(0.0, f64::max);
    assert!(worst < 1e-3 * top, "picture differs by {worst} of {top}");
}

#[test]
fn a_frame_stated_twice_must_agree_and_a_bad_one_is_named() {
    let d = tempdir();
    let mesh = fixtures().join("mesh/cube.obj").display().to_string();
    // The cloud records z; scatter told y of the same cloud is refused.
    let o = run_in(
        Some(d.path()),
        "scatter",
        &[&mesh, "-n", "10", "--up-axis", "z", "-o", "z.ply"],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = run_in(
        Some(d.path()),
        "scatter",
        &["z.ply", "-n", "10", "--up-axis", "y", "-o", "y.ply"],
        b"",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("--up-axis") && stderr(&o).contains("records"),
        "{}",
        stderr(&o)
    );
    let o = run_in(
        Some(d.path()),
        "scatter",
        &[&mesh, "-n", "10", "--meters-per-unit", "0", "-o", "m.ply"],
        b"",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--meters-per-unit"), "{}", stderr(&o));
    // A lights file's bad frame names the key.
    let e = pcsss::lights::parse(r#"{ "up_axis": "x", "lights": [] }"#, "l.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("up_axis"), "{e}");
    let e = pcsss::lights::parse(r#"{ "meters_per_unit": -1, "lights": [] }"#, "l.json")
        .unwrap_err()
        .to_string();
    assert!(e.contains("meters_per_unit"), "{e}");
}
