//! The optics every stage shares, as pure functions
//! (`docs/DESIGN.md#fresnel`, `#sssingle`): refraction at the boundary,
//! its Fresnel reflectance, and the Henyey-Greenstein phase function.
//! A leaf: illum's shadows through a medium, sssingle, and the medium's
//! random walks all read the boundary the same way.

use std::f64::consts::PI;

use glam::DVec3;

/// `I` (unit) refracted at a surface of unit normal `n` with index ratio
/// `r` (outside over inside); `None` on total internal reflection.
#[inline]
pub fn refract(i: DVec3, n: DVec3, r: f64) -> Option<DVec3> {
    let c = n.dot(i);
    let k = 1.0 - r * r * (1.0 - c * c);
    (k >= 0.0).then(|| (i * r - n * (r * c + k.sqrt())).normalize())
}

/// The unpolarised Fresnel reflectance of a dielectric for light arriving
/// from outside at cosine `cos_i` (`eta`: inside over outside); 1 on total
/// internal reflection (`docs/DESIGN.md#fresnel`).
#[inline]
pub fn fresnel(cos_i: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 0.0;
    }
    let ci = cos_i.clamp(0.0, 1.0);
    let sin_t2 = (1.0 - ci * ci) / (eta * eta);
    if sin_t2 >= 1.0 {
        return 1.0;
    }
    fresnel_at(ci, (1.0 - sin_t2).sqrt(), eta)
}

/// [`fresnel`] from `ci` in [0, 1] and the refracted cosine `ct` (`eta !=
/// 1`, no total internal reflection): for a caller that has `ct` already.
#[inline]
pub fn fresnel_at(ci: f64, ct: f64, eta: f64) -> f64 {
    if eta == 1.0 {
        return 0.0;
    }
    let rs = (ci - eta * ct) / (ci + eta * ct);
    let rp = (eta * ci - ct) / (eta * ci + ct);
    let f = 0.5 * (rs * rs + rp * rp);
    // (0/0 at a grazing cosine of exactly 0: all is reflected.)
    if f.is_finite() {
        f.min(1.0)
    } else {
        1.0
    }
}

/// The largest `|g|` used: the phase function stays finite.
pub const G_MAX: f64 = 0.998;

/// The Henyey-Greenstein phase function, normalised over the sphere:
/// `(1 - g^2) / (4 pi (1 + g^2 - 2 g c)^(3/2))`, `c` the cosine between the
/// light's travel direction and the scattered one.
#[inline]
pub fn hg(g: f64, c: f64) -> f64 {
    let g = g.clamp(-G_MAX, G_MAX);
    let den = hg_den(g, c);
    (1.0 - g * g) / (4.0 * PI * den * den.sqrt())
}

/// Henyey-Greenstein scaled to peak 1 (Marengo's):
/// `((1 - |g|)^2 / (1 + g^2 - 2 g c))^(3/2)`.
#[inline]
pub fn hg_peak1(g: f64, c: f64) -> f64 {
    let g = g.clamp(-G_MAX, G_MAX);
    let den = hg_den(g, c);
    let x = (1.0 - g.abs()).powi(2) / den;
    x * x.sqrt()
}

/// `1 + g^2 - 2 g c`, as `(1 - g)^2 + 2 g (1 - c)` (or with `1 + c` for
/// `g < 0`): no cancellation near the peak, where it is `(1 - |g|)^2`.
#[inline]
fn hg_den(g: f64, c: f64) -> f64 {
    let c = c.clamp(-1.0, 1.0);
    let d = if g >= 0.0 {
        (1.0 - g) * (1.0 - g) + 2.0 * g * (1.0 - c)
    } else {
        (1.0 + g) * (1.0 + g) - 2.0 * g * (1.0 + c)
    };
    d.max(f64::MIN_POSITIVE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fresnel_is_zero_at_eta_one_and_known_at_normal_incidence() {
        assert_eq!(fresnel(0.3, 1.0), 0.0);
        // ((eta - 1) / (eta + 1))^2 at normal incidence.
        let r = fresnel(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-15, "{r}");
        assert_eq!(fresnel(0.1, 0.5), 1.0, "total internal reflection");
        assert_eq!(fresnel(0.0, 1.33), 1.0);
    }

    #[test]
    fn hg_integrates_to_one_and_peaks_at_one() {
        // (Up to 0.9: sharper peaks need a finer rule than this one.)
        for g in [-0.9, -0.3, 0.0, 0.7, 0.9] {
            // int over the sphere = 2 pi int_-1^1 hg(c) dc (midpoint rule).
            let n = 200_000;
            let s: f64 = (0..n)
                .map(|k| hg(g, -1.0 + (k as f64 + 0.5) * 2.0 / n as f64))
                .sum::<f64>()
                * 2.0
                / n as f64;
            assert!((2.0 * PI * s - 1.0).abs() < 2e-3, "g {g}: {}", 2.0 * PI * s);
        }
        for g in [-0.999, -0.9, -0.3, 0.0, 0.7, 0.999] {
            let peak = hg_peak1(g, if g >= 0.0 { 1.0 } else { -1.0 });
            assert!((peak - 1.0).abs() < 1e-12, "g {g}: {peak}");
        }
    }
}
