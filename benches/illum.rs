//! illum speed: shadow rays per second for 1,000,000 points on a bumpy
//! sphere of ~100,000 triangles (it shadows itself) under 3 lights, on 1
//! and 2 threads, beside Embree 4 (Python embreex, installed by `make
//! bench`) tracing the very same rays in the same run; and the whole
//! `illum` process. `cargo bench --bench illum`; results in
//! target/bench/illum.txt.

mod common;

// The allocator the stages' binaries use, so in-process timings match.
pcsss::global_allocator!();

use std::fs::File;
use std::io::{BufWriter, Write};
use std::time::Instant;

use common::*;
use glam::DVec3;
use obvhs::ray::Ray;
use pcsss::formats::{self, Format};
use pcsss::geom::bvh::Occluder;
use pcsss::geom::columns::Columns;
use pcsss::geom::mesh::TriMesh;
use pcsss::lights;
use pcsss::Cloud;
use rayon::prelude::*;

const LIGHTS: &str = r#"{"lights": [
  {"name": "key", "type": "distant", "direction": [-0.5, -1.0, -0.3], "intensity": 2},
  {"name": "bulb", "type": "point", "position": [2.5, 1.0, 2.0], "intensity": 10},
  {"name": "spot", "type": "spot", "position": [-1.0, 3.0, -2.0], "direction": [0.3, -1.0, 0.7],
   "cone_angle": 45, "cone_delta": 10, "intensity": 12}
]}"#;

/// Best of 3 seconds to trace every ray on `threads` threads, and how
/// many were blocked.
fn trace(rays: &[Ray], threads: usize, hit: impl Fn(&Ray) -> bool + Sync) -> (f64, usize) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut blocked = 0;
    let secs = best(3, || {
        blocked = pool.install(|| rays.par_iter().filter(|r| hit(r)).count());
    });
    (secs, blocked)
}

fn write(path: &std::path::Path, c: &Cloud) {
    let mut w = BufWriter::new(File::create(path).unwrap());
    formats::write_cloud(&mut w, c, Format::DEFAULT).unwrap();
    w.flush().unwrap();
}

fn main() {
    let n: usize = std::env::var("BENCH_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1_000_000);
    let dir = bench_dir();
    // A sphere with bumps: valleys shadowed by ridges.
    let mesh = uv_sphere(158, 316, false, |th, ph| {
        1.0 + 0.15 * (5.0 * th).sin() * (7.0 * ph).cos()
    });
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let cloud = points_on(&mesh, n);
    let mesh_path = dir.join("illum_mesh.ply");
    let cloud_path = dir.join("illum_cloud.ply");
    let lights_path = dir.join("illum_lights.json");
    write(&mesh_path, &mesh);
    write(&cloud_path, &cloud);
    std::fs::write(&lights_path, LIGHTS).unwrap();

    // The rays illum casts, built as illum builds them.
    let t = Instant::now();
    let occ = Occluder::new(&m);
    let build = t.elapsed().as_secs_f64();
    let lights = lights::parse(LIGHTS, "bench").unwrap();
    let p = cloud.points().vec3_f64("P").unwrap();
    let nn = cloud.points().vec3_f64("N").unwrap();
    // Light by light, points in cloud order, as illum traces them.
    let rays: Vec<Ray> = lights
        .iter()
        .flat_map(|l| {
            p.par_iter()
                .zip(&nn)
                .flat_map_iter(|(p, n)| {
                    let (p, n) = (DVec3::from_array(*p), DVec3::from_array(*n).normalize());
                    let mut arr = Vec::new();
                    l.arrivals(p, n, 0.5, 0.5, &mut arr);
                    arr.into_iter()
                        .map(|a| occ.shadow_ray(p, n, a.dir, a.dist))
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let (t1, blocked) = trace(&rays, 1, |r| occ.occluded_ray(r));
    let (t2, _) = trace(&rays, 2, |r| occ.occluded_ray(r));
    // The code path for processors without AVX, on the same tree.
    let base = Occluder::new(&m).without_avx();
    let (s1, base_blocked) = trace(&rays, 1, |r| base.occluded_ray(r));
    let (s2, _) = trace(&rays, 2, |r| base.occluded_ray(r));
    // obvhs's own CWBVH traversal on the same triangles and rays (kept to
    // show why the project traverses its own 4-wide BVH).
    let t = Instant::now();
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        occ.triangles(),
        obvhs::BvhBuildParams::medium_build(),
        &mut std::time::Duration::default(),
    );
    let cw_build = t.elapsed().as_secs_f64();
    let cw_tris: Vec<_> = cw
        .primitive_indices
        .iter()
        .map(|&i| occ.triangles()[i as usize])
        .collect();
    // obvhs needs +0.0 for a zero direction component.
    let cw_hit = |r: &Ray| {
        let r = Ray::new(r.origin, r.direction + glam::Vec3A::ZERO, r.tmin, r.tmax);
        !cw.ray_traverse_miss(r, |r, i| cw_tris[i].intersect(r))
    };
    let (c1, cw_blocked) = trace(&rays, 1, cw_hit);
    let (c2, _) = trace(&rays, 2, cw_hit);

    // The distant light's rays alone, through the BVH and through the
    // grid down its direction that illum builds for them.
    let key = match lights[0].shape {
        lights::Shape::Distant { to_light } => to_light,
        _ => unreachable!("the first light is distant"),
    };
    let t = Instant::now();
    let cols = Columns::new(&occ, key).expect("a grid for the key light");
    let cols_build = t.elapsed().as_secs_f64();
    let key_dir = occ.shadow_ray(DVec3::ZERO, DVec3::Z, key, 1.0).direction;
    let parallel: Vec<Ray> = rays
        .iter()
        .filter(|r| r.direction == key_dir)
        .copied()
        .collect();
    let (k1, key_blocked) = trace(&parallel, 1, |r| occ.occluded_ray(r));
    let (k2, _) = trace(&parallel, 2, |r| occ.occluded_ray(r));
    let (g1, grid_blocked) = trace(&parallel, 1, |r| cols.occluded_ray(&occ, r));
    let (g2, _) = trace(&parallel, 2, |r| cols.occluded_ray(&occ, r));

    // The same rays and triangles for Embree.
    let embree = embree(&dir, occ.triangles(), &rays, "occluded");

    let nr = rays.len() as f64;
    let mut tab = Table::new(
        &format!(
            "illum: {n} points on a bumpy sphere of {} triangles, 3 lights, {} shadow rays ({} blocked); {}; best of 3",
            occ.triangle_count(),
            rays.len(),
            blocked,
            machine()
        ),
        "| case | build s | 1 thread | 2 threads |\n|---|---|---|---|",
    );
    tab.row(format!(
        "| pcsss (4-wide BVH from obvhs's PLOC build, {}), M rays/s | {build:.3} | {:.2} | {:.2} |",
        if occ.uses_avx() { "AVX" } else { "no AVX here" },
        nr / t1 / 1e6,
        nr / t2 / 1e6
    ));
    tab.row(format!(
        "| pcsss, the code path without AVX ({base_blocked} blocked), M rays/s | | {:.2} | {:.2} |",
        nr / s1 / 1e6,
        nr / s2 / 1e6
    ));
    tab.row(format!(
        "| obvhs CWBVH traversal ({cw_blocked} blocked), M rays/s | {cw_build:.3} | {:.2} | {:.2} |",
        nr / c1 / 1e6,
        nr / c2 / 1e6
    ));
    let np = parallel.len() as f64;
    tab.row(format!(
        "| the distant light's {} rays alone through the BVH ({key_blocked} blocked), M rays/s | | {:.2} | {:.2} |",
        parallel.len(),
        np / k1 / 1e6,
        np / k2 / 1e6
    ));
    let (cells, entries) = cols.size();
    tab.row(format!(
        "| the same through illum's grid down the light ({cells} cells, {entries} entries; {grid_blocked} blocked), M rays/s | {cols_build:.3} | {:.2} | {:.2} |",
        np / g1 / 1e6,
        np / g2 / 1e6
    ));
    match &embree {
        Some(e) => {
            embree_rows(&mut tab, e, nr, t1, t2, "");
            tab.row(format!(
                "| blocked rays: pcsss {blocked}, Embree {}, robust {} | | | |",
                e["blocked"], e["blocked_robust"]
            ));
        }
        None => tab.row("| Embree (embreex) not available: run `make bench` | | | |".into()),
    }
    let b = std::path::Path::new(env!("CARGO_BIN_EXE_illum"));
    let cmd = |threads: usize, shadows: &str| {
        format!(
            "RAYON_NUM_THREADS={threads} {} {} --lights {} {shadows} -o {}",
            b.display(),
            cloud_path.display(),
            lights_path.display(),
            dir.join("illum_out.ply").display()
        )
    };
    let shadows = format!("--mesh {}", mesh_path.display());
    let secs = |threads, s: &str| {
        best_cmd(3, &cmd(threads, s)).map_or("failed".into(), |t| format!("{t:.2} s"))
    };
    tab.row(format!(
        "| whole `illum` process, PLY in and out, with shadows | | {} | {} |",
        secs(1, &shadows),
        secs(2, &shadows)
    ));
    tab.row(format!(
        "| whole `illum` process, `--no-shadows` | | {} | {} |",
        secs(1, "--no-shadows"),
        secs(2, "--no-shadows")
    ));
    tab.save("illum.txt");
}
