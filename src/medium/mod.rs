//! The physical medium both `ssmulti --model physical` and `sssingle
//! --model physical` read (`docs/DESIGN.md#physical-medium`): a
//! homogeneous medium under a smooth dielectric boundary, given per
//! channel by its single-scattering albedo and mean free path, or as
//! artists set it, by the surface colour a flat slab of it shows and its
//! diffuse mean free path.
//!
//! The reflectances are those of a semi-infinite slab lit at a cosine of
//! arrival: the multiple-scattering one from a table of random walks
//! ([`walk`], written by `examples/medium_table.rs`) over the phase
//! function's asymmetry, the relative index and the cosine, which gives
//! every albedo at once; the single-scattering one the exact integral over
//! exit directions. Thin parts (a slab's both faces) are in `thickness.rs`;
//! material files and presets in [`material`], and what a stage was
//! given of the medium decided in [`spec`]. The diffuse mean free path
//! is diffusion's (Grosjean's coefficient).

use std::f64::consts::PI;

use crate::error::{Error, Result};
use crate::optics::{fresnel, hg};
use walk::Histogram;

pub mod material;
pub mod mesh_walk;
pub mod slab_table;
pub mod spec;
pub mod table;
mod thickness;
pub mod walk;

pub use spec::{Choice, Given, Spec};
pub use thickness::Thinness;

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

/// A channel's medium in units of its mean free path (`sigma_t = 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Unit {
    /// Single-scattering albedo.
    alpha: f64,
    eta: f64,
    g: f64,
}

/// The effective transport coefficient `sigma_tr = sqrt(sigma_a / D)` of
/// a unit medium, Grosjean's diffusion coefficient `D = (2 sigma_a +
/// sigma_s') / (3 sigma_t'^2)` (the diffuse mean free path's inverse).
fn sigma_tr(m: Unit) -> f64 {
    let sa = 1.0 - m.alpha;
    let ss_r = m.alpha * (1.0 - m.g);
    let st_r = sa + ss_r;
    let d = (2.0 * sa + ss_r) / (3.0 * st_r * st_r);
    (sa / d).sqrt()
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

/// Where `x` falls among `nodes` (ascending or descending): the node
/// below it and the fraction of the way to the next.
fn bracket(nodes: &[f64], x: f64) -> (usize, f64) {
    let up = nodes[1] > nodes[0];
    let i = nodes
        .partition_point(|&v| if up { v <= x } else { v >= x })
        .clamp(1, nodes.len() - 1)
        - 1;
    let t = ((x - nodes[i]) / (nodes[i + 1] - nodes[i])).clamp(0.0, 1.0);
    (i, t)
}

/// The walk's histogram at `(eta, g)` for light arriving at cosine `mu_i`
/// with the normal: the table's nodes around it blended (the shares are
/// linear in a mixture of paths), its single-scattering share the exact
/// one.
fn histogram(eta: f64, g: f64, mu_i: f64) -> Histogram {
    let (i, tg) = bracket(&table::G, g);
    let (j, te) = bracket(&table::ETA, eta);
    // In the cosine's square root: the reflectance rises steeply as the
    // light nears grazing (like `mu ln mu` at eta 1), which a blend linear
    // in the cosine follows less well.
    let roots = table::MU.map(f64::sqrt);
    let (k, tm) = bracket(&roots, mu_i.clamp(0.0, 1.0).sqrt());
    let nm = table::MU.len();
    let mut v = vec![0.0f64; table::SHARES[0][0].len()];
    for (di, wg) in [(0, 1.0 - tg), (1, tg)] {
        for (dj, we) in [(0, 1.0 - te), (1, te)] {
            for (dk, wm) in [(0, 1.0 - tm), (1, tm)] {
                let w = wg * we * wm;
                if w > 0.0 {
                    let row = &table::SHARES[i + di][(j + dj) * nm + k + dk];
                    v.iter_mut().zip(row).for_each(|(a, &b)| *a += w * b as f64);
                }
            }
        }
    }
    // The single-scattering share is known exactly: it replaces the
    // blend's, and the rest is scaled to the remainder, so that the walk's
    // noise and the blend's error in it do not reach the total (a white
    // medium returns all the light that enters).
    let p1 = ss_reflectance(Unit { alpha: 1.0, eta, g }, walk::refracted(mu_i, eta));
    let rest: f64 = v[1..].iter().sum();
    let k = if rest > 0.0 { (1.0 - p1) / rest } else { 0.0 };
    v[0] = p1;
    v[1..].iter_mut().for_each(|x| *x *= k);
    let survivors = v.pop().unwrap_or(0.0);
    Histogram { bins: v, survivors }
}

/// A table row as a histogram (its last column the survivors', when it
/// has one).
fn split(mut v: Vec<f64>, survivors: bool) -> Histogram {
    let survivors = if survivors {
        v.pop().unwrap_or(0.0)
    } else {
        0.0
    };
    Histogram { bins: v, survivors }
}

/// The single-scattering reflectance of a unit medium for unit power
/// refracted in at cosine `mu_t` with the inward normal: scattered once
/// at depth `z` (reached with `e^(-z / mu_t) / mu_t`) into a direction of
/// cosine `mu` with the surface and azimuth `phi`, it leaves with
/// `e^(-z / mu)` and the Fresnel transmittance out, so
/// `alpha int_0^1 int_0^2pi p(cos theta) T(mu) mu / (mu + mu_t) dphi dmu`,
/// `cos theta = sqrt(1 - mu_t^2) sqrt(1 - mu^2) cos phi - mu_t mu`
/// (Simpson's rule up to the critical cosine, below which the light is
/// reflected back; along the normal the azimuth drops out).
fn ss_reflectance(m: Unit, mu_t: f64) -> f64 {
    // Leaving: from inside at cosine mu, the Fresnel of a medium of index
    // 1 / eta seen from outside.
    let t_out = |mu: f64| 1.0 - fresnel(mu, 1.0 / m.eta);
    let lo = if m.eta > 1.0 {
        (1.0 - 1.0 / (m.eta * m.eta)).sqrt()
    } else {
        0.0
    };
    let mu_t = mu_t.clamp(0.0, 1.0);
    let st = (1.0 - mu_t * mu_t).sqrt();
    let f = |mu: f64| {
        let s = (1.0 - mu * mu).max(0.0).sqrt();
        let ring = if st * s == 0.0 {
            2.0 * PI * hg(m.g, -mu_t * mu)
        } else {
            // (Symmetric in phi: twice the half turn.)
            2.0 * simpson(|phi| hg(m.g, st * s * phi.cos() - mu_t * mu), 0.0, PI, 128)
        };
        // (Grazing both ways at eta 1, the depth factor's limit is 1.)
        let depth = if mu + mu_t > 0.0 {
            mu / (mu + mu_t)
        } else {
            1.0
        };
        ring * t_out(mu) * depth
    };
    m.alpha * simpson(f, lo, 1.0, 512)
}

/// The transmittance into the medium of light arriving at cosine `mu_i`.
fn t_in(eta: f64, mu_i: f64) -> f64 {
    1.0 - fresnel(mu_i, eta)
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

/// How a medium is given: a single-scattering albedo or the surface
/// colour it shows (`colour`), a mean free path or the diffuse one
/// (`diffuse`), the index and the asymmetry. Per-point materials build one
/// a group of points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Recipe {
    pub albedo: [f64; 3],
    pub colour: bool,
    pub dist: [f64; 3],
    pub diffuse: bool,
    pub eta: f64,
    pub g: f64,
}

impl Recipe {
    /// The medium it gives; errors name the parameter as the options do.
    pub fn medium(&self) -> Result<Medium> {
        if self.colour {
            return Medium::from_colour(self.albedo, self.dist, self.diffuse, self.eta, self.g);
        }
        let mfp = if self.diffuse {
            Medium::mfp_of_dmfp(self.albedo, self.dist, self.eta, self.g)?
        } else {
            self.dist
        };
        Medium::new(self.albedo, mfp, self.eta, self.g)
    }
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
        let ti = t_in(eta, 1.0);
        let h = histogram(eta, g, 1.0);
        Ok(Medium {
            albedo,
            mfp,
            eta,
            g,
            rm: [0, 1, 2].map(|c| ti * h.reflectance(albedo[c], 2)),
            rs: [0, 1, 2].map(|c| ti * ss_reflectance(unit(c), 1.0)),
            dmfp: [0, 1, 2].map(|c| {
                let s = sigma_tr(unit(c));
                if s > 0.0 {
                    mfp[c] / s
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
        let h = histogram(eta, g, 1.0);
        let top = colour_of(&h, ALPHA_MAX, eta, g);
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
            albedo[c] = invert_colour(&h, want, eta, g);
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
            let s = sigma_tr(Unit {
                alpha: albedo[c].clamp(0.0, 1.0),
                eta,
                g,
            });
            if s <= 0.0 || s.is_nan() {
                return Err(Error::param(
                    "albedo",
                    format!(
                        "channel {c} is {:?}: a medium that absorbs nothing has no diffuse mean free path",
                        albedo[c]
                    ),
                ));
            }
            mfp[c] = dmfp[c] * s;
        }
        Ok(mfp)
    }

    /// The whole diffuse reflectance of a flat slab, `rm + rs`.
    pub fn colour(&self) -> [f64; 3] {
        [0, 1, 2].map(|c| self.rm[c] + self.rs[c])
    }

    /// The multiple-scattering reflectance per channel for light arriving
    /// at cosine `mu_i` with the normal (`rm` at 1): oblique light enters
    /// shallower and more of it comes back out, but less of it enters
    /// under a dielectric.
    pub fn rm_at(&self, mu_i: f64) -> [f64; 3] {
        let h = histogram(self.eta, self.g, mu_i);
        let ti = t_in(self.eta, mu_i);
        self.albedo.map(|a| ti * h.reflectance(a, 2))
    }

    /// The single-scattering reflectance per channel under light that
    /// arrives evenly from the whole sky (cosine-weighted:
    /// `int_0^1 rs(mu_i) 2 mu_i dmu_i`, Simpson's rule in `sqrt(mu_i)`,
    /// where `rs` changes fastest): what single scattering returns of the
    /// light between surfaces (`docs/DESIGN.md#light-between-surfaces`).
    pub fn rs_diffuse(&self) -> [f64; 3] {
        // mu = s^2: 2 mu dmu = 4 s^3 ds.
        [0, 1, 2].map(|c| {
            simpson(
                |s| 4.0 * s * s * s * self.rs_channel(c, s * s),
                0.0,
                1.0,
                32,
            )
        })
    }

    /// The multiple-scattering reflectance per channel under light that
    /// arrives evenly from the whole sky (cosine-weighted:
    /// `int_0^1 rm(mu_i) 2 mu_i dmu_i`, Simpson's rule in `sqrt(mu_i)` over
    /// [`Medium::incidence`]'s nodes): what a walk that enters evenly
    /// (ssmulti's walk method, by reciprocity) returns of a flat
    /// slab.
    pub fn rm_diffuse(&self) -> [f64; 3] {
        let inc = self.incidence();
        [0, 1, 2].map(|c| {
            let rm = |mu: f64| inc.factor(mu)[c] * self.rm[c];
            simpson(|s| 4.0 * s * s * s * rm(s * s), 0.0, 1.0, 32)
        })
    }

    /// The multiple-scattering reflectance of light spread over the
    /// hemisphere (a constant dome's: `R_md`, [`Medium::rm_diffuse`]) over
    /// the one along the normal, per channel: the incidence factor of
    /// such light, which one mean cosine cannot give (`rm` is not linear
    /// in it: at eta 1.3 `rm(2/3)` is 3.6-8% above `R_md`).
    pub fn diffuse_incidence(&self) -> [f64; 3] {
        let d = self.rm_diffuse();
        [0, 1, 2].map(|c| {
            if self.rm[c] > 0.0 {
                d[c] / self.rm[c]
            } else {
                1.0
            }
        })
    }

    /// [`Medium::rs_at`] of channel `c` alone.
    fn rs_channel(&self, c: usize, mu_i: f64) -> f64 {
        let mu = mu_i.clamp(0.0, 1.0);
        let m = Unit {
            alpha: self.albedo[c],
            eta: self.eta,
            g: self.g,
        };
        t_in(self.eta, mu) * ss_reflectance(m, walk::refracted(mu, self.eta))
    }

    /// The single-scattering reflectance per channel for light arriving
    /// at cosine `mu_i` with the normal (`rs` at 1): the exact quadrature,
    /// with the Fresnel transmittance in.
    pub fn rs_at(&self, mu_i: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| self.rs_channel(c, mu_i))
    }

    /// [`Medium::rs_at`] itself (not a ratio), tabulated for
    /// [`Incidence::factor`].
    pub fn single_by_cosine(&self) -> Incidence {
        let values = (0..INCIDENCE_NODES)
            .map(|k| self.rs_at((k as f64 / (INCIDENCE_NODES - 1) as f64).powi(2)))
            .collect();
        Incidence { values }
    }

    /// [`Medium::rm_at`] over `rm`, tabulated for [`Incidence::factor`].
    pub fn incidence(&self) -> Incidence {
        let values = (0..INCIDENCE_NODES)
            .map(|k| {
                let r = self.rm_at((k as f64 / (INCIDENCE_NODES - 1) as f64).powi(2));
                [0, 1, 2].map(|c| {
                    if self.rm[c] > 0.0 {
                        r[c] / self.rm[c]
                    } else {
                        1.0
                    }
                })
            })
            .collect();
        Incidence { values }
    }
}

/// Cosines at which [`Incidence`] holds its values, evenly spaced in the
/// cosine's square root on `[0, 1]` (the ratio is smooth in the cosine
/// but near grazing, where it rises like `mu ln mu` at eta 1 and
/// Fresnel's transmittance falls under a dielectric: there the nodes
/// are dense).
const INCIDENCE_NODES: usize = 33;

/// A per-channel quantity by the cosine of the light's arrival: the
/// multiple-scattering reflectance over the one along the normal
/// ([`Medium::incidence`]), or the single-scattering reflectance
/// ([`Medium::single_by_cosine`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Incidence {
    values: Vec<[f64; 3]>,
}

impl Incidence {
    /// The value per channel at cosine `mu` (clamped to `[0, 1]`),
    /// linearly in its square root between the nodes.
    pub fn factor(&self, mu: f64) -> [f64; 3] {
        let x = mu.clamp(0.0, 1.0).sqrt() * (INCIDENCE_NODES - 1) as f64;
        let i = (x.floor() as usize).min(INCIDENCE_NODES - 2);
        let t = x - i as f64;
        let (a, b) = (self.values[i], self.values[i + 1]);
        [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]))
    }
}

/// The relative indices and asymmetries the reflectance table covers.
pub const ETA_RANGE: (f64, f64) = (table::ETA[0], table::ETA[table::ETA.len() - 1]);
pub const G_RANGE: (f64, f64) = (table::G[0], table::G[table::G.len() - 1]);

fn check_common(eta: f64, g: f64) -> Result<()> {
    let (e0, e1) = ETA_RANGE;
    if !(eta.is_finite() && (e0..=e1).contains(&eta)) {
        return Err(Error::param(
            "eta",
            format!("{eta:?} is not in [{e0}, {e1}] (the physical model's reflectance table)"),
        ));
    }
    let (g0, g1) = G_RANGE;
    if !(g.is_finite() && (g0..=g1).contains(&g)) {
        return Err(Error::param(
            "g",
            format!("{g:?} is not in [{g0}, {g1}] (the physical model's reflectance table)"),
        ));
    }
    Ok(())
}

/// The surface colour of single-scattering albedo `alpha`: the whole
/// diffuse reflectance of a flat slab (multiple and single scattering,
/// entry at normal incidence).
pub fn surface_colour(alpha: f64, eta: f64, g: f64) -> f64 {
    colour_of(&histogram(eta, g, 1.0), alpha, eta, g)
}

/// [`surface_colour`] with the walk's histogram at `(eta, g)` given.
fn colour_of(h: &Histogram, alpha: f64, eta: f64, g: f64) -> f64 {
    let m = Unit { alpha, eta, g };
    t_in(eta, 1.0) * (h.reflectance(alpha, 2) + ss_reflectance(m, 1.0))
}

/// The single-scattering albedo whose surface colour is `want`: bisection
/// on alpha (the colour rises with it: every term of the walk's sum
/// does), the midpoint taken in `log(1 - alpha)` while the bracket spans
/// decades (the colour changes fastest as alpha nears 1), to 1e-13.
fn invert_colour(h: &Histogram, want: f64, eta: f64, g: f64) -> f64 {
    if want <= 0.0 {
        return 0.0;
    }
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
        if colour_of(h, mid, eta, g) < want {
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
                    let alpha = invert_colour(&histogram(eta, g, 1.0), want, eta, g);
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
    fn reflectances_rise_with_albedo_to_all_that_enters() {
        for eta in [1.0, 1.33, 2.2] {
            for g in [-0.5, 0.0, 0.9] {
                let mut last = -1.0;
                // (Up to ALPHA_MAX = 1 - 0.01^3.)
                for k in 0..100 {
                    let alpha = 1.0 - (1.0 - k as f64 / 99.0 * 0.99).powi(3);
                    let c = surface_colour(alpha, eta, g);
                    assert!(c > last, "eta {eta} g {g} alpha {alpha}: {c} after {last}");
                    last = c;
                }
                // A white medium returns all the light that enters (the
                // walk's survivors too, by their tail).
                // At any cosine of arrival.
                for mu in [1.0, 0.6, 0.1] {
                    let white = histogram(eta, g, mu).reflectance(1.0, 2)
                        + ss_reflectance(Unit { alpha: 1.0, eta, g }, walk::refracted(mu, eta));
                    assert!(
                        (white - 1.0).abs() < 1e-9,
                        "eta {eta} g {g} mu {mu}: {white}"
                    );
                }
            }
        }
    }

    /// Single scattering under light from the whole sky: at eta 1 and g 0
    /// the cosine-weighted mean of `alpha / 2 (1 - mu ln((1 + mu) / mu))`
    /// is `2 alpha / 3 (1 - ln 2)`; under a dielectric less enters, and
    /// forward scattering returns less.
    #[test]
    fn single_scattering_of_light_from_every_side_has_its_closed_form() {
        let alpha = [0.3, 0.8, 1.0];
        let m = Medium::new(alpha, [1.0; 3], 1.0, 0.0).unwrap();
        let got = m.rs_diffuse();
        for c in 0..3 {
            let want = 2.0 * alpha[c] / 3.0 * (1.0 - std::f64::consts::LN_2);
            assert!(
                (got[c] - want).abs() < 1e-5 * want,
                "{got:?} against {want}"
            );
        }
        // By cosine: the closed form, and its table between the nodes.
        let table = m.single_by_cosine();
        for mu in [1.0f64, 0.4, 0.1, 0.0] {
            let log = if mu > 0.0 {
                mu * ((1.0 + mu) / mu).ln()
            } else {
                0.0
            };
            let (at, tab) = (m.rs_at(mu), table.factor(mu));
            for c in 0..3 {
                let want = 0.5 * alpha[c] * (1.0 - log);
                assert!((at[c] - want).abs() <= 1e-6 * want, "mu {mu}: {at:?}");
                assert!((tab[c] - want).abs() <= 2e-3 * alpha[c], "mu {mu}: {tab:?}");
            }
        }
        let glass = Medium::new(alpha, [1.0; 3], 1.5, 0.0).unwrap().rs_diffuse();
        let forward = Medium::new(alpha, [1.0; 3], 1.0, 0.8).unwrap().rs_diffuse();
        for c in 0..3 {
            assert!(glass[c] < got[c] && forward[c] < got[c] && glass[c] > 0.0);
        }
    }

    /// Isotropic scattering at eta 1 has closed forms at every cosine of
    /// arrival: all orders `1 - H(mu) sqrt(1 - alpha)`, single scattering
    /// `alpha / 2 (1 - mu ln((1 + mu) / mu))`. The blend of the table's
    /// cosines, with the exact single share, gives their difference
    /// between the nodes as well as on them.
    #[test]
    fn oblique_light_is_reflected_as_chandrasekhar_says() {
        let h = walk::tests::chandrasekhar_h;
        let single = |a: f64, mu: f64| {
            let log = if mu > 0.0 {
                mu * ((1.0 + mu) / mu).ln()
            } else {
                0.0
            };
            0.5 * a * (1.0 - log)
        };
        for mu in [1.0, 0.9, 0.7, 0.6, 0.4, 0.2, 0.1, 0.02, 0.0] {
            let alpha = [0.5, 0.9, 0.99];
            let m = Medium::new(alpha, [1.0; 3], 1.0, 0.0).unwrap();
            let got = m.rm_at(mu);
            for c in 0..3 {
                let a = alpha[c];
                let s = ss_reflectance(
                    Unit {
                        alpha: a,
                        eta: 1.0,
                        g: 0.0,
                    },
                    mu,
                );
                assert!(
                    (s - single(a, mu)).abs() < 1e-6 * single(a, mu),
                    "mu {mu} alpha {a}: single {s}"
                );
                let want = 1.0 - h(a, mu) * (1.0 - a).sqrt() - single(a, mu);
                // The table's noise (40,000 paths off the normal: 1.4% of
                // the smallest, alpha 0.5 at grazing) and its blend between
                // cosines (0.6% at most between the nodes).
                assert!(
                    (got[c] - want).abs() < 0.015 * want,
                    "mu {mu} alpha {a}: table {}, closed form {want}",
                    got[c]
                );
            }
            let f = m.incidence().factor(mu);
            assert!(f.iter().all(|x| x.is_finite()), "mu {mu}: {f:?}");
            for c in 0..3 {
                assert!((f[c] - got[c] / m.rm[c]).abs() < 2e-3, "mu {mu}: {f:?}");
            }
        }
    }

    /// Under a dielectric less oblique light gets in: the ratio falls to
    /// 0 at grazing, where none enters.
    #[test]
    fn grazing_light_does_not_enter_a_dielectric() {
        let m = Medium::new([0.9; 3], [1.0; 3], 1.33, 0.3).unwrap();
        assert_eq!(m.rm_at(0.0), [0.0; 3]);
        let inc = m.incidence();
        assert_eq!(inc.factor(1.0), [1.0; 3]);
        assert_eq!(inc.factor(0.0), [0.0; 3]);
        assert_eq!(inc.factor(-3.0), [0.0; 3]);
        assert_eq!(inc.factor(7.0), [1.0; 3]);
    }

    /// The table was written by the walk: its rows have the walk's bins,
    /// and each row is a whole (every path leaves or survives).
    #[test]
    fn the_table_is_the_walks() {
        let nb = walk::edges().len() - 1;
        assert_eq!(table::SHARES.len(), table::G.len());
        assert!(table::SHARES
            .iter()
            .all(|g| g.len() == table::ETA.len() * table::MU.len()));
        for row in table::SHARES.iter().flat_map(|g| g.iter()) {
            assert_eq!(row.len(), nb + 1);
            let sum: f64 = row.iter().map(|&x| x as f64).sum();
            assert!((sum - 1.0).abs() < 1e-5, "{sum}");
        }
    }

    /// The walk's single-scattering share is the exact integral (light
    /// reflected back in at the surface cannot leave unscattered again),
    /// and between the table's nodes a fresh walk agrees with the blend.
    #[test]
    fn the_walk_agrees_with_the_closed_form_and_the_blend() {
        let paths = 100_000;
        for (eta, g) in [(1.33, 0.3), (1.45, 0.75), (1.0, 0.1)] {
            // Followed to 20,000 events: the reflectances read weigh a
            // longer path by at most 0.999^20000 < 3e-9.
            let fresh = walk::walk_faces_upto(g, eta, 1.0, f64::INFINITY, paths, 99, 20_000).0;
            let exact = ss_reflectance(Unit { alpha: 1.0, eta, g }, 1.0);
            let p1 = fresh.bins[0];
            let sigma = (p1 / paths as f64).sqrt();
            assert!(
                (p1 - exact).abs() < 4.0 * sigma,
                "eta {eta} g {g}: {p1} against {exact}"
            );
            let blend = histogram(eta, g, 1.0);
            for alpha in [0.3, 0.8, 0.95, 0.999] {
                let (a, b) = (fresh.reflectance(alpha, 2), blend.reflectance(alpha, 2));
                // Both walks' noise, and the blend's own error.
                let sigma = (a / paths as f64).sqrt() + (a / table::PATHS as f64).sqrt();
                assert!(
                    (a - b).abs() < 4.0 * sigma + 0.005 * a,
                    "eta {eta} g {g} alpha {alpha}: walk {a}, table {b}"
                );
            }
        }
    }
}
