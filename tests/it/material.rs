//! Materials that travel (`--material FILE|PRESET`, formats/MATERIAL.md):
//! a preset or a file gives the stages exactly what the same medium given
//! option by option gives, and an option that says otherwise is refused,
//! naming both.

use crate::util::*;

/// A lit cloud on the cube, as ssmulti and sssingle take it.
fn lit(dir: &std::path::Path) -> String {
    let mesh = cube();
    let mut c = scatter_n(&mesh, 400, 2, pcsss::stages::scatter::PtareaMode::Prim);
    let m = pcsss::geom::mesh::TriMesh::from_cloud(&mesh).unwrap();
    let p = pcsss::stages::facet::Params {
        mode: pcsss::stages::facet::Mode::Flat,
        weight: pcsss::stages::facet::Weight::Angle,
        cusp: 60.0,
        weld: true,
    };
    pcsss::stages::facet::facet_points(&mut c, &m, &p).unwrap();
    let n = c.len();
    c.points_mut()
        .set_vec3("illum", pcsss::Role::Color, &vec![[1.0f32, 0.5, 0.25]; n])
        .unwrap();
    let path = dir.join("lit.ply");
    std::fs::write(&path, to_bytes(&c, pcsss::formats::Format::DEFAULT)).unwrap();
    path.display().to_string()
}

/// A lights file in `dir` with one distant light from above: its path.
fn sun(dir: &std::path::Path) -> String {
    let lights = dir.join("l.json");
    std::fs::write(
        &lights,
        r#"{"lights": [{"name": "sun", "type": "distant", "direction": [-0.3, -1, -0.5]}]}"#,
    )
    .unwrap();
    lights.display().to_string()
}

/// ssM of `ssmulti lit.ply ARGS`.
fn ssm(dir: &std::path::Path, lit: &str, args: &[&str]) -> Vec<[f64; 3]> {
    let out = dir.join("out.ply").display().to_string();
    let mut all = vec![lit, "-o", &out];
    all.extend(args);
    let o = run("ssmulti", &all, b"");
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    from_bytes(&std::fs::read(&out).unwrap())
        .points()
        .vec3_f64("ssM")
        .unwrap()
}

#[test]
fn a_preset_or_a_file_gives_what_its_options_give() {
    let d = tempdir();
    let lit = lit(d.path());
    // Skim milk in a scene whose unit is a centimetre.
    let p = pcsss::medium::material::preset("skimmilk", 10.0).unwrap();
    let list = |v: [f64; 3]| format!("{:?},{:?},{:?}", v[0], v[1], v[2]);
    let (albedo, mfp) = (list(p.albedo.unwrap()), list(p.mfp.unwrap()));
    let by_options = ssm(
        d.path(),
        &lit,
        &[
            "--model", "physical", "--albedo", &albedo, "--mfp", &mfp, "--eta", "1.3",
        ],
    );
    let file = d.path().join("milk.json");
    std::fs::write(&file, r#"{"preset": "skimmilk", "unit_length": 10}"#).unwrap();
    let by_file = ssm(d.path(), &lit, &["--material", file.to_str().unwrap()]);
    assert_eq!(by_options, by_file);
    // The same value given again is no conflict.
    let again = ssm(
        d.path(),
        &lit,
        &["--material", file.to_str().unwrap(), "--eta", "1.3"],
    );
    assert_eq!(by_file, again);
    // A file of the artist's parameters.
    std::fs::write(
        &file,
        r#"{"color": [0.8, 0.5, 0.3], "dmfp": 0.05, "g": 0.2}"#,
    )
    .unwrap();
    assert_eq!(
        ssm(d.path(), &lit, &["--material", file.to_str().unwrap()]),
        ssm(
            d.path(),
            &lit,
            &[
                "--model",
                "physical",
                "--color",
                "0.8,0.5,0.3",
                "--dmfp",
                "0.05",
                "--g",
                "0.2"
            ],
        )
    );
    // A preset by name: millimetres.
    let p = pcsss::medium::material::preset("ketchup", 1.0).unwrap();
    let (albedo, mfp) = (list(p.albedo.unwrap()), list(p.mfp.unwrap()));
    assert_eq!(
        ssm(d.path(), &lit, &["--material", "Ketchup"]),
        ssm(
            d.path(),
            &lit,
            &["--model", "physical", "--albedo", &albedo, "--mfp", &mfp],
        )
    );
}

#[test]
fn a_material_and_an_option_that_disagree_are_refused_naming_both() {
    let d = tempdir();
    let lit = lit(d.path());
    let bad = d.path().join("bad.json");
    std::fs::write(&bad, r#"{"albedo": 0.9, "mfp": 1, "shine": 2}"#).unwrap();
    let bad = bad.to_str().unwrap();
    for (args, code, says) in [
        (
            &["--material", "skin1", "--eta", "1.4"][..],
            2,
            "--eta: eta 1.4 conflicts with the material's eta 1.3 (preset skin1)",
        ),
        (
            &["--material", "skin1", "--albedo", "0.5"][..],
            2,
            "--albedo",
        ),
        (&["--material", "skin1", "--dmfp", "1"][..], 2, "--dmfp"),
        (
            &["--material", "skin1", "--model", "seed"][..],
            2,
            "--model",
        ),
        (&["--material", "jelly"][..], 2, "skimmilk"),
        (&["--material", bad][..], 1, "shine"),
    ] {
        let out = d.path().join("out.ply");
        let mut all = vec![lit.as_str(), "-o", out.to_str().unwrap()];
        all.extend(args);
        let o = run("ssmulti", &all, b"");
        assert_eq!(o.status.code(), Some(code), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{args:?}: {}", stderr(&o));
        assert_eq!(stderr(&o).lines().count(), 1, "{}", stderr(&o));
        assert!(!out.exists());
    }
}

/// The bake takes `MATERIAL=`: every stage that reads the medium is given
/// it, the model is physical, and no option says otherwise.
#[test]
fn the_bake_passes_the_material_to_every_stage() {
    let d = tempdir();
    let bin = bin("ssmulti");
    let o = std::process::Command::new("make")
        .args(["-n", "-C"])
        .arg(std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines"))
        .arg(format!("OUT={}", d.path().display()))
        .arg(format!("BIN={}", bin.parent().unwrap().display()))
        .args(["MATERIAL=skin1", "INDIRECT=8"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    // (A command's lines joined.)
    let text = String::from_utf8_lossy(&o.stdout).replace("\\\n", " ");
    for stage in ["illum", "ssmulti", "sssingle"] {
        // The stage's own commands (not the build's, if make would build).
        let run = format!("{}/{stage} ", bin.parent().unwrap().display());
        let lines: Vec<&str> = text
            .lines()
            .filter(|l| l.trim_start().starts_with(&run))
            .collect();
        assert!(!lines.is_empty(), "{stage}: {text}");
        for l in lines {
            assert!(l.contains("--material skin1"), "{l}");
            assert!(!l.contains("--eta") && !l.contains("--albedo"), "{l}");
        }
    }
    assert!(text.contains("--model physical"), "{text}");
}

/// sssingle takes what ssmulti recorded in the cloud when it is not told:
/// the physical medium (given to ssmulti as a colour and a diffuse mean
/// free path), or the seed model's Rd, sd and t_rgb; an option that says
/// otherwise is an error naming both (issue 44: `sssingle --sd 0.25` on a
/// cloud baked at sd 0.6 used Rd 1 and no --rgb).
#[test]
fn sssingle_takes_the_medium_ssmulti_recorded() {
    let d = tempdir();
    let lit = lit(d.path());
    let cube = fixtures().join("mesh/cube.obj").display().to_string();
    let lights = sun(d.path());
    let single = |cloud: &str, args: &[&str]| {
        let out = d.path().join("s.ply").display().to_string();
        let mut all = vec![
            cloud,
            "--mesh",
            &cube,
            "--lights",
            &lights,
            "--eye=3,4,5",
            "-o",
            &out,
        ];
        all.extend(args);
        let o = run("sssingle", &all, b"");
        (o, out)
    };
    let ss_of = |out: &str| {
        from_bytes(&std::fs::read(out).unwrap())
            .points()
            .vec3_f64("ssS")
            .unwrap()
    };
    // ssmulti's options (given to sssingle too: told the same), and one
    // that disagrees with them.
    let physical = [
        "--model",
        "physical",
        "--color",
        "0.8,0.5,0.3",
        "--dmfp",
        "0.2,0.1,0.05",
        "--g",
        "0.3",
    ];
    let seed = ["--rd", "0.9,0.5,0.3", "--sd", "0.6", "--rgb"];
    for (ss_args, conflict, says) in [
        (&physical[..], &["--eta", "1.4"][..], "--eta"),
        (&seed[..], &["--sd", "0.25"][..], "ssmulti_sd 0.6"),
    ] {
        let baked = d.path().join("baked.ply").display().to_string();
        let mut a = vec![lit.as_str(), "-o", &baked];
        a.extend(ss_args);
        let o = run("ssmulti", &a, b"");
        assert!(o.status.success(), "{}", stderr(&o));
        let (o, out) = single(&baked, &[]);
        assert!(o.status.success(), "{}", stderr(&o));
        let told_nothing = ss_of(&out);
        let (o, out) = single(&baked, ss_args);
        assert!(o.status.success(), "{}", stderr(&o));
        assert_eq!(told_nothing, ss_of(&out), "{ss_args:?}");
        let (o, _) = single(&baked, conflict);
        assert_eq!(o.status.code(), Some(2), "{conflict:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(says), "{}", stderr(&o));
        // --model seed on a physical record: the seed model, no conflict.
        if ss_args[0] == "--model" {
            let (o, out) = single(&baked, &["--model", "seed", "--sd", "0.3"]);
            assert!(o.status.success(), "{}", stderr(&o));
            assert_ne!(ss_of(&out), told_nothing);
        }
    }
}

/// Lazy ssS in render takes the medium ssmulti recorded in the cloud when
/// given none: the same picture as with the medium given, and an option
/// that says otherwise is refused naming both.
#[test]
fn render_s_lazy_single_scattering_takes_the_recorded_medium() {
    let d = tempdir();
    let at = |n: &str| d.path().join(n).display().to_string();
    let torus = fixtures().join("mesh/torus.obj").display().to_string();
    let lights = fixtures().join("lights/torus.json").display().to_string();
    std::fs::write(
        d.path().join("cam.json"),
        r#"{ "position": [0.0, -3.4, 2.0], "look_at": [0.0, 0.0, -0.1], "up": [0, 0, 1], "fov": 35, "width": 24, "height": 18 }"#,
    )
    .unwrap();
    let b = |n: &str| bin(n).display().to_string();
    let medium = "--model physical --albedo 0.95,0.8,0.6 --mfp 0.05 --eta 1.3 --g 0.2";
    shell(
        d.path(),
        &format!(
            "{m} {torus} | {p} --class face --attr area --method sum --as Tarea > mesh.ply && \
             {s} mesh.ply -n 3000 --seed 3 | {f} --mesh mesh.ply | {p} --normalize | \
             {i} --lights {lights} --mesh mesh.ply | {ss} {medium} -o ss.ply",
            m = b("measure"),
            p = b("promote"),
            s = b("scatter"),
            f = b("facet"),
            i = b("illum"),
            ss = b("ssmulti"),
        ),
    );
    let render = |extra: &str, out: &str| {
        let mut args: Vec<String> = [
            "--mesh",
            "mesh.ply",
            "--camera",
            "cam.json",
            "--cloud",
            "ss.ply",
            "--single-lights",
            &lights,
            "--samples",
            "4",
            "-o",
            out,
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        args.extend(extra.split_whitespace().map(String::from));
        let refs: Vec<&str> = args.iter().map(|s| s.as_str()).collect();
        run_in(Some(d.path()), "render", &refs, b"")
    };
    let o = render(medium, "given.exr");
    assert!(o.status.success(), "{}", stderr(&o));
    let o = render("", "recorded.exr");
    assert!(o.status.success(), "{}", stderr(&o));
    let read = |n: &str| {
        pcsss::formats::read_cloud_file(std::path::Path::new(&at(n)), &pcsss::formats::Select::All)
            .unwrap()
            .points()
            .vec3_f64("beauty")
            .unwrap()
    };
    let (given, recorded) = (read("given.exr"), read("recorded.exr"));
    assert!(given.iter().any(|v| v[0] > 0.0));
    assert_eq!(given, recorded);
    let o = render("--eta 1.5", "clash.exr");
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--eta"), "{}", stderr(&o));
    assert!(!d.path().join("clash.exr").exists());
}

/// A material file is read once by every stage that takes one: given as
/// a named pipe, which gives its text to one reader only, a second read
/// would wait for a writer that never comes (or read nothing).
#[test]
fn every_stage_reads_its_material_file_once() {
    use std::process::{Command, Stdio};
    let d = tempdir();
    let lit = lit(d.path());
    let cube = fixtures().join("mesh/cube.obj").display().to_string();
    let lights = sun(d.path());
    let out = d.path().join("out.ply").display().to_string();
    let stages: [(&str, Vec<&str>); 4] = [
        ("ssmulti", vec![&lit]),
        ("illum", vec![&lit, "--lights", &lights, "--mesh", &cube]),
        (
            "sssingle",
            vec![&lit, "--mesh", &cube, "--lights", &lights, "--eye=3,4,5"],
        ),
        ("filter", vec![&lit, "--cloud", &lit, "--attr", "ssM"]),
    ];
    for (stage, args) in stages {
        let fifo = d.path().join(format!("{stage}.json"));
        let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
        assert!(made.success());
        let pipe = fifo.clone();
        // (Blocks until the stage opens the pipe; left waiting if it never
        // does, which the stage's own failure then reports.)
        std::thread::spawn(move || {
            std::fs::write(pipe, r#"{"preset": "skin1", "unit_length": 1}"#)
        });
        let mut child = Command::new(bin(stage))
            .args(&args)
            .args(["-o", &out, "--material"])
            .arg(&fifo)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if start.elapsed() > std::time::Duration::from_secs(120) {
                child.kill().unwrap();
                panic!("{stage} waits on its material pipe: it opened the file twice");
            }
            std::thread::sleep(std::time::Duration::from_millis(50));
        };
        let mut err = String::new();
        std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
        assert!(status.success(), "{stage}: {err}");
        let c = from_bytes(&std::fs::read(&out).unwrap());
        assert!(!c.is_empty(), "{stage}");
    }
}
