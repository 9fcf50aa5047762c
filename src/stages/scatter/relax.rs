//! Relaxation (the Scatter SOP's relax iterations, Turk's re-tiling by
//! repulsion): every iteration moves each point away from its neighbours
//! closer than `R = 1.5 * spacing`, in its triangle's plane, by at most
//! half the spacing, then walks it over the mesh from its own triangle to
//! where the move ends (`Adjacency::walk`: a few triangles, where a
//! closest-point query from scratch would search the whole mesh).
//! Neighbours come from a grid of `R` cells rebuilt each iteration. Moves
//! are computed from the previous iteration's positions only (Jacobi), so
//! the result does not depend on the thread count.

use glam::DVec3;
use rand_pcg::Pcg32;
use rayon::prelude::*;

use super::{hex_spacing, Sample};
use crate::geom::grid::PointGrid;
use crate::geom::mesh::{Adjacency, TriMesh};
use crate::geom::{self};
use crate::maths::uniform53;
use crate::progress::Progress;

/// The reach of the repulsion, in spacings.
const REACH: f64 = 1.5;
/// The step for a unit force, in reaches (measured on a sphere: gains
/// from 0.7 up oscillate).
const GAIN: f64 = 0.5;
/// Grid cells, in reaches: larger cells cost more distance tests but
/// fewer cell lookups, which cost more (measured: 4 twice as fast as 2).
const CELL: f64 = 4.0;
/// The longest step, in spacings.
const MAX_STEP: f64 = 0.5;

/// `iters` iterations on `samples` (points on `m`, of total area `total`).
pub(super) fn relax(
    m: &TriMesh,
    samples: &mut Vec<Sample>,
    iters: u32,
    seed: u64,
    total: f64,
    progress: &Progress,
) {
    let n = samples.len();
    if n < 2 || m.tris.is_empty() {
        return;
    }
    let adj = Adjacency::new(m);
    let normals: Vec<DVec3> = (0..m.tris.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = m.tri(t);
            geom::unit_or_zero(geom::tri_cross(a, b, c))
        })
        .collect();
    let d = hex_spacing(total, n);
    let reach = REACH * d;
    let max_step = MAX_STEP * d;
    for it in 0..iters {
        let pos: Vec<DVec3> = samples.iter().map(|s| s.p).collect();
        let grid = PointGrid::new(&pos, CELL * reach);
        let moved = grid.map_near(reach, |k, near| {
            let i = grid.order()[k] as usize;
            let s = samples[i];
            let q = grid.rel()[k];
            let mut f = DVec3::ZERO;
            for &(t, r2) in near {
                let r = r2.sqrt();
                let dir = if r > 1e-9 * d {
                    (q - grid.rel()[t as usize]) / r
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
            let mut step = f * (GAIN * reach);
            let len = step.length();
            if len > max_step {
                step *= max_step / len;
            }
            if step == DVec3::ZERO {
                return s;
            }
            let (t, w) = adj.walk(m, s.tri as usize, s.p + step);
            let [a, b, c] = m.tri(t);
            Sample {
                p: geom::blend(w, a, b, c),
                tri: t as u32,
                w,
            }
        });
        // Kept in the grid's order: the next grid finds them nearly
        // sorted, and neighbours sit near each other in memory.
        *samples = moved;
        progress.inc(1);
    }
}

/// Pushes apart every pair of points closer than `tau` hexagonal
/// spacings: each point of such a pair moves half the shortfall away from
/// the other (summed over its close pairs, at most half the spacing), in
/// its triangle's plane, and walks there; `iters` rounds, each from the
/// previous one's positions. Relaxation leaves a tail of close pairs
/// where the density has not evened out yet (a few in ten thousand
/// below 0.6 spacings after 4 iterations); this removes it without
/// moving the points that have room.
pub(super) fn separate(m: &TriMesh, samples: &mut Vec<Sample>, tau: f64, iters: u32, total: f64) {
    let n = samples.len();
    if n < 2 || m.tris.is_empty() {
        return;
    }
    let adj = Adjacency::new(m);
    let d = hex_spacing(total, n);
    let reach = tau * d;
    for _ in 0..iters {
        let pos: Vec<DVec3> = samples.iter().map(|s| s.p).collect();
        let grid = PointGrid::new(&pos, CELL * reach);
        let moved = grid.map_near(reach, |k, near| {
            let s = samples[grid.order()[k] as usize];
            let q = grid.rel()[k];
            let [a, b, c] = m.tri(s.tri as usize);
            let nrm = geom::unit_or_zero(geom::tri_cross(a, b, c));
            let mut f = DVec3::ZERO;
            for &(t, _) in near {
                // Apart in the tangent plane until the straight distance is
                // `reach`: across a thin part of the mesh (the other point
                // on the far side) only a tangential offset can help.
                let d3 = q - grid.rel()[t as usize];
                let g = d3.dot(nrm);
                let tv = d3 - nrm * g;
                let s0 = tv.length();
                if s0 > 1e-9 * d {
                    let s1 = (reach * reach - g * g).max(0.0).sqrt();
                    f += tv / s0 * (0.5 * (s1 - s0).max(0.0));
                }
            }
            if f == DVec3::ZERO {
                return s;
            }
            let len = f.length();
            if len > 0.5 * d {
                f *= 0.5 * d / len;
            }
            let (t, w) = adj.walk(m, s.tri as usize, s.p + f);
            let [a, b, c] = m.tri(t);
            Sample {
                p: geom::blend(w, a, b, c),
                tri: t as u32,
                w,
            }
        });
        *samples = moved;
    }
}
