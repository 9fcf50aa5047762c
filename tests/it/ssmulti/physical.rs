//! `--model physical` against what it must be: a flat, evenly lit surface
//! returns its irradiance times the medium's multiple-scattering
//! reflectance, the sums equal the f64 double loop of DESIGN.md's text
//! with the medium's kernel, and a closed object returns no more light
//! than enters it.

#![allow(clippy::needless_range_loop)]

use super::*;
use pcsss::cloud::DetailValue;
use pcsss::medium::Medium;

fn physical(medium: Medium) -> Params {
    Params {
        medium: Some(medium),
        ..Params::default()
    }
}

#[test]
fn a_flat_evenly_lit_plane_gives_its_irradiance_times_the_reflectance() {
    let e = [2.0, 1.0, 0.5];
    // Kernel distances (kappa dmfp / 3) of 0.16, 0.11, 0.08 on a plane
    // of 1.2 x 1.2 with points 0.004 apart. (Channel normalisation, by the
    // disk's integral, is off by the grid's quadrature of the profile's
    // 1 / r core: 1.9% here, 1% at half the spacing.)
    let (k, h) = (301usize, 0.004);
    let m = Medium::from_colour([0.8, 0.5, 0.2], [0.037, 0.025, 0.018], true, 1.33, 0.0).unwrap();
    let p = physical(m);
    let ld = p.distances();
    let ld1 = ld.iter().copied().fold(0.0, f64::max);
    assert!((ld1 - 12.952642092055077 * 0.037 / 3.0).abs() < 1e-12);
    for (jitter, norm, tol) in [
        (0.0, Norm::Seed, 1e-5),
        (0.5, Norm::Seed, 1e-3),
        (0.5, Norm::Local, 1e-5),
    ] {
        let c = grid(k, h, e, jitter, 5);
        let mut out = c.clone();
        ssmulti::ssmulti(&mut out, &Params { norm, ..p }, &Progress::hidden()).unwrap();
        let got = out.points().vec3_f64("ssM").unwrap();
        let pos = c.points().vec3_f64("P").unwrap();
        let span = (k - 1) as f64 * h;
        let mut worst: f64 = 0.0;
        let mut inner = 0;
        let mut mean = [0.0f64; 3];
        let mut sq = 0.0f64;
        // (Source normalisation: a source near the edge spreads over its
        // part of the disk, so its receivers lie up to 2 D from the edge.)
        let far = 2.0 * ld1;
        for (q, v) in pos.iter().zip(&got) {
            if q[0] > far && q[0] < span - far && q[1] > far && q[1] < span - far {
                inner += 1;
                for ch in 0..3 {
                    let want = m.rm[ch] * e[ch];
                    worst = worst.max(rel_err(v[ch], want));
                    mean[ch] += v[ch] / want;
                    sq += (v[ch] / want - 1.0).powi(2);
                }
            }
        }
        assert!(inner > 10_000, "{inner}");
        let mean = mean.map(|x| x / inner as f64 - 1.0);
        let rms = (sq / (3 * inner) as f64).sqrt();
        eprintln!("jitter {jitter}, {norm:?}: worst {worst:e}, mean {mean:?}, rms {rms:e}");
        // A regular grid: every point's sum the same. Jittered points
        // are not: the profile's 1 / r core weighs a close neighbour
        // heavily, so each point is off by its neighbourhood, but the
        // mean holds (what a shade point's filter averages).
        if jitter == 0.0 || norm == Norm::Local {
            assert!(worst < tol, "jitter {jitter}, {norm:?}: worst {worst:e}");
        } else {
            assert!(
                mean.iter().all(|x| x.abs() < tol),
                "jitter {jitter}, {norm:?}: mean {mean:?}"
            );
        }
        // What it used is recorded.
        let rec = out.detail("ssmulti_reflectance").unwrap().components();
        assert_eq!(rec, m.rm.to_vec());
        assert_eq!(
            out.detail("ssmulti_colour")
                .unwrap()
                .components()
                .iter()
                .map(|x| (x * 1e4).round())
                .collect::<Vec<_>>(),
            vec![8000.0, 5000.0, 2000.0]
        );
    }
}

/// Light arriving obliquely (`illum_cos` from illum): the plane returns
/// its irradiance times the reflectance at that cosine, which is more than
/// along the normal at eta 1 and less near grazing under a dielectric.
#[test]
fn oblique_light_is_returned_by_the_reflectance_at_its_cosine() {
    let e = [2.0, 1.0, 0.5];
    let (k, h) = (201usize, 0.006);
    for (eta, cos) in [(1.0, 0.5), (1.33, 0.5), (1.33, 0.05)] {
        let m = Medium::from_colour([0.8, 0.5, 0.2], [0.05, 0.035, 0.025], true, eta, 0.0).unwrap();
        let p = physical(m);
        let ld1 = p.distances().iter().copied().fold(0.0, f64::max);
        let mut c = grid(k, h, e, 0.0, 5);
        c.points_mut()
            .set_scalar("illum_cos", vec![cos as f32; k * k])
            .unwrap();
        let mut out = c.clone();
        let rep = ssmulti::ssmulti(&mut out, &p, &Progress::hidden()).unwrap();
        assert!(rep.by_incidence);
        assert_eq!(
            *out.detail("ssmulti_incidence").unwrap(),
            DetailValue::Str("illum_cos".into())
        );
        let want = m.rm_at(cos as f32 as f64);
        let (normal, oblique) = (m.rm[1], want[1]);
        assert!(
            if eta == 1.0 {
                oblique > 1.05 * normal
            } else {
                oblique != normal
            },
            "eta {eta} cos {cos}: {oblique} against {normal} along the normal"
        );
        let got = out.points().vec3_f64("ssM").unwrap();
        let pos = c.points().vec3_f64("P").unwrap();
        let span = (k - 1) as f64 * h;
        let far = 2.0 * ld1;
        let mut inner = 0;
        for (q, v) in pos.iter().zip(&got) {
            if q[0] > far && q[0] < span - far && q[1] > far && q[1] < span - far {
                inner += 1;
                for ch in 0..3 {
                    let w = want[ch] * e[ch];
                    // The incidence table's linear blend between cosines.
                    assert!(
                        rel_err(v[ch], w) < 2e-3,
                        "eta {eta} cos {cos}: {} against {w}",
                        v[ch]
                    );
                }
            }
        }
        assert!(inner > 1000, "{inner}");
        // Without illum_cos: along the normal, and said so.
        let mut plain = grid(k, h, e, 0.0, 5);
        let rep = ssmulti::ssmulti(&mut plain, &p, &Progress::hidden()).unwrap();
        assert!(!rep.by_incidence);
        assert_eq!(
            *plain.detail("ssmulti_incidence").unwrap(),
            DetailValue::Str("normal".into())
        );
    }
}

/// Light between surfaces (`illum_indirect` from `illum --indirect`, part
/// of `illum`): the plane returns the direct light times `rm` and the
/// indirect light times `rm + rs_diffuse`, its single scattering too.
#[test]
fn light_between_surfaces_brings_its_single_scattering() {
    let (direct, indirect) = ([2.0, 1.0, 0.5], [0.3, 0.6, 0.9]);
    let e = [0, 1, 2].map(|c| direct[c] + indirect[c]);
    let (k, h) = (201usize, 0.006);
    let m = Medium::new([0.95, 0.8, 0.5], [0.02, 0.03, 0.05], 1.0, 0.0).unwrap();
    let p = physical(m);
    let ld1 = p.distances().iter().copied().fold(0.0, f64::max);
    let mut c = grid(k, h, e, 0.0, 5);
    let ind = vec![indirect.map(|x| x as f32); k * k];
    c.points_mut()
        .set_vec3("illum_indirect", pcsss::cloud::Role::Color, &ind)
        .unwrap();
    let rep = ssmulti::ssmulti(&mut c, &p, &Progress::hidden()).unwrap();
    assert!(rep.indirect);
    assert!(c.detail("ssmulti_indirect").is_some());
    let rs = m.rs_diffuse();
    let got = c.points().vec3_f64("ssM").unwrap();
    let pos = c.points().vec3_f64("P").unwrap();
    let (span, far) = ((k - 1) as f64 * h, 2.0 * ld1);
    let mut inner = 0;
    for (q, v) in pos.iter().zip(&got) {
        if q[0] > far && q[0] < span - far && q[1] > far && q[1] < span - far {
            inner += 1;
            for ch in 0..3 {
                let w = m.rm[ch] * e[ch] + rs[ch] * indirect[ch];
                assert!(rel_err(v[ch], w) < 1e-3, "{} against {w}", v[ch]);
            }
        }
    }
    assert!(inner > 1000, "{inner}");
}

/// Light entering a thin part (`thickness` from `illum --thickness`): the
/// plane returns its irradiance times the multiple-scattering light a slab
/// that thick sends out of both faces.
#[test]
fn a_thin_part_returns_what_a_slab_that_thick_does() {
    let e = [2.0, 1.0, 0.5];
    let (k, h) = (201usize, 0.006);
    let m = Medium::new([0.95, 0.8, 0.5], [0.02, 0.03, 0.05], 1.3, 0.2).unwrap();
    let p = physical(m);
    let ld1 = p.distances().iter().copied().fold(0.0, f64::max);
    for t in [0.005, 0.04, 1e9] {
        let mut c = grid(k, h, e, 0.0, 5);
        c.points_mut()
            .set_scalar("thickness", vec![t as f32; k * k])
            .unwrap();
        let rep = ssmulti::ssmulti(&mut c, &p, &Progress::hidden()).unwrap();
        assert!(rep.by_thickness && !rep.by_incidence);
        assert_eq!(
            *c.detail("ssmulti_thickness").unwrap(),
            DetailValue::Str("thickness".into())
        );
        let want = m.rm_slab(t as f32 as f64);
        // (A fraction of a mean free path scatters little; one to a few
        // return more than a thick part, which absorbs what diffuses deep.)
        if t < 0.01 {
            assert!(
                want.iter().zip(&m.rm).all(|(a, b)| a < &(0.5 * b)),
                "{want:?}"
            );
        }
        let got = c.points().vec3_f64("ssM").unwrap();
        let pos = c.points().vec3_f64("P").unwrap();
        let (span, far) = ((k - 1) as f64 * h, 2.0 * ld1);
        for (q, v) in pos.iter().zip(&got) {
            if q[0] > far && q[0] < span - far && q[1] > far && q[1] < span - far {
                for ch in 0..3 {
                    let w = want[ch] * e[ch];
                    // The thickness table's blend in ln T.
                    assert!(rel_err(v[ch], w) < 0.01, "T {t}: {} against {w}", v[ch]);
                }
            }
        }
    }
}

/// A NaN `illum_cos` or `thickness` is refused, naming the point and
/// the attribute.
#[test]
fn nan_weights_are_refused_naming_the_point() {
    let m = Medium::new([0.8; 3], [0.05; 3], 1.3, 0.0).unwrap();
    for name in ["illum_cos", "thickness"] {
        let mut c = wavy(200, DVec3::ZERO, 1.0, 4);
        let mut v = vec![0.5f32; 200];
        v[37] = f32::NAN;
        c.points_mut().set_scalar(name, v).unwrap();
        let err = ssmulti::ssmulti(&mut c, &physical(m), &Progress::hidden())
            .unwrap_err()
            .to_string();
        assert!(err.contains("point 37") && err.contains(name), "{err}");
    }
}

/// A slab two mean free paths thick, lit on one face: the light its
/// thickness returns leaves by both faces, a share moved to the far
/// face's points so that, after the kernel spreads both, the far face
/// returns the share the slab walk gives (the kernel alone puts half as
/// much there); together the two faces return the whole.
#[test]
fn a_slab_lit_on_one_face_shares_its_light_between_its_faces() {
    let m = Medium::new([0.9; 3], [0.02; 3], 1.0, 0.0).unwrap();
    let p = physical(m);
    let ld1 = p.distances()[0];
    let (k, h, t) = (161usize, 0.005, 0.04);
    let span = (k - 1) as f64 * h;
    // The lit face (z 0, facing down) and the far one (z t, facing up,
    // or down too: then nothing is moved).
    let slab = |far_up: bool| {
        let (mut pos, mut nrm, mut area, mut e) = (vec![], vec![], vec![], vec![]);
        for (z, up, lit) in [(0.0, false, true), (t, far_up, false)] {
            for a in 0..k {
                for b in 0..k {
                    pos.push([a as f64 * h, b as f64 * h, z]);
                    nrm.push([0.0, 0.0, if up { 1.0 } else { -1.0 }]);
                    area.push(h * h);
                    e.push(if lit { [1.0; 3] } else { [0.0; 3] });
                }
            }
        }
        let mut c = cloud_of(&pos, &nrm, &area, &e);
        c.points_mut()
            .set_scalar("thickness", vec![t as f32; 2 * k * k])
            .unwrap();
        c
    };
    let faces = |c: &Cloud| {
        let got = run(c, &p);
        let pos = c.points().vec3_f64("P").unwrap();
        let far = 2.0 * ld1;
        let (mut s, mut n) = ([0.0f64; 2], [0usize; 2]);
        for (q, v) in pos.iter().zip(&got) {
            if q[0] > far && q[0] < span - far && q[1] > far && q[1] < span - far {
                let f = (q[2] > 0.0) as usize;
                s[f] += v[0];
                n[f] += 1;
            }
        }
        assert!(n[0] > 100 && n[1] > 100, "{n:?}");
        [s[0] / n[0] as f64, s[1] / n[1] as f64]
    };
    let [near, far] = faces(&slab(true));
    let whole = m.rm_slab(t)[0];
    assert!(
        rel_err(near + far, whole) < 0.02,
        "{near} + {far} against {whole}"
    );
    let want = m.through_slab(t)[0];
    let [n0, f0] = faces(&slab(false));
    let (moved, kernel) = (far / (near + far), f0 / (n0 + f0));
    eprintln!("far face's share {moved} (kernel alone {kernel}), the walk's {want}");
    assert!(
        (moved - want).abs() < 0.01 && (kernel - want).abs() > 0.1,
        "far face's share {moved} (kernel alone {kernel}), the walk's {want}"
    );
}

#[test]
fn the_sums_equal_the_double_loop_with_the_medium_kernel() {
    let m = Medium::new([0.99, 0.9, 0.6], [0.05, 0.04, 0.1], 1.4, 0.3).unwrap();
    let p = physical(m);
    let c = wavy(3000, DVec3::new(3.0, -2.0, 1.0), 1.0, 9);
    let got = run(&c, &p);
    // DESIGN.md's double loop (`brute`) with Marengo's parameters that
    // give the same kernels: per-channel distances `Rd * sd` equal to the
    // medium's, each channel then scaled from Rd to the reflectance.
    let r = p.resolved();
    let ld = p.distances();
    let as_seed = Params {
        medium: None,
        rd: ld,
        sd: 1.0,
        ..r
    };
    assert_eq!((as_seed.norm, as_seed.rgb), (Norm::Source, true));
    let want = brute(&c, &as_seed);
    let mut worst: f64 = 0.0;
    for (g, w) in got.iter().zip(&want) {
        for ch in 0..3 {
            worst = worst.max(rel_err(g[ch], w[ch] * m.rm[ch] / ld[ch]));
        }
    }
    assert!(worst < 1e-5, "worst {worst:e}");
    // Half of it in the dark, whole leaves of it: the source
    // normalisation's area pass skips them (no light to spread), and the
    // sums are still the double loop's.
    let mut half = c.clone();
    let pos = c.points().vec3_f64("P").unwrap();
    let mut e: Vec<[f32; 3]> = c
        .points()
        .vec3_f64("illum")
        .unwrap()
        .iter()
        .map(|v| v.map(|x| x as f32))
        .collect();
    for (v, q) in e.iter_mut().zip(&pos) {
        if q[1] > -1.0 {
            *v = [0.0; 3];
        }
    }
    half.points_mut()
        .set_vec3("illum", Role::Color, &e)
        .unwrap();
    let got = run(&half, &p);
    let want = brute(&half, &as_seed);
    let mut worst: f64 = 0.0;
    for (g, w) in got.iter().zip(&want) {
        for ch in 0..3 {
            worst = worst.max(rel_err(g[ch], w[ch] * m.rm[ch] / ld[ch]));
        }
    }
    assert!(worst < 1e-5, "half dark: worst {worst:e}");
}

/// A unit sphere of 10,000 points (and with `shell`, a second one of
/// radius 0.97 inside it, facing inwards and unlit: a thin shell), lit
/// from +z with irradiance `cos`: the cloud, the points' areas and the
/// light that enters (before Fresnel).
pub(super) fn lit_sphere(shell: bool) -> (Cloud, f64) {
    let mesh = icosphere(3);
    let outer = scatter_n(&mesh, 10_000, 3, pcsss::stages::scatter::PtareaMode::Prim);
    let mut p = outer.points().vec3_f64("P").unwrap();
    let mut a = outer.points().scalar_f64("ptarea").unwrap();
    let mut n: Vec<[f64; 3]> = p
        .iter()
        .map(|q| DVec3::from_array(*q).normalize().to_array())
        .collect();
    let mut e: Vec<[f64; 3]> = n.iter().map(|q| [q[2].max(0.0); 3]).collect();
    let entering: f64 = (0..p.len()).map(|i| e[i][0] * a[i]).sum();
    if shell {
        let k = p.len();
        for i in 0..k {
            p.push(p[i].map(|x| 0.97 * x));
            a.push(a[i] * 0.97 * 0.97);
            n.push(n[i].map(|x| -x));
            e.push([0.0; 3]);
        }
    }
    (cloud_of(&p, &n, &a, &e), entering)
}

#[test]
fn a_closed_sphere_and_a_thin_shell_return_no_more_light_than_enters() {
    // Source normalisation spreads each source's light over the area
    // within its reach: what leaves is what enters times the reflectance,
    // for distances short and long against the size, and through a shell
    // thinner than them.
    for shell in [false, true] {
        let (c, entering) = lit_sphere(shell);
        let area = c.points().scalar_f64("ptarea").unwrap();
        for dmfp in [0.02, 0.1, 0.3] {
            let m = Medium::from_colour(
                [0.9, 0.6, 0.3],
                [dmfp, dmfp * 0.7, dmfp * 0.5],
                true,
                1.3,
                0.0,
            )
            .unwrap();
            let got = run(&c, &physical(m));
            for ch in 0..3 {
                let out: f64 = (0..area.len()).map(|i| got[i][ch] * area[i]).sum();
                let most = entering * m.rm[ch];
                assert!(
                    (out / most - 1.0).abs() < 1e-4,
                    "shell {shell}, dmfp {dmfp}, channel {ch}: {out} against {most}"
                );
            }
        }
    }
}

#[test]
fn a_white_medium_and_tiny_or_huge_paths_are_refused_or_finite() {
    // Albedo 1 absorbs nothing: no diffusion length.
    let m = Medium::new([1.0, 0.5, 0.5], [1.0; 3], 1.3, 0.0).unwrap();
    let err = ssmulti::validate(&physical(m)).unwrap_err().to_string();
    assert!(err.contains("albedo") && err.contains("channel 0"), "{err}");
    let c = wavy(500, DVec3::ZERO, 1.0, 2);
    for (mfp, eta, alpha) in [
        (1e-8, 1.0001, 0.3),
        (1e-3, 3.0, 0.9999),
        (1e8, 1.3, 0.5),
        (1e-3, 1.3, 0.0),
        (1.0, 1.0, 0.9999),
    ] {
        let m = Medium::new([alpha; 3], [mfp; 3], eta, 0.0).unwrap();
        let got = run(&c, &physical(m));
        assert!(
            got.iter().flatten().all(|x| x.is_finite() && *x >= 0.0),
            "mfp {mfp}, eta {eta}, albedo {alpha}"
        );
        // With the light's cosines and the thicknesses behind (grazing to
        // along the normal; nothing, a hair's breadth, an open mesh's
        // float maximum, infinity): finite too.
        let mut weighed = c.clone();
        let n = weighed.points().len();
        let cos: Vec<f32> = (0..n).map(|i| [0.0, 0.01, 0.5, 1.0, 1.5][i % 5]).collect();
        let thick: Vec<f32> = (0..n)
            .map(|i| [0.0, 1e-30, 0.3, f32::MAX, f32::INFINITY][i % 5])
            .collect();
        weighed.points_mut().set_scalar("illum_cos", cos).unwrap();
        weighed.points_mut().set_scalar("thickness", thick).unwrap();
        let w = run(&weighed, &physical(m));
        assert!(
            w.iter().flatten().all(|x| x.is_finite() && *x >= 0.0),
            "weighed: mfp {mfp}, eta {eta}, albedo {alpha}"
        );
        if mfp < 1e-6 {
            // A kernel narrower than every point's disk: each point
            // returns its own light, the limit as the kernel shrinks.
            let e = c.points().vec3_f64("illum").unwrap();
            for (g, e) in got.iter().zip(&e) {
                for ch in 0..3 {
                    assert!(
                        rel_err(g[ch], m.rm[ch] * e[ch]) < 1e-6,
                        "{g:?} against {e:?}"
                    );
                }
            }
        }
    }
}
