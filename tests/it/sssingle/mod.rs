//! `sssingle` against independent truth: a flat slab (a box much wider
//! than the mean free path) under one distant light, seen from far away.
//! The physical model against Hanrahan and Krueger's closed form, the
//! seed model against the quadrature of its estimator's expectation; both
//! with Fresnel and Henyey-Greenstein written here from the textbook
//! (angle forms), not taken from the library.

use std::f64::consts::PI;

use glam::DVec3;

use crate::util::*;
use pcsss::cloud::Role;
use pcsss::geom::mesh::TriMesh;
use pcsss::lights::{self, Light};
use pcsss::progress::Progress;
use pcsss::stages::sssingle::{self, Model, Params};
use pcsss::Cloud;

mod bad_input;
mod filter;
mod shadow;
mod slab;
mod stability;

/// A box `[-w, w]^2 x [-t, 0]` (top face at z = 0), shifted by `offset`.
pub(super) fn slab_mesh(w: f64, t: f64, offset: DVec3) -> Cloud {
    let mut p = Vec::new();
    for &z in &[-t, 0.0] {
        for &(x, y) in &[(-w, -w), (w, -w), (w, w), (-w, w)] {
            p.push((DVec3::new(x, y, z) + offset).to_array());
        }
    }
    // Outward-facing quads (counter-clockwise seen from outside).
    let faces = vec![
        vec![4, 5, 6, 7],
        vec![0, 3, 2, 1],
        vec![0, 1, 5, 4],
        vec![1, 2, 6, 5],
        vec![2, 3, 7, 6],
        vec![3, 0, 4, 7],
    ];
    mesh_from(&p, &faces)
}

/// `k x k` points of the top face within `half` of its centre, normal +z,
/// f64 positions.
pub(super) fn top_points(k: usize, half: f64, offset: DVec3) -> Cloud {
    let mut p = Vec::new();
    for i in 0..k {
        for j in 0..k {
            let f = |a: usize| -half + 2.0 * half * (a as f64 + 0.5) / k as f64;
            p.push((DVec3::new(f(i), f(j), 0.0) + offset).to_array());
        }
    }
    let mut c = Cloud::with_points(p.len());
    c.points_mut().set_vec3("P", Role::Point, &p).unwrap();
    let n = vec![[0.0f32, 0.0, 1.0]; p.len()];
    c.points_mut().set_vec3("N", Role::Normal, &n).unwrap();
    c
}

/// A distant light arriving from `theta_i` (degrees from +z, in the x-z
/// plane) with colour `cl`.
pub(super) fn distant(theta_i: f64, cl: [f64; 3]) -> Vec<Light> {
    let t = theta_i.to_radians();
    let text = format!(
        r#"{{"lights": [{{"type": "distant", "name": "sun", "color": [{}, {}, {}], "direction": [{}, 0, {}]}}]}}"#,
        cl[0],
        cl[1],
        cl[2],
        -t.sin(),
        -t.cos()
    );
    lights::parse(&text, "test").unwrap()
}

/// The eye far away in direction `theta_o` (degrees from +z, azimuth
/// `phi` degrees) from `offset`.
pub(super) fn eye(theta_o: f64, phi: f64, offset: DVec3) -> DVec3 {
    let (t, f) = (theta_o.to_radians(), phi.to_radians());
    offset + DVec3::new(t.sin() * f.cos(), t.sin() * f.sin(), t.cos()) * 1e7
}

/// Runs sssingle; the `ssS` of every point.
pub(super) fn run(cloud: &Cloud, mesh: &Cloud, lights: &[Light], p: &Params) -> Vec<[f64; 3]> {
    let mut c = cloud.clone();
    let m = TriMesh::from_cloud(mesh).unwrap();
    sssingle::sssingle(&mut c, &m, lights, p, &Progress::hidden()).unwrap();
    c.points().vec3_f64("ssS").unwrap()
}

/// Snell's law: the refracted angle for incidence `theta` (radians) into
/// relative index `eta`; `None` past the critical angle.
pub(super) fn snell(theta: f64, eta: f64) -> Option<f64> {
    let s = theta.sin() / eta;
    (s <= 1.0).then(|| s.asin())
}

/// Fresnel transmittance, unpolarised, from the angle forms
/// (`r_s = -sin(ti - tt) / sin(ti + tt)`, `r_p = tan(ti - tt) / tan(ti + tt)`).
pub(super) fn fresnel_t(theta: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 1.0;
    }
    let Some(tt) = snell(theta, eta) else {
        return 0.0;
    };
    if theta == 0.0 {
        let r = (eta - 1.0) / (eta + 1.0);
        return 1.0 - r * r;
    }
    let rs = (theta - tt).sin() / (theta + tt).sin();
    let rp = (theta - tt).tan() / (theta + tt).tan();
    1.0 - 0.5 * (rs * rs + rp * rp)
}

/// Henyey-Greenstein, normalised over the sphere.
pub(super) fn hg(g: f64, c: f64) -> f64 {
    (1.0 - g * g) / (4.0 * PI * (1.0 + g * g - 2.0 * g * c).powf(1.5))
}

/// The angles of the slab: incidence `ti`, view `to` (radians, view at
/// azimuth 0 or 180) and the cosine between the refracted light's travel
/// direction and the refracted view ray's way back up.
pub(super) struct Angles {
    pub mu_i: f64,
    pub mu_i_t: f64,
    pub mu_o_t: f64,
    pub kti: f64,
    pub kto: f64,
    /// Cosine for the physical model (refracted light direction).
    pub cos_phys: f64,
    /// Cosine for the seed model (the light's unrefracted direction).
    pub cos_seed: f64,
}

impl Angles {
    pub fn new(theta_i: f64, theta_o: f64, phi_o: f64, eta: f64) -> Angles {
        let (ti, to) = (theta_i.to_radians(), theta_o.to_radians());
        let (tti, tto) = (snell(ti, eta).unwrap(), snell(to, eta).unwrap());
        // The light travels in the x-z plane towards -x (from +x... arrives
        // from direction (sin ti, 0, cos ti)); inside it travels along
        // (-sin tti, 0, -cos tti). The view's way back up inside points
        // along (sin tto cos phi, sin tto sin phi, cos tto).
        let f = phi_o.to_radians();
        let up = DVec3::new(tto.sin() * f.cos(), tto.sin() * f.sin(), tto.cos());
        let light_in = DVec3::new(-tti.sin(), 0.0, -tti.cos());
        let light_out = DVec3::new(-ti.sin(), 0.0, -ti.cos());
        Angles {
            mu_i: ti.cos(),
            mu_i_t: tti.cos(),
            mu_o_t: tto.cos(),
            kti: fresnel_t(ti, eta),
            kto: fresnel_t(to, eta),
            cos_phys: light_in.dot(up),
            cos_seed: light_out.dot(up),
        }
    }
}
