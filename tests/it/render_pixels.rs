//! `render --spp` and `--pixel-filter`: coverage against the exact
//! fraction of a pixel a square covers, the premultiplied colour, the
//! physical model's beauty as a radiance, and the default filter radius
//! against the cloud's spacing.

use crate::util::*;
use pcsss::progress::Progress;
use pcsss::stages::filter::{self, Params, Reach, Source};
use pcsss::stages::render::{self, Camera, PixelFilter, Pixels, Scene};
use pcsss::{Cloud, DetailValue, Role};

/// The square [-1, 1]^2 at z = 0, seen from (0, 0, 4) by a 32 x 32 camera
/// whose field of view puts its edges through the middle of pixels 3
/// and 28 (x = 1 at 28.5 pixels: tan(fov / 2) = 1.28 / 4).
fn square_scene() -> (Cloud, Camera) {
    (unit_square(), Camera::parse(&camera_text(), "cam").unwrap())
}

fn camera_text() -> String {
    let fov = 2.0 * (0.32f64).atan().to_degrees();
    format!(
        r#"{{"position": [0, 0, 4], "look_at": [0, 0, 0], "fov": {fov}, "width": 32, "height": 32}}"#
    )
}

/// A constant ssM on a grid over the square (and beyond it).
fn constant_cloud(v: [f32; 3]) -> Cloud {
    let mut p = Vec::new();
    for i in 0..41 {
        for j in 0..41 {
            p.push([-1.2 + 0.06 * i as f64, -1.2 + 0.06 * j as f64, 0.0]);
        }
    }
    let mut c = Cloud::with_points(p.len());
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    pts.set_vec3("N", Role::Normal, &vec![[0f32, 0., 1.]; p.len()])
        .unwrap();
    pts.set_vec3("ssM", Role::Color, &vec![v; p.len()]).unwrap();
    c
}

fn picture(mesh: &Cloud, cam: &Camera, cloud: &Cloud, pixels: Pixels) -> Cloud {
    let sources = [Source::Stored("ssM")];
    let scene = Scene {
        mesh,
        mesh_name: "square",
        camera: cam,
        cloud,
        cloud_name: "cloud",
        filter: Params {
            reach: Reach::Nearest(4),
            facing: false,
        },
        sources: &sources,
        direct: None,
        pixels,
    };
    render::render_scene(&scene, &Progress::hidden()).unwrap().0
}

/// (x, y) -> (A, beauty) of an image cloud.
fn pixels_of(img: &Cloud) -> std::collections::HashMap<(i64, i64), (f64, [f64; 3])> {
    let pts = img.points();
    let x = pts.scalar_f64("pixel_x").unwrap();
    let y = pts.scalar_f64("pixel_y").unwrap();
    let a = pts.scalar_f64("A").unwrap();
    let b = pts.vec3_f64("beauty").unwrap();
    (0..img.len())
        .map(|i| ((x[i] as i64, y[i] as i64), (a[i], b[i])))
        .collect()
}

#[test]
fn stratified_samples_cover_an_edge_pixel_by_exactly_its_fraction() {
    let (mesh, cam) = square_scene();
    let ssm = [0.5f32, 0.25, 0.125];
    let cloud = constant_cloud(ssm);
    let img = picture(
        &mesh,
        &cam,
        &cloud,
        Pixels {
            spp: 16,
            filter: PixelFilter::Box,
            seed: 3,
        },
    );
    let px = pixels_of(&img);
    // Inside 4..=27 on both axes: covered whole; on 3 and 28 half (4 x 4
    // strata split by the edge through the middle), the corners a quarter.
    assert_eq!(px.len(), 26 * 26);
    for (&(x, y), &(a, b)) in &px {
        let edge = |v: i64| v == 3 || v == 28;
        let want = match (edge(x), edge(y)) {
            (false, false) => 1.0,
            (true, true) => 0.25,
            _ => 0.5,
        };
        assert_eq!(a, want, "pixel ({x}, {y})");
        for c in 0..3 {
            // Premultiplied: the colour times the coverage.
            assert!(
                (b[c] - want * ssm[c] as f64).abs() < 1e-6,
                "({x}, {y}): {b:?}"
            );
        }
    }
    assert_eq!(
        img.detail("render_spp").map(|d| d.components()),
        Some(vec![16.0])
    );
}

#[test]
fn a_gaussian_pixel_filter_keeps_a_constant_and_halves_at_the_edge() {
    let (mesh, cam) = square_scene();
    let cloud = constant_cloud([1.0, 1.0, 1.0]);
    let img = picture(
        &mesh,
        &cam,
        &cloud,
        Pixels {
            spp: 64,
            filter: PixelFilter::Gaussian,
            seed: 5,
        },
    );
    let px = pixels_of(&img);
    for (&(x, y), &(a, b)) in &px {
        let inside = |v: i64| (6..=25).contains(&v);
        if inside(x) && inside(y) {
            assert!(
                (a - 1.0).abs() < 1e-12 && (b[0] - 1.0).abs() < 1e-6,
                "({x}, {y}): {a} {b:?}"
            );
        }
        // Along an edge, away from the corners: half, to the jitter.
        if (x == 3 || x == 28) && inside(y) {
            assert!((a - 0.5).abs() < 0.03, "({x}, {y}): {a}");
        }
    }
    assert_eq!(
        img.detail("render_pixel_filter"),
        Some(&DetailValue::Str("gaussian".into()))
    );
    // The filter reaches beyond the square: some coverage at 2 and 29.
    assert!(px.keys().any(|&(x, _)| x == 2) && px.keys().any(|&(x, _)| x == 29));
}

#[test]
fn one_sample_a_pixel_hits_where_the_pixel_centres_ray_meets_the_square() {
    // The camera at z = 4 looking down -z with up +y: pixel (x, y)'s
    // centre ray meets z = 0 at (4 u, 4 v), u = (2 (x + 0.5) / 32 - 1)
    // tan(fov / 2), v = (1 - 2 (y + 0.5) / 32) tan(fov / 2), tan = 0.32.
    let (mesh, cam) = square_scene();
    let cloud = constant_cloud([0.5, 0.25, 0.125]);
    let img = picture(&mesh, &cam, &cloud, Pixels::default());
    assert!(!img.points().has("A"));
    let pts = img.points();
    let (x, y) = (
        pts.scalar_f64("pixel_x").unwrap(),
        pts.scalar_f64("pixel_y").unwrap(),
    );
    let p = pts.vec3_f64("P").unwrap();
    let mut inside = 0;
    for px in 0..32 {
        for py in 0..32 {
            let u = (2.0 * (px as f64 + 0.5) / 32.0 - 1.0) * 0.32;
            let v = (1.0 - 2.0 * (py as f64 + 0.5) / 32.0) * 0.32;
            let want = [4.0 * u, 4.0 * v];
            if want.iter().any(|w| (w.abs() - 1.0).abs() < 1e-9) {
                // Pixels 3 and 28: their centres' rays graze the edge.
                continue;
            }
            let hit = want[0].abs() < 1.0 && want[1].abs() < 1.0;
            let at = (0..img.len()).find(|&i| x[i] == px as f64 && y[i] == py as f64);
            assert_eq!(at.is_some(), hit, "pixel ({px}, {py})");
            if let Some(i) = at {
                inside += 1;
                assert!(
                    (p[i][0] - want[0]).abs() < 1e-6
                        && (p[i][1] - want[1]).abs() < 1e-6
                        && p[i][2].abs() < 1e-6,
                    "pixel ({px}, {py}): {:?}",
                    p[i]
                );
            }
        }
    }
    assert_eq!(inside, 24 * 24);
}

#[test]
fn the_physical_models_beauty_is_its_exitance_over_pi() {
    let (mesh, cam) = square_scene();
    let mut cloud = constant_cloud([0.5, 0.25, 0.125]);
    cloud.set_detail(
        "ssmulti_radiance",
        DetailValue::Str(pcsss::stages::ssmulti::RADIANCE.into()),
    );
    let img = picture(&mesh, &cam, &cloud, Pixels::default());
    let b = img.points().vec3_f64("beauty").unwrap();
    let m = img.points().vec3_f64("ssM").unwrap();
    for (b, m) in b.iter().zip(&m) {
        for c in 0..3 {
            assert!((b[c] - m[c] / std::f64::consts::PI).abs() < 1e-7);
        }
    }
    assert_eq!(
        img.detail("render_beauty"),
        Some(&DetailValue::Str("ssM / pi".into()))
    );
}

#[test]
fn render_writes_coverage_as_alpha_in_the_exr_and_the_png() {
    let d = tempdir();
    let mesh = unit_square();
    let cloud = constant_cloud([0.5, 0.25, 0.125]);
    let (m, c, k) = (
        d.path().join("sq.ply"),
        d.path().join("c.ply"),
        d.path().join("cam.json"),
    );
    std::fs::write(&m, to_bytes(&mesh, pcsss::formats::Format::DEFAULT)).unwrap();
    std::fs::write(&c, to_bytes(&cloud, pcsss::formats::Format::DEFAULT)).unwrap();
    std::fs::write(&k, camera_text()).unwrap();
    let (exr, png) = (d.path().join("o.exr"), d.path().join("o.png"));
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (m, k, c, exr_s) = (s(&m), s(&k), s(&c), s(&exr));
    let render_with = |more: &[&str]| {
        let mut a = vec!["--mesh", &m, "--camera", &k, "--cloud", &c, "-o", &exr_s];
        a.extend_from_slice(more);
        run("render", &a, b"")
    };
    let o = render_with(&["--nfp", "4", "--spp", "16", "--png", &s(&png)]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = pcsss::formats::read_cloud_file(&exr, &pcsss::formats::Select::All).unwrap();
    assert_eq!(img.len(), 26 * 26);
    let a = img.points().scalar_f64("A").unwrap();
    assert_eq!(a.iter().filter(|&&x| x == 0.5).count(), 4 * 24);
    let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
    let mut r = dec.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgba);
    let alpha = |x: usize, y: usize| buf[4 * (y * 32 + x) + 3];
    assert_eq!(
        (alpha(10, 10), alpha(28, 10), alpha(28, 3), alpha(0, 0)),
        (255, 128, 64, 0)
    );
    // Bad sample counts are refused naming the option.
    for bad in ["0", "5000"] {
        let o = render_with(&["--spp", bad]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(stderr(&o).contains("--spp"), "{}", stderr(&o));
    }
    // A PNG alone, without -o: the same picture, and no OpenEXR.
    let (alone, exr2) = (d.path().join("alone.png"), d.path().join("o2.exr"));
    let base = [
        "--mesh",
        m.as_str(),
        "--camera",
        &k,
        "--cloud",
        &c,
        "--nfp",
        "4",
        "--spp",
        "16",
    ];
    let mut a = base.to_vec();
    a.extend(["--png", alone.to_str().unwrap()]);
    let o = run("render", &a, b"");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(&alone).unwrap(), std::fs::read(&png).unwrap());
    assert!(!exr2.exists());
    let names: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        names
            .iter()
            .filter(|n| n.to_string_lossy().ends_with(".exr"))
            .count(),
        1
    );
    // Neither: a usage error naming the output.
    let o = run("render", &base, b"");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--output"), "{}", stderr(&o));
}

#[test]
fn the_default_filter_radius_never_falls_below_the_clouds_spacing() {
    // Points 0.06 apart (ptarea 0.0036) with a scattering distance of
    // 0.02: a quarter of it reads no point at most shade points.
    let mut cloud = constant_cloud([1.0, 1.0, 1.0]);
    let n = cloud.len();
    cloud
        .points_mut()
        .set_scalar("ptarea", vec![0.0036f32; n])
        .unwrap();
    cloud.set_detail("ssmulti_sd", DetailValue::F64(0.02));
    let sources = [Source::Stored("ssM")];
    let shade = {
        let (mesh, cam) = square_scene();
        render::render(&mesh, &cam).unwrap().0
    };
    let run_with = |radius: Option<f64>| {
        let setup =
            filter::Setup::new(&cloud, &[], filter::Lazy::default(), None, radius, false).unwrap();
        let mut s = shade.clone();
        let rep = filter::filter(
            &cloud,
            "c",
            &mut s,
            &setup.params,
            &sources,
            &Progress::hidden(),
        )
        .unwrap();
        (setup.params.reach, setup.note, rep.empty)
    };
    let (reach, note, empty) = run_with(None);
    assert_eq!(reach, Reach::Radius(2.0 * (0.0036f32 as f64).sqrt()));
    assert!(note.unwrap().contains("spacing"));
    assert_eq!(empty, 0);
    // Given explicitly, the fraction is honoured, and leaves holes.
    let (reach, note, empty) = run_with(Some(0.25));
    assert_eq!(reach, Reach::Radius(0.25 * 0.02));
    assert!(note.is_none() && empty > 0);
    // The details scatter and promote record win over the points' own.
    let mut c2 = cloud.clone();
    c2.set_detail("Tarea", DetailValue::F64(4.0));
    c2.set_detail("scatter_count", DetailValue::F64(100.0));
    assert_eq!(filter::spacing(&c2), Some(0.2));
}

/// The physical model's ssM (recorded, or computed lazily) is filtered
/// over two spacings by default, however long its kernel; the seed
/// model's over a quarter of D.
#[test]
fn the_physical_models_ssm_is_filtered_over_two_spacings() {
    let mut cloud = constant_cloud([1.0, 1.0, 1.0]);
    cloud.set_detail("Tarea", DetailValue::F64(4.0));
    cloud.set_detail("scatter_count", DetailValue::F64(10_000.0));
    let h = 0.02;
    // A long kernel: a quarter of it is far above two spacings.
    cloud.set_detail("ssmulti_sd", DetailValue::F64(4.0));
    let reach = |c: &pcsss::Cloud, multi: Option<&pcsss::stages::ssmulti::Params>| {
        let lazy = filter::Lazy {
            multi,
            ..filter::Lazy::default()
        };
        filter::Setup::new(c, &[], lazy, None, None, false)
            .unwrap()
            .params
            .reach
    };
    assert_eq!(reach(&cloud, None), Reach::Radius(1.0));
    let mut physical = cloud.clone();
    physical.set_detail("ssmulti_model", DetailValue::Str("physical".into()));
    physical.set_detail("ssmulti_distances", DetailValue::V3D([4.0, 2.0, 1.0]));
    assert_eq!(reach(&physical, None), Reach::Radius(2.0 * h));
    let medium = pcsss::medium::Medium::new([0.9; 3], [1.0; 3], 1.0, 0.0).unwrap();
    let lazy = pcsss::stages::ssmulti::Params {
        medium: Some(medium),
        ..Default::default()
    };
    assert_eq!(reach(&cloud, Some(&lazy)), Reach::Radius(2.0 * h));
}

/// A mesh's vertex colours are the render's beauty: `ssM + ssS` for the
/// seed model, `ssM / pi + ssS` for the physical one (an exitance made
/// radiance), clamped, or tone mapped with `--exposure` as the PNG is.
#[test]
fn vertex_colours_are_the_beauty_tone_mapped_as_the_png() {
    let d = tempdir();
    let (m, s) = ([0.6f32, 0.3, 0.1], [0.05f32, 0.02, 0.01]);
    let mut cloud = constant_cloud(m);
    let n = cloud.len();
    cloud
        .points_mut()
        .set_vec3("ssS", Role::Color, &vec![s; n])
        .unwrap();
    let mesh = to_bytes(&unit_square(), pcsss::formats::Format::DEFAULT);
    let srgb = |x: f64| {
        let x = x.clamp(0.0, 1.0);
        let v = if x <= 0.0031308 {
            12.92 * x
        } else {
            1.055 * x.powf(1.0 / 2.4) - 0.055
        };
        (v * 255.0 + 0.5) as u8
    };
    for (physical, exposure) in [(false, None), (true, None), (true, Some(2.0))] {
        let mut c = cloud.clone();
        if physical {
            c.set_detail(
                "ssmulti_radiance",
                DetailValue::Str(pcsss::stages::ssmulti::RADIANCE.into()),
            );
        }
        let path = d.path().join("c.ply");
        std::fs::write(&path, to_bytes(&c, pcsss::formats::Format::DEFAULT)).unwrap();
        let mut args = vec!["--cloud", path.to_str().unwrap(), "--nfp", "1"];
        let e = exposure.map(|e: f64| e.to_string());
        if let Some(e) = &e {
            args.extend(["--exposure", e]);
        }
        let o = run("filter", &args, &mesh);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = from_bytes(&o.stdout);
        let k = if physical {
            std::f64::consts::FRAC_1_PI
        } else {
            1.0
        };
        for (c, name) in ["red", "green", "blue"].iter().enumerate() {
            let beauty = k * m[c] as f64 + s[c] as f64;
            let x = exposure.map_or(beauty, |e| 1.0 - (-e * beauty).exp());
            let got = out.points().scalar_f64(name).unwrap();
            assert!(
                got.iter().all(|&v| (v - srgb(x) as f64).abs() <= 1.0),
                "{physical} {exposure:?} {name}: {got:?} against {}",
                srgb(x)
            );
        }
    }
}

/// `render --width/--height` set the picture's size in place of the
/// camera's: one alone keeps the camera's aspect, both are taken as
/// given, the vertical field of view stays (the square fills the same
/// share of the height); a side of 0 or past the largest is refused
/// naming it.
#[test]
fn render_takes_the_pictures_size_from_width_and_height() {
    let cam = Camera::parse(
        r#"{"position": [0, 0, 4], "look_at": [0, 0, 0], "width": 512, "height": 256}"#,
        "cam",
    )
    .unwrap();
    let size = |w, h| {
        let c = cam.clone().sized(w, h).unwrap();
        (c.width, c.height, c.fov)
    };
    assert_eq!(size(None, None), (512, 256, cam.fov));
    assert_eq!(size(Some(640), None), (640, 320, cam.fov));
    assert_eq!(size(None, Some(101)), (202, 101, cam.fov));
    assert_eq!(size(Some(7), Some(9)), (7, 9, cam.fov));
    assert_eq!(size(Some(1), None), (1, 1, cam.fov));
    // The aspect would take the width past the largest side: the height
    // given is named.
    let err = cam
        .clone()
        .sized(None, Some(16384))
        .unwrap_err()
        .to_string();
    assert!(err.contains("height") && err.contains("32768"), "{err}");
    let d = tempdir();
    let (m, c, k) = (
        d.path().join("sq.ply"),
        d.path().join("c.ply"),
        d.path().join("cam.json"),
    );
    std::fs::write(
        &m,
        to_bytes(&unit_square(), pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let cloud = constant_cloud([0.5, 0.25, 0.125]);
    std::fs::write(&c, to_bytes(&cloud, pcsss::formats::Format::DEFAULT)).unwrap();
    std::fs::write(&k, camera_text()).unwrap();
    let png = d.path().join("o.png");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let (m, k, c, png_s) = (s(&m), s(&k), s(&c), s(&png));
    let render_with = |more: &[&str]| {
        let mut a = vec![
            "--mesh", &m, "--camera", &k, "--cloud", &c, "--png", &png_s, "--nfp", "4",
        ];
        a.extend_from_slice(more);
        run("render", &a, b"")
    };
    let dims = || {
        let dec = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&png).unwrap()));
        let info = dec.read_info().unwrap();
        (info.info().width, info.info().height)
    };
    for (more, want) in [
        (&["--width", "64"][..], (64, 64)),
        (&["--width", "48", "--height", "24"][..], (48, 24)),
        (&["--height", "20"][..], (20, 20)),
    ] {
        let o = render_with(more);
        assert!(o.status.success(), "{more:?}: {}", stderr(&o));
        assert_eq!(dims(), want, "{more:?}");
    }
    for (more, name) in [
        (&["--width", "0"][..], "--width"),
        (&["--height", "16385"][..], "--height"),
    ] {
        let o = render_with(more);
        assert_eq!(o.status.code(), Some(2), "{more:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(name), "{more:?}: {}", stderr(&o));
    }
}
