//! Geometry as pure free functions: triangle and polygon measures,
//! polygon triangulation, triangle sampling, closest points; and the
//! structures built over geometry: meshes ([`mesh`]), a BVH for rays
//! ([`bvh`]), a k-d tree over points ([`kdtree`]), grids over points
//! ([`grid`]).
//!
//! Everything is f64 and takes positions relative to a triangle's first
//! vertex before crossing, so results hold at large coordinates.

pub mod bvh;
pub mod columns;
pub mod grid;
pub mod kdtree;
pub mod mesh;
pub mod ray_tri;

use glam::DVec3;

/// Twice the vector area of triangle `abc` (its normal times 2 * area).
#[inline]
pub fn tri_cross(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a)
}

/// Area of triangle `abc`: 0 for a degenerate one, never NaN for finite input.
#[inline]
pub fn tri_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    0.5 * tri_cross(a, b, c).length()
}

/// Newell's normal of a polygon: twice its vector area. Exact for planar
/// polygons of any shape, a sensible average for non-planar ones.
pub fn newell(pts: &[DVec3]) -> DVec3 {
    let Some(&o) = pts.first() else {
        return DVec3::ZERO;
    };
    let mut n = DVec3::ZERO;
    for i in 0..pts.len() {
        let (a, b) = (pts[i] - o, pts[(i + 1) % pts.len()] - o);
        n += a.cross(b);
    }
    n
}

/// Unit normal of `v`, or zero when `v` has no direction.
#[inline]
pub fn unit_or_zero(v: DVec3) -> DVec3 {
    let l = v.length();
    if l > 0.0 && l.is_finite() {
        v / l
    } else {
        DVec3::ZERO
    }
}

/// Perimeter of a closed polygon.
pub fn perimeter(pts: &[DVec3]) -> f64 {
    (0..pts.len())
        .map(|i| (pts[(i + 1) % pts.len()] - pts[i]).length())
        .sum()
}

/// Triangulates polygon `pts` (indices into `pts`) by ear clipping in the
/// plane of its Newell normal, so non-convex planar polygons come out
/// right; triangles and degenerate polygons fall back to a fan. Fewer than
/// three vertices give nothing.
pub fn triangulate(pts: &[DVec3], out: &mut Vec<[usize; 3]>) {
    let n = pts.len();
    if n < 3 {
        return;
    }
    if n == 3 {
        out.push([0, 1, 2]);
        return;
    }
    let Some(p2) = project_2d(pts) else {
        return fan(n, out);
    };
    let cross2 = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
    };
    // (Strictly convex: exactly ear clipping's triangles. Past the size
    // where ear clipping turns slow, convex up to rounding.)
    if convex_2d(&p2, n > MAX_CONCAVE_CORNERS) {
        // The triangles ear clipping finds on a convex polygon (its first
        // ear each time: a fan around the last corner), in linear time.
        for i in 0..n - 3 {
            out.push([n - 1, i, i + 1]);
        }
        out.push([n - 3, n - 2, n - 1]);
        return;
    }
    let mut ring: Vec<usize> = (0..n).collect();
    let start = out.len();
    while ring.len() > 3 {
        let m = ring.len();
        let ear = (0..m).find(|&i| {
            let (a, b, c) = (ring[(i + m - 1) % m], ring[i], ring[(i + 1) % m]);
            if cross2(p2[a], p2[b], p2[c]) <= 0.0 {
                return false;
            }
            ring.iter().all(|&k| {
                k == a
                    || k == b
                    || k == c
                    || cross2(p2[a], p2[b], p2[k]) < 0.0
                    || cross2(p2[b], p2[c], p2[k]) < 0.0
                    || cross2(p2[c], p2[a], p2[k]) < 0.0
            })
        });
        match ear {
            Some(i) => {
                out.push([ring[(i + m - 1) % m], ring[i], ring[(i + 1) % m]]);
                ring.remove(i);
            }
            None => {
                // Self-intersecting or degenerate: a fan of the whole polygon.
                out.truncate(start);
                return fan(n, out);
            }
        }
    }
    out.push([ring[0], ring[1], ring[2]]);
}

/// Is the projected polygon convex (every turn to the left, once
/// around)? Strictly, or (`slack`) allowing turns to the right as small as
/// the rounding of its coordinates (a many-sided polygon read as f32).
fn convex_2d(p: &[[f64; 2]], slack: bool) -> bool {
    let n = p.len();
    // A corner moved by f32 rounding of the coordinates (`scale` their
    // size) changes a turn's cross product by about that times the edges.
    let scale = p
        .iter()
        .fold(0.0f64, |m, q| m.max(q[0].abs()).max(q[1].abs()));
    let mut turning = 0.0;
    for i in 0..n {
        let (a, b, c) = (p[i], p[(i + 1) % n], p[(i + 2) % n]);
        let (e, f) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
        let cross = e[0] * f[1] - e[1] * f[0];
        let least = if slack {
            -4.0 * f32::EPSILON as f64 * scale * (e[0].hypot(e[1]) + f[0].hypot(f[1]))
        } else {
            0.0
        };
        if cross.is_nan() || cross <= least {
            return false;
        }
        turning += cross.atan2(e[0] * f[0] + e[1] * f[1]);
    }
    // Once around: 2 pi (a star that winds twice turns 4 pi).
    turning < 3.0 * std::f64::consts::PI
}

/// Is the polygon (in 3D, projected on its plane) convex, up to the
/// rounding of its coordinates?
pub fn is_convex(pts: &[DVec3]) -> bool {
    pts.len() >= 3 && project_2d(pts).is_some_and(|p2| convex_2d(&p2, true))
}

/// The polygon in 2D, dropping the dominant axis of its Newell normal,
/// counter-clockwise when seen along the normal; `None` when the normal
/// is zero (a degenerate polygon).
fn project_2d(pts: &[DVec3]) -> Option<Vec<[f64; 2]>> {
    let nrm = newell(pts);
    let ax = nrm.abs().max_position();
    if nrm[ax] == 0.0 {
        return None;
    }
    let (u, v) = match ax {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let flip = nrm[ax] < 0.0;
    Some(
        pts.iter()
            .map(|p| if flip { [p[v], p[u]] } else { [p[u], p[v]] })
            .collect(),
    )
}

/// The most corners of a face that is not convex: ear clipping takes time
/// quadratic (at worst cubic) in them. A convex face of any size takes
/// linear time.
pub const MAX_CONCAVE_CORNERS: usize = 1024;

fn fan(n: usize, out: &mut Vec<[usize; 3]>) {
    for k in 1..n - 1 {
        out.push([0, k, k + 1]);
    }
}

/// Uniform barycentric weights on a triangle from two uniform numbers in
/// [0, 1) (the square-root warp, pbrt's `SampleUniformTriangle`).
#[inline]
pub fn sample_triangle(r1: f64, r2: f64) -> [f64; 3] {
    let s = r1.sqrt();
    [1.0 - s, s * (1.0 - r2), s * r2]
}

/// The point of triangle `abc` closest to `p` (Ericson, Real-Time Collision
/// Detection, 5.1.5), as barycentric weights.
pub fn closest_on_triangle(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // Degenerate triangle: the nearest of its vertices.
        let d = [
            (p - a).length_squared(),
            (p - b).length_squared(),
            (p - c).length_squared(),
        ];
        let k = (0..3).min_by(|&i, &j| d[i].total_cmp(&d[j])).unwrap_or(0);
        let mut w = [0.0; 3];
        w[k] = 1.0;
        return w;
    }
    let (v, w) = (vb / denom, vc / denom);
    [1.0 - v - w, v, w]
}

/// The barycentric weights of `q`'s projection onto the plane of triangle
/// `abc` (negative outside it); `None` for a degenerate triangle.
#[inline]
pub fn barycentric_in_plane(q: DVec3, a: DVec3, b: DVec3, c: DVec3) -> Option<[f64; 3]> {
    let (ab, ac, aq) = (b - a, c - a, q - a);
    let (d00, d01, d11) = (ab.dot(ab), ab.dot(ac), ac.dot(ac));
    let (d20, d21) = (aq.dot(ab), aq.dot(ac));
    let den = d00 * d11 - d01 * d01;
    if !(den > 0.0 && den.is_finite()) {
        return None;
    }
    let v = (d11 * d20 - d01 * d21) / den;
    let w = (d00 * d21 - d01 * d20) / den;
    Some([1.0 - v - w, v, w])
}

/// Two unit vectors that make an orthonormal basis with the unit `n`
/// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
pub fn tangent_basis(n: DVec3) -> (DVec3, DVec3) {
    let sign = 1f64.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        DVec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        DVec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Clips the convex polygon `poly` to the half-plane `dot(x, v) <= c`
/// (Sutherland-Hodgman), into `out`. Each edge (from the vertex of the
/// same index to the next) carries a label, in `lab` and `olab`: the
/// edge the line makes gets `k`, the others keep theirs.
pub fn clip_half_plane(
    (poly, lab): (&[[f64; 2]], &[u32]),
    v: [f64; 2],
    c: f64,
    k: u32,
    (out, olab): (&mut Vec<[f64; 2]>, &mut Vec<u32>),
) {
    out.clear();
    olab.clear();
    let side = |p: [f64; 2]| p[0] * v[0] + p[1] * v[1] - c;
    for (i, &p) in poly.iter().enumerate() {
        let q = poly[(i + 1) % poly.len()];
        let (sp, sq) = (side(p), side(q));
        if sp <= 0.0 {
            out.push(p);
            // From a vertex on the line to one beyond it, the edge runs
            // along the line.
            olab.push(if sp == 0.0 && sq > 0.0 { k } else { lab[i] });
        }
        if (sp < 0.0 && sq > 0.0) || (sp > 0.0 && sq < 0.0) {
            let t = sp / (sp - sq);
            out.push([p[0] + (q[0] - p[0]) * t, p[1] + (q[1] - p[1]) * t]);
            // Leaving, the edge from here runs along the line; entering,
            // along the rest of the old edge.
            olab.push(if sp < 0.0 { k } else { lab[i] });
        }
    }
}

/// The distance from `p` to the segment `ab`.
pub fn segment_distance(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t - p).length()
}

/// The area of a simple 2D polygon (shoelace formula).
pub fn polygon_area_2d(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    let twice: f64 = (0..n)
        .map(|k| {
            let (p, q) = (poly[k], poly[(k + 1) % n]);
            p[0] * q[1] - q[0] * p[1]
        })
        .sum();
    0.5 * twice.abs()
}

/// `w0 a + w1 b + w2 c`.
#[inline]
pub fn blend(w: [f64; 3], a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    // Relative to `a`, so large coordinates keep their precision.
    a + (b - a) * w[1] + (c - a) * w[2]
}

/// A compensated (Neumaier) sum: rounding does not grow with the count.
#[derive(Clone, Copy, Debug, Default)]
pub struct Sum {
    s: f64,
    c: f64,
}

impl Sum {
    /// Adds `x`.
    #[inline]
    pub fn add(&mut self, x: f64) {
        let t = self.s + x;
        if self.s.abs() >= x.abs() {
            self.c += (self.s - t) + x;
        } else {
            self.c += (x - t) + self.s;
        }
        self.s = t;
    }

    /// The sum.
    pub fn value(&self) -> f64 {
        self.s + self.c
    }
}

impl FromIterator<f64> for Sum {
    fn from_iter<I: IntoIterator<Item = f64>>(it: I) -> Self {
        let mut s = Sum::default();
        it.into_iter().for_each(|x| s.add(x));
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn d(x: f64, y: f64, z: f64) -> DVec3 {
        DVec3::new(x, y, z)
    }

    #[test]
    fn clipping_labels_the_new_edge_and_keeps_the_others() {
        // The unit square (edges 0..4 from its corners, counter-clockwise)
        // cut by x + y <= 1.5: the corner (1, 1) goes, a new edge 9 joins
        // (1, 0.5) to (0.5, 1).
        let sq = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let (mut out, mut lab) = (Vec::new(), Vec::new());
        clip_half_plane(
            (&sq, &[0, 1, 2, 3]),
            [1.0, 1.0],
            1.5,
            9,
            (&mut out, &mut lab),
        );
        assert_eq!(
            out,
            vec![[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 1.0]]
        );
        assert_eq!(lab, vec![0, 1, 9, 2, 3]);
        assert!((polygon_area_2d(&out) - 0.875).abs() < 1e-15);
        // Through a corner: the edge from it along the line is the new one.
        clip_half_plane(
            (&sq, &[0, 1, 2, 3]),
            [1.0, 1.0],
            1.0,
            9,
            (&mut out, &mut lab),
        );
        assert_eq!(out, vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        assert_eq!(lab, vec![0, 9, 3]);
        // A line that misses the polygon changes nothing.
        clip_half_plane(
            (&sq, &[0, 1, 2, 3]),
            [1.0, 1.0],
            5.0,
            9,
            (&mut out, &mut lab),
        );
        assert_eq!(
            (out.as_slice(), lab.as_slice()),
            (&sq[..], &[0, 1, 2, 3][..])
        );
    }

    #[test]
    fn ear_clipping_a_non_convex_l_shape_keeps_its_area() {
        // An L of area 3 (unit squares), counter-clockwise, in the xz plane.
        let pts = [
            d(0., 0., 0.),
            d(2., 0., 0.),
            d(2., 0., 1.),
            d(1., 0., 1.),
            d(1., 0., 2.),
            d(0., 0., 2.),
        ];
        let mut t = Vec::new();
        triangulate(&pts, &mut t);
        assert_eq!(t.len(), 4);
        let a: f64 = t
            .iter()
            .map(|k| tri_area(pts[k[0]], pts[k[1]], pts[k[2]]))
            .sum();
        assert!((a - 3.0).abs() < 1e-12, "{a}");
        assert!((newell(&pts).length() / 2.0 - 3.0).abs() < 1e-12);
    }

    #[test]
    fn closest_point_regions() {
        let (a, b, c) = (d(0., 0., 0.), d(1., 0., 0.), d(0., 1., 0.));
        let w = closest_on_triangle(d(0.2, 0.2, 5.0), a, b, c);
        assert!(
            (w[0] - 0.6).abs() < 1e-12 && (w[1] - 0.2).abs() < 1e-12 && (w[2] - 0.2).abs() < 1e-12
        );
        assert_eq!(
            closest_on_triangle(d(-1., -1., 0.), a, b, c),
            [1.0, 0.0, 0.0]
        );
        assert_eq!(
            closest_on_triangle(d(0.5, -1., 0.), a, b, c),
            [0.5, 0.5, 0.0]
        );
        let w = closest_on_triangle(d(1., 1., 0.), a, b, c);
        assert!((w[1] - 0.5).abs() < 1e-12 && (w[2] - 0.5).abs() < 1e-12);
        // Degenerate: a point triangle.
        assert_eq!(closest_on_triangle(d(1., 1., 1.), a, a, a)[0], 1.0);
    }

    #[test]
    fn compensated_sum_does_not_drift() {
        let s: Sum = std::iter::once(1e16)
            .chain(std::iter::repeat_n(1.0, 1000))
            .chain(std::iter::once(-1e16))
            .collect();
        assert_eq!(s.value(), 1000.0);
    }
}
