//! Shared by the benchmark programs: timing, the machine's description,
//! the Python interpreter, the result table.

#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Best wall time in seconds of `reps` runs of `f`.
pub fn best<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    (0..reps)
        .map(|_| {
            let t = Instant::now();
            std::hint::black_box(f());
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

/// Best wall time of a shell command (whole process), or None if it failed.
pub fn best_cmd(reps: usize, cmd: &str) -> Option<f64> {
    let mut best = f64::INFINITY;
    for _ in 0..reps {
        let t = Instant::now();
        let out = std::process::Command::new("bash")
            .args(["-o", "pipefail", "-c", cmd])
            .output()
            .ok()?;
        let dt = t.elapsed().as_secs_f64();
        if !out.status.success() {
            eprintln!("failed: {cmd}: {}", String::from_utf8_lossy(&out.stderr));
            return None;
        }
        best = best.min(dt);
    }
    Some(best)
}

/// CPU model and core count.
pub fn machine() -> String {
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    format!("{cpu}, {cores} cores")
}

/// The Python with the benchmark's packages: $PCSSS_PYTHON, else the
/// project's venv (made by `make bench`), else python3.
pub fn python() -> String {
    if let Ok(p) = std::env::var("PCSSS_PYTHON") {
        return p;
    }
    let venv = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/pyenv/bin/python");
    if venv.exists() {
        return venv.display().to_string();
    }
    "python3".into()
}

/// Where benchmark inputs and results go.
pub fn bench_dir() -> PathBuf {
    let d = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A results table, printed and saved.
pub struct Table {
    pub title: String,
    pub rows: Vec<String>,
}

impl Table {
    pub fn new(title: &str, header: &str) -> Self {
        println!("{title}\n{header}");
        Table {
            title: title.into(),
            rows: vec![header.into()],
        }
    }

    pub fn row(&mut self, r: String) {
        println!("{r}");
        self.rows.push(r);
    }

    pub fn save(&self, name: &str) {
        let p = bench_dir().join(name);
        let text = format!("{}\n{}\n", self.title, self.rows.join("\n"));
        std::fs::write(&p, text).unwrap();
        println!("saved {}", p.display());
    }
}

/// A UV sphere mesh: `rings` x `segs` quads as two triangles each, the
/// vertex at polar angle `th` and azimuth `ph` at radius `radius(th, ph)`;
/// positions in f64 or f32.
pub fn uv_sphere(
    rings: usize,
    segs: usize,
    f64_positions: bool,
    radius: impl Fn(f64, f64) -> f64,
) -> pcsss::Cloud {
    use pcsss::{AttrData, Attribute, Cloud, Column, Element, ListColumn, Role, ScalarType};
    use std::f64::consts::PI;
    let mut p: Vec<[f64; 3]> = Vec::new();
    for i in 0..=rings {
        let th = PI * i as f64 / rings as f64;
        for j in 0..segs {
            let ph = 2.0 * PI * j as f64 / segs as f64;
            let r = radius(th, ph);
            p.push([
                r * th.sin() * ph.cos(),
                r * th.sin() * ph.sin(),
                r * th.cos(),
            ]);
        }
    }
    let id = |i: usize, j: usize| (i * segs + j % segs) as i32;
    let mut items = Vec::new();
    for i in 0..rings {
        for j in 0..segs {
            items.extend([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            items.extend([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let nf = items.len() / 3;
    let mut c = Cloud::with_points(p.len());
    if f64_positions {
        c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    } else {
        let p32: Vec<[f32; 3]> = p.iter().map(|v| v.map(|x| x as f32)).collect();
        c.points_mut().set_vec3("P", Role::Point, &p32).unwrap();
    }
    let mut l = ListColumn::new(ScalarType::U8, ScalarType::I32);
    l.offsets = (0..=nf).map(|f| 3 * f).collect();
    l.items = Column::I32(items);
    let mut e = Element::new("face", nf);
    e.set(Attribute {
        name: "vertex_indices".into(),
        data: AttrData::List(l),
    })
    .unwrap();
    c.elements.push(e);
    c
}

/// Writes a little-endian f64 array as .npy.
pub fn npy(path: &Path, shape: &[usize], data: &[f64]) {
    let shape = match shape {
        [n] => format!("({n},)"),
        [n, m] => format!("({n}, {m})"),
        _ => unreachable!(),
    };
    let mut header = format!("{{'descr': '<f8', 'fortran_order': False, 'shape': {shape}, }}");
    while (10 + header.len() + 1) % 64 != 0 {
        header.push(' ');
    }
    header.push('\n');
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    f.write_all(b"\x93NUMPY\x01\x00").unwrap();
    f.write_all(&(header.len() as u16).to_le_bytes()).unwrap();
    f.write_all(header.as_bytes()).unwrap();
    for x in data {
        f.write_all(&x.to_le_bytes()).unwrap();
    }
}

/// Reads a little-endian f64 .npy array (any shape), flattened.
pub fn read_npy(path: &Path) -> Vec<f64> {
    let b = std::fs::read(path).unwrap();
    let hlen = u16::from_le_bytes([b[8], b[9]]) as usize;
    let header = String::from_utf8_lossy(&b[10..10 + hlen]);
    assert!(header.contains("'<f8'"), "{header}");
    b[10 + hlen..]
        .chunks_exact(8)
        .map(|c| f64::from_le_bytes(c.try_into().unwrap()))
        .collect()
}

/// Embree (Python embreex) on `rays` against `tris`, both in a BVH's unit
/// frame, with `query` "occluded" (shadow rays) or "intersect" (nearest
/// hits): the JSON line of benches/py/embree_rays.py, or None (with the
/// reason on stderr) when embreex is not installed.
pub fn embree(
    dir: &Path,
    tris: &[obvhs::triangle::Triangle],
    rays: &[obvhs::ray::Ray],
    query: &str,
) -> Option<serde_json::Value> {
    let tris_bin = dir.join(format!("embree_{query}_tris.f32"));
    let rays_bin = dir.join(format!("embree_{query}_rays.f32"));
    let mut w = std::io::BufWriter::new(std::fs::File::create(&tris_bin).ok()?);
    for t in tris {
        for v in [t.v0, t.v1, t.v2] {
            for x in v.to_array() {
                w.write_all(&x.to_le_bytes()).ok()?;
            }
        }
    }
    w.flush().ok()?;
    let mut w = std::io::BufWriter::new(std::fs::File::create(&rays_bin).ok()?);
    for r in rays {
        for x in r
            .origin
            .to_array()
            .into_iter()
            .chain(r.direction.to_array())
            .chain([r.tmax])
        {
            w.write_all(&x.to_le_bytes()).ok()?;
        }
    }
    w.flush().ok()?;
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/py/embree_rays.py");
    std::process::Command::new(python())
        .args([script, tris_bin.to_str()?, rays_bin.to_str()?, query])
        .output()
        .ok()
        .filter(|o| {
            if !o.status.success() {
                eprintln!("embree: {}", String::from_utf8_lossy(&o.stderr));
            }
            o.status.success()
        })
        .and_then(|o| serde_json::from_slice(&o.stdout).ok())
}

/// `n` points on `mesh` (scatter, seed 1, per-face areas) with smooth
/// normals (facet, cusp 60).
pub fn points_on(mesh: &pcsss::Cloud, n: usize) -> pcsss::Cloud {
    let m = pcsss::geom::mesh::TriMesh::from_cloud(mesh).unwrap();
    let mut cloud = pcsss::stages::scatter::scatter(
        mesh,
        &pcsss::stages::scatter::Params {
            amount: pcsss::stages::scatter::Amount::Count(n),
            seed: 1,
            ptarea: pcsss::stages::scatter::PtareaMode::Prim,
            relax: 0,
            ..pcsss::stages::scatter::Params::new(pcsss::stages::scatter::Amount::Count(0))
        },
    )
    .unwrap();
    pcsss::stages::facet::facet_points(
        &mut cloud,
        &m,
        &pcsss::stages::facet::Params {
            mode: pcsss::stages::facet::Mode::Smooth,
            weight: pcsss::stages::facet::Weight::Angle,
            cusp: 60.0,
            weld: true,
        },
    )
    .unwrap();
    cloud
}

/// Embree's rates on `n` rays (robust mode off and on, from
/// embree_rays.py's answer `e`) and ours over them, with our best
/// seconds `t1` and `t2` on 1 and 2 threads; `what` names Embree's query.
pub fn embree_rows(tab: &mut Table, e: &serde_json::Value, n: f64, t1: f64, t2: f64, what: &str) {
    let f = |k: &str| e[k].as_f64().unwrap_or(f64::NAN);
    let build = format!("{:.3}", f("build"));
    for (mode, label, build, ratio) in [
        (
            "",
            format!("Embree 4 {what}(embreex, robust off; 2 = two processes)"),
            build.as_str(),
            "Embree",
        ),
        (
            "_robust",
            "Embree 4 robust mode (watertight, as pcsss)".to_string(),
            "",
            "Embree robust",
        ),
    ] {
        let (s1, s2) = (
            f(&format!("seconds_1{mode}")),
            f(&format!("seconds_2{mode}")),
        );
        tab.row(format!(
            "| {label}, M rays/s | {build} | {:.2} | {:.2} |",
            n / s1 / 1e6,
            n / s2 / 1e6
        ));
        tab.row(format!(
            "| pcsss / {ratio} | | {:.2} | {:.2} |",
            s1 / t1,
            s2 / t2
        ));
    }
}
