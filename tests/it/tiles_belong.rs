//! Tiles that do not belong together are never merged (issue 42): a tile
//! of another split of other data with the same name and points, tiles
//! baked with different parameters, a halo width that is not one, and a
//! manifest edited with its id recomputed (paths out of its folder, counts
//! that disagree) or that never ends. Each refusal is one line naming what
//! is wrong; the output is never written.

use std::path::{Path, PathBuf};

use pcsss::tiles::Manifest;
use pcsss::{Cloud, DetailValue};

use crate::util::*;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Runs `pctile args`: exit status, one line of stderr.
fn pctile(args: &[&str]) -> (Option<i32>, String) {
    let o = run("pctile", args, b"");
    let err = stderr(&o);
    if !o.status.success() {
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
    }
    (o.status.code(), err)
}

/// `ssmulti ARGS` on every tile of `t` into `out`.
fn bake(t: &Path, out: &Path, args: &[&str]) {
    std::fs::create_dir_all(out).unwrap();
    for e in std::fs::read_dir(t).unwrap() {
        let p = e.unwrap().path();
        let name = p.file_name().unwrap().to_str().unwrap().to_string();
        if name.starts_with("tile_") {
            let mut a = vec![s(&p)];
            a.extend_from_slice(args);
            let o_path = out.join(&name);
            a.extend_from_slice(&["-o", s(&o_path)]);
            let o = run("ssmulti", &a, b"");
            assert!(o.status.success(), "{}", stderr(&o));
        }
    }
}

fn cloud(shift: f32) -> Cloud {
    let mut c = crate::ssmulti::wavy(3000, glam::DVec3::new(1.0, -2.0, 1.0), 1.0, 5);
    // Same points, other light: the data differs, the positions do not.
    let mut il = c.points().vec3_f32("illum").unwrap();
    for v in &mut il {
        v[0] += shift;
    }
    c.points_mut()
        .set_vec3("illum", pcsss::Role::Color, &il)
        .unwrap();
    c
}

/// `cloud(0.0)` written to `dir/in.ply` and split into `tiles` tiles with
/// halo `halo` in `dir/T`: the input's path and the split's.
fn split_fresh(dir: &Path, tiles: usize, halo: f64) -> (PathBuf, PathBuf) {
    let input = dir.join("in.ply");
    std::fs::write(&input, to_bytes(&cloud(0.0), LE)).unwrap();
    let t = dir.join("T");
    let (n, h) = (tiles.to_string(), halo.to_string());
    let args = ["split", s(&input), "--tiles", &n, "--halo", &h, "-o", s(&t)];
    assert_eq!(pctile(&args).0, Some(0));
    (input, t)
}

#[test]
fn a_tile_of_another_split_of_other_data_is_refused() {
    let d = tempdir();
    let (input, t) = split_fresh(d.path(), 3, 0.3);
    let o = d.path().join("O");
    bake(&t, &o, &["--sd", "0.3"]);
    // The same name, the same points, other light; split again in place.
    std::fs::write(&input, to_bytes(&cloud(0.25), LE)).unwrap();
    assert_eq!(
        pctile(&[
            "split",
            s(&input),
            "--tiles",
            "3",
            "--halo",
            "0.3",
            "-o",
            s(&t)
        ])
        .0,
        Some(0)
    );
    let out = d.path().join("merged.ply");
    let (code, err) = pctile(&["merge", s(&t), "--from", s(&o), "-o", s(&out)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(
        err.contains("a tile of another split") && err.contains("tile_0000.ply"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn tiles_baked_with_other_parameters_are_refused_naming_both() {
    let d = tempdir();
    let (_, t) = split_fresh(d.path(), 2, 0.5);
    for (i, (a, b, what)) in [
        (
            &["--sd", "0.3"][..],
            &["--sd", "0.3", "--falloff", "exp"][..],
            "ssmulti_falloff",
        ),
        (
            &["--sd", "0.3"][..],
            &["--sd", "0.3", "--bounce", "0.5"][..],
            "ssmulti_bounce",
        ),
        (
            &["--sd", "0.3"][..],
            &["--sd", "0.3", "--norm", "local"][..],
            "ssmulti_norm",
        ),
        (
            &["--sd", "0.3"][..],
            &["--sd", "0.3", "--rgb", "--rd", "1,0.5,0.5"][..],
            "ssmulti_rd",
        ),
    ]
    .into_iter()
    .enumerate()
    {
        let o = d.path().join(format!("O{i}"));
        bake(&t, &o, a);
        // Tile 1 baked again otherwise.
        let t1 = o.join("tile_0001.ply");
        let mut args = vec![];
        let src = t.join("tile_0001.ply");
        args.push(s(&src));
        args.extend_from_slice(b);
        args.extend_from_slice(&["-o", s(&t1)]);
        let r = run("ssmulti", &args, b"");
        assert!(r.status.success(), "{}", stderr(&r));
        let out = d.path().join(format!("merged{i}.ply"));
        let (code, err) = pctile(&["merge", s(&t), "--from", s(&o), "-o", s(&out)]);
        assert_eq!(code, Some(1), "{what}: {err}");
        assert!(
            err.contains(what) && err.contains("tile_0000.ply") && err.contains("tile_0001.ply"),
            "{err}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn a_halo_width_that_is_not_one_is_refused() {
    let d = tempdir();
    let mut c = cloud(0.0);
    for (w, name) in [(f64::NAN, "nan"), (f64::INFINITY, "inf"), (-1.0, "neg")] {
        c.points_mut()
            .set(pcsss::Attribute::scalar(
                "pctile_halo",
                pcsss::Column::U8(vec![0; 3000]),
            ))
            .unwrap();
        c.set_detail("pctile_halo_width", DetailValue::F64(w));
        let f = d.path().join(format!("{name}.ply"));
        std::fs::write(&f, to_bytes(&c, LE)).unwrap();
        let o = run("ssmulti", &[s(&f), "--sd", "0.3", "-o", "/dev/null"], b"");
        assert_eq!(o.status.code(), Some(1), "{name}: {}", stderr(&o));
        assert!(stderr(&o).contains("pctile_halo_width"), "{}", stderr(&o));
    }
}

/// Writes `m` as the manifest of `dir` with its id recomputed, as a hand
/// that knows the format would.
fn forge(dir: &Path, m: &mut Manifest) {
    m.split = m.checksum();
    let text = serde_json::to_string_pretty(m).unwrap();
    std::fs::write(dir.join("manifest.json"), text).unwrap();
}

#[test]
fn a_forged_manifest_is_refused_and_one_that_never_ends_is_not_read_whole() {
    let d = tempdir();
    let (_, t) = split_fresh(d.path(), 2, 0.5);
    let good = Manifest::read(&t).unwrap();
    std::fs::write(d.path().join("outside.ply"), b"ply\n").unwrap();
    type Edit = Box<dyn Fn(&mut Manifest)>;
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|m| m.tiles[0].file = "../outside.ply".into()),
            "plain file name",
        ),
        (
            Box::new(|m| m.tiles[1].file = "/etc/passwd".into()),
            "plain file name",
        ),
        (
            Box::new(|m| m.rest = Some("../outside.ply".into())),
            "plain file name",
        ),
        (Box::new(|m| m.elements[0].count += 5), "not one of"),
        (Box::new(|m| m.halo = -1.0), "halo -1"),
    ];
    let out = d.path().join("merged.ply");
    for (edit, want) in &cases {
        let mut m = good.clone();
        edit(&mut m);
        forge(&t, &mut m);
        let (code, err) = pctile(&["merge", s(&t), "-o", s(&out)]);
        assert_eq!(code, Some(1), "{want}: {err}");
        assert!(
            err.contains("manifest.json") && err.contains(want),
            "{want}: {err}"
        );
        assert!(!out.exists());
    }
    // A manifest that goes on forever.
    std::fs::remove_file(t.join("manifest.json")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", t.join("manifest.json")).unwrap();
    let (code, err) = pctile(&["merge", s(&t), "-o", s(&out)]);
    assert_eq!(code, Some(1), "{err}");
    assert!(err.contains("larger than"), "{err}");
}

#[test]
fn a_split_opens_the_files_its_tiles_need_or_says_how_many_it_can() {
    let d = tempdir();
    let input = d.path().join("in.ply");
    std::fs::write(&input, to_bytes(&cloud(0.0), LE)).unwrap();
    let split = |limits: &str, tiles: &str, out: &str| {
        let cmd = format!(
            "{limits}; exec {} split {} --tiles {tiles} --halo 0.01 -q -o {}",
            bin("pctile").display(),
            s(&input),
            s(&d.path().join(out))
        );
        std::process::Command::new("bash")
            .args(["-c", &cmd])
            .output()
            .unwrap()
    };
    // A soft limit below the tiles, a hard one above: raised, and done.
    let o = split("ulimit -Hn 4096; ulimit -Sn 64", "300", "raised");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        Manifest::read(&d.path().join("raised"))
            .unwrap()
            .tiles
            .len(),
        300
    );
    // Both below: refused before any file, naming what would do.
    let o = split("ulimit -n 64", "300", "refused");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let err = stderr(&o);
    assert!(
        err.contains("--tiles") && err.contains("at most 48 tiles"),
        "{err}"
    );
    assert!(!d.path().join("refused").exists());
}
