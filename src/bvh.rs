//! Shadow-ray occlusion against a mesh: a compressed 8-wide BVH (`obvhs`'s
//! CWBVH, chosen by measurement: see `benches/illum.rs` and the README)
//! over the mesh's triangles.
//!
//! Precision: the BVH is f32, in the mesh's own frame `(p - centre) /
//! scale` (centre and scale of its bounding box, computed in f64), so a
//! scene far from the origin or at any size is traced exactly as the same
//! scene near the origin at unit size. Ray origins are moved off their
//! surface by Wächter and Binder's integer-ulp offset ("A Fast and Robust
//! Method for Avoiding Self-Intersection", Ray Tracing Gems, ch. 6), in
//! that unit frame: the offset is a few ulps of the coordinate, never a
//! fixed distance that would be huge at small scales or vanish at large
//! ones.

use std::time::Duration;

use glam::{DVec3, Vec3A};
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::cwbvh::CwBvh;
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use crate::mesh::TriMesh;

/// Any-hit occlusion queries on a mesh.
pub struct Occluder {
    bvh: Option<CwBvh>,
    /// Triangles in the BVH's primitive order (a triangle split by the
    /// builder appears once per piece).
    tris: Vec<Triangle>,
    centre: DVec3,
    inv_scale: f64,
}

impl Occluder {
    /// Builds the BVH over every triangle of `mesh` with a non-zero area.
    pub fn new(mesh: &TriMesh) -> Occluder {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &mesh.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let (centre, scale) = if lo.x <= hi.x {
            let extent = (hi - lo).max_element();
            ((lo + hi) * 0.5, if extent > 0.0 { extent } else { 1.0 })
        } else {
            (DVec3::ZERO, 1.0)
        };
        let inv_scale = 1.0 / scale;
        let local = |p: DVec3| Vec3A::from(((p - centre) * inv_scale).as_vec3());
        let input: Vec<Triangle> = (0..mesh.tris.len())
            .filter_map(|t| {
                let [a, b, c] = mesh.tri(t);
                let tri = Triangle {
                    v0: local(a),
                    v1: local(b),
                    v2: local(c),
                };
                // Degenerate triangles occlude nothing.
                ((tri.v1 - tri.v0).cross(tri.v2 - tri.v0) != Vec3A::ZERO).then_some(tri)
            })
            .collect();
        if input.is_empty() {
            return Occluder {
                bvh: None,
                tris: input,
                centre,
                inv_scale,
            };
        }
        let bvh = build_cwbvh_from_tris(
            &input,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        );
        let tris = bvh
            .primitive_indices
            .iter()
            .map(|&i| input[i as usize])
            .collect();
        Occluder {
            bvh: Some(bvh),
            tris,
            centre,
            inv_scale,
        }
    }

    /// Number of triangles that can occlude.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Is the segment from `origin` (a point on the surface with normal
    /// `normal` on the side the ray leaves from) along the unit `dir` for
    /// `dist` (infinite for a distant light) blocked by the mesh?
    pub fn occluded(&self, origin: DVec3, normal: DVec3, dir: DVec3, dist: f64) -> bool {
        let Some(bvh) = &self.bvh else {
            return false;
        };
        let o = ((origin - self.centre) * self.inv_scale).as_vec3();
        let o = offset_ray(o.into(), Vec3A::from(normal.as_vec3()));
        let tmax = if dist.is_finite() {
            // Stop short of the light by a relative margin: a light on a
            // surface does not shadow itself.
            (dist * self.inv_scale * (1.0 - 1e-5)) as f32
        } else {
            f32::INFINITY
        };
        // `+ 0.0` turns -0.0 into +0.0: obvhs picks the octant from the
        // sign bits and misses with a negative zero (measured:
        // `a_box_shadows_exactly_the_points_behind_it`).
        let d = Vec3A::from(dir.as_vec3()) + Vec3A::ZERO;
        let ray = Ray::new(o, d, 0.0, tmax);
        !bvh.ray_traverse_miss(ray, |ray, i| self.tris[i].intersect(ray))
    }
}

/// Wächter and Binder's offset of a surface point `p` along `n` by a
/// number of ulps proportional to the coordinate (and by a small absolute
/// amount near zero, where ulps are tiny).
pub fn offset_ray(p: Vec3A, n: Vec3A) -> Vec3A {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let one = |p: f32, n: f32| {
        let of = (INT_SCALE * n) as i32;
        let pi = f32::from_bits((p.to_bits() as i32 + if p < 0.0 { -of } else { of }) as u32);
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            pi
        }
    };
    Vec3A::new(one(p.x, n.x), one(p.y, n.y), one(p.z, n.z))
}
