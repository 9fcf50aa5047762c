//! The physical medium both `ssmulti --model physical` and `sssingle
//! --model physical` read (`docs/DESIGN.md#physical-medium`): a
//! homogeneous medium under a smooth dielectric boundary, given per
//! channel by its single-scattering albedo and mean free path, or as
//! artists set it, by the surface colour a flat slab of it shows and its
//! diffuse mean free path.
//!
//! The multiple-scattering reflectance is photon beam diffusion's (Habel,
//! Christensen and Jarosz 2013): the light refracted in along the normal
//! is a beam of dipoles (Grosjean's diffusion coefficient, the
//! extrapolated boundary of d'Eon and Irving's Fresnel moments), each
//! dipole's exitance integrated over the surface in closed form but for
//! the beam's near-field correction, which is integrated numerically.
//! The single-scattering reflectance is the exact one-dimensional integral
//! over exit directions.

use std::f64::consts::PI;

use super::sssingle::optics::{fresnel, hg};
use crate::error::{Error, Result};

/// Which model a stage uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum Model {
    /// Marengo's (Houdini's): Rd and sd, the falloff kernels.
    #[default]
    Seed,
    /// A physical medium: single-scattering albedo and mean free path
    /// (or surface colour and diffuse mean free path), eta, g.
    Physical,
}

/// Depth samples of the beam (midpoints of the reduced extinction's
/// distribution).
const BEAM_SAMPLES: usize = 128;
/// Steps of the near-field correction's integral over a dipole's distance.
const NEAR_STEPS: usize = 64;

/// A channel's medium in units of its mean free path (`sigma_t = 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Unit {
    /// Single-scattering albedo.
    alpha: f64,
    eta: f64,
    g: f64,
}

/// d'Eon and Irving's (2011) fits of the first two moments of the Fresnel
/// reflectance seen from inside a medium of relative index `eta`.
fn fresnel_moments(eta: f64) -> (f64, f64) {
    let (e2, e3, e4, e5) = (eta * eta, eta.powi(3), eta.powi(4), eta.powi(5));
    if eta < 1.0 {
        (
            0.45966 - 1.73965 * eta + 3.37668 * e2 - 3.904945 * e3 + 2.49277 * e4 - 0.68441 * e5,
            0.27614 - 0.87350 * eta + 1.12077 * e2 - 0.65095 * e3 + 0.07883 * e4 + 0.04860 * e5,
        )
    } else {
        let r = 1.0 / eta;
        (
            -4.61686 + 11.1136 * eta - 10.4646 * e2 + 5.11455 * e3 - 1.27198 * e4 + 0.12746 * e5,
            -547.033 + 45.3087 * r * r * r - 218.725 * r * r + 458.843 * r + 404.557 * eta
                - 189.519 * e2
                + 54.9327 * e3
                - 9.00603 * e4
                + 0.63942 * e5,
        )
    }
}

/// The diffusion constants of a unit medium.
struct Diffusion {
    /// Reduced extinction and albedo.
    st_r: f64,
    alpha_r: f64,
    /// Grosjean's diffusion coefficient and the effective transport
    /// coefficient.
    d: f64,
    s_tr: f64,
    /// The extrapolated boundary's depth (negative: above the surface).
    ze: f64,
    /// Exitance weights of the fluence and the flux.
    c_phi: f64,
    c_e: f64,
}

impl Diffusion {
    fn of(m: Unit) -> Diffusion {
        let sa = 1.0 - m.alpha;
        let ss_r = m.alpha * (1.0 - m.g);
        let st_r = sa + ss_r;
        let d = (2.0 * sa + ss_r) / (3.0 * st_r * st_r);
        let (fm1, fm2) = fresnel_moments(m.eta);
        Diffusion {
            st_r,
            alpha_r: ss_r / st_r,
            d,
            s_tr: (sa / d).sqrt(),
            ze: -2.0 * d * (1.0 + 3.0 * fm2) / (1.0 - 2.0 * fm1),
            c_phi: 0.25 * (1.0 - 2.0 * fm1),
            c_e: 0.5 * (1.0 - 3.0 * fm2),
        }
    }

    /// The exitance at distance `r` on the surface from the dipole with
    /// its real source at depth `zr`: `c_phi phi + c_e E.n`.
    fn dipole(&self, zr: f64, r: f64) -> f64 {
        let zv = -zr + 2.0 * self.ze;
        let (dr, dv) = ((r * r + zr * zr).sqrt(), (r * r + zv * zv).sqrt());
        let (er, ev) = ((-self.s_tr * dr).exp(), (-self.s_tr * dv).exp());
        let phi = (er / dr - ev / dv) / (4.0 * PI * self.d);
        let e = (zr * (1.0 + self.s_tr * dr) * er / (dr * dr * dr)
            - zv * (1.0 + self.s_tr * dv) * ev / (dv * dv * dv))
            / (4.0 * PI);
        self.c_phi * phi + self.c_e * e
    }

    /// The dipole at depth `zr`, integrated over the surface: in closed
    /// form, `int 2 pi r (c_phi phi + c_e E.n) dr`.
    fn dipole_total(&self, zr: f64) -> f64 {
        let zv = (2.0 * self.ze - zr).abs();
        let phi = if self.s_tr > 0.0 {
            ((-self.s_tr * zr).exp() - (-self.s_tr * zv).exp()) / (2.0 * self.d * self.s_tr)
        } else {
            (zv - zr) / (2.0 * self.d)
        };
        let e = 0.5 * ((-self.s_tr * zr).exp() + (-self.s_tr * zv).exp());
        self.c_phi * phi + self.c_e * e
    }

    /// The beam's near-field correction at depth `zr`: the dipole weighted
    /// by `e^(-2 st_r (dr + zr))`, integrated over the surface (by the
    /// distance `dr` from the source, Simpson's rule over the span where
    /// the weight is above e^-40).
    fn near_total(&self, zr: f64) -> f64 {
        let f = |x: f64| {
            let dr = zr + x;
            let r = (dr * dr - zr * zr).max(0.0).sqrt();
            // 2 pi r dr = 2 pi d(dr) dr: the area element by distance.
            2.0 * PI * dr * (-2.0 * self.st_r * (dr + zr)).exp() * self.dipole(zr, r)
        };
        simpson(f, 0.0, 20.0 / self.st_r, NEAR_STEPS)
    }
}

/// Composite Simpson's rule for `f` on `[a, b]` in `n` (even) pieces.
fn simpson(f: impl Fn(f64) -> f64, a: f64, b: f64, n: usize) -> f64 {
    let h = (b - a) / n as f64;
    let mut s = f(a) + f(b);
    for k in 1..n {
        s += f(a + k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * h / 3.0
}

/// The multiple-scattering reflectance of a unit medium: photon beam
/// diffusion's exitance over the whole surface for unit power refracted
/// in along the normal.
fn ms_reflectance(m: Unit) -> f64 {
    if m.alpha <= 0.0 {
        return 0.0;
    }
    let k = Diffusion::of(m);
    let mut sum = 0.0;
    for i in 0..BEAM_SAMPLES {
        let u = (i as f64 + 0.5) / BEAM_SAMPLES as f64;
        let zr = -(-u).ln_1p() / k.st_r;
        sum += k.dipole_total(zr) - k.near_total(zr);
    }
    (k.alpha_r * k.alpha_r * sum / BEAM_SAMPLES as f64).max(0.0)
}

/// The single-scattering reflectance of a unit medium for unit power
/// refracted in along the normal: scattered once at depth `t` into a
/// direction of cosine `mu` with the surface, it leaves with
/// `e^(-t / mu)` and the Fresnel transmittance out, so
/// `alpha int_0^1 2 pi p(-mu) T(mu) mu / (1 + mu) dmu` (Simpson's rule up
/// to the critical cosine; below it the light is reflected back).
fn ss_reflectance(m: Unit) -> f64 {
    // Leaving: from inside at cosine mu, the Fresnel of a medium of index
    // 1 / eta seen from outside.
    let t_out = |mu: f64| 1.0 - fresnel(mu, 1.0 / m.eta);
    let lo = if m.eta > 1.0 {
        (1.0 - 1.0 / (m.eta * m.eta)).sqrt()
    } else {
        0.0
    };
    let f = |mu: f64| 2.0 * PI * hg(m.g, -mu) * t_out(mu) * mu / (1.0 + mu);
    m.alpha * simpson(f, lo, 1.0, 512)
}

/// The transmittance into the medium at normal incidence, the entry every
/// reflectance here is taken at.
fn t_in(eta: f64) -> f64 {
    1.0 - fresnel(1.0, eta)
}

/// The largest single-scattering albedo a surface colour inverts to.
const ALPHA_MAX: f64 = 0.999_999;

/// The physical medium of one run: per channel, what the stages read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Medium {
    /// Single-scattering albedo.
    pub albedo: [f64; 3],
    /// Mean free path `1 / sigma_t`.
    pub mfp: [f64; 3],
    /// Relative index of refraction (inside over outside).
    pub eta: f64,
    /// Henyey-Greenstein asymmetry.
    pub g: f64,
    /// The multiple-scattering reflectance (entry at normal incidence,
    /// exit into every direction): what ssM on a flat slab is, over its
    /// irradiance.
    pub rm: [f64; 3],
    /// The single-scattering reflectance, likewise.
    pub rs: [f64; 3],
    /// The diffusion's decay length `1 / sigma_tr` (the diffuse mean
    /// free path), in the scene's units; infinite without absorption.
    pub dmfp: [f64; 3],
}

impl Medium {
    /// The medium of single-scattering `albedo` and mean free path `mfp`
    /// per channel; parameters named in errors as the command line's.
    pub fn new(albedo: [f64; 3], mfp: [f64; 3], eta: f64, g: f64) -> Result<Medium> {
        check_common(eta, g)?;
        for (c, &a) in albedo.iter().enumerate() {
            if !(0.0..=1.0).contains(&a) {
                return Err(Error::param(
                    "albedo",
                    format!("channel {c} is {a:?}: not in [0, 1]"),
                ));
            }
        }
        for (c, &m) in mfp.iter().enumerate() {
            if !(m.is_finite() && m > 0.0) {
                return Err(Error::param(
                    "mfp",
                    format!("channel {c} is {m:?}: not a finite distance > 0"),
                ));
            }
        }
        let unit = |c: usize| Unit {
            alpha: albedo[c],
            eta,
            g,
        };
        let ti = t_in(eta);
        Ok(Medium {
            albedo,
            mfp,
            eta,
            g,
            rm: [0, 1, 2].map(|c| ti * ms_reflectance(unit(c))),
            rs: [0, 1, 2].map(|c| ti * ss_reflectance(unit(c))),
            dmfp: [0, 1, 2].map(|c| {
                let k = Diffusion::of(unit(c));
                if k.s_tr > 0.0 {
                    mfp[c] / k.s_tr
                } else {
                    f64::INFINITY
                }
            }),
        })
    }

    /// The medium whose flat slab shows surface colour `colour` (its
    /// whole diffuse reflectance, single scattering included), each
    /// channel's single-scattering albedo found by inverting
    /// [`surface_colour`]; `mfp` the mean free path, or with `diffuse`
    /// the diffuse mean free path `1 / sigma_tr`.
    pub fn from_colour(
        colour: [f64; 3],
        mfp: [f64; 3],
        diffuse: bool,
        eta: f64,
        g: f64,
    ) -> Result<Medium> {
        check_common(eta, g)?;
        let top = surface_colour(ALPHA_MAX, eta, g);
        let mut albedo = [0.0; 3];
        for c in 0..3 {
            let want = colour[c];
            if !(0.0..=top).contains(&want) {
                return Err(Error::param(
                    "color",
                    format!(
                        "channel {c} is {want:?}: not in [0, {top:.4}] (the whitest a medium of eta {eta} and g {g} shows)"
                    ),
                ));
            }
            albedo[c] = invert_colour(want, eta, g);
        }
        let name = if diffuse { "dmfp" } else { "mfp" };
        for (c, &m) in mfp.iter().enumerate() {
            if !(m.is_finite() && m > 0.0) {
                return Err(Error::param(
                    name,
                    format!("channel {c} is {m:?}: not a finite distance > 0"),
                ));
            }
        }
        let mfp = if diffuse {
            Medium::mfp_of_dmfp(albedo, mfp, eta, g)?
        } else {
            mfp
        };
        Medium::new(albedo, mfp, eta, g)
    }

    /// The mean free paths of single-scattering `albedo` with diffuse mean
    /// free paths `dmfp` (`dmfp sigma_tr`); a channel that absorbs
    /// nothing has no diffusion length, and is refused naming `albedo`.
    pub fn mfp_of_dmfp(albedo: [f64; 3], dmfp: [f64; 3], eta: f64, g: f64) -> Result<[f64; 3]> {
        let mut mfp = [0.0; 3];
        for c in 0..3 {
            let k = Diffusion::of(Unit {
                alpha: albedo[c].clamp(0.0, 1.0),
                eta,
                g,
            });
            if k.s_tr <= 0.0 || k.s_tr.is_nan() {
                return Err(Error::param(
                    "albedo",
                    format!(
                        "channel {c} is {:?}: a medium that absorbs nothing has no diffuse mean free path",
                        albedo[c]
                    ),
                ));
            }
            mfp[c] = dmfp[c] * k.s_tr;
        }
        Ok(mfp)
    }

    /// The whole diffuse reflectance of a flat slab, `rm + rs`.
    pub fn colour(&self) -> [f64; 3] {
        [0, 1, 2].map(|c| self.rm[c] + self.rs[c])
    }
}

fn check_common(eta: f64, g: f64) -> Result<()> {
    if !(eta.is_finite() && eta > 0.0 && eta <= 1e3) {
        return Err(Error::param("eta", format!("{eta:?} is not in (0, 1e3]")));
    }
    if !(g.is_finite() && (-1.0..=1.0).contains(&g)) {
        return Err(Error::param("g", format!("{g:?} is not in [-1, 1]")));
    }
    Ok(())
}

/// The surface colour of single-scattering albedo `alpha`: the whole
/// diffuse reflectance of a flat slab (multiple and single scattering,
/// entry at normal incidence).
pub fn surface_colour(alpha: f64, eta: f64, g: f64) -> f64 {
    let m = Unit { alpha, eta, g };
    t_in(eta) * (ms_reflectance(m) + ss_reflectance(m))
}

/// The single-scattering albedo whose surface colour is `want`: bisection
/// on `1 - alpha` in a logarithmic scale (the colour changes fastest as
/// alpha nears 1), then on alpha itself, to 1e-12.
fn invert_colour(want: f64, eta: f64, g: f64) -> f64 {
    if want <= 0.0 {
        return 0.0;
    }
    // The colour rises with alpha: bisect on alpha, with the midpoint
    // taken in log(1 - alpha) while the bracket spans decades.
    let (mut lo, mut hi) = (0.0f64, ALPHA_MAX);
    for _ in 0..200 {
        if hi - lo <= 1e-13 {
            break;
        }
        let (a, b) = (1.0 - lo, 1.0 - hi);
        let mid = if a / b > 4.0 {
            1.0 - (a * b).sqrt()
        } else {
            0.5 * (lo + hi)
        };
        if surface_colour(mid, eta, g) < want {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dipole's exitance integrated over the surface numerically
    /// equals the closed form.
    #[test]
    fn the_dipole_total_is_its_integral() {
        for alpha in [0.3, 0.9, 0.99] {
            let k = Diffusion::of(Unit {
                alpha,
                eta: 1.33,
                g: 0.0,
            });
            for zr in [0.05, 0.5, 3.0] {
                // By r = zr sinh(u): smooth and decaying.
                let n = 20_000;
                let umax = 30.0;
                let h = umax / n as f64;
                let f = |u: f64| {
                    let r = zr * f64::sinh(u);
                    2.0 * PI * r * k.dipole(zr, r) * zr * f64::cosh(u)
                };
                let mut s = f(0.0) + f(umax);
                for i in 1..n {
                    s += f(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
                }
                let num = s * h / 3.0;
                let closed = k.dipole_total(zr);
                assert!(
                    (num - closed).abs() <= 1e-6 * closed.abs().max(1e-3),
                    "alpha {alpha}, zr {zr}: {num} against {closed}"
                );
            }
        }
    }

    #[test]
    fn the_surface_colour_inverts_to_its_albedo() {
        for eta in [1.0, 1.33, 1.5] {
            for g in [0.0, 0.8] {
                for k in 0..=16 {
                    let want = 0.01 + (0.989 * k as f64 / 16.0);
                    let top = surface_colour(ALPHA_MAX, eta, g);
                    if want > top {
                        continue;
                    }
                    let alpha = invert_colour(want, eta, g);
                    let back = surface_colour(alpha, eta, g);
                    assert!(
                        (back - want).abs() <= 1e-4 * want,
                        "eta {eta} g {g}: {want} -> {alpha} -> {back}"
                    );
                }
            }
        }
    }

    #[test]
    fn reflectances_rise_with_albedo_and_stay_near_one() {
        // (Diffusion overshoots a white medium's 1 by under 1% at eta 1.)
        for eta in [1.0, 1.33] {
            let mut last = -1.0;
            for k in 0..=100 {
                let alpha = 1.0 - (1.0 - k as f64 / 100.0).powi(3);
                let c = surface_colour(alpha.min(ALPHA_MAX), eta, 0.0);
                assert!(c >= last && c < 1.01, "eta {eta} alpha {alpha}: {c}");
                last = c;
            }
        }
    }
}
