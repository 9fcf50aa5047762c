//! The geometry stages chained as a shell pipe, and bad geometry input.

use crate::util::*;
use pcsss::stages::scatter::PtareaMode;
use pcsss::Cloud;

#[test]
fn the_chain_runs_as_a_shell_pipe() {
    let d = tempdir();
    let cube = fixtures().join("mesh/cube.obj");
    let b = |n: &str| bin(n).display().to_string();
    let cmd = format!(
        "{m} {cube} | {p} --class face --attr area --as Tarea > mesh.ply && \
         {s} mesh.ply -n 2000 --seed 7 | {f} --mesh mesh.ply | {p} --normalize -o cloud.ply",
        m = b("measure"),
        p = b("promote"),
        s = b("scatter"),
        f = b("facet"),
        cube = cube.display()
    );
    shell(d.path(), &cmd);
    let c = from_bytes(&std::fs::read(d.path().join("cloud.ply")).unwrap());
    assert_eq!(c.len(), 2000);
    for a in ["P", "N", "ptarea", "sourceprim", "sourceuv"] {
        assert!(c.points().has(a), "{a}");
    }
    assert_eq!(c.detail_f64("Tarea").unwrap(), 6.0);
}

#[test]
fn bad_geometry_input_is_a_clear_error() {
    let d = tempdir();
    let write =
        |name: &str, c: &Cloud| std::fs::write(d.path().join(name), to_bytes(c, LE)).unwrap();
    write(
        "nan.ply",
        &mesh_from(
            &[[0.0, 0.0, 0.0], [f64::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[vec![0, 1, 2]],
        ),
    );
    write(
        "missing.ply",
        &mesh_from(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[vec![0, 1, 9]],
        ),
    );
    write(
        "flat.ply",
        &mesh_from(
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            &[vec![0, 1, 2]],
        ),
    );
    write("cloud.ply", &Cloud::with_points(0));
    let cases: &[(&str, &[&str], &str)] = &[
        (
            "measure",
            &["nan.ply"],
            "vertex 1 has a non-finite position",
        ),
        (
            "scatter",
            &["nan.ply", "-n", "10"],
            "vertex 1 has a non-finite position",
        ),
        (
            "measure",
            &["missing.ply"],
            "face 0 refers to vertex 9, but the mesh has 3 vertices",
        ),
        ("scatter", &["flat.ply", "-n", "10"], "total area is 0"),
        ("scatter", &["cloud.ply", "-n", "10"], "no faces"),
        ("scatter", &["flat.ply", "--density", "NaN"], "--density"),
        ("facet", &["cloud.ply"], "needs --mesh MESH"),
        (
            "promote",
            &["cloud.ply", "--normalize"],
            "missing detail attribute 'Tarea'",
        ),
        (
            "promote",
            &["cloud.ply", "--attr", "illum"],
            "missing point attribute 'illum' (run 'illum' first",
        ),
    ];
    for (stage, args, want) in cases {
        let out = run_in(Some(d.path()), stage, args, b"");
        let e = stderr(&out);
        // (A bad parameter is exit 2, as a usage error.)
        let code = if want.starts_with("--") { 2 } else { 1 };
        assert_eq!(out.status.code(), Some(code), "{stage} {args:?}: {e}");
        assert_eq!(e.lines().count(), 1, "{e}");
        assert!(e.contains(want), "{stage} {args:?}: '{e}' lacks '{want}'");
    }
    // N = 0 is a documented result: an empty cloud with the attributes.
    write("cube.ply", &cube());
    let out = run_in(Some(d.path()), "scatter", &["cube.ply", "-n", "0"], b"");
    assert!(out.status.success(), "{}", stderr(&out));
    let c = from_bytes(&out.stdout);
    assert_eq!(c.len(), 0);
    assert!(c.points().has("ptarea"));
    // A cloud without sourceprim and no mesh: facet says what it needs.
    let out = run_in(
        Some(d.path()),
        "facet",
        &[],
        &to_bytes(&scatter_n(&cube(), 5, 1, PtareaMode::Prim), LE),
    );
    assert!(stderr(&out).contains("needs --mesh"), "{}", stderr(&out));
}
