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
//! `ptarea`:
//! - `prim`: a triangle's area shared equally by its points; sums to the
//!   mesh area exactly.
//! - `knn`: `pi r_k^2 / k` from the distance `r_k` to the k-th nearest
//!   other point (k = 8): follows local density; needs `promote
//!   --normalize` to sum to `Tarea`.

use glam::DVec3;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;
use rand_core::RngCore;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use crate::cloud::{Cloud, Role};
use crate::column::ScalarType;
use crate::error::{Error, Result};
use crate::geom::{self, Sum};
use crate::mesh::TriMesh;

/// How `ptarea` is estimated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PtareaMode {
    Prim,
    Knn,
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
            format!("{density} is not a finite number >= 0"),
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

/// A uniform number in [0, 1) with 53 random bits.
#[inline]
fn uniform(r: &mut Pcg32) -> f64 {
    let hi = (r.next_u32() >> 5) as u64;
    let lo = (r.next_u32() >> 6) as u64;
    ((hi << 26) | lo) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// Scatters points on `mesh` (a cloud with faces).
pub fn scatter(mesh: &Cloud, p: &Params) -> Result<Cloud> {
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
    let u0 = uniform(&mut Pcg32::new(p.seed, u64::MAX));
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
    let samples: Vec<(DVec3, [f64; 3])> = (0..n)
        .into_par_iter()
        .map(|k| {
            let mut r = Pcg32::new(p.seed, k as u64);
            let w = geom::sample_triangle(uniform(&mut r), uniform(&mut r));
            let [a, b, c] = m.tri(tri_of[k] as usize);
            (geom::blend(w, a, b, c), w)
        })
        .collect();
    let ptarea: Vec<f32> = match p.ptarea {
        PtareaMode::Prim => {
            let mut per = vec![0u32; areas.len()];
            tri_of.iter().for_each(|&t| per[t as usize] += 1);
            tri_of
                .iter()
                .map(|&t| (areas[t as usize] / per[t as usize] as f64) as f32)
                .collect()
        }
        PtareaMode::Knn => knn_area(&samples.iter().map(|s| s.0).collect::<Vec<_>>(), total),
    };
    let mut cloud = Cloud::with_points(n);
    cloud.detail = mesh.detail.clone();
    let pts = cloud.points_mut();
    let f64_positions = mesh.points().vec3_columns("P")?[0].ty() == ScalarType::F64;
    if f64_positions {
        pts.set_vec3(
            "P",
            Role::Point,
            &samples.iter().map(|s| s.0.to_array()).collect::<Vec<_>>(),
        )?;
    } else {
        let rows: Vec<[f32; 3]> = samples.iter().map(|s| s.0.as_vec3().to_array()).collect();
        pts.set_vec3("P", Role::Point, &rows)?;
    }
    pts.set_scalar("ptarea", ptarea)?;
    pts.set_scalar(
        "sourceprim",
        tri_of
            .iter()
            .map(|&t| tri_face[t as usize] as i32)
            .collect(),
    )?;
    let uv: Vec<[f32; 3]> = samples
        .iter()
        .map(|s| [s.1[1] as f32, s.1[2] as f32, 0.0])
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
    let o = pos[0];
    let rel: Vec<[f64; 3]> = pos.iter().map(|p| (*p - o).to_array()).collect();
    let tree: ImmutableKdTree<f64, u32, 3, 32> = ImmutableKdTree::new_from_slice(&rel);
    let nk = std::num::NonZero::new(k + 1).expect("k + 1 > 0");
    rel.par_iter()
        .map(|q| {
            let near = tree.nearest_n::<SquaredEuclidean>(q, nk);
            let r2 = near.last().map_or(0.0, |nb| nb.distance);
            (std::f64::consts::PI * r2 / k as f64) as f32
        })
        .collect()
}
