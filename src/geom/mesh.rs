//! Meshes: a cloud's `face` element as polygons, their triangulation, and
//! closest-point queries.

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Cloud, ListColumn};
use crate::column::Scalar;
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
        // u32::MAX marks an index out of range or not whole (found again
        // below for the message, unless it is a vertex's index).
        let valid = |v: f64| v >= 0.0 && v < n as f64 && (v as u32) as f64 == v;
        let indices: Vec<u32> = crate::with_column!(&list.items, items => items
            .par_iter()
            .map(|x| {
                let v = x.to_f64();
                if valid(v) {
                    v as u32
                } else {
                    u32::MAX
                }
            })
            .collect());
        if indices.par_iter().any(|&i| i == u32::MAX) {
            if let Some(k) = (0..list.items.len()).find(|&k| !valid(list.items.get_f64(k))) {
                let v = list.items.get_f64(k);
                let face = list.offsets.partition_point(|&o| o <= k) - 1;
                return Err(Error::invalid(format!(
                    "face {face} refers to vertex {v}, but the mesh has {n} vertices"
                )));
            }
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
    /// The surface's open edges: each edge that exactly one triangle of
    /// non-zero area has (vertices at the same position counted as one,
    /// so a seam between copies is no edge), as its two ends and the
    /// triangle's third corner, in triangle order. A closed mesh costs a
    /// sort of its edges by vertex index and nothing more: positions are
    /// compared only for the edges that one triangle has by index.
    pub fn open_edges(&self) -> Vec<[DVec3; 3]> {
        use rayon::prelude::*;
        let pair = |a: u32, b: u32| (a.min(b) as u64) << 32 | a.max(b) as u64;
        // The edges of the triangles of non-zero area, by their ends'
        // indices; the rest's slots hold a key no edge has, three times.
        const DEAD: u64 = u64::MAX;
        let live = |t: usize| {
            let [a, b, c] = self.tri(t);
            geom::tri_cross(a, b, c) != DVec3::ZERO
        };
        let mut keys = vec![DEAD; 3 * self.tris.len()];
        keys.par_chunks_mut(3).enumerate().for_each(|(t, e)| {
            if live(t) {
                let v = self.tris[t].map(|c| self.vertex(c) as u32);
                for k in 0..3 {
                    e[k] = pair(v[(k + 1) % 3], v[(k + 2) % 3]);
                }
            }
        });
        // (A radix sort over the bits the indices use.)
        let bits = 64 - (self.positions.len() as u64).leading_zeros();
        crate::radix::sort_bits(&mut keys, 0, 32 + bits);
        let once: std::collections::HashSet<u64> = keys
            .chunk_by(|x, y| x == y)
            .filter(|r| r.len() == 1)
            .map(|r| r[0])
            .collect();
        drop(keys);
        if once.is_empty() {
            return Vec::new();
        }
        // Those edges' triangles, and the edges again by their ends'
        // positions: a seam between copies of vertices is no edge.
        let ends = |tk: usize| {
            let (t, k) = (tk / 3, tk % 3);
            let c = self.tri(t);
            [c[(k + 1) % 3], c[(k + 2) % 3], c[k]]
        };
        let once = &once;
        let candidates: Vec<usize> = (0..self.tris.len())
            .into_par_iter()
            .filter(|&t| live(t))
            .flat_map_iter(|t| {
                let v = self.tris[t].map(|c| self.vertex(c) as u32);
                (0..3)
                    .filter(move |&k| once.contains(&pair(v[(k + 1) % 3], v[(k + 2) % 3])))
                    .map(move |k| t * 3 + k)
            })
            .collect();
        let bits = |p: DVec3| p.to_array().map(|x| (x + 0.0).to_bits());
        let mut by_pos: Vec<([[u64; 3]; 2], usize)> = candidates
            .iter()
            .filter_map(|&tk| {
                let [a, b, _] = ends(tk);
                let (a, b) = (bits(a), bits(b));
                // (Both ends at one position: no edge.)
                (a != b).then(|| ([a.min(b), a.max(b)], tk))
            })
            .collect();
        by_pos.par_sort_unstable();
        let mut open: Vec<usize> = by_pos
            .chunk_by(|x, y| x.0 == y.0)
            .filter(|r| r.len() == 1)
            .map(|r| r[0].1)
            .collect();
        open.sort_unstable();
        open.into_iter().map(ends).collect()
    }

    /// The mesh's fingerprint: XXH3-128 of its positions and polygons, in
    /// 32 hex digits. Recorded by the stages that trace rays against it,
    /// so that clouds baked against other meshes are told apart.
    pub fn digest(&self) -> String {
        let mut h = xxhash_rust::xxh3::Xxh3::new();
        for p in &self.positions {
            for x in p.to_array() {
                h.update(&x.to_bits().to_le_bytes());
            }
        }
        for o in &self.polys.offsets {
            h.update(&(*o as u64).to_le_bytes());
        }
        for i in &self.polys.indices {
            h.update(&i.to_le_bytes());
        }
        format!("{:032x}", h.digest128())
    }

    /// The mesh of `cloud`: its `P` and faces, polygons triangulated by ear
    /// clipping. Errors on no faces, faces pointing at missing vertices and
    /// non-finite positions.
    pub fn from_cloud(cloud: &Cloud) -> Result<TriMesh> {
        let polys = Polygons::of(cloud)?;
        let positions: Vec<DVec3> = cloud
            .points()
            .vec3_f64("P")?
            .into_par_iter()
            .map(DVec3::from_array)
            .collect();
        if let Some(i) = positions.par_iter().position_first(|p| !p.is_finite()) {
            return Err(Error::invalid(format!(
                "vertex {i} has a non-finite position {:?}",
                positions[i].to_array()
            )));
        }
        // Chunks of faces triangulated in parallel, each giving its
        // triangles and its faces' ends among them; the first error in
        // face order is the one reported.
        const CHUNK: usize = 1 << 14;
        type Chunk = (Vec<[u32; 3]>, Vec<u32>);
        let chunks: Vec<Result<Chunk>> = (0..polys.len().div_ceil(CHUNK))
            .into_par_iter()
            .map(|c| {
                let faces = c * CHUNK..((c + 1) * CHUNK).min(polys.len());
                let mut tris = Vec::with_capacity(faces.len());
                let mut ends = Vec::with_capacity(faces.len());
                let mut local = Vec::new();
                let mut pts = Vec::new();
                for f in faces {
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
                    ends.push(tris.len() as u32);
                }
                Ok((tris, ends))
            })
            .collect();
        let chunks = chunks.into_iter().collect::<Result<Vec<_>>>()?;
        let mut face_tris = Vec::with_capacity(polys.len() + 1);
        face_tris.push(0u32);
        let mut base = 0u32;
        for (tris, ends) in &chunks {
            face_tris.extend(ends.iter().map(|e| base + e));
            base += tris.len() as u32;
        }
        let tris = crate::disjoint::concat(chunks.into_iter().map(|c| c.0).collect());
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

    /// The triangle of face `f` a point scattered on it lies on: the one
    /// whose point at barycentric weights `w` is nearest `p` (`sourceuv`
    /// is relative to one triangle of the face's triangulation, and the
    /// face's other triangles put `w` elsewhere). `None` for a face with
    /// no triangle.
    pub fn triangle_at(&self, f: usize, w: [f64; 3], p: DVec3) -> Option<usize> {
        (self.face_tris[f]..self.face_tris[f + 1])
            .min_by(|&a, &b| {
                let d = |t: u32| {
                    let [x, y, z] = self.tri(t as usize);
                    (geom::blend(w, x, y, z) - p).length_squared()
                };
                d(a).total_cmp(&d(b))
            })
            .map(|t| t as usize)
    }

    /// The faces of a cloud's `sourceprim` values, checked to be faces of
    /// this mesh (an error names the first point that is not).
    pub fn source_faces(&self, prim: &[f64]) -> Result<()> {
        let nf = self.face_count();
        match prim.iter().position(|&f| !(f >= 0.0 && f < nf as f64)) {
            Some(i) => Err(Error::invalid(format!(
                "point {i} has sourceprim {}, but the mesh has {nf} faces (is the mesh the one it was scattered on?)",
                prim[i]
            ))),
            None => Ok(()),
        }
    }

    /// [`Self::source_faces`], and each point of `pos` lies on its face:
    /// within `1e-4` of the mesh's size plus the f32 rounding of its
    /// coordinates (scatter places points on their faces, relaxed or not,
    /// and `follow` moves them with them). A cloud scattered on another
    /// mesh with as many faces passes the count and fails this: its
    /// points lie off their faces. The error names the first such point.
    pub fn source_faces_at(&self, prim: &[f64], pos: &[[f64; 3]]) -> Result<()> {
        self.source_faces(prim)?;
        let (lo, hi) = self.positions.iter().fold(
            (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let size = (hi - lo).length();
        if !size.is_finite() {
            return Ok(());
        }
        let far = |i: usize| -> Option<f64> {
            let p = DVec3::from_array(pos[i]);
            let f = prim[i] as usize;
            let d = (self.face_tris[f]..self.face_tris[f + 1])
                .map(|t| {
                    let [a, b, c] = self.tri(t as usize);
                    (geom::blend(geom::closest_on_triangle(p, a, b, c), a, b, c) - p).length()
                })
                .fold(f64::INFINITY, f64::min);
            let tol = 1e-4 * size + 1e-6 * p.abs().max_element();
            // (A NaN distance, a non-finite point, is the stage's own
            // error to name.)
            (d > tol && d.is_finite()).then_some(d)
        };
        let bad = (0..prim.len().min(pos.len()))
            .into_par_iter()
            .find_first(|&i| far(i).is_some());
        match bad {
            Some(i) => Err(Error::invalid(format!(
                "point {i} lies {:.3e} from its face {} (sourceprim) on a mesh {size:.3e} across: \
                 is the mesh the one it was scattered on?",
                far(i).unwrap_or(0.0),
                prim[i]
            ))),
            None => Ok(()),
        }
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
            .into_par_iter()
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
    /// Each triangle's corner positions, copied: a walk reads one
    /// triangle's 72 bytes where `TriMesh::tri` follows three indices.
    tri: Vec<[DVec3; 3]>,
    /// The open edges (of exactly one triangle), as `triangle * 3 +
    /// corner` (the edge opposite the corner), sorted.
    open: Vec<u32>,
}

impl Adjacency {
    /// The adjacency of `mesh`'s triangles.
    pub fn new(mesh: &TriMesh) -> Adjacency {
        use rayon::prelude::*;
        // One id per distinct position: positions sorted by their bits.
        let mut by_pos: Vec<([u64; 3], u32)> = mesh
            .positions
            .par_iter()
            .enumerate()
            .map(|(v, p)| (p.to_array().map(|x| (x + 0.0).to_bits()), v as u32))
            .collect();
        by_pos.par_sort_unstable();
        let mut weld = vec![0u32; mesh.positions.len()];
        let mut id = 0u32;
        for (k, &(bits, v)) in by_pos.iter().enumerate() {
            if k > 0 && bits != by_pos[k - 1].0 {
                id += 1;
            }
            weld[v as usize] = id;
        }
        drop(by_pos);
        let tri: Vec<[DVec3; 3]> = (0..mesh.tris.len())
            .into_par_iter()
            .map(|t| mesh.tri(t))
            .collect();
        // Each triangle's welded corners; triangles of no area are left
        // out (a walk never enters one).
        let corners: Vec<Option<[u32; 3]>> = (0..mesh.tris.len())
            .into_par_iter()
            .map(|t| {
                let [a, b, c] = tri[t];
                (geom::tri_cross(a, b, c) != DVec3::ZERO)
                    .then(|| mesh.tris[t].map(|c| weld[mesh.vertex(c)]))
            })
            .collect();
        // Every edge as (high vertex, triangle * 3 + corner) in the bucket
        // of its low vertex, in triangle order (a counting sort): the
        // triangles sharing an edge sit in one small bucket.
        let edge = |v: &[u32; 3], k: usize| {
            let (a, b) = (v[(k + 1) % 3], v[(k + 2) % 3]);
            (a.min(b), a.max(b))
        };
        let mut start = vec![0u32; id as usize + 2];
        for v in corners.iter().flatten() {
            for k in 0..3 {
                start[edge(v, k).0 as usize + 1] += 1;
            }
        }
        for i in 1..start.len() {
            start[i] += start[i - 1];
        }
        let mut at = start.clone();
        let mut bucket = vec![0u64; *start.last().expect("not empty") as usize];
        for (t, v) in corners.iter().enumerate() {
            if let Some(v) = v {
                for k in 0..3 {
                    let (a, b) = edge(v, k);
                    bucket[at[a as usize] as usize] = (b as u64) << 32 | (t * 3 + k) as u64;
                    at[a as usize] += 1;
                }
            }
        }
        drop(at);
        // Each bucket sorted, so the triangles of an edge follow each
        // other (a vertex shared by a million triangles costs a sort, not
        // a million squared).
        let mut rest: &mut [u64] = &mut bucket;
        let mut runs: Vec<&mut [u64]> = Vec::with_capacity(start.len());
        for w in start.windows(2) {
            let (run, tail) = rest.split_at_mut((w[1] - w[0]) as usize);
            runs.push(run);
            rest = tail;
        }
        // An edge with exactly two triangles links them; one with exactly
        // one is open (the surface's boundary); a degenerate edge (both
        // ends at one position) leads nowhere.
        let (links, open): (Vec<(u32, u32)>, Vec<u32>) = runs
            .into_par_iter()
            .enumerate()
            .map(|(a, run)| {
                run.sort_unstable();
                let (mut links, mut open) = (Vec::new(), Vec::new());
                for e in run.chunk_by(|x, y| x >> 32 == y >> 32) {
                    if (e[0] >> 32) as usize == a {
                        continue;
                    }
                    match e.len() {
                        1 => open.push(e[0] as u32),
                        2 => links.push((e[0] as u32, e[1] as u32)),
                        _ => {}
                    }
                }
                (links, open)
            })
            .reduce(
                || (Vec::new(), Vec::new()),
                |(mut l, mut o), (l2, o2)| {
                    l.extend(l2);
                    o.extend(o2);
                    (l, o)
                },
            );
        let mut adj = vec![[NO_TRIANGLE; 3]; mesh.tris.len()];
        for (e, f) in links {
            let (e, f) = (e as usize, f as usize);
            adj[e / 3][e % 3] = (f / 3) as u32;
            adj[f / 3][f % 3] = (e / 3) as u32;
        }
        let mut open = open;
        open.sort_unstable();
        Adjacency { adj, tri, open }
    }

    /// The surface's open edges: each edge that exactly one triangle of
    /// non-zero area has, as its two ends and the triangle's third corner
    /// (the side the surface lies on), in triangle order.
    pub fn open_edges(&self) -> Vec<[DVec3; 3]> {
        self.open
            .iter()
            .map(|&e| {
                let (t, k) = (e as usize / 3, e as usize % 3);
                let c = self.tri[t];
                [c[(k + 1) % 3], c[(k + 2) % 3], c[k]]
            })
            .collect()
    }

    /// The neighbours of triangle `t` across its edges.
    pub fn of(&self, t: usize) -> [u32; 3] {
        self.adj[t]
    }

    /// The corner positions of triangle `t` (`TriMesh::tri`).
    #[inline]
    pub fn tri(&self, t: usize) -> [DVec3; 3] {
        self.tri[t]
    }

    /// Moves a point of triangle `t` to `q` along the surface: `q` is put
    /// in the plane of `t`; while it falls outside `t` across an edge with
    /// a triangle beyond, the walk steps there and puts it in that plane.
    /// Where no triangle lies beyond (an open edge), or the walk would go
    /// back where it came from (a fold), or after `MAX_WALK` steps, the
    /// answer is the point of the current triangle closest to `q`. Meant
    /// for moves of a few triangles; a far move ends where the walk stops.
    pub fn walk(&self, mut t: usize, q: DVec3) -> (usize, [f64; 3]) {
        const MAX_WALK: usize = 64;
        let mut from = NO_TRIANGLE as usize;
        for _ in 0..MAX_WALK {
            let [a, b, c] = self.tri[t];
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
        let [a, b, c] = self.tri[t];
        (t, geom::closest_on_triangle(q, a, b, c))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;
    use rand_pcg::Pcg32;

    /// A mesh of triangles over `positions`, each its own polygon.
    fn mesh(positions: Vec<DVec3>, tris: &[[u32; 3]]) -> TriMesh {
        let indices: Vec<u32> = tris.iter().flatten().copied().collect();
        TriMesh {
            positions,
            polys: Polygons {
                offsets: (0..=tris.len()).map(|f| 3 * f).collect(),
                indices,
            },
            tris: (0..tris.len() as u32)
                .map(|f| [3 * f, 3 * f + 1, 3 * f + 2])
                .collect(),
            face_tris: (0..=tris.len() as u32).collect(),
        }
    }

    /// Adjacency by its definition, pair by pair: the triangle across the
    /// edge opposite corner `k` is the other one of exactly two triangles
    /// of area that have an edge between the same two positions (not one
    /// position twice).
    fn brute(m: &TriMesh) -> Vec<[u32; 3]> {
        let area = |t: usize| {
            let [a, b, c] = m.tri(t);
            geom::tri_cross(a, b, c) != DVec3::ZERO
        };
        let at = |t: usize, k: usize| m.positions[m.vertex(m.tris[t][k])].to_array();
        let ends = |t: usize, k: usize| {
            let (a, b) = (at(t, (k + 1) % 3), at(t, (k + 2) % 3));
            let key = |p: [f64; 3]| p.map(|x| (x + 0.0).to_bits());
            let (a, b) = (key(a), key(b));
            (a.min(b), a.max(b))
        };
        (0..m.tris.len())
            .map(|t| {
                std::array::from_fn(|k| {
                    let e = ends(t, k);
                    if !area(t) || e.0 == e.1 {
                        return NO_TRIANGLE;
                    }
                    let sharing: Vec<usize> = (0..m.tris.len())
                        .filter(|&u| area(u))
                        .flat_map(|u| (0..3).map(move |j| (u, j)))
                        .filter(|&(u, j)| ends(u, j) == e)
                        .map(|(u, _)| u)
                        .collect();
                    match sharing[..] {
                        [a, b] if a == t => b as u32,
                        [a, b] if b == t => a as u32,
                        _ => NO_TRIANGLE,
                    }
                })
            })
            .collect()
    }

    #[test]
    fn adjacency_is_what_its_definition_says() {
        // A grid of squares split in two, with every position written
        // twice (seams between unwelded copies), a fin of three triangles
        // on one edge, a triangle across the grid's first row, and one
        // with two corners at one position (no area).
        let mut g = Pcg32::new(3, 9);
        let side = 7u32;
        let mut pos = Vec::new();
        for i in 0..side {
            for j in 0..side {
                let z = (g.next_u32() % 5) as f64 * 0.1;
                pos.push(DVec3::new(i as f64, j as f64, z));
            }
        }
        let copies = pos.len() as u32;
        pos.extend(pos.clone());
        let mut tris = Vec::new();
        for i in 0..side - 1 {
            for j in 0..side - 1 {
                let mut v = |a: u32, b: u32| (i + a) * side + j + b + copies * (g.next_u32() % 2);
                tris.push([v(0, 0), v(1, 0), v(1, 1)]);
                tris.push([v(0, 0), v(1, 1), v(0, 1)]);
            }
        }
        pos.push(DVec3::new(0.5, 0.5, 3.0));
        let apex = pos.len() as u32 - 1;
        tris.push([0, side + 1, apex]);
        tris.push([0, 1, 2]);
        tris.push([0, 0, side]);
        let m = mesh(pos, &tris);
        let adj = Adjacency::new(&m);
        let want = brute(&m);
        let linked = want.iter().flatten().filter(|&&t| t != NO_TRIANGLE).count();
        assert!(linked > 100, "the mesh is mostly connected ({linked})");
        for (t, w) in want.iter().enumerate() {
            assert_eq!(adj.of(t), *w, "triangle {t}");
        }
    }
}
