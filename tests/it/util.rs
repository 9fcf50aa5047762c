//! The harness: run a binary on stdin bytes, temp dirs, test clouds.

#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use pcsss::formats::{self, Encoding, Format, Select};
use pcsss::stages::scatter::{self, Amount, Params, PtareaMode};
use pcsss::{
    AttrData, Attribute, Cloud, Column, DetailValue, Element, ListColumn, Role, ScalarType,
};

/// Path of a binary of this package.
pub fn bin(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_BIN_EXE_pcinfo"));
    dir.parent().unwrap().join(name)
}

/// Runs `name args` with `stdin` bytes; returns the output.
pub fn run(name: &str, args: &[&str], stdin: &[u8]) -> Output {
    run_in(None, name, args, stdin)
}

/// Like [`run`], in directory `dir`.
pub fn run_in(dir: Option<&Path>, name: &str, args: &[&str], stdin: &[u8]) -> Output {
    let mut cmd = Command::new(bin(name));
    cmd.args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    if let Some(d) = dir {
        cmd.current_dir(d);
    }
    let mut child = cmd.spawn().expect("spawn binary");
    let mut sin = child.stdin.take().unwrap();
    let data = stdin.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = sin.write_all(&data);
    });
    let out = child.wait_with_output().expect("wait");
    writer.join().unwrap();
    out
}

/// Runs `name args` in `dir` with the environment variables `env` added
/// and standard input from the file `stdin` of `dir` (none: empty); asserts that
/// it succeeded, showing its stderr if not, and returns its stdout.
pub fn run_env(
    dir: &Path,
    name: &str,
    args: &[&str],
    env: &[(&str, &str)],
    stdin: Option<&str>,
) -> Vec<u8> {
    let mut cmd = Command::new(bin(name));
    cmd.args(args).current_dir(dir).envs(env.iter().copied());
    cmd.stdin(match stdin {
        Some(f) => Stdio::from(std::fs::File::open(dir.join(f)).expect("stdin file")),
        None => Stdio::null(),
    });
    let out = cmd.output().expect("run binary");
    assert!(
        out.status.success(),
        "{name} {args:?} {env:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// Runs `cmd` with bash in `dir` (pipefail set) and asserts it
/// succeeded, showing its stderr when it did not.
pub fn shell(dir: &Path, cmd: &str) -> Output {
    let out = Command::new("bash")
        .args(["-c", &format!("set -o pipefail; {cmd}")])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

/// Stderr as text.
pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A fresh temp directory.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

/// The repository's fixtures folder.
pub fn fixtures() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("fixtures")
}

/// The Stanford bunny fixture (3,674 triangles), read whole.
pub fn bunny() -> Cloud {
    formats::read_cloud_file(&fixtures().join("mesh/bunny.obj"), &formats::Select::All)
        .expect("the bunny fixture")
}

/// Writes a cloud to bytes.
pub fn to_bytes(c: &Cloud, f: Format) -> Vec<u8> {
    let mut v = Vec::new();
    formats::write_cloud(&mut v, c, f).expect("write");
    v
}

/// Reads a cloud from bytes.
pub fn from_bytes(b: &[u8]) -> Cloud {
    formats::read_cloud(b, &Select::All).expect("read")
}

pub const LE: Format = Format::Ply(Encoding::BinaryLe);
pub const BE: Format = Format::Ply(Encoding::BinaryBe);
pub const ASCII: Format = Format::Ply(Encoding::Ascii);

/// Extreme and ordinary values of each type, `n` = 6 rows.
pub fn extremes(t: ScalarType) -> Column {
    match t {
        ScalarType::I8 => Column::I8(vec![i8::MIN, -1, 0, 1, 42, i8::MAX]),
        ScalarType::U8 => Column::U8(vec![0, 1, 127, 128, 200, u8::MAX]),
        ScalarType::I16 => Column::I16(vec![i16::MIN, -1, 0, 1, 1234, i16::MAX]),
        ScalarType::U16 => Column::U16(vec![0, 1, 32767, 32768, 40000, u16::MAX]),
        ScalarType::I32 => Column::I32(vec![i32::MIN, -1, 0, 1, 123456789, i32::MAX]),
        ScalarType::U32 => Column::U32(vec![0, 1, 1 << 31, 3_000_000_000, 7, u32::MAX]),
        ScalarType::F32 => Column::F32(vec![
            -0.0,
            f32::MIN_POSITIVE / 8.0,
            0.1,
            f32::NAN,
            f32::NEG_INFINITY,
            f32::MAX,
        ]),
        ScalarType::F64 => Column::F64(vec![
            -0.0,
            f64::MIN_POSITIVE / 1024.0,
            0.1,
            f64::NAN,
            f64::INFINITY,
            1e300,
        ]),
    }
}

/// A cloud with every property type: scalars of all eight types, 3-vectors
/// with every role, list properties of every count and item type, an
/// element the toolkit knows nothing of, detail attributes of every type.
pub fn every_type_cloud() -> Cloud {
    let n = 6;
    let mut pts = Element::new("vertex", n);
    let p: Vec<[f64; 3]> = (0..n)
        .map(|i| [1e6 + i as f64 * 0.1, -1e6, 1e-3 * i as f64])
        .collect();
    pts.set_vec3("P", Role::Point, &p).unwrap();
    let nn: Vec<[f32; 3]> = (0..n)
        .map(|i| [0.0, (i as f32).sin(), (i as f32).cos()])
        .collect();
    pts.set_vec3("N", Role::Normal, &nn).unwrap();
    for t in ScalarType::ALL {
        pts.set(Attribute::scalar(
            &format!("s_{}", t.ply_name()),
            extremes(t),
        ))
        .unwrap();
    }
    pts.set(Attribute::vec3(
        "Cd",
        Role::Color,
        [
            extremes(ScalarType::U8),
            extremes(ScalarType::U8),
            extremes(ScalarType::U8),
        ],
    ))
    .unwrap();
    pts.set(Attribute::vec3(
        "rest",
        Role::Point,
        [
            extremes(ScalarType::F32),
            extremes(ScalarType::F32),
            extremes(ScalarType::F32),
        ],
    ))
    .unwrap();
    pts.set(Attribute::vec3(
        "vel",
        Role::Vector,
        [
            extremes(ScalarType::I16),
            extremes(ScalarType::I16),
            extremes(ScalarType::I16),
        ],
    ))
    .unwrap();
    pts.set(Attribute::vec3(
        "Nalt",
        Role::Normal,
        [
            extremes(ScalarType::F64),
            extremes(ScalarType::F64),
            extremes(ScalarType::F64),
        ],
    ))
    .unwrap();

    let mut lists = Element::new("lists", 3);
    for ct in ScalarType::ALL.into_iter().filter(|t| !t.is_float()) {
        for it in ScalarType::ALL {
            let vals = extremes(it);
            let mut l = ListColumn::new(ct, it);
            // Rows of 0, 2 and 4 items.
            let idx: Vec<usize> = vec![0, 1, 2, 3, 4, 5];
            l.items = vals.gather(&idx);
            l.offsets = vec![0, 0, 2, 6];
            lists
                .set(Attribute {
                    name: format!("l_{}_{}", ct.ply_name(), it.ply_name()),
                    data: AttrData::List(l),
                })
                .unwrap();
        }
    }
    let mut faces = Element::new("face", 2);
    let mut l = ListColumn::new(ScalarType::U8, ScalarType::I32);
    l.items = Column::I32(vec![0, 1, 2, 2, 3, 4, 5]);
    l.offsets = vec![0, 3, 7];
    faces
        .set(Attribute {
            name: "vertex_indices".into(),
            data: AttrData::List(l),
        })
        .unwrap();
    faces.set_scalar("area", vec![0.5f32, 1.5]).unwrap();

    let mut cloud = Cloud {
        elements: vec![pts, faces, lists, Element::new("empty_rows", 4)],
        ..Default::default()
    };
    cloud.comments.push("a comment with   inner  spaces".into());
    cloud.obj_info.push("made by tests".into());
    cloud.set_detail("Tarea", DetailValue::F64(std::f64::consts::PI * 4.0));
    cloud.set_detail("Tptarea", DetailValue::F32(0.1));
    cloud.set_detail("count", DetailValue::I32(-7));
    cloud.set_detail(
        "light_dir",
        DetailValue::V3F([0.0, -1.0, f32::MIN_POSITIVE]),
    );
    cloud.set_detail("origin", DetailValue::V3D([1e6, -1e6, 1e-300]));
    cloud.set_detail(
        "note",
        DetailValue::Str("quotes \" and\nnewline, ünïcödé".into()),
    );
    cloud
}

/// A UV sphere of radius `r` centred at `c`: `rings` latitude bands of
/// `segs` quads, triangles at the poles. Its exact area tends to 4 pi r^2.
pub fn uv_sphere(rings: usize, segs: usize, r: f64, c: [f64; 3]) -> Cloud {
    use std::f64::consts::PI;
    let mut p: Vec<[f64; 3]> = vec![[c[0], c[1], c[2] + r]];
    for i in 1..rings {
        let th = PI * i as f64 / rings as f64;
        for j in 0..segs {
            let ph = 2.0 * PI * j as f64 / segs as f64;
            p.push([
                c[0] + r * th.sin() * ph.cos(),
                c[1] + r * th.sin() * ph.sin(),
                c[2] + r * th.cos(),
            ]);
        }
    }
    p.push([c[0], c[1], c[2] - r]);
    let south = (p.len() - 1) as i32;
    let ring = |i: usize, j: usize| (1 + (i - 1) * segs + j % segs) as i32;
    let mut faces: Vec<Vec<i32>> = Vec::new();
    for j in 0..segs {
        faces.push(vec![0, ring(1, j), ring(1, j + 1)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segs {
            faces.push(vec![
                ring(i, j),
                ring(i + 1, j),
                ring(i + 1, j + 1),
                ring(i, j + 1),
            ]);
        }
    }
    for j in 0..segs {
        faces.push(vec![ring(rings - 1, j), south, ring(rings - 1, j + 1)]);
    }
    mesh_from(&p, &faces)
}

/// The square [-1, 1]^2 at z = 0, one quad.
pub fn unit_square() -> Cloud {
    mesh_from(
        &[
            [-1.0, -1.0, 0.0],
            [1.0, -1.0, 0.0],
            [1.0, 1.0, 0.0],
            [-1.0, 1.0, 0.0],
        ],
        &[vec![0, 1, 2, 3]],
    )
}

/// A mesh cloud from positions (f64) and polygons.
pub fn mesh_from(p: &[[f64; 3]], faces: &[Vec<i32>]) -> Cloud {
    let mut c = Cloud::with_points(p.len());
    c.points_mut().set_vec3("P", Role::Point, p).unwrap();
    let mut l = ListColumn::new(ScalarType::U8, ScalarType::I32);
    let mut items = Vec::new();
    for f in faces {
        items.extend_from_slice(f);
        l.offsets.push(items.len());
    }
    l.items = Column::I32(items);
    let mut e = Element::new("face", faces.len());
    e.set(Attribute {
        name: "vertex_indices".into(),
        data: AttrData::List(l),
    })
    .unwrap();
    c.elements.push(e);
    c
}

/// Values equal bit for bit (NaN included), structure equal.
pub fn assert_same_values(a: &Cloud, b: &Cloud) {
    assert_eq!(a.elements.len(), b.elements.len());
    for (ea, eb) in a.elements.iter().zip(&b.elements) {
        assert_eq!(ea.name, eb.name);
        assert_eq!(ea.len(), eb.len(), "element {}", ea.name);
        assert_eq!(ea.attrs().len(), eb.attrs().len(), "element {}", ea.name);
        for (x, y) in ea.attrs().iter().zip(eb.attrs()) {
            assert_eq!(x.name, y.name);
            assert_eq!(x.type_name(), y.type_name(), "{}", x.name);
            let cols = |a: &pcsss::Attribute| -> Vec<pcsss::Column> {
                match &a.data {
                    AttrData::List(l) => vec![
                        l.items.clone(),
                        pcsss::Column::U32(l.offsets.iter().map(|&o| o as u32).collect()),
                    ],
                    _ => a.components().iter().map(|v| v.column().clone()).collect(),
                }
            };
            for (cx, cy) in cols(x).iter().zip(cols(y)) {
                assert_eq!(cx.len(), cy.len());
                for i in 0..cx.len() {
                    let (p, q) = (cx.get_f64(i), cy.get_f64(i));
                    assert!(
                        p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan()),
                        "{}.{} row {i}: {p} vs {q}",
                        ea.name,
                        x.name
                    );
                }
            }
        }
    }
    assert_eq!(a.detail, b.detail);
    assert_eq!(a.comments, b.comments);
    assert_eq!(a.obj_info, b.obj_info);
}

/// An interop test's tool is missing: a failure that says how to get
/// it. Interop tests are `#[ignore]`d under plain `cargo test` (reported
/// as ignored, not passed); `make test` installs their tools and runs
/// them (`--include-ignored`).
pub fn interop_missing(what: &str) -> ! {
    panic!("{what}: run the tests with `make test`, which installs it");
}

/// The Python interpreter (PCSSS_PYTHON, else python3), which must import
/// every one of `modules` ([`interop_missing`] otherwise).
pub fn python_with(modules: &[&str]) -> String {
    let py = std::env::var("PCSSS_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&py)
        .args(["-c", &format!("import {}", modules.join(", "))])
        .output()
        .is_ok_and(|o| o.status.success());
    if !ok {
        interop_missing(&format!("{py} lacks {}", modules.join("/")));
    }
    py
}

// The geometry tests' meshes and clouds.

/// A box `[lo, hi]` as OBJ text: six quads, outward normals
/// (counter-clockwise seen from outside).
pub fn box_obj(lo: [f64; 3], hi: [f64; 3]) -> String {
    let mut text = String::new();
    for k in 0..8 {
        let p = [0, 1, 2].map(|a| if (k >> a) & 1 == 1 { hi[a] } else { lo[a] });
        text += &format!("v {} {} {}\n", p[0], p[1], p[2]);
    }
    // (Corners numbered by their bits x, y, z.)
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [2, 4, 8, 6],
        [4, 3, 7, 8],
        [3, 1, 5, 7],
    ] {
        text += &format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]);
    }
    text
}

pub fn cube() -> Cloud {
    let b = std::fs::read(fixtures().join("mesh/cube.obj")).unwrap();
    from_bytes(&b)
}

pub fn scatter_n(mesh: &Cloud, n: usize, seed: u64, mode: PtareaMode) -> Cloud {
    scatter_relaxed(mesh, n, seed, mode, 0)
}

pub fn scatter_relaxed(mesh: &Cloud, n: usize, seed: u64, mode: PtareaMode, relax: u32) -> Cloud {
    scatter::scatter(
        mesh,
        &Params {
            amount: Amount::Count(n),
            seed,
            ptarea: mode,
            relax,
            ..pcsss::stages::scatter::Params::new(pcsss::stages::scatter::Amount::Count(0))
        },
    )
    .unwrap()
}

pub fn icosphere(level: u32) -> Cloud {
    let b = std::fs::read(fixtures().join(format!("mesh/icosphere{level}.obj"))).unwrap();
    from_bytes(&b)
}

/// A cloud's positions.
pub fn positions(c: &Cloud) -> Vec<glam::DVec3> {
    c.points()
        .vec3_f64("P")
        .unwrap()
        .into_iter()
        .map(glam::DVec3::from_array)
        .collect()
}

/// Every triangle index of `mesh`.
pub fn all_triangles(mesh: &pcsss::geom::mesh::TriMesh) -> Vec<usize> {
    (0..mesh.tris.len()).collect()
}

/// `n` points spread over the triangles `tris` of `mesh` by area (seeded
/// by `seed`), each with its triangle's outward normal.
pub fn points_on_triangles(
    mesh: &pcsss::geom::mesh::TriMesh,
    tris: &[usize],
    n: usize,
    seed: u64,
) -> Cloud {
    use pcsss::maths::uniform53;
    let areas: Vec<f64> = tris
        .iter()
        .map(|&t| {
            let [a, b, c] = mesh.tri(t);
            0.5 * (b - a).cross(c - a).length()
        })
        .collect();
    let total: f64 = areas.iter().sum();
    let mut r = rand_pcg::Pcg32::new(seed, 1);
    let (mut p, mut nrm) = (Vec::new(), Vec::new());
    for _ in 0..n {
        let mut u = uniform53(&mut r) * total;
        let k = areas
            .iter()
            .position(|&a| {
                u -= a;
                u < 0.0
            })
            .unwrap_or(areas.len() - 1);
        let [a, b, c] = mesh.tri(tris[k]);
        let (mut s, mut v) = (uniform53(&mut r), uniform53(&mut r));
        if s + v > 1.0 {
            (s, v) = (1.0 - s, 1.0 - v);
        }
        p.push((a + (b - a) * s + (c - a) * v).to_array());
        nrm.push((b - a).cross(c - a).normalize().as_vec3().to_array());
    }
    let mut c = Cloud::with_points(n);
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    c.points_mut().set_vec3("N", Role::Normal, &nrm).unwrap();
    c
}

/// How many entries of folder `dir` have a name `keep` takes.
pub fn count_names(dir: &Path, keep: impl Fn(&str) -> bool) -> usize {
    std::fs::read_dir(dir)
        .unwrap()
        .filter(|e| keep(&e.as_ref().unwrap().file_name().to_string_lossy()))
        .count()
}
