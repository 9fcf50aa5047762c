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
//!   `tau` spacings moves 0.8 of the shortfall away from the other,
//!   tangentially, so that the straight distance becomes `tau` (a pair
//!   across a thin part of the mesh separates too). Relaxation leaves a
//!   tail of close pairs where the density has not evened out yet (a few
//!   in ten thousand below 0.6 spacings after 4 iterations); rounds until
//!   no point moves remove it without moving the points that have room.
//!   After the first round only the points near a mover are looked at (a
//!   third of the points, then fewer each round), with the same result.
//!
//! A relaxation round moves each point as its neighbours are found on a
//! grid (`geom::grid`): points move up to half a spacing a round, so
//! lists of neighbours would not outlast one. The last relaxation round
//! before separation, and the separation rounds, use Verlet lists: every
//! point's neighbours within the reach plus a skin (0.3 spacings for
//! relaxation, 0.5 for separation), kept until some point has moved half
//! the skin since (then no pair can have come within the reach unseen).
//! Points are kept in the grid's (Morton) order, so a point's neighbours
//! sit near it in memory.

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
/// The step for a unit force, in reaches (on a sphere, gains from 0.7 up
/// oscillate).
const GAIN: f64 = 0.5;
/// The longest step, in spacings.
const MAX_STEP: f64 = 0.5;
/// The Verlet lists' skin, in spacings: relaxation moves points up to
/// half a spacing a round, so its lists seldom outlast a round and have
/// none, but the last round's, which the separation rounds go on with
/// (their reach is shorter: 0.8 spacings and this skin leave them 0.5 of
/// slack); separation moves points a few hundredths, and a wider skin
/// lets its lists last several rounds.
const SKIN: f64 = 0.3;
const SEPARATE_SKIN: f64 = 0.5;
/// A separation round moves each point of a close pair this part of the
/// pair's shortfall: 0.5 would close an isolated pair's in one round, but
/// most close pairs have other close neighbours pushing back, and the
/// larger push settles them in fewer rounds with a wider closest pair
/// (benches/results/HISTORY.md, "Measurements behind the code").
const SEPARATE_PUSH: f64 = 0.8;
/// A shortfall under this many spacings is not pushed.
const SEPARATE_TOL: f64 = 1e-3;

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
    let pos: Vec<DVec3> = samples.par_iter().map(|s| s.p).collect();
    let grid = PointGrid::new(&pos, 2.0 * r);
    let (start, other) = grid.near_lists(r);
    let order = grid.order();
    *samples = order.par_iter().map(|&i| samples[i as usize]).collect();
    Lists {
        start,
        other,
        at: order.par_iter().map(|&i| pos[i as usize]).collect(),
    }
}

/// `relax` relaxation iterations, then up to `separate` separation rounds
/// at `tau` spacings, on `samples` (points on `m`, whose adjacency is
/// `adj`, of total area `total`); the points come back in another order.
#[allow(clippy::too_many_arguments)]
pub(super) fn polish(
    m: &TriMesh,
    adj: &Adjacency,
    samples: &mut Vec<Sample>,
    relax: u32,
    separate: u32,
    tau: f64,
    seed: u64,
    total: f64,
    progress: &Progress,
) {
    polish_with(
        m, adj, samples, relax, separate, tau, seed, total, progress, true,
    )
}

/// `polish`, where `sparse: false` looks at every point in every
/// separation round (to test that looking only near the movers changes
/// nothing).
#[allow(clippy::too_many_arguments)]
fn polish_with(
    m: &TriMesh,
    adj: &Adjacency,
    samples: &mut Vec<Sample>,
    relax: u32,
    separate: u32,
    tau: f64,
    seed: u64,
    total: f64,
    progress: &Progress,
    sparse: bool,
) {
    let n = samples.len();
    if n < 2 || m.tris.is_empty() || relax + separate == 0 {
        return;
    }
    let mut ph = progress.phases("scatter polish");
    let normals: Vec<DVec3> = (0..m.tris.len())
        .into_par_iter()
        .map(|t| {
            let [a, b, c] = adj.tri(t);
            geom::unit_or_zero(geom::tri_cross(a, b, c))
        })
        .collect();
    let d = hex_spacing(total, n);
    ph.mark("normals");
    // The move of sample `s` (index `i`) for a force from the
    // neighbours `near`, or None if it stays.
    let step_of =
        |cur: &[Sample], near: &[u32], i: usize, round: u32, relaxing: bool, reach: f64| {
            let s = cur[i];
            let q = s.p;
            let nrm = normals[s.tri as usize];
            let mut f = DVec3::ZERO;
            for &t in near {
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
                        // Coincident points (pushed onto the same edge or
                        // corner): apart along a direction of their own.
                        let mut g = Pcg32::new(seed ^ (round as u64) << 32, i as u64);
                        DVec3::new(uniform53(&mut g), uniform53(&mut g), uniform53(&mut g)) - 0.5
                    };
                    let x = 1.0 - r / reach;
                    f += dir * (x * x);
                } else {
                    // Apart in the tangent plane until the straight distance
                    // is `reach`: across a thin part of the mesh only a
                    // tangential offset can help. A shortfall under
                    // SEPARATE_TOL is left: re-projection onto a curved
                    // surface would otherwise keep pairs at `reach` moving
                    // by rounding-sized steps for ever.
                    let g = d3.dot(nrm);
                    let tv = d3 - nrm * g;
                    let s0 = tv.length();
                    if s0 > 1e-9 * d {
                        let s1 = (reach * reach - g * g).max(0.0).sqrt();
                        if s1 - s0 > SEPARATE_TOL * d {
                            f += tv / s0 * (SEPARATE_PUSH * (s1 - s0));
                        }
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
                return None;
            }
            let (t, w) = adj.walk(s.tri as usize, s.p + step);
            let [a, b, c] = adj.tri(t);
            Some(Sample {
                p: geom::blend(w, a, b, c),
                tri: t as u32,
                w,
            })
        };
    let mut list: Option<(Lists, f64)> = None;
    // Lists that reach past `reach` by twice as far as any point has
    // moved since they were made, else new ones.
    let refresh =
        |list: &mut Option<(Lists, f64)>, samples: &mut Vec<Sample>, reach: f64, skin: f64| {
            let fresh = list.as_ref().is_some_and(|(l, r)| {
                let slack = 0.5 * (*r - reach);
                slack > 0.0
                    && samples
                        .par_iter()
                        .zip(&l.at)
                        .all(|(s, a)| (s.p - *a).length_squared() <= slack * slack)
            });
            if !fresh {
                *list = Some((lists(samples, reach + skin), reach + skin));
            }
            !fresh
        };
    for round in 0..relax {
        let reach = REACH * d;
        let moved: Vec<Sample> = if round + 1 == relax && separate > 0 {
            // The last round's lists, with a skin, serve the separation
            // rounds that follow.
            refresh(&mut list, samples, reach, SKIN * d);
            ph.mark("relax lists");
            let l = &list.as_ref().expect("made above").0;
            let cur: &[Sample] = samples;
            (0..n)
                .into_par_iter()
                .map(|i| {
                    let near = &l.other[l.start[i]..l.start[i + 1]];
                    step_of(cur, near, i, round, true, reach).unwrap_or(cur[i])
                })
                .collect()
        } else {
            // Points move up to half a spacing a round, so lists would
            // not outlast it: each point moves as its neighbours are
            // found in a grid.
            let pos: Vec<DVec3> = samples.par_iter().map(|s| s.p).collect();
            let grid = PointGrid::new(&pos, 2.0 * reach);
            drop(pos);
            let sorted: Vec<Sample> = grid
                .order()
                .par_iter()
                .map(|&i| samples[i as usize])
                .collect();
            ph.mark("relax grid");
            grid.map_near(reach, Vec::new, |ids: &mut Vec<u32>, i, near| {
                ids.clear();
                ids.extend(near.iter().map(|&(t, _)| t));
                step_of(&sorted, ids, i, round, true, reach).unwrap_or(sorted[i])
            })
        };
        *samples = moved;
        ph.mark("relax moves");
        progress.inc(1);
    }
    // Separation rounds move few points after the first (pairs closer
    // than `tau` and the points they run into), so each round looks only
    // at the points that moved in the last one and those within `tau` of
    // where a mover was or is: the others' forces are what they were, 0.
    // The result is the same as moving every point every round.
    let reach = tau * d;
    let mut active: Option<Vec<u32>> = None;
    for round in relax..relax + separate {
        // Only the movers can have made the lists stale.
        let check = !sparse
            || active.is_none()
            || list.as_ref().is_some_and(|(l, r)| {
                let slack = 0.5 * (*r - reach);
                active.as_ref().expect("checked").par_iter().any(|&i| {
                    (samples[i as usize].p - l.at[i as usize]).length_squared() > slack * slack
                })
            });
        if check && refresh(&mut list, samples, reach, SEPARATE_SKIN * d) {
            // New lists come in a new order: start again from all.
            active = None;
        }
        let l = &list.as_ref().expect("made above").0;
        let cur: &[Sample] = samples;
        let movers: Vec<(u32, Sample)> = match &active {
            None => (0..n as u32)
                .into_par_iter()
                .filter_map(|i| {
                    let near = &l.other[l.start[i as usize]..l.start[i as usize + 1]];
                    step_of(cur, near, i as usize, round, false, reach).map(|s| (i, s))
                })
                .collect(),
            Some(a) => a
                .par_iter()
                .filter_map(|&i| {
                    let near = &l.other[l.start[i as usize]..l.start[i as usize + 1]];
                    step_of(cur, near, i as usize, round, false, reach).map(|s| (i, s))
                })
                .collect(),
        };
        let mut next: Vec<u32> = movers
            .par_iter()
            .flat_map_iter(|&(i, new)| {
                let old = cur[i as usize].p;
                l.other[l.start[i as usize]..l.start[i as usize + 1]]
                    .iter()
                    .copied()
                    .filter(move |&t| {
                        let p = cur[t as usize].p;
                        (p - old).length_squared() < reach * reach
                            || (p - new.p).length_squared() < reach * reach
                    })
                    .chain(std::iter::once(i))
            })
            .collect();
        next.par_sort_unstable();
        next.dedup();
        let settled = movers.is_empty();
        for (i, s) in movers {
            samples[i as usize] = s;
        }
        active = sparse.then_some(next);
        ph.mark("separate");
        progress.inc(1);
        if settled {
            // No pair closer than `tau` by more than SEPARATE_TOL: later
            // rounds would move nothing either.
            break;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::formats;

    /// Random points on a sphere of 1,280 triangles, sorted the way
    /// `polish` leaves them.
    fn random_on_sphere(n: usize) -> (TriMesh, Vec<Sample>, f64) {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/fixtures/mesh/icosphere3.obj");
        // (The OBJ reader alone: the generic reader would build every
        // format's into this test harness.)
        let file = std::fs::File::open(path).expect("the fixture opens");
        let cloud =
            formats::obj::read_obj(std::io::BufReader::new(file)).expect("the fixture reads");
        let m = TriMesh::from_cloud(&cloud).expect("a mesh");
        let areas = m.tri_areas();
        let total: f64 = areas.iter().sum();
        let mut acc = 0.0;
        let cdf: Vec<f64> = areas
            .iter()
            .map(|a| {
                acc += a;
                acc / total
            })
            .collect();
        let samples = super::super::stratified(&m, &cdf, &areas, n, 0.37, 5);
        (m, samples, total)
    }

    #[test]
    fn separation_near_the_movers_equals_separation_of_every_point() {
        let (m, start, total) = random_on_sphere(4000);
        for (relax, separate) in [(0, 12), (2, 12), (1, 30)] {
            let mut full = start.clone();
            let mut sparse = start.clone();
            let quiet = Progress::hidden();
            let adj = Adjacency::new(&m);
            polish_with(
                &m, &adj, &mut full, relax, separate, 0.8, 3, total, &quiet, false,
            );
            polish_with(
                &m,
                &adj,
                &mut sparse,
                relax,
                separate,
                0.8,
                3,
                total,
                &quiet,
                true,
            );
            let was: std::collections::HashSet<[u64; 3]> = start
                .iter()
                .map(|s| s.p.to_array().map(f64::to_bits))
                .collect();
            let moved = full
                .iter()
                .filter(|s| !was.contains(&s.p.to_array().map(f64::to_bits)))
                .count();
            assert!(moved > 1000, "many points move ({moved})");
            for (i, (a, b)) in full.iter().zip(&sparse).enumerate() {
                assert_eq!(
                    (a.p, a.tri, a.w),
                    (b.p, b.tri, b.w),
                    "point {i} after {relax} + {separate} rounds"
                );
            }
        }
    }
}
