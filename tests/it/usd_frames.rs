//! Animated USD stages (issue 60): read at a chosen time code (`--frame`,
//! interpolated as Pixar's library does), refused without one, listed by
//! `pcinfo --time-codes`, and baked frame by frame by `make frames`.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::util::*;
use pcsss::formats::usd;
use pcsss::names;

/// A quad whose points are sampled at 1 and 3 (z 0, then z 2) under a
/// translate sampled at 1 and 3 (x 0, then x 4), on a stage whose frames
/// run 1 to 3; a light whose intensity is sampled too.
fn animated(dir: &Path) -> PathBuf {
    let p = dir.join("anim.usda");
    std::fs::write(
        &p,
        r#"#usda 1.0
(
    startTimeCode = 1
    endTimeCode = 3
    metersPerUnit = 1
    upAxis = "Z"
)
def Xform "W" {
    double3 xformOp:translate.timeSamples = { 1: (0, 0, 0), 3: (4, 0, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
    def Mesh "M" {
        int[] faceVertexCounts = [4]
        int[] faceVertexIndices = [0, 1, 2, 3]
        uniform token subdivisionScheme = "none"
        point3f[] points.timeSamples = { 1: [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)], 3: [(0, 0, 2), (1, 0, 2), (1, 1, 2), (0, 1, 2)] }
    }
}
def DistantLight "Sun" {
    float inputs:intensity.timeSamples = { 1: 1, 3: 3 }
}
"#,
    )
    .unwrap();
    p
}

/// The points' mean of a cloud.
fn mean(c: &pcsss::Cloud) -> [f64; 3] {
    let p = c.points().vec3_f64("P").unwrap();
    let n = p.len() as f64;
    [0, 1, 2].map(|k| p.iter().map(|q| q[k]).sum::<f64>() / n)
}

#[test]
fn a_time_sampled_stage_is_read_at_the_time_code_given_and_refused_without_one() {
    let d = tempdir();
    let p = animated(d.path());
    // Without a time code: refused, naming the prim, the samples and the
    // option.
    let e = usd::read_mesh(&p, None).err().unwrap().to_string();
    assert!(
        e.contains("/W") && e.contains("2 time samples (1 to 3)") && e.contains("--frame"),
        "{e}"
    );
    // At a time code: samples interpolated (points and the transform),
    // held past the last, and the time recorded.
    for (t, want) in [
        (1.0, [0.5, 0.5, 0.0]),
        (2.0, [2.5, 0.5, 1.0]),
        (3.0, [4.5, 0.5, 2.0]),
        (7.0, [4.5, 0.5, 2.0]),
    ] {
        let m = usd::at_time(Some(t), || usd::read_mesh(&p, None)).unwrap();
        let got = mean(&m.cloud);
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 1e-9,
                "t {t}: {got:?} against {want:?}"
            );
        }
        assert_eq!(
            m.cloud.detail(names::D_USD_TIME),
            Some(&pcsss::cloud::DetailValue::F64(t))
        );
    }
    // The time is the caller's: restored after, and not kept by a read
    // that followed.
    assert_eq!(usd::stage::time(), None);
    let still = d.path().join("still.usda");
    std::fs::write(
        &still,
        "#usda 1.0\ndef Mesh \"M\" {\n int[] faceVertexCounts = [3]\n int[] faceVertexIndices = [0, 1, 2]\n \
         uniform token subdivisionScheme = \"none\"\n point3f[] points = [(0, 0, 0), (1, 0, 0), (0, 1, 0)]\n}\n",
    )
    .unwrap();
    // A stage without samples reads the same at any time code.
    let a = usd::read_mesh(&still, None).unwrap();
    let b = usd::at_time(Some(5.0), || usd::read_mesh(&still, None)).unwrap();
    assert_eq!(mean(&a.cloud), mean(&b.cloud));
    assert_eq!(a.cloud.detail(names::D_USD_TIME), None);
    // The lights too.
    let intensity = |t: f64| -> f64 {
        let l = usd::at_time(Some(t), || usd::lights_json(&p)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&l).unwrap();
        v["lights"][0]["intensity"].as_f64().unwrap()
    };
    let r = intensity(2.0) / intensity(1.0);
    assert!((r - 2.0).abs() < 1e-6, "{r}");
    let e = usd::lights_json(&p).err().unwrap().to_string();
    assert!(e.contains("/Sun") && e.contains("--frame"), "{e}");
}

#[test]
fn the_stages_take_frame_and_pcinfo_lists_the_time_codes() {
    let d = tempdir();
    let p = animated(d.path());
    let ps = p.to_str().unwrap();
    let out = d.path().join("m.ply");
    let o = run(
        "measure",
        &["-q", "--frame", "2", ps, "-o", out.to_str().unwrap()],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let c = pcsss::formats::read_cloud_file(&out, &pcsss::formats::Select::All).unwrap();
    assert!((mean(&c)[0] - 2.5).abs() < 1e-6, "{:?}", mean(&c));
    // Without --frame: a file's failure (exit 1), naming the option.
    let o = run("measure", &["-q", ps], b"");
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--frame"), "{}", stderr(&o));
    // Not a time code: a parameter's (exit 2).
    for bad in ["nan", "inf", "x"] {
        let o = run("measure", &["-q", "--frame", bad, ps], b"");
        assert_eq!(o.status.code(), Some(2), "{bad}: {}", stderr(&o));
        assert!(stderr(&o).contains("--frame"), "{}", stderr(&o));
    }
    // The frames.
    let o = run("pcinfo", &["--time-codes", ps], b"");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(String::from_utf8_lossy(&o.stdout), "1\n2\n3\n");
    // A stage that states none, and a file that is not a stage.
    let none = d.path().join("none.usda");
    std::fs::write(&none, "#usda 1.0\ndef Xform \"W\" {\n}\n").unwrap();
    let o = run("pcinfo", &["--time-codes", none.to_str().unwrap()], b"");
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("startTimeCode"), "{}", stderr(&o));
    let obj = fixtures().join("mesh/cube.obj");
    let o = run("pcinfo", &["--time-codes", obj.to_str().unwrap()], b"");
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("not a USD stage"), "{}", stderr(&o));
}

/// `make frames FRAMES=anim.usda` bakes each of the stage's frames on one
/// cloud: the same points, each at its own frame's place and time.
#[test]
fn make_frames_bakes_an_animated_stage_frame_by_frame() {
    let d = tempdir();
    let ball = d.path().join("ball.usda");
    // The icosphere, moved along x by a sampled translate.
    let obj = std::fs::read_to_string(fixtures().join("mesh/icosphere2.obj")).unwrap();
    let (mut pts, mut counts, mut idx) = (Vec::new(), Vec::new(), Vec::new());
    for l in obj.lines() {
        let w: Vec<&str> = l.split_whitespace().collect();
        match w.first() {
            Some(&"v") => pts.push(format!("({}, {}, {})", w[1], w[2], w[3])),
            Some(&"f") => {
                counts.push((w.len() - 1).to_string());
                for c in &w[1..] {
                    let i: usize = c.split('/').next().unwrap().parse().unwrap();
                    idx.push((i - 1).to_string());
                }
            }
            _ => {}
        }
    }
    std::fs::write(
        &ball,
        format!(
            "#usda 1.0\n(\n startTimeCode = 1\n endTimeCode = 3\n metersPerUnit = 1\n upAxis = \"Y\"\n)\n\
             def Mesh \"Ball\" {{\n int[] faceVertexCounts = [{}]\n int[] faceVertexIndices = [{}]\n \
             point3f[] points = [{}]\n uniform token subdivisionScheme = \"none\"\n \
             double3 xformOp:translate.timeSamples = {{ 1: (0, 0, 0), 3: (0.5, 0, 0) }}\n \
             uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}}\n",
            counts.join(", "),
            idx.join(", "),
            pts.join(", ")
        ),
    )
    .unwrap();
    let out = d.path().join("out");
    let o = Command::new("make")
        .args(["-s", "-C"])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
        .arg("frames")
        .arg(format!("FRAMES={}", ball.display()))
        .arg(format!("OUT={}", out.display()))
        .arg(format!(
            "BIN={}",
            bin("ssmulti").parent().unwrap().display()
        ))
        .args(["COUNT=2000", "SINGLE=0", "PROGRESS=0"])
        .env_remove("MAKEFLAGS")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let frames = std::fs::read_to_string(out.join("frames.txt")).unwrap();
    assert_eq!(frames.lines().count(), 3, "{frames}");
    let rest =
        pcsss::formats::read_cloud_file(&out.join("rest_cloud.ply"), &pcsss::formats::Select::All)
            .unwrap();
    let rp = rest.points().vec3_f64("P").unwrap();
    for (k, t) in [1.0, 2.0, 3.0].iter().enumerate() {
        let f = out.join(format!("ball.{:04}_cloud.ply", k + 1));
        let c = pcsss::formats::read_cloud_file(&f, &pcsss::formats::Select::All).unwrap();
        assert_eq!(
            c.detail(names::D_USD_TIME),
            Some(&pcsss::cloud::DetailValue::F64(*t))
        );
        // The same points, moved by the frame's translate.
        let cp = c.points().vec3_f64("P").unwrap();
        assert_eq!(cp.len(), rp.len());
        let dx = 0.25 * (*t - 1.0);
        for (a, b) in cp.iter().zip(&rp) {
            assert!(
                (a[0] - b[0] - dx).abs() < 1e-5 && (a[1] - b[1]).abs() < 1e-5,
                "{a:?} {b:?}"
            );
        }
        assert!(out.join(format!("ball.{:04}.png", k + 1)).exists());
    }
}

/// A USD camera's picture: without render settings, 512 pixels high at
/// the apertures' aspect; with a `RenderSettings` prim naming the camera,
/// its `resolution`, the aperture conformed to it as USD does (expanded by
/// default, cropped on request); settings that cannot be read are named.
#[test]
fn a_usd_camera_takes_the_render_settings_that_name_it() {
    let d = tempdir();
    let cam = |settings: &str| -> Result<serde_json::Value, String> {
        let p = d.path().join("cam.usda");
        std::fs::write(
            &p,
            format!(
                r#"#usda 1.0
def Camera "Cam" {{
    float focalLength = 50
    float horizontalAperture = 36
    float verticalAperture = 24
}}
{settings}
"#
            ),
        )
        .unwrap();
        usd::camera_json(&p, 512)
            .map(|t| serde_json::from_str(&t).unwrap())
            .map_err(|e| e.to_string())
    };
    let fov = |v_ap: f64| 2.0 * (v_ap / 100.0f64).atan().to_degrees();
    let close = |a: &serde_json::Value, b: f64| (a.as_f64().unwrap() - b).abs() < 1e-9;
    // None: 768 x 512, the apertures' 3:2.
    let c = cam("").unwrap();
    assert_eq!(
        (c["width"].as_u64(), c["height"].as_u64()),
        (Some(768), Some(512))
    );
    assert!(close(&c["fov"], fov(24.0)), "{c}");
    // A square picture: expanded, the vertical aperture grows to 36.
    let square = r#"def RenderSettings "Render" {
    rel camera = </Cam>
    uniform int2 resolution = (300, 300)
}"#;
    let c = cam(square).unwrap();
    assert_eq!(
        (c["width"].as_u64(), c["height"].as_u64()),
        (Some(300), Some(300))
    );
    assert!(close(&c["fov"], fov(36.0)), "{c}");
    // Cropped: it keeps 24.
    let crop = square.replace(
        "(300, 300)",
        "(300, 300)\n    uniform token aspectRatioConformPolicy = \"cropAperture\"",
    );
    assert!(close(&cam(&crop).unwrap()["fov"], fov(24.0)));
    // A wider picture, expanded: the vertical aperture stays.
    let wide = square.replace("(300, 300)", "(1920, 800)");
    let c = cam(&wide).unwrap();
    assert_eq!(
        (c["width"].as_u64(), c["height"].as_u64()),
        (Some(1920), Some(800))
    );
    assert!(close(&c["fov"], fov(24.0)), "{c}");
    // Settings for another camera are not this one's.
    assert_eq!(
        cam(&square.replace("</Cam>", "</Other>")).unwrap()["height"].as_u64(),
        Some(512)
    );
    // Unread or bad settings are named.
    let e = cam(&square.replace(
        "(300, 300)",
        "(300, 300)\n    uniform float pixelAspectRatio = 2",
    ))
    .unwrap_err();
    assert!(
        e.contains("/Render") && e.contains("pixelAspectRatio"),
        "{e}"
    );
    let e = cam(&square.replace("(300, 300)", "(0, 300)")).unwrap_err();
    assert!(e.contains("resolution"), "{e}");
    let e = cam(&square.replace(
        "(300, 300)",
        "(300, 300)\n    uniform token aspectRatioConformPolicy = \"adjustPixelAspectRatio\"",
    ))
    .unwrap_err();
    assert!(e.contains("adjustPixelAspectRatio"), "{e}");
    let two = format!("{square}\n{}", square.replace("\"Render\"", "\"Render2\""));
    let e = cam(&two).unwrap_err();
    assert!(e.contains("renderSettingsPrimPath"), "{e}");
}
