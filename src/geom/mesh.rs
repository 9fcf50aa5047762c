//! Meshes: a cloud's `face` element as polygons, their triangulation, and
//! closest-point queries.

use glam::DVec3;

use crate::cloud::{Cloud, ListColumn};
use crate::error::{Error, Result};
use crate::geom;

/// A cloud's faces as polygons over its points.
#[derive(Clone, Debug, PartialEq)]
pub struct Polygons {
    /// Polygon `f` is `indices[offsets[f]..offsets[f + 1]]`.
    pub offsets: Vec<usize>,
    /// Point indices, all checked to be in range.
    pub indices: Vec<u32>,
}

/// The names PLY writers use for a face's vertex list.
pub const FACE_LIST_NAMES: [&str; 2] = ["vertex_indices", "vertex_index"];

impl Polygons {
    /// The polygons of `cloud`; an error when it has no faces or a face
    /// points at a missing vertex.
    pub fn of(cloud: &Cloud) -> Result<Polygons> {
        let faces = cloud.faces().filter(|f| !f.is_empty()).ok_or_else(|| {
            Error::invalid("no faces: a mesh is needed (a PLY 'face' element or OBJ 'f' lines)")
        })?;
        let list: &ListColumn = FACE_LIST_NAMES
            .iter()
            .find_map(|n| faces.list(n).ok())
            .ok_or_else(|| Error::invalid("the 'face' element has no 'vertex_indices' list"))?;
        let n = cloud.len();
        let mut indices = Vec::with_capacity(list.items.len());
        for k in 0..list.items.len() {
            let v = list.items.get_f64(k);
            if !(v >= 0.0 && v < n as f64) || v.fract() != 0.0 {
                let face = list.offsets.partition_point(|&o| o <= k) - 1;
                return Err(Error::invalid(format!(
                    "face {face} refers to vertex {v}, but the mesh has {n} vertices"
                )));
            }
            indices.push(v as u32);
        }
        Ok(Polygons {
            offsets: list.offsets.clone(),
            indices,
        })
    }

    /// Number of polygons.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True when there are no polygons.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The vertex indices of polygon `f`.
    pub fn polygon(&self, f: usize) -> &[u32] {
        &self.indices[self.offsets[f]..self.offsets[f + 1]]
    }

    /// Number of triangles a triangulation gives (n - 2 per n-gon).
    pub fn triangle_count(&self) -> usize {
        (0..self.len())
            .map(|f| self.polygon(f).len().saturating_sub(2))
            .sum()
    }
}

/// A polygon mesh with its triangulation, positions in f64.
#[derive(Clone, Debug)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// The polygons.
    pub polys: Polygons,
    /// Triangles as corner ids (indices into `polys.indices`), so a
    /// triangle knows its face's per-corner data.
    pub tris: Vec<[u32; 3]>,
    /// Face `f` owns triangles `face_tris[f]..face_tris[f + 1]`.
    pub face_tris: Vec<u32>,
}

impl TriMesh {
    /// The mesh of `cloud`: its `P` and faces, polygons triangulated by ear
    /// clipping. Errors on no faces, faces pointing at missing vertices and
    /// non-finite positions.
    pub fn from_cloud(cloud: &Cloud) -> Result<TriMesh> {
        let polys = Polygons::of(cloud)?;
        let positions: Vec<DVec3> = cloud
            .points()
            .vec3_f64("P")?
            .into_iter()
            .map(DVec3::from_array)
            .collect();
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(Error::invalid(format!(
                "vertex {i} has a non-finite position {:?}",
                positions[i].to_array()
            )));
        }
        let mut tris = Vec::with_capacity(polys.triangle_count());
        let mut face_tris = Vec::with_capacity(polys.len() + 1);
        face_tris.push(0u32);
        let mut local = Vec::new();
        let mut pts = Vec::new();
        for f in 0..polys.len() {
            let poly = polys.polygon(f);
            pts.clear();
            pts.extend(poly.iter().map(|&v| positions[v as usize]));
            if pts.len() > geom::MAX_CONCAVE_CORNERS && !geom::is_convex(&pts) {
                return Err(Error::invalid(format!(
                    "face {f} has {} corners and is not convex (a concave face has at most {})",
                    pts.len(),
                    geom::MAX_CONCAVE_CORNERS
                )));
            }
            local.clear();
            geom::triangulate(&pts, &mut local);
            let base = polys.offsets[f] as u32;
            tris.extend(
                local
                    .iter()
                    .map(|t| [base + t[0] as u32, base + t[1] as u32, base + t[2] as u32]),
            );
            face_tris.push(tris.len() as u32);
        }
        Ok(TriMesh {
            positions,
            polys,
            tris,
            face_tris,
        })
    }

    /// Number of faces.
    pub fn face_count(&self) -> usize {
        self.polys.len()
    }

    /// The vertex id at corner `c`.
    #[inline]
    pub fn vertex(&self, corner: u32) -> usize {
        self.polys.indices[corner as usize] as usize
    }

    /// The three corners' positions of triangle `t`.
    #[inline]
    pub fn tri(&self, t: usize) -> [DVec3; 3] {
        let k = self.tris[t];
        [
            self.positions[self.vertex(k[0])],
            self.positions[self.vertex(k[1])],
            self.positions[self.vertex(k[2])],
        ]
    }

    /// The face a triangle belongs to.
    pub fn tri_faces(&self) -> Vec<u32> {
        let mut out = vec![0u32; self.tris.len()];
        for f in 0..self.face_count() {
            for t in self.face_tris[f]..self.face_tris[f + 1] {
                out[t as usize] = f as u32;
            }
        }
        out
    }

    /// An error unless some triangle has a non-zero area: a mesh of only
    /// degenerate faces can neither be seen nor let light in or block it,
    /// and is a wrong file rather than a scene.
    pub fn require_area(&self) -> Result<()> {
        if self.tris.is_empty() {
            return Err(Error::invalid("no faces: a mesh is needed"));
        }
        if !self.tri_areas().iter().any(|&a| a > 0.0) {
            return Err(Error::invalid(format!(
                "none of its {} faces has a non-zero area",
                self.face_count()
            )));
        }
        Ok(())
    }

    /// The area of every triangle.
    pub fn tri_areas(&self) -> Vec<f64> {
        (0..self.tris.len())
            .map(|t| {
                let [a, b, c] = self.tri(t);
                geom::tri_area(a, b, c)
            })
            .collect()
    }

    /// Unit face normals (Newell's; zero for a degenerate face).
    pub fn face_normals(&self) -> Vec<DVec3> {
        let mut pts = Vec::new();
        (0..self.face_count())
            .map(|f| {
                pts.clear();
                pts.extend(
                    self.polys
                        .polygon(f)
                        .iter()
                        .map(|&v| self.positions[v as usize]),
                );
                geom::unit_or_zero(geom::newell(&pts))
            })
            .collect()
    }
}

/// No triangle across this edge (an open edge, or one that more than two
/// triangles share).
pub const NO_TRIANGLE: u32 = u32::MAX;

/// Each triangle's neighbours across its three edges: `adj[t][k]` shares
/// the edge opposite corner `k` of `t` (or is `NO_TRIANGLE`). Vertices at
/// the same position count as one, so a mesh split along its UV seams is
/// still walked across them; triangles of no area have no neighbours and
/// are nobody's.
pub struct Adjacency {
    adj: Vec<[u32; 3]>,
}

impl Adjacency {
    /// The adjacency of `mesh`'s triangles.
    pub fn new(mesh: &TriMesh) -> Adjacency {
        use rayon::prelude::*;
        // One id per distinct position.
        let mut by_pos: Vec<u32> = (0..mesh.positions.len() as u32).collect();
        let bits = |v: u32| {
            mesh.positions[v as usize]
                .to_array()
                .map(|x| (x + 0.0).to_bits())
        };
        by_pos.par_sort_unstable_by_key(|&v| (bits(v), v));
        let mut weld = vec![0u32; mesh.positions.len()];
        let mut id = 0u32;
        for (k, &v) in by_pos.iter().enumerate() {
            if k > 0 && bits(v) != bits(by_pos[k - 1]) {
                id += 1;
            }
            weld[v as usize] = id;
        }
        // Every edge as (low vertex, high vertex, triangle * 3 + corner),
        // sorted: the triangles sharing an edge sit together.
        // Triangles of no area are left out: a walk never enters one.
        let mut edges: Vec<(u32, u32, u32)> = (0..mesh.tris.len())
            .into_par_iter()
            .filter(|&t| {
                let [a, b, c] = mesh.tri(t);
                geom::tri_cross(a, b, c) != DVec3::ZERO
            })
            .flat_map_iter(|t| {
                let v = mesh.tris[t].map(|c| weld[mesh.vertex(c)]);
                (0..3).map(move |k| {
                    let (a, b) = (v[(k + 1) % 3], v[(k + 2) % 3]);
                    (a.min(b), a.max(b), (t * 3 + k) as u32)
                })
            })
            .collect();
        edges.par_sort_unstable();
        let mut adj = vec![[NO_TRIANGLE; 3]; mesh.tris.len()];
        let mut i = 0;
        while i < edges.len() {
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == edges[i].0 && edges[j].1 == edges[i].1 {
                j += 1;
            }
            // A degenerate edge (both ends at one position) leads nowhere.
            if j - i == 2 && edges[i].0 != edges[i].1 {
                let (e, f) = (edges[i].2 as usize, edges[i + 1].2 as usize);
                adj[e / 3][e % 3] = (f / 3) as u32;
                adj[f / 3][f % 3] = (e / 3) as u32;
            }
            i = j;
        }
        Adjacency { adj }
    }

    /// The neighbours of triangle `t` across its edges.
    pub fn of(&self, t: usize) -> [u32; 3] {
        self.adj[t]
    }

    /// Moves a point of triangle `t` to `q` along the surface: `q` is put
    /// in the plane of `t`; while it falls outside `t` across an edge with
    /// a triangle beyond, the walk steps there and puts it in that plane.
    /// Where no triangle lies beyond (an open edge), or the walk would go
    /// back where it came from (a fold), or after `MAX_WALK` steps, the
    /// answer is the point of the current triangle closest to `q`. Meant
    /// for moves of a few triangles; a far move ends where the walk stops.
    pub fn walk(&self, mesh: &TriMesh, mut t: usize, q: DVec3) -> (usize, [f64; 3]) {
        const MAX_WALK: usize = 64;
        let mut from = NO_TRIANGLE as usize;
        for _ in 0..MAX_WALK {
            let [a, b, c] = mesh.tri(t);
            let Some(w) = geom::barycentric_in_plane(q, a, b, c) else {
                break;
            };
            let k = (0..3).min_by(|&i, &j| w[i].total_cmp(&w[j])).unwrap_or(0);
            if w[k] >= 0.0 {
                return (t, w);
            }
            let next = self.adj[t][k] as usize;
            if next == NO_TRIANGLE as usize || next == from {
                break;
            }
            from = t;
            t = next;
        }
        let [a, b, c] = mesh.tri(t);
        (t, geom::closest_on_triangle(q, a, b, c))
    }
}

/// Closest-point queries on a mesh's triangles, through the ray tracer's
/// BVH (`geom::bvh`): boxes nearest first, pruned by the best distance so
/// far. (A k-d tree of triangle centroids, searched outwards until no
/// triangle could be closer, degrades when huge triangles sit among tiny
/// ones: every centroid within the huge one's radius is a candidate.)
/// Triangles of no area are never the answer.
pub struct ClosestPoint<'a> {
    mesh: &'a TriMesh,
    bvh: crate::geom::bvh::Occluder,
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
        let bvh = crate::geom::bvh::Occluder::new(mesh);
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
