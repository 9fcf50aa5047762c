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
//! Light between surfaces ([`Walker::reentering`]): a walk that leaves
//! refracts out and flies on through the air; where that line meets the
//! mesh again it refracts back in (or reflects off it, by Fresnel's odds)
//! and walks on, as a path tracer follows it, so the light one part of
//! the object sends another is in the walk at every order. It ends where
//! the line meets nothing: the light there is the sky's.
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
use crate::optics::{fresnel, refract};

/// The most scattering events a walk is followed for; one still inside
/// then is cut ([`End::Cut`]: a bias of the share cut, which the report
/// counts). A walk in a medium that absorbs nothing, in an object a
/// hundred mean free paths across, takes about ten thousand.
pub const MAX_EVENTS: u32 = 1_000_000;

/// Below this throughput a walk goes on by Russian roulette.
const ROULETTE: f64 = 0.5;

/// The most reflections off the outside a walk's flight through the air
/// takes between two parts (each has Fresnel's odds, a few percent at
/// glancing angles and less head on): one still reflecting then is lost.
const MAX_REFLECTIONS: u32 = 64;

/// How a walk ended.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum End {
    /// It left through the mesh at `pos`, through a face of outward unit
    /// normal `normal`, after `events` scattering events, carrying
    /// `weight` per channel (the Fresnel transmittance in at its start,
    /// the channels' densities over the mixture's, the roulette's
    /// odds). A walk [`Walker::reentering`] leaves only towards the sky.
    /// `first_straight`: its first event was [`Event::straight`].
    Exit {
        pos: DVec3,
        normal: DVec3,
        events: u32,
        weight: [f64; 3],
        first_straight: bool,
    },
    /// Absorbed: the roulette ended it, or no channel carries anything.
    Absorbed,
    /// Still inside after [`MAX_EVENTS`].
    Cut,
    /// It left the mesh's box (through a hole of an open mesh).
    Lost,
}

/// A walk's scattering event, as [`Walker::walk_with`] shows it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Event {
    /// Where it scatters.
    pub pos: DVec3,
    /// The unit direction it arrived in.
    pub dir: DVec3,
    /// The throughput per channel, this event's albedo in.
    pub weight: [f64; 3],
    /// Its count: 1 for the walk's first event.
    pub events: u32,
    /// The walk's first event, reached along the start's refracted line
    /// with no reflection on the way (through every part that line
    /// crosses, [`Walker::reentering`]): single scattering along the
    /// view's path, which sssingle gives.
    pub straight: bool,
}

/// What walks through one mesh share (each walk takes its medium: a
/// per-point material's walk keeps its starting point's throughout, as
/// Cycles' random walk keeps its shading point's).
pub struct Walker<'a> {
    occ: &'a Occluder,
    /// Each triangle's outward unit normal (by the mesh's index).
    normals: Vec<DVec3>,
    /// How far inside the surface a walk starts, and a reflected one goes
    /// on: above the BVH's f32 rounding of the mesh (about 1e-7 of its
    /// size).
    inset: f64,
    /// The mesh's box, grown by a tenth: a walk beyond it is lost.
    lo: DVec3,
    hi: DVec3,
    /// Guided walks where the medium's albedo is high ([`Guide`]).
    guided: bool,
    /// Walks that leave fly on through the air and come back in where
    /// the line meets the mesh again.
    reenter: bool,
}

impl<'a> Walker<'a> {
    /// Walks through `mesh` (whose BVH is `occ`).
    pub fn new(mesh: &TriMesh, occ: &'a Occluder) -> Walker<'a> {
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
            inset: 1e-6 * size,
            lo: lo - grow,
            hi: hi + grow,
            guided: true,
            reenter: false,
        }
    }

    /// Walks that follow the light between surfaces: one that leaves
    /// flies on through the air, and comes back in where it meets the
    /// mesh again (see the module's doc). A walk then ends only towards
    /// the sky.
    pub fn reentering(mut self) -> Walker<'a> {
        self.reenter = true;
        self
    }

    /// Whether walks follow the light between surfaces.
    pub fn reenters(&self) -> bool {
        self.reenter
    }

    /// Walks drawn by the classic scheme alone (free flights at the
    /// extinction, directions by the phase function), without guiding:
    /// the same mean, more noise where the albedo is high.
    pub fn classic(mut self) -> Walker<'a> {
        self.guided = false;
        self
    }

    /// `medium` as this walker's walks take it: its extinctions and
    /// guide, worked out once for all the walks in it.
    pub fn medium(&self, medium: &Medium) -> WalkMedium {
        WalkMedium {
            sigma_t: medium.mfp.map(|m| 1.0 / m),
            albedo: medium.albedo,
            g: medium.g,
            eta: medium.eta,
            guide: if self.guided {
                Guide::new(medium)
            } else {
                None
            },
        }
    }

    /// One walk in `medium` (from [`Walker::medium`]) from the surface
    /// point `p` of outward unit normal `n`, with the random stream `r`.
    pub fn walk(&self, medium: &WalkMedium, p: DVec3, n: DVec3, r: &mut Pcg32) -> End {
        self.walk_with(medium, p, n, None, r, |_, _| {})
    }

    /// The BVH the walks go through.
    pub fn occluder(&self) -> &'a Occluder {
        self.occ
    }

    /// Triangle `t`'s outward unit normal.
    pub fn normal(&self, t: usize) -> DVec3 {
        self.normals[t]
    }

    /// [`Walker::walk`] (from the outside direction `towards`, a unit
    /// vector, when given, rather than one drawn cosine-weighted: the
    /// walks then estimate the radiance towards it, not the exitance; a
    /// point facing away from it ends at once), calling `at_event` at
    /// each scattering event with
    /// where the walk is, the direction it arrived in, its throughput
    /// there (the event's albedo in) and its event count: where a caller
    /// samples the lights (next-event estimation). The callback may draw
    /// from the walk's stream; one that draws nothing leaves the walk as
    /// [`Walker::walk`] takes it, bit for bit.
    pub fn walk_with(
        &self,
        medium: &WalkMedium,
        p: DVec3,
        n: DVec3,
        towards: Option<DVec3>,
        r: &mut Pcg32,
        mut at_event: impl FnMut(&Event, &mut Pcg32),
    ) -> End {
        let WalkMedium {
            sigma_t,
            albedo,
            g,
            eta,
            ref guide,
        } = *medium;
        // The surface the guide heads for: the start's, then where the
        // walk last came back in.
        let (mut p, mut n) = (p, n);
        // The outside direction, cosine-weighted about n, and the light
        // refracted in along it (Fresnel's share reflected is not
        // subsurface light).
        let (mut t1, mut t2) = tangent_basis(n);
        let (out, mu_o) = match towards {
            Some(v) => {
                let mu = v.dot(n);
                if mu <= 0.0 {
                    return End::Absorbed;
                }
                (v, mu)
            }
            None => {
                let (mu_o, phi) = (uniform53(r).sqrt(), 2.0 * PI * uniform53(r));
                let s_o = (1.0 - mu_o * mu_o).max(0.0).sqrt();
                (n * mu_o + (t1 * phi.cos() + t2 * phi.sin()) * s_o, mu_o)
            }
        };
        let t_in = 1.0 - fresnel(mu_o, eta);
        let mu_in = super::walk::refracted(mu_o, eta);
        let mut d = (-(out - n * mu_o) / eta - n * mu_in).normalize();
        let mut x = p - n * self.inset;
        let mut w = [t_in; 3];
        let mut events = 0u32;
        // The depth below the start's tangent plane of a face the first
        // flight's line meets (the far side of a thin part), which the
        // guided flights then also head for.
        let mut opposite: Option<f64> = None;
        // The last vertex scattered (its direction was drawn, guided or
        // not); false at the start and after a reflection.
        let mut scattered = false;
        let mut first = true;
        // A reflection (inside, or off the outside) came before: the
        // walk has left the start's refracted line.
        let (mut reflected, mut first_straight) = (false, false);
        loop {
            let total = w[0] + w[1] + w[2];
            if total.is_nan() || total <= 0.0 {
                return End::Absorbed;
            }
            // A channel by its throughput.
            let u = uniform53(r) * total;
            let h = if u < w[0] {
                0
            } else if u < w[0] + w[1] {
                1
            } else {
                2
            };
            let pick = w.map(|x| x / total);
            // After a scattering event: the direction by the phase
            // function, or guided (Dwivedi) towards the start's surface
            // or the far side, with the flight stretched along it.
            let mut lobes: Option<Lobes> = None;
            let mut sigma_h = sigma_t[h];
            if let (true, Some(gd)) = (scattered, &guide) {
                let back = opposite.map_or(0.0, |o| gd.back_share(o, (p - x).dot(n)));
                let guided = uniform53(r) < gd.fraction;
                let backward = uniform53(r) < back;
                if guided {
                    let mut mu = gd.sample(uniform53(r));
                    if backward {
                        mu = -mu;
                    }
                    let phi = 2.0 * PI * uniform53(r);
                    let s = (1.0 - mu * mu).max(0.0).sqrt();
                    let nd = (n * mu + (t1 * phi.cos() + t2 * phi.sin()) * s).normalize();
                    let hg = hg_pdf(g, d.dot(nd));
                    d = nd;
                    let l = gd.lobes(d.dot(n), hg, back);
                    sigma_h *= if backward {
                        l.back_stretch
                    } else {
                        l.fwd_stretch
                    };
                    lobes = Some(l);
                } else {
                    let nd = scatter(d, g, r);
                    let hg = hg_pdf(g, d.dot(nd));
                    d = nd;
                    lobes = Some(gd.lobes(d.dot(n), hg, back));
                }
            }
            let t = -(1.0 - uniform53(r)).ln() / sigma_h;
            // The first flight looks further, for the far side.
            let reach = match (&guide, first) {
                (Some(gd), true) => t.max(gd.probe),
                _ => t,
            };
            first = false;
            let hit = self.occ.nearest(x, d, 0.0, reach, Facing::Leaving);
            if reach > t {
                if let Some((_, s)) = hit {
                    opposite = Some((p - (x + d * s)).dot(n)).filter(|&o| o > 0.0);
                }
            }
            let hit = hit.filter(|&(_, s)| s < t);
            // Each channel's density of this flight under the mixture of
            // the ways it could have been drawn, the walk's value per
            // channel, and their one-sample balance.
            let flight = |st: f64, at: f64, through: bool| {
                if through {
                    (-st * at).exp()
                } else {
                    st * (-st * at).exp()
                }
            };
            let (at, through) = match hit {
                Some((_, s)) => (s, true),
                None => (t, false),
            };
            let dens = |c: usize| {
                let classic = flight(sigma_t[c], at, through);
                match (&lobes, &guide) {
                    (Some(l), Some(gd)) => {
                        let fwd = l.fwd * flight(sigma_t[c] * l.fwd_stretch, at, through);
                        let back = l.back * flight(sigma_t[c] * l.back_stretch, at, through);
                        (1.0 - gd.fraction) * classic + gd.fraction * (fwd + back)
                    }
                    _ => classic,
                }
            };
            let pdf: f64 = (0..3).map(|c| pick[c] * dens(c)).sum();
            match hit {
                Some((tri, s)) => {
                    w = [0, 1, 2].map(|c| w[c] * (-sigma_t[c] * s).exp() / pdf);
                    let nb = self.normals[tri];
                    let pos = x + d * s;
                    let mu = d.dot(nb).clamp(0.0, 1.0);
                    if uniform53(r) >= fresnel(mu, 1.0 / eta) {
                        let exit = End::Exit {
                            pos,
                            normal: nb,
                            events,
                            weight: w,
                            first_straight,
                        };
                        if !self.reenter {
                            return exit;
                        }
                        // Out into the air, and on to where the line
                        // meets the mesh again.
                        let out = refract(d, -nb, eta).unwrap_or(d);
                        match self.through_air(pos + nb * self.inset, out, eta, r) {
                            Air::Sky => return exit,
                            Air::Lost => return End::Lost,
                            Air::Back {
                                pos: q,
                                normal: nq,
                                dir,
                                reflected: off,
                            } => {
                                reflected |= off;
                                d = dir;
                                x = q - nq * self.inset;
                                (p, n) = (q, nq);
                                (t1, t2) = tangent_basis(nq);
                                opposite = None;
                                first = true;
                                scattered = false;
                                continue;
                            }
                        }
                    }
                    d = (d - nb * (2.0 * d.dot(nb))).normalize();
                    x = pos - nb * self.inset;
                    scattered = false;
                    reflected = true;
                }
                None => {
                    w = [0, 1, 2]
                        .map(|c| w[c] * albedo[c] * sigma_t[c] * (-sigma_t[c] * t).exp() / pdf);
                    x += d * t;
                    if !(x.cmpge(self.lo).all() && x.cmple(self.hi).all()) {
                        return End::Lost;
                    }
                    events += 1;
                    if events >= MAX_EVENTS {
                        return End::Cut;
                    }
                    if events == 1 {
                        first_straight = !reflected;
                    }
                    at_event(
                        &Event {
                            pos: x,
                            dir: d,
                            weight: w,
                            events,
                            straight: events == 1 && !reflected,
                        },
                        r,
                    );
                    if guide.is_none() {
                        d = scatter(d, g, r);
                    }
                    scattered = true;
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

impl Walker<'_> {
    /// A flight through the air from `from` along `dir` (just left the
    /// medium of index `eta`): where it meets the mesh from outside, the
    /// light refracts in (or reflects off, by Fresnel's odds, and flies
    /// on); where it meets nothing, the sky.
    fn through_air(&self, from: DVec3, dir: DVec3, eta: f64, r: &mut Pcg32) -> Air {
        let (mut o, mut d) = (from, dir);
        for k in 0..MAX_REFLECTIONS {
            let Some((tri, s)) = self.occ.nearest(o, d, 0.0, f64::INFINITY, Facing::Entering)
            else {
                return Air::Sky;
            };
            let nb = self.normals[tri];
            let q = o + d * s;
            let mu = (-d.dot(nb)).clamp(0.0, 1.0);
            if uniform53(r) >= fresnel(mu, eta) {
                let dir = refract(d, nb, 1.0 / eta).unwrap_or(d);
                return Air::Back {
                    pos: q,
                    normal: nb,
                    dir,
                    reflected: k > 0,
                };
            }
            d = (d - nb * (2.0 * d.dot(nb))).normalize();
            o = q + nb * self.inset;
        }
        Air::Lost
    }
}

/// Where a flight through the air ends ([`Walker::through_air`]).
enum Air {
    /// It meets nothing.
    Sky,
    /// It came back in at `pos`, through a face of outward unit normal
    /// `normal`, refracted to `dir`; `reflected` off the outside on the
    /// way.
    Back {
        pos: DVec3,
        normal: DVec3,
        dir: DVec3,
        reflected: bool,
    },
    /// Still reflecting after [`MAX_REFLECTIONS`].
    Lost,
}

/// A medium as a walk takes it ([`Walker::medium`]).
pub struct WalkMedium {
    sigma_t: [f64; 3],
    albedo: [f64; 3],
    g: f64,
    eta: f64,
    guide: Option<Guide>,
}

/// Guided walks (Dwivedi's sampling, Krivanek and d'Eon 2014, with Meng,
/// Hanika and Dachsbacher's direction density, as Cycles' "random walk
/// guided" draws them): in a half-space the light that leaves decays
/// with depth as `e^(-sigma_t z / nu)`, `nu` Dwivedi's diffusion length,
/// so a share of the flights after each event head for the start's
/// surface (their cosine with its normal drawn by `1 / (nu - mu)`) and
/// fly stretched along it (at `sigma_t (1 - mu / nu)`). Where the first
/// flight found a face beyond the start (a thin part), a share of those
/// head for it instead, mirrored. Every flight is weighed by its density
/// under the mixture of all the ways it could have been drawn (the
/// balance heuristic), so the mean is the classic walk's.
struct Guide {
    nu: f64,
    /// `ln((nu + 1) / (nu - 1))`.
    phase_log: f64,
    /// The share of flights guided.
    fraction: f64,
    /// The extinction the far side's share measures depths by.
    sigma: f64,
    /// How far the first flight looks for the far side.
    probe: f64,
}

/// A guided flight's direction densities (over the phase function's) and
/// stretches, forward (to the start's surface) and backward (to the far
/// side), each times its share.
struct Lobes {
    fwd: f64,
    back: f64,
    fwd_stretch: f64,
    back_stretch: f64,
}

impl Guide {
    /// The guide of `m`, or none where its albedo is too low to gain
    /// (walks are short there).
    fn new(m: &Medium) -> Option<Guide> {
        let (k, &top) = m
            .albedo
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))?;
        if top < GUIDE_ALBEDO {
            return None;
        }
        // Dwivedi's diffusion length (d'Eon and Krivanek 2020, eq. 67;
        // the highest albedo's: a length too short overshoots).
        let a = top.min(1.0 - 1e-9);
        let nu = 1.0 / (1.0 - a.powf(2.44294 - 0.0215813 * a + 0.578637 / a)).sqrt();
        if !(nu.is_finite() && nu > 1.0 + 1e-9) {
            return None;
        }
        let min_sigma = m.mfp.iter().fold(f64::INFINITY, |s, &l| s.min(1.0 / l));
        Some(Guide {
            nu,
            phase_log: ((nu + 1.0) / (nu - 1.0)).ln(),
            fraction: 1.0 - 0.5f64.max(m.g.abs().powf(0.125)),
            sigma: 1.0 / m.mfp[k],
            probe: 10.0 / min_sigma,
        })
    }

    /// A cosine with the start's normal, by `1 / (nu - mu)`.
    fn sample(&self, u: f64) -> f64 {
        (self.nu - (self.nu + 1.0) * (-u * self.phase_log).exp()).clamp(-1.0, 1.0)
    }

    /// The density over the sphere of a guided direction at cosine `mu`.
    fn density(&self, mu: f64) -> f64 {
        1.0 / (2.0 * PI * (self.nu - mu) * self.phase_log)
    }

    /// The share of guided flights that head for the far side
    /// `opposite` below the start's plane, at `depth` below it: a half
    /// midway, more the nearer the far side.
    fn back_share(&self, opposite: f64, depth: f64) -> f64 {
        let z = depth.clamp(0.0, opposite.max(0.0));
        1.0 / (1.0 + ((opposite - 2.0 * z) * self.sigma / self.nu).exp())
    }

    /// The lobes of a flight of cosine `mu` with the start's normal,
    /// whose phase-function density is `hg`, `back` the far side's share.
    fn lobes(&self, mu: f64, hg: f64, back: f64) -> Lobes {
        Lobes {
            fwd: (1.0 - back) * self.density(mu) / hg,
            back: back * self.density(-mu) / hg,
            fwd_stretch: 1.0 - mu / self.nu,
            back_stretch: 1.0 + mu / self.nu,
        }
    }
}

/// Below this highest albedo a walk is not guided: it ends in a few
/// events anyway.
const GUIDE_ALBEDO: f64 = 0.5;

/// Henyey-Greenstein's density over the sphere at cosine `c` (isotropic
/// where [`sample_hg`] draws so).
fn hg_pdf(g: f64, c: f64) -> f64 {
    if g.abs() < 1e-3 {
        return 1.0 / (4.0 * PI);
    }
    let den = 1.0 + g * g - 2.0 * g * c;
    (1.0 - g * g) / (4.0 * PI * den * den.sqrt())
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
