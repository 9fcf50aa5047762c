//! Shadow rays: how much of a light's sample gets from a point of the
//! mesh's surface to the light, decided one way for `illum` (from a cloud
//! point towards each light) and `sssingle` (from where light enters the
//! mesh on its way to a point inside): `docs/DESIGN.md#shadow-rays`.
//!
//! - **Origin.** A ray leaves a triangle of the mesh. It starts a few ulps
//!   off that triangle's plane, along the triangle's geometric normal, on
//!   the side the ray goes (Wächter and Binder's integer-ulp offset,
//!   [`crate::geom::bvh::offset_ray`]). That offset moves each coordinate
//!   by ulps of the coordinate's own size, so it is off the plane on the
//!   wanted side only when taken along the plane's normal: along the ray's
//!   direction it is not (it can land behind the plane, and the ray then
//!   meets the triangle it leaves, a few ulps away).
//! - **The terminator.** A cloud point whose smooth normal faces the light
//!   while its facet faces away sends its ray under its own facet. It
//!   leaves the solid again through a triangle that shares a corner with
//!   its own, and from there on is an ordinary shadow ray: the point is lit
//!   as the smooth surface its normals describe is. A ray that leaves
//!   farther away has crossed the solid.
//! - **A medium.** With the physical model's medium, a blocked ray carries
//!   `exp(-sigma_t d)` through each stretch inside the mesh and the Fresnel
//!   transmittance at each crossing, on a straight line (exact at eta 1;
//!   at other eta the refraction's sideways shift is not followed).
//!   Without one, the mesh is opaque: a blocked ray carries nothing.

use glam::DVec3;

use crate::geom::bvh::{Facing, Occluder};
use crate::geom::columns::Columns;
use crate::geom::mesh::TriMesh;
use crate::geom::{closest_on_triangle, tri_cross, unit_or_zero};
use crate::optics::fresnel;

/// Shadows of a medium: the light a shadow ray carries through the mesh's
/// inside, `exp(-sigma_t d)` over the length `d` it crosses, and the
/// boundary's Fresnel transmittance where it enters and leaves.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Passage {
    /// Extinction per channel (1 / the mean free path).
    pub sigma_t: DVec3,
    /// Relative index of refraction of the boundary.
    pub eta: f64,
}

/// What a shadow ray found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reach {
    /// Something lies in the way.
    pub blocked: bool,
    /// The share of the light that gets through, per channel: 1 when
    /// nothing is in the way, 0 when an opaque mesh is.
    pub through: DVec3,
}

impl Reach {
    const CLEAR: Reach = Reach {
        blocked: false,
        through: DVec3::ONE,
    };
}

/// Crossings a shadow ray follows through the mesh before it counts as
/// blocked.
const MAX_CROSSINGS: usize = 64;

/// How far from the mesh a cloud point may lie and still be on it, as a
/// share of the mesh's size (points written as f32 round by about 1e-7 of
/// it).
pub const ON_MESH: f64 = 1e-5;

/// A normal this close to its triangle's (the cosine between them) is the
/// triangle's: a ray off it is the ray off the triangle (flat normals,
/// rounded to f32).
const FLAT: f64 = 1.0 - 1e-9;

/// A cloud point a shadow ray starts from: its place, unit normal, the
/// mesh face it was scattered on if known, and the triangle under it once
/// a ray needed it.
#[derive(Clone, Copy, Debug)]
pub struct Point {
    p: DVec3,
    n: DVec3,
    face: Option<usize>,
    under: Option<Option<usize>>,
}

impl Point {
    /// The point at `p` with unit normal `n`.
    pub fn new(p: DVec3, n: DVec3) -> Point {
        Point {
            p,
            n,
            face: None,
            under: None,
        }
    }

    /// The point, with the face it was scattered on (its `sourceprim`): the
    /// first place to look for its triangle (a face the mesh does not have,
    /// or one the point is not on, is passed over).
    pub fn on_face(self, face: usize) -> Point {
        Point {
            face: Some(face),
            ..self
        }
    }
}

/// The mesh that casts shadows, its BVH, and the medium inside it (none:
/// opaque).
pub struct Shadows<'a> {
    mesh: &'a TriMesh,
    occ: &'a Occluder,
    medium: Option<Passage>,
    /// [`ON_MESH`] of the mesh's size.
    on_mesh: f64,
}

impl<'a> Shadows<'a> {
    /// Shadows cast by `mesh` (whose BVH is `occ`), through `medium` when
    /// given.
    pub fn new(mesh: &'a TriMesh, occ: &'a Occluder, medium: Option<Passage>) -> Shadows<'a> {
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in &mesh.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let size = if lo.x <= hi.x {
            (hi - lo).max_element()
        } else {
            0.0
        };
        Shadows {
            mesh,
            occ,
            medium,
            on_mesh: ON_MESH * size,
        }
    }

    /// The BVH.
    pub fn occluder(&self) -> &'a Occluder {
        self.occ
    }

    /// The medium inside the mesh, if any.
    pub fn medium(&self) -> Option<&Passage> {
        self.medium.as_ref()
    }

    /// The ray from cloud point `at` along unit `dir` to a light at `dist`
    /// (infinite: a distant light), through `cols` when they were built for
    /// `dir`. Traced first from the point off its normal: a clear ray is
    /// final. A blocked one looks for the triangle the point lies on (in
    /// the face it was scattered on, else the mesh's closest point; kept
    /// for the point's other rays) and is decided again from that
    /// triangle, unless the first ray was that triangle's own (the normal
    /// is the triangle's and the ray leaves it). A point off the mesh (a
    /// cloud over another surface) keeps the first answer.
    pub fn from_point(
        &self,
        cols: Option<&Columns>,
        at: &mut Point,
        dir: DVec3,
        dist: f64,
    ) -> Reach {
        let (p, n) = (at.p, at.n);
        if !self.any_hit(cols, p, n, dir, dist) {
            return Reach::CLEAR;
        }
        let face = at.face;
        let under = *at.under.get_or_insert_with(|| {
            face.and_then(|f| self.on_face(p, f))
                .or_else(|| self.triangle_under(p))
        });
        match under {
            Some(t) => {
                let f = self.facet(t);
                if f.dot(dir) > 0.0 && f.dot(n) >= FLAT {
                    self.blocked(p, n, dir, dist)
                } else {
                    self.from_triangle(cols, p, t, dir, dist)
                }
            }
            None => self.blocked(p, n, dir, dist),
        }
    }

    /// The ray from `p`, on triangle `t` of the mesh, along unit `dir` to a
    /// light at `dist`, through `cols` when built for `dir`: `sssingle`'s,
    /// where light enters the mesh (the ray leaves through `t`), and a
    /// cloud point's once its triangle is known.
    pub fn from_triangle(
        &self,
        cols: Option<&Columns>,
        p: DVec3,
        t: usize,
        dir: DVec3,
        dist: f64,
    ) -> Reach {
        let f = self.facet(t);
        if f.dot(dir) > 0.0 {
            return self.outside(cols, p, f, dir, dist);
        }
        // The terminator: the ray dives under its own triangle. Where it
        // leaves the solid again decides.
        let mut ray = self.occ.shadow_ray(p, -f, dir, dist);
        let Some(j) = self.occ.nearest_ray(&mut ray, Facing::Any) else {
            // Nothing behind the triangle (an open mesh): clear.
            return Reach::CLEAR;
        };
        let leaving = self.occ.leaf_normal(j).dot(dir) > 0.0;
        let u = self.occ.leaf_id(j) as usize;
        if !(leaving && self.share_a_corner(t, u)) {
            // Through the solid, or into something else first.
            return self.blocked(p, -f, dir, dist);
        }
        // Out again beside its own triangle: from there, an ordinary ray.
        let g = self.facet(u);
        let d = plane_dist(self.mesh.tri(u), p, dir).unwrap_or(0.0).max(0.0);
        let rest = if dist.is_finite() {
            (dist - d).max(0.0)
        } else {
            dist
        };
        self.outside(cols, p + dir * d, g, dir, rest)
    }

    /// The ray from `p`, on a triangle of unit normal `f` it leaves
    /// outwards, along `dir` for `dist`.
    fn outside(&self, cols: Option<&Columns>, p: DVec3, f: DVec3, dir: DVec3, dist: f64) -> Reach {
        if self.any_hit(cols, p, f, dir, dist) {
            self.blocked(p, f, dir, dist)
        } else {
            Reach::CLEAR
        }
    }

    /// Any hit on the ray from `p` moved off its surface along `n`.
    fn any_hit(&self, cols: Option<&Columns>, p: DVec3, n: DVec3, dir: DVec3, dist: f64) -> bool {
        match cols {
            Some(c) => c.occluded(self.occ, p, n, dir, dist),
            None => self.occ.occluded(p, n, dir, dist),
        }
    }

    /// A ray from `p` (moved off its surface along `n`) that meets the
    /// mesh: what crosses the medium, or nothing.
    fn blocked(&self, p: DVec3, n: DVec3, dir: DVec3, dist: f64) -> Reach {
        let through = match &self.medium {
            Some(m) => self.passage(m, p, n, dir, dist),
            None => DVec3::ZERO,
        };
        Reach {
            blocked: true,
            through,
        }
    }

    /// The light that the ray from `p` (moved off its surface along `n`)
    /// along `dir` for `dist` carries through the medium `m`: the product
    /// over its passages inside of `exp(-sigma_t d)` and the Fresnel
    /// transmittance where it enters and leaves. Each crossing is found in
    /// the BVH's f32 frame and placed in f64 on its triangle's plane, so a
    /// thin passage under a short mean free path keeps its length. A ray
    /// whose first crossing leaves the mesh started inside it, and crossed
    /// the medium from its start. Zero once every channel is below 1e-12,
    /// or after [`MAX_CROSSINGS`].
    fn passage(&self, m: &Passage, p: DVec3, n: DVec3, dir: DVec3, dist: f64) -> DVec3 {
        let occ = self.occ;
        let mut ray = occ.shadow_ray(p, n, dir, dist);
        let end = ray.tmax;
        let mut t = DVec3::ONE;
        // Where the ray went in (the distance from `p`), when inside.
        let mut inside: Option<f64> = None;
        for k in 0..MAX_CROSSINGS {
            let Some(j) = occ.nearest_ray(&mut ray, Facing::Any) else {
                // Never left: an open mesh, or the ray ends inside (a
                // light inside the mesh) - the medium up to the end counts.
                if let Some(t0) = inside {
                    let d = dist - t0;
                    if d.is_finite() {
                        t *= (-m.sigma_t * d.max(0.0)).exp();
                    } else {
                        return DVec3::ZERO;
                    }
                }
                return t;
            };
            let tri = self.mesh.tri(occ.leaf_id(j) as usize);
            let f = tri_cross(tri[0], tri[1], tri[2]);
            let at = plane_dist(tri, p, dir).unwrap_or_else(|| occ.mesh_dist(ray.tmax));
            let cos = (f.dot(dir) / f.length()).abs();
            let entering = f.dot(dir) < 0.0;
            match (entering, inside) {
                (true, None) => inside = Some(at),
                (false, Some(t0)) => {
                    t *= (-m.sigma_t * (at - t0).max(0.0)).exp();
                    inside = None;
                }
                // Leaving first: the ray started inside, and crossed the
                // medium from its start.
                (false, None) if k == 0 => t *= (-m.sigma_t * at.max(0.0)).exp(),
                // Two faces the same way in a row (a mesh that overlaps
                // itself): the boundary is crossed, the inside's length
                // counted from the first.
                _ => {}
            }
            t *= 1.0 - fresnel(cos, m.eta);
            if t.max_element() < 1e-12 {
                return DVec3::ZERO;
            }
            // On past this hit (a relative step: the unit frame's f32).
            let next = ray.tmax * (1.0 + 4.0 * f32::EPSILON) + 1e-7;
            ray.tmin = next;
            ray.tmax = end;
            if next >= end {
                return if inside.is_some() { DVec3::ZERO } else { t };
            }
        }
        DVec3::ZERO
    }

    /// The triangle of face `f` that `p` lies on (within [`ON_MESH`] of the
    /// mesh's size), if the mesh has that face.
    fn on_face(&self, p: DVec3, f: usize) -> Option<usize> {
        let m = self.mesh;
        if f >= m.face_count() {
            return None;
        }
        (m.face_tris[f]..m.face_tris[f + 1])
            .map(|t| {
                let [a, b, c] = m.tri(t as usize);
                let w = closest_on_triangle(p, a, b, c);
                ((a * w[0] + b * w[1] + c * w[2] - p).length(), t as usize)
            })
            .min_by(|x, y| x.0.total_cmp(&y.0))
            .filter(|x| x.0 <= self.on_mesh)
            .map(|x| x.1)
    }

    /// The triangle `p` lies on (within [`ON_MESH`] of the mesh's size):
    /// the mesh's nearest.
    fn triangle_under(&self, p: DVec3) -> Option<usize> {
        let (t, _, d) = self.occ.closest_point(self.mesh, p)?;
        (d <= self.on_mesh).then_some(t)
    }

    /// Triangle `t`'s unit geometric normal (outwards, by its winding).
    fn facet(&self, t: usize) -> DVec3 {
        let [a, b, c] = self.mesh.tri(t);
        unit_or_zero(tri_cross(a, b, c))
    }

    /// Do triangles `t` and `u` share a corner (by position: a mesh whose
    /// faces do not share vertices still shares their places)?
    fn share_a_corner(&self, t: usize, u: usize) -> bool {
        let (a, b) = (self.mesh.tri(t), self.mesh.tri(u));
        a.iter().any(|p| b.contains(p))
    }
}

/// The distance from `o` along unit `dir` to the plane of triangle `abc`,
/// in f64 (`None` parallel to it).
fn plane_dist([a, b, c]: [DVec3; 3], o: DVec3, dir: DVec3) -> Option<f64> {
    let n = tri_cross(a, b, c);
    let d = n.dot(a - o) / n.dot(dir);
    d.is_finite().then_some(d)
}
