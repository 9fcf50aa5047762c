//! Thin parts (`docs/DESIGN.md#thickness`): the light a slab of a
//! given thickness sends out of both faces, and out of its far face, from
//! the slab table of walks ([`slab_table`], written by
//! `examples/medium_slab_table.rs`), blended over `(eta, g, thickness)`,
//! and tabulated per medium over the thickness for `ssmulti`
//! ([`Thinness`]).

use super::walk::Histogram;
use super::{bracket, histogram, slab_table, split, t_in, table, Medium};

/// The walk's histogram at `(eta, g)` for a slab `thickness` mean free
/// paths thick lit along its normal, of the light that leaves through
/// either face: the slab table's nodes blended (bilinearly in `g` and
/// `eta`, linearly in `ln thickness`); thicker than its last node, blended
/// with the semi-infinite medium's linearly in `1 / thickness`; thinner
/// than its first, that node's scaled by `thickness / first` for one
/// event and its square for more (each event within the thickness).
fn slab_histogram(eta: f64, g: f64, thickness: f64) -> Histogram {
    slab_blend(&slab_table::SHARES, eta, g, thickness, true)
}

/// [`slab_histogram`] of the light that leaves through the far face
/// alone (thicker than the table's last node, blended with nothing: a
/// semi-infinite medium lets nothing through).
fn slab_through(eta: f64, g: f64, thickness: f64) -> Histogram {
    slab_blend(&slab_table::THROUGH, eta, g, thickness, false)
}

/// The blend of one of the slab tables (`rows` of `SHARES` or `THROUGH`,
/// with a survivors' column when `survivors`) at `(eta, g, thickness)`.
fn slab_blend<const N: usize, const M: usize>(
    rows: &[&[[f32; N]; M]],
    eta: f64,
    g: f64,
    thickness: f64,
    survivors: bool,
) -> Histogram {
    let nodes = &slab_table::THICKNESS;
    let (first, last) = (nodes[0], nodes[nodes.len() - 1]);
    // The semi-infinite medium, as a row of this table's shape.
    let deep = || -> Vec<f64> {
        if !survivors {
            return vec![0.0; N];
        }
        let h = histogram(eta, g, 1.0);
        let mut d = h.bins;
        d.push(h.survivors);
        d
    };
    if thickness.is_nan() || thickness == f64::INFINITY {
        return split(deep(), survivors);
    }
    let blend = |k: usize, tk: f64| -> Vec<f64> {
        let (i, tg) = bracket(&table::G, g);
        let (j, te) = bracket(&table::ETA, eta);
        let nt = nodes.len();
        let mut v = vec![0.0f64; N];
        for (di, wg) in [(0, 1.0 - tg), (1, tg)] {
            for (dj, we) in [(0, 1.0 - te), (1, te)] {
                for (dk, wt) in [(0, 1.0 - tk), (1, tk)] {
                    let w = wg * we * wt;
                    if w > 0.0 {
                        let row = &rows[i + di][(j + dj) * nt + k + dk];
                        v.iter_mut().zip(row).for_each(|(a, &b)| *a += w * b as f64);
                    }
                }
            }
        }
        v
    };
    let v = if thickness >= last {
        let w = last / thickness;
        let slab = blend(nodes.len() - 2, 1.0);
        slab.iter()
            .zip(&deep())
            .map(|(a, b)| w * a + (1.0 - w) * b)
            .collect()
    } else if thickness <= first {
        let k = thickness / first;
        let mut v = blend(0, 0.0);
        v[0] *= k;
        v[1..].iter_mut().for_each(|x| *x *= k * k);
        v
    } else {
        let logs: Vec<f64> = nodes.iter().map(|t| t.ln()).collect();
        let (k, tk) = bracket(&logs, thickness.ln());
        blend(k, tk)
    };
    split(v, survivors)
}

impl Medium {
    /// The multiple-scattering light per channel that leaves a slab
    /// `thickness` thick (in the scene's units) through either face, lit
    /// along its normal: `rm` for a thick one, less for a thin one.
    pub fn rm_slab(&self, thickness: f64) -> [f64; 3] {
        let ti = t_in(self.eta, 1.0);
        [0, 1, 2].map(|c| {
            let h = slab_histogram(self.eta, self.g, thickness / self.mfp[c]);
            ti * h.reflectance(self.albedo[c], 2)
        })
    }

    /// The share per channel of [`Medium::rm_slab`] that leaves through
    /// the far face (0 for a thick part; about a half for a thin one).
    pub fn through_slab(&self, thickness: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            let t = thickness / self.mfp[c];
            let all = slab_histogram(self.eta, self.g, t).reflectance(self.albedo[c], 2);
            let far = slab_through(self.eta, self.g, t).reflectance(self.albedo[c], 2);
            if all > 0.0 {
                (far / all).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
    }

    /// [`Medium::rm_slab`] over `rm`, tabulated for [`Thinness::factor`].
    pub fn thinness(&self) -> Thinness {
        let ratios = (0..THIN_NODES)
            .map(|k| {
                let x = THIN_LO + k as f64 * THIN_STEP;
                [0, 1, 2].map(|c| {
                    let t = x.exp() * self.mfp[c];
                    let r = self.rm_slab(t)[c];
                    if self.rm[c] > 0.0 {
                        r / self.rm[c]
                    } else {
                        1.0
                    }
                })
            })
            .collect();
        let through = (0..THIN_NODES)
            .map(|k| {
                let x = THIN_LO + k as f64 * THIN_STEP;
                [0, 1, 2].map(|c| self.through_slab(x.exp() * self.mfp[c])[c])
            })
            .collect();
        Thinness {
            ratios,
            through,
            mfp: self.mfp,
        }
    }
}

/// [`Thinness`]'s nodes: `ln(thickness / mfp)` from `THIN_LO` by
/// `THIN_STEP` (0.01 to 1000 mean free paths, 20 a decade).
const THIN_LO: f64 = -4.605_170_185_988_091;
const THIN_STEP: f64 = std::f64::consts::LN_10 / 20.0;
const THIN_NODES: usize = 101;

/// A medium's multiple-scattering light by the thickness behind the point
/// the light entered, over a thick part's.
#[derive(Clone, Debug, PartialEq)]
pub struct Thinness {
    /// Per node, per channel.
    ratios: Vec<[f64; 3]>,
    /// Per node, per channel: the share through the far face.
    through: Vec<[f64; 3]>,
    mfp: [f64; 3],
}

impl Thinness {
    /// The share per channel of the light a part `thickness` thick sends
    /// out that leaves through its far face ([`Medium::through_slab`]),
    /// linear in `ln(thickness / mfp)` between the nodes, the end nodes'
    /// beyond them (0 at 0 or a non-number).
    pub fn through(&self, thickness: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            let t = thickness / self.mfp[c];
            if t.is_nan() || t <= 0.0 {
                return 0.0;
            }
            let x = ((t.ln() - THIN_LO) / THIN_STEP).clamp(0.0, (THIN_NODES - 1) as f64);
            let i = (x.floor() as usize).min(THIN_NODES - 2);
            let f = x - i as f64;
            self.through[i][c] * (1.0 - f) + self.through[i + 1][c] * f
        })
    }

    /// The ratio per channel at `thickness` in the scene's units: linear
    /// in `ln(thickness / mfp)` between the nodes, the thickest node's
    /// beyond them (within 1e-3 of 1), and `(thickness / thinnest)^2` times
    /// the thinnest's below (0 at 0 or a non-number).
    pub fn factor(&self, thickness: f64) -> [f64; 3] {
        [0, 1, 2].map(|c| {
            let t = thickness / self.mfp[c];
            if t.is_nan() || t <= 0.0 {
                return 0.0;
            }
            let x = (t.ln() - THIN_LO) / THIN_STEP;
            if x <= 0.0 {
                return self.ratios[0][c] * (t / THIN_LO.exp()).powi(2);
            }
            if x >= (THIN_NODES - 1) as f64 {
                return self.ratios[THIN_NODES - 1][c];
            }
            let i = x.floor() as usize;
            let f = x - i as f64;
            self.ratios[i][c] * (1.0 - f) + self.ratios[i + 1][c] * f
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::walk;

    /// A slab lets through unscattered `e^-T` of the light along its
    /// normal at eta 1, and a white one returns all the rest through its
    /// faces; between the slab table's thicknesses a fresh walk agrees
    /// with the blend; thick, a slab is the semi-infinite medium.
    #[test]
    fn thin_slabs_return_what_they_scatter() {
        for t in [0.02, 0.1, 0.4, 1.5, 4.0, 12.0, 60.0] {
            let white = slab_histogram(1.0, 0.0, t).reflectance(1.0, 1);
            let want = 1.0 - (-t).exp();
            // (The blend in ln T: 1.5% between the nodes.)
            let tol = if t < slab_table::THICKNESS[0] {
                0.03
            } else {
                0.02
            };
            assert!(
                (white - want).abs() < tol * want,
                "T {t}: {white} against {want}"
            );
        }
        let paths = 100_000;
        for (eta, g, t) in [(1.33, 0.3, 0.7), (1.0, 0.8, 4.0), (1.6, -0.2, 0.15)] {
            let fresh = walk::walk_in(g, eta, 1.0, t, paths, 77);
            let blend = slab_histogram(eta, g, t);
            for alpha in [0.5, 0.9, 0.99] {
                let (a, b) = (fresh.reflectance(alpha, 2), blend.reflectance(alpha, 2));
                let sigma = (a / paths as f64).sqrt() + (a / slab_table::PATHS as f64).sqrt();
                assert!(
                    (a - b).abs() < 4.0 * sigma + 0.03 * a,
                    "eta {eta} g {g} T {t} alpha {alpha}: walk {a}, table {b}"
                );
            }
        }
        let m = Medium::new([0.5, 0.9, 0.99], [1.0, 2.0, 0.5], 1.33, 0.4).unwrap();
        let thin = m.thinness();
        let far = thin.factor(1e6);
        assert!(far.iter().all(|&f| (f - 1.0).abs() < 5e-3), "{far:?}");
        assert_eq!(thin.factor(0.0), [0.0; 3]);
        assert_eq!(thin.factor(f64::NAN), [0.0; 3]);
        assert_eq!(thin.factor(f64::INFINITY), thin.factor(1e300));
        for t in [0.01, 0.3, 2.0, 20.0] {
            let (f, r) = (thin.factor(t), m.rm_slab(t));
            for c in 0..3 {
                assert!(
                    (f[c] - r[c] / m.rm[c]).abs() < 0.01 * r[c] / m.rm[c] + 1e-6,
                    "T {t}: {f:?}"
                );
            }
        }
    }
}
