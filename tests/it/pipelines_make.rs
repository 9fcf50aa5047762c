//! Which stages `make -C pipelines` runs (issue 60): `BIN=` when given,
//! else the ones installed on PATH, else this clone's build (under
//! `CARGO_TARGET_DIR` when set); and which passes a bake takes.

use std::path::Path;
use std::process::{Command, Output};

use crate::util::*;

/// `make -n -C pipelines ARGS` with `PATH` = `path` (and make's own) and
/// `CARGO_TARGET_DIR` as given: its commands, each on one line.
fn dry_run(args: &[String], path: Option<&Path>, target_dir: Option<&Path>) -> (Output, String) {
    let mut cmd = Command::new("make");
    cmd.arg("-n")
        .arg("-C")
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
        .args(args)
        .env_remove("CARGO_TARGET_DIR")
        .env_remove("MAKEFLAGS")
        .env_remove("MFLAGS");
    if let Some(p) = path {
        let system = "/usr/local/bin:/usr/bin:/bin";
        cmd.env("PATH", format!("{}:{system}", p.display()));
    } else {
        cmd.env("PATH", "/usr/local/bin:/usr/bin:/bin");
    }
    if let Some(t) = target_dir {
        cmd.env("CARGO_TARGET_DIR", t);
    }
    let o = cmd.output().unwrap();
    let text = String::from_utf8_lossy(&o.stdout).replace("\\\n", " ");
    (o, text)
}

/// The stages installed on PATH are the bake's, and make does not build
/// them, however new the sources are; `BIN=` wins over PATH; with
/// neither, this clone's build, under `CARGO_TARGET_DIR` when it is set;
/// a `BIN` without the stages is one line and exit 2.
#[test]
fn the_bake_runs_the_installed_stages_or_bin_and_builds_only_its_own() {
    let d = tempdir();
    let installed = d.path().join("installed");
    std::fs::create_dir(&installed).unwrap();
    for stage in [
        "measure", "promote", "scatter", "facet", "illum", "ssmulti", "sssingle", "render",
        "filter", "follow", "texture", "pcinfo", "pcdiff", "pctile",
    ] {
        let f = installed.join(stage);
        std::fs::write(&f, "#!/bin/sh\nexit 0\n").unwrap();
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&f, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let out = format!("OUT={}", d.path().join("out").display());
    let (o, text) = dry_run(&["bake".into(), out.clone()], Some(&installed), None);
    assert!(o.status.success(), "{}", stderr(&o));
    let run = format!("{}/ssmulti ", installed.display());
    assert!(text.contains(&run), "{text}");
    assert!(!text.contains("cargo build"), "{text}");
    // BIN= over PATH.
    let own = bin("ssmulti").parent().unwrap().to_path_buf();
    let (o, text) = dry_run(
        &["bake".into(), out.clone(), format!("BIN={}", own.display())],
        Some(&installed),
        None,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        text.contains(&format!("{}/ssmulti ", own.display())),
        "{text}"
    );
    assert!(
        !text.contains(&run) && !text.contains("cargo build"),
        "{text}"
    );
    // Neither: the clone's build, where CARGO_TARGET_DIR says.
    let elsewhere = d.path().join("elsewhere");
    let (o, text) = dry_run(&["bake".into(), out.clone()], None, Some(&elsewhere));
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(text.contains("cargo build --release"), "{text}");
    assert!(
        text.contains(&format!("{}/release/ssmulti ", elsewhere.display())),
        "{text}"
    );
    // A BIN without the stages.
    let empty = d.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (o, _) = dry_run(
        &["bake".into(), out, format!("BIN={}", empty.display())],
        None,
        None,
    );
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("BIN=") && err.contains("measure"), "{err}");
}

/// Walks that sample the lights follow the light between surfaces
/// themselves: `INDIRECT` adds no `illum --indirect` pass to them, and
/// does to the diffusion method (at the coarse cloud's points) and to
/// walks that take the cloud's light.
#[test]
fn walks_that_sample_the_lights_take_no_indirect_pass() {
    let d = tempdir();
    let out = format!("OUT={}", d.path().join("out").display());
    let own = format!("BIN={}", bin("ssmulti").parent().unwrap().display());
    for (extra, passes) in [
        (&["METHOD=walk"][..], false),
        (&["METHOD=walk", "SAMPLE_LIGHTS=0"][..], true),
        (&[][..], true),
    ] {
        let mut args: Vec<String> = vec![
            "bake".into(),
            out.clone(),
            own.clone(),
            "MODEL=physical".into(),
            "INDIRECT=16".into(),
        ];
        args.extend(extra.iter().map(|s| s.to_string()));
        let (o, text) = dry_run(&args, None, None);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(text.contains("--indirect "), passes, "{extra:?}: {text}");
        // The diffusion method's rays at the coarse cloud's points, twice
        // INDIRECT a point, their light carried to every point.
        if extra.is_empty() {
            assert!(
                text.contains("--indirect 32") && text.contains("--gather-at-exitance"),
                "{text}"
            );
        }
    }
}

/// `make bake` says one line a stage on stderr as it ends (the stage,
/// the file, its points, the seconds), leaves no stamp behind, and says
/// nothing with `PROGRESS=0`.
#[test]
fn the_bake_says_one_line_a_stage() {
    let d = tempdir();
    let own = format!("BIN={}", bin("ssmulti").parent().unwrap().display());
    for (k, progress) in ["1", "0"].iter().enumerate() {
        let out = d.path().join(format!("out{k}"));
        let o = Command::new("make")
            .args(["-s", "-C"])
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
            .args(["bake", "COUNT=3000", "SINGLE=0", &own])
            .arg(format!("OUT={}", out.display()))
            .arg(format!("PROGRESS={progress}"))
            .env_remove("MAKEFLAGS")
            .output()
            .unwrap();
        let err = stderr(&o);
        assert!(o.status.success(), "{err}");
        let lines: Vec<&str> = err.lines().collect();
        if *progress == "0" {
            assert!(lines.is_empty(), "{err}");
            continue;
        }
        let cloud = format!("scatter: {}/bunny_cloud.ply, 3000 points, ", out.display());
        assert!(
            lines
                .iter()
                .any(|l| l.starts_with(&cloud) && l.ends_with(" s")),
            "{err}"
        );
        for stage in ["measure", "illum", "ssmulti", "render", "filter"] {
            assert!(
                lines.iter().any(|l| l.starts_with(&format!("{stage}: "))),
                "{stage}: {err}"
            );
        }
        assert_eq!(lines.len(), 6, "{err}");
        assert_eq!(count_names(&out, |n| n.ends_with(".start")), 0);
    }
}

/// The Blender add-on's package (`make blender-addon`): a zip with its
/// manifest (the `wheels` key naming the wheel it holds, before the
/// first table, as Blender's TOML reader wants it), its modules and the
/// wheel; a missing wheel is one line.
#[test]
fn the_blender_add_on_packages_as_an_extension() {
    let d = tempdir();
    let wheel = d
        .path()
        .join("pcsss-0.1.0-cp39-abi3-manylinux_2_35_x86_64.whl");
    std::fs::write(&wheel, b"not a real wheel").unwrap();
    let zip = d.path().join("addon.zip");
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/blender/addon_package.py");
    let o = Command::new("python3")
        .arg(&script)
        .arg(&wheel)
        .arg(&zip)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let check = r#"
import sys, tomllib, zipfile
z = zipfile.ZipFile(sys.argv[1])
names = set(z.namelist())
m = tomllib.loads(z.read("blender_manifest.toml").decode())
assert m["id"] == "pcsss" and m["type"] == "add-on", m
assert m["wheels"] == ["./wheels/" + sys.argv[2]], m
assert m["blender_version_min"] >= "4.2.0", m
assert "permissions" in m and "files" in m["permissions"], m
for f in ("__init__.py", "bake.py", "cycles_fit.py", "wheels/" + sys.argv[2]):
    assert f in names, (f, names)
"#;
    let o = Command::new("python3")
        .args(["-c", check])
        .arg(&zip)
        .arg(wheel.file_name().unwrap())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let o = Command::new("python3")
        .arg(&script)
        .arg(d.path().join("none.whl"))
        .arg(d.path().join("x.zip"))
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(stderr(&o).contains("none.whl"), "{}", stderr(&o));
    assert!(!d.path().join("x.zip").exists());
    // The panel's presets are the library's.
    let bake = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/blender/pcsss_addon/bake.py");
    let presets = r#"
import ast, sys
tree = ast.parse(open(sys.argv[1]).read())
names = next(ast.literal_eval(n.value) for n in tree.body
             if isinstance(n, ast.Assign) and getattr(n.targets[0], "id", "") == "PRESETS")
print(" ".join(names))
"#;
    let o = Command::new("python3")
        .args(["-c", presets])
        .arg(&bake)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let panel: Vec<String> = String::from_utf8_lossy(&o.stdout)
        .split_whitespace()
        .map(String::from)
        .collect();
    let library: Vec<String> = pcsss::medium::material::PRESETS
        .iter()
        .map(|p| p.0.to_string())
        .collect();
    assert_eq!(panel, library);
}
