//! The pair loop: a receiver leaf gathers the source groups within its
//! reach once, then each group of eight receivers (one a vector lane)
//! sums the sources within reach of its bounding sphere, one source
//! broadcast to the eight lanes at a time. The f32 lanes are added into
//! f64 every [`FLUSH`] sources: the rounding does not grow with the
//! neighbour count. Channels of different reaches (t_rgb) take the
//! sources in tiers, so that a short channel evaluates only the pairs
//! its reach covers.

use super::columns::Columns;
use super::gather::Gathered;
use super::lanes::{madd, maxf, Kernel, Kernels, Lanes, LANES};
use super::normalise::Normaliser;
#[cfg(target_arch = "x86_64")]
use super::simd::Avx2;
use super::simd::Baseline;
use super::simd::{Detected, Isa};
use super::tree::Leaf;

/// What the pair loop needs to know about the run.
#[derive(Clone, Copy)]
pub(super) struct Setup {
    /// Channel distances (0: the channel gets nothing).
    pub ld: [f32; 3],
    pub ld1: f32,
    pub inv_ld1: f32,
    /// How far a source can add anything: `reach(falloff, ld1)`.
    pub reach: f32,
    /// Each channel's own reach, `reach(falloff, ld[c])`.
    pub reaches: [f32; 3],
    /// The channels by reach, the longest first.
    pub by_reach: [usize; 3],
    pub bounce: f32,
    /// One kernel for all channels (not t_rgb, or equal distances).
    pub single: bool,
    /// Every source's `illum` has three equal channels (summed once).
    pub grey: bool,
    pub local: bool,
}

/// A group of receivers in the lanes (leaf frame); padding lanes sit far
/// away and their sums are dropped.
struct Receivers {
    x: Lanes,
    y: Lanes,
    z: Lanes,
    nx: Lanes,
    ny: Lanes,
    nz: Lanes,
}

/// The receivers' sums: f32 lanes flushed into f64 every `FLUSH`
/// sources, so no lane ever holds more than `FLUSH` terms and the
/// rounding does not grow with the neighbour count. `[0..3]` are the
/// channels, `[3..6]` the local areas.
struct ReceiverSums {
    total: [[f64; LANES]; 6],
}

/// Sources summed in f32 before a flush into f64.
const FLUSH: usize = 64;

/// Adds, for the eight receivers `r`, the sources of `g` in `list`: a
/// receiver beyond reach of a source gets a zero term from it (the
/// kernel clips itself or is masked). `K` is the kernel at `ld1`
/// (`SINGLE`: every channel) or per channel, then for the first `NCH`
/// channels of `ord` only (those whose reach covers the list; the
/// accumulators are in `ord`'s order). `I` is the instruction set.
/// Returns the pairs evaluated.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn sum_sources<
    K: Kernel,
    const SINGLE: bool,
    const GREY: bool,
    const BOUNCE: bool,
    const LOCAL: bool,
    const NCH: usize,
    I: Isa,
>(
    s: &Setup,
    ks: &[K; 3],
    ord: [usize; 3],
    g: &Gathered,
    list: &[u32],
    r: &Receivers,
    acc: &mut ReceiverSums,
) -> u64 {
    let n = g.n;
    let r2max = s.ld1 * s.ld1;
    // (Grey: only the first channel is gathered and summed; one kernel
    // takes the channels in their own order.)
    let ord = if SINGLE { [0, 1, 2] } else { ord };
    // (Plain indexing, not `array::map`: its closures are not inlined
    // into the AVX2 loop, which then cannot see the columns' lengths or
    // the distances and runs a lane at a time.)
    let (c0, c1, c2) = (ord[0], ord[1], ord[2]);
    let all = !GREY as usize;
    let (q0, q1, q2) = (&g.q[c0][..n], &g.q[c1][..n * all], &g.q[c2][..n * all]);
    let ld = [s.ld[c0], s.ld[c1], s.ld[c2]];
    let d2 = [ld[0] * ld[0], ld[1] * ld[1], ld[2] * ld[2]];
    let kc = [ks[c0], ks[c1], ks[c2]];
    // Columns a run does not use are empty: sliced only when used.
    let used = |v: &'_ [f32], on: bool| -> usize {
        if on {
            n.min(v.len())
        } else {
            0
        }
    };
    let (nx, ny, nz) = (
        &g.nx[..used(&g.nx, BOUNCE)],
        &g.ny[..used(&g.ny, BOUNCE)],
        &g.nz[..used(&g.nz, BOUNCE)],
    );
    let ar = &g.a[..used(&g.a, LOCAL)];
    let rm = &g.rmin[..used(&g.rmin, K::RMIN)];
    let (x, y, z) = (&g.x[..n], &g.y[..n], &g.z[..n]);
    let z8: Lanes = [0.0; LANES];
    for chunk in list.chunks(FLUSH) {
        // The channels' sums and the area sums, in `ord`'s order (named
        // lanes: arrays of them keep the loop from vectorising).
        let (mut s0, mut s1, mut s2, mut a0, mut a1, mut a2) = (z8, z8, z8, z8, z8, z8);
        for &i in chunk {
            let i = i as usize;
            // (One check: every column is `n` long.)
            assert!(i < n);
            let (sx, sy, sz) = (x[i], y[i], z[i]);
            let rmi = if K::RMIN { rm[i] } else { 0.0 };
            // (The kernel weights and reach masks for the area sums.)
            let (mut wl, mut wl1, mut wl2, mut ml) = (z8, z8, z8, z8);
            for k in 0..LANES {
                let dx = r.x[k] - sx;
                let dy = r.y[k] - sy;
                let dz = r.z[k] - sz;
                let r2 = madd::<I>(dz, dz, madd::<I>(dy, dy, dx * dx));
                // A kernel that clips itself needs no reach mask (m is
                // then the constant 1, folded away).
                let m = if K::CLIPS || r2 <= r2max { 1.0f32 } else { 0.0 };
                // (A plain select: `f32::min`'s NaN rule costs two more
                // instructions; r2 is never NaN here.)
                let r2c = if K::CLIPS || r2 < r2max { r2 } else { r2max };
                // (Not computed where unused: one kernel takes `r2c`.)
                let d = r2c.sqrt();
                let kb = if BOUNCE {
                    let nn = madd::<I>(r.nz[k], nz[i], madd::<I>(r.ny[k], ny[i], r.nx[k] * nx[i]));
                    let nl =
                        madd::<I>(r.nz[k], dz, madd::<I>(r.ny[k], dy, r.nx[k] * dx)) * s.inv_ld1;
                    let b = 1.0 - (1.0 - nn) * (1.0 - nl) * 0.5;
                    madd::<I>(s.bounce, b - 1.0, 1.0).max(0.0) * m
                } else {
                    m
                };
                if SINGLE {
                    let w = kc[0].w2::<I>(r2c, rmi);
                    wl[k] = w;
                    let kw = kb * w;
                    s0[k] = madd::<I>(q0[i], kw, s0[k]);
                    if !GREY {
                        s1[k] = madd::<I>(q1[i], kw, s1[k]);
                        s2[k] = madd::<I>(q2[i], kw, s2[k]);
                    }
                    if LOCAL {
                        ml[k] = m;
                    }
                } else {
                    // Per channel: inside its own distance (0 costs
                    // nothing: its kernel is never used, its mask is 0).
                    let mc = |j: usize| if K::CLIPS || r2 <= d2[j] { 1.0f32 } else { 0.0 };
                    let wc = |j: usize| {
                        if ld[j] > 0.0 {
                            kc[j].w::<I>(d, rmi) * mc(j)
                        } else {
                            0.0
                        }
                    };
                    let w0 = wc(0);
                    s0[k] = madd::<I>(q0[i], kb * w0, s0[k]);
                    let w1 = if NCH >= 2 { wc(1) } else { 0.0 };
                    if NCH >= 2 {
                        s1[k] = madd::<I>(q1[i], kb * w1, s1[k]);
                    }
                    let w2 = if NCH >= 3 { wc(2) } else { 0.0 };
                    if NCH >= 3 {
                        s2[k] = madd::<I>(q2[i], kb * w2, s2[k]);
                    }
                    if LOCAL {
                        (wl[k], wl1[k], wl2[k]) = (w0, w1, w2);
                    }
                }
            }
            // The area sums in a loop of their own: in the one above
            // they keep the compiler from vectorising it with exp and
            // Burley (the variants benchmark, `BENCH_VARIANTS=1`).
            if LOCAL {
                for k in 0..LANES {
                    if SINGLE {
                        a0[k] = madd::<I>(ar[i], ml[k] * wl[k], a0[k]);
                    } else {
                        a0[k] = madd::<I>(ar[i], wl[k], a0[k]);
                        if NCH >= 2 {
                            a1[k] = madd::<I>(ar[i], wl1[k], a1[k]);
                        }
                        if NCH >= 3 {
                            a2[k] = madd::<I>(ar[i], wl2[k], a2[k]);
                        }
                    }
                }
            }
        }
        // (Through a black box: otherwise the compiler matches the f32
        // lanes to the f64 sums' four-wide vectors and runs the whole
        // loop four lanes at a time.)
        let lanes = std::hint::black_box([s0, s1, s2, a0, a1, a2]);
        for (j, v) in lanes.into_iter().enumerate() {
            let t = &mut acc.total[ord[j % 3] + j / 3 * 3];
            for k in 0..LANES {
                t[k] += v[k] as f64;
            }
        }
    }
    (list.len() * LANES) as u64
}

/// Sums every receiver of the task's leaf `rl`: the source leaves `near`
/// (each in its own frame) and the pseudo-sources (in `rl`'s frame). The
/// source groups within reach of the leaf are gathered into the scratch
/// once; each group of eight receivers then sums those within reach of
/// its bounding sphere, the receivers in the lanes. Writes the
/// receivers' `ssM` (the normaliser of their sums) to `out` (the leaf's
/// lanes); returns the pairs evaluated. The order of the sums is fixed by
/// the leaves, so they do not depend on the thread count.
#[inline(always)]
fn sum_leaf_as<
    K: Kernel,
    const SINGLE: bool,
    const GREY: bool,
    const BOUNCE: bool,
    const LOCAL: bool,
    I: Isa,
>(
    isa: I,
    ks: &[K; 3],
    task: LeafTask<'_>,
) -> u64 {
    let LeafTask {
        run,
        leaf: rl,
        near,
        pseudo: ps,
        scratch: gat,
        out,
    } = task;
    let (s, cols, norm) = (&run.setup, run.cols, &run.norm);
    let mut pairs = 0u64;
    let end = rl.col + rl.len;
    let len = cols.id.len();
    // The leaf's box in its own frame, grown by the reach (and a little
    // for rounding).
    let grow = 1e-5 * (rl.hi - rl.lo).max_element() + 1e-6 * s.ld1 as f64;
    let blo = (rl.lo - rl.origin - grow).as_vec3().to_array();
    let bhi = (rl.hi - rl.origin + grow).as_vec3().to_array();
    let reach = s.reach * (1.0 + 1e-6);
    gat.clear();
    for nb in near {
        let src_end = nb.col + nb.src;
        // The source leaf's groups' spheres, all at once (a leaf has at
        // most `LANES` groups; the columns are padded after the last),
        // their centres in this leaf's frame, against its box.
        let g0 = nb.col / LANES;
        let l = |v: &[f32]| -> Lanes { v[g0..g0 + LANES].try_into().expect("padded") };
        let [sx, sy, sz, sr] = [0, 1, 2, 3].map(|a| l(&cols.sph[a]));
        let (mut d2, mut rr) = ([0.0; LANES], [0.0; LANES]);
        for k in 0..LANES {
            let (ox, oy, oz) = (sx[k] - nb.off[0], sy[k] - nb.off[1], sz[k] - nb.off[2]);
            let gx = maxf(maxf(blo[0] - ox, ox - bhi[0]), 0.0);
            let gy = maxf(maxf(blo[1] - oy, oy - bhi[1]), 0.0);
            let gz = maxf(maxf(blo[2] - oz, oz - bhi[2]), 0.0);
            d2[k] = gx * gx + gy * gy + gz * gz;
            rr[k] = (reach + sr[k]) * (reach + sr[k]);
        }
        let mut near = isa.le_mask(&d2, &rr) & ((1u32 << nb.src.div_ceil(LANES)) - 1);
        while near != 0 {
            let g = nb.col + near.trailing_zeros() as usize * LANES;
            near &= near - 1;
            let valid = (1u32 << (src_end - g).min(LANES)) - 1;
            gat.group(cols, g, nb.off, valid, [!GREY, BOUNCE, LOCAL, K::RMIN]);
        }
    }
    gat.seal();
    // The channels by reach, longest first, and the reaches' tiers: the
    // sources of tier `t` are summed for the channels `ord[..=t]`.
    let ord = s.by_reach;
    for gs in (rl.col..end).step_by(LANES) {
        let h = &cols.hot[gs / LANES];
        let [cx, cy, cz, cr] = [0, 1, 2, 3].map(|a| cols.sph[a][gs / LANES]);
        let within = |t: usize| {
            let d = s.reaches[ord[t]] * (1.0 + 1e-6) + cr;
            if s.ld[ord[t]] > 0.0 {
                d * d
            } else {
                -1.0
            }
        };
        if SINGLE {
            gat.select(isa, [cx, cy, cz], reach + cr, [(reach + cr) * (reach + cr)]);
        } else {
            gat.select(
                isa,
                [cx, cy, cz],
                reach + cr,
                [within(0), within(1), within(2)],
            );
        }
        assert!(gs + LANES <= len);
        let lanes = |v: &[f32]| -> Lanes { v[gs..gs + LANES].try_into().expect("a group") };
        let zero = [0.0; LANES];
        let r = Receivers {
            x: h.x,
            y: h.y,
            z: h.z,
            nx: if BOUNCE { lanes(&cols.nx) } else { zero },
            ny: if BOUNCE { lanes(&cols.ny) } else { zero },
            nz: if BOUNCE { lanes(&cols.nz) } else { zero },
        };
        let mut acc = ReceiverSums {
            total: [[0.0; LANES]; 6],
        };
        // The sources of `g` in `list`, for the first `nch` channels
        // by reach (one kernel: all).
        macro_rules! sum {
            ($single:tt, $nch:literal, $g:expr, $list:expr) => {
                sum_sources::<K, $single, GREY, BOUNCE, LOCAL, $nch, I>(
                    s, ks, ord, $g, $list, &r, &mut acc,
                )
            };
        }
        if SINGLE {
            pairs += sum!(true, 1, gat, gat.list(0));
        } else {
            pairs += sum!(false, 1, gat, gat.list(0));
            pairs += sum!(false, 2, gat, gat.list(1));
            pairs += sum!(false, 3, gat, gat.list(2));
        }
        if let Some(ps) = ps {
            // (Every channel: pseudo-sources are not in tiers.)
            pairs += sum!(SINGLE, 3, ps, ps.list(0));
        }
        if GREY {
            // (The other channels' sums would be the same numbers.)
            acc.total[1] = acc.total[0];
            acc.total[2] = acc.total[0];
        }
        for k in 0..(end - gs).min(LANES) {
            out[gs - rl.col + k] = norm.apply(&acc.total.map(|t| t[k]));
        }
    }
    pairs
}

/// Sums the task's leaf with the run's kernel and switches, on
/// instruction set `isa`.
#[inline(always)]
pub(super) fn sum_leaf<I: Isa>(isa: I, task: LeafTask<'_>) -> u64 {
    let s = &task.run.setup;
    // Grey light is summed in one channel, and only with one kernel.
    let grey = s.single && s.grey;
    macro_rules! go {
        ($ks:expr; $(($si:literal, $g:literal, $b:literal, $l:literal)),*) => {
            match (s.single, grey, s.bounce > 0.0, s.local) {
                $(($si, $g, $b, $l) => sum_leaf_as::<_, $si, $g, $b, $l, I>(isa, $ks, task),)*
                (false, true, _, _) => unreachable!("grey is single"),
            }
        };
        ($ks:expr) => {
            go!($ks;
                (true, true, false, false), (true, true, false, true),
                (true, true, true, false), (true, true, true, true),
                (true, false, false, false), (true, false, false, true),
                (true, false, true, false), (true, false, true, true),
                (false, false, false, false), (false, false, false, true),
                (false, false, true, false), (false, false, true, true))
        };
    }
    match task.run.kernels {
        Kernels::Smooth(k) => go!(&k),
        Kernels::Exp(k) => go!(&k),
        Kernels::Burley(k) => go!(&k),
    }
}

/// A source leaf as a receiver leaf sees it: its first column, its
/// sources (the first `src` lanes), and the offset from its origin to the
/// receiver leaf's.
pub(super) struct Near {
    col: usize,
    src: usize,
    off: [f32; 3],
}

impl Near {
    /// Source leaf `s` as receiver leaf `rl` sees it.
    pub(super) fn of(s: &Leaf, rl: &Leaf) -> Near {
        Near {
            col: s.col,
            src: s.src,
            off: (rl.origin - s.origin).as_vec3().to_array(),
        }
    }
}

/// What every leaf of a run shares.
pub(super) struct Run<'a> {
    pub setup: Setup,
    pub kernels: Kernels,
    pub cols: &'a Columns,
    pub norm: Normaliser,
    /// The instruction set the pair loop runs on.
    pub isa: Detected,
}

/// One receiver leaf's work: the run, the leaf, the source leaves in its
/// reach and the pseudo-sources standing in for clusters (approximate
/// method), the scratch the sources are gathered into, and where the
/// leaf's `ssM` goes (one row a lane of the leaf).
pub(super) struct LeafTask<'a> {
    pub run: &'a Run<'a>,
    pub leaf: &'a Leaf,
    pub near: &'a [Near],
    pub pseudo: Option<&'a Gathered>,
    pub scratch: &'a mut Gathered,
    pub out: &'a mut [[f32; 3]],
}
impl Detected {
    /// Sums a leaf (see [`sum_leaf`]) on this instruction set.
    pub(super) fn sum_leaf(self, task: LeafTask<'_>) -> u64 {
        match self {
            Detected::Baseline => sum_leaf(Baseline, task),
            // SAFETY: `avx2` proves the CPU has the loop's features.
            #[cfg(target_arch = "x86_64")]
            Detected::Avx2(avx2) => unsafe { sum_leaf_avx2(avx2, task) },
        }
    }
}

/// [`sum_leaf`] compiled with AVX2, FMA, POPCNT and BMI1 enabled, so that
/// the pair loop's lanes become 256-bit vectors.
///
/// # Safety
/// The CPU must have AVX2, FMA, POPCNT and BMI1 (an [`Avx2`] value is the
/// proof: only [`detect`] makes one).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma,popcnt,bmi1")]
unsafe fn sum_leaf_avx2(avx2: Avx2, task: LeafTask<'_>) -> u64 {
    sum_leaf(avx2, task)
}
