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
//! `--blue` makes a Poisson-disk set instead, with the exact count: the
//! points that weighted sample elimination keeps of three times as many
//! random ones (see `blue`), then evened out over the surface (see
//! `relax`): 2 relaxation iterations, then rounds that push apart pairs
//! closer than 0.8 hexagonal spacings until none is left (at most 64).
//! `--relax ITER` alone spreads random points by repulsion, like the
//! Scatter SOP's relax iterations; it is slower than `--blue` and leaves
//! closer pairs.
//!
//! `ptarea`:
//! - `prim`: a triangle's area shared equally by its points, and a
//!   triangle without points gives its area to the point nearest its
//!   centroid; sums to the mesh area exactly.
//! - `knn`: `pi r_k^2 / k` from the distance `r_k` to the k-th nearest
//!   other point (k = 8): follows local density; needs `promote
//!   --normalize` to sum to `Tarea`.
//! - `voronoi`: the point's Voronoi cell in its tangent plane (see
//!   `voronoi_areas`); needs `promote --normalize`. On a unit sphere the
//!   RMS error of the `ssmulti` kernel sum over 8000 points with ~60
//!   neighbours is 0.0087 with `prim`, 0.0035 with `voronoi`, under 0.001
//!   with `voronoi` on relaxed points (`tests/it/scatter.rs`).
//! - `centroid`: each Voronoi cell's area placed at the cell's centroid,
//!   shared with two neighbours (see `voronoi_weights`); the most accurate
//!   on blue noise, where it halves that error; needs `promote
//!   --normalize`.

mod blue;
mod relax;
mod voronoi;

pub use voronoi::{voronoi_areas, voronoi_weights};

use std::sync::atomic::{AtomicU32, Ordering};

use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::column::ScalarType;
use crate::error::{Error, Result};
use crate::geom::grid::PointGrid;
use crate::geom::kdtree::PointTree;
use crate::geom::mesh::{Adjacency, TriMesh};
use crate::geom::{self, Sum};
use crate::maths::uniform53;
use crate::progress::Progress;

/// How `ptarea` is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum PtareaMode {
    /// A triangle's area shared by its points (sums to the mesh's area).
    Prim,
    /// pi r^2 / k from the 8 nearest neighbours (follows local density).
    Knn,
    /// The Voronoi cell in the tangent plane (pair with promote
    /// --normalize).
    Voronoi,
    /// The Voronoi cell's area placed at its centroid, shared with two
    /// neighbours (most accurate with --blue; pair with promote
    /// --normalize).
    Centroid,
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
    /// Relaxation iterations (0: none).
    pub relax: u32,
    /// Blue noise: weighted sample elimination (see `blue`) from
    /// `candidates` times the points asked for, then `BLUE_RELAX`
    /// relaxation iterations (or `relax` when not 0) and close pairs
    /// pushed apart (`SEPARATE`); `false`: stratified random points.
    pub blue: bool,
    /// Candidates per point kept, for `blue`.
    pub candidates: f64,
}

/// Bytes a mesh's triangle takes at scatter's peak (its areas and
/// sampling tables, `--blue`'s adjacency for the relaxation), with a
/// margin: peaks measured on the Stanford dragon and a mesh of 1e7
/// triangles (benches/results/HISTORY.md, "Memory a triangle").
pub const MESH_BYTES: u64 = 300;

/// The default candidates per point of `--blue`: see `blue` for what
/// more or fewer buy (benches/results/blue_noise.txt).
pub const CANDIDATES: f64 = 3.0;
/// Relaxation iterations of `--blue` (unless `--relax` says otherwise):
/// more leave closer pairs across the dragon's creases; one is faster and
/// as accurate over wide kernels, but its kernel sums over tens of
/// neighbours are less accurate (test
/// `relax_with_voronoi_weights_cuts_the_kernel_error`; the figures in
/// benches/results/HISTORY.md, "Measurements behind the code").
pub const BLUE_RELAX: u32 = 2;
/// `--blue` pushes apart pairs closer than this many hexagonal
/// spacings, in rounds until no point moves, at most `SEPARATE_ROUNDS`.
pub const SEPARATE: f64 = 0.8;
/// The most separation rounds: the bunny and the dragon settle in a few
/// dozen, and the rounds after the first dozen move a few points each; a
/// cluster that never settles (points jammed in a concave crease,
/// pushing each other back and forth) stops here too (the counts in
/// benches/results/HISTORY.md, "Measurements behind the code").
pub const SEPARATE_ROUNDS: u32 = 64;
/// The range of `--candidates`.
pub const CANDIDATES_RANGE: (f64, f64) = (1.5, 64.0);

impl Params {
    /// `amount` points, seed 0, `prim` areas, no relaxation, random.
    pub fn new(amount: Amount) -> Params {
        Params {
            amount,
            seed: 0,
            ptarea: PtareaMode::Prim,
            relax: 0,
            blue: false,
            candidates: CANDIDATES,
        }
    }
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
            "density",
            format!("{density:?} is not a finite number >= 0"),
        ));
    }
    let n = (density * area).round();
    if n > MAX_POINTS as f64 {
        return Err(Error::param(
            "density",
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
    let mut ph = progress.phases("scatter");
    let m = TriMesh::from_cloud(mesh)?;
    crate::memory::check_mesh(m.tris.len(), MESH_BYTES)?;
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
                "count",
                format!("{n} is more than {MAX_POINTS}"),
            ));
        }
        Amount::Count(n) => n,
        Amount::Density(d) => count_for_density(d, total)?,
    };
    // The option that set the count, for errors about it.
    let flag = if matches!(p.amount, Amount::Density(_)) {
        "density"
    } else {
        "count"
    };
    let (lo, hi) = CANDIDATES_RANGE;
    if p.blue && !(p.candidates >= lo && p.candidates <= hi) {
        return Err(Error::param(
            "candidates",
            format!("{:?} is not a number from {lo} to {hi}", p.candidates),
        ));
    }
    // Candidates for blue noise: at least one more than the points kept.
    let cands = if p.blue && n > 0 {
        ((n as f64 * p.candidates).ceil() as usize).max(n + 1)
    } else {
        n
    };
    // About 200 bytes a point at the peak (samples, areas, the columns
    // written, Voronoi's temporaries) and 100 a candidate (its position, the
    // grid, its pairs); asked for before the work.
    crate::memory::check_available(
        200 * n as u64 + if cands > n { 100 * cands as u64 } else { 0 },
        flag,
        &format!("{n} points"),
    )?;
    let relax_iters = if p.blue && p.relax == 0 {
        BLUE_RELAX
    } else {
        p.relax
    };
    let separate = if p.blue { SEPARATE_ROUNDS } else { 0 };
    let polishing = relax_iters + separate > 0 && n > 1;
    ph.mark("setup");
    let (mut samples, adjacency) = if cands > n {
        // Only the candidates' positions are kept (under half a sample's
        // bytes): the points kept are made again from their indices.
        let tri_of = stratified_tris(&cdf, &areas, cands, u0);
        let pos: Vec<DVec3> = (0..cands)
            .into_par_iter()
            .map(|k| sample_at(&m, &tri_of, k, p.seed).p)
            .collect();
        ph.mark("candidates");
        // The mesh's adjacency, which only the polish needs, is built
        // beside the elimination: it fills the elimination's serial
        // stretches (its last removals, one at a time).
        let (keep, adjacency) = rayon::join(
            || blue::eliminate(pos, n, total, flag, progress),
            || polishing.then(|| Adjacency::new(&m)),
        );
        let samples = keep?
            .par_iter()
            .map(|&k| sample_at(&m, &tri_of, k as usize, p.seed))
            .collect();
        ph.mark("eliminate");
        (samples, adjacency)
    } else {
        let samples = stratified(&m, &cdf, &areas, cands, u0, p.seed);
        ph.mark("candidates");
        (samples, None)
    };
    // The surface's open edges, where Voronoi cells stop (from the
    // polish's adjacency when there is one).
    let voronoi = matches!(p.ptarea, PtareaMode::Voronoi | PtareaMode::Centroid);
    let mut open_edges: Option<Vec<[DVec3; 3]>> = None;
    if polishing {
        let adjacency = adjacency.unwrap_or_else(|| Adjacency::new(&m));
        progress.start("relaxing", (relax_iters + separate) as u64);
        relax::polish(
            &m,
            &adjacency,
            &mut samples,
            relax_iters,
            separate,
            SEPARATE,
            p.seed,
            total,
            progress,
        );
        progress.finish();
        ph.mark("polish");
        if voronoi {
            open_edges = Some(adjacency.open_edges());
        }
    }
    let ptarea: Vec<f32> = match p.ptarea {
        PtareaMode::Prim => prim_area(&m, &areas, total, &samples),
        PtareaMode::Knn => knn_area(&samples.iter().map(|s| s.p).collect::<Vec<_>>(), total),
        PtareaMode::Voronoi | PtareaMode::Centroid => {
            let pos: Vec<DVec3> = samples.iter().map(|s| s.p).collect();
            let nrm: Vec<DVec3> = samples
                .iter()
                .map(|s| {
                    let [a, b, c] = m.tri(s.tri as usize);
                    geom::tri_cross(a, b, c)
                })
                .collect();
            // Blue noise's cells close within a shorter first reach.
            let reach = if p.blue {
                voronoi::SPACED_REACH
            } else {
                voronoi::REACH
            };
            let open = open_edges.unwrap_or_else(|| m.open_edges());
            ph.mark("open edges");
            if p.ptarea == PtareaMode::Centroid {
                voronoi::voronoi_weights_within(&pos, &nrm, total, reach, &open)
            } else {
                voronoi::voronoi_areas_within(&pos, &nrm, total, reach, &open)
            }
        }
    };
    ph.mark("ptarea");
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
    let mut record = vec![
        ("scatter_count", DetailValue::F64(n as f64)),
        ("scatter_seed", DetailValue::Str(p.seed.to_string())),
        (
            "scatter_ptarea",
            DetailValue::Str(format!("{:?}", p.ptarea).to_lowercase()),
        ),
        (
            "scatter_relax",
            DetailValue::I32(p.relax.min(i32::MAX as u32) as i32),
        ),
        ("scatter_blue", DetailValue::I32(p.blue as i32)),
    ];
    if p.blue {
        record.push(("scatter_candidates", DetailValue::F64(p.candidates)));
    }
    cloud.record("scatter_", record);
    Ok(cloud)
}

/// `n` points stratified along the cumulative area `cdf` (sample `k` at
/// `(k + u0) / n` of it), each uniform in its triangle from its own
/// stream `Pcg32(seed, k)`.
fn stratified(
    m: &TriMesh,
    cdf: &[f64],
    areas: &[f64],
    n: usize,
    u0: f64,
    seed: u64,
) -> Vec<Sample> {
    let tri_of = stratified_tris(cdf, areas, n, u0);
    (0..n)
        .into_par_iter()
        .map(|k| sample_at(m, &tri_of, k, seed))
        .collect()
}

/// The triangle of each of `n` points stratified along `cdf` (see
/// `stratified`).
///
/// Point `k` goes to the first triangle with area whose `cdf` is above
/// `(k + u0) / n` (the last with area if none is): the targets rise with
/// `k`, so a walk from the last point's triangle finds it, and each
/// chunk of points starts its walk from a binary search (the areas are
/// not negative, so `cdf` never falls).
fn stratified_tris(cdf: &[f64], areas: &[f64], n: usize, u0: f64) -> Vec<u32> {
    const CHUNK: usize = 1 << 16;
    let last = areas
        .iter()
        .rposition(|&a| a > 0.0)
        .expect("total area > 0");
    let parts: Vec<Vec<u32>> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let ks = c * CHUNK..((c + 1) * CHUNK).min(n);
            let mut out = Vec::with_capacity(ks.len());
            let first = (ks.start as f64 + u0) / n as f64;
            let mut t = cdf.partition_point(|&x| x <= first).min(last);
            for k in ks {
                let target = (k as f64 + u0) / n as f64;
                while t < last && (cdf[t] <= target || areas[t] == 0.0) {
                    t += 1;
                }
                out.push(t as u32);
            }
            out
        })
        .collect();
    crate::disjoint::concat(parts)
}

/// Point `k` of `stratified`: uniform in its triangle `tri_of[k]` from
/// the stream `Pcg32(seed, k)`, so any one point can be made again alone
/// (blue noise keeps only its candidates' positions, and makes the
/// points it keeps again).
fn sample_at(m: &TriMesh, tri_of: &[u32], k: usize, seed: u64) -> Sample {
    let mut r = Pcg32::new(seed, k as u64);
    let w = geom::sample_triangle(uniform53(&mut r), uniform53(&mut r));
    let t = tri_of[k];
    let [a, b, c] = m.tri(t as usize);
    Sample {
        p: geom::blend(w, a, b, c),
        tri: t,
        w,
    }
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
/// always the mesh's area (`total`).
fn prim_area(m: &TriMesh, areas: &[f64], total: f64, samples: &[Sample]) -> Vec<f32> {
    let per: Vec<AtomicU32> = (0..areas.len()).map(|_| AtomicU32::new(0)).collect();
    samples.par_iter().for_each(|s| {
        per[s.tri as usize].fetch_add(1, Ordering::Relaxed);
    });
    let per: Vec<u32> = per.into_iter().map(AtomicU32::into_inner).collect();
    let mut acc: Vec<f64> = samples
        .par_iter()
        .map(|s| areas[s.tri as usize] / per[s.tri as usize] as f64)
        .collect();
    let empty: Vec<usize> = (0..areas.len())
        .into_par_iter()
        .filter(|&t| per[t] == 0 && areas[t] > 0.0)
        .collect();
    if !empty.is_empty() && !samples.is_empty() {
        // Cells of 2 spacings, which answer at once the centroids with a
        // point within one spacing: on blue noise all but a few in ten
        // thousand, on random points all but a few in a hundred; narrower
        // cells cost random points time, and a k-d tree is slower
        // (benches/results/HISTORY.md, "Measurements behind the code").
        let pos: Vec<DVec3> = samples.par_iter().map(|s| s.p).collect();
        let grid = PointGrid::new(&pos, 2.0 * hex_spacing(total, samples.len()));
        drop(pos);
        let centroids: Vec<DVec3> = empty
            .par_iter()
            .map(|&t| {
                let [a, b, c] = m.tri(t);
                (a + b + c) / 3.0
            })
            .collect();
        let owner = grid.nearest(&centroids);
        for (&t, s) in empty.iter().zip(owner) {
            if let Some(s) = s {
                acc[grid.order()[s as usize] as usize] += areas[t];
            }
        }
    }
    acc.into_iter().map(|a| a as f32).collect()
}

/// Spacing of `n` points on `area` in a hexagonal lattice: the largest
/// distance `n` points on that area can all keep from each other.
pub fn hex_spacing(area: f64, n: usize) -> f64 {
    (2.0 * area / (3f64.sqrt() * n as f64)).sqrt()
}

/// How evenly points are spread: each point's distance to its nearest
/// other point, over the hexagonal spacing of as many points on `area`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spacing {
    /// Mean (1 in a hexagonal lattice, about 0.5 for random points).
    pub mean: f64,
    /// Smallest (0.75 and more for a good Poisson-disk set).
    pub min: f64,
    /// Coefficient of variation: standard deviation over mean.
    pub cv: f64,
}

/// The nearest-neighbour statistics of `positions` on a surface of area
/// `area` (at least two points).
pub fn spacing(positions: &[DVec3], area: f64) -> Spacing {
    let n = positions.len();
    if n < 2 {
        return Spacing {
            mean: f64::NAN,
            min: f64::NAN,
            cv: f64::NAN,
        };
    }
    let tree = PointTree::new(positions.iter().copied(), positions[0]);
    let d: Vec<f64> = positions
        .par_iter()
        .map(|&q| {
            tree.nearest(q, 2)
                .last()
                .map_or(0.0, |nb| nb.distance.sqrt())
        })
        .collect();
    let h = hex_spacing(area, n);
    let mean = d.iter().copied().collect::<Sum>().value() / n as f64;
    let var = d
        .iter()
        .map(|x| (x - mean) * (x - mean))
        .collect::<Sum>()
        .value()
        / n as f64;
    Spacing {
        mean: mean / h,
        min: d.iter().copied().fold(f64::INFINITY, f64::min) / h,
        cv: var.sqrt() / mean,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;

    #[test]
    fn stratified_triangles_in_chunks_are_the_serial_walks() {
        // The walk all in one, as the chunks must reproduce it.
        let serial = |cdf: &[f64], areas: &[f64], n: usize, u0: f64| -> Vec<u32> {
            let last = areas.iter().rposition(|&a| a > 0.0).unwrap();
            let mut t = 0usize;
            (0..n)
                .map(|k| {
                    let target = (k as f64 + u0) / n as f64;
                    while t < last && (cdf[t] <= target || areas[t] == 0.0) {
                        t += 1;
                    }
                    t as u32
                })
                .collect()
        };
        let mut g = Pcg32::new(11, 3);
        for tris in [1usize, 7, 1000, 300_000] {
            // Zero areas first, last and in runs between; a few huge.
            let mut areas: Vec<f64> = (0..tris)
                .map(|i| match g.next_u32() % 10 {
                    _ if tris > 1 && (i == 0 || i + 1 == tris) => 0.0,
                    0..=2 => 0.0,
                    3 => 1e3,
                    _ => (g.next_u32() % 1000) as f64 * 1e-3,
                })
                .collect();
            if areas.iter().all(|&a| a == 0.0) {
                areas[tris / 2] = 1.0;
            }
            let total: f64 = areas.iter().sum();
            let mut acc = 0.0;
            let cdf: Vec<f64> = areas
                .iter()
                .map(|&a| {
                    acc += a;
                    acc / total
                })
                .collect();
            for n in [1usize, 5, (1 << 16) - 1, (1 << 16) + 3, 3 * (1 << 16) + 17] {
                for u0 in [0.0, 0.37, 0.999_999] {
                    assert_eq!(
                        stratified_tris(&cdf, &areas, n, u0),
                        serial(&cdf, &areas, n, u0),
                        "{tris} triangles, {n} points, u0 {u0}"
                    );
                }
            }
        }
    }
}
