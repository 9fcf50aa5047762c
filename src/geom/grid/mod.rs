//! A uniform grid over points, for neighbours within a fixed radius when
//! the points are about evenly spread (scatter's candidates, blue noise):
//! a cell twice the radius holds a dozen points, and all the points of a
//! cell are answered together from the 27 cells around it, where a k-d
//! tree would descend from its root for every point.
//!
//! Points are sorted by cell key in Morton order (then by index, so the
//! grid is the same on any thread count) and kept in that order relative
//! to the box's lower corner. Scans go group by group (aligned cubes of
//! 16 cells a side, `GROUP`): a group's cells read their neighbours from a
//! dense table of the group and the cells around it. Where a scan visits
//! too few of a group's cells for a table to pay, cells visited in order
//! find their neighbours by galloping search from where the last ones
//! were (a few keys away, in cache); single queries search the keys from
//! scratch. Empty cells cost nothing, so a surface in a large box costs
//! what its points cost.

use std::ops::Range;

use glam::DVec3;
use rayon::prelude::*;

pub mod dense;
mod nearest;
mod runs;
#[cfg(test)]
use runs::SIDE;
use runs::{Cursor, Table, GROUP, MIN_TABLE};

/// Bits of a cell coordinate in a key.
const BITS: u32 = 21;
/// Cells along an axis at most: the cell grows for a box that would
/// need more.
const MAX_CELLS: f64 = ((1u64 << BITS) - 4) as f64;

/// An aligned cube of cells (`PointGrid::blocks`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Block {
    /// Its occupied cells.
    pub cells: Range<usize>,
    /// Its points (sorted indices).
    pub points: Range<usize>,
    /// The parities of its coordinates (0..8).
    pub colour: u8,
}

/// Points sorted into cubic cells.
pub struct PointGrid {
    inv: f64,
    cell: f64,
    /// The points' lower corner: the grid's frame starts there.
    lo: DVec3,
    /// The highest cell coordinates holding points, along each axis.
    top: [u64; 3],
    /// The caller's index of each point, in cell order.
    order: Vec<u32>,
    /// Positions relative to the box's lower corner, in cell order.
    rel: Vec<DVec3>,
    /// Each occupied cell's key, ascending.
    keys: Vec<u64>,
    /// Cell `c` holds sorted points `start[c]..start[c + 1]`.
    start: Vec<u32>,
    /// Each occupied group's key (`key >> 3 GROUP`), ascending, and its
    /// first cell: group `g`'s cells are `group_start[g]..group_start[g +
    /// 1]`.
    group_keys: Vec<u64>,
    group_start: Vec<u32>,
}

/// Indices `0..n` sorted by a key, ties by index: packed as `key <<
/// index_bits | index` and radix-sorted by the key's bits only (the
/// indices are in order already) when both fit in 64 bits, as they do
/// unless a box spans more than about 2^((64 - index bits) / 3) cells;
/// else pairs, by a comparison sort.
enum Sorted {
    Packed { keys: Vec<u64>, index_bits: u32 },
    Pairs(Vec<(u64, u32)>),
}

impl Sorted {
    /// `0..n` (fewer than 2^32) sorted by `key_of`, whose keys have at
    /// most `key_bits` bits.
    fn new(n: usize, key_bits: u32, key_of: impl Fn(usize) -> u64 + Sync) -> Sorted {
        let index_bits = (usize::BITS - n.leading_zeros()).max(1);
        if key_bits + index_bits <= 64 {
            let mut keys: Vec<u64> = (0..n)
                .into_par_iter()
                .map(|i| key_of(i) << index_bits | i as u64)
                .collect();
            crate::radix::sort_bits(&mut keys, index_bits, index_bits + key_bits);
            Sorted::Packed { keys, index_bits }
        } else {
            let mut pairs: Vec<(u64, u32)> = (0..n)
                .into_par_iter()
                .map(|i| (key_of(i), i as u32))
                .collect();
            pairs.par_sort_unstable();
            Sorted::Pairs(pairs)
        }
    }

    fn len(&self) -> usize {
        match self {
            Sorted::Packed { keys, .. } => keys.len(),
            Sorted::Pairs(p) => p.len(),
        }
    }

    /// The key of the `s`-th in order.
    #[inline]
    fn key(&self, s: usize) -> u64 {
        match self {
            Sorted::Packed { keys, index_bits } => keys[s] >> index_bits,
            Sorted::Pairs(p) => p[s].0,
        }
    }

    /// The index of the `s`-th in order.
    #[inline]
    fn index(&self, s: usize) -> u32 {
        match self {
            Sorted::Packed { keys, index_bits } => (keys[s] & ((1u64 << index_bits) - 1)) as u32,
            Sorted::Pairs(p) => p[s].1,
        }
    }

    /// The indices in order.
    fn order(&self) -> Vec<u32> {
        match self {
            Sorted::Packed { keys, index_bits } => {
                let mask = (1u64 << index_bits) - 1;
                keys.par_iter().map(|&k| (k & mask) as u32).collect()
            }
            Sorted::Pairs(p) => p.par_iter().map(|&(_, i)| i).collect(),
        }
    }
}

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f00000000ffff;
    x = (x | x << 16) & 0x1f0000ff0000ff;
    x = (x | x << 8) & 0x100f00f00f00f00f;
    x = (x | x << 4) & 0x10c30c30c30c30c3;
    (x | x << 2) & 0x1249249249249249
}

/// The inverse of `spread`.
fn compact(x: u64) -> u64 {
    let mut x = x & 0x1249249249249249;
    x = (x | x >> 2) & 0x10c30c30c30c30c3;
    x = (x | x >> 4) & 0x100f00f00f00f00f;
    x = (x | x >> 8) & 0x1f0000ff0000ff;
    x = (x | x >> 16) & 0x1f00000000ffff;
    (x | x >> 32) & 0x1f_ffff
}

/// A cell's key: its coordinates interleaved (Morton order), so that
/// cells near in space are mostly near in the sorted points, and so are
/// the memory a neighbourhood's work touches.
fn key(c: [u64; 3]) -> u64 {
    spread(c[0]) << 2 | spread(c[1]) << 1 | spread(c[2])
}

fn coords(k: u64) -> [u64; 3] {
    [compact(k >> 2), compact(k >> 1), compact(k)]
}

/// The bits the keys of cells up to `top` along each axis need.
fn key_bits(top: [u64; 3]) -> u32 {
    let axis = top
        .iter()
        .map(|&x| u64::BITS - x.leading_zeros())
        .max()
        .unwrap_or(0)
        .max(1);
    3 * axis
}

/// The cell at `at` plus `n` less one along each axis (`n` in `0..3`),
/// None off the grid's coordinates.
fn neighbour(at: [u64; 3], n: [u64; 3]) -> Option<[u64; 3]> {
    let top = (1u64 << BITS) - 1;
    let mut c = [0u64; 3];
    for a in 0..3 {
        let x = at[a] + n[a];
        if x == 0 || x - 1 > top {
            return None;
        }
        c[a] = x - 1;
    }
    Some(c)
}

/// The lower and upper corners of `points`' box, on every thread
/// (infinite, upper below lower, without points).
pub fn bounds(points: &[DVec3]) -> (DVec3, DVec3) {
    let none = || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    points
        .par_iter()
        .fold(none, |(lo, hi), p| (lo.min(*p), hi.max(*p)))
        .reduce(none, |a, b| (a.0.min(b.0), a.1.max(b.1)))
}

impl PointGrid {
    /// The grid of `points` (finite, fewer than 2^32) with cells of side
    /// at least `cell` (larger when the box would need more than 2^21
    /// cells along an axis).
    pub fn new(points: &[DVec3], cell: f64) -> PointGrid {
        let (lo, hi) = bounds(points);
        let extent = if points.is_empty() {
            0.0
        } else {
            (hi - lo).max_element()
        };
        let mut cell = if cell.is_finite() && cell > 0.0 {
            cell
        } else {
            1.0
        };
        if extent / cell > MAX_CELLS {
            cell = extent / MAX_CELLS;
        }
        let lo = if points.is_empty() { DVec3::ZERO } else { lo };
        let inv = 1.0 / cell;
        // The points are at or above `lo`, where truncation is the floor
        // (and `as` takes what is below 0 to 0): without SSE4.1 in the
        // baseline target, `floor` is a call into libm, a third of the
        // cost of a key.
        let coord = |p: DVec3| -> [u64; 3] {
            let c = (p - lo) * inv;
            let cell = |x: f64| x.min(MAX_CELLS) as u64;
            [cell(c.x), cell(c.y), cell(c.z)]
        };
        let top = coord(hi.max(lo));
        let sorted = Sorted::new(points.len(), key_bits(top), |i| key(coord(points[i])));
        // The occupied cells' keys and first points, from the sorted
        // points' keys.
        let (order, (keys, start)): (Vec<u32>, _) = rayon::join(
            || sorted.order(),
            || {
                let mut keys = Vec::new();
                let mut start = Vec::new();
                for s in 0..sorted.len() {
                    let k = sorted.key(s);
                    if keys.last() != Some(&k) {
                        keys.push(k);
                        start.push(s as u32);
                    }
                }
                start.push(sorted.len() as u32);
                (keys, start)
            },
        );
        let mut group_keys = Vec::new();
        let mut group_start = Vec::new();
        for (c, &k) in keys.iter().enumerate() {
            if group_keys.last() != Some(&(k >> (3 * GROUP))) {
                group_keys.push(k >> (3 * GROUP));
                group_start.push(c as u32);
            }
        }
        group_start.push(keys.len() as u32);
        let rel = order.par_iter().map(|&i| points[i as usize] - lo).collect();
        PointGrid {
            inv,
            cell,
            lo,
            top,
            order,
            rel,
            keys,
            start,
            group_keys,
            group_start,
        }
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        self.order.len()
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The side of a cell (at least what was asked for).
    pub fn cell(&self) -> f64 {
        self.cell
    }

    /// The caller's index of each point, in cell order (sorted indices
    /// below index this).
    pub fn order(&self) -> &[u32] {
        &self.order
    }

    /// The grid's corner, which [`PointGrid::rel`] positions are relative to.
    pub fn corner(&self) -> DVec3 {
        self.lo
    }

    /// Positions in cell order, relative to the grid's corner.
    pub fn rel(&self) -> &[DVec3] {
        &self.rel
    }

    /// The number of occupied cells.
    pub fn cells(&self) -> usize {
        self.keys.len()
    }

    /// The grid's occupied cells grouped into aligned cubes of `2^k`
    /// cells a side, `k` the smallest that puts at least `per_block`
    /// points in a block on average, in grid order (Morton order keeps an
    /// aligned cube's cells together). Blocks of one colour are a block
    /// apart or more, so with cells at least twice a radius no point of
    /// one is within the radius of a point of another.
    pub fn blocks(&self, per_block: usize) -> Vec<Block> {
        let mut shift = 0;
        while shift < 3 * BITS {
            let mut count = 0usize;
            let mut last = u64::MAX;
            for &k in &self.keys {
                if k >> shift != last {
                    last = k >> shift;
                    count += 1;
                }
            }
            if self.len() >= per_block * count || count <= 1 {
                break;
            }
            shift += 3;
        }
        let mut out: Vec<Block> = Vec::new();
        let mut last = u64::MAX;
        for (c, &k) in self.keys.iter().enumerate() {
            let run = self.cell_points(c);
            if k >> shift == last {
                let b = out.last_mut().expect("a block is open");
                b.cells.end = c + 1;
                b.points.end = run.end;
            } else {
                last = k >> shift;
                out.push(Block {
                    cells: c..c + 1,
                    points: run,
                    // The block's key: its coordinates' low bits are
                    // bits 0, 1, 2 of the shifted key (z, y, x).
                    colour: (last & 7) as u8,
                });
            }
        }
        out
    }

    /// The sorted points of cell `c`.
    fn cell_points(&self, c: usize) -> Range<usize> {
        self.start[c] as usize..self.start[c + 1] as usize
    }

    /// The lower corner of cell `c` in the grid's frame.
    fn cell_corner(&self, c: usize) -> DVec3 {
        let [x, y, z] = coords(self.keys[c]);
        DVec3::new(x as f64, y as f64, z as f64) * self.cell
    }

    /// The sorted points' runs of every occupied cell within `ring` cells
    /// along each axis of the cell holding `rel` (a position in the grid's
    /// frame; outside the box it is the nearest cell), into `out` (cleared
    /// first); runs that follow each other are merged.
    fn around_point(&self, rel: DVec3, ring: u64, out: &mut Vec<Range<usize>>) {
        let c = (rel * self.inv).floor();
        let clamp = |x: f64| x.clamp(0.0, MAX_CELLS) as u64;
        self.around([clamp(c.x), clamp(c.y), clamp(c.z)], ring, out);
    }

    fn around(&self, at: [u64; 3], ring: u64, out: &mut Vec<Range<usize>>) {
        out.clear();
        let top = (1u64 << BITS) - 1;
        let span = |x: u64| x.saturating_sub(ring)..=(x + ring).min(top);
        for x in span(at[0]) {
            for y in span(at[1]) {
                for z in span(at[2]) {
                    if let Ok(c) = self.keys.binary_search(&key([x, y, z])) {
                        let r = self.cell_points(c);
                        match out.last_mut() {
                            Some(last) if last.end == r.start => last.end = r.end,
                            _ => out.push(r),
                        }
                    }
                }
            }
        }
    }

    /// `f(w, s, near)` for every point `s` (sorted index), where `near`
    /// holds the other points within `r` (at most half a cell) as (sorted
    /// index, squared distance), in grid order, and `w` is a workspace
    /// `init` makes once per task of cells; the results in grid order.
    /// Work goes cell by cell (`scan`).
    pub fn map_near<W, T: Send>(
        &self,
        r: f64,
        init: impl Fn() -> W + Sync,
        f: impl Fn(&mut W, usize, &[(u32, f64)]) -> T + Sync,
    ) -> Vec<T> {
        let parts = self.per_task(r, |cs, near, out: &mut Vec<T>| {
            let mut w = init();
            self.scan(cs, r, near, |s, near| out.push(f(&mut w, s, near)));
        });
        crate::disjoint::concat(parts)
    }

    /// `map_near`, where `f` also gets the runs of the 27 cells around the
    /// point's cell (every point within a cell's side of it is in them),
    /// for a point that needs to look farther than `r`.
    pub fn map_near_runs<W, T: Send>(
        &self,
        r: f64,
        init: impl Fn() -> W + Sync,
        f: impl Fn(&mut W, usize, &[(u32, f64)], &[Range<usize>; 27]) -> T + Sync,
    ) -> Vec<T> {
        let parts = self.per_task(r, |cs, near, out: &mut Vec<T>| {
            let mut w = init();
            self.scan_with_runs(cs, r, near, |s, near, runs| {
                out.push(f(&mut w, s, near, runs))
            });
        });
        crate::disjoint::concat(parts)
    }

    /// Every point's neighbours within `r` (at most half a cell), in grid
    /// order: point `s`'s are `other[start[s]..start[s + 1]]` (sorted
    /// indices).
    pub fn near_lists(&self, r: f64) -> (Vec<usize>, Vec<u32>) {
        let parts = self.per_task(r, |cs, near, out: &mut (Vec<u32>, Vec<u32>)| {
            self.scan(cs, r, near, |_, near| {
                out.0.push(near.len() as u32);
                out.1.extend(near.iter().map(|&(t, _)| t));
            });
        });
        // Each task fills its points' list ends, counting from the end of
        // the earlier tasks' lists.
        let mut start = vec![0usize; self.len() + 1];
        let mut rest = &mut start[1..];
        let mut dst = Vec::with_capacity(parts.len());
        let mut base = 0usize;
        for p in &parts {
            let (a, b) = rest.split_at_mut(p.0.len());
            dst.push((a, base));
            rest = b;
            base += p.1.len();
        }
        dst.into_par_iter()
            .zip(&parts)
            .for_each(|((d, mut at), p)| {
                for (d, &c) in d.iter_mut().zip(&p.0) {
                    at += c as usize;
                    *d = at;
                }
            });
        let other: Vec<Vec<u32>> = parts.into_iter().map(|p| p.1).collect();
        (start, crate::disjoint::concat(other))
    }

    /// Runs `work` on tasks of consecutive whole groups (64 cells or
    /// more together; the last task may have fewer) in parallel, each
    /// with its own output, in cell order.
    fn per_task<O: Default + Send>(
        &self,
        r: f64,
        work: impl Fn(Range<usize>, &mut Vec<(u32, f64)>, &mut O) + Sync,
    ) -> Vec<O> {
        assert!(r <= 0.5 * self.cell, "the radius is at most half a cell");
        let mut tasks: Vec<Range<usize>> = Vec::new();
        let mut from = 0;
        for &end in &self.group_start[1..] {
            let end = end as usize;
            if end - from >= 64 {
                tasks.push(from..end);
                from = end;
            }
        }
        if from < self.cells() {
            tasks.push(from..self.cells());
        }
        tasks
            .par_iter()
            .map(|cs| {
                let mut out = O::default();
                let mut near = Vec::with_capacity(32);
                work(cs.clone(), &mut near, &mut out);
                out
            })
            .collect()
    }

    /// `f(s, near)` for the points of cells `cs` in order, `near` holding
    /// the other points within `r` (at most half a cell) as (sorted index,
    /// squared distance), in grid order. Each point reads the 8 cells on
    /// its side of its cell's middle, of the 27 around its cell looked up
    /// once a cell. (A first test in f32, vectorised a block at a time,
    /// was measured slower: the runs are a dozen points.)
    pub fn scan(
        &self,
        cs: Range<usize>,
        r: f64,
        near: &mut Vec<(u32, f64)>,
        mut f: impl FnMut(usize, &[(u32, f64)]),
    ) {
        self.scan_with_runs(cs, r, near, |s, near, _| f(s, near))
    }

    /// `scan`, where `f` also gets the runs of the 27 cells around the
    /// point's cell (indexed as `runs27`'s), which hold every point
    /// within a cell's side of it.
    fn scan_with_runs(
        &self,
        cs: Range<usize>,
        r: f64,
        near: &mut Vec<(u32, f64)>,
        mut f: impl FnMut(usize, &[(u32, f64)], &[Range<usize>; 27]),
    ) {
        let r2 = r * r;
        let half = 0.5 * self.cell;
        let mut cursor = Cursor::new();
        let mut table: Option<Table> = None;
        // The end of the current group's cells in `cs`, and whether they
        // read a table.
        let (mut group_end, mut tabled) = (0, false);
        for c in cs.clone() {
            if c >= group_end {
                let g = self.keys[c] >> (3 * GROUP);
                group_end = self.group_cells(g).end.min(cs.end);
                tabled = group_end - c >= MIN_TABLE;
                if tabled {
                    self.fill(g, table.get_or_insert_with(Table::new));
                }
            }
            let runs = match &table {
                Some(t) if tabled => self.runs_from(c, t),
                _ => self.runs27(c, &mut cursor),
            };
            let mid = self.cell_corner(c) + half;
            for s in self.cell_points(c) {
                let q = self.rel[s];
                let side = |x: f64, m: f64| if x < m { [0, 1] } else { [1, 2] };
                let (sx, sy, sz) = (side(q.x, mid.x), side(q.y, mid.y), side(q.z, mid.z));
                // Every point of the runs is written and only those
                // within `r` are counted: no branch to mispredict.
                let mut len = 0;
                for dx in sx {
                    for dy in sy {
                        for dz in sz {
                            let run = runs[9 * dx + 3 * dy + dz].clone();
                            if near.len() < len + run.len() {
                                near.resize(len + run.len(), (0, 0.0));
                            }
                            for t in run {
                                let d2 = (self.rel[t] - q).length_squared();
                                near[len] = (t as u32, d2);
                                len += (d2 <= r2 && t != s) as usize;
                            }
                        }
                    }
                }
                f(s, &near[..len], &runs);
            }
        }
    }

    /// Calls `f(sorted index, squared distance)` for every point within
    /// `r` of `rel` (grid frame), in cell order.
    pub fn for_each_within(&self, rel: DVec3, r: f64, mut f: impl FnMut(usize, f64)) {
        let ring = (r * self.inv).ceil().max(1.0) as u64;
        let mut runs = Vec::with_capacity(16);
        self.around_point(rel, ring, &mut runs);
        let r2 = r * r;
        for run in runs {
            for s in run {
                let d2 = (self.rel[s] - rel).length_squared();
                if d2 <= r2 {
                    f(s, d2);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    /// `p` in the grid's frame: from the points' lower corner.
    fn to_rel(pts: &[DVec3], p: DVec3) -> DVec3 {
        p - pts
            .iter()
            .fold(DVec3::splat(f64::INFINITY), |lo, q| lo.min(*q))
    }

    #[test]
    fn within_finds_what_brute_force_finds() {
        let mut g = Pcg32::new(7, 1);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64;
        let pts: Vec<DVec3> = (0..3000)
            .map(|_| DVec3::new(u(), u() * 0.3, u() * 2.0) + 1e6)
            .collect();
        let rel: Vec<DVec3> = pts.iter().map(|&p| to_rel(&pts, p)).collect();
        for cell in [0.05, 0.13, 1.0, 10.0] {
            let grid = PointGrid::new(&pts, cell);
            assert_eq!(grid.len(), pts.len());
            for (i, &q) in rel.iter().enumerate().step_by(97) {
                for r in [0.02, 0.1, 0.31] {
                    let mut got: Vec<u32> = Vec::new();
                    grid.for_each_within(q, r, |s, _| got.push(grid.order()[s]));
                    got.sort_unstable();
                    let want: Vec<u32> = (0..pts.len() as u32)
                        .filter(|&j| (rel[j as usize] - q).length() <= r)
                        .collect();
                    assert_eq!(got, want, "cell {cell} r {r} point {i}");
                }
            }
        }
    }

    #[test]
    fn scan_finds_every_pair_brute_force_finds() {
        // A thin slab and a sphere: cells visited in order are mostly
        // neighbours (their runs reused), with jumps between.
        let mut g = Pcg32::new(4, 8);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64;
        let mut pts: Vec<DVec3> = (0..4000)
            .map(|_| DVec3::new(u(), u(), u() * 0.05))
            .collect();
        for _ in 0..2000 {
            let d = DVec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize_or_zero();
            pts.push(DVec3::new(2.0, 0.5, 0.5) + 0.3 * d);
        }
        let r = 0.03;
        let grid = PointGrid::new(&pts, 2.0 * r);
        let mut got = Vec::new();
        let mut near = Vec::new();
        grid.scan(0..grid.cells(), r, &mut near, |s, nb| {
            let a = grid.order()[s];
            got.extend(nb.iter().map(|&(t, _)| (a, grid.order()[t as usize])));
        });
        got.sort_unstable();
        let rel: Vec<DVec3> = pts.iter().map(|&p| to_rel(&pts, p)).collect();
        let mut want = Vec::new();
        for (i, p) in rel.iter().enumerate() {
            for (j, q) in rel.iter().enumerate() {
                if i != j && (*p - *q).length_squared() <= r * r {
                    want.push((i as u32, j as u32));
                }
            }
        }
        assert!(want.len() > 10_000, "{} pairs", want.len());
        assert_eq!(got, want);
    }

    #[test]
    fn scan_by_tables_and_by_searches_finds_what_within_finds() {
        // Points filling a cube of 3 groups a side (every group has all
        // 26 around it), scanned whole (each group's cells read a table)
        // and in runs of 7 cells (too few for a table: searched).
        let mut g = Pcg32::new(5, 1);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64;
        let pts: Vec<DVec3> = (0..30_000).map(|_| DVec3::new(u(), u(), u())).collect();
        let r = 0.5 / (3 * SIDE) as f64;
        let grid = PointGrid::new(&pts, 2.0 * r);
        assert!(
            grid.group_keys.len() >= 27,
            "{} groups",
            grid.group_keys.len()
        );
        let mut want = Vec::new();
        for s in 0..grid.len() {
            let mut v = Vec::new();
            grid.for_each_within(grid.rel()[s], r, |t, _| {
                if t != s {
                    v.push(t as u32)
                }
            });
            v.sort_unstable();
            want.push(v);
        }
        assert!(want.iter().map(Vec::len).sum::<usize>() > 3_000);
        for step in [grid.cells(), 7] {
            let mut got = vec![Vec::new(); grid.len()];
            let mut near = Vec::new();
            for from in (0..grid.cells()).step_by(step) {
                let cs = from..(from + step).min(grid.cells());
                grid.scan(cs, r, &mut near, |s, nb| {
                    got[s] = nb.iter().map(|&(t, _)| t).collect();
                    got[s].sort_unstable();
                });
            }
            assert_eq!(got, want, "runs of {step} cells");
        }
    }

    #[test]
    fn map_near_finds_what_within_finds() {
        let mut g = Pcg32::new(9, 2);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64;
        let pts: Vec<DVec3> = (0..4000).map(|_| DVec3::new(u(), u(), u() * 0.1)).collect();
        let r = 0.04;
        let grid = PointGrid::new(&pts, 2.0 * r);
        let got = grid.map_near(
            r,
            || (),
            |_, _, near| {
                let mut v: Vec<u32> = near.iter().map(|&(t, _)| t).collect();
                v.sort_unstable();
                v
            },
        );
        for (s, got) in got.iter().enumerate() {
            let mut want = Vec::new();
            grid.for_each_within(grid.rel()[s], r, |t, _| {
                if t != s {
                    want.push(t as u32)
                }
            });
            want.sort_unstable();
            assert_eq!(got, &want, "point {s}");
        }
    }

    #[test]
    fn blocks_cover_the_points_in_order_and_a_colour_keeps_apart() {
        // Points on two crossing planes and a sphere: surfaces, as scatter
        // gives.
        let mut g = Pcg32::new(11, 3);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64;
        let mut pts: Vec<DVec3> = Vec::new();
        for _ in 0..3000 {
            pts.push(DVec3::new(u(), u(), 0.5));
            pts.push(DVec3::new(0.5, u(), u()));
            let d = DVec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize_or_zero();
            pts.push(DVec3::splat(0.5) + 0.4 * d);
        }
        let r = 0.01;
        let grid = PointGrid::new(&pts, 2.0 * r);
        for per in [1, 50, 400, 100_000] {
            let blocks = grid.blocks(per);
            let mut next = 0;
            let mut next_cell = 0;
            for b in &blocks {
                assert_eq!(b.points.start, next, "blocks follow each other");
                assert_eq!(b.cells.start, next_cell, "blocks follow each other");
                assert!(!b.points.is_empty());
                assert_eq!(
                    grid.cell_points(b.cells.start).start..grid.cell_points(b.cells.end - 1).end,
                    b.points,
                    "a block's points are its cells' points"
                );
                next = b.points.end;
                next_cell = b.cells.end;
            }
            assert_eq!(next_cell, grid.cells());
            assert_eq!(next, grid.len());
            if per > 1 && per < 100_000 {
                assert!(
                    grid.len() >= per * blocks.len() / 2,
                    "{per}: {} blocks",
                    blocks.len()
                );
            }
            // No point is within the reach of a point of another block of
            // its colour.
            let mut block_of = vec![0usize; grid.len()];
            for (k, b) in blocks.iter().enumerate() {
                for s in b.points.clone() {
                    block_of[s] = k;
                }
            }
            for s in 0..grid.len() {
                let (k, c) = (block_of[s], blocks[block_of[s]].colour);
                grid.for_each_within(grid.rel()[s], r, |t, _| {
                    let j = block_of[t];
                    assert!(
                        j == k || blocks[j].colour != c,
                        "{per}: point {s} of block {k} reaches block {j}, both colour {c}"
                    );
                });
            }
        }
    }

    #[test]
    fn morton_keys_round_trip() {
        for c in [
            [0, 0, 0],
            [1, 2, 3],
            [(1 << 21) - 1, 5, (1 << 21) - 1],
            [123_456, 7, 1_999_999],
        ] {
            assert_eq!(coords(key(c)), c);
        }
    }

    #[test]
    fn empty_and_huge_boxes_are_fine() {
        let g = PointGrid::new(&[], 1.0);
        assert!(g.is_empty());
        let mut n = 0;
        g.for_each_within(DVec3::ZERO, 1.0, |_, _| n += 1);
        assert_eq!(n, 0);
        // 1e30 across with cells of 1: the cell grows to fit the keys.
        let pts = [DVec3::ZERO, DVec3::splat(1e30), DVec3::new(1.0, 0.0, 0.0)];
        let g = PointGrid::new(&pts, 1.0);
        assert!(g.cell() > 1e23);
        let mut got = Vec::new();
        g.for_each_within(to_rel(&pts, DVec3::ZERO), 2.0, |s, _| {
            got.push(g.order()[s])
        });
        got.sort_unstable();
        assert_eq!(got, vec![0, 2]);
    }
}
