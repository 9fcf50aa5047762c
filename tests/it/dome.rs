//! The dome light (formats/LIGHTS.md#dome) against closed forms: a plane
//! under a constant dome receives `pi L`; under a map bright above the
//! horizon alone, `pi L` facing up and `pi L / 2` facing sideways; under
//! a map of `L cos(theta)`, `2 pi / 3`; a square overhead shadows it by
//! its view factor. Through the binaries, the map is read beside the
//! lights file and a bad one is named.

use std::f64::consts::PI;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::lights;
use pcsss::progress::Progress;
use pcsss::stages::illum;
use pcsss::Cloud;

/// `n` points at the origin with normal `normal`.
fn points(n: usize, normal: [f32; 3]) -> Cloud {
    let mut c = Cloud::with_points(n);
    c.points_mut()
        .set_vec3("P", Role::Point, &vec![[0.0f32; 3]; n])
        .unwrap();
    c.points_mut()
        .set_vec3("N", Role::Normal, &vec![normal; n])
        .unwrap();
    c
}

/// Writes a lat-long map (RGB float OpenEXR) of `w` x `h` texels whose
/// value at texel centre `(u, v)` is `f(u, v)`.
fn write_map(path: &std::path::Path, w: usize, h: usize, f: impl Fn(f64, f64) -> f32 + Sync) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let v = f((x as f64 + 0.5) / w as f64, (y as f64 + 0.5) / h as f64);
        (v, v, v)
    })
    .unwrap();
}

/// Mean illum (red) over the points.
fn mean_illum(c: &Cloud) -> f64 {
    let e = c.points().vec3_f64("illum").unwrap();
    e.iter().map(|v| v[0]).sum::<f64>() / e.len() as f64
}

fn lit(mut c: Cloud, lights: &[lights::Light], shadows: Option<&illum::Shadows>) -> Cloud {
    illum::illum(&mut c, lights, shadows, 7, &Progress::hidden()).unwrap();
    c
}

#[test]
fn a_constant_dome_gives_pi_l_on_a_plane_and_a_square_overhead_its_view_factor() {
    let l = lights::parse(
        r#"{ "lights": [ { "name": "sky", "type": "dome", "color": [0.5, 0.25, 1.0], "intensity": 2 } ] }"#,
        "sky.json",
    )
    .unwrap();
    // Unshadowed, every cosine-drawn ray brings pi L / samples: exact.
    let c = lit(points(10, [0.0, 0.0, 1.0]), &l, None);
    for e in c.points().vec3_f64("illum").unwrap() {
        for (k, want) in [1.0, 0.5, 2.0].iter().enumerate() {
            assert!((e[k] - PI * want).abs() < 1e-6 * PI * want, "{e:?}");
        }
    }
    // A square of half-side 1 at height 1 over the point hides the
    // sky by its view factor F = (2 / pi) (2 X / sqrt(1 + X^2)) atan(Y / sqrt(1 + X^2)), X = Y = 1.
    let sq = mesh_from(
        &[
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ],
        &[vec![0, 1, 2, 3]],
    );
    let tris = pcsss::geom::mesh::TriMesh::from_cloud(&sq).unwrap();
    let occ = illum::occluder(&tris).unwrap();
    let shadows = illum::Shadows::new(&tris, &occ, None);
    let s2 = 2f64.sqrt();
    let f = 2.0 / PI * (2.0 / s2 * (1.0 / s2).atan());
    let c = lit(points(4000, [0.0, 0.0, 1.0]), &l, Some(&shadows));
    let got = mean_illum(&c);
    let want = PI * 1.0 * (1.0 - f);
    assert!((got / want - 1.0).abs() < 0.01, "{got} vs {want} (F = {f})");
}

#[test]
fn a_map_is_drawn_by_its_light_and_agrees_with_closed_forms() {
    let d = tempdir();
    // Above the horizon (v < 1/2) radiance 1, below black.
    write_map(&d.path().join("half.exr"), 64, 32, |_, v| {
        if v < 0.5 {
            1.0
        } else {
            0.0
        }
    });
    // Radiance cos(theta) above the horizon.
    write_map(&d.path().join("cos.exr"), 64, 128, |_, v| {
        if v < 0.5 {
            (PI * v).cos() as f32
        } else {
            0.0
        }
    });
    let read = |map: &str, extra: &str| {
        let text = format!(
            r#"{{ "up_axis": "z", "lights": [ {{ "name": "sky", "type": "dome", "map": "{map}" {extra} }} ] }}"#
        );
        lights::parse_file_in(&text, "sky.json", Some(d.path()))
            .unwrap()
            .in_frame(&pcsss::frame::Frame {
                up: Some(pcsss::frame::UpAxis::Z),
                meters_per_unit: None,
            })
    };
    // The file's up axis is z and the cloud's too: the map's top is +Z.
    let half = read("half.exr", "");
    let up = mean_illum(&lit(points(2000, [0.0, 0.0, 1.0]), &half, None));
    assert!((up / PI - 1.0).abs() < 0.01, "facing up: {up}");
    let side = mean_illum(&lit(points(2000, [1.0, 0.0, 0.0]), &half, None));
    assert!(
        (side / (PI / 2.0) - 1.0).abs() < 0.01,
        "facing sideways: {side}"
    );
    let down = mean_illum(&lit(points(200, [0.0, 0.0, -1.0]), &half, None));
    assert!(down.abs() < 1e-12, "facing down: {down}");
    // Turning the map about its up axis changes nothing here.
    let turned = read("half.exr", r#", "rotation": 70"#);
    let side2 = mean_illum(&lit(points(2000, [1.0, 0.0, 0.0]), &turned, None));
    assert!((side2 / (PI / 2.0) - 1.0).abs() < 0.01, "{side2}");
    // L = cos(theta): the integral of cos^2 over the upper hemisphere.
    let cos = read("cos.exr", r#", "samples": 256"#);
    let e = mean_illum(&lit(points(2000, [0.0, 0.0, 1.0]), &cos, None));
    assert!((e / (2.0 * PI / 3.0) - 1.0).abs() < 0.01, "cos map: {e}");
}

#[test]
fn a_dome_through_the_binaries_reads_its_map_beside_the_lights_file() {
    let d = tempdir();
    std::fs::create_dir(d.path().join("sky")).unwrap();
    write_map(&d.path().join("sky/map.exr"), 32, 16, |u, v| {
        if v < 0.5 {
            1.0 + 20.0 * (u < 0.1) as u8 as f32
        } else {
            0.05
        }
    });
    std::fs::write(
        d.path().join("sky/lights.json"),
        r#"{ "lights": [ { "name": "sky", "type": "dome", "map": "map.exr", "samples": 32 } ] }"#,
    )
    .unwrap();
    std::fs::write(d.path().join("sky/black.exr"), b"").unwrap();
    let cube = fixtures().join("mesh/cube.obj").display().to_string();
    let b = |n: &str| bin(n).display().to_string();
    shell(
        d.path(),
        &format!(
            "{s} {cube} -n 500 | {f} --mesh {cube} -o cloud.ply && \
             {i} cloud.ply --lights sky/lights.json --mesh {cube} -o lit.ply",
            s = b("scatter"),
            f = b("facet"),
            i = b("illum"),
        ),
    );
    let lit = from_bytes(&std::fs::read(d.path().join("lit.ply")).unwrap());
    let e = lit.points().vec3_f64("illum").unwrap();
    let n = lit.points().vec3_f64("N").unwrap();
    // The cube's top sees the bright sky, its bottom the dim ground.
    let mean = |up: bool| {
        let v: Vec<f64> = e
            .iter()
            .zip(&n)
            .filter(|(_, n)| if up { n[1] > 0.9 } else { n[1] < -0.9 })
            .map(|(e, _)| e[0])
            .collect();
        v.iter().sum::<f64>() / v.len() as f64
    };
    let (top, bottom) = (mean(true), mean(false));
    assert!(top > 2.0 && bottom < 0.5 && bottom > 0.0, "{top} {bottom}");
    // A missing or bad map is named, with no output.
    for (map, says) in [("nothing.exr", "nothing.exr"), ("black.exr", "black.exr")] {
        std::fs::write(
            d.path().join("sky/bad.json"),
            format!(r#"{{ "lights": [ {{ "name": "sky", "type": "dome", "map": "{map}" }} ] }}"#),
        )
        .unwrap();
        let o = run_in(
            Some(d.path()),
            "illum",
            &[
                "cloud.ply",
                "--lights",
                "sky/bad.json",
                "--no-shadows",
                "-o",
                "bad.ply",
            ],
            b"",
        );
        assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
        assert!(
            stderr(&o).contains(says) && stderr(&o).contains("lights[0].map"),
            "{}",
            stderr(&o)
        );
        assert!(!d.path().join("bad.ply").exists());
    }
}
