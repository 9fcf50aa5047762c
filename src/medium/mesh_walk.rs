//! Random walks through the medium a closed mesh bounds
//! (`docs/DESIGN.md#the-walk-method`): from a point of the surface, light
//! refracted in (Fresnel at `eta`, the outside direction cosine-weighted)
//! takes free flights at the medium's extinction and scatters by
//! Henyey-Greenstein until it leaves through the mesh (the BVH's nearest
//! hit among the faces a ray leaves by), reflected back in at the
//! boundary by Fresnel's odds. By reciprocity a walk from `x_o` that
//! leaves at `x_i` carries the light that entered at `x_i` to `x_o`.
//!
//! One walk serves the three channels (their extinctions differ): each
//! free flight is drawn at one channel's extinction, the channel chosen
//! in proportion to the throughput each still carries, and every channel
//! is weighted by its own density over the mixture's (the one-sample
//! balance heuristic of spectral MIS, as Cycles' random walk does). A
//! walk whose throughput falls below a half continues by Russian
//! roulette (unbiased: the survivors carry what the others lose).
//!
//! The mesh must be closed: a walk that leaves through a hole goes on
//! outside; it is lost when it leaves the mesh's box, and returns
//! nothing ([`End::Lost`]).

use std::f64::consts::PI;

use glam::DVec3;
use rand_pcg::Pcg32;

use super::walk::sample_hg;
use super::Medium;
use crate::geom::bvh::{Facing, Occluder};
use crate::geom::mesh::TriMesh;
use crate::geom::tangent_basis;
use crate::maths::uniform53;
use crate::optics::fresnel;

/// The most scattering events a walk is followed for; one still inside
/// then is cut ([`End::Cut`]: a bias of the share cut, which the report
/// counts). A walk in a medium that absorbs nothing, in an object a
/// hundred mean free paths across, takes about ten thousand.
pub const MAX_EVENTS: u32 = 1_000_000;

/// Below this throughput a walk goes on by Russian roulette.
const ROULETTE: f64 = 0.5;

/// How a walk ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    /// It left through the mesh at `pos`, through a face of outward unit
    /// normal `normal`, after `events` scattering events, carrying
    /// `weight` per channel (the Fresnel transmittance in at its start,
    /// the channels' densities over the mixture's, the roulette's
    /// odds).
    Exit {
        pos: DVec3,
        normal: DVec3,
        events: u32,
        weight: [f64; 3],
    },
    /// Absorbed: the roulette ended it, or no channel carries anything.
    Absorbed,
    /// Still inside after [`MAX_EVENTS`].
    Cut,
    /// It left the mesh's box (through a hole of an open mesh).
    Lost,
}

/// What walks through one mesh and medium share.
pub struct Walker<'a> {
    occ: &'a Occluder,
    /// Each triangle's outward unit normal (by the mesh's index).
    normals: Vec<DVec3>,
    sigma_t: [f64; 3],
    albedo: [f64; 3],
    g: f64,
    eta: f64,
    /// How far inside the surface a walk starts, and a reflected one goes
    /// on: above the BVH's f32 rounding of the mesh (about 1e-7 of its
    /// size).
    inset: f64,
    /// The mesh's box, grown by a tenth: a walk beyond it is lost.
    lo: DVec3,
    hi: DVec3,
}

impl<'a> Walker<'a> {
    /// Walks through `mesh` (whose BVH is `occ`) in `medium`.
    pub fn new(mesh: &TriMesh, occ: &'a Occluder, medium: &Medium) -> Walker<'a> {
        let (lo, hi) = crate::geom::grid::bounds(&mesh.positions);
        let size = (hi - lo).max_element().max(f64::MIN_POSITIVE);
        let grow = DVec3::splat(0.1 * size);
        let normals = (0..mesh.tris.len())
            .map(|t| {
                let [a, b, c] = mesh.tri(t);
                (b - a).cross(c - a).normalize_or_zero()
            })
            .collect();
        Walker {
            occ,
            normals,
            sigma_t: medium.mfp.map(|m| 1.0 / m),
            albedo: medium.albedo,
            g: medium.g,
            eta: medium.eta,
            inset: 1e-6 * size,
            lo: lo - grow,
            hi: hi + grow,
        }
    }

    /// One walk from the surface point `p` of outward unit normal `n`,
    /// with the random stream `r`.
    pub fn walk(&self, p: DVec3, n: DVec3, r: &mut Pcg32) -> End {
        // The outside direction, cosine-weighted about n, and the light
        // refracted in along it (Fresnel's share reflected is not
        // subsurface light).
        let (mu_o, phi) = (uniform53(r).sqrt(), 2.0 * PI * uniform53(r));
        let (t1, t2) = tangent_basis(n);
        let s_o = (1.0 - mu_o * mu_o).max(0.0).sqrt();
        let out = n * mu_o + (t1 * phi.cos() + t2 * phi.sin()) * s_o;
        let t_in = 1.0 - fresnel(mu_o, self.eta);
        let mu_in = super::walk::refracted(mu_o, self.eta);
        let mut d = (-(out - n * mu_o) / self.eta - n * mu_in).normalize();
        let mut x = p - n * self.inset;
        let mut w = [t_in; 3];
        let mut events = 0u32;
        loop {
            let total = w[0] + w[1] + w[2];
            if total.is_nan() || total <= 0.0 {
                return End::Absorbed;
            }
            // A channel by its throughput; the flight at its extinction.
            let u = uniform53(r) * total;
            let h = if u < w[0] {
                0
            } else if u < w[0] + w[1] {
                1
            } else {
                2
            };
            let t = -(1.0 - uniform53(r)).ln() / self.sigma_t[h];
            let pick = w.map(|x| x / total);
            match self.occ.nearest(x, d, 0.0, t, Facing::Leaving) {
                Some((tri, s)) => {
                    // At the boundary: the channels' odds of flying this far.
                    let tr = self.sigma_t.map(|st| (-st * s).exp());
                    let pdf: f64 = (0..3).map(|c| pick[c] * tr[c]).sum();
                    w = [0, 1, 2].map(|c| w[c] * tr[c] / pdf);
                    let nb = self.normals[tri];
                    let pos = x + d * s;
                    let mu = d.dot(nb).clamp(0.0, 1.0);
                    if uniform53(r) >= fresnel(mu, 1.0 / self.eta) {
                        return End::Exit {
                            pos,
                            normal: nb,
                            events,
                            weight: w,
                        };
                    }
                    d = (d - nb * (2.0 * d.dot(nb))).normalize();
                    x = pos - nb * self.inset;
                }
                None => {
                    let f = [0, 1, 2]
                        .map(|c| self.albedo[c] * self.sigma_t[c] * (-self.sigma_t[c] * t).exp());
                    let pdf: f64 = (0..3)
                        .map(|c| pick[c] * self.sigma_t[c] * (-self.sigma_t[c] * t).exp())
                        .sum();
                    w = [0, 1, 2].map(|c| w[c] * f[c] / pdf);
                    x += d * t;
                    if !(x.cmpge(self.lo).all() && x.cmple(self.hi).all()) {
                        return End::Lost;
                    }
                    events += 1;
                    if events >= MAX_EVENTS {
                        return End::Cut;
                    }
                    d = scatter(d, self.g, r);
                    let top = w[0].max(w[1]).max(w[2]);
                    if top < ROULETTE {
                        let q = top / ROULETTE;
                        if uniform53(r) >= q {
                            return End::Absorbed;
                        }
                        w = w.map(|x| x / q);
                    }
                }
            }
        }
    }
}

/// The direction `d` scattered by Henyey-Greenstein `g`.
fn scatter(d: DVec3, g: f64, r: &mut Pcg32) -> DVec3 {
    let c = sample_hg(g, uniform53(r));
    let s = (1.0 - c * c).max(0.0).sqrt();
    let phi = 2.0 * PI * uniform53(r);
    let (t1, t2) = tangent_basis(d);
    (d * c + (t1 * phi.cos() + t2 * phi.sin()) * s).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scattering_keeps_unit_length_and_hg_s_mean_cosine() {
        let mut r = Pcg32::new(1, 2);
        for k in 0..1000 {
            let n = DVec3::new(
                uniform53(&mut r) - 0.5,
                uniform53(&mut r) - 0.5,
                uniform53(&mut r) - 0.5 - (k % 2) as f64,
            )
            .normalize();
            assert!((scatter(n, 0.8, &mut r).length() - 1.0).abs() < 1e-12);
        }
        // Henyey-Greenstein's mean cosine is g.
        let d = DVec3::Z;
        let m: f64 = (0..200_000).map(|_| scatter(d, 0.6, &mut r).z).sum::<f64>() / 200_000.0;
        assert!((m - 0.6).abs() < 0.005, "{m}");
    }
}
