//! The exact method against an f64 double loop written from docs/DESIGN.md,
//! and what it skips.

use super::*;

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
        for norm in [Norm::Seed, Norm::Channel, Norm::Local, Norm::Source] {
            for (rgb, rd) in [
                (false, [0.8, 0.5, 0.3]),
                (true, [0.8, 0.5, 0.3]),
                (true, [0.6, 0.6, 0.6]),
                (true, [0.7, 0.0, 0.35]),
                // (The channels summed longest reach first.)
                (true, [0.3, 0.8, 0.5]),
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
        for norm in [Norm::Seed, Norm::Channel, Norm::Local, Norm::Source] {
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
    // A distance of zero has no kernel (the limit sd -> 0 is Rd * illum,
    // not the 0 an empty sum gives): refused, naming --sd.
    let e = ssmulti::ssmulti(
        &mut copy,
        &Params {
            sd: 0.0,
            ..Params::default()
        },
        &Progress::hidden(),
    )
    .unwrap_err();
    assert!(
        e.is_param() && e.to_string().contains("parameter sd"),
        "{e}"
    );
}
