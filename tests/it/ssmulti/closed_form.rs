//! Independent truth: the flat plane, the kernels' disk integrals by
//! quadrature, the open edge, the lit pole of a sphere.

use super::*;

#[test]
fn a_flat_evenly_lit_plane_gives_rd_times_e() {
    let e = [2.0, 1.0, 0.5];
    let rd = [0.9, 0.5, 0.2];
    let (k, h, sd) = (200usize, 0.005, 0.25);
    let ld1 = 0.9 * sd;
    let interior = |q: &[f64; 3], k: usize, h: f64| {
        let m = (k - 1) as f64 * h;
        q[0] > ld1 && q[0] < m - ld1 && q[1] > ld1 && q[1] < m - ld1
    };
    // The regular grid's own quadrature error is 1.8e-6 at 22 points per
    // ld1 (h = 0.01, measured with an f64 sum) and falls as h^3: at 45
    // points per ld1 it is below 3e-7, and f32 pairs add about 1.5e-7.
    for (jitter, tol) in [(0.0, 1e-6), (1.0, 1e-3)] {
        let c = grid(k, h, e, jitter, 3);
        let p = Params {
            rd,
            sd,
            ..Params::default()
        };
        let got = run(&c, &p);
        let pos = c.points().vec3_f64("P").unwrap();
        let mut worst: f64 = 0.0;
        for (q, v) in pos.iter().zip(&got) {
            if interior(q, k, h) {
                for ch in 0..3 {
                    worst = worst.max(rel_err(v[ch], rd[ch] * e[ch]));
                }
            }
        }
        assert!(worst < tol, "jitter {jitter}: worst {worst:e}");
    }
    // Every falloff and normalisation on a coarser regular grid.
    let (k, h) = (120usize, 0.01);
    let c = grid(k, h, e, 0.0, 3);
    let pos = c.points().vec3_f64("P").unwrap();
    for falloff in falloffs() {
        for norm in [Norm::Seed, Norm::Channel, Norm::Local, Norm::Source] {
            let p = Params {
                rd,
                sd,
                falloff,
                norm,
                ..Params::default()
            };
            let got = run(&c, &p);
            // The slides' exp falloff and the truncated Burley profile jump
            // to 0 at D: which grid points fall inside the disk is Gauss's
            // circle problem, an error of O((h / D)^(3/2)) times the jump
            // (4e-3 for exp with sigma -> 0, 22 points per D). Local
            // normalisation divides the same sum by itself: exact. Source
            // normalisation too, but a source within D of the edge is
            // spread over the part of its disk there is: its receivers lie
            // up to 2 D from the edge.
            let margin = if norm == Norm::Source { 2.0 } else { 1.0 };
            let tol = match (falloff, norm) {
                (_, Norm::Local | Norm::Source) => 1e-5,
                (Falloff::Smooth, _) => 1e-5,
                _ => 1e-2,
            };
            for (q, v) in pos.iter().zip(&got) {
                let m = (k - 1) as f64 * h;
                let far = margin * ld1;
                if q[0] > far && q[0] < m - far && q[1] > far && q[1] < m - far {
                    for ch in 0..3 {
                        let err = rel_err(v[ch], rd[ch] * e[ch]);
                        assert!(err < tol, "{falloff:?} {norm:?}: {v:?}, error {err:e}");
                    }
                }
            }
        }
    }
}

#[test]
#[allow(clippy::excessive_precision)] // the decimal digits as computed
fn every_falloff_integrates_to_its_disk_integral() {
    for d in [1e-3, 1.0, 7.0] {
        let mut cases = vec![Falloff::Smooth];
        for sigma in [1e-8, 1e-4, 0.3, 0.5, 0.7, 1.0, 5.0, 30.0, 1e3] {
            cases.push(Falloff::Exp { sigma });
        }
        for kappa in [0.5, 3.0, BURLEY_KAPPA, 40.0] {
            cases.push(Falloff::Burley { kappa });
        }
        for f in cases {
            // Fine pieces near 0, where exp and Burley are steep.
            let g = |r: f64| ssmulti::falloff(f, r, d, 0.0) * 2.0 * PI * r;
            let num = quad(g, d * 1e-3, 2000) + quad(|r| g(r + d * 1e-3), d * (1.0 - 1e-3), 20000);
            let exact = ssmulti::disk_integral(f, d);
            assert!(
                rel_err(num, exact) < 1e-9,
                "{f:?} D {d}: quadrature {num} vs {exact}"
            );
            assert!(exact.is_finite() && exact > 0.0);
        }
    }
    // The limits: sigma -> 0 is pi D^2; large sigma is 2 pi D^2 / sigma^2.
    assert!(
        rel_err(
            ssmulti::disk_integral(Falloff::Exp { sigma: 1e-12 }, 1.0),
            PI
        ) < 1e-11
    );
    assert!(
        rel_err(
            ssmulti::disk_integral(Falloff::Exp { sigma: 1e3 }, 1.0),
            2.0 * PI / 1e6
        ) < 1e-12
    );
    // (1 - e^-s (1 + s)) / s^2 against 50-digit values (Python decimal,
    // 80 terms of the exponential series): the series below 0.5, the
    // closed form above.
    for (s, want) in [
        (1e-8, 0.499_999_996_666_666_679_166_666_633_333_333_4),
        (0.001, 0.499_666_791_633_340_276_587_475_176_369_322_941_7),
        (0.25, 0.423_984_338_571_902_635_096_594_660_433_587_054_1),
        (0.4999, 0.360_839_062_849_747_469_749_348_304_581_673_987),
        (0.5, 0.360_816_041_724_199_458_377_202_790_052_917_279_3),
        (2.0, 0.148_498_537_572_540_481_079_500_378_770_636_697_4),
    ] {
        let got = ssmulti::exp_disk_factor(s);
        assert!(rel_err(got, want) < 4e-16, "{s}: {got} vs {want}");
    }
}

#[test]
fn local_normalisation_keeps_an_open_edge_lit() {
    // A half-plane: x >= 0. At the edge Houdini's normalisation sees half
    // the disk (exactly half the kernel's integral): 0.5 Rd E; the local
    // one divides by the area present: Rd E.
    let (k, h, sd) = (140usize, 0.01, 0.3);
    let c = grid(k, h, [1.0; 3], 0.0, 0);
    let pos = c.points().vec3_f64("P").unwrap();
    let mid = (k - 1) as f64 * h / 2.0;
    for (norm, want) in [(Norm::Seed, 0.5), (Norm::Local, 1.0)] {
        let got = run(
            &c,
            &Params {
                sd,
                norm,
                ..Params::default()
            },
        );
        let edge: Vec<f64> = pos
            .iter()
            .zip(&got)
            .filter(|(q, _)| q[0] == 0.0 && (q[1] - mid).abs() < 0.2)
            .map(|(_, v)| v[0])
            .collect();
        assert!(!edge.is_empty());
        for v in edge {
            // The edge points sit on the boundary: their own row counts
            // half, so Houdini's value is 0.5 plus half a row's share.
            assert!((v - want).abs() < 0.03, "{norm:?}: {v} vs {want}");
        }
    }
}

#[test]
fn the_lit_pole_of_a_sphere_matches_the_continuous_integral() {
    // The independent value: sd 0.3, Rd (1, 0.5, 0.25), bounce 0,
    // smooth, seed normalisation, a distant light of colour 1 along -z on
    // the unit sphere: at the lit pole (0.989286, 0.494643, 0.247321).
    let sphere = uv_sphere(200, 400, 1.0, [0.0; 3]);
    let mut cloud = pcsss::stages::scatter::scatter(
        &sphere,
        &pcsss::stages::scatter::Params {
            amount: pcsss::stages::scatter::Amount::Count(200_000),
            seed: 4,
            ptarea: pcsss::stages::scatter::PtareaMode::Voronoi,
            relax: 5,
            ..pcsss::stages::scatter::Params::new(pcsss::stages::scatter::Amount::Count(0))
        },
    )
    .unwrap();
    let p = cloud.points().vec3_f64("P").unwrap();
    let a = cloud.points().scalar_f64("ptarea").unwrap();
    let total: f64 = a.iter().sum();
    let n: Vec<[f32; 3]> = p
        .iter()
        .map(|q| DVec3::from_array(*q).normalize().as_vec3().to_array())
        .collect();
    let e: Vec<[f32; 3]> = n.iter().map(|v| [v[2].max(0.0); 3]).collect();
    let scaled: Vec<f32> = a.iter().map(|x| (x * 4.0 * PI / total) as f32).collect();
    let pts = cloud.points_mut();
    pts.set_vec3("N", Role::Normal, &n).unwrap();
    pts.set_vec3("illum", Role::Color, &e).unwrap();
    pts.set_scalar("ptarea", scaled).unwrap();
    let got = run(
        &cloud,
        &Params {
            rd: [1.0, 0.5, 0.25],
            sd: 0.3,
            ..Params::default()
        },
    );
    let want = [0.989286, 0.494643, 0.247321];
    // Points within 0.02 of the pole: the value changes by less than
    // 1e-4 there.
    let near: Vec<&[f64; 3]> = p
        .iter()
        .zip(&got)
        .filter(|(q, _)| q[2] > 0.9998)
        .map(|(_, v)| v)
        .collect();
    assert!(near.len() > 3);
    for v in near {
        for c in 0..3 {
            assert!(rel_err(v[c], want[c]) < 2e-3, "{v:?} vs {want:?}");
        }
    }
}
