//! Shadowed single scattering: light that enters a slab is first traced
//! from where it enters to the light, so a plate between the light and
//! the slab darkens the points beneath it (to exactly 0 in the seed
//! model, where the mesh is opaque; in the physical model by what crosses
//! the plate's medium, per channel), and leaves the points it does not
//! hide bit for bit as they are without it. `--no-shadows` (Marengo's
//! estimator) ignores the plate entirely.

use super::*;

/// The corners and outward quads of the box `lo..hi`, its vertex
/// numbers starting at `base`.
fn cuboid(lo: DVec3, hi: DVec3, base: i32) -> (Vec<[f64; 3]>, Vec<Vec<i32>>) {
    let mut p = Vec::new();
    for &z in &[lo.z, hi.z] {
        for &(x, y) in &[(lo.x, lo.y), (hi.x, lo.y), (hi.x, hi.y), (lo.x, hi.y)] {
            p.push([x, y, z]);
        }
    }
    let quads = [
        [4, 5, 6, 7],
        [0, 3, 2, 1],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    (
        p,
        quads
            .iter()
            .map(|q| q.iter().map(|&i| i + base).collect())
            .collect(),
    )
}

/// The slab `[-1, 1]^2 x [-0.5, 0]`, with a plate over its `x < 0` half
/// (`[-3, 0] x [-3, 3] x [1, 1.1]`) when `plate`.
fn scene(plate: bool) -> Cloud {
    let (mut p, mut f) = cuboid(DVec3::new(-1.0, -1.0, -0.5), DVec3::new(1.0, 1.0, 0.0), 0);
    if plate {
        let (q, g) = cuboid(DVec3::new(-3.0, -3.0, 1.0), DVec3::new(0.0, 3.0, 1.1), 8);
        p.extend(q);
        f.extend(g);
    }
    mesh_from(&p, &f)
}

fn point_light() -> Vec<Light> {
    lights::parse(
        r#"{"lights": [{"type": "point", "name": "bulb", "color": [1, 0.5, 0.25], "position": [0, 0, 2]}]}"#,
        "test",
    )
    .unwrap()
}

#[test]
fn a_plate_between_light_and_slab_shadows_exactly_what_it_hides() {
    // The plate's edge (x = 0 at z = 1) casts its shadow's edge to x = 0
    // on the slab for the bulb at (0, 0, 2), and for light straight down.
    let cloud = top_points(24, 0.9, DVec3::ZERO);
    let xs: Vec<f64> = cloud
        .points()
        .vec3_f64("P")
        .unwrap()
        .iter()
        .map(|p| p[0])
        .collect();
    let physical = Params {
        model: Model::Physical,
        albedo: [0.9, 0.6, 0.3],
        mfp: [0.01, 0.02, 0.03],
        eta: 1.3,
        g: 0.2,
        samples: 16,
        eye: eye(20.0, 30.0, DVec3::ZERO),
        ..Params::default()
    };
    let seed = Params {
        model: Model::Seed,
        rd: [0.9, 0.6, 0.3],
        sd: 0.05,
        rgb: true,
        ..physical.clone()
    };
    let lights_of = [point_light(), distant(0.0, [1.0, 0.5, 0.25])];
    for p in [&physical, &seed] {
        for ls in &lights_of {
            let unshadowed = Params {
                shadows: false,
                ..p.clone()
            };
            let bare = run(&cloud, &scene(false), ls, p);
            let shaded = run(&cloud, &scene(true), ls, p);
            let ignored = run(&cloud, &scene(true), ls, &unshadowed);
            let what = format!("{:?}, {}", p.model, ls[0].name);
            // Without the plate, shadow rays find nothing.
            assert_eq!(bare, run(&cloud, &scene(false), ls, &unshadowed), "{what}");
            // --no-shadows: the plate changes nothing.
            assert_eq!(ignored, bare, "{what}");
            let (mut dark, mut lit) = (0, 0);
            for (i, &x) in xs.iter().enumerate() {
                assert!(bare[i].iter().all(|&v| v > 0.0), "{what}: point {i} unlit");
                // Light enters within a few mean free paths (or, seed,
                // scattering distances) of the point.
                if x < -0.15 {
                    match p.model {
                        Model::Seed => {
                            assert_eq!(shaded[i], [0.0; 3], "{what}: point {i} at x {x}")
                        }
                        Model::Physical => {
                            // Through the plate (0.1 thick) at cosines
                            // from 1 down to 0.85 (the bulb's slant over
                            // where light enters): exp(-0.1 / (cos mfp))
                            // and Fresnel in and out, per channel.
                            let through = |cos: f64, c: usize| {
                                let t = fresnel_t(cos.acos(), p.eta);
                                (-0.1 / (cos * p.mfp[c])).exp() * t * t
                            };
                            for c in 0..3 {
                                let (lo, hi) = (through(0.85, c), through(1.0, c));
                                // (ssS is stored as f32.)
                                let r = shaded[i][c] / bare[i][c];
                                assert!(
                                    r >= lo * (1.0 - 1e-6) && r <= hi * (1.0 + 1e-6),
                                    "{what}: point {i} channel {c}: {r} not in [{lo}, {hi}]"
                                );
                                if ls[0].name == "sun" {
                                    assert!(
                                        (r / hi - 1.0).abs() < 1e-6,
                                        "{what}: point {i} channel {c}: {r} against {hi}"
                                    );
                                }
                            }
                        }
                    }
                    dark += 1;
                } else if x > 0.15 {
                    assert_eq!(shaded[i], bare[i], "{what}: point {i} at x {x}");
                    lit += 1;
                }
            }
            assert!(dark > 200 && lit > 200, "{what}: {dark} dark, {lit} lit");
        }
    }
}

#[test]
fn the_report_counts_the_shadow_rays_and_what_they_found() {
    let cloud = top_points(8, 0.9, DVec3::ZERO);
    let m = TriMesh::from_cloud(&scene(true)).unwrap();
    let p = Params {
        model: Model::Physical,
        mfp: [0.01; 3],
        eye: eye(0.0, 0.0, DVec3::ZERO),
        ..Params::default()
    };
    let mut c = cloud.clone();
    let r = sssingle::sssingle(&mut c, &m, &point_light(), &p, &Progress::hidden()).unwrap();
    // Half the points lie under the plate.
    assert_eq!(r.shadow_rays, r.entered);
    let half = r.shadowed as f64 / r.shadow_rays as f64;
    assert!(
        (0.4..0.6).contains(&half),
        "{} of {}",
        r.shadowed,
        r.shadow_rays
    );
    assert_eq!(
        c.detail("sssingle_shadows"),
        Some(&pcsss::DetailValue::I32(1))
    );
    let off = Params {
        shadows: false,
        ..p
    };
    let r = sssingle::sssingle(&mut c, &m, &point_light(), &off, &Progress::hidden()).unwrap();
    assert_eq!((r.shadow_rays, r.shadowed), (0, 0));
    assert_eq!(
        c.detail("sssingle_shadows"),
        Some(&pcsss::DetailValue::I32(0))
    );
}
