//! `scatter` (Houdini's Scatter SOP): points on a mesh's surface.
//!
//! Placement is stratified by area: point `k` of `N` is at
//! `(k + u0) / N` of the way along the cumulative triangle area (one random
//! offset `u0`), so every triangle gets `floor` or `ceil` of its expected
//! share `N * area / total`, never a Poisson-noisy count. Within its
//! triangle a point is uniform (square-root warp) from its own random
//! stream `Pcg32(seed, k)`: equal seeds give equal clouds on any thread
//! count.
//!
//! Each point gets `P` (the mesh's position type), `ptarea` (float),
//! `sourceprim` (int, the face) and `sourceuv` (vector `(u, v, 0)`: the
//! point is `(1-u-v) a + u b + v c` of the face's triangle that contains
//! it, Houdini's convention; for polygons the triangle is the one of the
//! ear-clipping triangulation that `facet` recomputes). The mesh's detail
//! attributes are inherited.
//!
//! `--relax ITER` then spreads the points evenly (blue noise) by repulsion
//! on the surface, like the Scatter SOP's relax iterations (see `relax`).
//!
//! `ptarea`:
//! - `prim`: a triangle's area shared equally by its points, and a
//!   triangle without points gives its area to the point nearest its
//!   centroid; sums to the mesh area exactly.
//! - `knn`: `pi r_k^2 / k` from the distance `r_k` to the k-th nearest
//!   other point (k = 8): follows local density; needs `promote
//!   --normalize` to sum to `Tarea`.
//! - `voronoi`: the point's Voronoi cell in its tangent plane (see
//!   `voronoi_areas`); needs `promote --normalize`. The most accurate
//!   weights for every later sum: on a unit sphere the RMS error of the
//!   `ssmulti` kernel sum over 8000 points with ~60 neighbours is 0.0087
//!   with `prim`, 0.0035 with `voronoi`, 0.0006 with `voronoi` after 10
//!   relax iterations (`relax_with_voronoi_weights_cuts_the_kernel_error`).

use crate::maths::uniform53;
use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::cloud::{Cloud, Role};
use crate::column::ScalarType;
use crate::error::{Error, Result};
use crate::geom::kdtree::PointTree;
use crate::geom::mesh::{ClosestPoint, TriMesh};
use crate::geom::{self, Sum};
use crate::progress::Progress;

/// How `ptarea` is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PtareaMode {
    /// A triangle's area shared by its points (sums to the mesh's area).
    Prim,
    /// pi r^2 / k from the 8 nearest neighbours (follows local density).
    Knn,
    /// The Voronoi cell in the tangent plane (most accurate; pair with
    /// --relax and promote --normalize).
    Voronoi,
}

/// Parameters.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    /// How many points.
    pub amount: Amount,
    /// Random seed.
    pub seed: u64,
    /// `ptarea` estimate.
    pub ptarea: PtareaMode,
    /// Relaxation iterations (0: plain stratified random points).
    pub relax: u32,
}

/// The most points one run makes.
pub const MAX_POINTS: usize = 1 << 31;

/// How many points: a count, or a density per unit area of the mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Amount {
    Count(usize),
    Density(f64),
}

/// The point count for a density (points per unit area) on `area`.
pub fn count_for_density(density: f64, area: f64) -> Result<usize> {
    if !(density.is_finite() && density >= 0.0) {
        return Err(Error::param(
            "--density",
            format!("{density:?} is not a finite number >= 0"),
        ));
    }
    let n = (density * area).round();
    if n > MAX_POINTS as f64 {
        return Err(Error::param(
            "--density",
            format!("asks for {n:e} points (at most {MAX_POINTS})"),
        ));
    }
    Ok(n as usize)
}

/// Scatters points on `mesh` (a cloud with faces).
pub fn scatter(mesh: &Cloud, p: &Params) -> Result<Cloud> {
    scatter_with(mesh, p, &Progress::hidden())
}

/// `scatter`, counting the relaxation's iterations on `progress`.
pub fn scatter_with(mesh: &Cloud, p: &Params, progress: &Progress) -> Result<Cloud> {
    // Parameters first: an absurd one is reported before any geometry work.
    if let Amount::Density(d) = p.amount {
        count_for_density(d, 0.0)?;
    }
    let m = TriMesh::from_cloud(mesh)?;
    let areas = m.tri_areas();
    let total = areas.iter().copied().collect::<Sum>().value();
    if !(total > 0.0 && total.is_finite()) {
        return Err(Error::invalid(format!(
            "the mesh's total area is {total}: nothing to scatter on"
        )));
    }
    let tri_face = m.tri_faces();
    // Stratified along the cumulative area: points sorted by triangle.
    let mut cdf = Vec::with_capacity(areas.len());
    let mut acc = Sum::default();
    for &a in &areas {
        acc.add(a);
        cdf.push(acc.value() / total);
    }
    let u0 = uniform53(&mut Pcg32::new(p.seed, u64::MAX));
    let n = match p.amount {
        Amount::Count(n) if n > MAX_POINTS => {
            return Err(Error::param(
                "--count",
                format!("{n} is more than {MAX_POINTS}"),
            ));
        }
        Amount::Count(n) => n,
        Amount::Density(d) => count_for_density(d, total)?,
    };
    // About 200 bytes a point at the peak (samples, areas, the columns
    // written, Voronoi's temporaries): asked for before the work.
    let flag = if matches!(p.amount, Amount::Density(_)) {
        "--density"
    } else {
        "--count"
    };
    crate::memory::check_available(200 * n as u64, flag, &format!("{n} points"))?;
    let mut tri_of = Vec::with_capacity(n);
    let last = areas
        .iter()
        .rposition(|&a| a > 0.0)
        .expect("total area > 0");
    let mut t = 0usize;
    for k in 0..n {
        let target = (k as f64 + u0) / n as f64;
        while t < last && (cdf[t] <= target || areas[t] == 0.0) {
            t += 1;
        }
        tri_of.push(t as u32);
    }
    let mut samples: Vec<Sample> = (0..n)
        .into_par_iter()
        .map(|k| {
            let mut r = Pcg32::new(p.seed, k as u64);
            let w = geom::sample_triangle(uniform53(&mut r), uniform53(&mut r));
            let t = tri_of[k];
            let [a, b, c] = m.tri(t as usize);
            Sample {
                p: geom::blend(w, a, b, c),
                tri: t,
                w,
            }
        })
        .collect();
    if p.relax > 0 && n > 1 {
        progress.start("relaxing", p.relax as u64);
        relax(&m, &mut samples, p.relax, p.seed, total, progress);
        progress.finish();
    }
    let ptarea: Vec<f32> = match p.ptarea {
        PtareaMode::Prim => prim_area(&m, &areas, &samples),
        PtareaMode::Knn => knn_area(&samples.iter().map(|s| s.p).collect::<Vec<_>>(), total),
        PtareaMode::Voronoi => {
            let pos: Vec<DVec3> = samples.iter().map(|s| s.p).collect();
            let nrm: Vec<DVec3> = samples
                .iter()
                .map(|s| {
                    let [a, b, c] = m.tri(s.tri as usize);
                    geom::tri_cross(a, b, c)
                })
                .collect();
            voronoi_areas(&pos, &nrm, total)
        }
    };
    let mut cloud = Cloud::with_points(n);
    cloud.detail = mesh.detail.clone();
    let pts = cloud.points_mut();
    let f64_positions = mesh.points().vec3_columns("P")?[0].ty() == ScalarType::F64;
    if f64_positions {
        pts.set_vec3(
            "P",
            Role::Point,
            &samples.iter().map(|s| s.p.to_array()).collect::<Vec<_>>(),
        )?;
    } else {
        let rows: Vec<[f32; 3]> = samples.iter().map(|s| s.p.as_vec3().to_array()).collect();
        pts.set_vec3("P", Role::Point, &rows)?;
    }
    pts.set_scalar("ptarea", ptarea)?;
    pts.set_scalar(
        "sourceprim",
        samples
            .iter()
            .map(|s| tri_face[s.tri as usize] as i32)
            .collect(),
    )?;
    let uv: Vec<[f32; 3]> = samples
        .iter()
        .map(|s| [s.w[1] as f32, s.w[2] as f32, 0.0])
        .collect();
    pts.set_vec3("sourceuv", Role::Vector, &uv)?;
    Ok(cloud)
}

/// `pi r_k^2 / k` per point (k = 8 other points; fewer when the cloud is
/// smaller); a lone point stands for the whole area.
fn knn_area(pos: &[DVec3], total: f64) -> Vec<f32> {
    let k = 8.min(pos.len().saturating_sub(1));
    if k == 0 {
        return vec![total as f32; pos.len()];
    }
    // Relative to the first point: the tree's f64 arithmetic keeps its
    // precision far from the origin.
    let tree = PointTree::new(pos.iter().copied(), pos[0]);
    pos.par_iter()
        .map(|&q| {
            let near = tree.nearest(q, k + 1);
            let r2 = near.last().map_or(0.0, |nb| nb.distance);
            (std::f64::consts::PI * r2 / k as f64) as f32
        })
        .collect()
}

/// A point on the mesh: position, triangle, barycentric weights.
#[derive(Clone, Copy, Debug)]
struct Sample {
    p: DVec3,
    tri: u32,
    w: [f64; 3],
}

/// The per-primitive estimate: a triangle's area shared equally by its
/// points; a triangle that got no point (more triangles than points, or
/// after relaxation) gives its area to the point nearest its centroid, so
/// on a fine mesh this becomes a discrete Voronoi area and the sum is
/// always the mesh's area.
fn prim_area(m: &TriMesh, areas: &[f64], samples: &[Sample]) -> Vec<f32> {
    let mut per = vec![0u32; areas.len()];
    samples.iter().for_each(|s| per[s.tri as usize] += 1);
    let mut acc: Vec<f64> = samples
        .iter()
        .map(|s| areas[s.tri as usize] / per[s.tri as usize] as f64)
        .collect();
    let empty: Vec<usize> = (0..areas.len())
        .filter(|&t| per[t] == 0 && areas[t] > 0.0)
        .collect();
    if !empty.is_empty() && !samples.is_empty() {
        let tree = PointTree::new(samples.iter().map(|s| s.p), samples[0].p);
        let owner: Vec<u32> = empty
            .par_iter()
            .map(|&t| {
                let [a, b, c] = m.tri(t);
                tree.nearest_one((a + b + c) / 3.0).item
            })
            .collect();
        for (&t, &i) in empty.iter().zip(&owner) {
            acc[i as usize] += areas[t];
        }
    }
    acc.into_iter().map(|a| a as f32).collect()
}

/// Spacing of `n` points on `area` in a hexagonal lattice.
fn hex_spacing(area: f64, n: usize) -> f64 {
    (2.0 * area / (3f64.sqrt() * n as f64)).sqrt()
}

/// Relaxation (the Scatter SOP's relax iterations, Turk's re-tiling by
/// repulsion): every iteration moves each point away from its neighbours
/// closer than `R = 1.5 * spacing` within its triangle's plane, by at most
/// half the spacing, then puts it back on the mesh at the closest point.
/// Moves are computed from the previous iteration's positions only
/// (Jacobi), so the result does not depend on the thread count.
fn relax(
    m: &TriMesh,
    samples: &mut Vec<Sample>,
    iters: u32,
    seed: u64,
    total: f64,
    progress: &Progress,
) {
    let Some(cp) = ClosestPoint::new(m) else {
        return;
    };
    let normals: Vec<DVec3> = (0..m.tris.len())
        .map(|t| {
            let [a, b, c] = m.tri(t);
            geom::unit_or_zero(geom::tri_cross(a, b, c))
        })
        .collect();
    let n = samples.len();
    let d = hex_spacing(total, n);
    // Measured on a sphere (tests/it/geometry.rs): reach 1.5 and gain 0.5
    // converge fastest; gains from 0.7 up oscillate.
    let reach = 1.5 * d;
    let gain = 0.5;
    let max_step = 0.5 * d;
    let k = 13.min(n);
    let o = samples[0].p;
    for it in 0..iters {
        let rel: Vec<[f64; 3]> = samples.iter().map(|s| (s.p - o).to_array()).collect();
        let tree = PointTree::from_relative(&rel);
        let next: Vec<Sample> = (0..n)
            .into_par_iter()
            .map(|i| {
                let s = samples[i];
                let q = DVec3::from_array(rel[i]);
                let mut f = DVec3::ZERO;
                for nb in tree.nearest(q, k) {
                    let j = nb.item as usize;
                    if j == i {
                        continue;
                    }
                    let r = nb.distance.sqrt();
                    if r >= reach {
                        continue;
                    }
                    let dir = if r > 1e-9 * d {
                        (q - DVec3::from_array(rel[j])) / r
                    } else {
                        // Coincident points (pushed onto the same edge or
                        // corner): apart along a direction of their own.
                        let mut g = Pcg32::new(seed ^ (it as u64) << 32, i as u64);
                        DVec3::new(uniform53(&mut g), uniform53(&mut g), uniform53(&mut g)) - 0.5
                    };
                    let x = 1.0 - r / reach;
                    f += dir * (x * x);
                }
                let nrm = normals[s.tri as usize];
                f -= nrm * f.dot(nrm);
                let mut step = f * (gain * reach);
                let len = step.length();
                if len > max_step {
                    step *= max_step / len;
                }
                if step == DVec3::ZERO {
                    return s;
                }
                let hit = cp.query(s.p + step);
                let [a, b, c] = m.tri(hit.tri);
                Sample {
                    p: geom::blend(hit.bary, a, b, c),
                    tri: hit.tri as u32,
                    w: hit.bary,
                }
            })
            .collect();
        *samples = next;
        progress.inc(1);
    }
}

/// Neighbours a Voronoi cell is first cut by; doubled (up to
/// `VORONOI_KMAX`) until the cell is provably closed.
const VORONOI_K: usize = 16;
const VORONOI_KMAX: usize = 128;

/// The area of each point's Voronoi cell in its tangent plane: the
/// nearest `k` other points (16 at first), projected onto the plane through
/// the point with normal `normals[i]` (any unit vector when zero), cut a
/// square of half-width the 16th one's distance by their bisectors; while
/// a corner of the cell lies farther than half the k-th distance (a
/// farther point could still cut it) `k` doubles, up to 128. Random clouds
/// need this: next to an empty patch the 16 nearest points all lie on one
/// side (at 1M random points on a sphere, 16 left cells 4 times too
/// large, 0.05% on the total). Exact for points on a plane away from its
/// edges; on a smooth surface the error is of the order of the cell's size
/// over the radius of curvature. Cells at an open boundary stop at the
/// square and come out too large (`promote --normalize` rescales the
/// total). A lone point gets `lone`.
pub fn voronoi_areas(positions: &[DVec3], normals: &[DVec3], lone: f64) -> Vec<f32> {
    let n = positions.len();
    let k = VORONOI_K.min(n.saturating_sub(1));
    if k == 0 {
        return vec![lone as f32; n];
    }
    let o = positions[0];
    let rel: Vec<[f64; 3]> = positions.iter().map(|p| (*p - o).to_array()).collect();
    let tree = PointTree::from_relative(&rel);
    (0..n)
        .into_par_iter()
        .map(|i| {
            let nrm = geom::unit_or_zero(normals[i]);
            let (t1, t2) = geom::tangent_basis(if nrm == DVec3::ZERO { DVec3::Z } else { nrm });
            let q = DVec3::from_array(rel[i]);
            let mut kk = k;
            let mut h = 0.0;
            let mut cell = Vec::with_capacity(32);
            let mut tmp = Vec::with_capacity(32);
            loop {
                let near = tree.nearest(q, kk + 1);
                let far = near.last().map_or(0.0, |nb| nb.distance.sqrt());
                if h == 0.0 {
                    // The cell never reaches past the first ring's
                    // farthest point: bounds it at an open edge.
                    h = far;
                }
                cell.clear();
                cell.extend([[-h, -h], [h, -h], [h, h], [-h, h]]);
                for nb in &near {
                    if nb.item as usize == i {
                        continue;
                    }
                    let d = DVec3::from_array(rel[nb.item as usize]) - q;
                    let v = [d.dot(t1), d.dot(t2)];
                    let c = 0.5 * (v[0] * v[0] + v[1] * v[1]);
                    if c > 0.0 {
                        geom::clip_half_plane(&cell, v, c, &mut tmp);
                        std::mem::swap(&mut cell, &mut tmp);
                    }
                }
                // Closed for sure when no farther point's bisector can cut
                // it: its farthest corner within half the k-th distance.
                let reach = cell
                    .iter()
                    .map(|v| (v[0] * v[0] + v[1] * v[1]).sqrt())
                    .fold(0.0, f64::max);
                if 2.0 * reach <= far || kk >= n - 1 || kk >= VORONOI_KMAX {
                    break;
                }
                kk = (2 * kk).min(n - 1);
            }
            geom::polygon_area_2d(&cell) as f32
        })
        .collect()
}
