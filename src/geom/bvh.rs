//! Shadow-ray occlusion against a mesh. The tree is built by `obvhs` (PLOC
//! with reinsertion: a binary BVH of high quality), then collapsed into a
//! 4-wide BVH whose nodes keep the four children's boxes as columns, and
//! traversed here: four box tests at a time, the crossed children as a
//! bit mask, leaves of up to four triangles under a watertight test
//! ([`Tri::hit_t`]), four side by side ([`Tri4`]). The traversals are compiled twice, for processors
//! with AVX (chosen at run time) and without; both do the same
//! arithmetic in the same order (no fused multiply-add), so they find the
//! same hits to the bit. Chosen by measurement (`benches/illum.rs`,
//! `benches/sssingle.rs`; benches/results/HISTORY.md, "Measurements behind
//! the code"): on the same rays it is faster than obvhs's own CWBVH
//! traversal, and than 8-wide nodes, measured as a share of Embree's rate.
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
use obvhs::bvh2::builder::build_bvh2_from_tris;
use obvhs::bvh2::Bvh2;
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;
use obvhs::BvhBuildParams;

use crate::geom::mesh::TriMesh;
pub use crate::geom::ray_tri::Facing;
use crate::geom::ray_tri::{Sheared, Tri, Tri4};

/// Children per node.
const W: usize = 4;
/// Triangles per leaf at most.
const LEAF: u32 = 4;
/// No child in this slot.
const EMPTY: u32 = u32::MAX;
/// Traversal stack kept on the machine stack; deeper (a degenerate tree)
/// spills to the heap.
const STACK: usize = 64;

/// A 4-wide node: the children's boxes as columns, and what each child
/// is: `count[k] == 0` an inner node `child[k]`, `count[k] > 0` a leaf of
/// `count[k]` triangles from `child[k]`, `count[k] == EMPTY` nothing (its
/// box all at `+inf`, which no ray crosses: see [`slabs`]).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
struct Node {
    lo: [[f32; W]; 3],
    hi: [[f32; W]; 3],
    child: [u32; W],
    count: [u32; W],
}

impl Node {
    const NONE: Node = Node {
        lo: [[f32::INFINITY; W]; 3],
        hi: [[f32::INFINITY; W]; 3],
        child: [0; W],
        count: [EMPTY; W],
    };
}

/// Any-hit occlusion queries on a mesh.
pub struct Occluder {
    nodes: Vec<Node>,
    /// Triangles in leaf order.
    tris: Vec<Tri>,
    /// Each leaf's triangles side by side (a leaf child's `child` is its
    /// index here).
    quads: Vec<Tri4>,
    /// The same in obvhs's form (for comparisons with other tracers).
    plain: Vec<Triangle>,
    /// Each one's triangle index in the mesh.
    ids: Vec<u32>,
    centre: DVec3,
    inv_scale: f64,
    /// Traverse with AVX (the processor has it).
    avx: bool,
    /// The mesh's fingerprint ([`TriMesh::digest`]), for the stages that
    /// record what they traced against.
    pub mesh_digest: String,
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
        let mut ids_in = Vec::new();
        let input: Vec<Triangle> = (0..mesh.tris.len())
            .filter_map(|t| {
                let [a, b, c] = mesh.tri(t);
                let tri = Triangle {
                    v0: local(a),
                    v1: local(b),
                    v2: local(c),
                };
                // Degenerate triangles occlude nothing.
                let keep = (tri.v1 - tri.v0).cross(tri.v2 - tri.v0) != Vec3A::ZERO;
                if keep {
                    ids_in.push(t as u32);
                }
                keep.then_some(tri)
            })
            .collect();
        let mut occ = Occluder {
            nodes: Vec::new(),
            tris: Vec::new(),
            quads: Vec::new(),
            plain: Vec::new(),
            ids: Vec::new(),
            centre,
            inv_scale,
            avx: avx(),
            mesh_digest: mesh.digest(),
        };
        if input.is_empty() {
            return occ;
        }
        let mut params = BvhBuildParams::medium_build();
        params.max_prims_per_leaf = LEAF;
        let bvh = build_bvh2_from_tris(&input, params, &mut Duration::default());
        occ.nodes.push(Node::NONE);
        let root = &bvh.nodes[0];
        if root.is_leaf() {
            let first = occ.add_leaf(&bvh, &input, &ids_in, 0);
            let n = &mut occ.nodes[0];
            set_box(n, 0, root.aabb.min, root.aabb.max);
            n.child[0] = first;
            n.count[0] = root.prim_count;
        } else {
            // A work list, not recursion: a degenerate tree can be deep.
            let mut work = vec![(0usize, 0usize)];
            while let Some((id, at)) = work.pop() {
                occ.collapse(&bvh, &input, &ids_in, id, at, &mut work);
            }
        }
        occ
    }

    /// Appends the triangles of BVH2 leaf `id`; returns the leaf's index
    /// in `quads`.
    fn add_leaf(&mut self, bvh: &Bvh2, input: &[Triangle], ids: &[u32], id: usize) -> u32 {
        let n = &bvh.nodes[id];
        let first = self.tris.len() as u32;
        for k in 0..n.prim_count {
            let p = bvh.primitive_indices[(n.first_index + k) as usize];
            self.tris.push(Tri::new(&input[p as usize]));
            self.plain.push(input[p as usize]);
            self.ids.push(ids[p as usize]);
        }
        self.quads
            .push(Tri4::new(&self.tris[first as usize..], first));
        self.quads.len() as u32 - 1
    }

    /// Fills 4-wide node `at` from the children of BVH2 inner node `id`:
    /// the two children, then repeatedly the largest inner one opened,
    /// until four; inner children go on `work` as (BVH2 node, node).
    fn collapse(
        &mut self,
        bvh: &Bvh2,
        input: &[Triangle],
        ids: &[u32],
        id: usize,
        at: usize,
        work: &mut Vec<(usize, usize)>,
    ) {
        let first = bvh.nodes[id].first_index as usize;
        let mut kids: Vec<usize> = vec![first, first + 1];
        while kids.len() < W {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| !bvh.nodes[k].is_leaf())
                .max_by(|a, b| {
                    let area = |k: usize| bvh.nodes[k].aabb.half_area();
                    area(*a.1).total_cmp(&area(*b.1))
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let k = kids.swap_remove(i);
            let f = bvh.nodes[k].first_index as usize;
            kids.push(f);
            kids.push(f + 1);
        }
        for (slot, &k) in kids.iter().enumerate() {
            let n = bvh.nodes[k];
            let (child, count) = if n.is_leaf() {
                (self.add_leaf(bvh, input, ids, k), n.prim_count)
            } else {
                self.nodes.push(Node::NONE);
                (self.nodes.len() as u32 - 1, 0)
            };
            let node = &mut self.nodes[at];
            set_box(node, slot, n.aabb.min, n.aabb.max);
            node.child[slot] = child;
            node.count[slot] = count;
        }
        for (slot, &k) in kids.iter().enumerate() {
            if self.nodes[at].count[slot] == 0 {
                work.push((k, self.nodes[at].child[slot] as usize));
            }
        }
    }

    /// The same tree traversed by the code path for processors without
    /// AVX (that path is the one taken where AVX is missing; this is for
    /// the tests and benchmarks that hold the two side by side on a
    /// machine that has both).
    pub fn without_avx(mut self) -> Occluder {
        self.avx = false;
        self
    }

    /// Whether the traversals take the AVX code path.
    pub fn uses_avx(&self) -> bool {
        self.avx
    }

    /// Number of triangles that can occlude.
    pub fn triangle_count(&self) -> usize {
        self.tris.len()
    }

    /// Is the segment from `origin` (a point on the surface with normal
    /// `normal` on the side the ray leaves from) along the unit `dir` for
    /// `dist` (infinite for a distant light) blocked by the mesh?
    pub fn occluded(&self, origin: DVec3, normal: DVec3, dir: DVec3, dist: f64) -> bool {
        !self.nodes.is_empty() && self.occluded_ray(&self.shadow_ray(origin, normal, dir, dist))
    }

    /// The ray `occluded` traces, in the BVH's unit frame.
    pub fn shadow_ray(&self, origin: DVec3, normal: DVec3, dir: DVec3, dist: f64) -> Ray {
        let o = ((origin - self.centre) * self.inv_scale).as_vec3();
        let o = offset_ray(o.into(), Vec3A::from(normal.as_vec3()));
        let tmax = if dist.is_finite() {
            // Stop short of the light by a relative margin: a light on a
            // surface does not shadow itself.
            (dist * self.inv_scale * (1.0 - 1e-5)) as f32
        } else {
            f32::INFINITY
        };
        Ray::new(o, Vec3A::from(dir.as_vec3()), 0.0, tmax)
    }

    /// Does `ray` (in the unit frame) hit any triangle?
    pub fn occluded_ray(&self, ray: &Ray) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the processor has AVX.
            return unsafe { self.occluded_avx(ray) };
        }
        self.occluded_in(ray)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn occluded_avx(&self, ray: &Ray) -> bool {
        self.occluded_in(ray)
    }

    /// [`Occluder::occluded_ray`]'s traversal, inlined into each code
    /// path.
    #[inline(always)]
    fn occluded_in(&self, ray: &Ray) -> bool {
        let (o, id) = ray_slabs(ray);
        let sh = Sheared::new(ray);
        let mut stack = [0u32; STACK];
        let mut spill: Vec<u32> = Vec::new();
        let mut top = 1usize;
        loop {
            let at = if top > 0 {
                top -= 1;
                stack[top]
            } else if let Some(at) = spill.pop() {
                at
            } else {
                break;
            };
            let node = &self.nodes[at as usize];
            let (_, mut crossed) = slabs(node, &o, &id, ray.tmin, ray.tmax);
            // Children in their stored order: sorting them by distance
            // cost more than it saved (measured).
            while crossed != 0 {
                let k = crossed.trailing_zeros() as usize;
                crossed &= crossed - 1;
                let (child, count) = (node.child[k], node.count[k]);
                if count == 0 {
                    if top < STACK {
                        stack[top] = child;
                        top += 1;
                    } else {
                        spill.push(child);
                    }
                } else {
                    if self.quads[child as usize].hits(&self.tris, ray, &sh, count) != 0 {
                        return true;
                    }
                }
            }
        }
        false
    }

    /// The nearest hit of the ray from `origin` along the unit `dir` (a
    /// camera ray: no offset): the mesh triangle and the distance.
    pub fn closest(&self, origin: DVec3, dir: DVec3) -> Option<(usize, f64)> {
        self.nearest(origin, dir, 0.0, f64::INFINITY, Facing::Any)
    }

    /// The nearest hit of the ray from `origin` along the unit `dir` at a
    /// distance in `[tmin, tmax]` (`tmin` may be negative: a ray that
    /// starts on a surface can still find it): the mesh triangle and the
    /// distance, as precise as the f32 unit frame (about 1e-7 of the
    /// mesh's size; `sssingle` refines it in f64). Equal distances: the
    /// lowest triangle index. `facing` keeps only the triangles the ray
    /// enters or leaves the mesh through (by their winding: outward
    /// normals counter-clockwise).
    pub fn nearest(
        &self,
        origin: DVec3,
        dir: DVec3,
        tmin: f64,
        tmax: f64,
        facing: Facing,
    ) -> Option<(usize, f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let mut ray = self.unit_ray(origin, dir, tmin, tmax);
        self.nearest_ray(&mut ray, facing)
            .map(|j| (self.ids[j as usize] as usize, self.mesh_dist(ray.tmax)))
    }

    /// The ray from `origin` along the unit `dir` over `[tmin, tmax]`, in
    /// the BVH's unit frame (what [`Occluder::nearest`] traces; for
    /// comparisons with other ray tracers).
    pub fn unit_ray(&self, origin: DVec3, dir: DVec3, tmin: f64, tmax: f64) -> Ray {
        let o = ((origin - self.centre) * self.inv_scale).as_vec3();
        let (t0, t1) = (
            (tmin * self.inv_scale) as f32,
            (tmax * self.inv_scale) as f32,
        );
        Ray::new(o.into(), Vec3A::from(dir.as_vec3()), t0, t1)
    }

    /// The nearest hit of `ray` (in the unit frame): its place in leaf
    /// order, with `ray.tmax` set to its distance. Children are visited
    /// nearest first, and a child beyond the nearest hit so far is
    /// skipped.
    pub fn nearest_ray(&self, ray: &mut Ray, facing: Facing) -> Option<u32> {
        if self.nodes.is_empty() {
            return None;
        }
        #[cfg(target_arch = "x86_64")]
        if self.avx {
            // SAFETY: `avx` is set only where the processor has AVX.
            return unsafe { self.nearest_avx(ray, facing) };
        }
        self.nearest_in(ray, facing)
    }

    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn nearest_avx(&self, ray: &mut Ray, facing: Facing) -> Option<u32> {
        self.nearest_in(ray, facing)
    }

    /// [`Occluder::nearest_ray`]'s traversal, inlined into each code path.
    #[inline(always)]
    fn nearest_in(&self, ray: &mut Ray, facing: Facing) -> Option<u32> {
        let (o, id) = ray_slabs(ray);
        let sh = Sheared::new(ray);
        let mut best: Option<u32> = None;
        // (Entry distance, node) pairs: a node is skipped when the nearest
        // hit found since it was pushed lies before its entry.
        let mut stack = [(0f32, 0u32); STACK];
        let mut spill: Vec<(f32, u32)> = Vec::new();
        let mut top = 1usize;
        stack[0] = (ray.tmin, 0);
        loop {
            let (enter, at) = if top > 0 {
                top -= 1;
                stack[top]
            } else if let Some(e) = spill.pop() {
                e
            } else {
                break;
            };
            if enter > ray.tmax * (1.0 + 2.0 * f32::EPSILON) {
                continue;
            }
            let node = &self.nodes[at as usize];
            let (tnear, mut crossed) = slabs(node, &o, &id, ray.tmin, ray.tmax);
            // The inner children crossed, farthest first on the stack.
            let mut kids = [(0f32, 0u32); W];
            let mut nk = 0;
            while crossed != 0 {
                let k = crossed.trailing_zeros() as usize;
                crossed &= crossed - 1;
                let (child, count) = (node.child[k], node.count[k]);
                if count == 0 {
                    let mut j = nk;
                    while j > 0 && kids[j - 1].0 < tnear[k] {
                        kids[j] = kids[j - 1];
                        j -= 1;
                    }
                    kids[j] = (tnear[k], child);
                    nk += 1;
                } else {
                    let quad = &self.quads[child as usize];
                    let (ts, dets, mut lanes) = quad.edges(&self.tris, ray, &sh, count);
                    while lanes != 0 {
                        let l = lanes.trailing_zeros() as usize;
                        lanes &= lanes - 1;
                        let (t, j) = (ts[l], quad.first + l as u32);
                        if !facing.takes(dets[l]) || t > ray.tmax {
                            continue;
                        }
                        // Nearest first; equal distances: lowest index.
                        let better = t < ray.tmax
                            || best.is_none_or(|b| self.ids[j as usize] < self.ids[b as usize]);
                        if better {
                            ray.tmax = t;
                            best = Some(j);
                        }
                    }
                }
            }
            for &kid in &kids[..nk] {
                if top < STACK {
                    stack[top] = kid;
                    top += 1;
                } else {
                    spill.push(kid);
                }
            }
        }
        best
    }

    /// The closest point of `mesh` (the mesh this was built from) to `p`,
    /// among its triangles of non-zero area: (triangle, barycentric
    /// weights, distance); `None` without such triangles. Children are
    /// visited nearest box first, and a box farther than the best so far
    /// is skipped; triangles are measured in f64 against the mesh itself,
    /// boxes (f32, in the unit frame) with a margin for their rounding.
    pub fn closest_point(&self, mesh: &TriMesh, p: DVec3) -> Option<(usize, [f64; 3], f64)> {
        if self.nodes.is_empty() {
            return None;
        }
        let q = (p - self.centre) * self.inv_scale;
        // The boxes hold the f32-rounded triangles: a few ulps of the unit
        // frame may lie outside them.
        const MARGIN: f64 = 1e-6;
        let box_d2 = |node: &Node, k: usize| -> f64 {
            let mut d2 = 0.0;
            for a in 0..3 {
                let lo = node.lo[a][k] as f64 - MARGIN;
                let hi = node.hi[a][k] as f64 + MARGIN;
                let x = q[a];
                let e = if x < lo {
                    lo - x
                } else if x > hi {
                    x - hi
                } else {
                    0.0
                };
                d2 += e * e;
            }
            d2
        };
        let to_local2 = self.inv_scale * self.inv_scale;
        let mut best: Option<(usize, [f64; 3], f64)> = None;
        let mut best_d2 = f64::INFINITY; // in the unit frame
                                         // On the machine stack unless the tree is deep: one query a point.
        let mut stack: smallvec::SmallVec<[(f64, u32); STACK]> = smallvec::smallvec![(0.0, 0)];
        while let Some((enter, at)) = stack.pop() {
            if enter > best_d2 {
                continue;
            }
            let node = &self.nodes[at as usize];
            let mut kids = [(0f64, 0u32); W];
            let mut nk = 0;
            for k in 0..W {
                let (child, count) = (node.child[k], node.count[k]);
                if count == EMPTY {
                    continue;
                }
                let d2 = box_d2(node, k);
                if d2 > best_d2 {
                    continue;
                }
                if count == 0 {
                    // Farthest first on the stack.
                    let mut j = nk;
                    while j > 0 && kids[j - 1].0 < d2 {
                        kids[j] = kids[j - 1];
                        j -= 1;
                    }
                    kids[j] = (d2, child);
                    nk += 1;
                } else {
                    let first = self.quads[child as usize].first;
                    for j in first..first + count {
                        let t = self.ids[j as usize] as usize;
                        let [a, b, c] = mesh.tri(t);
                        let w = crate::geom::closest_on_triangle(p, a, b, c);
                        let d = (crate::geom::blend(w, a, b, c) - p).length();
                        let d2 = d * d * to_local2;
                        // Nearest first; equal distances: lowest index.
                        if d2 < best_d2 || (d2 == best_d2 && best.is_some_and(|b| t < b.0)) {
                            best_d2 = d2;
                            best = Some((t, w, d));
                        }
                    }
                }
            }
            stack.extend_from_slice(&kids[..nk]);
        }
        best
    }

    /// The triangles in the unit frame, in leaf order (for comparisons with
    /// other ray tracers on the same rays).
    pub fn triangles(&self) -> &[Triangle] {
        &self.plain
    }

    /// The ray test of triangle `j` of the leaf order (for
    /// [`crate::geom::columns`]).
    #[inline(always)]
    pub(crate) fn hit_leaf(&self, j: u32, ray: &Ray, sh: &Sheared, facing: Facing) -> Option<f32> {
        self.tris[j as usize].hit_t(ray, sh, facing)
    }

    /// The any-hit test of triangle `j` of the leaf order.
    #[inline(always)]
    pub(crate) fn hits_leaf(&self, j: u32, ray: &Ray, sh: &Sheared) -> bool {
        self.tris[j as usize].hits(ray, sh)
    }

    /// The mesh's index of triangle `j` of the leaf order.
    #[inline(always)]
    pub fn leaf_id(&self, j: u32) -> u32 {
        self.ids[j as usize]
    }

    /// The outward (counter-clockwise) normal of triangle `j` of the leaf
    /// order, not normalised: which side a ray meets it from.
    #[inline]
    pub fn leaf_normal(&self, j: u32) -> DVec3 {
        let t = &self.plain[j as usize];
        (t.v1 - t.v0).cross(t.v2 - t.v0).as_dvec3()
    }

    /// A distance in the unit frame in mesh units.
    #[inline]
    pub fn mesh_dist(&self, t: f32) -> f64 {
        t as f64 / self.inv_scale
    }
}

/// The ray's origin and reciprocal direction, kept finite (a zero
/// component becomes a huge one of the same sign: the slabs stay ordered).
#[inline(always)]
fn ray_slabs(ray: &Ray) -> ([f32; 3], [f32; 3]) {
    let inv = |d: f32| {
        let d = if d.abs() < 1e-30 {
            1e-30f32.copysign(d)
        } else {
            d
        };
        1.0 / d
    };
    (
        [ray.origin.x, ray.origin.y, ray.origin.z],
        [
            inv(ray.direction.x),
            inv(ray.direction.y),
            inv(ray.direction.z),
        ],
    )
}

/// The children's entry distances along the ray within `[tmin, tmax]`,
/// and which are crossed (bit `k`: entry <= exit), `tmax` grown to be
/// conservative (Ize, "Robust BVH Ray Traversal"). Written as lanes the
/// compiler turns into vector instructions: `min` and `max` as
/// comparisons (one instruction each, where `f32::min` also weighs NaNs;
/// none arise: the reciprocal direction is finite and the boxes' corners
/// are finite or, for an empty slot, both `+inf`, which gives an entry at
/// `+inf` or an exit at `-inf`: never crossed).
#[inline(always)]
fn slabs(node: &Node, o: &[f32; 3], id: &[f32; 3], tmin: f32, tmax: f32) -> ([f32; W], u32) {
    #[inline(always)]
    fn lesser(a: f32, b: f32) -> f32 {
        if a < b {
            a
        } else {
            b
        }
    }
    #[inline(always)]
    fn greater(a: f32, b: f32) -> f32 {
        if a > b {
            a
        } else {
            b
        }
    }
    let mut tnear = [tmin; W];
    // At most the largest finite distance: an empty slot's entry at `+inf`
    // then lies beyond it, also for a ray without end.
    let mut tfar = [lesser(tmax * (1.0 + 2.0 * f32::EPSILON), f32::MAX); W];
    for a in 0..3 {
        for k in 0..W {
            let t0 = (node.lo[a][k] - o[a]) * id[a];
            let t1 = (node.hi[a][k] - o[a]) * id[a];
            tnear[k] = greater(tnear[k], lesser(t0, t1));
            tfar[k] = lesser(tfar[k], greater(t0, t1));
        }
    }
    let mut crossed = 0u32;
    for k in 0..W {
        crossed |= ((tnear[k] <= tfar[k]) as u32) << k;
    }
    (tnear, crossed)
}

/// Whether the processor has AVX, for the traversals' AVX code path.
fn avx() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

fn set_box(n: &mut Node, slot: usize, lo: Vec3A, hi: Vec3A) {
    for a in 0..3 {
        n.lo[a][slot] = lo[a];
        n.hi[a][slot] = hi[a];
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
/// Closest-point queries on a mesh's triangles, through the ray tracer's
/// BVH (this module's): boxes nearest first, pruned by the best distance so
/// far. (A k-d tree of triangle centroids, searched outwards until no
/// triangle could be closer, degrades when huge triangles sit among tiny
/// ones: every centroid within the huge one's radius is a candidate.)
/// Triangles of no area are never the answer.
pub struct ClosestPoint<'a> {
    mesh: &'a TriMesh,
    bvh: Occluder,
}

/// A closest-point answer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Triangle index.
    pub tri: usize,
    /// Barycentric weights on it.
    pub bary: [f64; 3],
    /// Distance.
    pub dist: f64,
}

impl<'a> ClosestPoint<'a> {
    /// Builds the index; `None` for a mesh without triangles of non-zero
    /// area.
    pub fn new(mesh: &'a TriMesh) -> Option<Self> {
        let bvh = Occluder::new(mesh);
        if bvh.triangle_count() == 0 {
            return None;
        }
        Some(ClosestPoint { mesh, bvh })
    }

    /// The closest point of the mesh to `p`.
    pub fn query(&self, p: DVec3) -> Hit {
        let (tri, bary, dist) = self
            .bvh
            .closest_point(self.mesh, p)
            .expect("a BVH with triangles has a closest one");
        Hit { tri, bary, dist }
    }
}
