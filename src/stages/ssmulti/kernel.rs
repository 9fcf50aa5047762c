//! The falloffs in f64: the reference the tests and the approximate
//! method use, their disk integrals (`docs/DESIGN.md#falloffs`), and how
//! far a source can add anything.

use std::f64::consts::PI;

use crate::maths::smoothstep;

/// The falloff kernel (`docs/DESIGN.md#falloffs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Falloff {
    /// `1 - smooth(0, D, r)` (Houdini's).
    Smooth,
    /// `exp(-sigma r / D)` (the slides' alternative).
    Exp { sigma: f64 },
    /// Christensen-Burley, shape `d = D / kappa`, truncated at `D`.
    Burley { kappa: f64 },
}

/// A falloff's name, as the command line takes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FalloffKind {
    /// 1 - smoothstep(0, D, r) (Houdini's).
    Smooth,
    /// exp(-sigma r / D).
    Exp,
    /// Christensen-Burley diffusion profile, shape D / sigma, truncated at D.
    Burley,
}

/// The default `sigma` of the exp falloff.
pub const EXP_SIGMA: f64 = 4.0;

/// The default `kappa` of the Burley falloff, `d = D / kappa`: the
/// profile's mean radius `2.5 d` equals the smooth falloff's `4 D / 9`
/// (`kappa = 2.5 * 9 / 4`), so switching falloffs keeps the look's scale;
/// 88% of the untruncated profile's energy lies within `D`. Larger values
/// keep more of the tail but need denser clouds: the profile's core is
/// `d` wide and wants many points across it.
pub const BURLEY_KAPPA: f64 = 5.625;

impl Falloff {
    /// The falloff `kind` with shape `sigma` (exp's decay rate, Burley's
    /// `kappa`; their defaults when `None`; smooth has none).
    pub fn new(kind: FalloffKind, sigma: Option<f64>) -> Falloff {
        match kind {
            FalloffKind::Smooth => Falloff::Smooth,
            FalloffKind::Exp => Falloff::Exp {
                sigma: sigma.unwrap_or(EXP_SIGMA),
            },
            FalloffKind::Burley => Falloff::Burley {
                kappa: sigma.unwrap_or(BURLEY_KAPPA),
            },
        }
    }
}

/// Below this exponent a kernel's `e^x` is 0: weights under `e^-60`
/// (8.8e-27) of a point's own weight are nothing beside it, and their
/// products with `illum * ptarea` would be subnormal (~100 cycles each;
/// with this cut sigma 1000 costs what sigma 4 does in the variants
/// benchmark).
pub const EXP_CUT: f32 = -60.0;

/// `(1 - e^-s (1 + s)) / s^2`, stable for every `s > 0`: its series below
/// 0.5, `expm1` above (`docs/DESIGN.md#exp`).
pub fn exp_disk_factor(s: f64) -> f64 {
    if s < 0.5 {
        // sum_{k >= 2} (-1)^k (k - 1) / k! s^(k - 2)
        let mut term: f64 = 0.5; // k = 2: 1 / 2!
        let mut sum: f64 = 0.0;
        let mut k: f64 = 2.0;
        while term.abs() > 1e-18 * sum.abs().max(1e-300) || k < 4.0 {
            sum += term;
            // term_{k+1} / term_k = -s k / ((k + 1) (k - 1))
            term *= -s * k / ((k + 1.0) * (k - 1.0));
            k += 1.0;
            if k > 60.0 {
                break;
            }
        }
        sum
    } else {
        (-(-s).exp_m1() - s * (-s).exp()) / (s * s)
    }
}

/// The disk integral `I(D) = int_0^D W(r, D) 2 pi r dr` of a falloff.
pub fn disk_integral(f: Falloff, d: f64) -> f64 {
    match f {
        Falloff::Smooth => 3.0 * PI * d * d / 10.0,
        Falloff::Exp { sigma } => 2.0 * PI * d * d * exp_disk_factor(sigma),
        Falloff::Burley { kappa } => burley::disk_integral(kappa, d),
    }
}

/// The falloff at distance `r` in f64 (the reference the tests and the
/// approximate method use); `rmin` is the Burley regularisation radius of
/// the source point (see [`burley`]).
pub fn falloff(f: Falloff, r: f64, d: f64, rmin: f64) -> f64 {
    if r > d || d <= 0.0 {
        return 0.0;
    }
    match f {
        Falloff::Smooth => 1.0 - smoothstep(0.0, d, r),
        Falloff::Exp { sigma } => (-sigma * r / d).exp(),
        Falloff::Burley { kappa } => burley::profile(kappa, r, d, rmin),
    }
}

/// The Christensen-Burley falloff, truncated at `D` and renormalised over
/// the disk, evaluated at `max(r, r_min)` (`docs/DESIGN.md#burley`: the
/// disk integral and why `r_min = sqrt(ptarea / pi) / 2`).
pub mod burley {
    use std::f64::consts::PI;

    /// `I(D)` for shape `d = D / kappa`.
    pub fn disk_integral(kappa: f64, d: f64) -> f64 {
        -2.0 * PI * (d / kappa) * ((-kappa).exp_m1() + 3.0 * (-kappa / 3.0).exp_m1())
    }

    /// `W(max(r, rmin))` for `r <= D`.
    pub fn profile(kappa: f64, r: f64, d: f64, rmin: f64) -> f64 {
        let s = d / kappa;
        let r = r.max(rmin);
        if r <= 0.0 {
            return 0.0;
        }
        ((-r / s).exp() + (-r / (3.0 * s)).exp()) / r
    }

    /// The regularisation radius of a source of area `ptarea`.
    pub fn rmin(ptarea: f64) -> f64 {
        0.5 * (ptarea.max(0.0) / PI).sqrt()
    }
}

/// How far from a source its weight can be above 0, at largest distance
/// `ld1`: `ld1`, or less for a steep exp (sigma above 60: its weights are
/// 0 beyond `60 ld1 / sigma`, `EXP_CUT`) or a Burley profile with kappa
/// above 180 (both its exponentials are cut beyond `180 ld1 / kappa`).
/// Sources farther away are not visited: they would add exact zeros.
/// (With a margin over the f32 rounding of the weights' exponents.)
pub fn reach(f: Falloff, ld1: f64) -> f64 {
    let cut = -EXP_CUT as f64 * (1.0 + 1e-5);
    match f {
        Falloff::Smooth => ld1,
        Falloff::Exp { sigma } => ld1.min(cut * ld1 / sigma),
        Falloff::Burley { kappa } => ld1.min(3.0 * cut * ld1 / kappa),
    }
}
