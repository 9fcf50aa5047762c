//! Bad input: one clear line naming the parameter or the file, exit 2 for
//! a parameter, 1 for a file; and the eye inside the object.

use super::*;

/// The slab bake's files: cloud, mesh, lights.
fn files(dir: &std::path::Path) -> (String, String, String) {
    let cloud = dir.join("cloud.ply");
    let mesh = dir.join("mesh.ply");
    let lights = dir.join("lights.json");
    std::fs::write(
        &cloud,
        to_bytes(
            &top_points(3, 0.05, DVec3::ZERO),
            pcsss::formats::Format::DEFAULT,
        ),
    )
    .unwrap();
    std::fs::write(
        &mesh,
        to_bytes(
            &slab_mesh(5.0, 1.0, DVec3::ZERO),
            pcsss::formats::Format::DEFAULT,
        ),
    )
    .unwrap();
    std::fs::write(
        &lights,
        r#"{"lights": [{"type": "distant", "name": "sun", "direction": [0, 0, -1]}]}"#,
    )
    .unwrap();
    let s = |p: std::path::PathBuf| p.display().to_string();
    (s(cloud), s(mesh), s(lights))
}

#[test]
fn bad_parameters_and_files_get_one_clear_line() {
    let dir = tempdir();
    let (cloud, mesh, lights) = files(dir.path());
    let base = [
        "--mesh",
        &mesh,
        "--lights",
        &lights,
        "--eye=-3,4,5",
        "--sd",
        "0.3",
    ];
    let cases: Vec<(Vec<&str>, i32, &str)> = vec![
        (vec!["--eta", "0"], 2, "--eta"),
        (vec!["--eta", "NaN"], 2, "--eta"),
        (vec!["--eta", "-1.3"], 2, "--eta"),
        (vec!["--samples", "0"], 2, "--samples"),
        (vec!["--samples", "5000"], 2, "--samples"),
        (vec!["--g", "1.5"], 2, "--g"),
        (
            vec!["--model", "physical", "--mfp", "0.1", "--albedo", "1.2"],
            2,
            "--albedo",
        ),
        (vec!["--model", "physical", "--mfp", "0,1,2"], 2, "--mfp"),
        (vec!["--model", "physical", "--mfp", "-1"], 2, "--mfp"),
        (vec!["--model", "physical"], 2, "--mfp"),
        (vec!["--rd", "1,2"], 2, "--rd"),
        (vec!["--eye", "1,2"], 2, "--eye"),
    ];
    for (extra, code, names) in cases {
        let mut args: Vec<&str> = vec![&cloud];
        args.extend(base);
        args.extend(extra.iter().copied());
        let o = run_in(Some(dir.path()), "sssingle", &args, b"");
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{extra:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{extra:?}: {err}");
        assert!(err.contains(names), "{extra:?}: {err}");
        assert!(!err.contains("panicked"), "{extra:?}: {err}");
    }
    // No --sd for the seed model; no --mesh; a missing lights file; a
    // cloud without N.
    let o = run_in(
        Some(dir.path()),
        "sssingle",
        &[&cloud, "--mesh", &mesh, "--lights", &lights, "--eye=1,2,3"],
        b"",
    );
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--sd"), "{}", stderr(&o));
    let o = run_in(
        Some(dir.path()),
        "sssingle",
        &[&cloud, "--lights", &lights, "--eye=1,2,3", "--sd", "1"],
        b"",
    );
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--mesh"), "{}", stderr(&o));
    let o = run_in(
        Some(dir.path()),
        "sssingle",
        &[
            &cloud,
            "--mesh",
            &mesh,
            "--lights",
            "nosuch.json",
            "--eye=1,2,3",
            "--sd",
            "1",
        ],
        b"",
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("nosuch.json"), "{}", stderr(&o));
    let mut bare = Cloud::with_points(1);
    bare.points_mut()
        .set_vec3("P", Role::Point, &[[0.0, 0.0, 0.0]])
        .unwrap();
    let bare_path = dir.path().join("bare.ply").display().to_string();
    std::fs::write(&bare_path, to_bytes(&bare, pcsss::formats::Format::DEFAULT)).unwrap();
    let o = run_in(
        Some(dir.path()),
        "sssingle",
        &[
            &bare_path,
            "--mesh",
            &mesh,
            "--lights",
            &lights,
            "--eye=1,2,3",
            "--sd",
            "1",
        ],
        b"",
    );
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("'N'") && stderr(&o).contains("facet"),
        "{}",
        stderr(&o)
    );
    // Nothing was written.
    assert!(!dir.path().join("out.ply").exists());
}

#[test]
fn an_eye_inside_the_object_is_warned_about_with_a_count() {
    let dir = tempdir();
    let (cloud, mesh, lights) = files(dir.path());
    let out = dir.path().join("out.ply").display().to_string();
    let o = run_in(
        Some(dir.path()),
        "sssingle",
        &[
            &cloud,
            "--mesh",
            &mesh,
            "--lights",
            &lights,
            "--eye=0,0,-0.5",
            "--sd",
            "1",
            "-o",
            &out,
        ],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("the eye is inside the mesh: 9 of 9 points saw nothing"),
        "{}",
        stderr(&o)
    );
}

/// What computes nothing, or nothing right, says so with counts (issue
/// 42): points off the mesh, a mesh wound against them, a light inside
/// it; and a scene where all is well says nothing.
#[test]
fn points_off_the_mesh_a_mesh_wound_inwards_and_a_buried_light_are_warned_about() {
    let dir = tempdir();
    let (cloud, mesh, lights) = files(dir.path());
    let w = |name: &str, c: &pcsss::Cloud| {
        let p = dir.path().join(name);
        std::fs::write(&p, to_bytes(c, pcsss::formats::Format::DEFAULT)).unwrap();
        p.display().to_string()
    };
    // The slab moved away from its points, and the slab wound inwards.
    let moved = w(
        "moved.ply",
        &slab_mesh(5.0, 1.0, DVec3::new(20.0, 0.0, 0.0)),
    );
    let mut p = Vec::new();
    for &z in &[-1.0, 0.0] {
        for &(x, y) in &[(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)] {
            p.push([x, y, z]);
        }
    }
    // slab_mesh's quads, each wound the other way.
    let faces = vec![
        vec![7, 6, 5, 4],
        vec![1, 2, 3, 0],
        vec![4, 5, 1, 0],
        vec![5, 6, 2, 1],
        vec![6, 7, 3, 2],
        vec![7, 4, 0, 3],
    ];
    let flipped = w("flipped.ply", &mesh_from(&p, &faces));
    let buried = dir.path().join("buried.json");
    std::fs::write(
        &buried,
        r#"{"lights": [{"type": "distant", "name": "sun", "direction": [0, 0, -1]},
                       {"type": "point", "name": "buried", "position": [0, 0, -0.5]}]}"#,
    )
    .unwrap();
    let buried = buried.display().to_string();
    let out = dir.path().join("out.ply").display().to_string();
    let sssingle = |mesh: &str, lights: &str| {
        let o = run_in(
            Some(dir.path()),
            "sssingle",
            &[
                &cloud,
                "--mesh",
                mesh,
                "--lights",
                lights,
                "--eye=0,0,5",
                "--sd",
                "1",
                "-o",
                &out,
            ],
            b"",
        );
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let ok = sssingle(&mesh, &lights);
    assert!(!ok.contains("warning"), "{ok}");
    let err = sssingle(&moved, &lights);
    assert!(
        err.contains("9 of 9 points checked lie off the mesh"),
        "{err}"
    );
    assert!(
        err.contains("9 of 9 points seen from the eye had no light enter"),
        "{err}"
    );
    let err = sssingle(&flipped, &lights);
    assert!(
        err.contains("9 of 9 points checked face against the mesh"),
        "{err}"
    );
    let err = sssingle(&mesh, &buried);
    assert!(err.contains("light 'buried' is inside the mesh"), "{err}");
    assert!(!err.contains("sun"), "{err}");
}
