//! `follow`: a cloud scattered once on a rest mesh, moved onto every frame
//! of a bending cylinder, lies on each frame's surface, keeps its points
//! (count, order, sourceprim, sourceuv), and its normals are the frame's.

use glam::DVec3;

use crate::util::*;
use pcsss::geom::bvh::ClosestPoint;
use pcsss::geom::mesh::TriMesh;
use pcsss::stages::facet::{self, Mode, Weight};
use pcsss::stages::follow;
use pcsss::stages::scatter::PtareaMode;
use pcsss::Cloud;

/// A cylinder of radius 0.3 along +y from 0 to `len` (rings x segs quads,
/// open ends), bent in the x-y plane through `angle` radians about a
/// centre on the +x side (the bend of a finger or a tail).
pub fn bent_cylinder(rings: usize, segs: usize, len: f64, angle: f64) -> Cloud {
    use std::f64::consts::PI;
    let mut p = Vec::new();
    for i in 0..=rings {
        let y = len * i as f64 / rings as f64;
        for j in 0..segs {
            let a = 2.0 * PI * j as f64 / segs as f64;
            let (x, z) = (0.3 * a.cos(), 0.3 * a.sin());
            let q = if angle == 0.0 {
                [x, y, z]
            } else {
                let r = len / angle;
                let t = y / r;
                [r - (r - x) * t.cos(), (r - x) * t.sin(), z]
            };
            p.push(q);
        }
    }
    let id = |i: usize, j: usize| (i * segs + j % segs) as i32;
    let mut f = Vec::new();
    for i in 0..rings {
        for j in 0..segs {
            f.push(vec![id(i, j), id(i, j + 1), id(i + 1, j + 1), id(i + 1, j)]);
        }
    }
    mesh_from(&p, &f)
}

#[test]
fn a_cloud_follows_a_bending_cylinder_through_ten_frames() {
    let rest_mesh = bent_cylinder(24, 32, 3.0, 0.0);
    let rest = TriMesh::from_cloud(&rest_mesh).unwrap();
    let mut cloud = scatter_n(&rest_mesh, 5000, 9, PtareaMode::Prim);
    let params = facet::Params {
        mode: Mode::Smooth,
        weight: Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    facet::facet_points(&mut cloud, &rest, &params).unwrap();
    let (prim0, uv0) = (
        cloud.points().scalar_f64("sourceprim").unwrap(),
        cloud.points().vec3_f64("sourceuv").unwrap(),
    );
    for k in 0..10 {
        let angle = std::f64::consts::FRAC_PI_2 * k as f64 / 9.0;
        let frame = TriMesh::from_cloud(&bent_cylinder(24, 32, 3.0, angle)).unwrap();
        let mut c = cloud.clone();
        let rep = follow::follow(&mut c, &rest, &frame).unwrap();
        assert_eq!(rep.points, 5000);
        assert!(rep.normals);
        // The same points, in the same order.
        assert_eq!(c.points().scalar_f64("sourceprim").unwrap(), prim0);
        assert_eq!(c.points().vec3_f64("sourceuv").unwrap(), uv0);
        // On the frame's surface, to 1e-6.
        let cp = ClosestPoint::new(&frame).unwrap();
        let p = c.points().vec3_f64("P").unwrap();
        let worst = p
            .iter()
            .map(|q| cp.query(DVec3::from_array(*q)).dist)
            .fold(0.0, f64::max);
        assert!(worst < 1e-6, "frame {k}: {worst} off the surface");
        // The frame's own normals, as facet gives them on it.
        let mut direct = c.clone();
        facet::facet_points(&mut direct, &frame, &params).unwrap();
        let (n1, n2) = (
            c.points().vec3_f64("N").unwrap(),
            direct.points().vec3_f64("N").unwrap(),
        );
        let dev = n1
            .iter()
            .zip(&n2)
            .map(|(a, b)| DVec3::from_array(*a).angle_between(DVec3::from_array(*b)))
            .fold(0.0, f64::max);
        assert!(dev < 1e-5, "frame {k}: normals {dev} rad apart");
        // The areas stretch with the surface.
        let sum: f64 = c.points().scalar_f64("ptarea").unwrap().iter().sum();
        let area: f64 = frame.tri_areas().iter().sum();
        assert!(
            (sum / area - 1.0).abs() < 0.02,
            "frame {k}: {sum} vs {area}"
        );
    }
}

#[test]
fn another_mesh_is_refused_naming_it() {
    let d = tempdir();
    let rest = bent_cylinder(4, 8, 1.0, 0.0);
    let other = bent_cylinder(5, 8, 1.0, 0.3);
    let w = |name: &str, c: &Cloud| {
        std::fs::write(
            d.path().join(name),
            to_bytes(c, pcsss::formats::Format::DEFAULT),
        )
        .unwrap()
    };
    w("rest.ply", &rest);
    w("other.ply", &other);
    w("cloud.ply", &scatter_n(&rest, 100, 1, PtareaMode::Prim));
    let o = run_in(
        Some(d.path()),
        "follow",
        &[
            "cloud.ply",
            "--rest",
            "rest.ply",
            "--mesh",
            "other.ply",
            "-o",
            "out.ply",
        ],
        b"",
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("other.ply") && stderr(&o).contains("not the same mesh"),
        "{}",
        stderr(&o)
    );
    assert!(!d.path().join("out.ply").exists());
    // The frame itself through the binary: the cloud moves.
    w("bent.ply", &bent_cylinder(4, 8, 1.0, 0.3));
    let o = run_in(
        Some(d.path()),
        "follow",
        &[
            "cloud.ply",
            "--rest",
            "rest.ply",
            "--mesh",
            "bent.ply",
            "-o",
            "out.ply",
        ],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let out = from_bytes(&std::fs::read(d.path().join("out.ply")).unwrap());
    assert_eq!(out.len(), 100);
    assert!(out.detail("follow_mesh_digest").is_some());
}

/// The cylinder as OBJ text.
fn obj(c: &Cloud) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    for p in c.points().vec3_f64("P").unwrap() {
        writeln!(s, "v {:?} {:?} {:?}", p[0], p[1], p[2]).unwrap();
    }
    let polys = pcsss::geom::mesh::Polygons::of(c).unwrap();
    for f in 0..polys.len() {
        let v: Vec<String> = polys
            .polygon(f)
            .iter()
            .map(|i| (i + 1).to_string())
            .collect();
        writeln!(s, "f {}", v.join(" ")).unwrap();
    }
    s
}

/// `make frames` on ten frames of the bending cylinder: one cloud
/// scattered on the first, followed through all ten, a picture and a
/// time a frame.
#[test]
fn make_frames_bakes_a_bending_cylinder_on_one_cloud() {
    let d = tempdir();
    let anim = d.path().join("anim");
    std::fs::create_dir(&anim).unwrap();
    for k in 0..10 {
        let angle = std::f64::consts::FRAC_PI_2 * k as f64 / 9.0;
        let text = obj(&bent_cylinder(24, 32, 3.0, angle));
        std::fs::write(anim.join(format!("bend.{:04}.obj", k + 1)), text).unwrap();
    }
    std::fs::write(
        d.path().join("lights.json"),
        r#"{ "lights": [ { "name": "key", "type": "distant", "intensity": 2, "direction": [-0.3, -1, -0.5] } ] }"#,
    )
    .unwrap();
    std::fs::write(
        d.path().join("camera.json"),
        r#"{ "position": [1.5, 1.5, 8], "look_at": [1, 1.5, 0], "fov": 40, "width": 32, "height": 32 }"#,
    )
    .unwrap();
    let out = d.path().join("out");
    let o = std::process::Command::new("make")
        .args(["-s", "-C"])
        .arg(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
        .arg(format!("OUT={}", out.display()))
        .arg(format!("BIN={}", bin("follow").parent().unwrap().display()))
        .arg(format!("FRAMES={}/bend.####.obj", anim.display()))
        .arg(format!("LIGHTS={}", d.path().join("lights.json").display()))
        .arg(format!("CAMERA={}", d.path().join("camera.json").display()))
        .args(["COUNT=3000", "SD=0.1", "SINGLE=0", "frames"])
        .output()
        .expect("make runs");
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
    let times = std::fs::read_to_string(out.join("frames.txt")).unwrap();
    assert_eq!(times.lines().count(), 10, "{times}");
    let rest = from_bytes(&std::fs::read(out.join("rest_cloud.ply")).unwrap());
    let prim = rest.points().scalar_f64("sourceprim").unwrap();
    for k in 1..=10 {
        let name = format!("bend.{k:04}");
        assert!(out.join(format!("{name}.png")).exists(), "{name}");
        let c = from_bytes(&std::fs::read(out.join(format!("{name}_cloud.ply"))).unwrap());
        assert_eq!(c.points().scalar_f64("sourceprim").unwrap(), prim, "{name}");
    }
}
