//! The walk method (`ssmulti --method walk`) against independent truth:
//! a large thick box is a half-space, whose multiple scattering the
//! medium's own slab walk and Chandrasekhar's H give (the medium's
//! tests); a thin box lit from behind passes what the medium's slab walk
//! through a slab of that thickness passes; the bits do not depend on the
//! thread count; bad parameters are refused; a per-point material walks
//! in each point's medium.

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::geom::mesh::TriMesh;
use pcsss::medium::Medium;
use pcsss::progress::Progress;
use pcsss::stages::ssmulti::walk::{ssmulti_walk, WalkParams};
use pcsss::stages::ssmulti::Params;
use pcsss::Cloud;

/// A box `[lo, hi]` as a mesh, outward normals.
fn box_mesh(lo: [f64; 3], hi: [f64; 3]) -> TriMesh {
    TriMesh::from_cloud(&from_bytes(box_obj(lo, hi).as_bytes())).unwrap()
}

/// `ssM` of the points `pts` by `walks` walks a point through `mesh` in
/// the medium `m`, seeded by `seed`.
fn walked(mesh: &TriMesh, m: Medium, pts: &[Lit], walks: u32, seed: u64) -> Vec<[f64; 3]> {
    let mut c = cloud_of(pts);
    let w = WalkParams {
        walks,
        seed,
        ..WalkParams::default()
    };
    ssmulti_walk(&mut c, mesh, &physical(m), &w, &Progress::hidden()).unwrap();
    c.points().vec3_f64("ssM").unwrap()
}

/// A point: its position, normal, `illum` and `illum_cos`.
type Lit = ([f64; 3], [f64; 3], [f64; 3], f64);

/// The cloud of points `pts`.
fn cloud_of(pts: &[Lit]) -> Cloud {
    let mut c = Cloud::with_points(pts.len());
    let p = c.points_mut();
    p.set_vec3(
        "P",
        Role::Point,
        &pts.iter().map(|q| q.0).collect::<Vec<_>>(),
    )
    .unwrap();
    p.set_vec3(
        "N",
        Role::Normal,
        &pts.iter().map(|q| q.1).collect::<Vec<_>>(),
    )
    .unwrap();
    p.set_vec3(
        "illum",
        Role::Color,
        &pts.iter().map(|q| q.2).collect::<Vec<_>>(),
    )
    .unwrap();
    p.set_scalar("illum_cos", pts.iter().map(|q| q.3).collect::<Vec<f64>>())
        .unwrap();
    c
}

fn physical(m: Medium) -> Params {
    Params {
        medium: Some(m),
        ..Params::default()
    }
}

/// The top face of a box 200 mean free paths wide and 60 deep is a
/// half-space: under light at cosine `mu`, ssM is the medium's
/// multiple-scattering reflectance there, `rm_at(mu)`, per channel.
#[test]
fn a_thick_box_returns_the_half_space_s_reflectance() {
    let mesh = box_mesh([-100.0, -100.0, -60.0], [100.0, 100.0, 0.0]);
    for (albedo, eta, g, mu) in [
        ([0.9, 0.7, 0.5], 1.0, 0.0, 1.0),
        ([0.95, 0.8, 0.6], 1.3, 0.0, 0.5),
        ([0.9, 0.9, 0.9], 1.3, 0.6, 1.0),
    ] {
        let m = Medium::new(albedo, [1.0, 1.0, 1.0], eta, g).unwrap();
        // Points about the centre, and a floor of dark ones for the light
        // where walks leave elsewhere.
        let mut pts = Vec::new();
        for k in 0..64 {
            let (x, y) = ((k % 8) as f64 - 3.5, (k / 8) as f64 - 3.5);
            pts.push(([x, y, 0.0], [0.0, 0.0, 1.0], [1.0; 3], mu));
        }
        let ssm = walked(&mesh, m, &pts, 1500, 7);
        let want = m.rm_at(mu);
        for ch in 0..3 {
            let got: f64 = ssm.iter().map(|s| s[ch]).sum::<f64>() / ssm.len() as f64;
            // (96k walks: a standard error near 0.4%.)
            assert!(
                (got / want[ch] - 1.0).abs() < 0.015,
                "albedo {albedo:?} eta {eta} g {g} mu {mu}: channel {ch}: {got} against {}",
                want[ch]
            );
        }
    }
}

/// Light between surfaces (`illum --indirect` adds it to `illum`, and
/// keeps it apart as `illum_indirect`): on the half-space, its multiple
/// scattering with the rest, and its single scattering, which sssingle
/// does not follow, from the whole sky: `rm (E_d + E_i) + rs_diffuse E_i`.
#[test]
fn light_between_surfaces_returns_its_single_scattering_too() {
    let mesh = box_mesh([-100.0, -100.0, -60.0], [100.0, 100.0, 0.0]);
    let m = Medium::new([0.9, 0.7, 0.5], [1.0; 3], 1.3, 0.0).unwrap();
    let (direct, indirect) = (1.0, 0.5);
    let pts: Vec<Lit> = (0..64)
        .map(|k| {
            let (x, y) = ((k % 8) as f64 - 3.5, (k / 8) as f64 - 3.5);
            ([x, y, 0.0], [0.0, 0.0, 1.0], [direct + indirect; 3], 1.0)
        })
        .collect();
    let mut c = cloud_of(&pts);
    c.points_mut()
        .set_vec3("illum_indirect", Role::Color, &vec![[indirect; 3]; 64])
        .unwrap();
    let w = WalkParams {
        walks: 1500,
        seed: 9,
        ..WalkParams::default()
    };
    let rep = ssmulti_walk(&mut c, &mesh, &physical(m), &w, &Progress::hidden()).unwrap();
    assert!(rep.indirect);
    let ssm = c.points().vec3_f64("ssM").unwrap();
    let rs = m.rs_diffuse();
    for ch in 0..3 {
        let want = m.rm[ch] * (direct + indirect) + rs[ch] * indirect;
        let got: f64 = ssm.iter().map(|s| s[ch]).sum::<f64>() / ssm.len() as f64;
        assert!(
            (got / want - 1.0).abs() < 0.015,
            "channel {ch}: {got} against {want}"
        );
    }
}

/// The bits of a run do not depend on how many threads run it.
#[test]
fn the_same_bits_whatever_the_thread_count() {
    let mesh = box_mesh([0.0; 3], [4.0, 4.0, 1.0]);
    let m = Medium::new([0.9, 0.8, 0.7], [0.3, 0.5, 0.8], 1.3, 0.3).unwrap();
    let pts: Vec<_> = (0..200)
        .map(|k| {
            let (x, y) = ((k % 20) as f64 * 0.2 + 0.1, (k / 20) as f64 * 0.4 + 0.1);
            ([x, y, 1.0], [0.0, 0.0, 1.0], [x / 4.0, 0.5, 1.0], 0.8)
        })
        .collect();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut c = cloud_of(&pts);
        let w = WalkParams {
            walks: 16,
            seed: 3,
            ..WalkParams::default()
        };
        pool.install(|| ssmulti_walk(&mut c, &mesh, &physical(m), &w, &Progress::hidden()))
            .unwrap();
        c.points().vec3_f64("ssM").unwrap()
    };
    let one = run(1);
    assert!(one.iter().any(|s| s[0] > 0.0));
    assert_eq!(one, run(3));
}

/// A thin box lit from behind: the front's ssM is the light a slab of that
/// thickness passes after two events or more, as the medium's own slab
/// walk counts it (entering evenly, by reciprocity, and weighed as the
/// method weighs light along the normal).
#[test]
fn a_thin_box_passes_what_a_slab_passes() {
    use pcsss::medium::walk::walk_faces;
    let (albedo, eta, g) = ([0.95, 0.8, 0.5], 1.3, 0.0);
    let m = Medium::new(albedo, [1.0; 3], eta, g).unwrap();
    let rm_d = m.rm_diffuse();
    for thick in [0.5, 2.0] {
        let mesh = box_mesh([-60.0, -60.0, -thick], [60.0, 60.0, 0.0]);
        // The front (z = 0, dark) about the centre; the back lit along its
        // normal, sampled densely enough that every exit finds its light.
        let mut pts = Vec::new();
        for k in 0..16 {
            let (x, y) = ((k % 4) as f64 - 1.5, (k / 4) as f64 - 1.5);
            pts.push(([x, y, 0.0], [0.0, 0.0, 1.0], [0.0; 3], 1.0));
        }
        for k in 0..(41 * 41) {
            let (x, y) = ((k % 41) as f64 - 20.0, (k / 41) as f64 - 20.0);
            pts.push(([x, y, -thick], [0.0, 0.0, -1.0], [1.0; 3], 1.0));
        }
        let ssm = walked(&mesh, m, &pts, 3000, 11);
        // The slab: entering evenly (cosine-weighted outside, Fresnel in),
        // the share that leaves by the far face after two events or more.
        let nodes = 16;
        let mut through = [0.0; 3];
        for q in 0..nodes {
            // mu^2 uniform: cosine-weighted.
            let mu = ((q as f64 + 0.5) / nodes as f64).sqrt();
            let t_in = 1.0 - pcsss::optics::fresnel(mu, eta);
            let (_, far) = walk_faces(g, eta, mu, thick, 20_000, 5);
            for ch in 0..3 {
                through[ch] += t_in * far.reflectance(albedo[ch], 2) / nodes as f64;
            }
        }
        for ch in 0..3 {
            let want = through[ch] * m.rm[ch] / rm_d[ch];
            let got: f64 = ssm[..16].iter().map(|s| s[ch]).sum::<f64>() / 16.0;
            assert!(
                (got / want - 1.0).abs() < 0.03,
                "thickness {thick}: channel {ch}: {got} against {want}"
            );
        }
    }
}

/// Zero walks, a NaN or absurd medium, and the seed model are refused,
/// each naming its parameter; an open mesh loses the walks that leave
/// through its hole, and says how many.
#[test]
fn bad_parameters_are_refused_and_an_open_mesh_is_counted() {
    let mesh = box_mesh([0.0; 3], [1.0; 3]);
    let m = Medium::new([0.9; 3], [0.1; 3], 1.0, 0.0).unwrap();
    let mut c = cloud_of(&[([0.5, 0.5, 1.0], [0.0, 0.0, 1.0], [1.0; 3], 1.0)]);
    let hidden = Progress::hidden();
    let name = |e: pcsss::Error| match e {
        pcsss::Error::Param { name, .. } => name,
        e => panic!("{e}"),
    };
    let zero = WalkParams {
        walks: 0,
        seed: 0,
        ..WalkParams::default()
    };
    let e = ssmulti_walk(&mut c, &mesh, &physical(m), &zero, &hidden).unwrap_err();
    assert_eq!(name(e), "walks");
    let w = WalkParams::default();
    let e = ssmulti_walk(&mut c, &mesh, &Params::default(), &w, &hidden).unwrap_err();
    assert_eq!(name(e), "method");
    assert!(Medium::new([0.9; 3], [f64::NAN; 3], 1.0, 0.0).is_err());
    // The box without its top: walks leave through the hole.
    let mut text =
        String::from_utf8(std::fs::read(fixtures().join("mesh/cube.obj")).unwrap()).unwrap();
    text = text.replace("f 5 6 7 8\n", "");
    let open = TriMesh::from_cloud(&from_bytes(text.as_bytes())).unwrap();
    let rep = ssmulti_walk(&mut c, &open, &physical(m), &w, &hidden).unwrap();
    assert!(rep.lost * 4 > rep.walks, "{rep:?}");
    let rep = ssmulti_walk(&mut c, &mesh, &physical(m), &w, &hidden).unwrap();
    assert_eq!(rep.lost, 0);
    assert!(c.points().vec3_f64("ssM").unwrap()[0][0] > 0.0);
}

/// The binary: `--method walk` needs its mesh and the physical model,
/// each refusal naming the option at fault with exit 2; a run records its
/// method, walks, seed and mesh.
#[test]
fn the_binary_takes_the_walk_method() {
    let d = tempdir();
    let mesh = fixtures().join("mesh/cube.obj").display().to_string();
    let lit = d.path().join("lit.ply");
    let mut c = cloud_of(&[
        ([0.5, 0.5, 1.0], [0.0, 0.0, 1.0], [1.0; 3], 1.0),
        ([0.5, 0.5, 0.0], [0.0, 0.0, -1.0], [0.0; 3], 1.0),
    ]);
    // (The filter's radius: twice the spacing ptarea gives.)
    c.points_mut().set_scalar("ptarea", vec![0.5; 2]).unwrap();
    std::fs::write(&lit, to_bytes(&c, pcsss::formats::Format::DEFAULT)).unwrap();
    let lit = lit.display().to_string();
    let out = d.path().join("out.ply").display().to_string();
    for (args, flag) in [
        (vec!["--method", "walk", "--material", "skin1"], "--mesh"),
        (
            vec!["--method", "walk", "--mesh", &mesh, "--sd", "1"],
            "--method",
        ),
        (
            vec![
                "--method",
                "walk",
                "--mesh",
                &mesh,
                "--material",
                "skin1",
                "--walks",
                "0",
            ],
            "--walks",
        ),
    ] {
        let mut all = vec![lit.as_str(), "-o", &out];
        all.extend(&args);
        let o = run("ssmulti", &all, b"");
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(flag), "{args:?}: {}", stderr(&o));
        assert!(!std::path::Path::new(&out).exists());
    }
    let all = [
        lit.as_str(),
        "-o",
        &out,
        "--method",
        "walk",
        "--mesh",
        &mesh,
        "--material",
        "skin1",
        "--walks",
        "200",
        "--seed",
        "5",
    ];
    let o = run("ssmulti", &all, b"");
    assert!(o.status.success(), "{}", stderr(&o));
    let c = from_bytes(&std::fs::read(&out).unwrap());
    let detail = |k: &str| c.detail(k).map(|v| format!("{v:?}"));
    assert!(detail("ssmulti_method").unwrap().contains("walk"));
    assert!(detail("ssmulti_walks").unwrap().contains("200"));
    assert!(detail("ssmulti_seed").unwrap().contains('5'));
    assert!(detail("ssmulti_mesh").is_some());
    let ssm = c.points().vec3_f64("ssM").unwrap();
    assert!(ssm[0][0] > 0.0, "{ssm:?}");
    // filter computes the same ssM lazily by walks (render likewise,
    // through its own mesh); without a mesh, an error naming it.
    let shade = d.path().join("shade.ply").display().to_string();
    let stored = run("filter", &[&lit, "--cloud", &out, "-o", &shade], b"");
    assert!(stored.status.success(), "{}", stderr(&stored));
    let want = from_bytes(&std::fs::read(&shade).unwrap());
    let lazy = [
        lit.as_str(),
        "--cloud",
        &lit,
        "--material",
        "skin1",
        "--method",
        "walk",
        "--walk-mesh",
        &mesh,
        "--walks",
        "200",
        "--walk-seed",
        "5",
        "-o",
        &shade,
    ];
    let o = run("filter", &lazy, b"");
    assert!(o.status.success(), "{}", stderr(&o));
    let got = from_bytes(&std::fs::read(&shade).unwrap());
    assert_eq!(
        got.points().vec3_f32("ssM").unwrap(),
        want.points().vec3_f32("ssM").unwrap()
    );
    let o = run(
        "filter",
        &lazy[..7]
            .iter()
            .chain(&["-o", &shade])
            .copied()
            .collect::<Vec<_>>(),
        b"",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--walk-mesh"), "{}", stderr(&o));
}

/// The noise filtered on the cloud (`--denoise`), on a half-space lit on
/// one side of a line: against a run of 64 times the walks, the filtered
/// estimate's error is a fraction of the unfiltered one's, and the
/// shadow's edge stays where it is (the filter does not carry the lit
/// side's light across it, nor the dark side's in).
#[test]
fn the_filter_takes_the_noise_and_keeps_a_shadow_s_edge() {
    let mesh = box_mesh([-100.0, -100.0, -60.0], [100.0, 100.0, 0.0]);
    let m = Medium::new([0.9, 0.8, 0.6], [1.0; 3], 1.0, 0.0).unwrap();
    let pts: Vec<Lit> = (0..(24 * 24))
        .map(|k| {
            let (x, y) = ((k % 24) as f64 * 0.5 - 6.0, (k / 24) as f64 * 0.5 - 6.0);
            let e = if x < 0.0 { 1.0 } else { 0.0 };
            ([x, y, 0.0], [0.0, 0.0, 1.0], [e; 3], 1.0)
        })
        .collect();
    let run = |walks: u32, denoise: bool| {
        let mut c = cloud_of(&pts);
        let w = WalkParams {
            walks,
            seed: 21,
            denoise,
            ..WalkParams::default()
        };
        ssmulti_walk(&mut c, &mesh, &physical(m), &w, &Progress::hidden()).unwrap();
        c.points().vec3_f64("ssM").unwrap()
    };
    let truth = run(1024, false);
    let (raw, filtered) = (run(16, false), run(16, true));
    let rms = |v: &[[f64; 3]]| {
        let s: f64 = v
            .iter()
            .zip(&truth)
            .map(|(a, b)| (a[0] - b[0]).powi(2))
            .sum();
        (s / v.len() as f64).sqrt()
    };
    let (e_raw, e_filtered) = (rms(&raw), rms(&filtered));
    assert!(e_filtered < 0.5 * e_raw, "{e_filtered} against {e_raw}");
    // Across the edge: the mean over the points within a mean free path
    // of it on each side, filtered against unfiltered. (The unfiltered
    // mean is unbiased, and shares the filtered one's walks: their
    // difference is the filter's shift, where against the truth the
    // band's own noise, near 2% of the lit level, would hide it.)
    let band = |lo: f64, hi: f64, v: &[[f64; 3]]| {
        let sel: Vec<f64> = pts
            .iter()
            .zip(v)
            .filter(|(p, _)| p.0[0] >= lo && p.0[0] < hi)
            .map(|(_, s)| s[0])
            .collect();
        sel.iter().sum::<f64>() / sel.len() as f64
    };
    for (lo, hi) in [(-1.0, 0.0), (0.0, 1.0), (2.0, 4.0)] {
        let (f, t) = (band(lo, hi, &filtered), band(lo, hi, &raw));
        assert!(
            (f - t).abs() < 0.03 * band(-6.0, -3.0, &truth),
            "x in [{lo}, {hi}): {f} against {t}"
        );
    }
}

/// A per-point material: each point's walks take its own medium (as
/// Cycles' walk keeps its shading point's). On a half-space of two
/// albedos side by side under even light, each point returns its own
/// medium's `rm_at(1)`, wherever its walks leave; a constant attribute
/// gives the constant material's bits.
#[test]
fn a_per_point_material_walks_in_each_point_s_own_medium() {
    let d = tempdir();
    std::fs::write(
        d.path().join("box.obj"),
        box_obj([-100.0, -100.0, -60.0], [100.0, 100.0, 0.0]),
    )
    .unwrap();
    let (a, b) = (0.6, 0.95);
    let pts: Vec<Lit> = (0..64)
        .map(|k| {
            let (x, y) = ((k % 8) as f64 - 3.5, (k / 8) as f64 - 3.5);
            ([x, y, 0.0], [0.0, 0.0, 1.0], [1.0; 3], 1.0)
        })
        .collect();
    let run_with = |alb: &dyn Fn(f64) -> f64, material: &str| -> (Vec<[f64; 3]>, Cloud) {
        let mut c = cloud_of(&pts);
        let v: Vec<f64> = pts.iter().map(|p| alb(p.0[0])).collect();
        c.points_mut().set_scalar("alb", v).unwrap();
        std::fs::write(
            d.path().join("lit.ply"),
            to_bytes(&c, pcsss::formats::Format::DEFAULT),
        )
        .unwrap();
        std::fs::write(d.path().join("mat.json"), material).unwrap();
        let args = [
            "lit.ply",
            "--material",
            "mat.json",
            "--method",
            "walk",
            "--mesh",
            "box.obj",
            "--walks",
            "1500",
            "--seed",
            "3",
            "-o",
            "out.ply",
        ];
        let o = run_in(Some(d.path()), "ssmulti", &args, b"");
        assert!(o.status.success(), "{material}: {}", stderr(&o));
        let out = from_bytes(&std::fs::read(d.path().join("out.ply")).unwrap());
        (out.points().vec3_f64("ssM").unwrap(), out)
    };
    let per = r#"{"albedo": 0.8, "mfp": 1, "eta": 1.3, "per_point": {"albedo": "alb"}}"#;
    let (v, out) = run_with(&|x| if x < 0.0 { a } else { b }, per);
    assert!(matches!(
        out.detail("ssmulti_per_point"),
        Some(pcsss::cloud::DetailValue::Str(s)) if s == "albedo from alb"
    ));
    for (albedo, left) in [(a, true), (b, false)] {
        let want = Medium::new([albedo; 3], [1.0; 3], 1.3, 0.0)
            .unwrap()
            .rm_at(1.0)[0];
        let side: Vec<f64> = pts
            .iter()
            .zip(&v)
            .filter(|(p, _)| (p.0[0] < 0.0) == left)
            .map(|(_, s)| s[0])
            .collect();
        let got = side.iter().sum::<f64>() / side.len() as f64;
        // (48k walks a side: a standard error under 0.6%.)
        assert!(
            (got / want - 1.0).abs() < 0.02,
            "albedo {albedo}: {got} against {want}"
        );
    }
    let (constant, _) = run_with(&|_| a, r#"{"albedo": 0.6, "mfp": 1, "eta": 1.3}"#);
    let (per_constant, _) = run_with(&|_| a, per);
    assert_eq!(constant, per_constant);
}

/// Guided walks (Dwivedi's sampling, with the far side's lobe in a thin
/// part) have the classic walks' mean, through a thick box and a thin
/// one, at a high albedo and with anisotropy; and less noise a walk where
/// the albedo is high.
#[test]
fn guided_walks_keep_the_classic_mean_with_less_noise() {
    use pcsss::geom::bvh::Occluder;
    use pcsss::medium::mesh_walk::{End, Walker};
    use rand_pcg::Pcg32;
    // The mean and standard error of what walks from the top's centre
    // carry out after two events or more, channel 0 and 2.
    let stats = |walker: &Walker, m: &Medium, walks: u64| -> [(f64, f64); 2] {
        let m = walker.medium(m);
        let mut r = Pcg32::new(11, 0);
        let (mut s, mut q) = ([0.0; 2], [0.0; 2]);
        for _ in 0..walks {
            let e = walker.walk(&m, glam::DVec3::ZERO, glam::DVec3::Z, &mut r);
            if let End::Exit { events, weight, .. } = e {
                if events >= 2 {
                    for (k, c) in [0, 2].into_iter().enumerate() {
                        s[k] += weight[c];
                        q[k] += weight[c] * weight[c];
                    }
                }
            }
        }
        let n = walks as f64;
        [0, 1].map(|k| {
            let mean = s[k] / n;
            (mean, ((q[k] / n - mean * mean).max(0.0) / n).sqrt())
        })
    };
    for (depth, albedo, g) in [
        (60.0, [0.95, 0.9, 0.8], 0.0),
        (1.0, [0.99, 0.9, 0.6], 0.0),
        (3.0, [0.999, 0.99, 0.95], 0.5),
    ] {
        let mesh = box_mesh([-100.0, -100.0, -depth], [100.0, 100.0, 0.0]);
        let occ = Occluder::new(&mesh);
        let m = Medium::new(albedo, [1.0, 0.7, 0.5], 1.3, g).unwrap();
        let guided = stats(&Walker::new(&mesh, &occ), &m, 200_000);
        let classic = stats(&Walker::new(&mesh, &occ).classic(), &m, 200_000);
        for k in 0..2 {
            let ((a, ea), (b, eb)) = (guided[k], classic[k]);
            assert!(
                (a - b).abs() < 4.0 * (ea * ea + eb * eb).sqrt(),
                "depth {depth} albedo {albedo:?} g {g}: {a} +- {ea} against {b} +- {eb}"
            );
            if depth > 10.0 {
                assert!(ea < 0.9 * eb, "depth {depth}: noise {ea} against {eb}");
            }
        }
    }
}

/// Light spread over the hemisphere (a constant dome's: illum records it
/// as `illum_diffuse`) weighs as light from the whole sky, `R_md`, which
/// one mean cosine cannot give (`rm(2/3)` is 0.9-1.2% above `R_md` at eta
/// 1, 3.6% at eta 1.3): on a half-space under a dome of radiance `L` and a
/// distant light, the walk method's `ssM` and the diffusion method's are
/// `R_md pi L + rm(mu) E`.
#[test]
fn a_dome_s_light_weighs_as_light_from_the_whole_sky() {
    use pcsss::stages::illum;
    let mesh = box_mesh([-100.0, -100.0, -60.0], [100.0, 100.0, 0.0]);
    let lights = pcsss::lights::parse(
        r#"{ "lights": [ { "name": "sky", "type": "dome", "color": [1, 1, 1], "samples": 256 },
                         { "name": "sun", "type": "distant", "direction": [0, -0.8, -0.6], "intensity": 2 } ] }"#,
        "sky.json",
    )
    .unwrap();
    for (albedo, eta) in [([0.95, 0.9, 0.6], 1.0), ([0.95, 0.8, 0.6], 1.3)] {
        let m = Medium::new(albedo, [1.0; 3], eta, 0.0).unwrap();
        // A grid on the top, within the walks' reach of its centre.
        let pts: Vec<Lit> = (0..(30 * 30))
            .map(|k| {
                let (x, y) = ((k % 30) as f64 - 14.5, (k / 30) as f64 - 14.5);
                ([x, y, 0.0], [0.0, 0.0, 1.0], [0.0; 3], 1.0)
            })
            .collect();
        let mut c = cloud_of(&pts);
        c.points_mut()
            .set_scalar("ptarea", vec![1.0; pts.len()])
            .unwrap();
        illum::illum(&mut c, &lights, None, 1, &Progress::hidden()).unwrap();
        assert!(c.points().has("illum_diffuse"));
        let mut walk = c.clone();
        let w = WalkParams {
            walks: 600,
            seed: 4,
            ..WalkParams::default()
        };
        ssmulti_walk(&mut walk, &mesh, &physical(m), &w, &Progress::hidden()).unwrap();
        let mut kernel = c.clone();
        pcsss::stages::ssmulti::ssmulti(&mut kernel, &physical(m), &Progress::hidden()).unwrap();
        let (rd, r_sun) = (m.rm_diffuse(), m.rm_at(0.6));
        // The centre's points: the kernel's edge is 15 units away.
        let centre: Vec<usize> = (0..pts.len())
            .filter(|&i| pts[i].0[0].abs() < 5.0 && pts[i].0[1].abs() < 5.0)
            .collect();
        for (name, out) in [("walk", &walk), ("diffusion", &kernel)] {
            let ssm = out.points().vec3_f64("ssM").unwrap();
            for ch in 0..3 {
                let want = rd[ch] * std::f64::consts::PI + r_sun[ch] * 2.0 * 0.6;
                let got = centre.iter().map(|&i| ssm[i][ch]).sum::<f64>() / centre.len() as f64;
                assert!(
                    (got / want - 1.0).abs() < 0.01,
                    "{name}, albedo {albedo:?} eta {eta}: channel {ch}: {got} against {want}"
                );
            }
        }
    }
}

/// A medium that absorbs nothing is the walk method's alone: a walk ends
/// by leaving the mesh, the diffusion kernel would reach without end.
#[test]
fn albedo_1_is_taken_by_walks_and_refused_by_the_kernel() {
    let d = tempdir();
    let mut c = cloud_of(&[
        ([0.5, 0.5, 1.0], [0.0, 0.0, 1.0], [1.0; 3], 1.0),
        ([0.5, 0.5, 0.0], [0.0, 0.0, -1.0], [1.0; 3], 1.0),
    ]);
    c.points_mut().set_scalar("ptarea", vec![0.5; 2]).unwrap();
    std::fs::write(
        d.path().join("lit.ply"),
        to_bytes(&c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let mesh = fixtures().join("mesh/cube.obj").display().to_string();
    let medium = ["--model", "physical", "--albedo", "1", "--mfp", "0.05"];
    let mut walk = vec![
        "lit.ply", "-o", "walk.ply", "--method", "walk", "--mesh", &mesh,
    ];
    walk.extend(medium);
    let o = run_in(Some(d.path()), "ssmulti", &walk, b"");
    assert!(o.status.success(), "{}", stderr(&o));
    let out = from_bytes(&std::fs::read(d.path().join("walk.ply")).unwrap());
    assert!(out
        .points()
        .vec3_f64("ssM")
        .unwrap()
        .iter()
        .all(|v| v[0] > 0.0));
    let mut kernel = vec!["lit.ply", "-o", "kernel.ply"];
    kernel.extend(medium);
    let o = run_in(Some(d.path()), "ssmulti", &kernel, b"");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--albedo"), "{}", stderr(&o));
    assert!(!d.path().join("kernel.ply").exists());
}
