//! The depth distributions single scattering's samples are drawn from
//! (`docs/DESIGN.md#sssingle`), as pure functions; the optics at the
//! boundary and the phase function are [`crate::optics`]'s, re-exported
//! here for the stage.

pub use crate::optics::*;

/// `F(y) = 2y - 2y^3 + y^4`: the integral of the smooth falloff `1 - 3t^2
/// + 2t^3` over [0, y], normalised to 1 at y = 1 (Marengo's `cdfSingle`).
#[inline]
pub fn cdf_single(y: f64) -> f64 {
    let y = y.clamp(0.0, 1.0);
    y * (2.0 + y * y * (y - 2.0))
}

/// The inverse of [`cdf_single`] on [0, 1], to a few ulps: a cubic
/// Hermite interpolation between [`CDF_KNOTS`] tabulated knots (the
/// inverse and its slope, exact to a few ulps from [`cdf_single_solve`]),
/// within about 1e-10, then one Newton step, which squares that error
/// away. Near `u = 1` the inverse's slope is infinite (a triple root of
/// `1 - F`), so there, above [`CDF_TABLE_TOP`], it is solved directly.
/// Every depth sample calls this: solving each took three to five Newton
/// steps and a `cbrt`.
pub fn cdf_single_inv(u: f64) -> f64 {
    if u.is_nan() || u <= 0.0 {
        return 0.0;
    }
    if u >= CDF_TABLE_TOP {
        return cdf_single_solve(u);
    }
    let t = &*CDF_TABLE;
    let x = u * CDF_KNOTS as f64;
    // (u < 1: i < CDF_KNOTS, and i + 1 is a knot.)
    let i = (x as usize).min(CDF_KNOTS - 1);
    let f = x - i as f64;
    let (g, h) = (1.0 - f, 1.0 / CDF_KNOTS as f64);
    let y = (1.0 + 2.0 * f) * g * g * t[i].0
        + f * g * g * t[i].1 * h
        + f * f * (3.0 - 2.0 * f) * t[i + 1].0
        - f * f * g * t[i + 1].1 * h;
    let (v, d) = (cdf_single(y) - u, cdf_single_slope(y));
    (y - v / d).clamp(0.0, 1.0)
}

/// Knot intervals of [`cdf_single_inv`]'s table.
pub const CDF_KNOTS: usize = 1024;

/// Above this `u` the inverse is solved, not interpolated: its slope
/// grows without bound towards 1 (`y = 1 - cbrt((1 - u) / 2)` there).
pub const CDF_TABLE_TOP: f64 = 0.95;

/// The inverse at the knots `u = i / CDF_KNOTS` and its slope there.
static CDF_TABLE: std::sync::LazyLock<Vec<(f64, f64)>> = std::sync::LazyLock::new(|| {
    (0..=CDF_KNOTS)
        .map(|i| {
            let y = cdf_single_solve(i as f64 / CDF_KNOTS as f64);
            let d = cdf_single_slope(y);
            (y, if d > 0.0 { 1.0 / d } else { 0.0 })
        })
        .collect()
});

/// `F'(y) = 2 (1 - y)^2 (1 + 2y)`.
#[inline]
fn cdf_single_slope(y: f64) -> f64 {
    2.0 * (1.0 - y) * (1.0 - y) * (1.0 + 2.0 * y)
}

/// The inverse of [`cdf_single`] on [0, 1], to a few ulps, solved.
///
/// `F` is concave and its slope vanishes at 1 (`1 - F(1 - e) = e^3 (2 -
/// e)`: a triple root), so one formula does not serve the whole range.
/// Below `u = 1/2` (`y <= 0.27`) Newton's steps on `F(y) = u` start at the
/// series `y = w + w^3`, `w = u / 2`, and keep y's relative precision for
/// tiny u; above it they solve `e^3 (2 - e) = 1 - u` for `e = 1 - y` from
/// `e = cbrt((1 - u) / 2)`, where the slope in `e` stays away from zero.
/// Either start is within a few per cent, so the steps settle in two to
/// five (measured over u in steps of 1e-5; the bracket, and a cap of 16,
/// only guard against rounding).
pub fn cdf_single_solve(u: f64) -> f64 {
    if u.is_nan() || u <= 0.0 {
        return 0.0;
    }
    if u >= 1.0 {
        return 1.0;
    }
    if u <= 0.5 {
        let w = 0.5 * u;
        let y = newton(w + w * w * w, 0.0, 0.27, |y| {
            (cdf_single(y) - u, cdf_single_slope(y))
        });
        return y.clamp(0.0, 1.0);
    }
    let v = 1.0 - u;
    let e = newton((0.5 * v).cbrt(), 0.0, 1.0, |e| {
        (e * e * e * (2.0 - e) - v, 2.0 * e * e * (3.0 - 2.0 * e))
    });
    (1.0 - e).clamp(0.0, 1.0)
}

/// Newton's steps on the increasing `f` (which returns the value and the
/// slope) from `x` within `[lo, hi]`, until a step changes nothing at the
/// precision of `x` (bisection should a step leave the bracket).
#[inline]
fn newton(mut x: f64, mut lo: f64, mut hi: f64, f: impl Fn(f64) -> (f64, f64)) -> f64 {
    for _ in 0..16 {
        let (v, d) = f(x);
        if v == 0.0 {
            return x;
        }
        if v > 0.0 {
            hi = hi.min(x);
        } else {
            lo = lo.max(x);
        }
        let mut next = x - v / d;
        if !(next >= lo && next <= hi) {
            next = 0.5 * (lo + hi);
        }
        if (next - x).abs() <= 2.0 * f64::EPSILON * x.abs() {
            return next;
        }
        x = next;
    }
    x
}

/// The truncated exponential of rate `sigma` on [0, d] (`d` may be
/// infinite): `1 - e^(-sigma d)`, computed as `-expm1`.
#[inline]
pub fn trunc_mass(sigma: f64, d: f64) -> f64 {
    if d.is_infinite() {
        1.0
    } else {
        -(-sigma * d).exp_m1()
    }
}

/// The depth at `u` in [0, 1) of the truncated exponential of rate
/// `sigma` on [0, d] with mass `mass = trunc_mass(sigma, d)`.
#[inline]
pub fn trunc_exp_inv(u: f64, sigma: f64, mass: f64, d: f64) -> f64 {
    (-(-u * mass).ln_1p() / sigma).min(d)
}

/// The density at depth `s` of the truncated exponential of rate `sigma`
/// with mass `mass`.
#[inline]
pub fn trunc_exp_pdf(s: f64, sigma: f64, mass: f64) -> f64 {
    sigma * (-sigma * s).exp() / mass
}

/// The cumulative distribution of the truncated exponential of rate
/// `sigma` with mass `mass`, at depth `s`.
#[inline]
pub fn trunc_exp_cdf(s: f64, sigma: f64, mass: f64) -> f64 {
    (-(-sigma * s).exp_m1() / mass).min(1.0)
}

/// The depth at `u` in [0, 1) of the even mixture of three truncated
/// exponentials on [0, d] (rates `sigma`, masses `mass`): the root of
/// `Q(s) = (F_0 + F_1 + F_2) / 3 = u`, which lies between the smallest and
/// the largest of the three channels' own depths at `u`. Newton's steps
/// on `ln s` (the depths span decades: about five steps to 1e-10) kept
/// inside that bracket.
pub fn mixture_inv(u: f64, sigma: [f64; 3], mass: [f64; 3], d: f64) -> f64 {
    let own = [0, 1, 2].map(|c| trunc_exp_inv(u, sigma[c], mass[c], d));
    let mut lo = own.iter().copied().fold(f64::INFINITY, f64::min);
    let mut hi = own.iter().copied().fold(0.0, f64::max);
    if !(lo > 0.0 && hi > lo) {
        return hi;
    }
    // Start at the geometric mean of the three.
    let mut s = (own[0] * own[1] * own[2]).cbrt();
    for _ in 0..100 {
        // Q(s) - u and s Q'(s), one expm1 a channel.
        let (mut f, mut ds) = (-u, 0.0);
        for c in 0..3 {
            let em1 = (-sigma[c] * s).exp_m1();
            f -= em1 / (3.0 * mass[c]);
            ds += sigma[c] * s * (1.0 + em1) / (3.0 * mass[c]);
        }
        if f > 0.0 {
            hi = s;
        } else {
            lo = s;
        }
        // A step onto the bracket's end is taken: at convergence the step
        // returns `s`, which is one of the ends (rejecting it bisected
        // the bracket for some 30 more rounds).
        let next = s * (-f / ds).exp();
        let next = if next >= lo && next <= hi {
            next
        } else {
            (lo * hi).sqrt()
        };
        if (next - s).abs() <= 1e-10 * s || hi - lo <= 1e-10 * hi {
            return next;
        }
        s = next;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The interpolated inverse is the solved one to a few ulps, across
    /// every knot interval and both sides of the table's top.
    #[test]
    fn cdf_single_inv_interpolates_the_solved_inverse() {
        let mut rng = rand_pcg::Pcg32::new(7, 0);
        let mut worst: f64 = 0.0;
        for k in 0..200_000 {
            // Uniform, then crowded towards 0 and towards the top.
            let r = crate::maths::uniform24(&mut rng);
            let u = match k % 3 {
                0 => r,
                1 => r * r * r * r,
                _ => CDF_TABLE_TOP + (r - 0.5) * 1e-3,
            };
            let (a, b) = (cdf_single_inv(u), cdf_single_solve(u));
            let e = (a - b).abs() / b.max(f64::MIN_POSITIVE);
            worst = worst.max(e);
            assert!(e <= 4.0 * f64::EPSILON, "{u}: {a} vs {b}");
        }
        for i in 0..=CDF_KNOTS {
            let u = i as f64 / CDF_KNOTS as f64;
            for u in [u, u - 1e-12, u + 1e-12] {
                let (a, b) = (cdf_single_inv(u), cdf_single_solve(u));
                assert!((a - b).abs() <= 4.0 * f64::EPSILON * b.max(1e-300), "{u}");
            }
        }
        eprintln!("worst relative difference {worst:e}");
    }

    #[test]
    fn cdf_single_inverts() {
        for k in 0..=1000 {
            let u = k as f64 / 1000.0;
            let y = cdf_single_inv(u);
            assert!((0.0..=1.0).contains(&y));
            assert!((cdf_single(y) - u).abs() < 1e-14, "{u}: {y}");
        }
        // Relative precision for tiny u (F(y) = 2y near 0), and the ends.
        for u in [1e-300, 1e-100, 1e-12, 1e-6] {
            let y = cdf_single_inv(u);
            assert!((y / (0.5 * u) - 1.0).abs() < 1e-5, "{u}: {y}");
            assert!((cdf_single(y) / u - 1.0).abs() < 1e-15, "{u}: {y}");
        }
        for u in [1.0 - 1e-16, 1.0 - 1e-9, 0.5, 0.5 + 1e-16] {
            let y = cdf_single_inv(u);
            assert!((cdf_single(y) - u).abs() < 1e-15, "{u}: {y}");
        }
        assert_eq!(cdf_single_inv(0.0), 0.0);
        assert_eq!(cdf_single_inv(1.0), 1.0);
        assert_eq!(cdf_single_inv(-1.0), 0.0);
        assert_eq!(cdf_single_inv(2.0), 1.0);
    }

    #[test]
    fn the_mixture_inverts() {
        let sigma = [20.0, 10.0, 5.0];
        for d in [0.3, f64::INFINITY] {
            let mass = sigma.map(|x| trunc_mass(x, d));
            for k in 0..1000 {
                let u = k as f64 / 1000.0;
                let s = mixture_inv(u, sigma, mass, d);
                let f: f64 = (0..3)
                    .map(|c| trunc_exp_cdf(s, sigma[c], mass[c]))
                    .sum::<f64>()
                    / 3.0;
                assert!((f - u).abs() < 1e-9 * u.max(1e-3), "{d} {u}: {s} gives {f}");
            }
        }
    }

    #[test]
    fn truncated_exponentials_stay_finite_at_every_scale() {
        for sigma in [1e-8, 1.0, 1e8] {
            for d in [1e-8, 1.0, f64::INFINITY] {
                let m = trunc_mass(sigma, d);
                for u in [0.0, 0.5, 1.0 - 1e-9] {
                    let s = trunc_exp_inv(u, sigma, m, d);
                    assert!(s.is_finite() && s >= 0.0 && s <= d, "{sigma} {d} {u}: {s}");
                    assert!(trunc_exp_pdf(s, sigma, m).is_finite());
                }
            }
        }
    }
}
