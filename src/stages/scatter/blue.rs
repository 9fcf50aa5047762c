//! Blue noise by weighted sample elimination (Yuksel, "Sample Elimination
//! for Generating Poisson Disk Sample Sets", Eurographics 2015): of `M`
//! candidates on the surface keep `N` by removing, one at a time, the
//! candidate most crowded by the others still there.
//!
//! A candidate's crowding is the sum over the others within `d_max` of
//! `(1 - d / d_max)^8`, with `d_max` the spacing of `N` points in a
//! hexagonal lattice on the area (the largest Poisson-disk diameter `N`
//! points can have) and `d` held at or above
//! `d_min = d_max * 0.65 * (1 - (N / M)^1.5)` (the paper's weight
//! limiting: pairs closer than that are all equally bad, so a tight pair
//! does not decide alone where the gaps open). Removing a candidate lowers
//! its neighbours' crowding by their pair's term; the next to go is the
//! most crowded left. Distances are straight
//! lines in space, as the paper does on surfaces.
//!
//! Cost: the pairs within `d_max` are found once on a grid (about
//! `3.6 M / N` a candidate), in parallel; the elimination is a
//! serial loop over a bucket queue (crowding in 65,536 levels of the
//! largest; within a level the later candidate goes first), where a
//! binary heap spent 12 s on a million points re-sorting its neighbours
//! after every removal. Everything runs in a fixed order, so the result
//! does not depend on the thread count.

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::geom::grid::PointGrid;

/// The crowding exponent (the paper's alpha).
const ALPHA: i32 = 8;
/// Weight limiting: `d_min` is `BETA * (1 - (N/M)^GAMMA)` of `d_max`.
const BETA: f64 = 0.65;
const GAMMA: f64 = 1.5;
/// Levels of the elimination's bucket queue.
const BUCKETS: usize = 1 << 16;
/// Grid cells handled by one task.
const CELLS_PER_TASK: usize = 64;

/// A neighbour within `d_max` and the pair's crowding term.
#[derive(Clone, Copy, Debug, Default)]
struct Pair {
    other: u32,
    w: f32,
}

/// Of the candidates `cand` (points on a surface of area `area`) keeps
/// `n`: their indices, ascending. `param` names the option that asked
/// for the count, for the error when the pairs would not fit in memory.
pub fn eliminate(
    cand: &[DVec3],
    n: usize,
    area: f64,
    param: &str,
    progress: &crate::progress::Progress,
) -> Result<Vec<u32>> {
    let mut ph = progress.phases("scatter blue");
    let m = cand.len();
    if n >= m {
        return Ok((0..m as u32).collect());
    }
    if n == 0 {
        return Ok(Vec::new());
    }
    let d_max = super::hex_spacing(area, n);
    let d_min = d_max * BETA * (1.0 - (n as f64 / m as f64).powf(GAMMA));
    // Cells of twice the reach (`PointGrid::scan`).
    let grid = PointGrid::new(cand, 2.0 * d_max);
    ph.mark("grid");
    let tasks: Vec<Range<usize>> = (0..grid.cells())
        .step_by(CELLS_PER_TASK)
        .map(|c| c..(c + CELLS_PER_TASK).min(grid.cells()))
        .collect();
    // Each task's pairs, candidate by candidate in grid order, and how
    // many each candidate has. Grown with `try_reserve`: a surface folded
    // onto itself many times has far more pairs than the usual few per
    // candidate, and running out of memory is an error, not an abort.
    let found: Vec<Option<(Vec<u32>, Vec<Pair>)>> = tasks
        .par_iter()
        .map(|cells| {
            let mut counts = Vec::new();
            let mut out: Vec<Pair> = Vec::new();
            let mut near = Vec::with_capacity(64);
            let mut full = false;
            grid.scan(cells.clone(), d_max, &mut near, |_, near| {
                if full || out.try_reserve(near.len()).is_err() {
                    full = true;
                    return;
                }
                out.extend(near.iter().map(|&(t, d2)| {
                    let d = d2.sqrt().max(d_min);
                    Pair {
                        other: t,
                        w: (1.0 - d / d_max).powi(ALPHA) as f32,
                    }
                }));
                counts.push(near.len() as u32);
            });
            (!full).then_some((counts, out))
        })
        .collect();
    let too_big = || {
        crate::error::Error::param(
            param,
            format!("blue noise from {m} candidates needs more memory for their pairs than can be allocated here (a surface folded onto itself?)"),
        )
    };
    let mut offsets = Vec::with_capacity(m + 1);
    offsets.push(0usize);
    let mut total = 0usize;
    for f in &found {
        let (counts, _) = f.as_ref().ok_or_else(too_big)?;
        for &c in counts {
            total += c as usize;
            offsets.push(total);
        }
    }
    let mut pairs: Vec<Pair> = Vec::new();
    pairs.try_reserve_exact(total).map_err(|_| too_big())?;
    for (_, out) in found.into_iter().flatten() {
        pairs.extend_from_slice(&out);
    }
    ph.mark("pairs");
    let mut crowd: Vec<f64> = (0..m)
        .into_par_iter()
        .map(|s| {
            pairs[offsets[s]..offsets[s + 1]]
                .iter()
                .map(|p| p.w as f64)
                .sum()
        })
        .collect();
    // A bucket queue: crowding quantised to BUCKETS levels of the
    // largest, each level a stack. Crowding only falls, so an entry found
    // above its candidate's level is stale: it moves down and the search
    // goes on; the top level never rises.
    let wmax = crowd.iter().copied().fold(0.0, f64::max);
    let scale = if wmax > 0.0 {
        (BUCKETS - 1) as f64 / wmax
    } else {
        0.0
    };
    let level = |w: f64| ((w * scale) as usize).min(BUCKETS - 1);
    let mut buckets: Vec<Vec<u32>> = vec![Vec::new(); BUCKETS];
    for (s, &w) in crowd.iter().enumerate() {
        buckets[level(w)].push(s as u32);
    }
    ph.mark("queue");
    // A removed candidate's crowding is DEAD: one array read tells both.
    const DEAD: f64 = f64::NEG_INFINITY;
    let mut left = m;
    let mut top = BUCKETS - 1;
    while left > n {
        let Some(s) = buckets[top].pop() else {
            top -= 1;
            continue;
        };
        let s = s as usize;
        let b = level(crowd[s]);
        if b < top {
            buckets[b].push(s as u32);
            continue;
        }
        crowd[s] = DEAD;
        left -= 1;
        for p in &pairs[offsets[s]..offsets[s + 1]] {
            // DEAD stays DEAD.
            crowd[p.other as usize] -= p.w as f64;
        }
    }
    ph.mark("eliminate");
    let mut kept: Vec<u32> = (0..m)
        .filter(|&s| crowd[s] != DEAD)
        .map(|s| grid.order()[s])
        .collect();
    kept.sort_unstable();
    Ok(kept)
}
