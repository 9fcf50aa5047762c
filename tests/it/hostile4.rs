//! Hostile input and outputs, round four (issue 56's classes): files an
//! input names are inputs too, standard output is an output, what `-o
//! LINK` writes, `/dev/null` opened on purpose, reads with a ceiling.
//! Each test names its class, and checks both sides: the bad use is
//! refused with one line and the exit status, the valid one still works.

use std::os::unix::fs::symlink;
use std::path::Path;
use std::process::{Command, Stdio};

use crate::util::*;
use pcsss::{Cloud, Role};

/// Points with `P` and `N` (up), as a binary PLY in `dir`.
fn cloud_file(dir: &Path, name: &str) -> String {
    let mut c = Cloud::with_points(3);
    let p = [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    c.points_mut()
        .set_vec3("N", Role::Normal, &[[0.0f32, 0.0, 1.0]; 3])
        .unwrap();
    let f = dir.join(name);
    std::fs::write(&f, to_bytes(&c, LE)).unwrap();
    f.display().to_string()
}

/// A dome light's lights file and its map (a 4 x 2 OpenEXR image).
fn dome(dir: &Path) -> (String, std::path::PathBuf) {
    let map = dir.join("map.exr");
    exr::prelude::write_rgb_file(&map, 4, 2, |_, _| (1.0f32, 1.0, 1.0)).unwrap();
    let lights = dir.join("dome.json");
    std::fs::write(
        &lights,
        r#"{"lights": [{"name": "sky", "type": "dome", "map": "map.exr", "samples": 4}]}"#,
    )
    .unwrap();
    (lights.display().to_string(), map)
}

/// Runs `cmd` with bash in `dir`; its output, whatever its status.
fn bash(dir: &Path, cmd: &str) -> std::process::Output {
    Command::new("bash")
        .args(["-c", cmd])
        .current_dir(dir)
        .env(
            "PATH",
            format!(
                "{}:/usr/bin:/bin",
                bin("pcinfo").parent().unwrap().display()
            ),
        )
        .output()
        .unwrap()
}

/// One line on stderr saying what `what` says, the exit status `code`.
fn refused(o: &std::process::Output, code: i32, says: &str) {
    let err = stderr(o);
    assert_eq!(o.status.code(), Some(code), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains(says), "{err}");
}

#[test]
fn class_1_a_file_an_input_names_is_an_input() {
    let d = tempdir();
    let cloud = cloud_file(d.path(), "cloud.ply");
    let (lights, map) = dome(d.path());
    let before = std::fs::read(&map).unwrap();
    // illum lit by the dome, written to `out`.
    let illum_to = |out: &Path| {
        let args = [
            &cloud,
            "--lights",
            &lights,
            "--no-shadows",
            "-o",
            out.to_str().unwrap(),
        ];
        run("illum", &args, b"")
    };
    // The dome map the lights file names, as illum's output: refused
    // before any work, naming -o; the map untouched.
    let o = illum_to(&map);
    refused(&o, 2, "is also an input");
    assert!(
        stderr(&o).contains("--output") || stderr(&o).contains("-o"),
        "{}",
        stderr(&o)
    );
    assert_eq!(std::fs::read(&map).unwrap(), before);
    // Through a link to it: the same file.
    let link = d.path().join("link.exr");
    symlink(&map, &link).unwrap();
    refused(&illum_to(&link), 2, "is also an input");
    assert_eq!(std::fs::read(&map).unwrap(), before);
    // The valid use: the same run to another file.
    let o = illum_to(&d.path().join("lit.ply"));
    assert!(o.status.success(), "{}", stderr(&o));
    // render's direct light names the same map: its picture is refused
    // over it too.
    let cube = fixtures().join("mesh/cube.obj");
    let camera = fixtures().join("cameras/bunny.json");
    let o = run(
        "render",
        &[
            "--mesh",
            cube.to_str().unwrap(),
            "--camera",
            camera.to_str().unwrap(),
            "--cloud",
            &cloud,
            "--direct",
            &lights,
            "-o",
            map.to_str().unwrap(),
        ],
        b"",
    );
    refused(&o, 2, "is also an input");
    assert_eq!(std::fs::read(&map).unwrap(), before);

    // A sublayer of the stage read.
    std::fs::write(
        d.path().join("sub.usda"),
        "#usda 1.0\n\ndef Mesh \"m\"\n{\n    point3f[] points = [(0,0,0), (1,0,0), (0,1,0)]\n    int[] faceVertexCounts = [3]\n    int[] faceVertexIndices = [0, 1, 2]\n}\n",
    )
    .unwrap();
    std::fs::write(
        d.path().join("top.usda"),
        "#usda 1.0\n(\n    subLayers = [@./sub.usda@]\n)\n",
    )
    .unwrap();
    let sub = std::fs::read(d.path().join("sub.usda")).unwrap();
    let o = run_in(
        Some(d.path()),
        "pcconvert",
        &["top.usda", "-o", "sub.usda"],
        b"",
    );
    refused(&o, 2, "is also an input");
    assert_eq!(std::fs::read(d.path().join("sub.usda")).unwrap(), sub);
    let o = run_in(
        Some(d.path()),
        "pcconvert",
        &["top.usda", "-o", "flat.ply"],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // A sublayer that is not there: named, not skipped.
    std::fs::write(
        d.path().join("gone.usda"),
        "#usda 1.0\n(\n    subLayers = [@./sub.usda@, @./missing.usda@]\n)\n",
    )
    .unwrap();
    let o = run_in(
        Some(d.path()),
        "pcconvert",
        &["gone.usda", "-o", "x.ply"],
        b"",
    );
    refused(&o, 1, "missing.usda");
}

#[test]
fn class_2_standard_output_is_an_output_and_a_link_leads_to_its_file() {
    let d = tempdir();
    let cloud = cloud_file(d.path(), "in.ply");
    let before = std::fs::read(&cloud).unwrap();
    // Stdout opened on the input, read-write (no truncation by the shell).
    let o = bash(d.path(), "pcconvert in.ply 1<>in.ply");
    refused(&o, 2, "<stdout>");
    assert_eq!(std::fs::read(&cloud).unwrap(), before);
    // Stdin and stdout the same file.
    let o = bash(d.path(), "pcconvert < in.ply 1<>in.ply");
    refused(&o, 2, "<stdout>");
    assert_eq!(std::fs::read(&cloud).unwrap(), before);
    // `-o /dev/stdout` is standard output, whatever it is: a file here.
    let o = bash(
        d.path(),
        "pcconvert in.ply --format ply -o /dev/stdout > out.ply",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.path().join("out.ply")).unwrap(), before);
    assert!(std::fs::symlink_metadata("/dev/stdout")
        .unwrap()
        .file_type()
        .is_symlink());
    // ... and appended to when the shell appends.
    let o = bash(
        d.path(),
        "pcconvert in.ply --format ply -o /dev/stdout >> out.ply",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.path().join("out.ply")).unwrap().len(),
        2 * before.len()
    );
    // A pipe through /dev/fd/1.
    let o = bash(
        d.path(),
        "pcconvert in.ply --format ply -o /dev/fd/1 | cat > piped.ply",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.path().join("piped.ply")).unwrap(), before);
    // A link to a file: the file is written, the link stays.
    std::fs::write(d.path().join("real.ply"), b"old").unwrap();
    symlink("real.ply", d.path().join("link.ply")).unwrap();
    let o = bash(d.path(), "pcconvert in.ply -o link.ply");
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(std::fs::symlink_metadata(d.path().join("link.ply"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read(d.path().join("real.ply")).unwrap(), before);
    // A link to nothing yet: the file it names is made.
    symlink("made.ply", d.path().join("ahead.ply")).unwrap();
    let o = bash(d.path(), "pcconvert in.ply -o ahead.ply");
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(d.path().join("made.ply")).unwrap(), before);
    // No temp file left anywhere.
    let left: Vec<String> = std::fs::read_dir(d.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("pcsss"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn class_3_dev_null_opened_on_purpose_is_an_output_a_closed_stdout_is_not() {
    let d = tempdir();
    let cloud = cloud_file(d.path(), "in.ply");
    for name in ["pcconvert", "pcinfo"] {
        // As Python's subprocess.DEVNULL opens it: read and write.
        let null = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open("/dev/null")
            .unwrap();
        let o = Command::new(bin(name))
            .arg(&cloud)
            .stdout(Stdio::from(null))
            .stderr(Stdio::piped())
            .output()
            .unwrap();
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
    // Closed: refused, as before.
    let o = bash(d.path(), "pcconvert in.ply >&-");
    refused(&o, 1, "closed");
}

#[test]
fn class_5_reads_have_a_ceiling_whatever_the_file_says_its_size_is() {
    let d = tempdir();
    let cloud = cloud_file(d.path(), "cloud.ply");
    // /dev/zero as a dome map, a material file and a texture.
    std::fs::write(
        d.path().join("zero.json"),
        r#"{"lights": [{"name": "sky", "type": "dome", "map": "/dev/zero"}]}"#,
    )
    .unwrap();
    let o = run_in(
        Some(d.path()),
        "illum",
        &["cloud.ply", "--lights", "zero.json", "--no-shadows"],
        b"",
    );
    refused(&o, 1, "not a dome map");
    let o = run_in(
        Some(d.path()),
        "ssmulti",
        &["cloud.ply", "--material", "/dev/zero", "-o", "x.ply"],
        b"",
    );
    refused(&o, 1, "larger than");
    let mesh = fixtures().join("mesh/cube.obj");
    let o = run_in(
        Some(d.path()),
        "texture",
        &[
            &cloud,
            "--mesh",
            mesh.to_str().unwrap(),
            "--image",
            "/dev/zero",
            "--as",
            "Cd",
            "-o",
            "x.ply",
        ],
        b"",
    );
    refused(&o, 1, "not a texture image");
    // A FIFO that goes on past a material file's ceiling.
    let fifo = d.path().join("fifo.json");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let feeder = {
        let fifo = fifo.clone();
        std::thread::spawn(move || {
            use std::io::Write;
            if let Ok(mut f) = std::fs::OpenOptions::new().write(true).open(&fifo) {
                let block = vec![b' '; 1 << 16];
                for _ in 0..64 {
                    if f.write_all(&block).is_err() {
                        break;
                    }
                }
            }
        })
    };
    let o = run_in(
        Some(d.path()),
        "ssmulti",
        &[
            "cloud.ply",
            "--material",
            fifo.to_str().unwrap(),
            "-o",
            "x.ply",
        ],
        b"",
    );
    refused(&o, 1, "larger than");
    feeder.join().unwrap();
    // The valid use: a material file.
    std::fs::write(
        d.path().join("m.json"),
        r#"{"mfp": [1, 1, 1], "albedo": [0.8, 0.8, 0.8]}"#,
    )
    .unwrap();
    let mut c = from_bytes(&std::fs::read(&cloud).unwrap());
    c.points_mut()
        .set_vec3("illum", Role::Color, &[[1.0f32; 3]; 3])
        .unwrap();
    c.points_mut()
        .set(pcsss::Attribute::scalar(
            "ptarea",
            pcsss::Column::F32(vec![0.5; 3]),
        ))
        .unwrap();
    std::fs::write(d.path().join("lit.ply"), to_bytes(&c, LE)).unwrap();
    let o = run_in(
        Some(d.path()),
        "ssmulti",
        &["lit.ply", "--material", "m.json", "-o", "x.ply"],
        b"",
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn class_6_many_threads_under_an_address_limit_run_on_fewer() {
    let d = tempdir();
    cloud_file(d.path(), "cloud.ply");
    let mesh = fixtures().join("mesh/cube.obj");
    std::fs::write(
        d.path().join("sun.json"),
        r#"{"lights": [{"name": "sun", "type": "distant", "direction": [0, 0, -1]}]}"#,
    )
    .unwrap();
    for n in ["1000", "1024", "500"] {
        let cmd = format!(
            "ulimit -v 2000000; RAYON_NUM_THREADS={n} illum cloud.ply --lights sun.json --mesh {} -o lit.ply",
            mesh.display()
        );
        let o = bash(d.path(), &cmd);
        assert!(o.status.success(), "{n}: {:?} {}", o.status, stderr(&o));
        let err = stderr(&o);
        assert!(
            err.contains("running on") && !err.contains("panicked"),
            "{n}: {err}"
        );
    }
    // Without a limit, what was asked for.
    let o = bash(
        d.path(),
        &format!(
            "RAYON_NUM_THREADS=64 illum cloud.ply --lights sun.json --mesh {} -o lit.ply",
            mesh.display()
        ),
    );
    assert!(
        o.status.success() && !stderr(&o).contains("running on"),
        "{}",
        stderr(&o)
    );
}

/// A sphere of radius `r` as a USD stage in units of `mpu` metres, lit by
/// a distant light and seen by a camera `4 r` away: the same scene
/// whatever `mpu` is, when `r` is in that unit.
fn sphere_stage(path: &Path, r: f64, mpu: f64) {
    let m = uv_sphere(24, 48, r, [0.0, 0.0, 0.0]);
    let p = m.points().vec3_f64("P").unwrap();
    let polys = pcsss::geom::mesh::Polygons::of(&m).unwrap();
    let counts: Vec<String> = (0..polys.len())
        .map(|f| polys.polygon(f).len().to_string())
        .collect();
    let idx: Vec<String> = (0..polys.len())
        .flat_map(|f| {
            polys
                .polygon(f)
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
        })
        .collect();
    let pts: Vec<String> = p
        .iter()
        .map(|q| format!("({}, {}, {})", q[0], q[1], q[2]))
        .collect();
    let text = format!(
        r#"#usda 1.0
(
    metersPerUnit = {mpu}
    upAxis = "Y"
)

def Mesh "Ball"
{{
    int[] faceVertexCounts = [{}]
    int[] faceVertexIndices = [{}]
    point3f[] points = [{}]
    uniform token subdivisionScheme = "none"
}}

def DistantLight "Sun"
{{
    float inputs:intensity = 2
    float3 xformOp:rotateXYZ = (-40, 30, 0)
    uniform token[] xformOpOrder = ["xformOp:rotateXYZ"]
}}

def Camera "Eye"
{{
    float focalLength = 50
    float horizontalAperture = 36
    float verticalAperture = 36
    double3 xformOp:translate = (0, 0, {})
    uniform token[] xformOpOrder = ["xformOp:translate"]
}}
"#,
        counts.join(", "),
        idx.join(", "),
        pts.join(", "),
        6.0 * r
    );
    std::fs::write(path, text).unwrap();
}

#[test]
fn class_7_a_preset_s_lengths_follow_the_scene_s_unit() {
    let d = tempdir();
    // The same ball, 2 cm across, in centimetres and in millimetres.
    sphere_stage(&d.path().join("cm.usda"), 1.0, 0.01);
    sphere_stage(&d.path().join("mm.usda"), 10.0, 0.001);
    let pipelines = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    for name in ["cm", "mm"] {
        let stage = d.path().join(format!("{name}.usda"));
        let s = stage.display();
        let cmd = format!(
            "make -s -C {} bake MESH={s} LIGHTS={s} CAMERA={s} MATERIAL=skin1 COUNT=4000 SINGLE=0 OUT={} BIN={}",
            pipelines.display(),
            d.path().join(name).display(),
            bin("pcinfo").parent().unwrap().display()
        );
        let o = bash(d.path(), &cmd);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
    }
    // The cloud's mean free path is the preset's millimetres in the
    // scene's unit: a tenth of it in centimetres.
    let cloud = |name: &str| {
        from_bytes(&std::fs::read(d.path().join(name).join(format!("{name}_ss.ply"))).unwrap())
    };
    let mfp = |c: &Cloud| c.detail("ssmulti_mfp").unwrap().components();
    let (cm, mm) = (mfp(&cloud("cm")), mfp(&cloud("mm")));
    for c in 0..3 {
        assert!((cm[c] * 10.0 / mm[c] - 1.0).abs() < 1e-9, "{cm:?} {mm:?}");
    }
    // The same picture: every pixel both see, to the noise of two bakes
    // of points placed alike.
    let pic = |name: &str| {
        from_bytes(&std::fs::read(d.path().join(name).join(format!("{name}.exr"))).unwrap())
    };
    let (a, b) = (pic("cm"), pic("mm"));
    let (ea, eb) = (
        a.points().vec3_f64("beauty").unwrap(),
        b.points().vec3_f64("beauty").unwrap(),
    );
    assert_eq!(ea.len(), eb.len());
    let (mut sum, mut diff) = (0.0, 0.0);
    for (x, y) in ea.iter().zip(&eb) {
        for c in 0..3 {
            sum += x[c].abs();
            diff += (x[c] - y[c]).abs();
        }
    }
    assert!(
        sum > 0.0 && diff / sum < 1e-3,
        "the pictures differ by {} of their light",
        diff / sum
    );
    // A preset in a scene that records no unit: said once.
    let mesh = fixtures().join("mesh/cube.obj");
    let c = d.path().join("c.ply");
    let o = bash(
        d.path(),
        &format!(
            "scatter {} -n 200 | facet --mesh {} | illum --lights {}/cm.usda --no-shadows -o {}",
            mesh.display(),
            mesh.display(),
            d.path().display(),
            c.display()
        ),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = bash(d.path(), "ssmulti c.ply --material skin1 -o m.ply");
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    assert_eq!(err.matches("records no unit").count(), 1, "{err}");
}

#[test]
fn class_7_outputs_whose_extension_no_writer_knows_are_refused() {
    let d = tempdir();
    let input = cloud_file(d.path(), "in.ply");
    for out in ["x.usdx", "x.bgeo", "x.vdb", "x.PLY.gz"] {
        let o = bash(d.path(), &format!("pcconvert {input} -o {out}"));
        refused(&o, 2, "the writers do not know");
        assert!(!d.path().join(out).exists(), "{out}");
        // Before any work: a stage that would read stdin says so first.
        let o = bash(d.path(), &format!("ssmulti --sd 0.5 -o {out} < /dev/null"));
        refused(&o, 2, out);
    }
    // The names the writers know, any case, no extension, and a name
    // given its format.
    for (out, args, magic) in [
        ("a.PLY", "", &b"ply\n"[..]),
        ("a.exr", "", &[0x76, 0x2f, 0x31, 0x01][..]),
        ("a.usda", "", &b"#usda"[..]),
        ("a.usdc", "", &b"PXR-USDC"[..]),
        ("a.usd", "", &b"PXR-USDC"[..]),
        ("a.usdz", "", &b"PK\x03\x04"[..]),
        ("noext", "", &b"ply\n"[..]),
        ("a.usdc", "--format exr", &[0x76, 0x2f, 0x31, 0x01][..]),
    ] {
        let o = bash(d.path(), &format!("pcconvert {input} {args} -o {out}"));
        assert!(o.status.success(), "{out}: {}", stderr(&o));
        let bytes = std::fs::read(d.path().join(out)).unwrap();
        assert!(bytes.starts_with(magic), "{out}");
    }
}

#[test]
fn class_7_a_cloud_from_another_mesh_with_as_many_faces_is_refused() {
    let d = tempdir();
    let cube = fixtures().join("mesh/cube.obj");
    // The cube moved and squashed: the same faces, other places.
    let moved: String = std::fs::read_to_string(&cube)
        .unwrap()
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let x: Vec<f64> = v.split_whitespace().map(|t| t.parse().unwrap()).collect();
                format!("v {} {} {}\n", x[0] * 3.0 + 5.0, x[1], x[2] * 0.5)
            }
            None => format!("{l}\n"),
        })
        .collect();
    std::fs::write(d.path().join("moved.obj"), moved).unwrap();
    let c = cube.display();
    let o = bash(
        d.path(),
        &format!("scatter {c} -n 500 --seed 1 --relax 4 -o pts.ply"),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    for mode in ["flat", "smooth"] {
        let o = bash(
            d.path(),
            &format!("facet pts.ply --mesh moved.obj --mode {mode} -o n.ply"),
        );
        refused(&o, 1, "is the mesh the one it was scattered on?");
        assert!(stderr(&o).contains("sourceprim"), "{}", stderr(&o));
        // On its own mesh, relaxed points and all, it works.
        let o = bash(
            d.path(),
            &format!("facet pts.ply --mesh {c} --mode {mode} -o n.ply"),
        );
        assert!(o.status.success(), "{mode}: {}", stderr(&o));
    }
    // (texture's side: tests/it/texture.rs.)
}

#[test]
fn class_8_a_dry_run_writes_nothing_and_unsafe_paths_are_refused_on_one_line() {
    let d = tempdir();
    let pipelines = Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines");
    let cube = fixtures().join("mesh/cube.obj");
    for k in 1..=2 {
        std::fs::copy(&cube, d.path().join(format!("f.000{k}.obj"))).unwrap();
    }
    std::fs::create_dir(d.path().join("out")).unwrap();
    let times = d.path().join("out/frames.txt");
    std::fs::write(&times, "the timings of a real run\n").unwrap();
    let make = |args: &str| {
        bash(
            d.path(),
            &format!(
                "make -C {} {args} BIN={}",
                pipelines.display(),
                bin("pcinfo").parent().unwrap().display()
            ),
        )
    };
    let o = make(&format!(
        "-n frames FRAMES={dir}/f.####.obj OUT={dir}/out COUNT=300",
        dir = d.path().display()
    ));
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read_to_string(&times).unwrap(),
        "the timings of a real run\n"
    );
    assert!(!d.path().join("out/rest_cloud.ply").exists());
    // A path make or the shell would split or read: one line, exit 2,
    // nothing made.
    for (var, value) in [
        ("MESH", "my mesh.obj"),
        ("OUT", "out dir"),
        ("OUT", "it's"),
        ("MESH", "a;b.obj"),
        ("LIGHTS", "l(1).json"),
    ] {
        let o = make(&format!("-s bake {var}=\"{value}\""));
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{err}");
        let lines: Vec<&str> = err.lines().filter(|l| l.contains("***")).collect();
        assert_eq!(lines.len(), 1, "{err}");
        assert!(lines[0].contains(&format!("{var}={value}")), "{err}");
        assert!(!d.path().join(value).exists());
    }
}
