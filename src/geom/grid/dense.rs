//! Points within one fixed radius of arbitrary positions (`filter`'s and
//! `render`'s shade points reading a cloud): cubic cells of a side at
//! least the radius in a dense array over the points' box, so that a
//! query reads the 3 x 3 x 3 cells around its own as nine runs of
//! consecutive points (a row of three cells is contiguous), with no
//! search. A k-d tree answers the same, but is built over the whole
//! cloud on one thread, which can outlast all the queries (a mesh's few
//! thousand vertices), and descends from its root for every query.
//!
//! The cells are grown until there are at most `MAX_CELLS_PER_POINT`
//! per point (a radius far below the points' spacing, or a box mostly
//! empty): a query then reads more points per cell, never fewer than it
//! should. Points within a cell keep their input order, so the answers
//! come in an order that depends only on the points.

use glam::DVec3;
use rayon::prelude::*;

/// The most cells per point (and at least [`MIN_CELLS`] in all).
const MAX_CELLS_PER_POINT: usize = 4;
const MIN_CELLS: usize = 1 << 12;

/// Points sorted into the cells of a dense grid.
pub struct RadiusGrid {
    /// The points' lower corner (the grid's frame starts there).
    lo: DVec3,
    inv: f64,
    radius: f64,
    /// Cells along each axis.
    n: [usize; 3],
    /// Cell `c` holds sorted points `start[c]..start[c + 1]`.
    start: Vec<u32>,
    /// Positions relative to `lo`, in cell order.
    rel: Vec<DVec3>,
    /// The caller's index of each sorted point.
    order: Vec<u32>,
}

impl RadiusGrid {
    /// The grid of `points` (finite, fewer than 2^32) for queries within
    /// `radius` (finite, >= 0).
    pub fn new(points: &[DVec3], radius: f64) -> RadiusGrid {
        let (lo, hi) = super::bounds(points);
        let (lo, ext) = if points.is_empty() {
            (DVec3::ZERO, DVec3::ZERO)
        } else {
            (lo, hi - lo)
        };
        let limit = (MAX_CELLS_PER_POINT * points.len()).max(MIN_CELLS);
        let count = |cell: f64| -> Option<[usize; 3]> {
            let along = |e: f64| -> Option<usize> {
                let k = (e / cell).floor() + 1.0;
                (k.is_finite() && k <= limit as f64).then_some(k as usize)
            };
            let n = [along(ext.x)?, along(ext.y)?, along(ext.z)?];
            let total = n[0].checked_mul(n[1])?.checked_mul(n[2])?;
            (total <= limit).then_some(n)
        };
        // At least the radius (a little more: a point within it of a
        // query is then in a cell next to the query's, whatever the
        // rounding of their cell coordinates), never 0; doubled until the
        // cells fit.
        let mut cell = if radius > 0.0 && radius.is_finite() {
            radius * (1.0 + 1e-6)
        } else {
            ext.max_element().max(1.0) * 1e-9
        };
        let mut n = count(cell);
        while n.is_none() && cell.is_finite() {
            cell *= 2.0;
            n = count(cell);
        }
        // (A box too wide for f64, points near both ends of its range:
        // one cell holds them all.)
        let n = n.unwrap_or([1; 3]);
        let inv = if cell.is_finite() { 1.0 / cell } else { 0.0 };
        let index = |p: DVec3| -> usize {
            let c = (p - lo) * inv;
            let at = |x: f64, n: usize| (x.max(0.0) as usize).min(n - 1);
            (at(c.z, n[2]) * n[1] + at(c.y, n[1])) * n[0] + at(c.x, n[0])
        };
        let cells: Vec<u32> = points.par_iter().map(|&p| index(p) as u32).collect();
        // A counting sort, stable: within a cell, the input order.
        let mut start = vec![0u32; n[0] * n[1] * n[2] + 1];
        for &c in &cells {
            start[c as usize + 1] += 1;
        }
        for c in 1..start.len() {
            start[c] += start[c - 1];
        }
        let mut fill = start.clone();
        let mut order = vec![0u32; points.len()];
        for (i, &c) in cells.iter().enumerate() {
            order[fill[c as usize] as usize] = i as u32;
            fill[c as usize] += 1;
        }
        let rel = order.par_iter().map(|&i| points[i as usize] - lo).collect();
        RadiusGrid {
            lo,
            inv,
            radius,
            n,
            start,
            rel,
            order,
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

    /// Calls `f(index, squared distance)` for every point within the
    /// radius of `p`, in the grid's order (the same for the same points).
    pub fn for_each_within(&self, p: DVec3, mut f: impl FnMut(u32, f64)) {
        if self.order.is_empty() || !p.is_finite() {
            return;
        }
        let q = p - self.lo;
        let c = q * self.inv;
        // The cells from one before the query's to one after, within the
        // grid (a query far outside reads nothing).
        let span = |x: f64, n: usize| -> Option<(usize, usize)> {
            let k = x.floor();
            if k < -1.0 || k > n as f64 {
                return None;
            }
            let k = k as i64;
            Some(((k - 1).max(0) as usize, ((k + 1) as usize).min(n - 1)))
        };
        let (Some((x0, x1)), Some((y0, y1)), Some((z0, z1))) = (
            span(c.x, self.n[0]),
            span(c.y, self.n[1]),
            span(c.z, self.n[2]),
        ) else {
            return;
        };
        let r2 = self.radius * self.radius;
        for z in z0..=z1 {
            for y in y0..=y1 {
                let row = (z * self.n[1] + y) * self.n[0];
                let (a, b) = (self.start[row + x0], self.start[row + x1 + 1]);
                for s in a as usize..b as usize {
                    let d2 = (self.rel[s] - q).length_squared();
                    if d2 <= r2 {
                        f(self.order[s], d2);
                    }
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

    fn brute(pts: &[DVec3], q: DVec3, r: f64) -> Vec<u32> {
        (0..pts.len() as u32)
            .filter(|&j| (pts[j as usize] - q).length_squared() <= r * r)
            .collect()
    }

    /// Every radius, from far below the spacing (cells grown) to beyond
    /// the box, finds what brute force finds, queries inside and outside
    /// the box, far from the origin.
    #[test]
    fn within_finds_what_brute_force_finds() {
        let mut g = Pcg32::new(11, 3);
        let mut u = || g.next_u32() as f64 / u32::MAX as f64;
        let pts: Vec<DVec3> = (0..4000)
            .map(|_| DVec3::new(u() * 2.0, u() * 0.5, u() * 0.01) + 1e6)
            .collect();
        for r in [0.0, 1e-6, 0.003, 0.05, 0.3, 5.0] {
            let grid = RadiusGrid::new(&pts, r);
            assert_eq!(grid.len(), pts.len());
            let queries = pts.iter().step_by(61).copied().chain([
                DVec3::splat(1e6 - 0.2),
                DVec3::splat(1e6 + 3.0),
                DVec3::ZERO,
            ]);
            for q in queries {
                let mut got = Vec::new();
                grid.for_each_within(q, |i, d2| {
                    assert!((d2 - (pts[i as usize] - q).length_squared()).abs() <= 1e-12);
                    got.push(i)
                });
                got.sort_unstable();
                assert_eq!(got, brute(&pts, q, r), "r {r} q {q}");
            }
        }
    }

    /// No points, one point, and points all at one place.
    #[test]
    fn degenerate_clouds() {
        let g = RadiusGrid::new(&[], 1.0);
        g.for_each_within(DVec3::ZERO, |_, _| panic!("no points"));
        let one = [DVec3::new(3.0, -2.0, 1.0)];
        let g = RadiusGrid::new(&one, 0.5);
        let mut n = 0;
        g.for_each_within(DVec3::new(3.2, -2.0, 1.0), |i, _| {
            assert_eq!(i, 0);
            n += 1
        });
        assert_eq!(n, 1);
        // A box wider than f64's range: one cell, every point still found.
        let wide = [DVec3::splat(-1.5e308), DVec3::splat(1.5e308), DVec3::ZERO];
        let g = RadiusGrid::new(&wide, 1.0);
        let mut got = Vec::new();
        g.for_each_within(DVec3::new(0.5, 0.0, 0.0), |i, _| got.push(i));
        assert_eq!(got, vec![2]);
        let same = vec![DVec3::splat(7.0); 100];
        let g = RadiusGrid::new(&same, 0.0);
        let mut got = Vec::new();
        g.for_each_within(DVec3::splat(7.0), |i, _| got.push(i));
        assert_eq!(got, (0..100).collect::<Vec<_>>());
    }
}
