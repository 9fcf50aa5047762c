//! Rays inside the object: where the view ray enters and leaves it, and
//! where a light's ray from a point inside enters it, with the mesh's
//! normal there.
//!
//! The BVH ([`Occluder`]) finds the triangle in its f32 unit frame (about
//! 1e-7 of the mesh's size); the distance is then recomputed in f64
//! against that triangle's plane, from the ray's f64 origin, so that depths
//! of 1e-8 of the object's size (a tiny mean free path) stay exact.

use glam::DVec3;

use crate::geom::bvh::{Facing, Occluder};
use crate::geom::columns::Columns;
use crate::geom::mesh::TriMesh;
use crate::geom::{self, unit_or_zero};
use crate::lights::shadow::{Passage, Shadows};
use crate::optics::fresnel;
use crate::stages::facet::{corner_normals, Weight};

/// The most stretches of the medium a view ray is followed through.
pub const MAX_STRETCHES: usize = 16;

/// A stretch of the view ray inside the medium: where it starts, its
/// length (infinite: it never leaves), and the Fresnel transmittance of
/// the faces the ray crossed before it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stretch {
    pub at: DVec3,
    pub len: f64,
    pub kt: f64,
}

/// A surface hit: the distance along the ray, the mesh's unit normal
/// there, and the triangle hit.
#[derive(Clone, Copy, Debug)]
pub struct Entry {
    pub dist: f64,
    pub normal: DVec3,
    /// The mesh's triangle the ray leaves by.
    pub tri: usize,
}

/// The mesh, its BVH and its normals (corners split at the cusp angle).
pub struct Interior<'a> {
    mesh: &'a TriMesh,
    occ: Occluder,
    face_n: Vec<DVec3>,
    corner_n: Vec<DVec3>,
    tri_face: Vec<u32>,
    /// How far outside a point a view ray starts, to find the surface the
    /// point lies on (1e-5 of the mesh's size).
    margin: f64,
    /// How far behind its origin a light's ray still finds a surface (1e-6
    /// of the mesh's size: a point that rounding put just outside).
    behind: f64,
    /// The mesh's size: the longest side of its box.
    size: f64,
}

impl<'a> Interior<'a> {
    /// The queries on `mesh`, its normals smooth up to `cusp_deg`.
    pub fn new(mesh: &'a TriMesh, cusp_deg: f64) -> Interior<'a> {
        let face_n = mesh.face_normals();
        let corner_n = corner_normals(mesh, &face_n, Weight::Angle, cusp_deg, true);
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
        Interior {
            mesh,
            occ: Occluder::new(mesh),
            face_n,
            corner_n,
            tri_face: mesh.tri_faces(),
            margin: 1e-5 * size,
            behind: 1e-6 * size,
            size,
        }
    }

    /// The mesh's size (the longest side of its box).
    pub fn size(&self) -> f64 {
        self.size
    }

    /// The closest point of the mesh to `p`: its distance, and the face
    /// normal (unnormalised, as the winding gives it) of the triangle it
    /// lies on.
    pub fn closest(&self, p: DVec3) -> Option<(f64, DVec3)> {
        let (t, _, d) = self.occ.closest_point(self.mesh, p)?;
        let [a, b, c] = self.mesh.tri(t);
        Some((d, geom::tri_cross(a, b, c)))
    }

    /// The BVH (for counting and benchmarks).
    pub fn occluder(&self) -> &Occluder {
        &self.occ
    }

    /// The distance from `o` along unit `dir` to triangle `t`'s plane, in
    /// f64 (`None` parallel to it).
    fn plane_dist(&self, t: usize, o: DVec3, dir: DVec3) -> Option<f64> {
        plane_dist(self.mesh.tri(t), o, dir)
    }

    /// The mesh's normal on triangle `t` (corners `abc`) at point `p`:
    /// its corners' normals interpolated, the face's where they cancel.
    fn normal_on(&self, t: usize, [a, b, c]: [DVec3; 3], p: DVec3) -> DVec3 {
        let w = geom::closest_on_triangle(p, a, b, c);
        let k = self.mesh.tris[t];
        let n = self.corner_n[k[0] as usize] * w[0]
            + self.corner_n[k[1] as usize] * w[1]
            + self.corner_n[k[2] as usize] * w[2];
        let n = unit_or_zero(n);
        if n == DVec3::ZERO {
            self.face_n[self.tri_face[t] as usize]
        } else {
            n
        }
    }

    /// The view ray inside: the point where the ray along `dir` through
    /// `xo` (a cloud point, on the surface up to rounding) enters the mesh
    /// (`xo` itself when no surface lies that close), and the distance
    /// from there to where it leaves (infinite when it does not). Only
    /// the triangles the ray enters, then leaves, through are taken, so a
    /// point rounded to either side of its surface finds the same.
    pub fn view(&self, xo: DVec3, dir: DVec3) -> (DVec3, f64) {
        self.view_within(xo, dir, f64::INFINITY)
    }

    /// [`Interior::view`] for a caller that needs the distance only up to
    /// `far`: a ray that leaves farther (or not at all) may say infinite.
    /// Every distance up to `far` is the one `view` finds: the search goes
    /// a little beyond it, past the rounding of the BVH's f32 distances.
    /// (The seed model's depths stop at the longest scattering distance,
    /// a small part of most objects: the BVH then skips every box beyond.)
    pub fn view_within(&self, xo: DVec3, dir: DVec3, far: f64) -> (DVec3, f64) {
        let (on, len, _) = self.view_exit(xo, dir, far);
        (on, len)
    }

    /// [`Interior::view_within`], and the triangle the ray leaves by.
    fn view_exit(&self, xo: DVec3, dir: DVec3, far: f64) -> (DVec3, f64, Option<usize>) {
        let start = xo - dir * self.margin;
        let on = match self
            .occ
            .nearest(start, dir, 0.0, 2.0 * self.margin, Facing::Entering)
        {
            Some((t, _)) => match self.plane_dist(t, start, dir) {
                Some(d) => start + dir * d.clamp(0.0, 2.0 * self.margin),
                None => xo,
            },
            None => xo,
        };
        let reach = far * (1.0 + 1e-3) + 2.0 * self.margin;
        let (len, exit) = self.leave(on, dir, reach);
        (on, len, exit)
    }

    /// How far the ray from `on` (inside) along unit `dir` goes, within
    /// `reach`, before it leaves the mesh, and the triangle it leaves by
    /// (infinite and none: it does not, within `reach`).
    fn leave(&self, on: DVec3, dir: DVec3, reach: f64) -> (f64, Option<usize>) {
        self.occ
            .nearest(on, dir, -self.behind, reach, Facing::Leaving)
            .and_then(|(t, _)| Some((self.plane_dist(t, on, dir)?.max(0.0), Some(t))))
            .unwrap_or((f64::INFINITY, None))
    }

    /// The view ray's path through the medium: the stretch from the point
    /// ([`Interior::view`]), then every later one the ray crosses on past
    /// where it leaves (another part of the object, another object in the
    /// mesh), at most [`MAX_STRETCHES`], into `out`: each stretch's start,
    /// length, and the Fresnel transmittance (at `eta`) of the faces
    /// crossed before it. The ray goes on inside in its own direction:
    /// exact at eta 1, and between parallel faces at any eta (it leaves
    /// and enters again at the same angle, shifted sideways); total
    /// internal reflection ends the path.
    pub fn view_path(&self, xo: DVec3, dir: DVec3, eta: f64, out: &mut Vec<Stretch>) {
        out.clear();
        let (mut at, mut len, mut exit) = self.view_exit(xo, dir, f64::INFINITY);
        let mut kt = 1.0;
        loop {
            out.push(Stretch { at, len, kt });
            let Some(t) = exit else {
                return;
            };
            if out.len() >= MAX_STRETCHES {
                return;
            }
            // Out through the face it leaves by, and in again through the
            // next face it enters by, if any.
            let from = at + dir * len;
            let Some((u, _)) =
                self.occ
                    .nearest(from, dir, self.behind, f64::INFINITY, Facing::Entering)
            else {
                return;
            };
            let Some(gap) = plane_dist(self.mesh.tri(u), from, dir) else {
                return;
            };
            kt *= crossing(self.cos(t, dir), eta) * crossing(self.cos(u, dir), eta);
            if kt == 0.0 {
                return;
            }
            at = from + dir * gap.max(0.0);
            (len, exit) = self.leave(at, dir, f64::INFINITY);
        }
    }

    /// `|cos|` of the angle between unit `dir` and triangle `t`'s plane's
    /// normal.
    fn cos(&self, t: usize, dir: DVec3) -> f64 {
        let [a, b, c] = self.mesh.tri(t);
        unit_or_zero(geom::tri_cross(a, b, c)).dot(dir).abs()
    }

    /// Where the ray from `p` (inside) along unit `dir` first leaves the
    /// mesh within `max` (a light's distance): the distance, at least 0,
    /// and the mesh's normal there. A surface a little behind `p` counts
    /// (a point at a tiny depth that rounding put outside), one the ray
    /// would enter does not (a point just inside another face).
    pub fn entry(&self, p: DVec3, dir: DVec3, max: f64) -> Option<Entry> {
        self.entry_with(None, p, dir, max)
    }

    /// A grid for the rays of a distant light along `dir` ([`Columns`]:
    /// the same hits as the BVH's, found faster); `None` when the mesh
    /// does not suit one.
    pub fn columns(&self, dir: DVec3) -> Option<Columns> {
        Columns::new(&self.occ, dir)
    }

    /// Whether `rays` rays of one distant light repay a grid.
    pub fn columns_worth_it(&self, rays: u64) -> bool {
        crate::geom::columns::worth_it(
            &self.occ,
            rays,
            crate::geom::columns::NEAREST_RAYS_PER_TRIANGLE,
        )
    }

    /// [`Interior::entry`], through `cols` (built by
    /// [`Interior::columns`] for `dir`) when there is one.
    pub fn entry_with(
        &self,
        cols: Option<&Columns>,
        p: DVec3,
        dir: DVec3,
        max: f64,
    ) -> Option<Entry> {
        let (t, _) = match cols {
            Some(c) => c.nearest(&self.occ, p, dir, -self.behind, max, Facing::Leaving)?,
            None => self
                .occ
                .nearest(p, dir, -self.behind, max, Facing::Leaving)?,
        };
        // (The corners fetched once for the plane and the normal.)
        let tri = self.mesh.tri(t);
        let dist = plane_dist(tri, p, dir)?.max(0.0);
        Some(Entry {
            dist,
            normal: self.normal_on(t, tri, p + dir * dist),
            tri: t,
        })
    }

    /// The shadows the mesh casts, through `medium` when given.
    pub fn shadows(&self, medium: Option<Passage>) -> Shadows<'_> {
        Shadows::new(self.mesh, &self.occ, medium)
    }

    /// Is `eye` inside the mesh? The nearest surface a ray from it meets
    /// faces away from it (a closed mesh).
    pub fn contains(&self, eye: DVec3) -> bool {
        // Three directions, so a ray grazing an edge does not decide alone.
        let dirs = [
            DVec3::new(0.267, 0.535, 0.802),
            DVec3::new(-0.802, 0.267, -0.535),
            DVec3::new(0.535, -0.802, 0.267),
        ];
        let inside = dirs
            .iter()
            .filter(|d| {
                let d = d.normalize();
                self.occ.closest(eye, d).is_some_and(|(t, _)| {
                    let [a, b, c] = self.mesh.tri(t);
                    geom::tri_cross(a, b, c).dot(d) > 0.0
                })
            })
            .count();
        inside >= 2
    }
}

/// The Fresnel transmittance of a face that light crosses with the
/// direction of cosine `cos_t` to its normal inside (relative index
/// `eta`): at the angle outside whose refraction that is; 0 where none is
/// (total internal reflection).
fn crossing(cos_t: f64, eta: f64) -> f64 {
    let sin_o2 = eta * eta * (1.0 - cos_t * cos_t);
    if sin_o2 >= 1.0 {
        return 0.0;
    }
    1.0 - fresnel((1.0 - sin_o2).sqrt(), eta)
}

/// The distance from `o` along unit `dir` to the plane of triangle `abc`,
/// in f64 (`None` parallel to it).
fn plane_dist([a, b, c]: [DVec3; 3], o: DVec3, dir: DVec3) -> Option<f64> {
    let n = geom::tri_cross(a, b, c);
    let den = n.dot(dir);
    let d = n.dot(a - o) / den;
    d.is_finite().then_some(d)
}
