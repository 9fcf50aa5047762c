//! Tiled bakes (`pctile`): what a halo costs, and a cloud larger than
//! memory baked through ssmulti in tiles.
//!
//! - Halo overhead: the halo points a split adds, over the points, for
//!   tile counts and reaches (in mean spacings), on the dragon at 1M
//!   points (the bunny when the dragon is not fetched). Plans only, no
//!   files: `pcsss::tiles::Plan` on the points, counted as the split
//!   counts them.
//! - Out of core: a cloud of `BENCH_TILES_POINTS` points (default 4M;
//!   100000000 for the figure in docs/SCALE.md) generated straight to a
//!   PLY file, never held (random points on the bunny with P, N, ptarea,
//!   illum: 40 bytes a point), split with `--tile-memory
//!   BENCH_TILES_MEMORY` (default 1G) for ssmulti, each tile baked by its
//!   own ssmulti process one after the other, merged; every process's
//!   time and peak resident memory (`/usr/bin/time`). Beside it the
//!   untiled ssmulti of `BENCH_TILES_REFERENCE` points (default the same
//!   count, capped at 16M). sd is chosen for about 200 neighbours a point
//!   at every size, as the 16M figure of the issue had.
//!
//! `cargo bench --bench tiles`. Results: target/bench/tiles.txt.

mod common;

// The allocator the stages' binaries use, so in-process timings match.
pcsss::global_allocator!();

use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

use common::*;
use glam::DVec3;
use pcsss::formats::ply::write::{header_text_with, write_body};
use pcsss::formats::{self, Encoding, Select};
use pcsss::geom::mesh::TriMesh;
use pcsss::tiles::split::tile_counts;
use pcsss::tiles::Plan;
use pcsss::{Cloud, Element, Role};
use rand_core::RngCore;
use rand_pcg::Pcg32;

fn bin(name: &str) -> String {
    Path::new(env!("CARGO_BIN_EXE_pcinfo"))
        .with_file_name(name)
        .display()
        .to_string()
}

fn env_u64(name: &str, default: u64) -> u64 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// A mesh's triangles and their cumulative areas.
struct Surface {
    mesh: TriMesh,
    cdf: Vec<f64>,
    area: f64,
}

impl Surface {
    fn new(path: &str) -> Surface {
        let cloud = formats::read_cloud_file(Path::new(path), &Select::All).expect("mesh reads");
        let mesh = TriMesh::from_cloud(&cloud).expect("a mesh");
        let mut acc = 0.0;
        let cdf: Vec<f64> = mesh
            .tri_areas()
            .iter()
            .map(|a| {
                acc += a;
                acc
            })
            .collect();
        Surface {
            mesh,
            area: acc,
            cdf,
        }
    }

    /// A uniform point on the surface and its face's normal.
    fn point(&self, r: &mut Pcg32) -> (DVec3, DVec3) {
        let u = |r: &mut Pcg32| (r.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        let x = u(r) * self.area;
        let t = self.cdf.partition_point(|&c| c < x).min(self.cdf.len() - 1);
        let [a, b, c] = self.mesh.tri(t);
        let (s, q) = (u(r).sqrt(), u(r));
        let p = a * (1.0 - s) + b * (s * (1.0 - q)) + c * (s * q);
        let n = (b - a).cross(c - a).normalize_or_zero();
        (p, n)
    }
}

/// Writes `n` random points of `surf` to `path` a chunk at a time: P, N,
/// ptarea (area / n), illum (a key light from above, some ambient).
fn generate(surf: &Surface, n: u64, path: &Path) {
    let chunk = 1u64 << 20;
    let mut w = BufWriter::with_capacity(1 << 20, std::fs::File::create(path).unwrap());
    let rows = |k: u64, m: usize| -> Element {
        let mut r = Pcg32::new(0x5eed, k);
        let mut p = Vec::with_capacity(m);
        let mut nn = Vec::with_capacity(m);
        let mut e = Vec::with_capacity(m);
        let light = DVec3::new(0.3, 1.0, 0.4).normalize();
        for _ in 0..m {
            let (q, nrm) = surf.point(&mut r);
            p.push(q.as_vec3().to_array());
            nn.push(nrm.as_vec3().to_array());
            let l = nrm.dot(light).max(0.0) as f32 + 0.05;
            e.push([l, 0.8 * l, 0.6 * l]);
        }
        let mut el = Element::new("vertex", m);
        el.set_vec3("P", Role::Point, &p).unwrap();
        el.set_vec3("N", Role::Normal, &nn).unwrap();
        el.set_scalar("ptarea", vec![(surf.area / n as f64) as f32; m])
            .unwrap();
        el.set_vec3("illum", Role::Color, &e).unwrap();
        el
    };
    let mut head = Cloud::with_points(0);
    head.set_points(rows(0, 0));
    w.write_all(
        header_text_with(&head, Encoding::BinaryLe, |_, _| n)
            .unwrap()
            .as_bytes(),
    )
    .unwrap();
    let mut done = 0;
    while done < n {
        let m = chunk.min(n - done);
        write_body(&mut w, &rows(done / chunk, m as usize), Encoding::BinaryLe).unwrap();
        done += m;
    }
    w.flush().unwrap();
}

/// Runs a command under /usr/bin/time: (seconds, peak resident MiB).
fn timed(cmd: &[&str]) -> (f64, f64) {
    let t = Instant::now();
    let out = std::process::Command::new("/usr/bin/time")
        .args(["-f", "%M"])
        .args(cmd)
        .output()
        .expect("/usr/bin/time runs");
    let secs = t.elapsed().as_secs_f64();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{cmd:?}: {err}");
    let kb: f64 = err
        .lines()
        .last()
        .and_then(|l| l.trim().parse().ok())
        .expect("peak memory");
    (secs, kb / 1024.0)
}

fn halo_overhead(root: &str, t: &mut Table) {
    let dragon = format!("{root}/out/models/dragon_vrip.ply");
    let (name, mesh) = if Path::new(&dragon).exists() {
        ("dragon", dragon)
    } else {
        eprintln!("no dragon (`make -C pipelines fetch-dragon`): the bunny instead");
        ("bunny", format!("{root}/fixtures/mesh/bunny.obj"))
    };
    let surf = Surface::new(&mesh);
    let n = 1_000_000usize;
    let mut r = Pcg32::new(7, 0);
    let pts: Vec<DVec3> = (0..n).map(|_| surf.point(&mut r).0).collect();
    let spacing = (surf.area / n as f64).sqrt();
    let (lo, hi) = pts.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(a, b), p| (a.min(*p), b.max(*p)),
    );
    for tiles in [4usize, 16, 64, 256, 1024] {
        let mut s = pts.clone();
        let plan = Plan::new(&mut s, lo, hi, tiles);
        let mut row = format!("| {name} | {tiles} | {} |", n / tiles);
        for reach in [2.0, 5.0, 10.0, 20.0, 40.0] {
            let c = tile_counts(&plan, &pts, reach * spacing);
            let halo: u64 = c.iter().map(|x| x[1]).sum();
            row += &format!(" {:.1}% |", 100.0 * halo as f64 / n as f64);
        }
        t.row(row);
    }
}

fn main() {
    let root = env!("CARGO_MANIFEST_DIR");
    let mut t = Table::new(
        &format!(
            "Halo points a split adds, over the points (1M random points; reach in mean spacings sqrt(area / N): about pi r^2 neighbours within it); {}",
            machine()
        ),
        "| mesh | tiles | points a tile | reach 2 | 5 | 10 | 20 | 40 |\n|---|---|---|---|---|---|---|---|",
    );
    halo_overhead(root, &mut t);

    let n = env_u64("BENCH_TILES_POINTS", 4_000_000);
    let reference = env_u64("BENCH_TILES_REFERENCE", n.min(16_000_000));
    let memory = std::env::var("BENCH_TILES_MEMORY").unwrap_or_else(|_| "1G".into());
    let surf = Surface::new(&format!("{root}/fixtures/mesh/bunny.obj"));
    let dir: PathBuf = bench_dir().join("tiles");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let f = |name: &str| dir.join(name).display().to_string();
    // About 200 neighbours a point: pi ld^2 n / area = 200.
    let sd_for = |n: u64| (200.0 * surf.area / (std::f64::consts::PI * n as f64)).sqrt();
    let mut o = Table::new(
        &format!(
            "Out of core: ssmulti (exact, Rd 1, sd for about 200 neighbours) on the bunny; every process timed whole with its peak resident memory; tiles by `pctile split --for ssmulti --tile-memory {memory}`, baked one after the other; {}",
            machine()
        ),
        "| run | points | processes | time s | peak resident MiB | note |\n|---|---|---|---|---|---|",
    );

    // The untiled reference.
    let g = Instant::now();
    generate(&surf, reference, Path::new(&f("ref.ply")));
    eprintln!(
        "generated {reference} points in {:.1} s",
        g.elapsed().as_secs_f64()
    );
    let sd = format!("{}", sd_for(reference));
    let (s, m) = timed(&[
        &bin("ssmulti"),
        "-q",
        &f("ref.ply"),
        "--sd",
        &sd,
        "-o",
        &f("ref_ss.ply"),
    ]);
    o.row(format!(
        "| untiled ssmulti | {reference} | 1 | {s:.1} | {m:.0} | {:.0} bytes a point |",
        m * 1048576.0 / reference as f64
    ));
    let _ = std::fs::remove_file(f("ref.ply"));
    let _ = std::fs::remove_file(f("ref_ss.ply"));

    // The tiled bake.
    let g = Instant::now();
    generate(&surf, n, Path::new(&f("big.ply")));
    let gen = g.elapsed().as_secs_f64();
    let size = std::fs::metadata(f("big.ply")).unwrap().len();
    o.row(format!(
        "| generate (bench only) | {n} | 1 | {gen:.1} | - | {:.1} GB file |",
        size as f64 / 1e9
    ));
    let sd = format!("{}", sd_for(n));
    let args = format!("--sd {sd}");
    let tdir = f("split");
    let (s, m) = timed(&[
        &bin("pctile"),
        "-q",
        "split",
        &f("big.ply"),
        "--for",
        "ssmulti",
        "--stage-args",
        &args,
        "--tile-memory",
        &memory,
        "-o",
        &tdir,
    ]);
    let _ = std::fs::remove_file(f("big.ply"));
    let manifest = pcsss::tiles::Manifest::read(Path::new(&tdir)).unwrap();
    let halo: u64 = manifest.tiles.iter().map(|t| t.halo).sum();
    let most = manifest
        .tiles
        .iter()
        .map(|t| t.owned + t.halo)
        .max()
        .unwrap_or(0);
    o.row(format!(
        "| pctile split | {n} | 1 | {s:.1} | {m:.0} | {} tiles, largest {most} points with its halo; halo {:.1}% of the points |",
        manifest.tiles.len(),
        100.0 * halo as f64 / n as f64
    ));
    let odir = f("out");
    std::fs::create_dir_all(&odir).unwrap();
    let (mut total, mut peak) = (0.0f64, 0.0f64);
    for tile in &manifest.tiles {
        let input = format!("{tdir}/{}", tile.file);
        let output = format!("{odir}/{}", tile.file);
        let (s, m) = timed(&[&bin("ssmulti"), "-q", &input, "--sd", &sd, "-o", &output]);
        let _ = std::fs::remove_file(&input);
        total += s;
        peak = peak.max(m);
    }
    o.row(format!(
        "| ssmulti, each tile | {} | {} | {total:.1} | {peak:.0} | the largest process; budget {memory} |",
        n + halo,
        manifest.tiles.len()
    ));
    let (s, m) = timed(&[
        &bin("pctile"),
        "-q",
        "merge",
        &tdir,
        "--from",
        &odir,
        "-o",
        &f("merged.ply"),
    ]);
    o.row(format!("| pctile merge | {n} | 1 | {s:.1} | {m:.0} | |"));
    let _ = std::fs::remove_dir_all(&dir);
    let text = format!(
        "{}\n{}\n\n{}\n{}\n",
        t.title,
        t.rows.join("\n"),
        o.title,
        o.rows.join("\n")
    );
    std::fs::write(bench_dir().join("tiles.txt"), text).unwrap();
}
