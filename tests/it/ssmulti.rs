//! `ssmulti` against a plain f64 double loop written here, closed forms
//! (the plane, the kernel integrals, the lit pole of a sphere),
//! invariance under translation and scale, and bad input.

use std::f64::consts::PI;

use glam::DVec3;
use rand_core::RngCore;
use rand_pcg::Pcg32;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::progress::Progress;
use pcsss::stages::ssmulti::{self, burley, Falloff, Norm, Params, BURLEY_KAPPA};
use pcsss::Cloud;

fn unit(r: &mut Pcg32) -> f64 {
    r.next_u32() as f64 / 4294967296.0
}

/// A cloud from columns: f64 positions, f32 normals, ptarea, illum.
fn cloud_of(p: &[[f64; 3]], n: &[[f64; 3]], a: &[f64], e: &[[f64; 3]]) -> Cloud {
    let mut c = Cloud::with_points(p.len());
    let pts = c.points_mut();
    pts.set_vec3("P", Role::Point, p).unwrap();
    let n32: Vec<[f32; 3]> = n.iter().map(|v| v.map(|x| x as f32)).collect();
    pts.set_vec3("N", Role::Normal, &n32).unwrap();
    pts.set_scalar("ptarea", a.iter().map(|&x| x as f32).collect::<Vec<f32>>())
        .unwrap();
    let e32: Vec<[f32; 3]> = e.iter().map(|v| v.map(|x| x as f32)).collect();
    pts.set_vec3("illum", Role::Color, &e32).unwrap();
    c
}

fn run(c: &Cloud, p: &Params) -> Vec<[f64; 3]> {
    let mut c = c.clone();
    ssmulti::ssmulti(&mut c, p, &Progress::hidden()).unwrap();
    c.points().vec3_f64("ssM").unwrap()
}

/// docs/DESIGN.md's loop, in f64, every pair, written from the text.
fn brute(c: &Cloud, p: &Params) -> Vec<[f64; 3]> {
    let pos = c.points().vec3_f64("P").unwrap();
    let nrm = c.points().vec3_f64("N").unwrap();
    let area = c.points().scalar_f64("ptarea").unwrap();
    let illum = c.points().vec3_f64("illum").unwrap();
    let ld: Vec<f64> = p.rd.iter().map(|r| r * p.sd).collect();
    let ld1 = ld.iter().copied().fold(0.0, f64::max);
    let w = |r: f64, d: f64, i: usize| ssmulti::falloff(p.falloff, r, d, burley::rmin(area[i]));
    let mut out = Vec::new();
    for o in 0..pos.len() {
        let xo = DVec3::from_array(pos[o]);
        let no = DVec3::from_array(nrm[o]).normalize();
        let mut ssm = [0.0; 3];
        let mut loc = [0.0; 3];
        for i in 0..pos.len() {
            let xi = DVec3::from_array(pos[i]);
            let r = (xo - xi).length();
            if r > ld1 || ld1 == 0.0 {
                continue;
            }
            let ni = DVec3::from_array(nrm[i]).normalize();
            let li = (xo - xi) / ld1;
            let kb = 1.0 - (1.0 - no.dot(ni)) * (1.0 - no.dot(li)) / 2.0;
            let kb = 1.0 + p.bounce * (kb - 1.0);
            for c in 0..3 {
                let d = if p.rgb { ld[c] } else { ld1 };
                if d <= 0.0 || r > d {
                    continue;
                }
                if kb > 0.0 {
                    ssm[c] += kb * illum[i][c] * area[i] * w(r, d, i);
                }
                loc[c] += area[i] * w(r, d, i);
            }
        }
        let i1 = ssmulti::disk_integral(p.falloff, ld1);
        let mut v = [0.0; 3];
        for c in 0..3 {
            v[c] = match (p.norm, p.rgb) {
                (Norm::Seed, false) | (Norm::Channel, false) => p.rd[c] * ssm[c] / i1,
                (Norm::Seed, true) => ssm[c] / i1,
                (Norm::Channel, true) if ld[c] > 0.0 => {
                    p.rd[c] * ssm[c] / ssmulti::disk_integral(p.falloff, ld[c])
                }
                (Norm::Channel, true) => 0.0,
                (Norm::Local, _) if loc[c] > 0.0 => p.rd[c] * ssm[c] / loc[c],
                (Norm::Local, _) => 0.0,
            };
        }
        out.push(v);
    }
    out
}

/// A wavy sheet folded into a half-tube: neighbours facing many ways
/// (bounce matters), f64 positions around `offset`, random areas and
/// light, some points unlit.
fn wavy(n: usize, offset: DVec3, scale: f64, seed: u64) -> Cloud {
    let mut r = Pcg32::new(seed, 0);
    let (mut p, mut nn, mut a, mut e) = (vec![], vec![], vec![], vec![]);
    for k in 0..n {
        let u = unit(&mut r) * PI;
        let v = unit(&mut r) * 2.0;
        let rad = 1.0 + 0.1 * (5.0 * v).sin();
        let q = DVec3::new(rad * u.cos(), v, rad * u.sin());
        p.push((offset + q * scale).to_array());
        nn.push([u.cos(), 0.1 * (unit(&mut r) - 0.5), u.sin()]);
        a.push((0.5 + unit(&mut r)) * 2.0 * PI / n as f64 * scale * scale);
        if k % 5 == 0 {
            e.push([0.0; 3]);
        } else {
            e.push([unit(&mut r), unit(&mut r), 2.0 * unit(&mut r)]);
        }
    }
    cloud_of(&p, &nn, &a, &e)
}

fn falloffs() -> [Falloff; 4] {
    [
        Falloff::Smooth,
        Falloff::Exp { sigma: 3.0 },
        Falloff::Exp { sigma: 1e-6 },
        Falloff::Burley {
            kappa: BURLEY_KAPPA,
        },
    ]
}

fn rel_err(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs()).max(1e-30)
}

/// `c` under white light: every `illum` its first channel three times.
fn white(c: &Cloud) -> Cloud {
    let mut c = c.clone();
    let e: Vec<[f32; 3]> = c
        .points()
        .vec3_f64("illum")
        .unwrap()
        .iter()
        .map(|v| [v[0] as f32; 3])
        .collect();
    c.points_mut().set_vec3("illum", Role::Color, &e).unwrap();
    c
}

#[test]
fn exact_method_equals_the_f64_double_loop_for_every_setting() {
    let coloured = wavy(700, DVec3::ZERO, 1.0, 1);
    // White light takes the one-channel path where one kernel serves all.
    let grey = white(&coloured);
    let mut worst: f64 = 0.0;
    for (c, falloff) in [&coloured, &grey]
        .into_iter()
        .flat_map(|c| falloffs().map(|f| (c, f)))
    {
        for norm in [Norm::Seed, Norm::Channel, Norm::Local] {
            for (rgb, rd) in [
                (false, [0.8, 0.5, 0.3]),
                (true, [0.8, 0.5, 0.3]),
                (true, [0.6, 0.6, 0.6]),
                (true, [0.7, 0.0, 0.35]),
            ] {
                for bounce in [0.0, 0.5, 1.0] {
                    let p = Params {
                        rd,
                        sd: 0.6,
                        bounce,
                        rgb,
                        falloff,
                        norm,
                        tolerance: 0.0,
                        ..Params::default()
                    };
                    let got = run(c, &p);
                    let want = brute(c, &p);
                    // f32 pair arithmetic puts ~1e-7 ld1 of error on each
                    // distance: a receiver whose sum is all near-edge
                    // pairs (unlit itself, small value) sees that
                    // relatively magnified, so values below the channel's
                    // mean are judged against the mean.
                    let mean: Vec<f64> = (0..3)
                        .map(|ch| want.iter().map(|v| v[ch].abs()).sum::<f64>() / want.len() as f64)
                        .collect();
                    // Burley's 1/r weighs the nearest pairs most, whose
                    // f32 distances are the least precise relative to
                    // themselves (~5e-7 at one spacing): 2e-6 there.
                    let tol = match falloff {
                        Falloff::Burley { .. } => 2e-6,
                        _ => 1e-6,
                    };
                    for (g, w) in got.iter().zip(&want) {
                        for ch in 0..3 {
                            let e = (g[ch] - w[ch]).abs() / w[ch].abs().max(mean[ch]).max(1e-30);
                            worst = worst.max(e);
                            assert!(
                                e < tol,
                                "{falloff:?} {norm:?} rgb {rgb} rd {rd:?} bounce {bounce}: {g:?} vs {w:?}"
                            );
                        }
                    }
                }
            }
        }
    }
    eprintln!("worst relative difference {worst:e}");
}

/// White light is summed in one channel when one kernel serves all three
/// (the values: `exact_method_equals_the_f64_double_loop_for_every_setting`).
#[test]
fn white_light_sums_one_channel() {
    let coloured = wavy(300, DVec3::ZERO, 1.0, 2);
    let grey = white(&coloured);
    let report = |c: &Cloud, rgb: bool, rd: [f64; 3]| {
        let p = Params {
            rd,
            sd: 0.5,
            rgb,
            ..Params::default()
        };
        ssmulti::ssmulti(&mut c.clone(), &p, &Progress::hidden()).unwrap()
    };
    assert!(report(&grey, false, [0.8, 0.5, 0.3]).grey);
    assert!(report(&grey, true, [0.6, 0.6, 0.6]).grey);
    assert!(!report(&grey, true, [0.8, 0.5, 0.3]).grey);
    assert!(!report(&coloured, false, [0.8, 0.5, 0.3]).grey);
}

/// A square grid of `k` x `k` points of spacing `h` on z = 0, area `h^2`
/// each, uniform light `e`.
fn grid(k: usize, h: f64, e: [f64; 3], jitter: f64, seed: u64) -> Cloud {
    let mut r = Pcg32::new(seed, 1);
    let (mut p, mut n, mut a, mut l) = (vec![], vec![], vec![], vec![]);
    for i in 0..k {
        for j in 0..k {
            let dx = jitter * (unit(&mut r) - 0.5) * h;
            let dy = jitter * (unit(&mut r) - 0.5) * h;
            p.push([i as f64 * h + dx, j as f64 * h + dy, 0.0]);
            n.push([0.0, 0.0, 1.0]);
            a.push(h * h);
            l.push(e);
        }
    }
    cloud_of(&p, &n, &a, &l)
}

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
        for norm in [Norm::Seed, Norm::Channel, Norm::Local] {
            let p = Params {
                rd,
                sd,
                falloff,
                norm,
                ..Params::default()
            };
            let got = run(&c, &p);
            // The seed's exp falloff and the truncated Burley profile jump
            // to 0 at D: which grid points fall inside the disk is Gauss's
            // circle problem, an error of O((h / D)^(3/2)) times the jump
            // (4e-3 for exp with sigma -> 0, 22 points per D). Local
            // normalisation divides the same sum by itself: exact.
            let tol = match (falloff, norm) {
                (_, Norm::Local) => 1e-5,
                (Falloff::Smooth, _) => 1e-5,
                _ => 1e-2,
            };
            for (q, v) in pos.iter().zip(&got) {
                if interior(q, k, h) {
                    for ch in 0..3 {
                        let err = rel_err(v[ch], rd[ch] * e[ch]);
                        assert!(err < tol, "{falloff:?} {norm:?}: {v:?}, error {err:e}");
                    }
                }
            }
        }
    }
}

/// Composite Gauss-Legendre (5 points) of `f` on [0, d] in `m` pieces.
fn quad(f: impl Fn(f64) -> f64, d: f64, m: usize) -> f64 {
    let x = [
        0.0,
        -0.538_469_310_105_683,
        0.538_469_310_105_683,
        -0.906_179_845_938_664,
        0.906_179_845_938_664,
    ];
    let w = [
        0.568_888_888_888_889,
        0.478_628_670_499_366,
        0.478_628_670_499_366,
        0.236_926_885_056_189,
        0.236_926_885_056_189,
    ];
    let h = d / m as f64;
    let mut s = 0.0;
    for k in 0..m {
        let c = (k as f64 + 0.5) * h;
        for j in 0..5 {
            s += w[j] * f(c + x[j] * h / 2.0) * h / 2.0;
        }
    }
    s
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
fn translation_and_scale_change_nothing() {
    let base = wavy(1500, DVec3::ZERO, 1.0, 2);
    for falloff in falloffs() {
        let p = Params {
            rd: [0.9, 0.6, 0.3],
            sd: 0.4,
            bounce: 0.5,
            rgb: true,
            falloff,
            norm: Norm::Channel,
            tolerance: 0.0,
            ..Params::default()
        };
        let want = run(&base, &p);
        for (offset, scale) in [
            (DVec3::new(1e6, -1e6, 1e6), 1.0),
            (DVec3::ZERO, 1e-4),
            (DVec3::ZERO, 1e4),
        ] {
            let c = wavy(1500, offset, scale, 2);
            let got = run(
                &c,
                &Params {
                    sd: p.sd * scale,
                    ..p
                },
            );
            for (g, w) in got.iter().zip(&want) {
                for ch in 0..3 {
                    assert!(
                        (g[ch] - w[ch]).abs() <= 1e-5 * w[ch].abs().max(1e-3),
                        "{falloff:?} offset {offset} scale {scale}: {g:?} vs {w:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn a_power_of_two_scale_changes_no_bit() {
    // Lengths times 2^k, areas 2^2k, sd 2^k: every number in the sums is
    // scaled exactly, and `ptarea`'s own power-of-two prescale brings the
    // areas back to the same bits, so `ssM` is bit for bit the same.
    // Without that prescale this fails at 2^-40 (exp sigma 100, channel):
    // `illum * ptarea` (~1e-27) times exp's weights down to e^-60 is
    // subnormal and loses bits (and time). (Not below 2^-40: the f32 areas
    // would be subnormal as read.)
    let base = wavy(3000, DVec3::ZERO, 1.0, 5);
    let mut settings = vec![];
    for falloff in [
        Falloff::Smooth,
        Falloff::Exp { sigma: 4.0 },
        Falloff::Exp { sigma: 100.0 },
        Falloff::Burley {
            kappa: BURLEY_KAPPA,
        },
    ] {
        for (rgb, bounce, norm, tolerance) in [
            (false, 0.0, Norm::Seed, 0.0),
            (true, 0.5, Norm::Channel, 0.0),
            (true, 0.0, Norm::Local, 0.0),
            (false, 0.3, Norm::Local, 0.3),
        ] {
            settings.push(Params {
                rd: [0.9, 0.6, 0.3],
                sd: 0.8,
                bounce,
                rgb,
                falloff,
                norm,
                tolerance,
                ..Params::default()
            });
        }
    }
    for p in settings {
        let want = run(&base, &p);
        for k in [-24, -40, 40] {
            let s = 2f64.powi(k);
            let c = wavy(3000, DVec3::ZERO, s, 5);
            let got = run(&c, &Params { sd: p.sd * s, ..p });
            let bits = |v: &[[f64; 3]]| -> Vec<[u32; 3]> {
                v.iter().map(|x| x.map(|y| (y as f32).to_bits())).collect()
            };
            assert!(
                bits(&got) == bits(&want),
                "{:?} {:?} rgb {} tolerance {} at 2^{k}",
                p.falloff,
                p.norm,
                p.rgb,
                p.tolerance
            );
        }
    }
}

#[test]
fn local_normalisation_keeps_an_open_edge_lit() {
    // A half-plane: x >= 0. At the edge the seed's normalisation sees half
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
            // half, so the seed's value is 0.5 plus half a row's share.
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

#[test]
fn the_scene_decides_the_work() {
    let c = wavy(2000, DVec3::ZERO, 1.0, 5);
    let mut copy = c.clone();
    let rep = ssmulti::ssmulti(
        &mut copy,
        &Params {
            sd: 0.5,
            ..Params::default()
        },
        &Progress::hidden(),
    )
    .unwrap();
    // Every fifth point is unlit: not a source.
    assert_eq!(rep.sources, 1600);
    // Local normalisation needs every point's area.
    let rep = ssmulti::ssmulti(
        &mut copy,
        &Params {
            sd: 0.5,
            norm: Norm::Local,
            ..Params::default()
        },
        &Progress::hidden(),
    )
    .unwrap();
    assert_eq!(rep.sources, 2000);
    // All distances zero: nothing to do, zeros out.
    let rep = ssmulti::ssmulti(
        &mut copy,
        &Params {
            sd: 0.0,
            ..Params::default()
        },
        &Progress::hidden(),
    )
    .unwrap();
    assert_eq!(rep.pairs, 0);
    assert!(copy
        .points()
        .vec3_f64("ssM")
        .unwrap()
        .iter()
        .all(|v| *v == [0.0; 3]));
}

#[test]
fn sd_beyond_the_whole_object_sums_every_pair() {
    let c = wavy(700, DVec3::ZERO, 1.0, 3);
    for falloff in falloffs() {
        let p = Params {
            rd: [1.0, 0.5, 0.25],
            sd: 50.0,
            bounce: 0.5,
            falloff,
            ..Params::default()
        };
        let got = run(&c, &p);
        let want = brute(&c, &p);
        for (g, w) in got.iter().zip(&want) {
            for ch in 0..3 {
                assert!(rel_err(g[ch], w[ch]) < 2e-6, "{falloff:?}: {g:?} vs {w:?}");
                assert!(g[ch].is_finite());
            }
        }
    }
    // Reaches beyond f32's range (and beyond the padding lanes' "far
    // away"): every pair, no padding lane, finite sums; the seed's
    // normalisation divides by ~sd^2 (an f32 0), the local one gives the
    // mean light.
    // Every falloff: the kernels are taken no longer than 1e5-1e8 times
    // the object's size (uncapped, exp and Burley at sd 1e300 give 0:
    // sigma / D is an f32 0).
    for falloff in falloffs() {
        for sd in [1e20, 1e30, 1e300] {
            for (norm, tolerance) in [(Norm::Seed, 0.0), (Norm::Local, 0.0), (Norm::Local, 0.3)] {
                let p = Params {
                    rd: [1.0, 0.5, 0.25],
                    sd,
                    norm,
                    tolerance,
                    falloff,
                    ..Params::default()
                };
                let got = run(&c, &p);
                let want = brute(&c, &p);
                // Burley's weight is ~2 / r at any r here: clusters are
                // not exact for it (7.4e-4 relative at most, measured).
                let burley = matches!(falloff, Falloff::Burley { .. });
                let tol = if burley && tolerance > 0.0 {
                    2e-3
                } else {
                    1e-5
                };
                for (g, w) in got.iter().zip(&want) {
                    for ch in 0..3 {
                        let ok = match norm {
                            Norm::Local => rel_err(g[ch], w[ch]) < tol,
                            // (~sd^-2: an f32 0, or ~1e-20 for Burley's
                            // ~sd^-1.)
                            _ => (g[ch] - w[ch]).abs() < 1e-30 || rel_err(g[ch], w[ch]) < 1e-5,
                        };
                        assert!(
                            ok && g[ch].is_finite(),
                            "{falloff:?} sd {sd} {norm:?} tolerance {tolerance}: {g:?} vs {w:?}"
                        );
                    }
                }
            }
        }
    }
}

#[test]
fn a_steep_exp_equals_the_double_loop() {
    // Weights below e^-60 of a point's own are left out (subnormal
    // products): nothing at 5e-5 relative. (Not 1e-6: `e^-x` carries x
    // times the relative error of the f32 distance, a few 1e-7, and x
    // runs up to 60 here: sigma 60 measured 1.3e-6, and an unlit point
    // lit only from x ~ 27 by sigma 300, 1.04e-5.)
    // Sources beyond 60 D / sigma add exact zeros and are not visited.
    let c = wavy(700, DVec3::ZERO, 1.0, 5);
    let pairs = |sigma: f64, norm: Norm| {
        let p = Params {
            rd: [1.0, 0.5, 0.25],
            sd: 0.6,
            norm,
            falloff: Falloff::Exp { sigma },
            ..Params::default()
        };
        run_report(&c, &p).1.pairs
    };
    for sigma in [60.0, 300.0, 1e3, 1e6] {
        for norm in [Norm::Seed, Norm::Channel, Norm::Local] {
            let p = Params {
                rd: [1.0, 0.5, 0.25],
                sd: 0.6,
                norm,
                falloff: Falloff::Exp { sigma },
                ..Params::default()
            };
            if sigma >= 300.0 {
                let (few, all) = (pairs(sigma, norm), pairs(4.0, norm));
                assert!(
                    few * 4 < all,
                    "sigma {sigma}: {few} pairs, {all} at sigma 4"
                );
            }
            let got = run(&c, &p);
            let want = brute(&c, &p);
            // (An unlit point whose every source lies beyond the cut gets
            // 0, ~1e-30 where the lit ones get ~1: the floor.)
            let top = want.iter().flatten().fold(0.0, |m: f64, v| m.max(v.abs()));
            for (g, w) in got.iter().zip(&want) {
                for ch in 0..3 {
                    assert!(
                        (g[ch] - w[ch]).abs() <= 5e-5 * w[ch].abs() + 1e-24 * top,
                        "sigma {sigma} {norm:?}: {g:?} vs {w:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn sd_below_the_spacing_leaves_each_point_alone() {
    // Each point sees only itself: ssM = Rd illum ptarea W(0) / I(ld1).
    let c = grid(10, 1.0, [1.0, 2.0, 3.0], 0.0, 0);
    let got = run(
        &c,
        &Params {
            rd: [0.5; 3],
            sd: 0.1,
            ..Params::default()
        },
    );
    let i1 = ssmulti::disk_integral(Falloff::Smooth, 0.05);
    for v in got {
        for ch in 0..3 {
            let want = 0.5 * (ch + 1) as f64 / i1;
            assert!(rel_err(v[ch], want) < 1e-6, "{v:?}");
        }
    }
}

#[test]
fn ssmulti_in_a_pipe_same_bits_on_any_thread_count_and_bad_input() {
    let d = tempdir();
    let write =
        |name: &str, c: &Cloud| std::fs::write(d.path().join(name), to_bytes(c, LE)).unwrap();
    let c = wavy(5000, DVec3::ZERO, 1.0, 6);
    write("c.ply", &c);
    let mut outs = Vec::new();
    for threads in ["1", "2"] {
        let out = std::process::Command::new(bin("ssmulti"))
            .args([
                "--rd",
                "0.9,0.5,0.3",
                "--sd",
                "0.4",
                "--bounce",
                "0.5",
                "--rgb",
            ])
            .env("RAYON_NUM_THREADS", threads)
            .stdin(std::fs::File::open(d.path().join("c.ply")).unwrap())
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", stderr(&out));
        outs.push(out.stdout);
    }
    assert_eq!(outs[0], outs[1]);
    let back = from_bytes(&outs[0]);
    assert!(back.points().has("ssM") && back.points().has("illum"));
    // Without AVX2/FMA (the baseline loop): the same sums to rounding.
    let plain = std::process::Command::new(bin("ssmulti"))
        .args([
            "--rd",
            "0.9,0.5,0.3",
            "--sd",
            "0.4",
            "--bounce",
            "0.5",
            "--rgb",
        ])
        .env("PCSSS_NO_AVX2", "1")
        .stdin(std::fs::File::open(d.path().join("c.ply")).unwrap())
        .output()
        .unwrap();
    assert!(plain.status.success());
    let a = back.points().vec3_f64("ssM").unwrap();
    let b = from_bytes(&plain.stdout).points().vec3_f64("ssM").unwrap();
    for (x, y) in a.iter().zip(&b) {
        for ch in 0..3 {
            assert!(
                (x[ch] - y[ch]).abs() <= 1e-6 * x[ch].abs().max(1e-3),
                "{x:?} vs {y:?}"
            );
        }
    }
    // An empty cloud writes an empty cloud.
    write("empty.ply", &cloud_of(&[], &[], &[], &[]));
    let out = run_in(Some(d.path()), "ssmulti", &["empty.ply", "--sd", "1"], b"");
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(from_bytes(&out.stdout).len(), 0);
    // Duplicate points: finite, and equal to each other.
    let dup = cloud_of(
        &[[0.0; 3]; 200],
        &[[0.0, 0.0, 1.0]; 200],
        &[0.01; 200],
        &[[1.0; 3]; 200],
    );
    let got = run(&dup, &Params::default());
    assert!(got.iter().all(|v| v[0].is_finite() && v[0] == got[0][0]));
    // Bad input.
    let mut nan = c.clone();
    let mut e = nan.points().vec3_f32("illum").unwrap();
    e[42] = [f32::NAN, 0.0, 0.0];
    nan.points_mut().set_vec3("illum", Role::Color, &e).unwrap();
    write("nan.ply", &nan);
    let mut zero = c.clone();
    let mut n = zero.points().vec3_f32("N").unwrap();
    n[7] = [0.0; 3];
    zero.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    write("zero_n.ply", &zero);
    let mut no_illum = c.clone();
    no_illum.points_mut().remove("illum");
    write("no_illum.ply", &no_illum);
    let cases: &[(&[&str], &str)] = &[
        (
            &["nan.ply", "--sd", "1"],
            "point 42: illum is [NaN, 0.0, 0.0]",
        ),
        (
            &["zero_n.ply", "--sd", "1"],
            "point 7: N is [0.0, 0.0, 0.0]",
        ),
        (
            &["no_illum.ply", "--sd", "1"],
            "missing point attribute 'illum' (run 'illum' first",
        ),
        (&["c.ply", "--sd=-1"], "--sd"),
        (&["c.ply", "--sd", "NaN"], "--sd"),
        (&["c.ply", "--sd", "1", "--rd", "1,-0.5,1"], "--rd"),
        (&["c.ply", "--sd", "1", "--rd", "1,NaN,1"], "--rd"),
        (&["c.ply", "--sd", "1", "--rd", "1,2"], "--rd"),
        (&["c.ply", "--sd", "1", "--bounce", "2"], "--bounce"),
        (
            &["c.ply", "--sd", "1", "--falloff", "exp", "--sigma", "0"],
            "--sigma",
        ),
        (
            &["c.ply", "--sd", "1", "--falloff", "exp", "--sigma", "NaN"],
            "--sigma",
        ),
    ];
    for (args, want) in cases {
        let out = run_in(Some(d.path()), "ssmulti", args, b"");
        let e = stderr(&out);
        assert_ne!(out.status.code(), Some(0), "{args:?}");
        assert_eq!(e.trim().lines().count(), 1, "{args:?}: {e}");
        assert!(e.contains(want), "{args:?}: '{e}' lacks '{want}'");
    }
}

#[test]
fn exp_approx_is_within_two_ulp() {
    let mut worst: f64 = 0.0;
    let mut x = -87.0f32;
    while x <= 0.0 {
        let got = ssmulti::exp_approx(x) as f64;
        let want = (x as f64).exp();
        worst = worst.max((got - want).abs() / want);
        x += 1e-4;
    }
    eprintln!("exp_approx worst relative error {worst:e}");
    assert!(worst < 1.2e-7, "{worst:e}");
    // Below -87 it is e^-87 (a zero weight), NaN included; above 0, 1.
    let tiny = (-87.0f64).exp();
    for x in [-87.5, -1e4, f32::MIN, f32::NEG_INFINITY, f32::NAN] {
        let got = ssmulti::exp_approx(x) as f64;
        assert!((got - tiny).abs() < 1e-6 * tiny, "{x}: {got:e}");
    }
    for x in [0.0, -0.0, 1e-30, 1.0, 1e30, f32::INFINITY] {
        assert_eq!(ssmulti::exp_approx(x), 1.0, "{x}");
    }
}

#[test]
fn the_approximate_method_converges_to_the_exact_one() {
    // A wavy half-tube with ~800 neighbours per point: clusters matter.
    let c = wavy(16000, DVec3::ZERO, 1.0, 8);
    for falloff in falloffs() {
        for (rgb, bounce, norm) in [
            (false, 0.0, Norm::Seed),
            (true, 0.7, Norm::Channel),
            (false, 0.3, Norm::Local),
        ] {
            let p = Params {
                rd: [0.9, 0.6, 0.3],
                sd: 0.5,
                bounce,
                rgb,
                falloff,
                norm,
                tolerance: 0.0,
                ..Params::default()
            };
            let exact = run(&c, &p);
            let rms = |v: &[[f64; 3]]| {
                let (mut num, mut den) = (0.0, 0.0);
                for (a, e) in v.iter().zip(&exact) {
                    for ch in 0..3 {
                        num += (a[ch] - e[ch]).powi(2);
                        den += e[ch].powi(2);
                    }
                }
                (num / den).sqrt()
            };
            let mut last = f64::INFINITY;
            // Measured on this cloud, worst over the settings (smooth,
            // seed): 1.1e-2, 4.9e-3, 3.0e-4.
            for (tol, bound) in [(0.4, 0.02), (0.2, 0.006), (0.1, 0.001)] {
                let err = rms(&run(
                    &c,
                    &Params {
                        tolerance: tol,
                        ..p
                    },
                ));
                eprintln!("{falloff:?} rgb {rgb} {norm:?} tol {tol}: {err:e}");
                assert!(
                    err < bound,
                    "{falloff:?} rgb {rgb} {norm:?} tol {tol}: {err:e}"
                );
                assert!(
                    err <= last * 1.05,
                    "{falloff:?} tol {tol}: {err:e} after {last:e}"
                );
                last = err;
            }
        }
    }
}

#[test]
fn small_clusters_across_the_exp_jump_are_summed_whole() {
    // exp sigma 4 jumps from e^-4 of its centre value to 0 at D: clusters
    // straddling D are taken whole when they are small beside that jump
    // (`jump_scale`), opened otherwise. Sigma 1's jump is larger: none are.
    // Measured on this cloud (~29,000 neighbours), share of the exact
    // pairs and RMS error: sigma 4, 0.079 at 1.36e-3 (0.242 at 1.28e-3
    // with no straddling cluster); sigma 1, 0.184 at 5.2e-3 (taking every
    // straddling cluster, JUMP_K 0.5: 0.005 at 1.37e-2).
    let c = wavy(60000, DVec3::ZERO, 1.0, 12);
    for (sigma, share_in, bound) in [(4.0, 0.0..0.15, 2e-3), (1.0, 0.1..0.3, 7e-3)] {
        let p = Params {
            sd: 1.0,
            falloff: Falloff::Exp { sigma },
            ..Params::default()
        };
        let mut a = c.clone();
        let exact = ssmulti::ssmulti(&mut a, &p, &Progress::hidden()).unwrap();
        let e = a.points().vec3_f64("ssM").unwrap();
        let q = Params {
            tolerance: 0.3,
            ..p
        };
        let approx = ssmulti::ssmulti(&mut a, &q, &Progress::hidden()).unwrap();
        let v = a.points().vec3_f64("ssM").unwrap();
        let (mut num, mut den) = (0.0, 0.0);
        for (x, y) in v.iter().zip(&e) {
            num += (x[0] - y[0]).powi(2);
            den += y[0].powi(2);
        }
        let err = (num / den).sqrt();
        let share = approx.pairs as f64 / exact.pairs as f64;
        eprintln!("sigma {sigma}: {share:.3} of the pairs, RMS {err:e}");
        assert!(share_in.contains(&share), "sigma {sigma}: {share}");
        assert!(err < bound, "sigma {sigma}: {err:e}");
    }
}

#[test]
fn the_approximate_method_does_less_work_and_keeps_its_bits_on_any_thread_count() {
    let c = wavy(20000, DVec3::ZERO, 1.0, 9);
    let mut a = c.clone();
    let p = Params {
        sd: 0.8,
        ..Params::default()
    };
    let exact = ssmulti::ssmulti(&mut a, &p, &Progress::hidden()).unwrap();
    let approx = ssmulti::ssmulti(
        &mut a,
        &Params {
            tolerance: 0.2,
            ..p
        },
        &Progress::hidden(),
    )
    .unwrap();
    assert!(
        approx.pairs * 5 < exact.pairs,
        "{} vs {}",
        approx.pairs,
        exact.pairs
    );
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let two = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let p = Params {
        tolerance: 0.2,
        ..p
    };
    let r1 = one.install(|| run(&c, &p));
    let r2 = two.install(|| run(&c, &p));
    assert_eq!(r1, r2);
}

#[test]
fn one_and_two_point_clouds_are_summed_exactly() {
    // One point, two apart, three at one position (a cloud of size 0: the
    // kernels' cap on D must not shorten Burley's, whose self weight
    // depends on D through r_min).
    let clouds: [Vec<[f64; 3]>; 3] = [
        vec![[0.0; 3]],
        vec![[0.0; 3], [0.1, 0.0, 0.0]],
        vec![[0.3, -0.2, 0.1]; 3],
    ];
    for p in clouds {
        let n = p.len();
        let c = cloud_of(
            &p,
            &vec![[0.0, 0.0, 1.0]; n],
            &vec![0.5; n],
            &vec![[1.0, 2.0, 4.0]; n],
        );
        for falloff in falloffs() {
            for sd in [1.0, 0.1, 1e20] {
                for norm in [Norm::Seed, Norm::Local] {
                    let params = Params {
                        rd: [0.5; 3],
                        sd,
                        bounce: 1.0,
                        falloff,
                        norm,
                        ..Params::default()
                    };
                    let got = run(&c, &params);
                    let want = brute(&c, &params);
                    for (g, w) in got.iter().zip(&want) {
                        for ch in 0..3 {
                            assert!(
                                rel_err(g[ch], w[ch]) < 2e-6,
                                "{n} points, {falloff:?}, sd {sd}, {norm:?}: {g:?} vs {w:?}"
                            );
                        }
                    }
                }
            }
        }
    }
}

/// `a` and `b` as one cloud, `a`'s points first.
fn joined(a: &Cloud, b: &Cloud) -> Cloud {
    let cols = |c: &Cloud| {
        let pts = c.points();
        (
            pts.vec3_f64("P").unwrap(),
            pts.vec3_f64("N").unwrap(),
            pts.scalar_f64("ptarea").unwrap(),
            pts.vec3_f64("illum").unwrap(),
        )
    };
    let (mut p, mut n, mut ar, mut e) = cols(a);
    let (p2, n2, a2, e2) = cols(b);
    p.extend(p2);
    n.extend(n2);
    ar.extend(a2);
    e.extend(e2);
    cloud_of(&p, &n, &ar, &e)
}

/// Sums and report of `c`.
fn run_report(c: &Cloud, p: &Params) -> (Vec<[f64; 3]>, ssmulti::Report) {
    let mut c = c.clone();
    let r = ssmulti::ssmulti(&mut c, p, &Progress::hidden()).unwrap();
    (c.points().vec3_f64("ssM").unwrap(), r)
}

#[test]
fn an_outlier_or_a_tiny_part_far_away_costs_nothing_and_changes_nothing() {
    let p = Params {
        sd: 0.2,
        bounce: 0.5,
        ..Params::default()
    };
    let same = |a: &[[f64; 3]], b: &[[f64; 3]], what: &str| {
        let top = a.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
        for (x, y) in a.iter().zip(b) {
            for ch in 0..3 {
                assert!(
                    (x[ch] - y[ch]).abs() <= 1e-6 * top,
                    "{what}: {x:?} vs {y:?}"
                );
            }
        }
    };
    let part = wavy(20000, DVec3::ZERO, 1.0, 11);
    let (alone, r_alone) = run_report(&part, &p);
    // One point 1e6 away: the box the Morton codes quantise is a million
    // times the part's, which fits in one cell of it.
    let far = cloud_of(
        &[[1e6, -1e6, 1e6]],
        &[[0.0, 0.0, 1.0]],
        &[0.01],
        &[[1.0; 3]],
    );
    let (got, r) = run_report(&joined(&part, &far), &p);
    same(&alone, &got[..20000], "outlier");
    assert!(got[20000].iter().all(|v| v.is_finite()));
    assert!(
        r.pairs <= r_alone.pairs + 64,
        "with the outlier {} pairs, without {}",
        r.pairs,
        r_alone.pairs
    );
    // The same part beside a scene 1e5 wide whose points see only
    // themselves.
    let scene = wavy(2000, DVec3::new(0.0, 1e3, 0.0), 1e5, 12);
    let (got, r) = run_report(&joined(&part, &scene), &p);
    same(&alone, &got[..20000], "small part");
    assert!(
        r.pairs <= r_alone.pairs + 2000 * 64,
        "in the scene {} pairs, alone {}",
        r.pairs,
        r_alone.pairs
    );
}

#[test]
fn points_spread_over_every_scale_give_finite_sums() {
    // x = 1.5^-k down to subnormal numbers: more scales than the
    // leaves' recoding follows (the deepest are cut in runs).
    let n = 1900;
    let pos: Vec<[f64; 3]> = (0..n)
        .map(|k| [1.5f64.powi(-(k as i32)), 0.0, 0.0])
        .collect();
    let c = cloud_of(
        &pos,
        &vec![[0.0, 0.0, 1.0]; n],
        &vec![1e-3; n],
        &vec![[1.0, 0.5, 0.25]; n],
    );
    let p = Params {
        sd: 4.0,
        ..Params::default()
    };
    let got = run(&c, &p);
    let want = brute(&c, &p);
    for (g, w) in got.iter().zip(&want) {
        for ch in 0..3 {
            assert!(rel_err(g[ch], w[ch]) < 1e-6, "{g:?} vs {w:?}");
        }
    }
}
