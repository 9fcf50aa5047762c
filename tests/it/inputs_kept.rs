//! An output never replaces an input (issue 42): every binary refuses,
//! before any work, an output path that is one of its inputs (by any path,
//! hard link, symbolic link or standard input redirected from it), or a
//! split's directory that holds its input; no input changes and nothing is
//! left behind. Outputs are created with the umask, and a file written
//! over keeps its mode.

use std::collections::BTreeMap;
use std::hash::{Hash, Hasher};
use std::os::unix::fs::PermissionsExt;
use std::path::Path;
use std::process::{Command, Stdio};

use crate::util::*;

/// Every file under `dir`: its content's hash and its mode.
fn snapshot(dir: &Path) -> BTreeMap<String, (u64, u32)> {
    fn walk(root: &Path, dir: &Path, out: &mut BTreeMap<String, (u64, u32)>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            let meta = std::fs::symlink_metadata(&p).unwrap();
            let name = p.strip_prefix(root).unwrap().display().to_string();
            if meta.is_dir() {
                walk(root, &p, out);
            } else if meta.file_type().is_symlink() {
                out.insert(name, (0, 0));
            } else {
                let mut h = std::collections::hash_map::DefaultHasher::new();
                std::fs::read(&p).unwrap().hash(&mut h);
                out.insert(name, (h.finish(), meta.permissions().mode() & 0o777));
            }
        }
    }
    let mut out = BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// PATH with the stages first.
fn path_with_bins() -> String {
    let bins = bin("ssmulti").parent().unwrap().display().to_string();
    format!("{bins}:{}", std::env::var("PATH").unwrap_or_default())
}

/// A small bake in `dir` made by the stages themselves: the cube's mesh
/// (`mesh.ply`), lit points (`cloud.ply`), their ssM (`ss.ply`), the
/// lights and camera, a split of the lit points in `T` and its tiles baked
/// into `O`.
fn bake(dir: &Path) {
    let sh = |cmd: &str| {
        let o = Command::new("bash")
            .args(["-eo", "pipefail", "-c", cmd])
            .current_dir(dir)
            .env("PATH", path_with_bins())
            .output()
            .unwrap();
        assert!(o.status.success(), "{cmd}: {}", stderr(&o));
    };
    let f = fixtures();
    sh(&format!(
        "measure -q {cube} | promote -q --class face --attr area --as Tarea -o mesh.ply",
        cube = f.join("mesh/cube.obj").display()
    ));
    std::fs::copy(f.join("lights/three.json"), dir.join("lights.json")).unwrap();
    std::fs::copy(f.join("cameras/bunny.json"), dir.join("cam.json")).unwrap();
    sh("scatter -q mesh.ply -n 2000 | facet -q --mesh mesh.ply | illum -q --lights lights.json --mesh mesh.ply -o cloud.ply");
    sh("ssmulti -q cloud.ply --sd 0.5 -o ss.ply");
    sh("pctile -q split cloud.ply --tiles 2 --halo 0.6 -o T");
    sh("mkdir O && for t in T/tile_*.ply; do ssmulti -q $t --sd 0.5 -o O/$(basename $t); done");
}

/// Runs `name args` in `dir` (standard input from `stdin`, a file of
/// `dir`, when given): the exit status, and stderr when it is one line.
fn run_at(dir: &Path, name: &str, args: &[&str], stdin: Option<&str>) -> (Option<i32>, String) {
    let input = match stdin {
        Some(f) => Stdio::from(std::fs::File::open(dir.join(f)).unwrap()),
        None => Stdio::null(),
    };
    let o = Command::new(bin(name))
        .args(args)
        .current_dir(dir)
        .stdin(input)
        .output()
        .unwrap();
    let err = stderr(&o);
    assert_eq!(err.lines().count(), 1, "{name} {args:?}: {err}");
    (o.status.code(), err)
}

#[test]
fn an_output_naming_an_input_is_refused_and_every_input_is_kept() {
    let d = tempdir();
    let dir = d.path();
    bake(dir);
    std::os::unix::fs::symlink("cloud.ply", dir.join("soft.ply")).unwrap();
    std::fs::hard_link(dir.join("cloud.ply"), dir.join("hard.ply")).unwrap();
    let cases: &[(&str, &[&str], Option<&str>, &str)] = &[
        (
            "illum",
            &[
                "cloud.ply",
                "--lights",
                "lights.json",
                "--no-shadows",
                "-o",
                "lights.json",
            ],
            None,
            "lights.json: is also an input",
        ),
        (
            "facet",
            &["cloud.ply", "--mesh", "mesh.ply", "-o", "mesh.ply"],
            None,
            "mesh.ply: is also an input",
        ),
        (
            "filter",
            &["mesh.ply", "--cloud", "ss.ply", "-o", "ss.ply"],
            None,
            "ss.ply: is also an input",
        ),
        (
            "sssingle",
            &[
                "ss.ply",
                "--mesh",
                "mesh.ply",
                "--lights",
                "lights.json",
                "--camera",
                "cam.json",
                "--sd",
                "0.5",
                "-o",
                "cam.json",
            ],
            None,
            "cam.json: is also an input",
        ),
        (
            "render",
            &[
                "--mesh", "mesh.ply", "--camera", "cam.json", "--cloud", "ss.ply", "-o", "out.exr",
                "--png", "mesh.ply",
            ],
            None,
            "--png",
        ),
        (
            "ssmulti",
            &["cloud.ply", "--sd", "0.5", "-o", "cloud.ply"],
            None,
            "cloud.ply: is also an input",
        ),
        (
            "ssmulti",
            &["cloud.ply", "--sd", "0.5", "-o", "soft.ply"],
            None,
            "soft.ply: is also an input (cloud.ply)",
        ),
        (
            "ssmulti",
            &["cloud.ply", "--sd", "0.5", "-o", "hard.ply"],
            None,
            "hard.ply: is also an input (cloud.ply)",
        ),
        (
            "ssmulti",
            &["--sd", "0.5", "-o", "cloud.ply"],
            Some("cloud.ply"),
            "is also an input (<stdin>)",
        ),
        (
            "pcconvert",
            &["cloud.ply", "-o", "./cloud.ply"],
            None,
            "is also an input",
        ),
        (
            "promote",
            &["mesh.ply", "--normalize", "-o", "mesh.ply"],
            None,
            "is also an input",
        ),
        (
            "pctile",
            &["merge", "T", "-o", "T/manifest.json"],
            None,
            "T/manifest.json: is also an input",
        ),
        (
            "pctile",
            &["merge", "T", "--from", "O", "-o", "O/tile_0001.ply"],
            None,
            "O/tile_0001.ply: is also an input",
        ),
        (
            "pctile",
            &["merge", "T", "-o", "T/tile_0000.ply"],
            None,
            "T/tile_0000.ply: is also an input",
        ),
        (
            "pctile",
            &[
                "split",
                "T/tile_0000.ply",
                "--tiles",
                "2",
                "--halo",
                "0.1",
                "-o",
                "T",
            ],
            None,
            "holds the input",
        ),
        (
            "pctile",
            &[
                "split",
                "cloud.ply",
                "--tiles",
                "2",
                "--halo",
                "0.1",
                "-o",
                ".",
            ],
            None,
            "holds the input",
        ),
    ];
    for (name, args, stdin, want) in cases {
        let before = snapshot(dir);
        let (code, err) = run_at(dir, name, args, *stdin);
        assert_eq!(code, Some(2), "{name} {args:?}: {err}");
        assert!(err.contains(want), "{name} {args:?}: {err}");
        assert!(
            err.contains("--output") || err.contains("--png"),
            "{name} {args:?}: {err}"
        );
        assert_eq!(snapshot(dir), before, "{name} {args:?} changed the folder");
    }
}

#[test]
fn outputs_take_the_umask_and_a_file_written_over_keeps_its_mode() {
    let d = tempdir();
    let dir = d.path();
    bake(dir);
    let mode = |f: &str| std::fs::metadata(dir.join(f)).unwrap().permissions().mode() & 0o777;
    let stage = |umask: &str, out: &str| {
        let cmd = format!(
            "umask {umask}; exec {} -q cloud.ply --sd 0.5 -o {out}",
            bin("ssmulti").display()
        );
        let o = Command::new("bash")
            .args(["-c", &cmd])
            .current_dir(dir)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
    };
    stage("077", "private.ply");
    assert_eq!(mode("private.ply"), 0o600);
    stage("022", "public.ply");
    assert_eq!(mode("public.ply"), 0o644);
    stage("002", "group.ply");
    assert_eq!(mode("group.ply"), 0o664);
    // Written over: the file keeps its own mode whatever the umask.
    std::fs::set_permissions(
        dir.join("private.ply"),
        std::fs::Permissions::from_mode(0o640),
    )
    .unwrap();
    stage("000", "private.ply");
    assert_eq!(mode("private.ply"), 0o640);
    // A split's tiles and manifest, and a merge, take the umask too.
    let cmd = format!(
        "umask 077; {b}/pctile -q split cloud.ply --tiles 2 --halo 0.6 -o U && {b}/pctile -q merge U -o merged.ply",
        b = bin("pctile").parent().unwrap().display()
    );
    let o = Command::new("bash")
        .args(["-c", &cmd])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    for f in [
        "U/tile_0000.ply",
        "U/tile_0001.ply",
        "U/manifest.json",
        "merged.ply",
    ] {
        assert_eq!(mode(f), 0o600, "{f}");
    }
}

#[test]
fn an_output_that_cannot_be_written_is_refused_before_the_work() {
    let d = tempdir();
    let dir = d.path();
    bake(dir);
    let ro = dir.join("ro");
    std::fs::create_dir(&ro).unwrap();
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
    // (As root a read-only folder can still be written: /proc's can not.)
    for out in ["ro/x.ply", "/proc/x.ply", "nosuch/x.ply"] {
        let before = snapshot(dir);
        let (code, err) = run_at(
            dir,
            "ssmulti",
            &["cloud.ply", "--sd", "0.5", "-o", out],
            None,
        );
        if out == "ro/x.ply" && code == Some(0) {
            // Root writes anywhere; the other paths still say it.
            let _ = std::fs::remove_file(dir.join(out));
            continue;
        }
        assert_eq!(code, Some(1), "{out}: {err}");
        assert!(err.contains(out), "{out}: {err}");
        // The stage said nothing of its work: it did none.
        assert!(!err.contains("pairs"), "{out}: {err}");
        assert_eq!(snapshot(dir), before, "{out}");
    }
}

#[test]
fn an_input_cut_short_while_it_is_read_gives_one_line_or_a_whole_result() {
    // What `cp` or `>` over a file do to a stage reading it: cut it short
    // at any moment. Every run ends by itself (no signal), with the
    // result of the whole file or one line naming it, and no temp file.
    let d = tempdir();
    let dir = d.path();
    let n = 1_000_000;
    let mut c = pcsss::Cloud::with_points(n);
    let p: Vec<[f32; 3]> = (0..n).map(|i| [i as f32, 0.5, -1.0]).collect();
    c.points_mut()
        .set_vec3("P", pcsss::Role::Point, &p)
        .unwrap();
    c.points_mut()
        .set_vec3("N", pcsss::Role::Normal, &p)
        .unwrap();
    let whole = to_bytes(&c, pcsss::formats::Format::DEFAULT);
    let f = dir.join("cut.ply");
    let mut outcomes = [0usize; 2];
    for k in 0..12u64 {
        std::fs::write(&f, &whole).unwrap();
        let child = Command::new(bin("pcconvert"))
            .args(["cut.ply", "-o", "out.ply"])
            .current_dir(dir)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // From before the read starts to after it ended.
        std::thread::sleep(std::time::Duration::from_millis(k * 4));
        std::fs::OpenOptions::new()
            .write(true)
            .open(&f)
            .unwrap()
            .set_len(whole.len() as u64 / 3)
            .unwrap();
        let o = child.wait_with_output().unwrap();
        let err = stderr(&o);
        match o.status.code() {
            Some(0) => outcomes[0] += 1,
            Some(1) => {
                assert_eq!(err.lines().count(), 1, "{err}");
                assert!(err.contains("cut.ply"), "{err}");
                outcomes[1] += 1;
            }
            other => panic!("run {k}: {other:?} {:?}: {err}", o.status),
        }
        let temps = crate::util::count_names(dir, |n| n.ends_with(".tmp"));
        assert_eq!(temps, 0, "run {k} left a temp file");
        if o.status.success() {
            // Read before the cut: the whole file, exactly.
            assert_eq!(
                std::fs::read(dir.join("out.ply")).unwrap(),
                whole,
                "run {k}"
            );
        }
    }
    eprintln!("whole results: {}, refused: {}", outcomes[0], outcomes[1]);
}

#[test]
fn a_split_stopped_while_it_spools_its_input_leaves_nothing() {
    let d = tempdir();
    let dir = d.path();
    bake(dir);
    let out = dir.join("new/tiles");
    let mut child = Command::new(bin("pctile"))
        .args(["split", "--tiles", "2", "--halo", "0.5", "-o"])
        .arg(&out)
        .current_dir(dir)
        .stdin(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Half the cloud, and standard input kept open: the split waits in
    // its spool for the rest.
    let cloud = std::fs::read(dir.join("cloud.ply")).unwrap();
    let mut stdin = child.stdin.take().unwrap();
    std::io::Write::write_all(&mut stdin, &cloud[..cloud.len() / 2]).unwrap();
    let spooling = || {
        std::fs::read_dir(&out)
            .map(|r| {
                r.filter_map(|e| e.ok())
                    .any(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
            })
            .unwrap_or(false)
    };
    let mut seen = false;
    for _ in 0..2000 {
        if spooling() {
            seen = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    assert!(seen, "the spool never appeared");
    // SAFETY: kill(2) on the pid of a child this test started and has not
    // reaped, so the pid is still its own.
    unsafe { libc::kill(child.id() as i32, libc::SIGTERM) };
    let status = child.wait().unwrap();
    drop(stdin);
    use std::os::unix::process::ExitStatusExt;
    assert_eq!(status.signal(), Some(libc::SIGTERM), "{status:?}");
    // The directories the split made (new/tiles) are gone with its spool.
    assert!(!dir.join("new").exists(), "the split's directory was left");
}
