//! The shadow-ray BVH against a brute-force f64 test of every triangle.

use glam::{DVec3, Vec3A};
use obvhs::ray::Ray;
use pcsss::geom::bvh::Occluder;
use pcsss::geom::mesh::TriMesh;
use rand_core::RngCore;
use rand_pcg::Pcg32;

use crate::util::*;

fn unit(r: &mut Pcg32) -> f64 {
    r.next_u32() as f64 / 4294967296.0
}

/// A uniform point on triangle `t` of `m`, and its outward normal.
fn on_triangle(m: &TriMesh, t: usize, r: &mut Pcg32) -> (DVec3, DVec3) {
    let [a, b, c] = m.tri(t);
    let (u, v) = (unit(r), unit(r));
    let (u, v) = if u + v > 1.0 {
        (1.0 - u, 1.0 - v)
    } else {
        (u, v)
    };
    (
        a + (b - a) * u + (c - a) * v,
        (b - a).cross(c - a).normalize(),
    )
}

/// The ray parameter of a hit of the segment `o + t d`, `t` in
/// `[0, tmax]`, with `abc` in f64, and how far inside the triangle it is
/// (the smallest barycentric weight) and from the segment's ends.
fn hit64(o: DVec3, d: DVec3, tmax: f64, abc: [DVec3; 3]) -> Option<(f64, f64)> {
    let (t, margin) = plane64(o, d, abc)?;
    (margin >= 0.0 && t >= 0.0 && t <= tmax).then_some((t, margin.min(t).min(tmax - t)))
}

/// Where the line `o + t d` meets the plane of `abc` in f64: `t`, and the
/// smallest barycentric weight there (negative outside the triangle);
/// `None` along the plane.
fn plane64(o: DVec3, d: DVec3, [a, b, c]: [DVec3; 3]) -> Option<(f64, f64)> {
    let (e1, e2) = (b - a, c - a);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-300 {
        return None;
    }
    let s = o - a;
    let u = s.dot(p) / det;
    let q = s.cross(e1);
    let v = d.dot(q) / det;
    Some((e2.dot(q) / det, u.min(v).min(1.0 - u - v)))
}

#[test]
fn any_hit_agrees_with_brute_force() {
    let mesh = soup(5);
    let mut r = Pcg32::new(5, 1);
    let m = TriMesh::from_cloud(&mesh).unwrap();
    let occ = Occluder::new(&m);
    let base = Occluder::new(&m).without_avx();
    assert_eq!(occ.triangle_count(), 400);
    // The BVH works in its own unit frame: compare there, with the
    // triangles it holds.
    let tris: Vec<[DVec3; 3]> = occ
        .triangles()
        .iter()
        .map(|t| [t.v0, t.v1, t.v2].map(|v| DVec3::from(Vec3A::to_array(&v).map(|x| x as f64))))
        .collect();
    let (mut checked, mut hits) = (0, 0);
    for k in 0..20000 {
        let o = DVec3::new(unit(&mut r), unit(&mut r), unit(&mut r)) - 0.5;
        let mut d = DVec3::new(unit(&mut r), unit(&mut r), unit(&mut r)) - 0.5;
        // Axis-aligned rays, with +0 and -0 components, every few.
        match k % 5 {
            0 => d = DVec3::new(0.0, -0.0, if d.z > 0.0 { 1.0 } else { -1.0 }),
            1 => d = DVec3::new(-0.0, d.y.signum(), 0.0),
            _ => d = d.normalize(),
        }
        let tmax = if k % 3 == 0 {
            f64::INFINITY
        } else {
            unit(&mut r)
        };
        let o32 = o.as_vec3();
        let o64 = DVec3::new(o32.x as f64, o32.y as f64, o32.z as f64);
        let d32 = d.as_vec3();
        let d64 = DVec3::new(d32.x as f64, d32.y as f64, d32.z as f64);
        let ray = Ray::new(o32.into(), d32.into(), 0.0, tmax as f32);
        // Both code paths alike, also where f32 may go either way.
        assert_eq!(
            occ.occluded_ray(&ray),
            base.occluded_ray(&ray),
            "ray {k}: the paths differ"
        );
        let hits64: Vec<(f64, f64)> = tris
            .iter()
            .filter_map(|t| hit64(o64, d64, tmax, *t))
            .collect();
        // Hits within 1e-5 of an edge or of the segment's ends can go
        // either way in f32.
        if hits64.iter().any(|h| h.1 < 1e-5) {
            continue;
        }
        let near_miss = tris.iter().any(|t| {
            let grown = hit64(o64, d64, tmax * (1.0 + 1e-5) + 1e-5, *t);
            grown.is_some() && hit64(o64, d64, tmax, *t).is_none()
        });
        if near_miss {
            continue;
        }
        let want = !hits64.is_empty();
        assert_eq!(occ.occluded_ray(&ray), want, "ray {k}: {o} {d} {tmax}");
        checked += 1;
        hits += want as usize;
    }
    assert!(
        checked > 15000 && hits > 3000,
        "{checked} checked, {hits} hits"
    );
}

#[test]
fn an_empty_or_degenerate_mesh_occludes_nothing() {
    let mesh = mesh_from(
        &[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        &[vec![0, 1, 2]],
    );
    let occ = Occluder::new(&TriMesh::from_cloud(&mesh).unwrap());
    assert_eq!(occ.triangle_count(), 0);
    assert!(!occ.occluded(
        DVec3::new(1.0, -1.0, 0.0),
        DVec3::Y,
        DVec3::Y,
        f64::INFINITY
    ));
}

#[test]
fn thousands_of_coincident_triangles_are_traced_whole() {
    // One triangle repeated: the tree over equal boxes is as deep as the
    // builder makes it; every copy must still be reachable.
    let mut p = Vec::new();
    let mut faces = Vec::new();
    for k in 0..5000 {
        p.extend([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        faces.push(vec![3 * k, 3 * k + 1, 3 * k + 2]);
    }
    p.push([5.0, 5.0, 5.0]); // widens the frame
    let mesh = mesh_from(&p, &faces);
    let occ = Occluder::new(&TriMesh::from_cloud(&mesh).unwrap());
    assert_eq!(occ.triangle_count(), 5000);
    let up = DVec3::Z;
    assert!(occ.occluded(DVec3::new(0.2, 0.2, -1.0), -up, up, f64::INFINITY));
    assert!(occ.occluded(DVec3::new(0.2, 0.2, -1.0), -up, up, 1.5));
    assert!(!occ.occluded(DVec3::new(0.2, 0.2, -1.0), -up, up, 0.5));
    assert!(!occ.occluded(DVec3::new(0.8, 0.8, -1.0), -up, up, f64::INFINITY));
}

#[test]
fn closest_points_through_the_bvh_match_brute_force_on_mixed_triangle_sizes() {
    // One huge triangle (1e3 across) beside a strip of 2,000 tiny ones
    // (1e-3 across), 1e6 from the origin, and a few of no area: the case
    // where a k-d tree of centroids has to visit every tiny centroid
    // within the huge triangle's radius.
    let o = [1e6, -1e6, 1e6];
    let mut p = vec![
        [o[0], o[1], o[2]],
        [o[0] + 1e3, o[1], o[2]],
        [o[0], o[1] + 1e3, o[2] + 10.0],
    ];
    let mut faces = vec![vec![0, 1, 2]];
    let mut r = Pcg32::new(4, 4);
    for k in 0..2000 {
        let b = p.len() as i32;
        let x = o[0] + 1.0 + k as f64 * 1e-3;
        let z = o[2] - 0.5 + unit(&mut r) * 1e-3;
        p.extend([
            [x, o[1] - 0.5, z],
            [x + 1e-3, o[1] - 0.5, z],
            [x, o[1] - 0.5 + 1e-3, z + 1e-4],
        ]);
        faces.push(vec![b, b + 1, b + 2]);
    }
    let b = p.len() as i32;
    p.extend([
        [o[0] + 5.0, o[1] - 0.5, o[2]],
        [o[0] + 6.0, o[1] - 0.5, o[2]],
    ]);
    faces.push(vec![b, b + 1, b + 1]);
    let cloud = mesh_from(&p, &faces);
    let mesh = TriMesh::from_cloud(&cloud).unwrap();
    let cp = pcsss::geom::bvh::ClosestPoint::new(&mesh).unwrap();
    let area = |t: usize| {
        let [a, b, c] = mesh.tri(t);
        pcsss::geom::tri_area(a, b, c)
    };
    for _ in 0..2000 {
        let q = DVec3::from_array(o)
            + DVec3::new(
                unit(&mut r) * 4.0 - 1.0,
                unit(&mut r) * 2.0 - 1.5,
                unit(&mut r) * 2.0 - 1.0,
            );
        let hit = cp.query(q);
        let best = (0..mesh.tris.len())
            .filter(|&t| area(t) > 0.0)
            .map(|t| {
                let [a, b, c] = mesh.tri(t);
                let w = pcsss::geom::closest_on_triangle(q, a, b, c);
                (pcsss::geom::blend(w, a, b, c) - q).length()
            })
            .fold(f64::INFINITY, f64::min);
        assert!(
            (hit.dist - best).abs() <= 1e-9 * (1.0 + best),
            "{q:?}: {} against {best}",
            hit.dist
        );
        assert!(area(hit.tri) > 0.0, "a triangle of no area");
    }
}

/// A soup of 400 triangles in the unit cube, one in seven long and thin.
fn soup(seed: u64) -> pcsss::cloud::Cloud {
    let mut r = Pcg32::new(seed, 0);
    let mut p = Vec::new();
    let mut faces = Vec::new();
    for k in 0..400 {
        let c = DVec3::new(unit(&mut r), unit(&mut r), unit(&mut r));
        let s = if k % 7 == 0 { 0.5 } else { 0.08 };
        for _ in 0..3 {
            let q = c + DVec3::new(unit(&mut r) - 0.5, unit(&mut r) - 0.5, unit(&mut r) - 0.5) * s;
            p.push(q.to_array());
        }
        faces.push(vec![3 * k, 3 * k + 1, 3 * k + 2]);
    }
    mesh_from(&p, &faces)
}

#[test]
fn parallel_rays_through_columns_find_the_bvh_hits_and_the_true_ones() {
    use pcsss::geom::bvh::Facing;
    use pcsss::geom::columns::Columns;
    let bunny = bunny();
    let meshes = [
        ("bunny", bunny),
        ("soup", soup(9)),
        // Far from the origin and small: the unit frame takes both.
        ("sphere", uv_sphere(24, 48, 1e-3, [1e6, -2e6, 5e5])),
    ];
    let dirs = [
        DVec3::Z,
        -DVec3::X,
        DVec3::new(1.0, 1.0, 1.0),
        DVec3::new(0.8, -0.5, -0.35),
        DVec3::new(-0.3, -0.2, 1.0),
        DVec3::new(1e-9, 1.0, 0.0),
    ];
    let mut r = Pcg32::new(11, 0);
    for (name, mesh) in &meshes {
        let m = TriMesh::from_cloud(mesh).unwrap();
        let occ = Occluder::new(&m);
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in &m.positions {
            lo = lo.min(*p);
            hi = hi.max(*p);
        }
        let size = (hi - lo).max_element();
        let (mut same, mut total, mut hits, mut true_checked) = (0, 0, 0, 0);
        for dir in dirs {
            let dir = dir.normalize();
            let cols = Columns::new(&occ, dir).unwrap_or_else(|| panic!("{name}: no grid"));
            for k in 0..3000 {
                // Origins in the box grown by a fifth, and on the
                // triangles' edges and corners (rays through them).
                let o = if k % 3 == 0 {
                    let t = m.tri(k % m.tris.len());
                    let w = if k % 2 == 0 { 0.5 } else { 0.0 };
                    (t[0] * (1.0 - w) + t[1] * w) - dir * size * 0.7
                } else {
                    lo - (hi - lo) * 0.2
                        + (hi - lo) * 1.4 * DVec3::new(unit(&mut r), unit(&mut r), unit(&mut r))
                };
                let facing = [Facing::Any, Facing::Entering, Facing::Leaving][k / 3 % 3];
                let (tmin, tmax) = match k / 9 % 4 {
                    0 => (0.0, f64::INFINITY),
                    1 => (-0.01 * size, f64::INFINITY),
                    2 => (0.0, 0.3 * size),
                    _ => (-0.05 * size, 0.9 * size),
                };
                let a = occ.nearest(o, dir, tmin, tmax, facing);
                let b = cols.nearest(&occ, o, dir, tmin, tmax, facing);
                hits += a.is_some() as usize;
                total += (k % 3 != 0) as usize;
                if a == b {
                    same += (k % 3 != 0) as usize;
                } else if k % 3 != 0 {
                    // A random ray through an edge: the other triangle
                    // of it, at the same distance up to rounding.
                    let (Some(a), Some(b)) = (a, b) else {
                        panic!("{name} {dir:?} {o:?} {facing:?}: bvh {a:?}, columns {b:?}");
                    };
                    assert!(
                        (a.1 - b.1).abs() <= 1e-5 * size,
                        "{name} {dir:?} {o:?}: bvh {a:?}, columns {b:?}"
                    );
                } else {
                    // A ray through a corner or an edge, along an axis:
                    // the BVH's box test misses a box whose face the ray
                    // lies in exactly (its slab is empty), so where the
                    // ray only grazes the surface there it goes on. The
                    // grid misses nothing the BVH finds, and what it
                    // finds is on its triangle.
                    let b = b.unwrap_or_else(|| {
                        panic!("{name} {dir:?} {o:?}: bvh {a:?}, no columns hit")
                    });
                    assert!(
                        a.is_none_or(|a| b.1 <= a.1 + 1e-5 * size),
                        "{name} {dir:?} {o:?}: bvh {a:?}, columns {b:?}"
                    );
                    let [ta, tb, tc] = m.tri(b.0);
                    let p = o + dir * b.1;
                    let w = pcsss::geom::closest_on_triangle(p, ta, tb, tc);
                    let q = ta * w[0] + tb * w[1] + tc * w[2];
                    assert!(
                        (p - q).length() <= 1e-5 * size,
                        "{name} {dir:?} {o:?}: {b:?} is off its triangle by {}",
                        (p - q).length()
                    );
                }
                // Random rays away from edges: the nearest hit is the true
                // one (f64, every triangle).
                if k % 3 != 0 && facing == Facing::Any && tmin == 0.0 && tmax.is_infinite() {
                    let truth = (0..m.tris.len())
                        .filter_map(|t| hit64(o, dir, f64::INFINITY, m.tri(t)).map(|h| (t, h)))
                        .min_by(|x, y| x.1 .0.total_cmp(&y.1 .0));
                    if let Some((t, (d, margin))) = truth {
                        if margin > 1e-4 * size {
                            let b = b.expect("a true hit");
                            assert_eq!(b.0, t, "{name} {dir:?} {o:?}: {b:?} against {d} {margin}");
                            assert!((b.1 - d).abs() <= 1e-5 * size, "{name}: {b:?} against {d}");
                            true_checked += 1;
                        }
                    } else {
                        assert_eq!(b, None, "{name} {dir:?} {o:?}");
                    }
                }
            }
        }
        assert!(
            same * 1000 >= total * 998,
            "{name}: {same} of {total} random rays the same"
        );
        assert!(
            hits * 5 > total && true_checked > 100,
            "{name}: {hits} hits, {true_checked} checked against the truth"
        );
    }
}

#[test]
fn columns_decline_what_they_cannot_hold_and_hold_nothing_for_nothing() {
    use pcsss::geom::columns::Columns;
    // Fifty huge squares stacked face to face over one small triangle:
    // seen face on, every cell holds every square: too many entries.
    let mut p = Vec::new();
    let mut faces = Vec::new();
    for k in 0..50 {
        let z = k as f64 * 0.01;
        let b = p.len() as i32;
        p.extend([[0.0, 0.0, z], [1.0, 0.0, z], [1.0, 1.0, z], [0.0, 1.0, z]]);
        faces.push(vec![b, b + 1, b + 2, b + 3]);
    }
    let m = TriMesh::from_cloud(&mesh_from(&p, &faces)).unwrap();
    let occ = Occluder::new(&m);
    assert!(Columns::new(&occ, DVec3::Z).is_none());
    // Edge on, the same stack is thin: a grid.
    assert!(Columns::new(&occ, DVec3::X).is_some());
    // A flat mesh seen edge on projects to a segment: a row of cells, not
    // a square of them.
    let (mut p, mut faces) = (Vec::new(), Vec::new());
    for k in 0..1000 {
        let x = k as f64;
        let b = p.len() as i32;
        p.extend([[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 0.0, 1.0]]);
        faces.push(vec![b, b + 1, b + 2]);
    }
    let occ = Occluder::new(&TriMesh::from_cloud(&mesh_from(&p, &faces)).unwrap());
    let edge_on = Columns::new(&occ, DVec3::Z).unwrap();
    assert!(edge_on.size().0 <= 3 * 2000 + 2, "{:?}", edge_on.size());
    // No triangle, or no direction: no grid.
    let flat = mesh_from(
        &[[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
        &[vec![0, 1, 2]],
    );
    let occ = Occluder::new(&TriMesh::from_cloud(&flat).unwrap());
    assert!(Columns::new(&occ, DVec3::Z).is_none());
    let occ = Occluder::new(&TriMesh::from_cloud(&soup(1)).unwrap());
    assert!(Columns::new(&occ, DVec3::ZERO).is_none());
    assert!(Columns::new(&occ, DVec3::NAN).is_none());
}

#[test]
fn shadow_rays_through_columns_are_blocked_as_through_the_bvh() {
    use pcsss::geom::columns::Columns;
    let bunny = bunny();
    let mut r = Pcg32::new(3, 0);
    for mesh in [bunny, soup(4), uv_sphere(24, 48, 1e-3, [1e6, -2e6, 5e5])] {
        let m = TriMesh::from_cloud(&mesh).unwrap();
        let occ = Occluder::new(&m);
        let (mut same, mut blocked, mut total) = (0, 0, 0);
        for dir in [
            DVec3::new(0.8, -0.5, -0.35),
            DVec3::Y,
            DVec3::new(-0.3, -0.2, 1.0),
        ] {
            let dir = dir.normalize();
            let cols = Columns::new(&occ, dir).unwrap();
            for k in 0..4000 {
                // A point on a triangle, its normal towards the light.
                let (p, n) = on_triangle(&m, k % m.tris.len(), &mut r);
                let n = if n.dot(dir) < 0.0 { -n } else { n };
                let dist = if k % 2 == 0 {
                    f64::INFINITY
                } else {
                    (m.tri(0)[0] - p).length()
                };
                let want = occ.occluded(p, n, dir, dist);
                total += 1;
                blocked += want as usize;
                same += (cols.occluded(&occ, p, n, dir, dist) == want) as usize;
                // Another direction goes through the BVH.
                assert_eq!(
                    cols.occluded(&occ, p, n, -dir, dist),
                    occ.occluded(p, n, -dir, dist)
                );
            }
        }
        assert!(same * 1000 >= total * 998, "{same} of {total} the same");
        assert!(blocked * 10 > total, "{blocked} of {total} blocked");
    }
}

/// The nearest hit in f64 over every triangle of `m` (the BVH's facing
/// rule: outward normals counter-clockwise) with its distance and the
/// cosine of its angle with the triangle's normal, and whether it is
/// clear: no
/// other hit or near miss within the f32 ray's rounding of its distance
/// and not within that rounding or `1e-4` (in barycentric units) of an
/// edge, where f32 may choose either.
fn nearest64(
    m: &TriMesh,
    o: DVec3,
    d: DVec3,
    tmin: f64,
    facing: pcsss::geom::bvh::Facing,
) -> (Option<(usize, f64, f64)>, bool) {
    use pcsss::geom::bvh::Facing;
    let mut hits: Vec<(f64, usize, f64, f64, f64)> = Vec::new();
    for t in 0..m.tris.len() {
        let [a, b, c] = m.tri(t);
        let ccw = (b - a).cross(c - a);
        let side = ccw.dot(d);
        let keep = match facing {
            Facing::Any => true,
            Facing::Entering => side < 0.0,
            Facing::Leaving => side > 0.0,
        };
        if !keep || ccw.length() == 0.0 {
            continue;
        }
        // Near misses too (a negative margin): f32 may take them.
        let Some((dist, margin)) = plane64(o, d, [a, b, c]) else {
            continue;
        };
        if margin > -1e-4 && dist >= tmin {
            let longest = (b - a).length().max((c - b).length()).max((a - c).length());
            hits.push((
                dist,
                t,
                margin,
                side.abs() / ccw.length(),
                ccw.length() / longest,
            ));
        }
    }
    hits.sort_by(|a, b| a.0.total_cmp(&b.0));
    let Some(&(s, t, margin, cos, height)) = hits.first() else {
        return (None, true);
    };
    // The f32 frame's rounding (1e-7 of the mesh's size) along the ray,
    // stretched by a grazing angle: hits closer than that to `tmin` or to
    // each other can go either way.
    let tol = |s: f64, cos: f64| 1e-6 * (1.0 + s.abs()) / cos;
    // The f32 ray (its origin and direction rounded, 1e-7 of their size)
    // passes beside the f64 one: a hit closer than that to an edge, in
    // the triangle's plane, can go to its neighbour.
    let beside = 1e-6 * (1.0 + o.length() + s.abs()) / cos;
    let clear = margin > 1e-4
        && margin * height > beside
        && s - tmin > tol(s, cos)
        && hits
            .get(1)
            .is_none_or(|h| h.0 - s > tol(s, cos).max(tol(h.0, h.3)));
    (Some((t, s, cos)), clear)
}

#[test]
fn nearest_hits_agree_with_brute_force_on_both_code_paths_inside_outside_grazing_and_far_away() {
    use pcsss::geom::bvh::Facing;
    // A bumpy closed sphere: rays from inside (as a walk's) and from
    // outside, along its triangles and through their edges.
    let mut m = TriMesh::from_cloud(&uv_sphere(60, 120, 1.0, [0.0; 3])).unwrap();
    for p in &mut m.positions {
        let (th, ph) = (p.z.clamp(-1.0, 1.0).acos(), p.y.atan2(p.x));
        *p *= 1.0 + 0.15 * (5.0 * th).sin() * (7.0 * ph).cos();
    }
    let fast = Occluder::new(&m);
    let base = Occluder::new(&m).without_avx();
    // Far from the origin, the same scene: the unit frame keeps its hits.
    let shift = DVec3::new(1e6, -1e6, 1e6);
    let mut far_m = TriMesh::from_cloud(&uv_sphere(60, 120, 1.0, [0.0; 3])).unwrap();
    far_m.positions = m.positions.iter().map(|p| *p + shift).collect();
    let far = Occluder::new(&far_m);
    let mut r = Pcg32::new(11, 3);
    let dir = |r: &mut Pcg32| DVec3::new(unit(r) - 0.5, unit(r) - 0.5, unit(r) - 0.5).normalize();
    let (mut checked, mut kinds) = (0, [0usize; 5]);
    for k in 0..20000 {
        let kind = k % 5;
        let (o, d, tmin, facing) = match kind {
            // Inside, anywhere, any direction, for the first wall out.
            0 => (
                dir(&mut r) * 0.8 * unit(&mut r),
                dir(&mut r),
                0.0,
                Facing::Leaving,
            ),
            // From a point on the surface, inwards (a walk's first step),
            // the origin's own triangle allowed a little behind.
            1 => {
                let (p, n) = on_triangle(&m, (r.next_u32() as usize) % m.tris.len(), &mut r);
                let mut d = dir(&mut r);
                if d.dot(n) > 0.0 {
                    d = -d;
                }
                (p, d, -1e-4, Facing::Any)
            }
            // From far outside, towards the sphere.
            2 => {
                let o = dir(&mut r) * 1e3;
                let aim = dir(&mut r) * 0.9;
                (o, (aim - o).normalize(), 0.0, Facing::Entering)
            }
            // Grazing: along the plane of a triangle, from just outside
            // its edge.
            3 => {
                let t = (r.next_u32() as usize) % m.tris.len();
                let [a, b, c] = m.tri(t);
                let along = (b - a).normalize();
                let n = (b - a).cross(c - a).normalize();
                let d = (along + n * (unit(&mut r) - 0.5) * 1e-3).normalize();
                (a - along * 0.01, d, 0.0, Facing::Any)
            }
            // Through a shared edge's middle, from outside, near and 500
            // sizes away.
            _ => {
                let t = (r.next_u32() as usize) % m.tris.len();
                let [a, b, _] = m.tri(t);
                let mid = (a + b) * 0.5;
                let away = if k % 2 == 0 { 1.0 } else { 500.0 };
                let o = mid + (mid * 2.0 + dir(&mut r) * 0.1) * away;
                (o, (mid - o).normalize(), 0.0, Facing::Any)
            }
        };
        let got = fast.nearest(o, d, tmin, f64::INFINITY, facing);
        let got_base = base.nearest(o, d, tmin, f64::INFINITY, facing);
        assert_eq!(
            got.map(|h| (h.0, h.1.to_bits())),
            got_base.map(|h| (h.0, h.1.to_bits())),
            "ray {k}: the two code paths differ"
        );
        if kind == 4 {
            // The edge is there: the ray meets one of its two triangles
            // (which one is for f32 to choose).
            assert!(got.is_some(), "ray {k} through an edge found no hit");
            let far_hit = far.nearest(o + shift, d, tmin, f64::INFINITY, facing);
            assert!(
                far_hit.is_some(),
                "ray {k} through an edge at 1e6 found no hit"
            );
            kinds[4] += 1;
            continue;
        }
        let (want, clear) = nearest64(&m, o, d, tmin, facing);
        let got_far = far.nearest(o + shift, d, tmin, f64::INFINITY, facing);
        if !clear {
            continue;
        }
        for (what, g) in [("near", got), ("far", got_far)] {
            match (g, want) {
                (None, None) => {}
                (Some((tg, sg)), Some((tw, sw, cos))) => {
                    assert_eq!(
                        tg, tw,
                        "ray {k} ({what}): triangle {tg} at {sg}, brute force {tw} at {sw}"
                    );
                    // The f32 frame's rounding (1e-7 of the mesh's size)
                    // along the ray, stretched by a grazing angle.
                    let tol = 1e-6 * (1.0 + sw.abs()) / cos;
                    assert!(
                        (sg - sw).abs() < tol,
                        "ray {k} ({what}): {sg} against {sw} (cos {cos})"
                    );
                }
                _ => panic!("ray {k} ({what}, kind {kind}): {g:?}, brute force {want:?}"),
            }
        }
        checked += 1;
        kinds[kind] += 1;
    }
    assert!(
        checked > 10000 && kinds.iter().all(|&n| n > 1000),
        "{checked} checked, by kind {kinds:?}"
    );
    assert!(fast.uses_avx() || !std::arch::is_x86_feature_detected!("avx"));
}
