//! The ray-triangle test of the BVH ([`crate::geom::bvh`]) and of the
//! grids down a light ([`crate::geom::columns`]): watertight (Woop,
//! Benthin and Wald), one triangle at a time or a leaf's four side by
//! side with the same arithmetic, and which side of a triangle a query
//! takes.

use glam::Vec3A;
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;

/// Which triangles a nearest-hit query takes, by the side the ray meets
/// them from (outward normals wind counter-clockwise).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Facing {
    /// Every triangle.
    Any,
    /// Those the ray enters the mesh through (from outside).
    Entering,
    /// Those the ray leaves the mesh through (from inside).
    Leaving,
}

impl Facing {
    /// Whether a hit whose edge functions sum to `det` is taken. Outward
    /// normals wind counter-clockwise: seen from the origin down the ray,
    /// a triangle the ray enters through winds counter-clockwise (`det >
    /// 0` in the sheared frame's handedness), one it leaves through
    /// clockwise.
    #[inline(always)]
    pub(crate) fn takes(self, det: f32) -> bool {
        match self {
            Facing::Any => true,
            Facing::Entering => det > 0.0,
            Facing::Leaving => det < 0.0,
        }
    }
}

/// A ray made ready for the watertight triangle test (Woop, Benthin and
/// Wald, "Watertight Ray/Triangle Intersection", JCGT 2013): the axis the
/// ray runs most along (`kz`; `kx`, `ky` the others, swapped where the
/// ray runs down `kz` so the winding is kept), the shear that makes the
/// ray that axis, and the origin by those axes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sheared {
    k: [usize; 3],
    s: [f32; 3],
    o: [f32; 3],
}

impl Sheared {
    #[inline(always)]
    pub(crate) fn new(ray: &Ray) -> Sheared {
        let d = ray.direction;
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Sheared {
            k: [kx, ky, kz],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
            o: [ray.origin[kx], ray.origin[ky], ray.origin[kz]],
        }
    }
}

/// A triangle for the ray test: its three corners (in the unit frame, the
/// same f32 values in every triangle that shares one).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Tri {
    v: [[f32; 4]; 3],
}

impl Tri {
    pub(crate) fn new(t: &Triangle) -> Tri {
        let c = |v: Vec3A| [v.x, v.y, v.z, 0.0];
        Tri {
            v: [c(t.v0), c(t.v1), c(t.v2)],
        }
    }

    /// The hit distance in `[tmin, tmax]`, if any, on a triangle that
    /// faces the ray as `facing` asks.
    ///
    /// Watertight: the corners are moved to the ray's origin and sheared
    /// so that the ray runs down an axis, and the three edge functions
    /// are taken from the corners of each edge alone, so two triangles
    /// that share an edge compute it from the same two points and get the
    /// same value with opposite signs: a ray through the edge hits one of
    /// them or both, never neither, however far it comes from and however
    /// small the triangles (an edge function of exactly 0 is taken again
    /// in f64, where it is exact). The hit distance is as precise as the
    /// unit frame's f32 (about 1e-7 of the mesh's size).
    #[inline(always)]
    pub(crate) fn hit_t(&self, ray: &Ray, sh: &Sheared, facing: Facing) -> Option<f32> {
        let (det, t) = self.edges(ray, sh)?;
        facing.takes(det).then_some(t)
    }

    /// Is there a hit in `[tmin, tmax]`?
    #[inline(always)]
    pub(crate) fn hits(&self, ray: &Ray, sh: &Sheared) -> bool {
        self.edges(ray, sh).is_some()
    }

    /// The sum of the edge functions (twice the triangle's area seen down
    /// the ray, signed by its winding) and the hit distance, for a hit in
    /// `[tmin, tmax]`.
    #[inline(always)]
    pub(crate) fn edges(&self, ray: &Ray, sh: &Sheared) -> Option<(f32, f32)> {
        let [kx, ky, kz] = sh.k;
        let [sx, sy, sz] = sh.s;
        let at = |c: &[f32; 4]| {
            let z = c[kz] - sh.o[2];
            (c[kx] - sh.o[0] - sx * z, c[ky] - sh.o[1] - sy * z, z)
        };
        let (ax, ay, az) = at(&self.v[0]);
        let (bx, by, bz) = at(&self.v[1]);
        let (cx, cy, cz) = at(&self.v[2]);
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || v == 0.0 || w == 0.0 {
            let e = |px: f32, py: f32, qx: f32, qy: f32| {
                (px as f64 * qy as f64 - py as f64 * qx as f64) as f32
            };
            u = e(cx, cy, bx, by);
            v = e(ax, ay, cx, cy);
            w = e(bx, by, ax, ay);
        }
        if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let t = (u * (sz * az) + v * (sz * bz) + w * (sz * cz)) / det;
        (t >= ray.tmin && t <= ray.tmax).then_some((det, t))
    }
}

/// A leaf's triangles side by side for the same test four at a time
/// (Embree's `Triangle4`): corner `c`'s coordinate on axis `a` of lane
/// `l` at `v[a][c][l]`; a leaf of fewer than four repeats its last
/// triangle in the lanes left, which the mask of its count drops.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct Tri4 {
    v: [[[f32; 4]; 3]; 3],
    /// The leaf's first triangle in leaf order.
    pub(crate) first: u32,
}

impl Tri4 {
    pub(crate) fn new(tris: &[Tri], first: u32) -> Tri4 {
        let mut v = [[[0.0; 4]; 3]; 3];
        for l in 0..4 {
            let t = &tris[l.min(tris.len() - 1)];
            for (c, corner) in t.v.iter().enumerate() {
                for a in 0..3 {
                    v[a][c][l] = corner[a];
                }
            }
        }
        Tri4 { v, first }
    }

    /// [`Tri::edges`] on the four lanes at once, with the same arithmetic
    /// in the same order (the same bits): the hit distances, the edge
    /// functions' sums and a mask of the lanes (below `count`) hit in
    /// `[tmin, tmax]`. A lane with an edge function of exactly zero is
    /// taken again by the one-triangle test, which redoes it in f64.
    #[inline(always)]
    pub(crate) fn edges(
        &self,
        tris: &[Tri],
        ray: &Ray,
        sh: &Sheared,
        count: u32,
    ) -> ([f32; 4], [f32; 4], u32) {
        let [kx, ky, kz] = sh.k;
        let [sx, sy, sz] = sh.s;
        let (vx, vy, vz) = (&self.v[kx], &self.v[ky], &self.v[kz]);
        let mut px = [[0f32; 4]; 3];
        let mut py = [[0f32; 4]; 3];
        let mut pz = [[0f32; 4]; 3];
        for c in 0..3 {
            for l in 0..4 {
                let z = vz[c][l] - sh.o[2];
                px[c][l] = vx[c][l] - sh.o[0] - sx * z;
                py[c][l] = vy[c][l] - sh.o[1] - sy * z;
                pz[c][l] = z;
            }
        }
        let (mut ts, mut dets) = ([0f32; 4], [0f32; 4]);
        let mut hit = 0u32;
        let mut redo = 0u32;
        for l in 0..4 {
            let (ax, ay, az) = (px[0][l], py[0][l], pz[0][l]);
            let (bx, by, bz) = (px[1][l], py[1][l], pz[1][l]);
            let (cx, cy, cz) = (px[2][l], py[2][l], pz[2][l]);
            let u = cx * by - cy * bx;
            let v = ax * cy - ay * cx;
            let w = bx * ay - by * ax;
            redo |= ((u == 0.0 || v == 0.0 || w == 0.0) as u32) << l;
            let inside = !((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0));
            let det = u + v + w;
            let t = (u * (sz * az) + v * (sz * bz) + w * (sz * cz)) / det;
            let ok = inside && det != 0.0 && det.is_finite() && t >= ray.tmin && t <= ray.tmax;
            hit |= (ok as u32) << l;
            ts[l] = t;
            dets[l] = det;
        }
        let live = (1u32 << count) - 1;
        let (mut hit, mut redo) = (hit & live, redo & live);
        while redo != 0 {
            let l = redo.trailing_zeros() as usize;
            redo &= redo - 1;
            hit &= !(1 << l);
            if let Some((det, t)) = tris[self.first as usize + l].edges(ray, sh) {
                hit |= 1 << l;
                ts[l] = t;
                dets[l] = det;
            }
        }
        (ts, dets, hit)
    }

    /// The lanes hit, for an any-hit query (as fast as one triangle at a
    /// time with an out at the first hit, measured).
    #[inline(always)]
    pub(crate) fn hits(&self, tris: &[Tri], ray: &Ray, sh: &Sheared, count: u32) -> u32 {
        self.edges(tris, ray, sh, count).2
    }
}
