//! Small numeric helpers the stages share: Hermite's smoothstep (the
//! falloffs, spot lights' edges, `pcfilter`'s weights) and uniform numbers
//! from a seeded random stream (one stream a point, so that results do
//! not depend on the thread count).

use rand_core::RngCore;

/// Hermite smoothstep (`docs/DESIGN.md#smoothstep`): `t = clamp((x - a)
/// / (b - a), 0, 1)`, `3t^2 - 2t^3`; a step at `b` when `b <= a`.
#[inline]
pub fn smoothstep(a: f64, b: f64, x: f64) -> f64 {
    if b <= a {
        return if x >= b { 1.0 } else { 0.0 };
    }
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// A uniform number in [0, 1) with 53 random bits (two draws).
#[inline]
pub fn uniform53(r: &mut impl RngCore) -> f64 {
    let hi = (r.next_u32() >> 5) as u64;
    let lo = (r.next_u32() >> 6) as u64;
    ((hi << 26) | lo) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A uniform number in [0, 1) with 24 random bits (one draw): enough
/// for a jitter within a stratum.
#[inline]
pub fn uniform24(r: &mut impl RngCore) -> f64 {
    (r.next_u32() >> 8) as f64 * (1.0 / (1u32 << 24) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smoothstep_is_hermite_and_clamped() {
        assert_eq!(smoothstep(0.0, 1.0, -1.0), 0.0);
        assert_eq!(smoothstep(0.0, 1.0, 2.0), 1.0);
        assert_eq!(smoothstep(0.0, 1.0, 0.5), 0.5);
        assert_eq!(smoothstep(1.0, 3.0, 1.5), 0.15625);
        assert_eq!(smoothstep(2.0, 2.0, 2.0), 1.0);
        assert_eq!(smoothstep(2.0, 2.0, 1.9), 0.0);
    }

    #[test]
    fn uniforms_stay_in_the_unit_interval() {
        let mut r = rand_pcg::Pcg32::new(7, 3);
        for _ in 0..10_000 {
            let (a, b) = (uniform53(&mut r), uniform24(&mut r));
            assert!((0.0..1.0).contains(&a) && (0.0..1.0).contains(&b));
        }
    }
}
