//! The point nearest each of many positions (scatter's `prim` areas give
//! each triangle without a point to the point nearest its centroid).
//! The positions are sorted into the grid's cells and answered group by
//! group from the dense tables the scans read (`runs::Table`), where a
//! k-d tree over the points would first be built on one thread before the
//! first query.

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

use super::runs::{Table, GROUP, MIN_TABLE};
use super::{coords, key, key_bits, neighbour, PointGrid, Sorted};
use crate::geom::kdtree::PointTree;

/// Queries a parallel task answers, at least (whole groups of cells).
const TASK: usize = 256;

impl PointGrid {
    /// The nearest point to each of `queries` (positions in the frame the
    /// grid's points came in): its sorted index, or None for a query that
    /// is not finite or when the grid has no points. Ties go to the lower
    /// index, but for queries farther than `8 r` from every point.
    ///
    /// Queries with a point within `r`, half a cell, are answered from
    /// the 8 cells on their side of their cell's middle: cells should be
    /// large enough for most. The rest search the cells within `2 r`, `4
    /// r`, then `8 r` (27, 125 and 729 key searches each), and what is
    /// left a k-d tree of all the points, built only for them. A widening
    /// that would cost more key searches than there are points (a tree's
    /// build costs about that) is skipped for the tree: a far part of a
    /// mesh with no point on it, all of whose triangles are queries,
    /// costs a tree, not a search of hundreds of cells each.
    pub fn nearest(&self, queries: &[DVec3]) -> Vec<Option<u32>> {
        let r = 0.5 * self.cell;
        if self.is_empty() {
            return vec![None; queries.len()];
        }
        let mut out = self.nearest_within(queries, r);
        let mut rest: Vec<usize> = (0..queries.len())
            .filter(|&i| out[i].is_none() && queries[i].is_finite())
            .collect();
        let budget = self.len().max(1 << 16);
        for (reach, searches) in [(2.0 * r, 27), (4.0 * r, 125), (8.0 * r, 729)] {
            if rest.is_empty() || rest.len().saturating_mul(searches) > budget {
                break;
            }
            let found: Vec<Option<u32>> = rest
                .par_iter()
                .map(|&i| {
                    let mut best = NONE;
                    self.for_each_within(queries[i] - self.lo, reach, |s, d2| {
                        best = best.min(packed(d2, s as u32));
                    });
                    unpacked(best).map(|(_, s)| s)
                })
                .collect();
            for (&i, f) in rest.iter().zip(found) {
                out[i] = f;
            }
            rest.retain(|&i| out[i].is_none());
        }
        if !rest.is_empty() {
            let rel: Vec<[f64; 3]> = self.rel.iter().map(|p| p.to_array()).collect();
            let tree = PointTree::from_relative(&rel);
            let found: Vec<u32> = rest
                .par_iter()
                .map(|&i| tree.nearest_one(queries[i] - self.lo).item)
                .collect();
            for (&i, f) in rest.iter().zip(found) {
                out[i] = Some(f);
            }
        }
        out
    }

    /// The nearest point within `r` (at most half a cell) of each query,
    /// or None.
    fn nearest_within(&self, queries: &[DVec3], r: f64) -> Vec<Option<u32>> {
        let top = self.top;
        // A query's cell, clamped into the box: with `r` at most half a
        // cell, one more than a cell outside has no point within `r`, and
        // one less than that reaches only the cells next to its own.
        // (Truncation, not `floor`, which is a call into libm on the
        // baseline target: from -1 on, `x + 1` truncates to the floor plus
        // one.)
        let cell_of = |q: DVec3| -> Option<[u64; 3]> {
            let c = ((q - self.lo) * self.inv).to_array();
            let mut at = [0u64; 3];
            for a in 0..3 {
                if !(c[a] >= -1.0 && c[a] < top[a] as f64 + 2.0) {
                    return None;
                }
                at[a] = ((c[a] + 1.0) as u64).saturating_sub(1).min(top[a]);
            }
            Some(at)
        };
        let cells: Vec<Option<[u64; 3]>> = queries.par_iter().map(|&q| cell_of(q)).collect();
        let live: Vec<u32> = (0..queries.len() as u32)
            .filter(|&i| cells[i as usize].is_some())
            .collect();
        let cell_key = |j: usize| key(cells[live[j] as usize].expect("live"));
        let sorted = Sorted::new(live.len(), key_bits(top), cell_key);
        // Tasks of whole groups of the sorted queries.
        let mut tasks: Vec<Range<usize>> = Vec::new();
        let mut from = 0;
        for s in 1..=sorted.len() {
            let end = s == sorted.len()
                || sorted.key(s) >> (3 * GROUP) != sorted.key(s - 1) >> (3 * GROUP);
            if end && (s - from >= TASK || s == sorted.len()) {
                tasks.push(from..s);
                from = s;
            }
        }
        let r2 = r * r;
        let found: Vec<Vec<(u32, Option<u32>)>> = tasks
            .par_iter()
            .map(|task| {
                let mut out = Vec::with_capacity(task.len());
                let mut table: Option<Table> = None;
                let mut s = task.start;
                while s < task.end {
                    let g = sorted.key(s) >> (3 * GROUP);
                    let mut e = s + 1;
                    while e < task.end && sorted.key(e) >> (3 * GROUP) == g {
                        e += 1;
                    }
                    let tabled = e - s >= MIN_TABLE;
                    if tabled {
                        self.fill(g, table.get_or_insert_with(Table::new));
                    }
                    for s in s..e {
                        let i = live[sorted.index(s) as usize];
                        let q = queries[i as usize] - self.lo;
                        let k = sorted.key(s);
                        let at = coords(k);
                        let local = coords(k & ((1u64 << (3 * GROUP)) - 1));
                        // The cells on the query's side of its cell's
                        // middle, as offsets 0..3 from one cell below.
                        let side = [0, 1, 2].map(|a| {
                            let mid = (at[a] as f64 + 0.5) * self.cell;
                            if q[a] < mid {
                                0
                            } else {
                                1
                            }
                        });
                        let mut best = NONE;
                        for o in 0..8 {
                            let d = [o >> 2 & 1, o >> 1 & 1, o & 1].map(|x| x as u64);
                            let n = [0, 1, 2].map(|a| side[a] + d[a]);
                            let run = if tabled {
                                table
                                    .as_ref()
                                    .expect("filled above")
                                    .run([0, 1, 2].map(|a| (local[a] + n[a]) as usize))
                            } else {
                                self.run_at(at, n)
                            };
                            for t in run {
                                let d2 = (self.rel[t] - q).length_squared();
                                best = best.min(packed(d2, t as u32));
                            }
                        }
                        let near = unpacked(best).filter(|&(d2, _)| d2 <= r2);
                        out.push((i, near.map(|(_, s)| s)));
                    }
                    s = e;
                }
                out
            })
            .collect();
        let mut out = vec![None; queries.len()];
        for (i, f) in found.into_iter().flatten() {
            out[i as usize] = f;
        }
        out
    }

    /// The points of the cell at `at` plus `n` less one along each axis
    /// (`n` in `0..3`), by a search of the keys.
    fn run_at(&self, at: [u64; 3], n: [u64; 3]) -> Range<usize> {
        let Some(c) = neighbour(at, n) else {
            return 0..0;
        };
        match self.keys.binary_search(&key(c)) {
            Ok(c) => self.cell_points(c),
            Err(_) => 0..0,
        }
    }
}

/// A (squared distance, index) packed so that the smaller of two is the
/// nearer, or of two as near the lower index: a squared distance is not
/// negative, and then its bits are in the order of its values (a `min`
/// without a branch to mispredict).
fn packed(d2: f64, s: u32) -> u128 {
    (d2.to_bits() as u128) << 32 | s as u128
}

/// The squared distance and index of `packed`'s value, None for `NONE`.
fn unpacked(p: u128) -> Option<(f64, u32)> {
    (p != NONE).then(|| (f64::from_bits((p >> 32) as u64), p as u32))
}

/// Nothing found yet.
const NONE: u128 = u128::MAX;

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    #[test]
    fn nearest_finds_what_brute_force_finds() {
        let mut g = Pcg32::new(11, 3);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64 - 0.5;
        let dir = |u: &mut dyn FnMut() -> f64| DVec3::new(u(), u(), u()).normalize_or(DVec3::X);
        // Points on a unit sphere far from the origin, and a far speck.
        let centre = DVec3::splat(1e6);
        let mut pts: Vec<DVec3> = (0..4000).map(|_| centre + dir(&mut u)).collect();
        pts.push(centre + DVec3::new(40.0, 0.0, 0.0));
        // Queries near the sphere (most answered from their 8 cells),
        // inside and around it (the wider searches, the tree), outside
        // the points' box, and one not finite.
        let mut queries: Vec<DVec3> = (0..3000)
            .map(|i| {
                let r = [1.0 + 0.02 * u(), 0.5 + u(), 3.0 + 4.0 * u()][i % 3];
                centre + dir(&mut u) * r
            })
            .collect();
        queries.push(centre + DVec3::new(-30.0, 0.0, 0.0));
        queries.push(centre + DVec3::new(0.0, 1.0 + 1e-9, 0.0));
        queries.push(DVec3::new(f64::NAN, 0.0, 0.0));
        // Many queries far from every point: straight to the k-d tree.
        let far: Vec<DVec3> = (0..3000)
            .map(|_| centre + DVec3::new(-100.0, 0.0, 0.0) + dir(&mut u) * 5.0)
            .collect();
        // A few queries at a time are answered by searches of the keys
        // (too few in a group for a table).
        let few: Vec<DVec3> = queries.iter().copied().step_by(40).collect();
        for (cell, queries) in [0.03, 0.1, 0.2, 1.0]
            .into_iter()
            .flat_map(|c| [(c, &queries), (c, &few), (c, &far)])
        {
            let grid = PointGrid::new(&pts, cell);
            let got = grid.nearest(queries);
            for (i, (&q, g)) in queries.iter().zip(&got).enumerate() {
                if !q.is_finite() {
                    assert_eq!(*g, None, "query {i}");
                    continue;
                }
                let d2 = |j: usize| (pts[j] - q).length_squared();
                let want = (0..pts.len())
                    .min_by(|&a, &b| d2(a).total_cmp(&d2(b)))
                    .expect("points");
                let g = grid.order()[g.expect("a point") as usize] as usize;
                assert!(
                    g == want || d2(g) == d2(want),
                    "cell {cell} query {i}: point {g} at {} for {want} at {}",
                    d2(g).sqrt(),
                    d2(want).sqrt()
                );
            }
        }
        assert_eq!(
            PointGrid::new(&[], 1.0).nearest(&queries[..2]),
            [None, None]
        );
    }
}
