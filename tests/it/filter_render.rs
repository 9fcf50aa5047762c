//! `filter` and `render`: the reconstruction against fields whose answer
//! is known (constant, linear), lazy against eager, the camera against a
//! sphere's closed form, the bunny bake against a small golden image.

use glam::DVec3;
use rand_core::RngCore;
use rand_pcg::Pcg32;

use crate::util::*;
use pcsss::progress::Progress;
use pcsss::stages::filter::{self, pcfilter_weight, Params, Reach, Source};
use pcsss::stages::render::{self, Camera};
use pcsss::stages::ssmulti;
use pcsss::{Cloud, Role};

fn unit(r: &mut Pcg32) -> f64 {
    r.next_u32() as f64 / 4294967296.0
}

/// A `k x k` grid of spacing `h` in the z = 0 plane (jittered by
/// `jitter * h`), normals +z, `ssM` from `field`.
fn plane(k: usize, h: f64, jitter: f64, field: impl Fn(DVec3) -> [f32; 3]) -> Cloud {
    let mut r = Pcg32::new(7, 11);
    let mut p = Vec::new();
    for i in 0..k {
        for j in 0..k {
            let dx = (unit(&mut r) - 0.5) * jitter * h;
            let dy = (unit(&mut r) - 0.5) * jitter * h;
            p.push([i as f64 * h + dx, j as f64 * h + dy, 0.0]);
        }
    }
    let mut c = Cloud::with_points(p.len());
    let v: Vec<[f32; 3]> = p.iter().map(|q| field(DVec3::from_array(*q))).collect();
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    pts.set_vec3("N", Role::Normal, &vec![[0f32, 0., 1.]; p.len()])
        .unwrap();
    pts.set_vec3("ssM", Role::Color, &v).unwrap();
    c
}

/// Shade points at the given positions, normals +z.
fn shade_at(p: &[[f64; 3]]) -> Cloud {
    let mut c = Cloud::with_points(p.len());
    c.points_mut().set_vec3("P", Role::Point, p).unwrap();
    c.points_mut()
        .set_vec3("N", Role::Normal, &vec![[0f32, 0., 1.]; p.len()])
        .unwrap();
    c
}

fn filt(
    cloud: &Cloud,
    shade: &Cloud,
    reach: Reach,
    facing: bool,
) -> (Vec<[f64; 3]>, filter::Report) {
    let mut s = shade.clone();
    let rep = filter::filter(
        cloud,
        "cloud",
        &mut s,
        &Params { reach, facing },
        &[Source::Stored("ssM")],
        &Progress::hidden(),
    )
    .unwrap();
    (s.points().vec3_f64("ssM").unwrap(), rep)
}

/// Shade points strewn over the middle of the `k x k` plane.
fn strewn(k: usize, h: f64, n: usize) -> Vec<[f64; 3]> {
    let mut r = Pcg32::new(3, 5);
    let span = (k - 1) as f64 * h;
    (0..n)
        .map(|_| {
            [
                span * (0.3 + 0.4 * unit(&mut r)),
                span * (0.3 + 0.4 * unit(&mut r)),
                0.0,
            ]
        })
        .collect()
}

#[test]
fn pcfilter_weights_are_houdinis() {
    assert_eq!(pcfilter_weight(0.0, 1.0), 1.0);
    // smoothstep(0, 1.1, 0.55) = 0.5.
    assert!((pcfilter_weight(0.55, 1.0) - 0.5).abs() < 1e-15);
    // The farthest point used keeps a little weight: 1 - s(1/1.1).
    let t: f64 = 1.0 / 1.1;
    assert!((pcfilter_weight(1.0, 1.0) - (1.0 - t * t * (3.0 - 2.0 * t))).abs() < 1e-15);
    assert_eq!(pcfilter_weight(0.0, 0.0), 1.0);
}

#[test]
fn a_constant_cloud_filters_to_the_constant_everywhere() {
    let c = plane(40, 0.1, 0.8, |_| [0.7, 0.25, 0.125]);
    let s = shade_at(&strewn(40, 0.1, 500));
    for reach in [Reach::Nearest(1), Reach::Nearest(16), Reach::Radius(0.23)] {
        for facing in [false, true] {
            let (v, rep) = filt(&c, &s, reach, facing);
            assert_eq!(rep.empty, 0);
            for x in &v {
                for (k, want) in [0.7f32, 0.25, 0.125].iter().enumerate() {
                    assert!(
                        (x[k] - *want as f64).abs() < 1e-6,
                        "{reach:?} {facing}: {x:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_linear_ramp_comes_back_at_the_weighted_centroid() {
    // ssM = a . P + b: the filter returns the ramp at the weighted
    // centroid of the points it used (its documented bias), and on an
    // even grid, where the neighbourhoods are balanced, at the shade point.
    let ramp = |q: DVec3| -> f64 { 0.3 + 2.0 * q.x - 0.7 * q.y };
    let field = |q: DVec3| [ramp(q) as f32, 1.0, 0.0];
    let jittered = plane(40, 0.1, 0.8, field);
    let s = strewn(40, 0.1, 300);
    let shade = shade_at(&s);
    let pos = jittered.points().vec3_f64("P").unwrap();
    let val = jittered.points().vec3_f32("ssM").unwrap();
    for reach in [Reach::Nearest(12), Reach::Radius(0.25)] {
        let (v, _) = filt(&jittered, &shade, reach, false);
        let index = filter::CloudIndex::new(&jittered, false, reach).unwrap();
        for (i, q) in s.iter().enumerate() {
            let nb = index.neighbours(DVec3::from_array(*q), None);
            let maxd = nb.iter().map(|a| a.1).fold(0.0, f64::max);
            let (mut c, mut ws) = (DVec3::ZERO, 0.0);
            for &(j, d) in &nb {
                let w = pcfilter_weight(d, maxd);
                c += DVec3::from_array(pos[j as usize]) * w;
                ws += w;
            }
            let c = c / ws;
            // Stored values are f32: compare with the f32 ramp's error.
            let tol = 1e-6
                * nb.iter()
                    .map(|&(j, _)| val[j as usize][0].abs() as f64)
                    .fold(1.0, f64::max);
            assert!(
                (v[i][0] - ramp(c)).abs() < tol,
                "{reach:?}: {} vs {}",
                v[i][0],
                ramp(c)
            );
        }
    }
    // On the even grid, at a grid point's centre of symmetry (the shade
    // point at a cell centre or a node), the bias vanishes.
    let even = plane(40, 0.1, 0.0, field);
    let centres: Vec<[f64; 3]> = (15..25)
        .flat_map(|i| (15..25).map(move |j| [i as f64 * 0.1 + 0.05, j as f64 * 0.1 + 0.05, 0.0]))
        .collect();
    let (a, _) = filt(&even, &shade_at(&centres), Reach::Nearest(16), false);
    let (b, _) = filt(&even, &shade_at(&centres), Reach::Radius(0.25), false);
    for (i, q) in centres.iter().enumerate() {
        let want = ramp(DVec3::from_array(*q));
        assert!((a[i][0] - want).abs() < 1e-5, "nfp {} vs {want}", a[i][0]);
        assert!(
            (b[i][0] - want).abs() < 1e-5,
            "radius {} vs {want}",
            b[i][0]
        );
    }
}

#[test]
fn nfp_and_radius_agree_on_a_uniform_cloud() {
    // A smooth field on an even grid: 12 nearest and radius 0.2 (about 12
    // points) give the same answer to the field's curvature.
    let field = |q: DVec3| [((q.x * 1.3).sin() * (q.y * 0.7).cos()) as f32, 0.5, 0.25];
    let c = plane(60, 0.05, 0.0, field);
    let s = shade_at(&strewn(60, 0.05, 400));
    let (a, _) = filt(&c, &s, Reach::Nearest(12), false);
    let (b, _) = filt(&c, &s, Reach::Radius(0.1), false);
    for (x, y) in a.iter().zip(&b) {
        assert!((x[0] - y[0]).abs() < 2e-3, "{x:?} {y:?}");
        assert!((x[1] - 0.5).abs() < 1e-6 && (y[2] - 0.25).abs() < 1e-6);
    }
}

#[test]
fn facing_keeps_the_far_side_out_and_empty_reach_is_counted() {
    // Two sheets 0.05 apart, facing away from each other, different ssM.
    let mut top = plane(20, 0.1, 0.0, |_| [1.0, 1.0, 1.0]);
    let mut bottom = plane(20, 0.1, 0.0, |_| [0.0, 0.0, 0.0]);
    let shift = |c: &mut Cloud, z: f64, nz: f32| {
        let p: Vec<[f64; 3]> = c
            .points()
            .vec3_f64("P")
            .unwrap()
            .iter()
            .map(|q| [q[0], q[1], z])
            .collect();
        let n = c.len();
        c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
        c.points_mut()
            .set_vec3("N", Role::Normal, &vec![[0f32, 0., nz]; n])
            .unwrap();
    };
    shift(&mut top, 0.05, 1.0);
    shift(&mut bottom, 0.0, -1.0);
    let both = concat(&top, &bottom);
    let s = shade_at(&[[1.0, 1.0, 0.05], [50.0, 50.0, 0.0]]);
    let (v, rep) = filt(&both, &s, Reach::Radius(0.2), true);
    assert_eq!(v[0], [1.0, 1.0, 1.0]);
    assert_eq!(v[1], [0.0, 0.0, 0.0]);
    assert_eq!(rep.empty, 1);
    let (v, _) = filt(&both, &s, Reach::Radius(0.2), false);
    assert!(
        v[0][0] < 0.9,
        "without facing the far sheet bleeds in: {v:?}"
    );
}

fn concat(a: &Cloud, b: &Cloud) -> Cloud {
    let pa = a.points().vec3_f64("P").unwrap();
    let pb = b.points().vec3_f64("P").unwrap();
    let na = a.points().vec3_f32("N").unwrap();
    let nb = b.points().vec3_f32("N").unwrap();
    let va = a.points().vec3_f32("ssM").unwrap();
    let vb = b.points().vec3_f32("ssM").unwrap();
    let mut c = Cloud::with_points(pa.len() + pb.len());
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &[pa, pb].concat()).unwrap();
    pts.set_vec3("N", Role::Normal, &[na, nb].concat()).unwrap();
    pts.set_vec3("ssM", Role::Color, &[va, vb].concat())
        .unwrap();
    c
}

// ---------------------------------------------------------------------
// Lazy evaluation.

/// A lit unit sphere of `n` random points (illum = max(0, z)).
fn sphere(n: usize) -> Cloud {
    let mut r = Pcg32::new(19, 23);
    let p: Vec<[f64; 3]> = (0..n)
        .map(|_| {
            let z = 2.0 * unit(&mut r) - 1.0;
            let phi = 2.0 * std::f64::consts::PI * unit(&mut r);
            let s = (1.0 - z * z).sqrt();
            [s * phi.cos(), s * phi.sin(), z]
        })
        .collect();
    let n32: Vec<[f32; 3]> = p.iter().map(|q| q.map(|x| x as f32)).collect();
    let e: Vec<[f32; 3]> = p.iter().map(|q| [q[2].max(0.0) as f32; 3]).collect();
    let mut c = Cloud::with_points(n);
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    pts.set_vec3("N", Role::Normal, &n32).unwrap();
    pts.set_scalar(
        "ptarea",
        vec![(4.0 * std::f64::consts::PI / n as f64) as f32; n],
    )
    .unwrap();
    pts.set_vec3("illum", Role::Color, &e).unwrap();
    c
}

/// `n` random points on the unit sphere's cap z > 0.5 (a quarter of its
/// area).
fn cap_points(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let mut r = Pcg32::new(seed, 9);
    (0..n)
        .map(|_| {
            let z = 0.5 + 0.5 * unit(&mut r);
            let phi = 2.0 * std::f64::consts::PI * unit(&mut r);
            let s = (1.0 - z * z).sqrt();
            [s * phi.cos(), s * phi.sin(), z]
        })
        .collect()
}

/// `ssM` filtered at `shade` from `full` (which has it) and lazily from
/// `cloud` (which has only `illum`) with `sp`: the two equal to 1e-6, and
/// not all 0; the lazy run's report.
fn eager_equals_lazy(
    cloud: &Cloud,
    full: &Cloud,
    shade: &Cloud,
    params: &Params,
    sp: &ssmulti::Params,
) -> filter::Report {
    let (mut eager, mut lazy) = (shade.clone(), shade.clone());
    let hidden = Progress::hidden();
    let stored = [Source::Stored("ssM")];
    filter::filter(full, "cloud", &mut eager, params, &stored, &hidden).unwrap();
    let multi = [Source::Multi(sp, None)];
    let rep = filter::filter(cloud, "cloud", &mut lazy, params, &multi, &hidden).unwrap();
    let a = eager.points().vec3_f32("ssM").unwrap();
    let b = lazy.points().vec3_f32("ssM").unwrap();
    assert_eq!(a.len(), shade.len());
    assert!(a.iter().flatten().any(|&x| x > 0.0));
    for (x, y) in a.iter().zip(&b) {
        for k in 0..3 {
            assert!(
                (x[k] - y[k]).abs() <= 1e-6 * x[k].abs().max(1e-6),
                "{x:?} {y:?}"
            );
        }
    }
    rep
}

#[test]
fn lazy_equals_eager_and_does_only_the_work_the_view_needs() {
    let cloud = sphere(60_000);
    let sp = ssmulti::Params {
        rd: [1.0, 0.5, 0.25],
        sd: 0.2,
        rgb: true,
        ..Default::default()
    };
    let mut full = cloud.clone();
    ssmulti::ssmulti(&mut full, &sp, &Progress::hidden()).unwrap();
    // Shade points on the cap z > 0.5: a quarter of the sphere's area.
    let cap = cap_points(5000, 5);
    let reach = Reach::Radius(0.05);
    for facing in [false, true] {
        let params = Params { reach, facing };
        let mut shade = shade_at(&cap);
        let nrm: Vec<[f32; 3]> = cap.iter().map(|q| q.map(|x| x as f32)).collect();
        shade
            .points_mut()
            .set_vec3("N", Role::Normal, &nrm)
            .unwrap();
        let rep = eager_equals_lazy(&cloud, &full, &shade, &params, &sp);
        let (_, read, computed) = rep.lazy[0].clone();
        // The cap z > 0.45 (reach 0.05) is 27.5% of the sphere: the points
        // read are about that, and the computed leaves not many more.
        let frac_read = read as f64 / cloud.len() as f64;
        let frac_done = computed as f64 / cloud.len() as f64;
        eprintln!(
            "lazy, facing {facing}: read {frac_read:.3}, computed {frac_done:.3} of the cloud"
        );
        assert!((0.25..0.30).contains(&frac_read), "read {frac_read}");
        assert!(
            frac_done >= frac_read && frac_done < 0.33,
            "computed {frac_done}"
        );
    }
}

#[test]
fn lazy_physical_ssm_equals_the_stored_one() {
    let cloud = sphere(20_000);
    let m = pcsss::medium::Medium::new([0.95, 0.9, 0.8], [0.01, 0.02, 0.03], 1.3, 0.2).unwrap();
    let sp = ssmulti::Params {
        medium: Some(m),
        ..Default::default()
    };
    let mut full = cloud.clone();
    ssmulti::ssmulti(&mut full, &sp, &Progress::hidden()).unwrap();
    let params = Params {
        reach: Reach::Radius(0.05),
        facing: false,
    };
    eager_equals_lazy(&cloud, &full, &shade_at(&cap_points(2000, 6)), &params, &sp);
}

#[test]
fn filter_binary_eager_lazy_mesh_and_errors() {
    let dir = tempdir();
    let cloud = sphere(20_000);
    let cpath = dir.path().join("illum.ply");
    std::fs::write(&cpath, to_bytes(&cloud, LE)).unwrap();
    let c = cpath.to_str().unwrap();
    let shade = to_bytes(&shade_at(&[[0.0, 0.0, 1.0], [0.6, 0.0, 0.8]]), LE);
    // No ssM, no --sd: the error names ssmulti.
    let o = run("filter", &["--cloud", c], &shade);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("ssmulti"), "{}", stderr(&o));
    // Lazy through the binary = eager through the binaries.
    let lazy = run(
        "filter",
        &["--cloud", c, "--sd", "0.2", "--rd", "1,0.5,0.25", "--rgb"],
        &shade,
    );
    assert!(lazy.status.success(), "{}", stderr(&lazy));
    let ss = run(
        "ssmulti",
        &[c, "--sd", "0.2", "--rd", "1,0.5,0.25", "--rgb"],
        b"",
    );
    assert!(ss.status.success(), "{}", stderr(&ss));
    let spath = dir.path().join("ss.ply");
    std::fs::write(&spath, &ss.stdout).unwrap();
    let eager = run("filter", &["--cloud", spath.to_str().unwrap()], &shade);
    assert!(eager.status.success(), "{}", stderr(&eager));
    let (a, b) = (from_bytes(&lazy.stdout), from_bytes(&eager.stdout));
    assert_eq!(
        a.points().vec3_f32("ssM").unwrap(),
        b.points().vec3_f32("ssM").unwrap()
    );
    // --facing needs N on the shade points: names facet.
    let mut bare = Cloud::with_points(1);
    bare.points_mut()
        .set_vec3("P", Role::Point, &[[0f32, 0., 1.]])
        .unwrap();
    let o = run(
        "filter",
        &["--cloud", spath.to_str().unwrap(), "--facing"],
        &to_bytes(&bare, LE),
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("'N'") && stderr(&o).contains("facet"),
        "{}",
        stderr(&o)
    );
    // Absurd parameters.
    for args in [
        &["--nfp", "0"][..],
        &["--radius", "-1"][..],
        &["--radius", "nan"][..],
    ] {
        let mut a = vec!["--cloud", spath.to_str().unwrap()];
        a.extend_from_slice(args);
        let o = run("filter", &a, &shade);
        assert_ne!(o.status.code(), Some(0), "{args:?}");
        assert!(stderr(&o).contains(args[0]), "{args:?}: {}", stderr(&o));
    }
    // A mesh's own vertices: ssM and vertex colours.
    let mesh = std::fs::read(fixtures().join("mesh/icosphere2.obj")).unwrap();
    let o = run("filter", &["--cloud", spath.to_str().unwrap()], &mesh);
    assert!(o.status.success(), "{}", stderr(&o));
    let m = from_bytes(&o.stdout);
    assert!(m.faces().is_some());
    for a in ["ssM", "red", "green", "blue", "N"] {
        assert!(m.points().has(a), "{a}");
    }
}

// ---------------------------------------------------------------------
// render.

#[test]
fn the_camera_sees_a_sphere_as_its_closed_form() {
    // Icosphere level 3 (radius 1) from 5 units: pixels whose ray passes
    // within the sphere's silhouette are covered, P lies on the mesh.
    let mesh = from_bytes(&std::fs::read(fixtures().join("mesh/icosphere3.obj")).unwrap());
    let cam = Camera::parse(
        r#"{"position": [0, 0, 5], "look_at": [0, 0, 0], "fov": 30, "width": 96, "height": 64}"#,
        "cam",
    )
    .unwrap();
    let (shade, rep) = render::render(&mesh, &cam).unwrap();
    assert_eq!(rep.pixels, 96 * 64);
    // The sphere's angular radius asin(1/5); pixels inside it (allow the
    // facets' shortfall of the sphere at the rim: a ring of pixels).
    let mut inside = 0;
    let mut ring = 0;
    let eye = DVec3::new(0.0, 0.0, 5.0);
    for y in 0..64 {
        for x in 0..96 {
            let d = cam.ray(x, y);
            // Distance of the ray from the centre.
            let dist = (eye - d * eye.dot(d)).length();
            inside += (dist < 0.985) as usize;
            ring += (dist < 1.0) as usize;
        }
    }
    assert!(
        rep.covered >= inside && rep.covered <= ring,
        "{} covered, {inside}..{ring} expected",
        rep.covered
    );
    let p = shade.points().vec3_f64("P").unwrap();
    let n = shade.points().vec3_f64("N").unwrap();
    for (q, m) in p.iter().zip(&n) {
        let r = DVec3::from_array(*q).length();
        assert!((0.98..=1.0 + 1e-6).contains(&r), "{r}");
        // Smooth normals point outwards, toward the camera's side.
        assert!(DVec3::from_array(*m).dot(DVec3::from_array(*q)) > 0.95);
        assert!(q[2] > 0.0);
    }
    // Camera files: unknown keys, bad values, named.
    for (text, key) in [
        (
            r#"{"position": [0,0,5], "look_at": [0,0,0], "fov": 200}"#,
            "fov",
        ),
        (r#"{"position": [0,0,5], "look_at": [0,0,5]}"#, "look_at"),
        (r#"{"position": [0,5,0], "look_at": [0,0,0]}"#, "up"),
        (
            r#"{"position": [0,0,5], "look_at": [0,0,0], "width": 0}"#,
            "width",
        ),
        (
            r#"{"position": [0,0,5], "look_at": [0,0,0], "zoom": 2}"#,
            "zoom",
        ),
        (r#"{"position": [0,0], "look_at": [0,0,0]}"#, "position"),
    ] {
        let e = Camera::parse(text, "cam.json").unwrap_err().to_string();
        assert!(e.contains("cam.json") && e.contains(key), "{text}: {e}");
    }
}

#[test]
fn the_bunny_bake_matches_its_small_golden_render() {
    // The whole chain through the binaries at a small size (20,000
    // points, 64 x 64 pixels), against fixtures/golden/bunny_64.exr.
    let dir = tempdir();
    let d = dir.path();
    let bunny = fixtures().join("mesh/bunny.obj");
    let lights = fixtures().join("lights/bunny.json");
    let camera = fixtures().join("cameras/bunny_64.json");
    let s = |p: &std::path::Path| p.to_str().unwrap().to_string();
    let step = |name: &str, args: Vec<String>, stdin: &[u8]| -> Vec<u8> {
        let a: Vec<&str> = args.iter().map(|x| x.as_str()).collect();
        let o = run(name, &a, stdin);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        o.stdout
    };
    let m = step("measure", vec![s(&bunny)], b"");
    let mesh = step(
        "promote",
        vec![
            "--class".into(),
            "face".into(),
            "--attr".into(),
            "area".into(),
            "--as".into(),
            "Tarea".into(),
        ],
        &m,
    );
    let mesh_path = d.join("mesh.ply");
    std::fs::write(&mesh_path, &mesh).unwrap();
    let sc = step(
        "scatter",
        vec![
            s(&mesh_path),
            "-n".into(),
            "20000".into(),
            "--seed".into(),
            "0".into(),
            "--ptarea".into(),
            "voronoi".into(),
            "--relax".into(),
            "3".into(),
        ],
        b"",
    );
    let fc = step("facet", vec!["--mesh".into(), s(&mesh_path)], &sc);
    let cl = step("promote", vec!["--normalize".into()], &fc);
    let il = step(
        "illum",
        vec![
            "--lights".into(),
            s(&lights),
            "--mesh".into(),
            s(&mesh_path),
        ],
        &cl,
    );
    let ss = step(
        "ssmulti",
        vec![
            "--rd".into(),
            "0.9,0.5,0.3".into(),
            "--sd".into(),
            "0.6".into(),
            "--rgb".into(),
        ],
        &il,
    );
    let ss_path = d.join("ss.ply");
    std::fs::write(&ss_path, &ss).unwrap();
    let out = d.join("bunny.exr");
    let png = d.join("bunny.png");
    step(
        "render",
        vec![
            "--mesh".into(),
            s(&mesh_path),
            "--camera".into(),
            s(&camera),
            "--cloud".into(),
            s(&ss_path),
            "-o".into(),
            s(&out),
            "--png".into(),
            s(&png),
        ],
        b"",
    );
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let golden = fixtures().join("golden/bunny_64.exr");
    if std::env::var_os("PCSSS_BLESS").is_some() {
        std::fs::copy(&out, &golden).unwrap();
    }
    // Pixels and their values; the tolerance covers rounding differences
    // between machines (FMA or not), far below what a change of the
    // method would make.
    let o = run(
        "pcdiff",
        &[
            &s(&golden),
            &s(&out),
            "--abs",
            "1e-4",
            "--rel",
            "1e-3",
            "--ignore",
            "filter_reach,filter_facing",
        ],
        b"",
    );
    assert!(
        o.status.success(),
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        stderr(&o)
    );
}

#[test]
fn the_direct_term_adds_kd_times_the_light() {
    // A square at z = 0 seen from above, under a distant light straight
    // down (intensity 2), a cloud of constant ssM on it.
    let mesh = unit_square();
    let cam = Camera::parse(
        r#"{"position": [0, 0, 4], "look_at": [0, 0, 0], "fov": 20, "width": 32, "height": 32}"#,
        "cam",
    )
    .unwrap();
    let (mut shade, rep) = render::render(&mesh, &cam).unwrap();
    assert_eq!(rep.covered, 32 * 32);
    let cloud = plane(30, 0.1, 0.0, |_| [0.5, 0.25, 0.125]);
    // Centre the plane's cloud on the square.
    let p: Vec<[f64; 3]> = cloud
        .points()
        .vec3_f64("P")
        .unwrap()
        .iter()
        .map(|q| [q[0] - 1.45, q[1] - 1.45, 0.0])
        .collect();
    let mut cloud = cloud;
    cloud.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    filter::filter(
        &cloud,
        "cloud",
        &mut shade,
        &Params {
            reach: Reach::Nearest(4),
            facing: false,
        },
        &[Source::Stored("ssM")],
        &Progress::hidden(),
    )
    .unwrap();
    let lights = pcsss::lights::parse(
        r#"{"lights": [{"name": "sun", "type": "distant", "intensity": 2.0, "direction": [0, 0, -1]}]}"#,
        "l.json",
    )
    .unwrap();
    let tris = pcsss::geom::mesh::TriMesh::from_cloud(&mesh).unwrap();
    let occ = pcsss::geom::bvh::Occluder::new(&tris);
    let shadows = pcsss::lights::shadow::Shadows::new(&tris, &occ, None);
    let kd = [0.1, 0.2, 0.4];
    render::beauty(
        &mut shade,
        &[("ssM", 1.0)],
        None,
        Some((&lights, &shadows, kd)),
        &Progress::hidden(),
    )
    .unwrap();
    let b = shade.points().vec3_f64("beauty").unwrap();
    for v in &b {
        for (k, base) in [0.5, 0.25, 0.125].iter().enumerate() {
            assert!((v[k] - (base + 2.0 * kd[k])).abs() < 1e-6, "{v:?}");
        }
    }
    // Without lights the beauty is ssM.
    render::beauty(&mut shade, &[("ssM", 1.0)], None, None, &Progress::hidden()).unwrap();
    let b = shade.points().vec3_f64("beauty").unwrap();
    assert!((b[0][0] - 0.5).abs() < 1e-6);
}

#[test]
fn render_checks_its_inputs_before_working() {
    let dir = tempdir();
    let cam = dir.path().join("cam.json");
    std::fs::write(&cam, r#"{"position": [0, 0, 4], "look_at": [0, 0, 0]}"#).unwrap();
    let mesh = fixtures().join("mesh/icosphere1.obj");
    let out = dir.path().join("o.exr");
    let base = |extra: &[&str]| {
        let mut a = vec![
            "--mesh".to_string(),
            mesh.display().to_string(),
            "--camera".into(),
            cam.display().to_string(),
            "--cloud".into(),
            mesh.display().to_string(),
            "-o".into(),
            out.display().to_string(),
        ];
        a.extend(extra.iter().map(|s| s.to_string()));
        a
    };
    for (extra, want) in [
        (&["--kd", "-1"][..], "--kd"),
        (&["--direct", "/nonexistent/lights.json"][..], "lights.json"),
        (&["--exposure", "0"][..], "--exposure"),
    ] {
        let args = base(extra);
        let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        let o = run("render", &a, b"");
        assert_ne!(o.status.code(), Some(0));
        let e = stderr(&o);
        assert!(
            e.contains(want) && e.trim().lines().count() == 1,
            "{extra:?}: {e}"
        );
        assert!(!out.exists());
    }
    // A cloud without ssM and no --sd: names ssmulti.
    let args = base(&[]);
    let a: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
    let o = run("render", &a, b"");
    assert!(stderr(&o).contains("ssmulti"), "{}", stderr(&o));
}

/// The radius filter against a brute-force f64 pcfilter over every cloud
/// point (independent of the grid that finds the neighbours), on a curved
/// cloud with facing points and shade points inside, at the edge of and
/// beyond the cloud; the same bits on one thread and on two.
#[test]
fn the_radius_filter_equals_brute_force_on_any_threads() {
    let mut r = Pcg32::new(21, 4);
    // A wavy sheet, far from the origin, with a field that varies.
    let off = DVec3::new(3e5, -2e5, 1e5);
    let pts: Vec<DVec3> = (0..6000)
        .map(|_| {
            let (x, y) = (unit(&mut r) * 4.0, unit(&mut r) * 3.0);
            DVec3::new(x, y, 0.3 * (2.0 * x).sin() * y.cos()) + off
        })
        .collect();
    let val: Vec<[f32; 3]> = pts
        .iter()
        .map(|p| {
            let q = *p - off;
            [
                (q.x * q.y) as f32,
                (1.0 + q.z) as f32,
                (q.x - q.y).cos() as f32,
            ]
        })
        .collect();
    let mut cloud = Cloud::with_points(pts.len());
    let arr: Vec<[f64; 3]> = pts.iter().map(|p| p.to_array()).collect();
    cloud.points_mut().set_vec3("P", Role::Point, &arr).unwrap();
    cloud
        .points_mut()
        .set_vec3("ssM", Role::Color, &val)
        .unwrap();
    let shade: Vec<[f64; 3]> = (0..400)
        .map(|_| {
            let (x, y) = (unit(&mut r) * 5.0 - 0.5, unit(&mut r) * 4.0 - 0.5);
            (DVec3::new(x, y, 0.3 * (2.0 * x).sin() * y.cos()) + off).to_array()
        })
        .chain([(off + DVec3::new(50.0, 0.0, 0.0)).to_array()])
        .collect();
    let sc = shade_at(&shade);
    for radius in [0.02, 0.15, 0.6] {
        let reach = Reach::Radius(radius);
        let pool = |n: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap()
        };
        let (one, rep) = pool(1).install(|| filt(&cloud, &sc, reach, false));
        let (two, _) = pool(2).install(|| filt(&cloud, &sc, reach, false));
        let bits =
            |v: &[[f64; 3]]| -> Vec<[u64; 3]> { v.iter().map(|x| x.map(f64::to_bits)).collect() };
        assert_eq!(
            bits(&one),
            bits(&two),
            "radius {radius}: threads changed a bit"
        );
        let mut empty = 0;
        for (i, s) in shade.iter().enumerate() {
            let s = DVec3::from_array(*s);
            let nb: Vec<(usize, f64)> = pts
                .iter()
                .enumerate()
                .map(|(j, p)| (j, (*p - s).length()))
                .filter(|&(_, d)| d <= radius)
                .collect();
            if nb.is_empty() {
                empty += 1;
                assert_eq!(one[i], [0.0; 3], "radius {radius}, shade point {i}");
                continue;
            }
            let maxd = nb.iter().map(|a| a.1).fold(0.0, f64::max);
            let (mut sum, mut ws) = ([0.0f64; 3], 0.0);
            for &(j, d) in &nb {
                let w = pcfilter_weight(d, maxd);
                for c in 0..3 {
                    sum[c] += w * val[j][c] as f64;
                }
                ws += w;
            }
            for c in 0..3 {
                let want = (sum[c] / ws) as f32 as f64;
                assert!(
                    (one[i][c] - want).abs() <= 1e-6 * want.abs().max(1.0),
                    "radius {radius}, shade point {i}, channel {c}: {} vs {want}",
                    one[i][c]
                );
            }
        }
        assert_eq!(rep.empty, empty, "radius {radius}");
    }
}

/// `n` random points on the unit cube's faces, outward normals, lit from
/// above (illum `0.1 + max(0, N.z)`).
fn cube_cloud(n: usize) -> Cloud {
    let mut r = Pcg32::new(29, 31);
    let mut p = Vec::with_capacity(n);
    let mut nrm = Vec::with_capacity(n);
    for k in 0..n {
        let (face, a, b) = (k % 6, unit(&mut r), unit(&mut r));
        let (axis, side) = (face / 2, (face % 2) as f64);
        let mut q = [a, b, a];
        q[axis] = side;
        q[(axis + 1) % 3] = a;
        q[(axis + 2) % 3] = b;
        let mut m = [0.0f32; 3];
        m[axis] = if side > 0.5 { 1.0 } else { -1.0 };
        p.push(q);
        nrm.push(m);
    }
    let e: Vec<[f32; 3]> = nrm.iter().map(|m| [0.1 + m[2].max(0.0); 3]).collect();
    let mut c = Cloud::with_points(n);
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    pts.set_vec3("N", Role::Normal, &nrm).unwrap();
    pts.set_scalar("ptarea", vec![(6.0 / n as f64) as f32; n])
        .unwrap();
    pts.set_vec3("illum", Role::Color, &e).unwrap();
    c
}

/// The walk method lazily (filter and render compute `ssM` by walks only
/// for the cloud points read): the same values as `ssmulti --method
/// walk` stored, with the filter on the cloud and without; only the work
/// the view needs.
#[test]
fn lazy_walks_equal_the_stored_ones() {
    use pcsss::stages::ssmulti::walk::{ssmulti_walk, WalkParams};
    let mesh_cloud = from_bytes(&std::fs::read(fixtures().join("mesh/cube.obj")).unwrap());
    let mesh = pcsss::geom::mesh::TriMesh::from_cloud(&mesh_cloud).unwrap();
    let cloud = cube_cloud(6000);
    let m = pcsss::medium::Medium::new([0.95, 0.9, 0.8], [0.05, 0.08, 0.1], 1.3, 0.0).unwrap();
    let sp = ssmulti::Params {
        medium: Some(m),
        ..Default::default()
    };
    // Shade points on a corner of the top face.
    let mut r = Pcg32::new(3, 4);
    let top: Vec<[f64; 3]> = (0..300)
        .map(|_| [0.3 * unit(&mut r), 0.3 * unit(&mut r), 1.0])
        .collect();
    let params = Params {
        reach: Reach::Radius(0.05),
        facing: false,
    };
    let hidden = Progress::hidden();
    // With and without the filter, evenly and from an eye above.
    for (denoise, eye) in [(false, None), (true, None), (true, Some([0.2, 0.3, 9.0]))] {
        let walk = WalkParams {
            walks: 16,
            seed: 8,
            denoise,
            eye: eye.map(glam::DVec3::from_array),
        };
        let mut full = cloud.clone();
        ssmulti_walk(&mut full, &mesh, &sp, &walk, &hidden).unwrap();
        let (mut eager, mut lazy) = (shade_at(&top), shade_at(&top));
        let stored = [Source::Stored("ssM")];
        filter::filter(&full, "cloud", &mut eager, &params, &stored, &hidden).unwrap();
        let setup = filter::WalkSetup {
            mesh: &mesh,
            walk,
            lights: None,
        };
        let by_walks = [Source::Multi(&sp, Some(&setup))];
        let rep = filter::filter(&cloud, "cloud", &mut lazy, &params, &by_walks, &hidden).unwrap();
        let a = eager.points().vec3_f32("ssM").unwrap();
        let b = lazy.points().vec3_f32("ssM").unwrap();
        assert!(a.iter().flatten().any(|&x| x > 0.0));
        assert_eq!(a, b, "denoise {denoise}, eye {eye:?}");
        let (_, read, computed) = rep.lazy[0].clone();
        assert!(read < cloud.len() / 20, "read {read}");
        // (From an eye, the points read that face away do not walk.)
        if eye.is_none() {
            assert_eq!(computed, read, "denoise {denoise}");
        } else {
            assert!(0 < computed && computed < read, "{computed} of {read}");
        }
    }
}
