//! Moving points over the surface to even them out, in rounds that each
//! move every point from the previous round's positions only (Jacobi), so
//! the result does not depend on the thread count. Each move is made in
//! the plane of the point's triangle and walked over the mesh from that
//! triangle (`Adjacency::walk`: a few triangles, where a closest-point
//! query from scratch would search the whole mesh).
//!
//! Two kinds of round:
//! - relaxation (the Scatter SOP's relax iterations, Turk's re-tiling by
//!   repulsion): away from the neighbours closer than `1.5` spacings, with
//!   a force `(1 - r / R)^2` each, a step of half the reach for a unit
//!   force, at most half a spacing;
//! - separation (`--blue`'s last rounds): each point of a pair closer than
//!   `tau` spacings moves half the shortfall away from the other,
//!   tangentially, so that the straight distance becomes `tau` (a pair
//!   across a thin part of the mesh separates too). Relaxation leaves a
//!   tail of close pairs where the density has not evened out yet (a few
//!   in ten thousand below 0.6 spacings after 4 iterations); 12 rounds remove
//!   it without moving the points that have room.
//!
//! Neighbours come from Verlet lists: every point's neighbours within the
//! reach plus a skin (0.3 spacings for relaxation, 0.5 for separation),
//! found on a grid (`geom::grid`) and kept until some point has moved half
//! the skin since (then no pair can have come within the reach unseen). Points are kept in the grid's
//! (Morton) order, so a point's neighbours sit near it in memory.

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
/// The longest step, in spacings.
const MAX_STEP: f64 = 0.5;
/// The Verlet lists' skin, in spacings: relaxation moves points up to
/// half a spacing a round, so its lists last a round or two whatever the
/// skin; separation moves them a few hundredths, and a wider skin lets
/// its lists last several rounds.
const SKIN: f64 = 0.3;
const SEPARATE_SKIN: f64 = 0.5;

/// Neighbour lists of points in their own order: point `i`'s are
/// `other[start[i]..start[i + 1]]`.
struct Lists {
    start: Vec<usize>,
    other: Vec<u32>,
    /// Positions when the lists were made.
    at: Vec<DVec3>,
}

/// Sorts `samples` into the grid's order and lists each one's
/// neighbours within `r`.
fn lists(samples: &mut Vec<Sample>, r: f64) -> Lists {
    let pos: Vec<DVec3> = samples.iter().map(|s| s.p).collect();
    let grid = PointGrid::new(&pos, 2.0 * r);
    let (start, other) = grid.near_lists(r);
    *samples = grid.order().iter().map(|&i| samples[i as usize]).collect();
    Lists {
        start,
        other,
        at: samples.iter().map(|s| s.p).collect(),
    }
}

/// `relax` relaxation iterations, then `separate` separation rounds at
/// `tau` spacings, on `samples` (points on `m`, of total area `total`);
/// the points come back in another order.
#[allow(clippy::too_many_arguments)]
pub(super) fn polish(
    m: &TriMesh,
    samples: &mut Vec<Sample>,
    relax: u32,
    separate: u32,
    tau: f64,
    seed: u64,
    total: f64,
    progress: &Progress,
) {
    let n = samples.len();
    if n < 2 || m.tris.is_empty() || relax + separate == 0 {
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
    let mut list: Option<(Lists, f64)> = None;
    for round in 0..relax + separate {
        let relaxing = round < relax;
        let (reach, skin) = if relaxing {
            (REACH * d, SKIN * d)
        } else {
            (tau * d, SEPARATE_SKIN * d)
        };
        // Lists that reach past this round's reach by twice as far as any
        // point has moved since they were made.
        let fresh = list.as_ref().is_some_and(|(l, r)| {
            let slack = 0.5 * (*r - reach);
            slack > 0.0
                && samples
                    .par_iter()
                    .zip(&l.at)
                    .all(|(s, a)| (s.p - *a).length_squared() <= slack * slack)
        });
        if !fresh {
            list = Some((lists(samples, reach + skin), reach + skin));
        }
        let l = &list.as_ref().expect("made above").0;
        let cur: &[Sample] = samples;
        let moved: Vec<Sample> = (0..n)
            .into_par_iter()
            .map(|i| {
                let s = cur[i];
                let q = s.p;
                let nrm = normals[s.tri as usize];
                let mut f = DVec3::ZERO;
                for &t in &l.other[l.start[i]..l.start[i + 1]] {
                    let d3 = q - cur[t as usize].p;
                    let r2 = d3.length_squared();
                    if r2 >= reach * reach {
                        continue;
                    }
                    if relaxing {
                        let r = r2.sqrt();
                        let dir = if r > 1e-9 * d {
                            d3 / r
                        } else {
                            // Coincident points (pushed onto the same edge
                            // or corner): apart along a direction of their
                            // own.
                            let mut g = Pcg32::new(seed ^ (round as u64) << 32, i as u64);
                            DVec3::new(uniform53(&mut g), uniform53(&mut g), uniform53(&mut g))
                                - 0.5
                        };
                        let x = 1.0 - r / reach;
                        f += dir * (x * x);
                    } else {
                        // Apart in the tangent plane until the straight
                        // distance is `reach`: across a thin part of the
                        // mesh only a tangential offset can help.
                        let g = d3.dot(nrm);
                        let tv = d3 - nrm * g;
                        let s0 = tv.length();
                        if s0 > 1e-9 * d {
                            let s1 = (reach * reach - g * g).max(0.0).sqrt();
                            f += tv / s0 * (0.5 * (s1 - s0).max(0.0));
                        }
                    }
                }
                let mut step = f - nrm * f.dot(nrm);
                if relaxing {
                    step *= GAIN * reach;
                }
                let len = step.length();
                if len > MAX_STEP * d {
                    step *= MAX_STEP * d / len;
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
            })
            .collect();
        *samples = moved;
        progress.inc(1);
    }
}
