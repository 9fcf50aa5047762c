//! Nearest hits of parallel rays: every ray of a distant light travels
//! along the same direction `d`, so seen down `d` each ray is a point and
//! meets only the triangles whose shadows on a plane across `d` cover
//! that point. [`Columns`] rasterises the triangles of an [`Occluder`]
//! (in its f32 unit frame, with its triangle test) into a grid on that
//! plane, each cell's triangles sorted by their nearest depth along `d`;
//! a ray looks up its one cell and tests its triangles in depth order
//! until the next one starts beyond the nearest hit so far.
//!
//! The answers are the BVH's: the same triangle test on the same f32 ray,
//! and every triangle the ray can hit is in its cell (each is entered in
//! every cell its projection, grown by a margin far above the rounding of
//! the projection and of the test's edge tolerance, touches). Equal
//! distances go to the lowest triangle index, as in the BVH. Two
//! departures, both at edges and corners: a ray through an edge may take
//! the other triangle of the edge, at the same distance up to rounding;
//! and a ray along an axis exactly through a corner of the mesh can hit
//! there, where the BVH's box test (an empty slab) misses the box whose
//! face the ray lies in.
//!
//! When the grid would hold too many entries (a mesh of huge triangles
//! over tiny ones), [`Columns::new`] declines and the caller keeps the
//! BVH.

use glam::{DVec3, Vec3A};
use obvhs::ray::Ray;

use crate::geom::bvh::{Facing, Occluder};
use crate::geom::ray_tri::Sheared;

/// Cells per triangle. On the bunny bake at 1M points, anything from
/// 0.5 to 16 gave sssingle the same time within the machine's noise (by
/// hand): the cells' triangles are tested in depth order and the first
/// hit ends the search, so a cell's size hardly matters.
const CELLS_PER_TRI: f64 = 2.0;
/// At most this many cells.
const MAX_CELLS: usize = 1 << 24;
/// At most this many entries per triangle on average, or no grid.
const MAX_REFS_PER_TRI: usize = 24;
/// At most this many entries in all (12 bytes each: 400 MB), or no grid:
/// a mesh of tens of millions of triangles keeps the BVH alone.
const MAX_ENTRIES: usize = 1 << 25;
/// The margin around each triangle's projection and depth range, in the
/// unit frame (coordinates within 1 of the origin): a hundred times the
/// rounding of an f32 projection there.
const PAD: f32 = 1e-5;

/// A grid is built serially; each ray through it saves a fraction of a
/// microsecond against the BVH (more for sssingle's nearest hits from
/// inside the mesh than for illum's shadow rays), and the rays run on
/// every thread: below these many rays a triangle, a grid does not repay
/// its building (the build and ray rates in `benches/illum.rs`,
/// `benches/sssingle.rs` and benches/results/HISTORY.md, "Measurements
/// behind the code").
pub const NEAREST_RAYS_PER_TRIANGLE: u64 = 4;
/// The same for shadow rays (any hit).
pub const SHADOW_RAYS_PER_TRIANGLE: u64 = 16;

/// Whether `rays` parallel rays through `occ`, `per_triangle` of them
/// needed a triangle, repay building a grid.
pub fn worth_it(occ: &Occluder, rays: u64, per_triangle: u64) -> bool {
    rays >= per_triangle * occ.triangle_count() as u64
}

/// One triangle in a cell: its place in the occluder's leaf order and its
/// depth range along `d`.
#[derive(Clone, Copy, Debug)]
struct Entry {
    tri: u32,
    zmin: f32,
    zmax: f32,
}

/// The grid on the plane across `d`: its corner, cell size and size in
/// cells.
#[derive(Clone, Copy, Debug)]
struct Raster {
    lo: [f32; 2],
    inv_cell: f32,
    cell: f32,
    nx: usize,
    ny: usize,
}

/// The triangles of an occluder seen down one direction.
pub struct Columns {
    /// The rays' direction, as given.
    dir: DVec3,
    /// The same and the plane's axes, in the unit frame.
    d: Vec3A,
    u: Vec3A,
    v: Vec3A,
    grid: Raster,
    /// Cell `c`'s entries are `entries[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    entries: Vec<Entry>,
}

impl Columns {
    /// The grid for rays along the unit `dir` through `occ`'s triangles;
    /// `None` when there are none or it would be too large.
    pub fn new(occ: &Occluder, dir: DVec3) -> Option<Columns> {
        let tris = occ.triangles();
        if tris.is_empty() || !dir.is_finite() || dir == DVec3::ZERO {
            return None;
        }
        // Exactly the direction `nearest` gives its rays.
        let d = Vec3A::from(dir.as_vec3());
        let u = Vec3A::from(dir.any_orthonormal_vector().as_vec3());
        let v = d.cross(u).normalize();
        let proj: Vec<[[f32; 3]; 3]> = tris
            .iter()
            .map(|t| [t.v0, t.v1, t.v2].map(|p| [p.dot(u), p.dot(v), p.dot(d)]))
            .collect();
        let (mut lo, mut hi) = ([f32::INFINITY; 2], [f32::NEG_INFINITY; 2]);
        for c in proj.iter().flatten() {
            for a in 0..2 {
                lo[a] = lo[a].min(c[a]);
                hi[a] = hi[a].max(c[a]);
            }
        }
        if !(lo[0].is_finite() && lo[1].is_finite() && hi[0].is_finite() && hi[1].is_finite()) {
            return None;
        }
        let lo = lo.map(|x| x - 2.0 * PAD);
        let (w, h) = (hi[0] + 2.0 * PAD - lo[0], hi[1] + 2.0 * PAD - lo[1]);
        let cells = (CELLS_PER_TRI * tris.len() as f64).clamp(1.0, MAX_CELLS as f64);
        // Square cells, `cells` of them over the box; a box thinner than a
        // cell in one direction (a flat mesh seen edge on, all of it one
        // point) gets a row of `cells`: at most about 3 `cells` in all.
        let cell = ((w as f64 * h as f64 / cells)
            .sqrt()
            .max(w.max(h) as f64 / cells)) as f32;
        if !(cell > 0.0 && cell.is_finite()) {
            return None;
        }
        let nx = ((w / cell).ceil() as usize).max(1);
        let ny = ((h / cell).ceil() as usize).max(1);
        if nx.saturating_mul(ny) > MAX_CELLS {
            return None;
        }
        let grid = Raster {
            lo,
            inv_cell: 1.0 / cell,
            cell,
            nx,
            ny,
        };
        // Count, then fill: each triangle's cells row by row.
        let budget = (MAX_REFS_PER_TRI * tris.len()).min(MAX_ENTRIES);
        let mut start = vec![0u32; nx * ny + 1];
        let mut total = 0usize;
        for p in &proj {
            grid.spans(p, |row, c0, c1| {
                for c in c0..=c1 {
                    start[row * nx + c] += 1;
                }
                total += c1 - c0 + 1;
            });
            if total > budget {
                return None;
            }
        }
        let mut at = 0u32;
        for s in start.iter_mut() {
            let n = *s;
            *s = at;
            at += n;
        }
        let mut fill = start.clone();
        let mut entries = vec![
            Entry {
                tri: 0,
                zmin: 0.0,
                zmax: 0.0
            };
            total
        ];
        for (j, p) in proj.iter().enumerate() {
            let e = Entry {
                tri: j as u32,
                zmin: p[0][2].min(p[1][2]).min(p[2][2]) - PAD,
                zmax: p[0][2].max(p[1][2]).max(p[2][2]) + PAD,
            };
            grid.spans(p, |row, c0, c1| {
                for c in c0..=c1 {
                    let k = row * nx + c;
                    entries[fill[k] as usize] = e;
                    fill[k] += 1;
                }
            });
        }
        for c in 0..nx * ny {
            let (a, b) = (start[c] as usize, start[c + 1] as usize);
            entries[a..b]
                .sort_unstable_by(|x, y| x.zmin.total_cmp(&y.zmin).then(x.tri.cmp(&y.tri)));
        }
        Some(Columns {
            dir,
            d,
            u,
            v,
            grid,
            start,
            entries,
        })
    }

    /// The grid's cells: how many, and the entries in all.
    pub fn size(&self) -> (usize, usize) {
        (self.grid.nx * self.grid.ny, self.entries.len())
    }

    /// The cell of the ray's origin (none: outside the grid, where no
    /// triangle is) and the origin's depth along `d`.
    #[inline]
    fn cell(&self, ray: &Ray) -> Option<(&[Entry], f32)> {
        let o = ray.origin;
        let (pu, pv, z0) = (o.dot(self.u), o.dot(self.v), o.dot(self.d));
        let g = &self.grid;
        let fu = (pu - g.lo[0]) * g.inv_cell;
        let fv = (pv - g.lo[1]) * g.inv_cell;
        if !(fu >= 0.0 && fv >= 0.0 && fu < g.nx as f32 && fv < g.ny as f32) {
            return None;
        }
        let (cx, cy) = ((fu as usize).min(g.nx - 1), (fv as usize).min(g.ny - 1));
        let c = cy * g.nx + cx;
        Some((
            &self.entries[self.start[c] as usize..self.start[c + 1] as usize],
            z0,
        ))
    }

    /// What [`Occluder::occluded`] answers for a shadow ray along this
    /// grid's direction (the BVH's when `dir` is another).
    pub fn occluded(
        &self,
        occ: &Occluder,
        origin: DVec3,
        normal: DVec3,
        dir: DVec3,
        dist: f64,
    ) -> bool {
        if dir != self.dir {
            return occ.occluded(origin, normal, dir, dist);
        }
        self.occluded_ray(occ, &occ.shadow_ray(origin, normal, dir, dist))
    }

    /// [`Occluder::occluded_ray`] for a ray along this grid's direction
    /// (in `occ`'s unit frame, `occ` the occluder this was built from).
    pub fn occluded_ray(&self, occ: &Occluder, ray: &Ray) -> bool {
        debug_assert_eq!(ray.direction, self.d);
        let Some((cell, z0)) = self.cell(ray) else {
            return false;
        };
        let zeps = zeps(z0);
        let sh = Sheared::new(ray);
        for e in cell {
            if e.zmin - z0 > ray.tmax + zeps {
                break;
            }
            if e.zmax - z0 >= ray.tmin - zeps && occ.hits_leaf(e.tri, ray, &sh) {
                return true;
            }
        }
        false
    }

    /// What [`Occluder::nearest`] answers for the ray from `origin` along
    /// `dir` over `[tmin, tmax]`, `occ` the occluder this was built from:
    /// the mesh triangle and the distance (through the BVH when `dir` is
    /// not this grid's).
    pub fn nearest(
        &self,
        occ: &Occluder,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        facing: Facing,
    ) -> Option<(usize, f64)> {
        if dir != self.dir {
            return occ.nearest(origin, dir, tmin, tmax, facing);
        }
        let mut ray = occ.unit_ray(origin, self.dir, tmin, tmax);
        self.nearest_ray(occ, &mut ray, facing)
            .map(|b| (occ.leaf_id(b) as usize, occ.mesh_dist(ray.tmax)))
    }

    /// [`Occluder::nearest_ray`] for a ray along this grid's direction (in
    /// `occ`'s unit frame, `occ` the occluder this was built from): the
    /// hit's place in leaf order, with `ray.tmax` set to its distance.
    pub fn nearest_ray(&self, occ: &Occluder, ray: &mut Ray, facing: Facing) -> Option<u32> {
        debug_assert_eq!(ray.direction, self.d);
        let (cell, z0) = self.cell(ray)?;
        let mut best: Option<u32> = None;
        let zeps = zeps(z0);
        let sh = Sheared::new(ray);
        for e in cell {
            if e.zmin - z0 > ray.tmax + zeps {
                break;
            }
            if e.zmax - z0 < ray.tmin - zeps {
                continue;
            }
            if let Some(t) = occ.hit_leaf(e.tri, ray, &sh, facing) {
                let better =
                    t < ray.tmax || best.is_none_or(|b| occ.leaf_id(e.tri) < occ.leaf_id(b));
                if better {
                    ray.tmax = t;
                    best = Some(e.tri);
                }
            }
        }
        best
    }
}

/// How far a hit's distance may stray from its triangle's depth range
/// measured from an origin at depth `z0`: the margin, and the rounding of
/// the depths.
#[inline]
fn zeps(z0: f32) -> f32 {
    PAD + 4.0 * f32::EPSILON * z0.abs()
}

impl Raster {
    /// Calls `f(row, first column, last column)` for each row of cells
    /// the triangle `p` (projected corners), grown by the margin, touches:
    /// within a row, the columns between the least and greatest `u` of
    /// the triangle's part inside the row's band.
    fn spans(&self, p: &[[f32; 3]; 3], mut f: impl FnMut(usize, usize, usize)) {
        let vmin = p[0][1].min(p[1][1]).min(p[2][1]) - PAD;
        let vmax = p[0][1].max(p[1][1]).max(p[2][1]) + PAD;
        let r0 = self.index(vmin, 1, self.ny);
        let r1 = self.index(vmax, 1, self.ny);
        for row in r0..=r1 {
            // The band, grown by the margin, clipped to the triangle's.
            let b0 = (self.lo[1] + row as f32 * self.cell - PAD).max(vmin);
            let b1 = (self.lo[1] + (row + 1) as f32 * self.cell + PAD).min(vmax);
            let (mut umin, mut umax) = (f32::INFINITY, f32::NEG_INFINITY);
            let mut take = |x: f32| {
                umin = umin.min(x);
                umax = umax.max(x);
            };
            for k in 0..3 {
                let (a, b) = (p[k], p[(k + 1) % 3]);
                if a[1] >= b0 && a[1] <= b1 {
                    take(a[0]);
                }
                // Where the edge crosses the band's two lines.
                for y in [b0, b1] {
                    if (a[1] - y) * (b[1] - y) < 0.0 {
                        let t = (y - a[1]) / (b[1] - a[1]);
                        take(a[0] + t * (b[0] - a[0]));
                    }
                }
            }
            if umin > umax {
                // The band only grazes the triangle (its margin): its
                // whole width is taken.
                umin = p[0][0].min(p[1][0]).min(p[2][0]);
                umax = p[0][0].max(p[1][0]).max(p[2][0]);
            }
            // The crossings are rounded: their margin is the triangle's
            // size times a few ulps, on top of the fixed one.
            let slack = PAD + 1e-6 * (umax - umin);
            let c0 = self.index(umin - slack, 0, self.nx);
            let c1 = self.index(umax + slack, 0, self.nx);
            f(row, c0, c1);
        }
    }

    /// The cell index of coordinate `x` on axis `a`, clamped to `[0, n)`.
    #[inline]
    fn index(&self, x: f32, a: usize, n: usize) -> usize {
        let i = ((x - self.lo[a]) * self.inv_cell).floor();
        if i.is_nan() || i < 0.0 {
            0
        } else {
            (i as usize).min(n - 1)
        }
    }
}
