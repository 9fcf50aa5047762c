//! `pcdiff`: tolerances, structure, exit codes.

use crate::util::*;
use pcsss::{Cloud, DetailValue, Role};

fn cloud(scale: f32) -> Cloud {
    let mut c = Cloud::with_points(4);
    let p: Vec<[f32; 3]> = (0..4).map(|i| [i as f32, 1.0, 2.0]).collect();
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    c.points_mut()
        .set_scalar("ptarea", vec![0.25 * scale, 0.25, 0.25, 0.25])
        .unwrap();
    c.set_detail("Tarea", DetailValue::F64(1.0));
    c
}

fn diff(a: &Cloud, b: &Cloud, args: &[&str]) -> (i32, String) {
    let d = tempdir();
    std::fs::write(d.path().join("a.ply"), to_bytes(a, LE)).unwrap();
    std::fs::write(d.path().join("b.ply"), to_bytes(b, ASCII)).unwrap();
    let mut all = vec!["a.ply", "b.ply"];
    all.extend_from_slice(args);
    let out = run_in(Some(d.path()), "pcdiff", &all, b"");
    (
        out.status.code().unwrap(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
    )
}

#[test]
fn identical_clouds_agree_across_encodings() {
    assert_eq!(diff(&cloud(1.0), &cloud(1.0), &[]).0, 0);
}

#[test]
fn relative_and_absolute_tolerances() {
    let (a, b) = (cloud(1.0), cloud(1.0 + 1e-5));
    let (code, out) = diff(&a, &b, &[]);
    assert_eq!(code, 1);
    assert!(out.contains("vertex.ptarea: max abs"), "{out}");
    assert!(out.contains("1 values past tolerance"), "{out}");
    assert_eq!(diff(&a, &b, &["--rel", "1e-4"]).0, 0);
    assert_eq!(diff(&a, &b, &["--rel", "1e-6"]).0, 1);
    assert_eq!(diff(&a, &b, &["--abs", "1e-5"]).0, 0);
    assert_eq!(diff(&a, &b, &["--tol", "ptarea=0,1e-4"]).0, 0);
    assert_eq!(diff(&a, &b, &["--ignore", "ptarea"]).0, 0);
    assert_eq!(diff(&a, &b, &["--only", "P"]).0, 0);
}

#[test]
fn structure_differences_count() {
    let a = cloud(1.0);
    let mut b = cloud(1.0);
    b.points_mut().remove("ptarea");
    let (code, out) = diff(&a, &b, &[]);
    assert_eq!(code, 1);
    assert!(out.contains("vertex.ptarea only in A"), "{out}");
    let mut b = cloud(1.0);
    b.set_detail("Tarea", DetailValue::F64(1.1));
    assert_eq!(diff(&a, &b, &[]).0, 1);
    assert_eq!(diff(&a, &b, &["--tol", "Tarea=0.2"]).0, 0);
    let b = Cloud::with_points(3);
    let (code, out) = diff(&a, &b, &[]);
    assert_eq!(code, 1);
    assert!(out.contains("4 rows in A, 3 in B"), "{out}");
}

#[test]
fn trouble_is_exit_2() {
    let out = run("pcdiff", &["/nonexistent.ply", "-"], b"");
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).starts_with("pcdiff: /nonexistent.ply: "));
    let out = run("pcdiff", &["a", "b", "--rel", "-1"], b"");
    assert_eq!(out.status.code(), Some(2));
}
