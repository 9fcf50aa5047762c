//! The walk method sampling the lights at its events (`ssmulti --method
//! walk --lights`) against independent truth: a flat slab's reflectance
//! (the medium's walk table) under a distant light, through an
//! index-matched and a dielectric boundary; and the lit pole of a ball,
//! where a forward light tracer written here (photons from the sun into
//! the mesh, followed to where they leave) gives the exitance. On the
//! ball the light taken from the cloud where a walk leaves is 7% high
//! (docs/DESIGN.md, "The light a walk takes").

use std::f64::consts::PI;

use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::geom::bvh::{Facing, Occluder};
use pcsss::geom::mesh::TriMesh;
use pcsss::geom::tangent_basis;
use pcsss::lights::Light;
use pcsss::maths::uniform53;
use pcsss::medium::walk::sample_hg;
use pcsss::medium::Medium;
use pcsss::progress::Progress;
use pcsss::stages::ssmulti::walk::{ssmulti_walk_lit, WalkParams};
use pcsss::stages::ssmulti::Params;
use pcsss::Cloud;

fn sun(to_light: [f64; 3]) -> Vec<Light> {
    let t = format!(
        r#"{{"lights": [{{"type": "distant", "name": "sun", "color": [1, 1, 1], "direction": [{}, {}, {}]}}]}}"#,
        -to_light[0], -to_light[1], -to_light[2]
    );
    pcsss::lights::parse(&t, "sun.json").unwrap()
}

/// The mean `ssM` over `cloud` lit by `lights` (through `illum`), walked
/// through `mesh` in `m`, sampling the lights or not.
fn walked(mesh: &TriMesh, mut cloud: Cloud, m: Medium, lights: &[Light], sample: bool) -> [f64; 3] {
    pcsss::stages::illum::illum(&mut cloud, lights, None, 1, &Progress::hidden()).unwrap();
    let p = Params {
        medium: Some(m),
        ..Default::default()
    };
    let w = WalkParams {
        walks: 1000,
        seed: 4,
        ..WalkParams::default()
    };
    let l = sample.then_some(lights);
    ssmulti_walk_lit(&mut cloud, mesh, &p, &w, l, &Progress::hidden()).unwrap();
    let v = cloud.points().vec3_f64("ssM").unwrap();
    let n = v.len() as f64;
    [0, 1, 2].map(|c| v.iter().map(|x| x[c]).sum::<f64>() / n)
}

/// A box 10 wide and 3 deep, its top at z = 0: 200 mean free paths wide
/// and 60 deep at a mean free path of 0.05, a half-space at its middle.
fn slab() -> TriMesh {
    TriMesh::from_cloud(&from_bytes(
        box_obj([-5.0, -5.0, -3.0], [5.0, 5.0, 0.0]).as_bytes(),
    ))
    .unwrap()
}

/// `n` points on the slab's top within a unit of its middle, facing up.
fn on_top(n: usize) -> Cloud {
    let mut r = Pcg32::new(9, 1);
    let (p, nn): (Vec<[f64; 3]>, Vec<[f32; 3]>) = (0..n)
        .map(|_| {
            let x = 2.0 * uniform53(&mut r) - 1.0;
            let y = 2.0 * uniform53(&mut r) - 1.0;
            ([x, y, 0.0], [0.0, 0.0, 1.0])
        })
        .unzip();
    let mut c = Cloud::with_points(n);
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    c.points_mut().set_vec3("N", Role::Normal, &nn).unwrap();
    c
}

#[test]
fn sampled_lights_give_a_flat_slab_its_reflectance() {
    let mfp = 0.05;
    let mesh = slab();
    let top = on_top(40);
    for eta in [1.0, 1.3] {
        for mu in [1.0f64, 0.5] {
            let m = Medium::new([0.95, 0.8, 0.5], [mfp; 3], eta, 0.0).unwrap();
            let c = top.clone();
            let l = sun([(1.0 - mu * mu).sqrt(), 0.0, mu]);
            let got = walked(&mesh, c, m, &l, true);
            let want = m.rm_at(mu).map(|r| r * mu);
            for ch in 0..3 {
                let e = got[ch] / want[ch] - 1.0;
                assert!(
                    e.abs() < 0.015,
                    "eta {eta}, mu {mu}, channel {ch}: {} against rm(mu) E {} ({e:+.4})",
                    got[ch],
                    want[ch]
                );
            }
        }
    }
}

/// The exitance of `n + 2`-event light over the triangles `cap` of `mesh`
/// lit by a sun of irradiance 1 along `-z`, by a forward light tracer:
/// photons over a disc of radius `r` above the mesh, followed from where
/// they enter (eta 1) to where they leave, absorbed by the albedo's odds,
/// scattered by Henyey-Greenstein `g`.
fn traced(mesh: &TriMesh, cap: &[usize], m: &Medium, photons: u64, r: f64) -> f64 {
    let occ = Occluder::new(mesh);
    let in_cap: std::collections::HashSet<usize> = cap.iter().copied().collect();
    let area: f64 = cap
        .iter()
        .map(|&t| {
            let [a, b, c] = mesh.tri(t);
            0.5 * (b - a).cross(c - a).length()
        })
        .sum();
    let sigma = 1.0 / m.mfp[0];
    let hits: u64 = (0..photons / 4096)
        .into_par_iter()
        .map(|k| {
            let mut rng = Pcg32::new(77, k);
            let mut hits = 0u64;
            for _ in 0..4096 {
                let (u, v) = (uniform53(&mut rng), uniform53(&mut rng));
                let (rad, phi) = (r * u.sqrt(), 2.0 * PI * v);
                let from = DVec3::new(rad * phi.cos(), rad * phi.sin(), 10.0);
                let mut d = DVec3::new(0.0, 0.0, -1.0);
                let Some((_, s)) = occ.nearest(from, d, 0.0, f64::INFINITY, Facing::Entering)
                else {
                    continue;
                };
                let mut x = from + d * (s + 1e-7);
                let mut n = 0u32;
                loop {
                    let t = -(1.0 - uniform53(&mut rng)).ln() / sigma;
                    if let Some((tri, _)) = occ.nearest(x, d, 0.0, t, Facing::Leaving) {
                        if n >= 2 && in_cap.contains(&tri) {
                            hits += 1;
                        }
                        break;
                    }
                    x += d * t;
                    n += 1;
                    if uniform53(&mut rng) >= m.albedo[0] {
                        break;
                    }
                    let c = sample_hg(m.g, uniform53(&mut rng));
                    let s = (1.0 - c * c).max(0.0).sqrt();
                    let phi = 2.0 * PI * uniform53(&mut rng);
                    let (t1, t2) = tangent_basis(d);
                    d = (d * c + (t1 * phi.cos() + t2 * phi.sin()) * s).normalize();
                }
            }
            hits
        })
        .sum();
    // Each photon carries the disc's power over their count.
    hits as f64 * (PI * r * r / photons as f64) / area
}

#[test]
fn sampled_lights_on_a_ball_match_a_forward_light_tracer() {
    let mesh = TriMesh::from_cloud(&icosphere(3)).unwrap();
    // The ball's cap facing the sun: the triangles whose middle is within
    // 0.25 of the axis (5 mean free paths).
    let cap: Vec<usize> = (0..mesh.tris.len())
        .filter(|&t| {
            let [a, b, c] = mesh.tri(t);
            let mid = (a + b + c) / 3.0;
            mid.z > 0.0 && mid.x.hypot(mid.y) < 0.25
        })
        .collect();
    for g in [0.0, 0.6] {
        let m = Medium::new([0.95; 3], [0.05; 3], 1.0, g).unwrap();
        let want = traced(&mesh, &cap, &m, 2_000_000, 1.02);
        let l = sun([0.0, 0.0, 1.0]);
        let got = walked(&mesh, points_on_triangles(&mesh, &cap, 200, 5), m, &l, true)[0];
        let old = walked(
            &mesh,
            points_on_triangles(&mesh, &cap, 200, 5),
            m,
            &l,
            false,
        )[0];
        eprintln!("g {g}: traced {want:.4}, sampled {got:.4}, from the cloud {old:.4}");
        let e = got / want - 1.0;
        assert!(
            e.abs() < 0.03,
            "g {g}: the walks sampling the sun give {got:.4}, the light tracer {want:.4} ({e:+.4})"
        );
    }
}

#[test]
fn lights_other_than_illum_s_or_a_mapped_dome_are_refused() {
    let mesh = TriMesh::from_cloud(&icosphere(2)).unwrap();
    let mut c = points_on_triangles(&mesh, &all_triangles(&mesh), 20, 2);
    let m = Medium::new([0.9; 3], [0.05; 3], 1.0, 0.0).unwrap();
    let p = Params {
        medium: Some(m),
        ..Default::default()
    };
    let w = WalkParams {
        walks: 4,
        ..WalkParams::default()
    };
    let hidden = Progress::hidden();
    // A cloud no illum lit.
    let l = sun([0.0, 0.0, 1.0]);
    c.points_mut()
        .set_vec3("illum", Role::Color, &vec![[1f32; 3]; 20])
        .unwrap();
    let e = ssmulti_walk_lit(&mut c.clone(), &mesh, &p, &w, Some(&l), &hidden).unwrap_err();
    assert!(e.to_string().contains("illum_lights_digest"), "{e}");
    // Lit by other lights.
    pcsss::stages::illum::illum(&mut c, &l, None, 1, &hidden).unwrap();
    let other = sun([0.0, 1.0, 0.0]);
    let e = ssmulti_walk_lit(&mut c.clone(), &mesh, &p, &w, Some(&other), &hidden).unwrap_err();
    assert!(e.to_string().contains("not the lights illum lit"), "{e}");
    // The same lights: taken, and recorded.
    ssmulti_walk_lit(&mut c, &mesh, &p, &w, Some(&l), &hidden).unwrap();
    assert!(c.detail("ssmulti_lights_digest").is_some());
}

/// `make METHOD=walk EXIT=eye`: the walks start from the camera's
/// direction, the cloud records the eye, and render takes that ssM for
/// that camera alone (another is refused, naming the camera).
#[test]
fn walks_towards_the_camera_render_for_that_camera_alone() {
    let d = tempdir();
    let out = d.path().join("out");
    let o = std::process::Command::new("make")
        .args(["-s", "-C"])
        .arg(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
        .arg(format!("OUT={}", out.display()))
        .arg(format!("BIN={}", bin("render").parent().unwrap().display()))
        .args([
            "MODEL=physical",
            "METHOD=walk",
            "WALKS=4",
            "EXIT=eye",
            "COUNT=3000",
            "SAMPLES=4",
            "SPP=1",
            "ALBEDO=0.9",
            "MFP=0.2",
            "ETA=1.3",
        ])
        .output()
        .expect("make runs");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let ss = from_bytes(&std::fs::read(out.join("bunny_ss.ply")).unwrap());
    assert!(ss.detail("ssmulti_eye").is_some());
    assert!(ss.detail("ssmulti_lights_digest").is_some());
    // Another camera: refused before any work, exit 2.
    let cam = d.path().join("other.json");
    std::fs::write(
        &cam,
        r#"{"position": [6.0, 8.0, 22.0], "look_at": [0.0, 4.6, 0.0], "up": [0, 1, 0], "fov": 30, "width": 32, "height": 32}"#,
    )
    .unwrap();
    let r = std::process::Command::new(bin("render"))
        .arg("--mesh")
        .arg(out.join("bunny_mesh.ply"))
        .arg("--camera")
        .arg(&cam)
        .arg("--cloud")
        .arg(out.join("bunny_sss.ply"))
        .arg("-o")
        .arg(d.path().join("x.exr"))
        .output()
        .unwrap();
    assert_eq!(
        r.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&r.stderr)
    );
    let msg = String::from_utf8_lossy(&r.stderr);
    assert!(msg.contains("walked towards the eye"), "{msg}");
}

/// Walks from an eye: a point facing away from it does not walk (0, not
/// counted as computed), one facing it does.
#[test]
fn points_facing_away_from_the_eye_do_not_walk() {
    let mesh = TriMesh::from_cloud(&icosphere(2)).unwrap();
    let mut c = points_on_triangles(&mesh, &all_triangles(&mesh), 200, 7);
    let l = sun([0.0, 0.0, 1.0]);
    pcsss::stages::illum::illum(&mut c, &l, None, 1, &Progress::hidden()).unwrap();
    let p = Params {
        medium: Some(Medium::new([0.9; 3], [0.05; 3], 1.0, 0.0).unwrap()),
        ..Default::default()
    };
    let eye = DVec3::new(0.0, 0.0, 10.0);
    let w = WalkParams {
        walks: 8,
        eye: Some(eye),
        ..WalkParams::default()
    };
    let rep = ssmulti_walk_lit(&mut c, &mesh, &p, &w, Some(&l), &Progress::hidden()).unwrap();
    let pos = c.points().vec3_f64("P").unwrap();
    let nrm = c.points().vec3_f64("N").unwrap();
    let ssm = c.points().vec3_f64("ssM").unwrap();
    let facing: Vec<bool> = (0..pos.len())
        .map(|i| DVec3::from_array(nrm[i]).dot(eye - DVec3::from_array(pos[i])) > 0.0)
        .collect();
    assert_eq!(rep.computed, facing.iter().filter(|&&f| f).count());
    assert_eq!(rep.walks, 8 * rep.computed as u64);
    for i in 0..pos.len() {
        if !facing[i] {
            assert_eq!(ssm[i], [0.0; 3], "point {i}");
        }
    }
    // Those facing the eye and the sun are lit.
    assert!((0..pos.len()).any(|i| facing[i] && ssm[i][0] > 0.0));
}

/// One walk serves three channels of different mean free paths (the
/// spectral MIS): on the half-space each channel still returns its own
/// albedo's reflectance, whatever its mean free path (a half-space's
/// reflectance does not depend on it).
#[test]
fn channels_of_different_mean_free_paths_each_return_their_own_reflectance() {
    let mesh = slab();
    let top = on_top(300);
    // skin1's albedos, its mean free paths' spread (red twice blue's) and
    // four times that.
    for mfp in [[0.05, 0.035, 0.025], [0.05, 0.025, 0.0125]] {
        let mu: f64 = 0.85;
        let m = Medium::new([0.9585, 0.838, 0.678], mfp, 1.0, 0.0).unwrap();
        let c = top.clone();
        let l = sun([(1.0 - mu * mu).sqrt(), 0.0, mu]);
        let got = walked(&mesh, c, m, &l, true);
        let want = m.rm_at(mu).map(|r| r * mu);
        for ch in 0..3 {
            let e = got[ch] / want[ch] - 1.0;
            assert!(
                e.abs() < 0.02,
                "mfp {mfp:?}, channel {ch}: {} against rm(mu) E {} ({e:+.4})",
                got[ch],
                want[ch]
            );
        }
    }
}
