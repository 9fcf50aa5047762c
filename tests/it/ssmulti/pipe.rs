//! The ssmulti binary in a pipe: thread counts, the baseline loop, bad
//! input.

use super::*;

#[test]
fn ssmulti_in_a_pipe_same_bits_on_any_thread_count_and_bad_input() {
    let d = tempdir();
    let write =
        |name: &str, c: &Cloud| std::fs::write(d.path().join(name), to_bytes(c, LE)).unwrap();
    let c = wavy(5000, DVec3::ZERO, 1.0, 6);
    write("c.ply", &c);
    let mut outs = Vec::new();
    for threads in ["1", "2"] {
        outs.push(run_env(
            d.path(),
            "ssmulti",
            &[
                "--rd",
                "0.9,0.5,0.3",
                "--sd",
                "0.4",
                "--bounce",
                "0.5",
                "--rgb",
            ],
            &[("RAYON_NUM_THREADS", threads)],
            Some("c.ply"),
        ));
    }
    assert_eq!(outs[0], outs[1]);
    let back = from_bytes(&outs[0]);
    assert!(back.points().has("ssM") && back.points().has("illum"));
    // Without AVX2/FMA (the baseline loop): the same sums to rounding.
    let plain = run_env(
        d.path(),
        "ssmulti",
        &[
            "--rd",
            "0.9,0.5,0.3",
            "--sd",
            "0.4",
            "--bounce",
            "0.5",
            "--rgb",
        ],
        &[("PCSSS_NO_AVX2", "1")],
        Some("c.ply"),
    );
    let a = back.points().vec3_f64("ssM").unwrap();
    let b = from_bytes(&plain).points().vec3_f64("ssM").unwrap();
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
