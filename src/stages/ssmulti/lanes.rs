//! The falloffs in f32 for the pair loop's lanes: eight receivers, one a
//! lane, each source broadcast to all eight. Branch-free, so that the
//! loop vectorises; the f64 reference is [`super::kernel`].

use super::kernel::{Falloff, EXP_CUT};
use super::params::LEAF;
pub(super) use super::simd::{Isa, Lanes, LANES};

/// A falloff in f32 for the pair loop, at `r <= D` (the caller masks
/// what lies beyond).
pub(super) trait Kernel: Copy {
    /// The weight is exactly 0 at `r >= D` without a mask (`r` beyond
    /// `D` included): the pair loop then needs no reach mask.
    const CLIPS: bool;
    /// Reads Burley's `r_min`.
    const RMIN: bool;
    /// The weight at distance `r`.
    fn w<I: Isa>(&self, r: f32, rmin: f32) -> f32;
    /// The weight at squared distance `r2` (`w` at its square root).
    #[inline(always)]
    fn w2<I: Isa>(&self, r2: f32, rmin: f32) -> f32 {
        self.w::<I>(r2.sqrt(), rmin)
    }
}

/// `a * b + c`, fused when the instruction set has FMA (elsewhere
/// `mul_add` is a library call).
#[inline(always)]
pub(super) fn madd<I: Isa>(a: f32, b: f32, c: f32) -> f32 {
    if I::FUSED {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

#[derive(Clone, Copy)]
pub(super) struct SmoothKernel {
    inv: f32,
    /// `inv^2`.
    inv2: f32,
}

/// `1 - 3t^2 + 2t^3 = 1 + s (2t - 3)` from `s = t^2` and `t`: two
/// multiply-adds, the last rounded once, so its error is that of `s` and
/// `t` (about 1e-7, where the f32 distances already put ~1e-7 of error on
/// `t`; tested against an f64 double loop). `t` clamped to 1 gives
/// exactly 0.
#[inline(always)]
fn smooth_st<I: Isa>(s: f32, t: f32) -> f32 {
    madd::<I>(s, madd::<I>(2.0, t, -3.0), 1.0)
}

impl Kernel for SmoothKernel {
    const CLIPS: bool = true;
    const RMIN: bool = false;
    #[inline(always)]
    fn w<I: Isa>(&self, r: f32, _: f32) -> f32 {
        let t = (r * self.inv).min(1.0);
        smooth_st::<I>(t * t, t)
    }
    #[inline(always)]
    fn w2<I: Isa>(&self, r2: f32, _: f32) -> f32 {
        // (Clamped before the square root: one multiply fewer than `w`.)
        let s = (r2 * self.inv2).min(1.0);
        smooth_st::<I>(s, s.sqrt())
    }
}

#[derive(Clone, Copy)]
pub(super) struct ExpKernel {
    c: f32,
}

impl Kernel for ExpKernel {
    const CLIPS: bool = false;
    const RMIN: bool = false;
    #[inline(always)]
    fn w<I: Isa>(&self, r: f32, _: f32) -> f32 {
        exp_weight(self.c * r)
    }
}

/// `e^(EXP_CUT / 3)`: below it, Burley's `e^(-r/d)`, the cube of its
/// `e^(-r/3d)`, is under `e^EXP_CUT` and 0.
const CUBE_CUT: f32 = 2.061_153_6e-9;

#[derive(Clone, Copy)]
pub(super) struct BurleyKernel {
    /// `-1 / 3d`.
    b: f32,
}

impl Kernel for BurleyKernel {
    const CLIPS: bool = false;
    const RMIN: bool = true;
    #[inline(always)]
    fn w<I: Isa>(&self, r: f32, rmin: f32) -> f32 {
        // A zero-area source (rmin 0) at r 0 carries nothing: a finite
        // huge weight times 0.
        let rr = r.max(rmin).max(1e-30);
        // e^(-r/d) = (e^(-r/3d))^3: one exponential, not two. The cube
        // of a value clamped to e^-20 (so never subnormal: e^-60), kept
        // only where e^(-r/d) is above `EXP_CUT` (as `exp_weight` does).
        let x = exp_weight(self.b * rr);
        let xc = x.max(CUBE_CUT);
        let x3 = if x >= CUBE_CUT { xc * xc * xc } else { 0.0 };
        (x3 + x) / rr
    }
}

/// `e^x` for `x <= 0` to about 2 ulp, branch-free so that it vectorises
/// (Cephes' `expf`: `x = n ln 2 + g`, a degree-5 polynomial for `e^g`,
/// times `2^n` built in the exponent bits). `x` is first brought into
/// `[-87, 0]` by plain selects that also send NaN to -87 (`e^-87`,
/// 1.6e-38: nothing): a NaN argument is then a zero weight, not a NaN
/// sum. `x` above -1e-8 is taken as 0
/// (`e^x` rounds to 1 there anyway; a tiny `g` would make `g * g`
/// subnormal, which costs ~100 cycles a lane). `n` is read out of the
/// float's bits (`n + 1.5 * 2^23` holds `n` in its low mantissa bits),
/// not by `as i32`, whose saturation rule kept the pair loop from
/// vectorising.
#[inline(always)]
pub fn exp_approx(x: f32) -> f32 {
    let x = if x > -87.0 { x } else { -87.0 };
    let x = if x < -1e-8 { x } else { 0.0 };
    let n = (x * std::f32::consts::LOG2_E + 0.5).floor();
    let g = x - n * 0.693_359_4 - n * -2.121_944_4e-4;
    let p = 1.987_569_1e-4_f32;
    let p = p * g + 1.398_199_9e-3;
    let p = p * g + 8.333_452e-3;
    let p = p * g + 4.166_579_6e-2;
    let p = p * g + 0.166_666_66;
    let p = p * g + 0.5;
    let e = p * g * g + g + 1.0;
    // n in [-126, 0]: its bits as an integer, then the exponent 2^n.
    const MAGIC: f32 = 12_582_912.0;
    let ni = (n + MAGIC).to_bits().wrapping_sub(MAGIC.to_bits());
    e * f32::from_bits(ni.wrapping_add(127) << 23)
}

/// A kernel's `e^x`: `exp_approx`, 0 below `EXP_CUT`.
#[inline(always)]
pub fn exp_weight(x: f32) -> f32 {
    let e = exp_approx(x);
    if x >= EXP_CUT {
        e
    } else {
        0.0
    }
}

// A leaf's groups fit one `Lanes` (the gather tests them at once).
const _: () = assert!(LEAF <= LANES * LANES);

/// The larger of `a` and `b` (`b` when either is NaN: one instruction,
/// where `f32::max`'s NaN rule costs three).
#[inline(always)]
pub(super) fn maxf(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// How much longer than the cloud's size a kernel's distance is taken in
/// the pair loop (smooth; exp and Burley, times sigma or kappa). Beyond
/// it, every pair's weight is exactly what it is at the cap: smooth's
/// `1 - 3t^2 + 2t^3` rounds to 1 in f32 below `t = 1e-5`, and
/// `exp_approx` is 1 above -1e-8 (for Burley, the size counts the
/// largest `r_min` too: its weight reads `max(r, r_min)`). Without it,
/// `1 / D^2` is subnormal in f32 past `D = 1.8e19` (every pair then
/// costs about 30 times as much) and `sigma / D` is 0 past f32's range.
const CAP_SMOOTH: f64 = 1e5;
/// [`CAP_SMOOTH`] for exp and Burley, times their sigma or kappa.
const CAP_EXP: f64 = 1e8;

/// The kernels of a run, monomorphised.
#[derive(Clone, Copy)]
pub(super) enum Kernels {
    Smooth([SmoothKernel; 3]),
    Exp([ExpKernel; 3]),
    Burley([BurleyKernel; 3]),
}

/// The shortest kernel distance the pair loop takes (scene units).
pub(super) const MIN_KERNEL: f64 = 1e-18;

impl Kernels {
    /// The kernels at distances `ld` (`ld1` when `single`), each taken
    /// no longer than `size` (the cloud's diagonal) times [`CAP_SMOOTH`]
    /// (exp, Burley: [`CAP_EXP`]).
    pub(super) fn new(f: Falloff, ld: [f64; 3], ld1: f64, single: bool, size: f64) -> Kernels {
        let cap = size
            * match f {
                Falloff::Smooth => CAP_SMOOTH,
                Falloff::Exp { sigma: k } | Falloff::Burley { kappa: k } => CAP_EXP * k.max(1.0),
            };
        // No kernel is shorter than `MIN_KERNEL`: `1 / D^2` stays an f32
        // (a kernel capped by a cloud only 1e-25 wide made it inf, and
        // `0 * inf` a NaN weight, read as 0). The pairs of such a cloud
        // are all closer than f32 distances resolve (their squares are
        // 0), so they weigh what a pair at r = 0 does, as the points of a
        // cloud of one position do.
        let d = |c: usize| {
            let l = if single { ld1 } else { ld[c] };
            l.min(cap).max(MIN_KERNEL) as f32
        };
        let safe = |d: f32| if d > 0.0 { d } else { 1.0 };
        match f {
            Falloff::Smooth => Kernels::Smooth([0, 1, 2].map(|c| {
                let inv = 1.0 / safe(d(c));
                SmoothKernel {
                    inv,
                    inv2: inv * inv,
                }
            })),
            Falloff::Exp { sigma } => Kernels::Exp([0, 1, 2].map(|c| ExpKernel {
                c: -(sigma as f32) / safe(d(c)),
            })),
            Falloff::Burley { kappa } => Kernels::Burley([0, 1, 2].map(|c| BurleyKernel {
                b: -(kappa as f32) / safe(d(c)) / 3.0,
            })),
        }
    }
}
