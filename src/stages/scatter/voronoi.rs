//! `ptarea voronoi`: the area of each point's Voronoi cell in its tangent
//! plane; `ptarea centroid`: those areas placed at the cells' centroids
//! (`voronoi_weights`).
//!
//! A point's cell is a square of half-width `R` (twice the hexagonal
//! spacing of the cloud on its area: it bounds a cell at an open edge) cut
//! by the bisectors of the other points within a first reach (`R`, or 0.8
//! `R` for `--blue`'s points), projected onto the plane through the point
//! with its normal, nearest first. It is closed for sure once its
//! farthest corner lies within half the distance of every point not yet
//! used; a cell not closed by the points within the first reach (next to
//! an empty patch, or at an open edge) is cut by those up to
//! twice its farthest corner (at most `2 sqrt 2 R`: the square bounds
//! it), at most the 256 nearest (a surface folded onto itself many
//! times). Exact for points on a plane away from its edges; on a smooth
//! surface the error is of the order of the cell's size over the radius
//! of curvature. At the surface's open edges (its boundary, a hole's rim)
//! a cell is cut by each open edge within its reach that it lies on the
//! inner side of, projected into its plane: the cells then sum to the
//! surface's area there too, where the square alone would make a
//! boundary point's cell several times an inner one's. (The cut is by
//! the edge's whole line: at a reflex corner of the boundary it takes a
//! little too much.) Each edge of
//! a cell remembers the point whose bisector made it: consecutive edges
//! give the Delaunay triangles around the point, which `centroid` shares
//! each area over.
//!
//! The points within the first reach come cell by cell from a grid of
//! cells twice as wide (`geom::grid`); the second round reads the 27
//! cells around when they reach far enough, else a query of its own. Each
//! point's cell depends only on the positions, so the result does not
//! depend on the thread count (nor on the first reach).

use std::collections::HashMap;
use std::ops::Range;

use glam::DVec3;

use super::hex_spacing;
use crate::geom::grid::PointGrid;
use crate::geom::{self};

/// The first reach, in hexagonal spacings.
pub(super) const REACH: f64 = 2.0;
/// The first reach for `--blue`'s points, kept 0.8 spacings apart: their
/// cells are small, and a shorter reach means fewer points to test and
/// sort a cell; the cells it leaves open take their second round from
/// the 27 grid cells the scan read; below 1.6 so many cells need a second
/// round that the phase is slower again (benches/results/HISTORY.md,
/// "Measurements behind the code"). The cells are the same whatever the
/// reach (the bounding square stays at `REACH`).
pub(super) const SPACED_REACH: f64 = 1.6;
/// The most points a cell is cut by.
const MAX_USED: usize = 256;

/// A reusable workspace for cells.
struct Cells<'a> {
    grid: &'a PointGrid,
    /// The bounding square's half-width (`REACH` spacings).
    square: f64,
    /// The first reach: the points within it come with each cell.
    reach: f64,
    near: Vec<(f64, usize)>,
    cell: Vec<[f64; 2]>,
    tmp: Vec<[f64; 2]>,
    /// The point (sorted index) whose bisector each edge of `cell` (from
    /// the vertex of the same index to the next) lies on; `NONE` for the
    /// bounding square's edges.
    lab: Vec<u32>,
    tlab: Vec<u32>,
}

/// The label of an edge of the bounding square.
const NONE: u32 = u32::MAX;

impl<'a> Cells<'a> {
    fn new(grid: &'a PointGrid, square: f64, reach: f64) -> Self {
        Cells {
            grid,
            square,
            reach,
            near: Vec::with_capacity(64),
            cell: Vec::with_capacity(32),
            tmp: Vec::with_capacity(32),
            lab: Vec::with_capacity(32),
            tlab: Vec::with_capacity(32),
        }
    }

    /// The cell of sorted point `s` in the plane of `nrm` (any unit
    /// vector when zero), in `self.cell`, in the basis returned; `first`
    /// holds the other points within the reach (sorted index, squared
    /// distance).
    fn cell(
        &mut self,
        s: usize,
        nrm: DVec3,
        first: &[(u32, f64)],
        runs: &[Range<usize>; 27],
    ) -> (DVec3, DVec3) {
        let nrm = geom::unit_or_zero(nrm);
        let (t1, t2) = geom::tangent_basis(if nrm == DVec3::ZERO { DVec3::Z } else { nrm });
        let rel = self.grid.rel();
        let q = rel[s];
        let (h, reach) = (self.square, self.reach);
        self.cell.clear();
        self.cell.extend([[-h, -h], [h, -h], [h, h], [-h, h]]);
        self.lab.clear();
        self.lab.extend([NONE; 4]);
        // The points within the first reach, then (when the cell is not
        // closed yet) those up to twice its farthest corner: after them
        // no point can cut it, and the square bounds that corner at
        // sqrt 2 h. Nearest first either way: the same cuts in the same
        // order whatever the first reach.
        let mut used = 0;
        for round in 0..2 {
            self.near.clear();
            let near = &mut self.near;
            let hi = if round == 0 {
                near.extend(first.iter().map(|&(t, d2)| (d2, t as usize)));
                reach
            } else {
                // Next to an empty patch or an open edge: the points that
                // can still cut it, up to twice its farthest corner.
                let hi = 2.0 * corner2(&self.cell).sqrt();
                let mut add = |t: usize, d2: f64| {
                    if t != s && d2 > reach * reach {
                        near.push((d2, t));
                    }
                };
                if hi <= self.grid.cell() {
                    // Within the 27 cells around, which the scan found:
                    // no search of the grid's keys.
                    for t in runs.iter().flat_map(|r| r.clone()) {
                        let d2 = (rel[t] - q).length_squared();
                        if d2 <= hi * hi {
                            add(t, d2);
                        }
                    }
                } else {
                    self.grid.for_each_within(q, hi, add);
                }
                hi
            };
            // Nearest first (ties in grid order): the far ones then rarely
            // cut, and the loop stops as soon as none can. A squared
            // distance is never negative, so its bits sort as it does.
            near.sort_unstable_by_key(|a| (a.0.to_bits(), a.1));
            let mut far2 = corner2(&self.cell);
            for &(d2, t) in near.iter() {
                if 4.0 * far2 <= d2 || used == MAX_USED {
                    return (t1, t2);
                }
                used += 1;
                let d = rel[t] - q;
                let v = [d.dot(t1), d.dot(t2)];
                let c = 0.5 * (v[0] * v[0] + v[1] * v[1]);
                // Most bisectors past the nearest few miss the cell: no
                // copy for those.
                if c > 0.0
                    && self
                        .cell
                        .iter()
                        .any(|p| p[0] * v[0] + p[1] * v[1] - c > 0.0)
                {
                    geom::clip_half_plane(
                        (&self.cell, &self.lab),
                        v,
                        c,
                        t as u32,
                        (&mut self.tmp, &mut self.tlab),
                    );
                    std::mem::swap(&mut self.cell, &mut self.tmp);
                    std::mem::swap(&mut self.lab, &mut self.tlab);
                    far2 = corner2(&self.cell);
                }
            }
            if 4.0 * corner2(&self.cell) <= hi * hi {
                break;
            }
        }
        (t1, t2)
    }
}

/// The open edges of the surface the points lie on, indexed by the grid
/// cells they pass through, for cutting the cells of the points next to
/// them.
pub(super) struct OpenEdges {
    /// Each edge's ends and its triangle's third corner, relative to the
    /// point grid's corner.
    edges: Vec<[DVec3; 3]>,
    /// Edges by the cells (of side `side`) they pass through.
    cells: HashMap<[i64; 3], Vec<u32>>,
    side: f64,
}

impl OpenEdges {
    /// `edges` (ends and third corner, as `Adjacency::open_edges` gives
    /// them) relative to `corner`, in cells of side `side`.
    fn new(edges: &[[DVec3; 3]], corner: DVec3, side: f64) -> OpenEdges {
        let edges: Vec<[DVec3; 3]> = edges.iter().map(|e| e.map(|p| p - corner)).collect();
        let mut cells: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, [a, b, _]) in edges.iter().enumerate() {
            // Every cell the edge passes through: points along it at most
            // half a cell apart.
            let steps = ((*b - *a).length() / (0.5 * side)).ceil().min(1e6) as usize + 1;
            for k in 0..=steps {
                let p = *a + (*b - *a) * (k as f64 / steps as f64);
                let ids = cells.entry(key(p, side)).or_default();
                if ids.last() != Some(&(i as u32)) {
                    ids.push(i as u32);
                }
            }
        }
        OpenEdges { edges, cells, side }
    }

    /// The edges that pass through the 27 cells around `q`, each once, in
    /// their order.
    fn near(&self, q: DVec3, out: &mut Vec<u32>) {
        out.clear();
        let c = key(q, self.side);
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(ids) = self.cells.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        out.extend_from_slice(ids);
                    }
                }
            }
        }
        out.sort_unstable();
        out.dedup();
    }
}

/// The cell of side `side` that holds `p`.
fn key(p: DVec3, side: f64) -> [i64; 3] {
    (p / side).floor().to_array().map(|x| x as i64)
}

impl Cells<'_> {
    /// Cuts the cell of sorted point `s` (in `self.cell`, in the tangent
    /// basis `(t1, t2)`) by the open edges within its reach whose inner
    /// side the point is on.
    fn cut_at_edges(
        &mut self,
        s: usize,
        (t1, t2): (DVec3, DVec3),
        open: &OpenEdges,
        near: &mut Vec<u32>,
    ) {
        let q = self.grid.rel()[s];
        // No corner of the cell is farther than this.
        let reach = std::f64::consts::SQRT_2 * self.square * (1.0 + 1e-9);
        open.near(q, near);
        for &e in near.iter() {
            let [a, b, c] = open.edges[e as usize];
            if geom::segment_distance(q, a, b) > reach {
                continue;
            }
            let flat = |x: DVec3| {
                let d = x - q;
                [d.dot(t1), d.dot(t2)]
            };
            let (a2, b2, c2) = (flat(a), flat(b), flat(c));
            // The edge's line in the plane, `v . x = k`, the surface on
            // the side of its triangle's third corner (`v . c < k`).
            let mut v = [b2[1] - a2[1], a2[0] - b2[0]];
            let mut k = v[0] * a2[0] + v[1] * a2[1];
            let inner = v[0] * c2[0] + v[1] * c2[1] - k;
            if inner == 0.0 || !inner.is_finite() {
                // Seen end on, or a triangle of no width in this plane.
                continue;
            }
            if inner > 0.0 {
                v = [-v[0], -v[1]];
                k = -k;
            }
            // A point beyond the edge (across a gap, a hole's far rim)
            // is not cut by it; one on it (to its rounding) is.
            let len = (v[0] * v[0] + v[1] * v[1]).sqrt();
            if k < -1e-9 * len * self.square {
                continue;
            }
            if self
                .cell
                .iter()
                .any(|p| p[0] * v[0] + p[1] * v[1] - k > 0.0)
            {
                geom::clip_half_plane(
                    (&self.cell, &self.lab),
                    v,
                    k,
                    NONE,
                    (&mut self.tmp, &mut self.tlab),
                );
                std::mem::swap(&mut self.cell, &mut self.tmp);
                std::mem::swap(&mut self.lab, &mut self.tlab);
            }
        }
    }
}

/// The area and centroid (from the origin) of a convex polygon.
fn area_centroid(poly: &[[f64; 2]]) -> (f64, [f64; 2]) {
    let n = poly.len();
    let (mut a2, mut cx, mut cy) = (0.0, 0.0, 0.0);
    for k in 0..n {
        let (p, q) = (poly[k], poly[(k + 1) % n]);
        let x = p[0] * q[1] - q[0] * p[1];
        a2 += x;
        cx += (p[0] + q[0]) * x;
        cy += (p[1] + q[1]) * x;
    }
    if a2 > 0.0 {
        (0.5 * a2, [cx / (3.0 * a2), cy / (3.0 * a2)])
    } else {
        (0.5 * a2.abs(), [0.0, 0.0])
    }
}

/// The squared distance of a cell's farthest corner from its point.
fn corner2(cell: &[[f64; 2]]) -> f64 {
    cell.iter()
        .map(|v| v[0] * v[0] + v[1] * v[1])
        .fold(0.0, f64::max)
}

/// The area of each point's Voronoi cell in its tangent plane (see the
/// module), for points on a surface of area `area` (which sets the first
/// reach); a lone point gets `area`.
pub fn voronoi_areas(positions: &[DVec3], normals: &[DVec3], area: f64) -> Vec<f32> {
    voronoi_areas_within(positions, normals, area, REACH, &[])
}

/// `voronoi_areas` with a first reach of `reach` spacings, the cells cut
/// at the surface's `open` edges (`Adjacency::open_edges`).
pub(super) fn voronoi_areas_within(
    positions: &[DVec3],
    normals: &[DVec3],
    area: f64,
    reach: f64,
    open: &[[DVec3; 3]],
) -> Vec<f32> {
    if positions.len() <= 1 {
        return vec![area as f32; positions.len()];
    }
    let (grid, by_sorted) = per_cell(positions, normals, area, reach, open, |cells, _, _| {
        geom::polygon_area_2d(&cells.cell)
    });
    in_input_order(&grid, by_sorted.into_iter())
}

/// The weights `scatter --ptarea centroid` gives: each point's Voronoi
/// cell area (as `voronoi_areas`), placed at the cell's centroid. The
/// centroid lies in a triangle of the point and two consecutive Voronoi
/// neighbours (a Delaunay triangle); the area is shared among those three
/// by the centroid's barycentric coordinates, so that a sum of weights
/// times a linear function is the function's integral over the cells,
/// where the point's own weight alone would miss it by the gradient
/// times the centroid's offset (the leading error of a weighted sum over
/// blue noise). The shares are never negative, and their total is each
/// cell's area. A centroid beyond the triangle's far edge (a cell next
/// to an empty patch) is moved onto it; a cell with no such triangle (at
/// an open edge) keeps its area.
pub fn voronoi_weights(positions: &[DVec3], normals: &[DVec3], area: f64) -> Vec<f32> {
    voronoi_weights_within(positions, normals, area, REACH, &[])
}

/// `voronoi_weights` with a first reach of `reach` spacings, the cells
/// cut at the surface's `open` edges.
pub(super) fn voronoi_weights_within(
    positions: &[DVec3],
    normals: &[DVec3],
    area: f64,
    reach: f64,
    open: &[[DVec3; 3]],
) -> Vec<f32> {
    let n = positions.len();
    if n <= 1 {
        return vec![area as f32; n];
    }
    let (grid, shares) = per_cell(
        positions,
        normals,
        area,
        reach,
        open,
        |cells, s, (t1, t2)| {
            let (a, c) = area_centroid(&cells.cell);
            let rel = cells.grid.rel();
            let at = |k: u32| {
                let d = rel[k as usize] - rel[s];
                [d.dot(t1), d.dot(t2)]
            };
            // Consecutive neighbours around the cell, in its edges' order.
            let mut labs = cells.lab.iter().copied().filter(|&k| k != NONE);
            let Some(first) = labs.next() else {
                return (a, [(NONE, 0.0); 2]);
            };
            let mut last = first;
            for kb in labs.chain(std::iter::once(first)) {
                let ka = std::mem::replace(&mut last, kb);
                let (pa, pb) = (at(ka), at(kb));
                let det = pa[0] * pb[1] - pa[1] * pb[0];
                if !det.is_finite() || det <= 0.0 {
                    continue;
                }
                let ba = (c[0] * pb[1] - c[1] * pb[0]) / det;
                let bb = (pa[0] * c[1] - pa[1] * c[0]) / det;
                if ba >= 0.0 && bb >= 0.0 {
                    let sum = ba + bb;
                    let (ba, bb, own) = if sum > 1.0 {
                        (ba / sum, bb / sum, 0.0)
                    } else {
                        (ba, bb, 1.0 - sum)
                    };
                    return (a * own, [(ka, a * ba), (kb, a * bb)]);
                }
            }
            (a, [(NONE, 0.0); 2])
        },
    );
    let mut w: Vec<f64> = shares.iter().map(|s| s.0).collect();
    // In sorted order, one point after another: the same sums on any
    // thread count.
    for (_, given) in &shares {
        for &(k, x) in given {
            if k != NONE {
                w[k as usize] += x;
            }
        }
    }
    in_input_order(&grid, w.into_iter())
}

/// `f(cells, s, basis)` of every point's cell (sorted index `s`, the
/// cell in `cells.cell` in the tangent `basis`), in the grid's order;
/// the first reach `spacings` hexagonal spacings.
fn per_cell<T: Send>(
    positions: &[DVec3],
    normals: &[DVec3],
    area: f64,
    spacings: f64,
    open: &[[DVec3; 3]],
    f: impl Fn(&Cells, usize, (DVec3, DVec3)) -> T + Sync,
) -> (PointGrid, Vec<T>) {
    let square = first_reach(positions, area, REACH);
    let reach = square * spacings / REACH;
    let grid = PointGrid::new(positions, 2.0 * reach);
    let order = grid.order();
    // (A cell reaches at most sqrt 2 of the square from its point: the 27
    // cells of side 1.5 squares around it hold every edge it may meet.)
    let open = (!open.is_empty()).then(|| OpenEdges::new(open, grid.corner(), 1.5 * square));
    let out = grid.map_near_runs(
        reach,
        || (Cells::new(&grid, square, reach), Vec::new()),
        |(cells, near), s, first, runs| {
            let basis = cells.cell(s, normals[order[s] as usize], first, runs);
            if let Some(open) = &open {
                cells.cut_at_edges(s, basis, open, near);
            }
            f(cells, s, basis)
        },
    );
    (grid, out)
}

/// Values in the grid's order back in the input's, as f32.
fn in_input_order(grid: &PointGrid, by_sorted: impl Iterator<Item = f64>) -> Vec<f32> {
    let order = grid.order();
    let mut out = vec![0f32; order.len()];
    for (s, a) in by_sorted.enumerate() {
        out[order[s] as usize] = a as f32;
    }
    out
}

/// `spacings` spacings of `n` points on `area`; from the box when the
/// area says nothing (not finite or not positive): as if the points
/// covered its largest face.
fn first_reach(positions: &[DVec3], area: f64, spacings: f64) -> f64 {
    let n = positions.len();
    let area = if area.is_finite() && area > 0.0 {
        area
    } else {
        let (lo, hi) = positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let e = hi - lo;
        (e.x * e.y).max(e.y * e.z).max(e.z * e.x)
    };
    let r = spacings * hex_spacing(area, n);
    if r.is_finite() && r > 0.0 {
        r
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;

    /// The cells do not depend on the first reach: a shorter one leaves
    /// more of them to the second round, which finds the same cuts.
    #[test]
    fn a_shorter_first_reach_makes_the_same_cells() {
        let mut g = rand_pcg::Pcg32::new(3, 7);
        let mut u = || g.next_u32() as f64 / 4294967296.0;
        // A jittered hexagonal lattice (points at least ~0.8 spacings
        // apart, as `--blue` leaves them) and random points, on a plane.
        let side = 60;
        let lattice: Vec<DVec3> = (0..side * side)
            .map(|k| {
                let (i, j) = ((k % side) as f64, (k / side) as f64);
                let x = i + 0.5 * (j % 2.0) + 0.1 * (u() - 0.5);
                let y = j * 0.75f64.sqrt() + 0.1 * (u() - 0.5);
                DVec3::new(x, y, 0.0)
            })
            .collect();
        let random: Vec<DVec3> = (0..side * side)
            .map(|_| DVec3::new(u() * side as f64, u() * side as f64, 0.0))
            .collect();
        for (name, pos) in [("lattice", lattice), ("random", random)] {
            let area = (side * side) as f64 * 0.75f64.sqrt();
            let nrm = vec![DVec3::Z; pos.len()];
            let wide = voronoi_areas_within(&pos, &nrm, area, REACH, &[]);
            for reach in [SPACED_REACH, 1.0] {
                let short = voronoi_areas_within(&pos, &nrm, area, reach, &[]);
                let same = wide.iter().zip(&short).filter(|(a, b)| a == b).count();
                assert_eq!(same, pos.len(), "{name}: areas, reach {reach}");
            }
            let wide = voronoi_weights_within(&pos, &nrm, area, REACH, &[]);
            let short = voronoi_weights_within(&pos, &nrm, area, SPACED_REACH, &[]);
            for (i, (a, b)) in wide.iter().zip(&short).enumerate() {
                assert!(
                    (a - b).abs() <= 1e-6 * a.abs(),
                    "{name}: weight {i}: {a} {b}"
                );
            }
            let total: f64 = wide.iter().map(|&w| w as f64).sum();
            assert!(
                total > 0.9 * area,
                "{name}: cells cover the plane ({total})"
            );
        }
    }
}
