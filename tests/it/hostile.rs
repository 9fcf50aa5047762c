//! Hostile input and outputs (issue 20's classes): one clear line naming
//! the file or parameter at fault, the right exit status, nothing left
//! behind. Each test names the class it covers.

use std::process::{Command, Stdio};

use crate::util::*;
use pcsss::{Cloud, Role};

/// A small lit cloud with ssM, and the bunny-free files a test needs.
fn files(dir: &std::path::Path) -> (String, String) {
    let mut c = Cloud::with_points(3);
    let p = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    c.points_mut()
        .set_vec3("N", Role::Normal, &[[0.0f32, 0.0, 1.0]; 3])
        .unwrap();
    c.points_mut()
        .set_vec3("ssM", Role::Color, &[[0.5f32, 0.25, 0.125]; 3])
        .unwrap();
    c.set_detail("ssmulti_sd", pcsss::DetailValue::F64(1.0));
    let cloud = dir.join("cloud.ply");
    std::fs::write(&cloud, to_bytes(&c, LE)).unwrap();
    let mesh = fixtures().join("mesh/cube.obj");
    (cloud.display().to_string(), mesh.display().to_string())
}

/// One line on stderr, no panic, the exit status; the line for checks.
fn one_line(o: &std::process::Output, code: i32, what: &str) -> String {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "{what}: {err}");
    assert_eq!(err.lines().count(), 1, "{what}: {err}");
    assert!(!err.contains("panicked"), "{what}: {err}");
    err
}

/// Class 5: an OS error is printed once; the file at fault is named
/// (the cloud, not the shade points; `<stdout>` on a full disk).
#[test]
fn errors_name_the_right_file_once() {
    let dir = tempdir();
    let (cloud, _) = files(dir.path());
    let o = run("pcinfo", &["nosuch.ply"], b"");
    let err = one_line(&o, 1, "missing file");
    assert_eq!(err.matches("No such file").count(), 1, "{err}");
    // NaN in the cloud, shade points fine.
    let mut bad = Cloud::with_points(2);
    bad.points_mut()
        .set_vec3("P", Role::Point, &[[f32::NAN, 0.0, 0.0], [1.0, 0.0, 0.0]])
        .unwrap();
    bad.points_mut()
        .set_vec3("ssM", Role::Color, &[[1.0f32; 3]; 2])
        .unwrap();
    let bad_path = dir.path().join("bad.ply").display().to_string();
    std::fs::write(&bad_path, to_bytes(&bad, LE)).unwrap();
    let o = run("filter", &["--cloud", &bad_path, &cloud, "--nfp", "1"], b"");
    let err = one_line(&o, 1, "NaN cloud");
    assert!(
        err.contains("bad.ply") && !err.contains("cloud.ply"),
        "{err}"
    );
    // A full disk on standard output.
    if std::path::Path::new("/dev/full").exists() {
        let full = std::fs::File::create("/dev/full").unwrap();
        let out = Command::new(bin("pcconvert"))
            .arg(&cloud)
            .stdout(Stdio::from(full))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        let err = one_line(&out, 1, "full disk");
        assert!(err.contains("<stdout>"), "{err}");
    }
}

/// Class 4: parameters outside their meaning are refused, exit 2.
#[test]
fn parameters_outside_their_meaning_are_refused() {
    let dir = tempdir();
    let (cloud, _) = files(dir.path());
    for t in ["0.6", "2", "100", "-0.1"] {
        let o = run("ssmulti", &[&cloud, "--sd", "1", "--tolerance", t], b"");
        let err = one_line(&o, 2, t);
        assert!(err.contains("--tolerance"), "{err}");
    }
    // A shade point without a direction under --facing is named.
    let mut shade = Cloud::with_points(2);
    shade
        .points_mut()
        .set_vec3("P", Role::Point, &[[0.0f32; 3], [1.0, 0.0, 0.0]])
        .unwrap();
    shade
        .points_mut()
        .set_vec3("N", Role::Normal, &[[0.0f32, 0.0, 1.0], [0.0; 3]])
        .unwrap();
    let shade_path = dir.path().join("shade.ply").display().to_string();
    std::fs::write(&shade_path, to_bytes(&shade, LE)).unwrap();
    let o = run("filter", &["--cloud", &cloud, &shade_path, "--facing"], b"");
    let err = one_line(&o, 1, "zero N");
    assert!(
        err.contains("shade point 1") && err.contains("direction"),
        "{err}"
    );
}

/// Class 6: outputs checked before any work, all or none, nothing left
/// behind by a signal.
#[test]
fn outputs_are_checked_first_written_all_or_none_and_cleaned_on_signals() {
    let dir = tempdir();
    let (cloud, mesh) = files(dir.path());
    let cam = fixtures()
        .join("cameras/bunny_64.json")
        .display()
        .to_string();
    let render = |extra: &[&str]| {
        let mut a = vec!["--mesh", &mesh, "--camera", &cam, "--cloud", &cloud];
        a.extend_from_slice(extra);
        run_in(Some(dir.path()), "render", &a, b"")
    };
    let o = render(&["-o", "r.exr", "--png", "r.exr"]);
    assert!(one_line(&o, 2, "png over exr").contains("--png"));
    let o = render(&["-o", "x.ply"]);
    assert!(one_line(&o, 2, "exr into ply").contains("--output"));
    let o = render(&["-o", "r.exr", "--png", "nodir/r.png"]);
    assert!(one_line(&o, 1, "no dir").contains("nodir"));
    assert!(!dir.path().join("r.exr").exists(), "r.exr written anyway");
    let o = run_in(
        Some(dir.path()),
        "pcconvert",
        &[&cloud, "-o", "nodir/x.ply"],
        b"",
    );
    assert!(one_line(&o, 1, "pcconvert no dir").contains("nodir"));
    let o = render(&["-o", "r.exr", "--png", "r.png"]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("r.exr").exists() && dir.path().join("r.png").exists());

    // SIGTERM while the output is being written: no temp file, no partial
    // output, death by the signal.
    let out = dir.path().join("big.ply");
    let mut child = Command::new(bin("scatter"))
        .args([&mesh, "-n", "20000000", "-q", "-o"])
        .arg(&out)
        .current_dir(dir.path())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let temps = || {
        std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            .count()
    };
    let mut seen = false;
    for _ in 0..4000 {
        if temps() > 0 {
            seen = true;
            unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let status = child.wait().unwrap();
    if seen {
        use std::os::unix::process::ExitStatusExt;
        assert!(
            status.signal() == Some(libc::SIGTERM) || status.code() == Some(128 + libc::SIGTERM),
            "{status:?}"
        );
        assert_eq!(temps(), 0, "a temp file was left behind");
        assert!(!out.exists(), "a partial output was left");
    } else {
        eprintln!("the write ended before a temp file was seen: signal not tested");
    }
}

/// Class 7: a golden test that names nothing is an error, not a pass.
#[test]
fn pcdiff_refuses_names_that_match_nothing() {
    let dir = tempdir();
    let (cloud, _) = files(dir.path());
    for args in [
        ["--only", "nosuch"],
        ["--ignore", "nosuch"],
        ["--tol", "nosuch=1"],
    ] {
        let mut a = vec![cloud.as_str(), cloud.as_str()];
        a.extend(args);
        let o = run("pcdiff", &a, b"");
        let err = one_line(&o, 2, &args.join(" "));
        assert!(err.contains("nosuch") && err.contains(args[0]), "{err}");
    }
    let o = run("pcdiff", &[&cloud, &cloud, "--only", "ssM,P", "-q"], b"");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Class 8: the documented mask syntax works on the command line.
#[test]
fn light_masks_with_braces_and_quotes_work_in_illum() {
    let dir = tempdir();
    let (cloud, _) = files(dir.path());
    let lights = dir.path().join("l.json");
    std::fs::write(
        &lights,
        r#"{"lights": [{"type": "distant", "name": "key", "direction": [0, 0, -1]},
                       {"type": "distant", "name": "rim", "direction": [0, 0, -1]},
                       {"type": "distant", "name": "a b", "direction": [0, 0, -1], "intensity": 2}]}"#,
    )
    .unwrap();
    let l = lights.display().to_string();
    for (mask, want) in [("{key,rim}", 2.0), ("\"a b\"", 2.0), ("*", 4.0)] {
        let o = run(
            "illum",
            &[
                &cloud,
                "--lights",
                &l,
                "--no-shadows",
                "--lmask",
                mask,
                "-q",
            ],
            b"",
        );
        assert!(o.status.success(), "{mask}: {}", stderr(&o));
        let c = from_bytes(&o.stdout);
        let e = c.points().vec3_f64("illum").unwrap();
        assert!((e[0][0] - want).abs() < 1e-6, "{mask}: {:?}", e[0]);
    }
}
