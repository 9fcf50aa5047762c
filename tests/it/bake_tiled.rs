//! The tiled bake of the pipelines' Makefile (`make -C pipelines tiled`):
//! the bunny at 1M points through ssmulti (exact) and filter, in 16 tiles,
//! equals the untiled bake, with the tiles run by make -j, by a Slurm job
//! array on the throwaway cluster `make test` starts, and by openjd-cli
//! running the Open Job Description template.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

use crate::tiles::{read, worst};
use crate::util::*;

fn make(out: &Path, target: &str, extra: &[String]) {
    let bin = bin("pctile");
    let mut cmd = Command::new("make");
    cmd.args(["-s", "-j2", "-C"])
        .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
        .arg(format!("OUT={}", out.display()))
        .arg(format!("BIN={}", bin.parent().unwrap().display()))
        // Random points and prim areas: the quickest cloud of 1M points;
        // a filter radius of 0.1 D, about 60 neighbours a point, keeps
        // the filter passes quick.
        .args([
            "COUNT=1000000",
            "BLUE=0",
            "PTAREA=prim",
            "RADIUS=0.1",
            "TILES=16",
        ])
        .args(extra)
        .arg(target);
    let o = cmd.output().expect("make runs");
    assert!(
        o.status.success(),
        "make {target} {extra:?}: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn check(out: &Path, engine: &str) {
    for (whole, tiled) in [
        ("bunny_ss.ply", "bunny_ss_tiled.ply"),
        ("bunny_filtered.ply", "bunny_filtered_tiled.ply"),
    ] {
        let (w, t) = (read(&out.join(whole)), read(&out.join(tiled)));
        assert_eq!(w.len(), 1_000_000);
        let e = worst(&t, &w, "ssM");
        eprintln!("{engine}: {tiled} against {whole}: worst difference {e:e}");
        assert!(e < 1e-6, "{engine}: {tiled}: {e}");
        assert_eq!(w.detail, t.detail, "{engine}: {tiled}");
    }
}

/// Removes the tiled results so that another engine makes them again.
fn clear(out: &Path) {
    let _ = std::fs::remove_dir_all(out.join("bunny_tiles"));
    for f in ["bunny_ss_tiled.ply", "bunny_filtered_tiled.ply"] {
        let _ = std::fs::remove_file(out.join(f));
    }
}

/// The untiled bake and the tiled one under make -j2, made once for the
/// tests of this file (in cargo's temp folder for tests, rebuilt at the
/// first use in a run).
fn baked() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("tiled_bake");
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        make(&dir, "tiled-check", &[]);
        dir
    })
}

/// A copy of [`baked`] for `engine` (times kept, so make remakes only
/// what [`clear`] removes).
fn copy_for(engine: &str) -> PathBuf {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("tiled_bake_{engine}"));
    let _ = std::fs::remove_dir_all(&out);
    let o = Command::new("cp")
        .arg("-a")
        .arg(baked())
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    clear(&out);
    out
}

#[test]
fn tiled_bake_of_a_million_points_under_make_equals_the_untiled_bake() {
    check(baked(), "make -j2");
}

#[test]
#[ignore = "interop: needs a Slurm cluster; `make test` starts one and runs it"]
fn tiled_bake_of_a_million_points_under_slurm_equals_the_untiled_bake() {
    if !std::env::var("SLURM_CONF").is_ok_and(|c| Path::new(&c).is_file()) {
        interop_missing("a Slurm cluster (SLURM_CONF; make test starts one)");
    }
    let out = &copy_for("slurm");
    make(out, "tiled", &["ENGINE=slurm".into()]);
    check(out, "slurm");
    let logs =
        crate::util::count_names(&out.join("bunny_tiles/ss/out"), |n| n.starts_with("slurm-"));
    assert_eq!(logs, 17, "16 array tasks and the merge ran under Slurm");
    // A tile that fails cancels the merge: submit.sh says so.
    let small = out.join("small");
    let o = crate::util::run(
        "pctile",
        &[
            "split",
            out.join("bunny_illum.ply").to_str().unwrap(),
            "--tiles",
            "2",
            "--halo",
            "0.1",
            "-o",
            small.to_str().unwrap(),
        ],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/slurm/submit.sh");
    let o = Command::new(script)
        .env("BIN", bin("pctile").parent().unwrap())
        .args([
            "--wait",
            small.to_str().unwrap(),
            out.join("small_out").to_str().unwrap(),
        ])
        .arg(out.join("never.ply"))
        .args(["ssmulti", "--sd", "-1"])
        .output()
        .unwrap();
    assert!(!o.status.success(), "a failed tile fails the submission");
    assert!(stderr(&o).contains("ended CANCELLED"), "{}", stderr(&o));
    assert!(!out.join("never.ply").exists());
    let _ = std::fs::remove_dir_all(out);
}

#[test]
#[ignore = "interop: needs openjd-cli; `make test` installs and runs it"]
fn tiled_bake_of_a_million_points_under_openjd_equals_the_untiled_bake() {
    let openjd = match std::env::var("PCSSS_OPENJD") {
        Ok(o) if Path::new(&o).is_file() => o,
        _ => interop_missing("openjd-cli (PCSSS_OPENJD; make test installs it)"),
    };
    let out = &copy_for("openjd");
    make(
        out,
        "tiled",
        &["ENGINE=openjd".into(), format!("OPENJD={openjd}")],
    );
    check(out, "openjd");
    let _ = std::fs::remove_dir_all(out);
}
