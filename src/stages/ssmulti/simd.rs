//! The instruction set of the pair loop, chosen at run time, and every
//! `unsafe` that choice needs.
//!
//! The pair loop is generic over an [`Isa`]: the baseline one (plain
//! multiply-adds, lane masks by comparison) or AVX2 with FMA. A value of
//! [`Avx2`] exists only when [`detect`] found the CPU to have it, so the
//! AVX intrinsics it runs are sound wherever it is passed; the loop
//! compiled with those features enabled is [`sum_leaf_avx2`].
//!
//! AVX-512 is not used: sixteen lanes evaluate more pairs past the reach,
//! and eight lanes with its 32 registers came out slower (the compiler
//! merges lanes into 512-bit vectors; benches/results/HISTORY.md,
//! "Measurements behind the code").

/// Receivers summed side by side: one a vector lane (AVX2: eight f32).
pub(super) const LANES: usize = 8;

/// Lanes of f32: eight receivers, one a lane.
pub(super) type Lanes = [f32; LANES];

/// Which pair loop a run may use.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Simd {
    /// The fastest this CPU has (AVX2 and FMA on x86-64 when present).
    #[default]
    Auto,
    /// The baseline loop (no fused multiply-adds: it rounds differently).
    Baseline,
}

/// An instruction set the pair loop is compiled for.
pub(super) trait Isa: Copy {
    /// Multiply-adds are fused (`mul_add`; without FMA it is a library
    /// call, so the baseline multiplies and adds).
    const FUSED: bool;
    /// Bit `k` set where `a[k] <= b[k]` (not where either is NaN).
    fn le_mask(self, a: &Lanes, b: &Lanes) -> u32;
}

/// The baseline instruction set.
#[derive(Clone, Copy, Debug)]
pub(super) struct Baseline;

impl Isa for Baseline {
    const FUSED: bool = false;
    #[inline(always)]
    fn le_mask(self, a: &Lanes, b: &Lanes) -> u32 {
        let mut bits = 0;
        for k in 0..LANES {
            bits |= ((a[k] <= b[k]) as u32) << k;
        }
        bits
    }
}

/// AVX2, FMA, POPCNT and BMI1: made only by [`detect`] on a CPU that has
/// them.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
pub(super) struct Avx2 {
    _detected: (),
}

#[cfg(target_arch = "x86_64")]
impl Isa for Avx2 {
    const FUSED: bool = true;
    #[inline(always)]
    fn le_mask(self, a: &Lanes, b: &Lanes) -> u32 {
        use std::arch::x86_64::{_mm256_cmp_ps, _mm256_loadu_ps, _mm256_movemask_ps, _CMP_LE_OQ};
        // SAFETY: an `Avx2` exists only on a CPU that has AVX2 (`detect`);
        // the loads read the 8 lanes of `a` and `b`.
        unsafe {
            _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(
                _mm256_loadu_ps(a.as_ptr()),
                _mm256_loadu_ps(b.as_ptr()),
            )) as u32
        }
    }
}

/// The instruction set found for a run.
#[derive(Clone, Copy, Debug)]
pub(super) enum Detected {
    Baseline,
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2),
}

/// What this CPU has, within what `simd` allows.
pub(super) fn detect(simd: Simd) -> Detected {
    #[cfg(target_arch = "x86_64")]
    if simd == Simd::Auto
        && is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("fma")
        && is_x86_feature_detected!("popcnt")
        && is_x86_feature_detected!("bmi1")
    {
        return Detected::Avx2(Avx2 { _detected: () });
    }
    let _ = simd;
    Detected::Baseline
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector mask agrees with the plain one, NaN included (false).
    #[test]
    fn le_mask_matches_lane_by_lane() {
        let a = [0.0, 1.0, -1.0, f32::NAN, 2.0, 3.0, f32::INFINITY, -0.0];
        let b = [0.0, 0.5, -0.5, 1.0, f32::NAN, 3.0, 1e30, 0.0];
        let plain = Baseline.le_mask(&a, &b);
        assert_eq!(plain, 0b1010_0101);
        #[cfg(target_arch = "x86_64")]
        if let Detected::Avx2(avx2) = detect(Simd::Auto) {
            assert_eq!(avx2.le_mask(&a, &b), plain);
        }
    }
}
