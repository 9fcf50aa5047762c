//! Scatter and facet speed: 1,000,000 points on a ~1,000,000-triangle
//! sphere mesh, whole process, beside Python trimesh (sample_surface + face
//! normals) in the same run; then blue noise (`scatter --blue`) on the
//! bunny and the dragon, time and quality (nearest-neighbour distance over
//! the hexagonal spacing of the count made), beside point-cloud-utils'
//! Poisson-disk sampling and `--relax 10`. `cargo bench --bench geometry`;
//! results in target/bench/geometry.txt and blue_noise.txt
//! (BENCH_PART=speed or blue: one of the two; BENCH_PCU_1M=1 adds
//! point-cloud-utils at a million points, five to six minutes a mesh;
//! BENCH_MESHES=dragon or bunny: the blue-noise table of that mesh
//! alone).

mod common;

// The allocator the stages' binaries use, so in-process timings match.
pcsss::global_allocator!();

use std::fs::File;
use std::io::{BufWriter, Write};

use common::*;
use pcsss::formats::{self, Format};

fn main() {
    let part = std::env::var("BENCH_PART").unwrap_or_default();
    if part != "blue" {
        speed();
    }
    if part != "speed" {
        blue_noise();
    }
}

/// The blue-noise table: each mesh, each count, each method.
fn blue_noise() {
    use pcsss::geom::mesh::TriMesh;
    use pcsss::stages::scatter;
    let root = env!("CARGO_MANIFEST_DIR");
    let dir = bench_dir();
    let out = dir.join("blue_out.ply").display().to_string();
    let scatter_bin = env!("CARGO_BIN_EXE_scatter");
    let py = python();
    let pcu = format!("{root}/benches/py/pcu_poisson.py");
    let mut meshes = vec![("bunny", format!("{root}/fixtures/mesh/bunny.obj"))];
    let dragon = format!("{root}/out/models/dragon_vrip.ply");
    if std::path::Path::new(&dragon).exists() {
        meshes.push(("dragon", dragon));
    } else {
        eprintln!("no dragon: `make -C pipelines fetch-dragon` fetches it");
    }
    if let Ok(only) = std::env::var("BENCH_MESHES") {
        meshes.retain(|(name, _)| only.split(',').any(|o| o == *name));
    }
    let mut t = Table::new(
        &format!("blue noise: nearest-neighbour distance over the hexagonal spacing sqrt(2A / (sqrt(3) N)) of the N points made (targets: min >= 0.75, cv <= 0.07); {}; whole process, best of 5 (pcu and relax: 1 run)", machine()),
        "| mesh | asked | method | points | seconds | mean | min | cv |\n|---|---|---|---|---|---|---|---|",
    );
    for (name, path) in &meshes {
        let mesh =
            formats::read_cloud_file(std::path::Path::new(path), &formats::Select::All).unwrap();
        let area: f64 = TriMesh::from_cloud(&mesh).unwrap().tri_areas().iter().sum();
        let mut row = |n: usize, what: &str, secs: Option<f64>| {
            let Some(secs) = secs else {
                t.row(format!("| {name} | {n} | {what} | failed | | | | |"));
                return;
            };
            let c = formats::read_cloud_file(std::path::Path::new(&out), &formats::Select::All)
                .unwrap();
            let pos: Vec<glam::DVec3> = c
                .points()
                .vec3_f64("P")
                .unwrap()
                .into_iter()
                .map(glam::DVec3::from_array)
                .collect();
            let s = scatter::spacing(&pos, area);
            t.row(format!(
                "| {name} | {n} | {what} | {} | {secs:.2} | {:.3} | {:.3} | {:.4} |",
                pos.len(),
                s.mean,
                s.min,
                s.cv
            ));
        };
        for n in [200_000usize, 1_000_000] {
            let cmd = |extra: &str| format!("{scatter_bin} {path} -n {n} {extra} -o {out}");
            // Best of 5: a run here swings by 10-20% with the shared
            // machine's load, and ours take seconds.
            row(n, "scatter --blue", best_cmd(5, &cmd("--blue")));
            row(
                n,
                "scatter --blue --ptarea centroid",
                best_cmd(5, &cmd("--blue --ptarea centroid")),
            );
            row(n, "scatter (random)", best_cmd(5, &cmd("")));
            if n == 200_000 {
                row(n, "scatter --relax 10", best_cmd(1, &cmd("--relax 10")));
            }
            // point-cloud-utils takes five to six minutes for a million:
            // only with BENCH_PCU_1M set.
            if n == 200_000 || std::env::var_os("BENCH_PCU_1M").is_some() {
                row(
                    n,
                    "point-cloud-utils sample_mesh_poisson_disk",
                    best_cmd(1, &format!("{py} {pcu} {path} {n} {out}")),
                );
            }
        }
    }
    t.save("blue_noise.txt");
}

/// Scatter and facet on the sphere, beside trimesh.
fn speed() {
    let n: usize = std::env::var("BENCH_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let dir = bench_dir();
    let mesh = uv_sphere(500, 1000, false, |_, _| 1.0);
    let tris = mesh.faces().unwrap().len();
    let path = dir.join("sphere_1m.ply");
    let mut w = BufWriter::new(File::create(&path).unwrap());
    formats::write_cloud(&mut w, &mesh, Format::DEFAULT).unwrap();
    w.flush().unwrap();
    let p = path.display().to_string();
    let out = dir.join("geometry_out.ply").display().to_string();
    let b = |s: &str| {
        format!(
            "{}/{s}",
            std::path::Path::new(env!("CARGO_BIN_EXE_pcinfo"))
                .parent()
                .unwrap()
                .display()
        )
    };
    let mut t = Table::new(
        &format!("scatter + facet: {n} points on a UV sphere of {tris} triangles; {}; best of 3, whole process", machine()),
        "| case | seconds |\n|---|---|",
    );
    let mut row = |name: &str, s: Option<f64>| {
        t.row(format!(
            "| {name} | {} |",
            s.map_or("failed".into(), |s| format!("{s:.2}"))
        ))
    };
    row(
        "scatter -n N",
        best_cmd(3, &format!("{} {p} -n {n} -o {out}", b("scatter"))),
    );
    row(
        "scatter -n N --ptarea knn",
        best_cmd(
            3,
            &format!("{} {p} -n {n} --ptarea knn -o {out}", b("scatter")),
        ),
    );
    row(
        "scatter -n N --ptarea voronoi",
        best_cmd(
            3,
            &format!("{} {p} -n {n} --ptarea voronoi -o {out}", b("scatter")),
        ),
    );
    row(
        "scatter -n N --relax 5 --ptarea voronoi",
        best_cmd(
            1,
            &format!(
                "{} {p} -n {n} --relax 5 --ptarea voronoi -o {out}",
                b("scatter")
            ),
        ),
    );
    row(
        "scatter -n N --blue --ptarea centroid",
        best_cmd(
            1,
            &format!(
                "{} {p} -n {n} --blue --ptarea centroid -o {out}",
                b("scatter")
            ),
        ),
    );
    row(
        "scatter | facet --mode flat",
        best_cmd(
            3,
            &format!(
                "{} {p} -n {n} | {} --mesh {p} --mode flat -o {out}",
                b("scatter"),
                b("facet")
            ),
        ),
    );
    row(
        "scatter | facet --mode smooth",
        best_cmd(
            3,
            &format!(
                "{} {p} -n {n} | {} --mesh {p} -o {out}",
                b("scatter"),
                b("facet")
            ),
        ),
    );
    let py = python();
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/py/trimesh_scatter.py");
    row(
        "python trimesh: load, sample_surface, face normals, write PLY",
        best_cmd(3, &format!("{py} {script} {p} {n} {out}")),
    );
    t.save("geometry.txt");
}
