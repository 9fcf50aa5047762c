//! Scatter and facet speed: 1,000,000 points on a ~1,000,000-triangle
//! sphere mesh, whole process, beside Python trimesh (sample_surface + face
//! normals) in the same run. `cargo bench --bench geometry`; results in
//! target/bench/geometry.txt.

mod common;

use std::fs::File;
use std::io::{BufWriter, Write};

use common::*;
use pcsss::formats::{self, Format};

fn main() {
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
