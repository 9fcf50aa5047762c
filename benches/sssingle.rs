//! sssingle: closest-hit rays per second beside Embree on the very same
//! rays, and the whole stage's time against its error.
//!
//! 1. The rays sssingle casts from inside a bumpy sphere of ~100,000
//!    triangles towards two lights (the seed model's depths, 16 a point),
//!    traced for their nearest hit on 1 and 2 threads by the project's BVH
//!    and by Embree 4 (Python embreex, installed by `make bench`, one
//!    thread per process): M rays/s, and both sides' hit counts and mean
//!    hit distance, which must agree. The distant light's rays also
//!    through the grid down its direction that sssingle builds
//!    (`geom::columns`).
//! 2. The whole `sssingle` process on the Stanford bunny at 1,000,000
//!    points with two lights (`fixtures/lights/bunny.json`, the bake's
//!    camera), samples 1 to 256.
//! 3. Error against independent truth at 1,000,000 points: a slab's top
//!    face under a distant light, the physical model with three mean free
//!    paths against the closed form (RMS relative error over points and
//!    channels), in process, samples 1 to 256.
//!
//! `cargo bench --bench sssingle` (or `make bench`); results in
//! target/bench/sssingle.txt. `BENCH_POINTS` changes the point counts of
//! 2 and 3, `BENCH_QUICK=1` stops the sample counts at 16, `BENCH_ONLY=rays`
//! runs 1 alone.

mod common;

// The allocator the stages' binaries use, so in-process timings match.
pcsss::global_allocator!();

use std::fs::File;
use std::io::{BufWriter, Write};
use std::time::Instant;

use common::*;
use glam::DVec3;
use obvhs::ray::Ray;
use pcsss::cloud::Role;
use pcsss::formats::{self, Format};
use pcsss::geom::bvh::{Facing, Occluder};
use pcsss::geom::columns::Columns;
use pcsss::geom::mesh::TriMesh;
use pcsss::lights::{self, Arrival};
use pcsss::progress::Progress;
use pcsss::stages::sssingle::{self, interior::Interior, optics, Model, Params};
use pcsss::Cloud;
use rayon::prelude::*;

const LIGHTS: &str = r#"{"lights": [
  {"name": "key", "type": "distant", "direction": [-0.5, -1.0, -0.3], "intensity": 2},
  {"name": "bulb", "type": "point", "position": [2.5, 1.0, 2.0], "intensity": 10}
]}"#;

fn write(path: &std::path::Path, c: &Cloud) {
    let mut w = BufWriter::new(File::create(path).unwrap());
    formats::write_cloud(&mut w, c, Format::DEFAULT).unwrap();
    w.flush().unwrap();
}

/// The rays sssingle's seed model casts from `cloud`'s points towards
/// `lights` (`samples` depths a point, at their strata's centres), in the
/// BVH's unit frame.
fn single_rays(
    interior: &Interior,
    cloud: &Cloud,
    lights: &[lights::Light],
    eye: DVec3,
    samples: usize,
) -> Vec<Ray> {
    let (eta, lu1) = (1.3, 0.3);
    let occ = interior.occluder();
    let p = cloud.points().vec3_f64("P").unwrap();
    let n = cloud.points().vec3_f64("N").unwrap();
    p.par_iter()
        .zip(&n)
        .flat_map_iter(|(p, n)| {
            let (xo, no) = (DVec3::from_array(*p), DVec3::from_array(*n).normalize());
            let wo = (eye - xo).normalize();
            let mut out = Vec::new();
            if no.dot(wo) <= 0.0 {
                return out;
            }
            let Some(to) = optics::refract(-wo, no, 1.0 / eta) else {
                return out;
            };
            let (x0, d) = interior.view(xo, to);
            let smax = d.min(lu1);
            let mut em: Vec<Arrival> = Vec::new();
            for k in 0..samples {
                let u = (k as f64 + 0.5) / samples as f64;
                let s = lu1 * optics::cdf_single_inv(u * optics::cdf_single(smax / lu1));
                let ps = x0 + to * s;
                for l in lights {
                    l.emissions(ps, 0.5, 0.5, &mut em);
                    out.extend(em.iter().map(|e| occ.unit_ray(ps, e.dir, 0.0, e.dist)));
                }
            }
            out
        })
        .collect()
}

/// Best of 3 seconds to find every ray's nearest hit on `threads`
/// threads; the hits and the sum of their distances (unit frame).
fn trace(
    rays: &[Ray],
    threads: usize,
    f: impl Fn(&Ray) -> Option<f32> + Sync,
) -> (f64, usize, f64) {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut res = (0, 0.0);
    let secs = best(3, || {
        res = pool.install(|| {
            rays.par_iter()
                .filter_map(&f)
                .fold(|| (0usize, 0.0f64), |(n, s), t| (n + 1, s + t as f64))
                .reduce(|| (0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
        });
    });
    (secs, res.0, res.1)
}

fn rays_vs_embree(tab: &mut Table, quick: bool) {
    let dir = bench_dir();
    let mesh = uv_sphere(158, 316, false, |th, ph| {
        1.0 + 0.15 * (5.0 * th).sin() * (7.0 * ph).cos()
    });
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let cloud = points_on(&mesh, if quick { 50_000 } else { 250_000 });
    let t = Instant::now();
    let interior = Interior::new(&m, 60.0);
    let build = t.elapsed().as_secs_f64();
    let lights = lights::parse(LIGHTS, "bench").unwrap();
    let rays = single_rays(&interior, &cloud, &lights, DVec3::new(0.5, 4.0, 3.0), 16);
    let occ = interior.occluder();
    let nearest = |facing| {
        move |r: &Ray| {
            let mut r = *r;
            occ.nearest_ray(&mut r, facing).map(|_| r.tmax)
        }
    };
    let (t1, hits, dist) = trace(&rays, 1, nearest(Facing::Any));
    let (t2, _, _) = trace(&rays, 2, nearest(Facing::Any));
    // The code path for processors without AVX, on the same tree.
    let base = Occluder::new(&m).without_avx();
    let base_nearest = |r: &Ray| {
        let mut r = *r;
        base.nearest_ray(&mut r, Facing::Any).map(|_| r.tmax)
    };
    let (s1, shits, _) = trace(&rays, 1, base_nearest);
    let (s2, _, _) = trace(&rays, 2, base_nearest);
    let (l1, lhits, _) = trace(&rays, 1, nearest(Facing::Leaving));
    let (l2, _, _) = trace(&rays, 2, nearest(Facing::Leaving));
    // The distant light's rays alone, through the BVH and through the
    // grid sssingle builds for that light.
    let key = match lights[0].shape {
        lights::Shape::Distant { to_light } => to_light,
        _ => unreachable!("the first light is distant"),
    };
    let cols = Columns::new(occ, key).expect("a grid for the key light");
    let key_dir = occ.unit_ray(DVec3::ZERO, key, 0.0, 1.0).direction;
    let parallel: Vec<Ray> = rays
        .iter()
        .filter(|r| r.direction == key_dir)
        .copied()
        .collect();
    let (b1, bhits, bdist) = trace(&parallel, 1, nearest(Facing::Leaving));
    let (b2, _, _) = trace(&parallel, 2, nearest(Facing::Leaving));
    let columns = |r: &Ray| {
        let mut r = *r;
        cols.nearest_ray(occ, &mut r, Facing::Leaving)
            .map(|_| r.tmax)
    };
    let t = Instant::now();
    let _ = Columns::new(occ, key);
    let cbuild = t.elapsed().as_secs_f64();
    let (c1, chits, cdist) = trace(&parallel, 1, columns);
    let (c2, _, _) = trace(&parallel, 2, columns);
    let embree = embree(&dir, occ.triangles(), &rays, "intersect");
    let nr = rays.len() as f64;
    tab.row(format!(
        "| {} rays from inside a bumpy sphere of {} triangles ({} points x 16 depths x 2 lights, those the eye sees) | | | |",
        rays.len(),
        occ.triangle_count(),
        cloud.len()
    ));
    tab.row(format!(
        "| pcsss nearest hit (4-wide BVH, {}), M rays/s | {build:.3} | {:.2} | {:.2} |",
        if occ.uses_avx() { "AVX" } else { "no AVX here" },
        nr / t1 / 1e6,
        nr / t2 / 1e6
    ));
    tab.row(format!(
        "| the same, the code path without AVX ({shits} hits), M rays/s | | {:.2} | {:.2} |",
        nr / s1 / 1e6,
        nr / s2 / 1e6
    ));
    tab.row(format!(
        "| pcsss nearest leaving hit (sssingle's query), M rays/s | | {:.2} | {:.2} |",
        nr / l1 / 1e6,
        nr / l2 / 1e6
    ));
    let np = parallel.len() as f64;
    tab.row(format!(
        "| the distant light's {} rays alone: nearest leaving hit through the BVH, M rays/s | | {:.2} | {:.2} |",
        parallel.len(),
        np / b1 / 1e6,
        np / b2 / 1e6
    ));
    let (cells, entries) = cols.size();
    tab.row(format!(
        "| the same through sssingle's grid down the light ({cells} cells, {entries} entries), M rays/s | {cbuild:.3} | {:.2} | {:.2} |",
        np / c1 / 1e6,
        np / c2 / 1e6
    ));
    tab.row(format!(
        "| hits: BVH {bhits}, grid {chits}; mean distance BVH {:.6}, grid {:.6} | | | |",
        bdist / bhits as f64,
        cdist / chits as f64
    ));
    match &embree {
        Some(e) => {
            embree_rows(tab, e, nr, t1, t2, "closest hit ");
            let f = |k: &str| e[k].as_f64().unwrap_or(f64::NAN);
            tab.row(format!(
                "| hits: pcsss {hits} (leaving {lhits}), Embree {}; mean distance pcsss {:.6}, Embree {:.6} | | | |",
                e["hits"],
                dist / hits as f64,
                f("dist") / f("hits")
            ));
        }
        None => tab.row("| Embree (embreex) not available: run `make bench` | | | |".into()),
    }
}

/// A box `[-w, w]^2 x [-t, 0]` (top face at z = 0).
fn slab(w: f64, t: f64) -> Cloud {
    let mut p = Vec::new();
    for &z in &[-t, 0.0] {
        for &(x, y) in &[(-w, -w), (w, -w), (w, w), (-w, w)] {
            p.push([x, y, z]);
        }
    }
    let faces: [[i32; 4]; 6] = [
        [4, 5, 6, 7],
        [0, 3, 2, 1],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    let mut c = Cloud::with_points(p.len());
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    let mut l = pcsss::ListColumn::new(pcsss::ScalarType::U8, pcsss::ScalarType::I32);
    let mut items = Vec::new();
    for f in faces {
        items.extend_from_slice(&f);
        l.offsets.push(items.len());
    }
    l.items = pcsss::Column::I32(items);
    let mut e = pcsss::Element::new("face", 6);
    e.set(pcsss::Attribute {
        name: "vertex_indices".into(),
        data: pcsss::AttrData::List(l),
    })
    .unwrap();
    c.elements.push(e);
    c
}

/// Unpolarised Fresnel transmittance from the angle forms.
fn kt(theta: f64, eta: f64) -> f64 {
    let tt = (theta.sin() / eta).asin();
    if theta == 0.0 {
        let r = (eta - 1.0) / (eta + 1.0);
        return 1.0 - r * r;
    }
    let rs = (theta - tt).sin() / (theta + tt).sin();
    let rp = (theta - tt).tan() / (theta + tt).tan();
    1.0 - 0.5 * (rs * rs + rp * rp)
}

fn main() {
    let quick = std::env::var_os("BENCH_QUICK").is_some();
    let n: usize = std::env::var("BENCH_POINTS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(if quick { 100_000 } else { 1_000_000 });
    let dir = bench_dir();
    let mut tab = Table::new(
        &format!(
            "sssingle: closest-hit rays beside Embree; {}; best of 3",
            machine()
        ),
        "| case | build s | 1 thread | 2 threads |\n|---|---|---|---|",
    );
    rays_vs_embree(&mut tab, quick);
    tab.save("sssingle.txt");
    if std::env::var("BENCH_ONLY").as_deref() == Ok("rays") {
        return;
    }

    // The whole stage on the bunny.
    let root = env!("CARGO_MANIFEST_DIR");
    let bunny = formats::read_cloud_file(
        std::path::Path::new(&format!("{root}/fixtures/mesh/bunny.obj")),
        &formats::Select::All,
    )
    .unwrap();
    let cloud = points_on(&bunny, n);
    let (mesh_path, cloud_path) = (
        dir.join("sssingle_bunny.ply"),
        dir.join("sssingle_cloud.ply"),
    );
    write(&mesh_path, &bunny);
    write(&cloud_path, &cloud);
    let sample_counts: &[u32] = if quick {
        &[1, 4, 16]
    } else {
        &[1, 4, 16, 64, 256]
    };
    let b = std::path::Path::new(env!("CARGO_BIN_EXE_sssingle"));
    tab.row(format!(
        "| whole `sssingle` process, bunny, {n} points, 2 lights (key, rim), seed model, sd 0.6, --rgb: samples | | seconds (2 threads) | |"
    ));
    for &k in sample_counts {
        let cmd = format!(
            "{} {} --mesh {} --lights {root}/fixtures/lights/bunny.json --camera {root}/fixtures/cameras/bunny.json --sd 0.6 --rd 0.9,0.5,0.3 --rgb --samples {k} -q -o {}",
            b.display(),
            cloud_path.display(),
            mesh_path.display(),
            dir.join("sssingle_out.ply").display()
        );
        let reps = if k >= 64 { 1 } else { 3 };
        let secs = best_cmd(reps, &cmd).map_or("failed".into(), |t| format!("{t:.2}"));
        tab.row(format!("| {k} | | {secs} | |"));
    }
    tab.save("sssingle.txt");

    // Time against error on the slab, in process.
    let side = (n as f64).sqrt().round() as usize;
    let mesh = TriMesh::from_cloud(&slab(10.0, 50.0)).unwrap();
    let mut pts = Vec::with_capacity(side * side);
    for i in 0..side {
        for j in 0..side {
            let f = |a: usize| -1.0 + 2.0 * (a as f64 + 0.5) / side as f64;
            pts.push([f(i), f(j), 0.0]);
        }
    }
    let mut slab_cloud = Cloud::with_points(pts.len());
    slab_cloud
        .points_mut()
        .set_vec3("P", Role::Point, &pts)
        .unwrap();
    slab_cloud
        .points_mut()
        .set_vec3("N", Role::Normal, &vec![[0.0f32, 0.0, 1.0]; pts.len()])
        .unwrap();
    let (ti, to, eta, g) = (30f64.to_radians(), 20f64.to_radians(), 1.33, 0.3);
    let light = lights::parse(
        &format!(
            r#"{{"lights": [{{"type": "distant", "name": "sun", "direction": [{}, 0, {}]}}]}}"#,
            -ti.sin(),
            -ti.cos()
        ),
        "bench",
    )
    .unwrap();
    let (tti, tto) = ((ti.sin() / eta).asin(), (to.sin() / eta).asin());
    // The view at azimuth 180: back up the refracted view ray.
    let up = DVec3::new(-tto.sin(), 0.0, tto.cos());
    let c = DVec3::new(-tti.sin(), 0.0, -tti.cos()).dot(up);
    let p = (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * c).powf(1.5));
    let albedo = [0.9, 0.7, 0.5];
    let truth = albedo.map(|a| {
        ti.cos() * a * kt(ti, eta) * kt(to, eta) * p / (eta * eta * (tti.cos() + tto.cos()))
    });
    tab.row(format!(
        "| error against the closed form: slab, {} points, physical model, mfp 0.05, 0.1, 0.2: samples | | seconds (2 threads), RMS relative error | |",
        pts.len()
    ));
    for &k in sample_counts {
        let params = Params {
            model: Model::Physical,
            albedo,
            mfp: [0.05, 0.1, 0.2],
            g,
            eta,
            samples: k,
            eye: DVec3::new(-to.sin(), 0.0, to.cos()) * 1e7,
            ..Params::default()
        };
        let mut out = Vec::new();
        let reps = if k >= 64 { 1 } else { 3 };
        let secs = best(reps, || {
            let (v, _) = sssingle::sssingle_values(
                &slab_cloud,
                &mesh,
                &light,
                &params,
                None,
                &Progress::hidden(),
            )
            .unwrap();
            out = v;
        });
        let s: f64 = out
            .iter()
            .flat_map(|v| (0..3).map(move |c| ((v[c] as f64 - truth[c]) / truth[c]).powi(2)))
            .sum();
        let rms = (s / (3 * out.len()) as f64).sqrt();
        tab.row(format!("| {k} | | {secs:.2} s, {rms:.1e} | |"));
    }
    tab.save("sssingle.txt");
}
