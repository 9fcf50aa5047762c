//! The sources a receiver leaf sums, gathered into its own frame, and
//! the lists of those within reach of each group of receivers.

use super::columns::{padded, Columns, FAR};
use super::lanes::{Lanes, LANES};
use super::simd::Isa;
/// A cluster of the approximate method standing in for its sources.
#[derive(Clone, Copy, Debug)]
pub(super) struct PseudoSource {
    /// Position in the receiver leaf's frame.
    pub pos: [f32; 3],
    /// The sources' mean normal.
    pub n: [f32; 3],
    /// `sum illum * ptarea`.
    pub q: [f32; 3],
    /// `sum ptarea`.
    pub a: f32,
    /// Burley's `r_min` for that area.
    pub rmin: f32,
}

/// The sources a receiver leaf sums, gathered from the source groups
/// within its reach into its frame, one column a value: the pair loop
/// broadcasts each source to the eight receivers in the lanes. Whole
/// groups are copied (`n` lanes), each with its bounding sphere (in the
/// leaf's frame) and its source lanes (a bit a lane); each group of
/// receivers then lists in `idx` the lanes it sums (those within reach
/// of its bounding sphere), in tiers by distance when the channels have
/// reaches of their own. Columns a run does not use are not written.
#[derive(Default)]
pub(super) struct Gathered {
    pub(super) n: usize,
    pub(super) x: Vec<f32>,
    pub(super) y: Vec<f32>,
    pub(super) z: Vec<f32>,
    pub(super) q: [Vec<f32>; 3],
    pub(super) nx: Vec<f32>,
    pub(super) ny: Vec<f32>,
    pub(super) nz: Vec<f32>,
    pub(super) a: Vec<f32>,
    pub(super) rmin: Vec<f32>,
    /// Per copied group: sphere (centre, radius; padded to whole lanes
    /// with spheres far away) and source lanes.
    pub(super) sx: Vec<f32>,
    pub(super) sy: Vec<f32>,
    pub(super) sz: Vec<f32>,
    pub(super) sr: Vec<f32>,
    pub(super) valid: Vec<u32>,
    /// The lanes summed, `m[t]` of them in tier `t` (see `select`;
    /// pseudo-sources and a single reach use tier 0 only).
    pub(super) idx: [Vec<u32>; TIERS],
    pub(super) m: [usize; TIERS],
}

/// Lists of lanes by distance: one a channel reach.
pub(super) const TIERS: usize = 3;

impl Gathered {
    pub(super) fn clear(&mut self) {
        self.n = 0;
        self.m = [0; TIERS];
    }

    /// Tier `t`'s lanes.
    #[inline(always)]
    pub(super) fn list(&self, t: usize) -> &[u32] {
        &self.idx[t][..self.m[t]]
    }

    /// Room for `more` lanes after the first `n`.
    fn room(&mut self, more: usize) {
        let want = self.n + more;
        if self.x.len() < want {
            let len = want.max(2 * self.x.len());
            for v in [&mut self.x, &mut self.y, &mut self.z] {
                v.resize(len, 0.0);
            }
            for v in &mut self.q {
                v.resize(len, 0.0);
            }
            for v in [
                &mut self.nx,
                &mut self.ny,
                &mut self.nz,
                &mut self.a,
                &mut self.rmin,
            ] {
                v.resize(len, 0.0);
            }
            // (`select` writes eight at a time.)
            for v in &mut self.idx {
                v.resize(len + LANES, 0);
            }
            // A sphere a group, padded to whole lanes (`seal`).
            let groups = len / LANES + LANES;
            for v in [&mut self.sx, &mut self.sy, &mut self.sz, &mut self.sr] {
                v.resize(groups, 0.0);
            }
            self.valid.resize(groups, 0);
        }
    }

    /// Copies a whole group of sources (lanes `c..c + LANES` of `cols`,
    /// `valid` the source lanes), moved by `-off`; the second and third
    /// channels of `illum * ptarea` (`with_q12`: not when grey), the normals
    /// (`with_n`), areas (`with_a`) and Burley's `r_min` (`with_rm`) when
    /// the run reads them.
    #[inline(always)]
    pub(super) fn group(
        &mut self,
        cols: &Columns,
        c: usize,
        off: [f32; 3],
        valid: u32,
        [with_q12, with_n, with_a, with_rm]: [bool; 4],
    ) {
        self.room(LANES);
        let (n, h) = (self.n, &cols.hot[c / LANES]);
        let put = |v: &mut Vec<f32>, src: &Lanes, d: f32| {
            let dst: &mut [f32; LANES] = (&mut v[n..n + LANES]).try_into().expect("room");
            for k in 0..LANES {
                dst[k] = src[k] - d;
            }
        };
        put(&mut self.x, &h.x, off[0]);
        put(&mut self.y, &h.y, off[1]);
        put(&mut self.z, &h.z, off[2]);
        put(&mut self.q[0], &h.q[0], 0.0);
        if with_q12 {
            put(&mut self.q[1], &h.q[1], 0.0);
            put(&mut self.q[2], &h.q[2], 0.0);
        }
        let lanes = |v: &[f32]| -> Lanes { v[c..c + LANES].try_into().expect("a group") };
        if with_n {
            put(&mut self.nx, &lanes(&cols.nx), 0.0);
            put(&mut self.ny, &lanes(&cols.ny), 0.0);
            put(&mut self.nz, &lanes(&cols.nz), 0.0);
        }
        if with_a {
            put(&mut self.a, &lanes(&cols.a), 0.0);
        }
        if with_rm {
            put(&mut self.rmin, &lanes(&cols.rmin), 0.0);
        }
        let [sx, sy, sz, sr] = [0, 1, 2, 3].map(|a| cols.sph[a][c / LANES]);
        let j = n / LANES;
        (self.sx[j], self.sy[j], self.sz[j], self.sr[j]) =
            (sx - off[0], sy - off[1], sz - off[2], sr);
        self.valid[j] = valid;
        self.n += LANES;
    }

    /// Pads the spheres to whole lanes (far away: never within reach).
    pub(super) fn seal(&mut self) {
        let g = self.n / LANES;
        for j in g..padded(g).min(self.sx.len()) {
            (self.sx[j], self.sy[j], self.sz[j], self.sr[j]) = (FAR, FAR, FAR, 0.0);
            self.valid[j] = 0;
        }
    }

    /// Lists in `idx` the lanes within reach of `centre` (leaf frame):
    /// the groups whose spheres come within `reach`, then their lanes
    /// within distance `r2[0]` (squared; descending). With `T` tiers,
    /// tier `t` gets the lanes within `r2[t]` but not within `r2[t + 1]`,
    /// so that a pair loop sums tier `t` for the channels whose reach
    /// covers it. A negative `r2[t]` takes nothing into tier `t` (and
    /// leaves its lanes to the tier before).
    #[inline(always)]
    pub(super) fn select<I: Isa, const T: usize>(
        &mut self,
        isa: I,
        centre: [f32; 3],
        reach: f32,
        r2: [f32; T],
    ) {
        let [cx, cy, cz] = centre;
        self.m = [0; TIERS];
        if self.n == 0 {
            return;
        }
        let n = self.n;
        let (x, y, z) = (&self.x[..n], &self.y[..n], &self.z[..n]);
        let mut r2l = [[0.0; LANES]; T];
        for t in 0..T {
            r2l[t] = [r2[t]; LANES];
        }
        let r2 = r2l;
        let mut m = [0; T];
        let ng = padded(n / LANES);
        for j0 in (0..ng).step_by(LANES) {
            let g = |v: &[f32]| -> Lanes { v[j0..j0 + LANES].try_into().expect("sealed") };
            let (sx, sy, sz, sr) = (g(&self.sx), g(&self.sy), g(&self.sz), g(&self.sr));
            let (mut d2, mut rr) = ([0.0; LANES], [0.0; LANES]);
            for k in 0..LANES {
                let (dx, dy, dz) = (sx[k] - cx, sy[k] - cy, sz[k] - cz);
                d2[k] = dx * dx + dy * dy + dz * dz;
                rr[k] = (reach + sr[k]) * (reach + sr[k]);
            }
            // (Not the padding spheres: a reach beyond f32's range, or
            // beyond `FAR`, would take them in.)
            let live = (n.div_ceil(LANES) - j0).min(LANES);
            let mut near = isa.le_mask(&d2, &rr) & ((1u32 << live) - 1);
            while near != 0 {
                let k = near.trailing_zeros() as usize;
                near &= near - 1;
                let (j, valid) = (j0 + k, self.valid[j0 + k]);
                let base = j * LANES;
                let l = |v: &[f32]| -> Lanes { v[base..base + LANES].try_into().expect("a group") };
                let (gx, gy, gz) = (l(x), l(y), l(z));
                let mut e2 = [0.0; LANES];
                for i in 0..LANES {
                    let (ex, ey, ez) = (gx[i] - cx, gy[i] - cy, gz[i] - cz);
                    e2[i] = ex * ex + ey * ey + ez * ez;
                }
                // (A loop, not `map`: its closure would not be inlined
                // into the AVX2 code, nor the intrinsics into it.)
                let mut within = [0u32; T];
                for t in 0..T {
                    within[t] = isa.le_mask(&e2, &r2[t]) & valid;
                }
                for t in 0..T {
                    let bits = if t + 1 < T {
                        within[t] & !within[t + 1]
                    } else {
                        within[t]
                    };
                    // The lanes, packed to the front (branch free: eight
                    // written, as many kept as there are bits).
                    let (to, from) = (
                        &mut self.idx[t][m[t]..m[t] + LANES],
                        &SET_BIT_POSITIONS[bits as usize],
                    );
                    for i in 0..LANES {
                        to[i] = (base + from[i] as usize) as u32;
                    }
                    m[t] += bits.count_ones() as usize;
                }
            }
        }
        self.m[..T].copy_from_slice(&m);
    }

    /// Adds a pseudo-source, every column filled, summed by every
    /// receiver (no spheres: `select` is not used on these).
    pub(super) fn point(&mut self, ps: PseudoSource) {
        let PseudoSource {
            pos: p,
            n,
            q,
            a,
            rmin,
        } = ps;
        self.room(1);
        let i = self.n;
        (self.x[i], self.y[i], self.z[i]) = (p[0], p[1], p[2]);
        for c in 0..3 {
            self.q[c][i] = q[c];
        }
        (self.nx[i], self.ny[i], self.nz[i]) = (n[0], n[1], n[2]);
        (self.a[i], self.rmin[i]) = (a, rmin);
        self.idx[0][i] = i as u32;
        self.n += 1;
        self.m[0] += 1;
    }
}

/// For each 8-bit mask, its set bits' positions in order (then zeros).
const SET_BIT_POSITIONS: [[u8; LANES]; 256] = {
    let mut t = [[0u8; LANES]; 256];
    let mut bits = 0;
    while bits < 256 {
        let (mut k, mut m) = (0, 0);
        while k < LANES {
            if bits >> k & 1 == 1 {
                t[bits][m] = k as u8;
                m += 1;
            }
            k += 1;
        }
        bits += 1;
    }
    t
};

#[cfg(test)]
mod tests {
    use super::*;

    /// Each mask's set bits, in order, at the front.
    #[test]
    fn set_bit_positions_lists_the_set_bits() {
        for bits in 0..256usize {
            let want: Vec<u8> = (0..LANES as u8).filter(|&k| bits >> k & 1 == 1).collect();
            assert_eq!(
                &SET_BIT_POSITIONS[bits][..want.len()],
                &want[..],
                "{bits:#b}"
            );
        }
    }
}
