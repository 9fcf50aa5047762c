//! Per-point materials (formats/MATERIAL.md#per-point): a constant
//! attribute gives the constant material's ssM bit for bit; two materials
//! side by side give each its own flat-surface reflectance far from the
//! border; many values are refused without `levels` and grouped with it.

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::medium::Medium;
use pcsss::stages::scatter::PtareaMode;
use pcsss::Cloud;

/// A flat square [-4, 4]^2 of `n` points, normal +z, illum 1, with the
/// per-point attribute `alb` from `f(x)`.
fn plane(n: usize, f: impl Fn(f64) -> f32) -> Cloud {
    let sq = mesh_from(
        &[
            [-4.0, -4.0, 0.0],
            [4.0, -4.0, 0.0],
            [4.0, 4.0, 0.0],
            [-4.0, 4.0, 0.0],
        ],
        &[vec![0, 1, 2, 3]],
    );
    let mut c = scatter_n(&sq, n, 5, PtareaMode::Prim);
    let m = c.len();
    c.points_mut()
        .set_vec3("N", Role::Normal, &vec![[0.0f32, 0.0, 1.0]; m])
        .unwrap();
    c.points_mut()
        .set_vec3("illum", Role::Color, &vec![[1.0f32; 3]; m])
        .unwrap();
    let x = c.points().vec3_f64("P").unwrap();
    let alb: Vec<[f32; 3]> = x.iter().map(|p| [f(p[0]); 3]).collect();
    c.points_mut().set_vec3("alb", Role::Color, &alb).unwrap();
    c
}

fn ssm(dir: &std::path::Path, c: &Cloud, material: &str) -> (Vec<[f64; 3]>, Cloud) {
    std::fs::write(
        dir.join("lit.ply"),
        to_bytes(c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    std::fs::write(dir.join("mat.json"), material).unwrap();
    let o = run_in(
        Some(dir),
        "ssmulti",
        &["lit.ply", "--material", "mat.json", "-o", "out.ply"],
        b"",
    );
    assert!(o.status.success(), "{material}: {}", stderr(&o));
    let out = from_bytes(&std::fs::read(dir.join("out.ply")).unwrap());
    (out.points().vec3_f64("ssM").unwrap(), out)
}

#[test]
fn a_constant_attribute_gives_the_constant_material_bit_for_bit() {
    let d = tempdir();
    let c = plane(3000, |_| 0.5);
    let (constant, _) = ssm(d.path(), &c, r#"{"color": 0.5, "dmfp": 0.2, "eta": 1.3}"#);
    let (per, out) = ssm(
        d.path(),
        &c,
        r#"{"color": 0.7, "dmfp": 0.2, "eta": 1.3, "per_point": {"color": "alb"}}"#,
    );
    assert_eq!(constant, per);
    assert!(matches!(
        out.detail("ssmulti_per_point"),
        Some(pcsss::cloud::DetailValue::Str(s)) if s == "color from alb"
    ));
}

#[test]
fn two_materials_side_by_side_each_reflect_their_own_far_from_the_border() {
    let d = tempdir();
    let (a, b) = (0.6f32, 0.95f32);
    let c = plane(20000, |x| if x < 0.0 { a } else { b });
    let mfp = 0.05;
    let (v, out) = ssm(
        d.path(),
        &c,
        &format!(
            r#"{{"albedo": 0.8, "mfp": {mfp}, "eta": 1.0, "per_point": {{"albedo": "alb"}}}}"#
        ),
    );
    let p = out.points().vec3_f64("P").unwrap();
    for (albedo, side) in [(a, -1.0), (b, 1.0)] {
        let want = Medium::new([albedo as f64; 3], [mfp; 3], 1.0, 0.0)
            .unwrap()
            .rm[0];
        // Points at least 1 from the border and from the edges.
        let got: Vec<f64> = p
            .iter()
            .zip(&v)
            .filter(|(q, _)| q[0] * side > 1.0 && q[0].abs() < 3.0 && q[1].abs() < 3.0)
            .map(|(_, s)| s[0])
            .collect();
        let mean = got.iter().sum::<f64>() / got.len() as f64;
        assert!(got.len() > 1000);
        assert!(
            (mean / want - 1.0).abs() < 0.02,
            "albedo {albedo}: {mean} vs the flat medium's {want}"
        );
    }
}

#[test]
fn many_values_need_levels_and_levels_group_them() {
    let d = tempdir();
    let c = plane(3000, |x| (0.5 + 0.05 * x) as f32);
    std::fs::write(
        d.path().join("lit.ply"),
        to_bytes(&c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    std::fs::write(
        d.path().join("mat.json"),
        r#"{"albedo": 0.8, "mfp": 0.05, "per_point": {"albedo": "alb"}}"#,
    )
    .unwrap();
    let o = run_in(
        Some(d.path()),
        "ssmulti",
        &["lit.ply", "--material", "mat.json", "-o", "out.ply"],
        b"",
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("levels"), "{}", stderr(&o));
    assert!(!d.path().join("out.ply").exists());
    let (_, out) = ssm(
        d.path(),
        &c,
        r#"{"albedo": 0.8, "mfp": 0.05, "per_point": {"albedo": "alb"}, "levels": 5}"#,
    );
    assert!(matches!(
        out.detail("ssmulti_per_point"),
        Some(pcsss::cloud::DetailValue::Str(s)) if s.contains("5 levels")
    ));
    // A per-point colour where the material gives an albedo is refused.
    std::fs::write(
        d.path().join("mat.json"),
        r#"{"albedo": 0.8, "mfp": 0.05, "per_point": {"color": "alb"}}"#,
    )
    .unwrap();
    let o = run_in(
        Some(d.path()),
        "ssmulti",
        &["lit.ply", "--material", "mat.json", "-o", "out2.ply"],
        b"",
    );
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("per_point.color"), "{}", stderr(&o));
}

/// ssmulti on `c` with `args`.
fn run_args(dir: &std::path::Path, c: &Cloud, args: &[&str]) -> Vec<[f64; 3]> {
    std::fs::write(
        dir.join("lit.ply"),
        to_bytes(c, pcsss::formats::Format::DEFAULT),
    )
    .unwrap();
    let mut all = vec!["lit.ply", "-o", "out.ply"];
    all.extend(args);
    let o = run_in(Some(dir), "ssmulti", &all, b"");
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    from_bytes(&std::fs::read(dir.join("out.ply")).unwrap())
        .points()
        .vec3_f64("ssM")
        .unwrap()
}

#[test]
fn the_seed_model_takes_rd_per_point_and_the_approximate_method_too() {
    let d = tempdir();
    // A constant Rd attribute: the constant's bits.
    let c = plane(3000, |_| 0.5);
    let constant = run_args(d.path(), &c, &["--rd", "0.5", "--sd", "0.3"]);
    let per = run_args(
        d.path(),
        &c,
        &["--rd", "0.9", "--sd", "0.3", "--per-point", "rd=alb"],
    );
    assert_eq!(constant, per);
    // Two halves: each returns its own Rd far from the border (the
    // source normalisation returns Rd times the light on an even
    // surface, whatever its sampling).
    let c = plane(20000, |x| if x < 0.0 { 0.3 } else { 0.9 });
    let p = c.points().vec3_f64("P").unwrap();
    for tol in ["0", "0.2"] {
        let v = run_args(
            d.path(),
            &c,
            &[
                "--sd",
                "1",
                "--norm",
                "source",
                "--per-point",
                "rd=alb",
                "--tolerance",
                tol,
            ],
        );
        for (rd, side) in [(0.3, -1.0), (0.9, 1.0)] {
            let got: Vec<f64> = p
                .iter()
                .zip(&v)
                .filter(|(q, _)| q[0] * side > 1.0 && q[0].abs() < 3.0 && q[1].abs() < 3.0)
                .map(|(_, s)| s[0])
                .collect();
            let mean = got.iter().sum::<f64>() / got.len() as f64;
            assert!(
                (mean / rd - 1.0).abs() < 0.02,
                "tolerance {tol}: Rd {rd}: {mean}"
            );
        }
    }
    // --per-point with the physical model is refused, naming it.
    let o = run_in(
        Some(d.path()),
        "ssmulti",
        &[
            "lit.ply",
            "--model",
            "physical",
            "--mfp",
            "0.1",
            "--per-point",
            "rd=alb",
            "-o",
            "x.ply",
        ],
        b"",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--per-point"), "{}", stderr(&o));
}
