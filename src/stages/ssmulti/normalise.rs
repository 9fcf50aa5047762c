//! A receiver's sums into `ssM`: the normalisation of
//! `docs/DESIGN.md#normalisations`, worked out once per run.

use super::kernel::disk_integral;
use super::params::{Distances, Norm, Params};

/// Turns a receiver's sums into `ssM`.
pub(super) struct Normaliser {
    /// Per channel, what the sum is multiplied by (not `Local`).
    factor: [f64; 3],
    rd: [f64; 3],
    local: bool,
    /// `Local` with one kernel: the area sum is `s[3]` for every channel.
    single: bool,
}

impl Normaliser {
    /// (`area_scale`: what the sums' areas were multiplied by.)
    pub(super) fn new(p: &Params, dist: Distances, area_scale: f64) -> Normaliser {
        let Distances { ld, ld1 } = dist;
        let i1 = disk_integral(p.falloff, ld1);
        let rd = p.gains();
        let factor = [0, 1, 2].map(|c| {
            let f = match (p.norm, p.rgb) {
                (Norm::Seed | Norm::Channel | Norm::Source, false) => rd[c] / i1,
                (Norm::Seed, true) => 1.0 / i1,
                (Norm::Channel | Norm::Source, true) if ld[c] > 0.0 => {
                    rd[c] / disk_integral(p.falloff, ld[c])
                }
                _ => 0.0,
            };
            f / area_scale
        });
        Normaliser {
            factor,
            rd,
            local: p.norm == Norm::Local,
            single: dist.single(p.rgb),
        }
    }

    /// `ssM` from a receiver's sums: `s[0..3]` the channels, `s[3..6]`
    /// the kernel-weighted areas (`Local`).
    #[inline(always)]
    pub(super) fn apply(&self, s: &[f64; 6]) -> [f32; 3] {
        [0, 1, 2].map(|c| {
            let v = if self.local {
                let a = if self.single { s[3] } else { s[3 + c] };
                if a > 0.0 {
                    self.rd[c] * s[c] / a
                } else {
                    0.0
                }
            } else {
                s[c] * self.factor[c]
            };
            v as f32
        })
    }
}
