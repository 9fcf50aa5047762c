//! `ptarea voronoi`: the area of each point's Voronoi cell in its tangent
//! plane.
//!
//! A point's cell is a square of half-width `R` (twice the hexagonal
//! spacing of the cloud on its area: it bounds a cell at an open edge) cut
//! by the bisectors of the other points within `R`, projected onto the
//! plane through the point with its normal, nearest first. It is closed
//! for sure once its farthest corner lies within half the distance of
//! every point not yet used; a cell not closed by the points within `R`
//! (next to an empty patch, or at an open edge) is cut by those up to
//! twice its farthest corner (at most `2 sqrt 2 R`: the square bounds
//! it), at most the 256 nearest (a surface folded onto itself many
//! times). Exact for
//! points on a plane away from its edges; on a smooth surface the error is
//! of the order of the cell's size over the radius of curvature. Cells at
//! an open boundary stop at the square and come out too large (`promote
//! --normalize` rescales the total).
//!
//! The points within `R` come cell by cell from a grid of `2 R` cells
//! (`geom::grid`), the rare second round from a query of its own; each
//! point's cell depends only on the positions, so the result does not
//! depend on the thread count.

use glam::DVec3;

use super::hex_spacing;
use crate::geom::grid::PointGrid;
use crate::geom::{self};

/// The first reach, in hexagonal spacings.
const REACH: f64 = 2.0;
/// The most points a cell is cut by.
const MAX_USED: usize = 256;

/// A reusable workspace for cells.
struct Cells<'a> {
    grid: &'a PointGrid,
    reach: f64,
    near: Vec<(f64, usize)>,
    cell: Vec<[f64; 2]>,
    tmp: Vec<[f64; 2]>,
}

impl<'a> Cells<'a> {
    fn new(grid: &'a PointGrid, reach: f64) -> Self {
        Cells {
            grid,
            reach,
            near: Vec::with_capacity(64),
            cell: Vec::with_capacity(32),
            tmp: Vec::with_capacity(32),
        }
    }

    /// The cell of sorted point `s` in the plane of `nrm` (any unit
    /// vector when zero), in `self.cell`, in the basis returned; `first`
    /// holds the other points within the reach (sorted index, squared
    /// distance).
    fn cell(&mut self, s: usize, nrm: DVec3, first: &[(u32, f64)]) -> (DVec3, DVec3) {
        let nrm = geom::unit_or_zero(nrm);
        let (t1, t2) = geom::tangent_basis(if nrm == DVec3::ZERO { DVec3::Z } else { nrm });
        let rel = self.grid.rel();
        let q = rel[s];
        let h = self.reach;
        self.cell.clear();
        self.cell.extend([[-h, -h], [h, -h], [h, h], [-h, h]]);
        // The points within `h`, then (when the cell is not closed yet)
        // those up to twice its farthest corner: after them no point can
        // cut it, and the square bounds that corner at sqrt 2 h.
        let mut used = 0;
        for round in 0..2 {
            self.near.clear();
            let near = &mut self.near;
            let hi = if round == 0 {
                near.extend(first.iter().map(|&(t, d2)| (d2, t as usize)));
                h
            } else {
                // Next to an empty patch or an open edge: the points that
                // can still cut it, up to twice its farthest corner.
                let hi = 2.0 * corner2(&self.cell).sqrt();
                self.grid.for_each_within(q, hi, |t, d2| {
                    if t != s && d2 > h * h {
                        near.push((d2, t));
                    }
                });
                hi
            };
            // Nearest first (ties in grid order): the far ones then rarely
            // cut, and the loop stops as soon as none can.
            near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            for &(d2, t) in near.iter() {
                if 4.0 * corner2(&self.cell) <= d2 || used == MAX_USED {
                    return (t1, t2);
                }
                used += 1;
                let d = rel[t] - q;
                let v = [d.dot(t1), d.dot(t2)];
                let c = 0.5 * (v[0] * v[0] + v[1] * v[1]);
                if c > 0.0 {
                    geom::clip_half_plane(&self.cell, v, c, &mut self.tmp);
                    std::mem::swap(&mut self.cell, &mut self.tmp);
                }
            }
            if 4.0 * corner2(&self.cell) <= hi * hi {
                break;
            }
        }
        (t1, t2)
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
    let n = positions.len();
    if n <= 1 {
        return vec![area as f32; n];
    }
    let reach = first_reach(positions, area);
    let grid = PointGrid::new(positions, 2.0 * reach);
    let order = grid.order();
    let mut out = vec![0f32; n];
    let by_sorted: Vec<f32> = grid.map_near(
        reach,
        || Cells::new(&grid, reach),
        |cells, s, first| {
            cells.cell(s, normals[order[s] as usize], first);
            geom::polygon_area_2d(&cells.cell) as f32
        },
    );
    for (s, a) in by_sorted.into_iter().enumerate() {
        out[order[s] as usize] = a;
    }
    out
}

/// `REACH` spacings of `n` points on `area`; from the box when the area
/// says nothing (not finite or not positive): as if the points covered
/// its largest face.
fn first_reach(positions: &[DVec3], area: f64) -> f64 {
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
    let r = REACH * hex_spacing(area, n);
    if r.is_finite() && r > 0.0 {
        r
    } else {
        1.0
    }
}
