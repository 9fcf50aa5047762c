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
//! most crowded left. Distances are straight lines in space, as the paper
//! does on surfaces. Pairs farther apart than `REACH d_max` are left out:
//! their terms are under 0.6% of the closest pair's (0.75 of `d_max`
//! against `d_min` = 0.53 of it at 3 candidates a point), the kept
//! points' spacing statistics do not change, and there are far fewer
//! pairs to find and update.
//!
//! Cost: each candidate's pairs (about `2 M / N` of them) are found on
//! a grid, block by block in parallel (`PointGrid::scan`), and written
//! into its block's lists, which stay where they were made. Finding each
//! pair from both ends makes twice the distance tests of finding it once,
//! but the one-ended way then had to spread the pairs to both ends' lists
//! through atomic cursors and sort them, with large arrays in between,
//! and was slower in all. The elimination works on the same blocks
//! of about 4,000 candidates (aligned cubes of grid cells,
//! `PointGrid::blocks`) in colour phases, the blocks of a colour in
//! parallel, each with its data in cache, down to 95% of the way to its
//! share of `N`; the last 5% of the removals go over all the candidates
//! at once, most crowded
//! first (`eliminate_serial`), so the counts can shift between blocks,
//! whose shares follow their candidates' counts. Without that tail the
//! spacing statistics do not change, but the ssmulti kernel error on the
//! sphere grows (benches/ssmulti.rs, accuracy); a twentieth keeps most of
//! what a tenth gives, for half its time. A single serial queue over all
//! the candidates spends its time in cache misses; the block elimination
//! leaves the same spacing statistics. The figures are in
//! benches/results/HISTORY.md, "Measurements behind the code".
//! Everything runs in a fixed order, so the result does not depend on
//! the thread count.

use glam::DVec3;
use rayon::prelude::*;

use crate::error::Result;
use crate::geom::grid::{Block, PointGrid};

/// The crowding exponent (the paper's alpha).
const ALPHA: i32 = 8;
/// Weight limiting: `d_min` is `BETA * (1 - (N/M)^GAMMA)` of `d_max`.
const BETA: f64 = 0.65;
const GAMMA: f64 = 1.5;
/// Pairs within this part of `d_max` count (see the module's notes).
const REACH: f64 = 0.75;
/// Levels of the serial elimination's bucket queue.
const BUCKETS: usize = 1 << 16;
/// Candidates per block of the elimination, about.
const BLOCK: usize = 4096;
/// Passes over the blocks, each taking every block a part of the way to
/// its share, in colour order (reversed on odd passes), so no block's
/// neighbours are always a pass ahead of it.
const PASSES: usize = 2;
/// Levels of a block's bucket queue.
const BLOCK_LEVELS: usize = 1 << 12;
/// The part of each block's removals made block by block (see the
/// module's notes).
const BLOCK_SHARE: f64 = 0.95;

/// A neighbour within the reach and the pair's crowding term, packed in
/// one word: the neighbour's index (sorted) above, the term's bits below.
#[derive(Clone, Copy)]
struct Pair(u64);

impl Pair {
    fn pack(other: u32, w: f32) -> Pair {
        Pair((other as u64) << 32 | w.to_bits() as u64)
    }

    fn get(self) -> (u32, f32) {
        ((self.0 >> 32) as u32, f32::from_bits(self.0 as u32))
    }
}

/// One block's candidates' neighbour lists: candidate `i` of the block
/// (sorted index `block.points.start + i`) has
/// `pairs[start[i]..start[i + 1]]`, and its crowding summed in that order
/// (moved out into one array before the elimination).
struct Lists {
    start: Vec<u32>,
    pairs: Vec<Pair>,
    crowd: Vec<f64>,
}

impl Lists {
    fn of(&self, i: usize) -> &[Pair] {
        &self.pairs[self.start[i] as usize..self.start[i + 1] as usize]
    }
}

/// Pairs reserved per candidate of a block before its scan: about 6 are
/// within the reach at three candidates a point on a flat surface
/// (`2 pi REACH^2 / sqrt(3)` times the candidates per point), so most
/// blocks never grow their list (the dragon at 1M uses 5.6 a candidate,
/// the bunny 6.1). With huge pages the unwritten tails are backed along
/// with the blocks written beside them, but 7 was no faster.
const PAIRS_RESERVED: usize = 8;

/// Of the candidates `cand` (points on a surface of area `area`) keeps
/// `n`: their indices, in the grid's (Morton) order, which keeps
/// neighbours near each other in memory for what follows. `param` names the parameter that
/// asked for the count, for the error when the pairs would not fit in memory.
pub fn eliminate(
    cand: Vec<DVec3>,
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
    let reach = REACH * d_max;
    // Cells of twice the reach (`PointGrid::scan`).
    let grid = PointGrid::new(&cand, 2.0 * reach);
    // The grid holds its own copy, in its order.
    drop(cand);
    ph.mark("grid");
    let blocks = grid.blocks(BLOCK);
    // Each block's lists, found in parallel block by block: every pair
    // twice, once from each end (twice the distance tests of finding it
    // once, but each list is written where it is kept, in an order that
    // does not depend on the threads, with no second pass to spread the
    // pairs). Grown with `try_reserve`: a surface folded onto itself many
    // times has far more pairs than the usual few per candidate, and
    // running out of memory is an error, not an abort.
    let lists: Vec<Option<Lists>> = blocks
        .par_iter()
        .map(|b| {
            let len = b.points.len();
            let mut l = Lists {
                start: Vec::with_capacity(len + 1),
                pairs: Vec::new(),
                crowd: Vec::with_capacity(len),
            };
            l.start.push(0);
            let mut near = Vec::with_capacity(64);
            let mut full = l.pairs.try_reserve(PAIRS_RESERVED * len).is_err();
            grid.scan(b.cells.clone(), reach, &mut near, |_, near| {
                if full
                    || l.pairs.len() + near.len() > u32::MAX as usize
                    || l.pairs.try_reserve(near.len()).is_err()
                {
                    full = true;
                    return;
                }
                let mut sum = 0.0;
                l.pairs.extend(near.iter().map(|&(t, d2)| {
                    let d = d2.sqrt().max(d_min);
                    let w = (1.0 - d / d_max).powi(ALPHA) as f32;
                    sum += w as f64;
                    Pair::pack(t, w)
                }));
                l.start.push(l.pairs.len() as u32);
                l.crowd.push(sum);
            });
            (!full).then_some(l)
        })
        .collect();
    ph.mark("pairs");
    let mut lists: Vec<Lists> = lists.into_iter().collect::<Option<_>>().ok_or_else(|| {
        crate::error::Error::param(
            param,
            format!("blue noise from {m} candidates needs more memory for their pairs than can be allocated here (a surface folded onto itself?)"),
        )
    })?;
    let mut crowd: Vec<f64> = crate::disjoint::concat(
        lists
            .iter_mut()
            .map(|l| std::mem::take(&mut l.crowd))
            .collect(),
    );
    ph.mark("crowding");
    let left = eliminate_blocks(&mut crowd, &lists, &blocks, n);
    ph.mark("blocks");
    eliminate_serial(&mut crowd, &lists, &blocks, left, n);
    ph.mark("serial");
    Ok((0..m)
        .into_par_iter()
        .filter(|&s| crowd[s] != DEAD)
        .map(|s| grid.order()[s])
        .collect())
}

/// A block's phase done: the block, its candidates left, and what its
/// removals take from candidates of other blocks.
type BlockDone = (usize, usize, Vec<(u32, f32)>);

/// A removed candidate's crowding: one array read tells both.
const DEAD: f64 = f64::NEG_INFINITY;

/// The first part of the elimination, in parallel: each block (see
/// `PointGrid::blocks`) removes, most crowded first, BLOCK_SHARE of the
/// candidates it would remove if it kept exactly its share of `n`, in
/// PASSES passes of 8 colour phases (blocks of one colour at the same
/// time, each alone in its cache; what a removal takes from a candidate
/// of another block is applied after the phase, in block order). Returns
/// how many candidates are left.
fn eliminate_blocks(crowd: &mut [f64], lists: &[Lists], blocks: &[Block], n: usize) -> usize {
    let sizes: Vec<usize> = blocks.iter().map(|b| b.points.len()).collect();
    let quota = apportion(&sizes, n);
    let remove: Vec<usize> = sizes
        .iter()
        .zip(&quota)
        .map(|(&s, &q)| ((s - q) as f64 * BLOCK_SHARE) as usize)
        .collect();
    let mut alive = sizes.clone();
    let level = levels(crowd, BLOCK_LEVELS);
    for pass in 0..PASSES {
        for step in 0..8u8 {
            let colour = if pass % 2 == 0 { step } else { 7 - step };
            let mut slices: Vec<&mut [f64]> = Vec::with_capacity(blocks.len());
            let mut rest: &mut [f64] = &mut *crowd;
            for b in blocks {
                let (head, tail) = rest.split_at_mut(b.points.len());
                slices.push(head);
                rest = tail;
            }
            let out: Vec<BlockDone> = slices
                .into_par_iter()
                .zip(alive.par_iter())
                .enumerate()
                .filter(|(b, _)| blocks[*b].colour == colour)
                .map(|(b, (cr, &alive_b))| {
                    let range = blocks[b].points.clone();
                    let goal = sizes[b] - (remove[b] * (pass + 1)).div_ceil(PASSES);
                    let mut deltas = Vec::new();
                    let mut left = alive_b;
                    if left <= goal {
                        return (b, left, deltas);
                    }
                    let mut queue = Buckets::new(BLOCK_LEVELS, cr, level);
                    while left > goal {
                        let Some(i) = queue.pop_most(cr, level) else {
                            break;
                        };
                        cr[i] = DEAD;
                        left -= 1;
                        for p in lists[b].of(i) {
                            let (other, w) = p.get();
                            let t = other as usize;
                            if range.contains(&t) {
                                cr[t - range.start] -= w as f64;
                            } else {
                                deltas.push((other, w));
                            }
                        }
                    }
                    (b, left, deltas)
                })
                .collect();
            for (b, left, deltas) in out {
                alive[b] = left;
                for (t, w) in deltas {
                    crowd[t as usize] -= w as f64;
                }
            }
        }
    }
    alive.iter().sum()
}

/// The rest of the elimination, serial: from `left` candidates alive to
/// `n`, the most crowded first over all of them, on a bucket queue with
/// crowding quantised to BUCKETS levels of the largest.
fn eliminate_serial(
    crowd: &mut [f64],
    lists: &[Lists],
    blocks: &[Block],
    mut left: usize,
    n: usize,
) {
    if left <= n {
        return;
    }
    let level = levels(crowd, BUCKETS);
    let mut queue = Buckets::new(BUCKETS, crowd, level);
    while left > n {
        let Some(s) = queue.pop_most(crowd, level) else {
            break;
        };
        crowd[s] = DEAD;
        left -= 1;
        let b = blocks.partition_point(|b| b.points.end <= s);
        for p in lists[b].of(s - blocks[b].points.start) {
            // DEAD stays DEAD.
            let (other, w) = p.get();
            crowd[other as usize] -= w as f64;
        }
    }
}

/// Crowding quantised to `count` levels of the largest in `crowd`
/// (crowding only falls, so no value later is above the top level).
fn levels(crowd: &[f64], count: usize) -> impl Fn(f64) -> usize + Copy + Sync {
    let wmax = crowd.iter().copied().fold(0.0, f64::max);
    let scale = if wmax > 0.0 {
        (count - 1) as f64 / wmax
    } else {
        0.0
    };
    move |w: f64| ((w * scale) as usize).min(count - 1)
}

/// A bucket queue of candidates by crowding level: each level a stack
/// linked through `next`, so filling it allocates twice, not once a
/// level.
struct Buckets {
    heads: Vec<u32>,
    next: Vec<u32>,
    top: usize,
}

const NONE: u32 = u32::MAX;

impl Buckets {
    /// The live candidates of `crowd` (indices into it) in `levels`
    /// levels by `level`; within a level the later candidate comes out
    /// first.
    fn new(levels: usize, crowd: &[f64], level: impl Fn(f64) -> usize) -> Buckets {
        let mut q = Buckets {
            heads: vec![NONE; levels],
            next: vec![NONE; crowd.len()],
            top: 0,
        };
        for (i, &w) in crowd.iter().enumerate() {
            if w != DEAD {
                q.push(i, level(w));
            }
        }
        q
    }

    fn push(&mut self, i: usize, l: usize) {
        self.next[i] = self.heads[l];
        self.heads[l] = i as u32;
        self.top = self.top.max(l);
    }

    /// The most crowded candidate (by its crowding now), taken out; None
    /// when none is left. Crowding only falls, so an entry found above
    /// its candidate's level now is stale: it moves down and the search
    /// goes on, and the top level never rises.
    fn pop_most(&mut self, crowd: &[f64], level: impl Fn(f64) -> usize) -> Option<usize> {
        loop {
            let i = self.heads[self.top];
            if i == NONE {
                if self.top == 0 {
                    return None;
                }
                self.top -= 1;
                continue;
            }
            let i = i as usize;
            self.heads[self.top] = self.next[i];
            let l = level(crowd[i]);
            if l < self.top {
                self.push(i, l);
                continue;
            }
            return Some(i);
        }
    }
}

/// `total` shared among parts of sizes `sizes` in proportion (largest
/// remainders, ties to the earlier part), none above its size.
fn apportion(sizes: &[usize], total: usize) -> Vec<usize> {
    let all: usize = sizes.iter().sum();
    if all == 0 {
        return vec![0; sizes.len()];
    }
    let mut out: Vec<usize> = sizes
        .iter()
        .map(|&s| ((s as u128 * total as u128) / all as u128) as usize)
        .collect();
    let given: usize = out.iter().sum();
    let mut order: Vec<(u128, usize)> = sizes
        .iter()
        .enumerate()
        .map(|(i, &s)| ((s as u128 * total as u128) % all as u128, i))
        .collect();
    order.sort_unstable_by(|a, b| b.0.cmp(&a.0).then(a.1.cmp(&b.1)));
    for &(_, i) in order.iter().take(total - given) {
        out[i] += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn apportion_shares_exactly_in_proportion() {
        for (sizes, total) in [
            (vec![3usize, 3, 3], 5usize),
            (vec![1, 2, 4000, 7, 1], 1337),
            (vec![5, 0, 5], 10),
            (vec![0, 0], 0),
            (vec![10, 20, 30], 0),
        ] {
            let got = apportion(&sizes, total);
            let all: usize = sizes.iter().sum();
            assert_eq!(got.iter().sum::<usize>(), total, "{sizes:?}");
            for (&g, &s) in got.iter().zip(&sizes) {
                assert!(g <= s, "{sizes:?} -> {got:?}");
                let exact = s as f64 * total as f64 / all.max(1) as f64;
                assert!((g as f64 - exact).abs() < 1.0, "{sizes:?} -> {got:?}");
            }
        }
    }
}
