//! The shared command-line conventions, through `pcconvert` and `pcinfo`.

use crate::util::*;
use pcsss::{Cloud, Role};

fn cloud_bytes(n: usize) -> Vec<u8> {
    let mut c = Cloud::with_points(n);
    let p: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, 0.5, -1.0]).collect();
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    to_bytes(&c, LE)
}

#[test]
fn stdin_to_stdout_when_no_paths() {
    let src = cloud_bytes(10);
    let out = run("pcconvert", &[], &src);
    assert!(out.status.success(), "{}", stderr(&out));
    assert_eq!(out.stdout, src);
    let out = run("pcconvert", &["-", "-o", "-"], &src);
    assert_eq!(out.stdout, src);
}

#[test]
fn output_format_from_flag_or_extension() {
    let d = tempdir();
    let src = cloud_bytes(3);
    let out = run_in(Some(d.path()), "pcconvert", &["-o", "a.ply"], &src);
    assert!(out.status.success());
    assert!(std::fs::read(d.path().join("a.ply"))
        .unwrap()
        .starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    let out = run_in(
        Some(d.path()),
        "pcconvert",
        &["--format", "ply-ascii", "-o", "b.ply"],
        &src,
    );
    assert!(out.status.success());
    assert!(std::fs::read(d.path().join("b.ply"))
        .unwrap()
        .starts_with(b"ply\nformat ascii 1.0\n"));
    let out = run("pcconvert", &["--format", "ply-be"], &src);
    assert!(out
        .stdout
        .starts_with(b"ply\nformat binary_big_endian 1.0\n"));
    let out = run("pcconvert", &["--format", "tiff"], &src);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("unknown format 'tiff'"));
}

#[test]
fn a_failed_run_leaves_no_file_and_keeps_the_old_one() {
    let d = tempdir();
    let target = d.path().join("out.ply");
    std::fs::write(&target, b"old").unwrap();
    let bad = std::fs::read(fixtures().join("ply/invalid/truncated_body.ply")).unwrap();
    let out = run_in(Some(d.path()), "pcconvert", &["-o", "out.ply"], &bad);
    assert_eq!(out.status.code(), Some(1));
    assert_eq!(std::fs::read(&target).unwrap(), b"old");
    let names: Vec<_> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 1, "no temp file left behind: {names:?}");
    let out = run_in(Some(d.path()), "pcconvert", &["-o", "fresh.ply"], &bad);
    assert_eq!(out.status.code(), Some(1));
    assert!(!d.path().join("fresh.ply").exists());
}

#[test]
fn a_broken_pipe_is_success() {
    let src = cloud_bytes(200_000);
    let d = tempdir();
    std::fs::write(d.path().join("in.ply"), &src).unwrap();
    let cmd = format!(
        "{} in.ply --format ply-ascii | head -c 100 > /dev/null",
        bin("pcconvert").display()
    );
    let out = shell(d.path(), &cmd);
    assert!(
        out.stderr.is_empty(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_missing_input_file_is_one_line_naming_it() {
    let out = run("pcinfo", &["/nonexistent/x.ply"], b"");
    assert_eq!(out.status.code(), Some(1));
    let e = stderr(&out);
    assert_eq!(e.lines().count(), 1);
    assert!(e.starts_with("pcinfo: /nonexistent/x.ply: "), "{e}");
}

#[test]
fn pcinfo_reports_attributes_with_stats_and_detail() {
    let out = run("pcinfo", &[], &to_bytes(&every_type_cloud(), LE));
    assert!(out.status.success());
    let s = String::from_utf8(out.stdout).unwrap();
    assert!(
        s.starts_with("points: 6\nfaces: 2 polygons, 3 triangles\n"),
        "{s}"
    );
    assert!(s.contains("element vertex: 6 rows"));
    assert!(s.contains("N  "));
    assert!(s.contains("float[3] normal"));
    assert!(s.contains("s_char"));
    assert!(s.contains("min -128  max 127"), "{s}");
    assert!(s.contains("NaN x1"));
    assert!(s.contains("Tarea"));
    assert!(s.contains("12.566371"));
    assert!(s.contains("element empty_rows: 4 rows"));
}
