//! Stability: mean free paths from 1e-8 to 1e8 of the object's size, eta
//! near 1, up to 3 and below 1, g at +-0.999, grazing light and view, a
//! cloud far from the origin, points on a mesh's edges and corners, any
//! thread count, and convergence as the sample count rises.

use super::*;

fn finite(v: &[[f64; 3]]) -> bool {
    v.iter()
        .all(|x| x.iter().all(|c| c.is_finite() && *c >= 0.0))
}

/// Every channel's relative error against the closed form, worst point.
fn worst_against(got: &[[f64; 3]], want: [f64; 3]) -> f64 {
    got.iter()
        .flat_map(|v| (0..3).map(move |c| (v[c] - want[c]).abs() / want[c]))
        .fold(0.0, f64::max)
}

fn physical(mfp: [f64; 3], eta: f64, g: f64, eye_at: DVec3, samples: u32) -> Params {
    Params {
        model: Model::Physical,
        albedo: [0.9, 0.7, 0.5],
        mfp,
        g,
        eta,
        samples,
        eye: eye_at,
        ..Params::default()
    }
}

/// The closed form on the semi-infinite slab (see slab.rs).
fn truth(a: &Angles, cl: [f64; 3], albedo: [f64; 3], g: f64, eta: f64) -> [f64; 3] {
    let p = hg(g, a.cos_phys);
    [0, 1, 2].map(|c| {
        cl[c] * a.mu_i * albedo[c] * a.kti * a.kto * p / (eta * eta * (a.mu_i_t + a.mu_o_t))
    })
}

#[test]
fn mean_free_paths_from_1e_minus_8_to_1e8_of_the_object_stay_finite_and_right() {
    // A slab 10 across and 1 thick: from points near its centre every
    // light path leaves through the top and every view ray through the
    // bottom, so the thin-slab closed form holds for any mean free path,
    // from 1e-8 of the object's size (scattering within 1e-7 of the
    // surface) to 1e8 (almost everything passes through).
    let cl = [1.0; 3];
    let cloud = top_points(3, 0.05, DVec3::ZERO);
    let mesh = slab_mesh(5.0, 1.0, DVec3::ZERO);
    let a = Angles::new(30.0, 20.0, 180.0, 1.33);
    let mut table = Vec::new();
    for rel in [1e-8, 1e-4, 1e-2, 1.0, 1e4, 1e8] {
        let mfp = 10.0 * rel;
        let p = physical([mfp; 3], 1.33, 0.3, eye(20.0, 180.0, DVec3::ZERO), 64);
        let got = run(&cloud, &mesh, &distant(30.0, cl), &p);
        assert!(finite(&got), "mfp {mfp}: {got:?}");
        let thin = -(-(1.0 / mfp) * (1.0 / a.mu_i_t + 1.0 / a.mu_o_t)).exp_m1();
        let want = truth(&a, cl, p.albedo, 0.3, 1.33).map(|x| x * thin);
        let e = worst_against(&got, want);
        table.push(format!(
            "mfp {rel:e} x size: {:.6e} vs {:.6e}, {e:.1e}",
            got[0][0], want[0]
        ));
        assert!(e < 0.01, "{}", table.last().unwrap());
    }
    eprintln!("{}", table.join("\n"));
}

#[test]
fn eta_near_one_up_to_three_and_below_one_gives_finite_answers() {
    let cl = [1.0; 3];
    let cloud = top_points(3, 0.05, DVec3::ZERO);
    let mesh = slab_mesh(20.0, 50.0, DVec3::ZERO);
    for eta in [1.0001, 1.5, 3.0] {
        let p = physical([0.1; 3], eta, 0.0, eye(20.0, 180.0, DVec3::ZERO), 64);
        let got = run(&cloud, &mesh, &distant(30.0, cl), &p);
        let a = Angles::new(30.0, 20.0, 180.0, eta);
        let e = worst_against(&got, truth(&a, cl, p.albedo, 0.0, eta));
        assert!(e < 0.01, "eta {eta}: {e}");
    }
    // Below 1: a view ray past the critical angle is totally reflected
    // (0, not NaN), and so is light arriving past it.
    for (eta, view, light) in [(0.7, 60.0, 10.0), (0.7, 10.0, 60.0), (0.7, 10.0, 20.0)] {
        let p = physical([0.1; 3], eta, 0.0, eye(view, 0.0, DVec3::ZERO), 16);
        let got = run(&cloud, &mesh, &distant(light, cl), &p);
        assert!(finite(&got), "eta {eta} view {view} light {light}: {got:?}");
        let critical = eta.asin().to_degrees();
        let total = view > critical || light > critical;
        assert_eq!(
            got[0][0] == 0.0,
            total,
            "eta {eta} view {view} light {light}: {got:?}"
        );
    }
}

#[test]
fn g_at_the_edges_and_grazing_angles_stay_finite() {
    let cl = [1.0; 3];
    let cloud = top_points(3, 0.05, DVec3::ZERO);
    let mesh = slab_mesh(20.0, 50.0, DVec3::ZERO);
    // Cosines of 1e-6 for the light and the view.
    let grazing = (1e-6f64).acos().to_degrees();
    for g in [-0.999, 0.999] {
        for (ti, to) in [
            (30.0, 20.0),
            (grazing, 20.0),
            (30.0, grazing),
            (grazing, grazing),
        ] {
            for model in [Model::Physical, Model::Seed] {
                let p = Params {
                    model,
                    sd: 0.3,
                    rd: [0.9, 0.5, 0.3],
                    ..physical([0.1; 3], 1.33, g, eye(to, 180.0, DVec3::ZERO), 16)
                };
                let got = run(&cloud, &mesh, &distant(ti, cl), &p);
                assert!(finite(&got), "g {g} in {ti} out {to} {model:?}: {got:?}");
            }
        }
    }
}

#[test]
fn a_cloud_far_from_the_origin_gives_the_same_sss() {
    let cl = [1.0, 0.8, 0.6];
    let lights = distant(30.0, cl);
    for model in [Model::Physical, Model::Seed] {
        let mut base = None;
        for offset in [DVec3::ZERO, DVec3::new(1e6, -1e6, 1e6)] {
            let cloud = top_points(3, 0.05, offset);
            let mesh = slab_mesh(1.0, 1.0, offset);
            let p = Params {
                model,
                sd: 0.3,
                rd: [0.9, 0.5, 0.3],
                rgb: true,
                ..physical([0.05, 0.1, 0.2], 1.33, 0.3, eye(20.0, 180.0, offset), 16)
            };
            let got = run(&cloud, &mesh, &lights, &p);
            match &base {
                None => base = Some(got),
                Some(b) => {
                    for (x, y) in got.iter().zip(b) {
                        for c in 0..3 {
                            assert!(
                                (x[c] - y[c]).abs() <= 1e-5 * y[c].abs(),
                                "{model:?}: {x:?} at 1e6, {y:?} at 0"
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn points_on_edges_and_corners_and_any_thread_count() {
    // A cube's vertices and edge midpoints, with their smooth normals.
    let mesh = slab_mesh(0.5, 1.0, DVec3::ZERO);
    let mut p = Vec::new();
    let mut n = Vec::new();
    for &z in &[0.0, -1.0] {
        for &(x, y) in &[
            (-0.5, -0.5),
            (0.5, -0.5),
            (0.5, 0.5),
            (-0.5, 0.5),
            (0.0, 0.5),
            (0.5, 0.0),
        ] {
            p.push([x, y, z]);
            let v = DVec3::new(x, y, z + 0.5).normalize();
            n.push(v.as_vec3().to_array());
        }
    }
    let mut cloud = Cloud::with_points(p.len());
    cloud.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    cloud.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    let lights = lights::parse(
        r#"{"lights": [{"type": "distant", "name": "a", "direction": [-1, -2, -3]},
                       {"type": "point", "name": "b", "position": [2, 1, 3], "intensity": 9},
                       {"type": "rect", "name": "c", "position": [0, 3, 0], "u": [1, 0, 0], "v": [0, 0, 1], "samples": 4, "two_sided": true}]}"#,
        "test",
    )
    .unwrap();
    for model in [Model::Physical, Model::Seed] {
        let params = Params {
            model,
            sd: 0.5,
            ..physical([0.1, 0.2, 0.3], 1.4, 0.5, DVec3::new(3.0, 2.0, 4.0), 8)
        };
        let mut first: Option<Vec<[f64; 3]>> = None;
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let got = pool.install(|| run(&cloud, &mesh, &lights, &params));
            assert!(finite(&got), "{model:?}: {got:?}");
            assert!(got.iter().any(|v| v[0] > 0.0), "{model:?}: all dark");
            match &first {
                None => first = Some(got),
                Some(f) => assert_eq!(&got, f, "{model:?}, {threads} threads"),
            }
        }
    }
}

#[test]
fn the_error_falls_as_the_samples_rise() {
    let cl = [1.0, 0.8, 0.6];
    let cloud = top_points(4, 0.05, DVec3::ZERO);
    let mesh = slab_mesh(20.0, 50.0, DVec3::ZERO);
    let a = Angles::new(40.0, 25.0, 180.0, 1.33);
    let mut table = vec!["samples | physical, one mfp | physical, three mfps".to_string()];
    let mut errs = Vec::new();
    for samples in [1, 4, 16, 64, 256] {
        let e = |mfp: [f64; 3]| {
            let p = physical(mfp, 1.33, 0.5, eye(25.0, 180.0, DVec3::ZERO), samples);
            let got = run(&cloud, &mesh, &distant(40.0, cl), &p);
            let want = truth(&a, cl, p.albedo, 0.5, 1.33);
            // RMS over points and channels.
            let s: f64 = got
                .iter()
                .flat_map(|v| (0..3).map(move |c| ((v[c] - want[c]) / want[c]).powi(2)))
                .sum();
            (s / (3 * got.len()) as f64).sqrt()
        };
        let (one, three) = (e([0.1; 3]), e([0.05, 0.1, 0.2]));
        table.push(format!("{samples} | {one:.1e} | {three:.1e}"));
        errs.push((one, three));
    }
    eprintln!("{}", table.join("\n"));
    for w in errs.windows(2) {
        assert!(w[1].0 < w[0].0 && w[1].1 < w[0].1, "{}", table.join("\n"));
    }
}
