//! A parallel, stable LSD radix sort of `u64` keys by a range of their
//! bits: what the Morton orders (ssmulti's leaves) are sorted with.
//!
//! Keys built as `code << index_bits | index` in index order are already
//! in order in their low bits, so only the code's bits need passes (11
//! bits a pass), against a comparison sort's ~20 compares a key; and
//! where the code's high bits already tell most keys apart, those alone
//! (`sort_bits`) and then the short runs that share them (`sort_runs`).
//! The result does not depend on the thread count (a sort has one
//! answer).

use rayon::prelude::*;

use crate::disjoint::Disjoint;

/// Below this many keys one thread sorts (the passes are too short to
/// share).
const PAR_MIN: usize = 1 << 15;

/// Widest digit: 2^11 counters a chunk stay in L1. (Nine bits, five
/// passes for 42 bits, are faster at 100k points but slower at 1M in
/// ssmulti's build: benches/results/HISTORY.md, "Measurements behind the
/// code".)
const MAX_DIGIT: u32 = 11;

/// From this many keys with more than one digit to sort by, the first
/// pass goes by the top digit and each of its buckets is then sorted by
/// the rest on its own, in cache: one pass through memory instead of
/// three for the grids' keys of millions of points.
const MSD_MIN: usize = 1 << 18;
/// Buckets up to this many keys are sorted by insertion.
const INSERTION_MAX: usize = 24;

/// Sorts `keys` by bits `lo..hi` (`hi <= 64`), stably: keys equal there
/// keep their order. With `lo == 0` and `hi == 64` that is a plain sort.
pub fn sort_bits(keys: &mut Vec<u64>, lo: u32, hi: u32) {
    let hi = hi.min(64);
    let n = keys.len();
    if hi <= lo || n < 2 {
        return;
    }
    if n < MSD_MIN || hi - lo <= MAX_DIGIT {
        return lsd(keys, lo, hi);
    }
    let shift = hi - MAX_DIGIT;
    lsd(keys, shift, hi);
    // The buckets of the top digit, each sorted by the bits below it.
    let top = |k: u64| k >> shift & ((1u64 << MAX_DIGIT) - 1);
    let mut buckets: Vec<&mut [u64]> = Vec::with_capacity(1 << MAX_DIGIT);
    let mut rest: &mut [u64] = keys;
    while !rest.is_empty() {
        let d = top(rest[0]);
        let len = rest.partition_point(|&k| top(k) == d);
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(len);
        buckets.push(head);
        rest = tail;
    }
    // A bucket the top digit did not split (points crowded in one corner
    // of a box an outlier stretches) is sorted by all threads, as a sort
    // of its own; the rest one bucket a thread.
    let (big, small): (Vec<&mut [u64]>, Vec<&mut [u64]>) =
        buckets.into_iter().partition(|b| b.len() >= MSD_MIN);
    for b in big {
        let mut v = b.to_vec();
        lsd(&mut v, lo, shift);
        b.copy_from_slice(&v);
    }
    small
        .into_par_iter()
        .for_each_init(Default::default, |scratch, b| {
            sort_small(b, scratch, lo, shift)
        });
}

/// `keys` (a bucket, mostly of a few thousand, in cache) sorted stably by bits
/// `lo..hi`, on one thread, with `scratch`'s keys as the second buffer
/// and its counters for the digits (kept from bucket to bucket).
fn sort_small(keys: &mut [u64], scratch: &mut (Vec<u64>, Vec<usize>), lo: u32, hi: u32) {
    let (scratch, counts) = scratch;
    let n = keys.len();
    if hi <= lo || n < 2 {
        return;
    }
    let mask = |k: u64| (k >> lo) & (u64::MAX >> (64 - (hi - lo)));
    if n <= INSERTION_MAX {
        for i in 1..n {
            let k = keys[i];
            let mut j = i;
            while j > 0 && mask(keys[j - 1]) > mask(k) {
                keys[j] = keys[j - 1];
                j -= 1;
            }
            keys[j] = k;
        }
        return;
    }
    // Digits of 8 bits for a bucket of a few thousand: 256 counters to
    // clear and add up a pass, where 2048 would cost as much as the keys.
    let digit_bits = if n < 4096 { 8 } else { MAX_DIGIT };
    let passes = (hi - lo).div_ceil(digit_bits);
    let width = (hi - lo).div_ceil(passes);
    scratch.clear();
    scratch.resize(n, 0);
    if counts.len() < 1 << width {
        counts.resize(1 << width, 0);
    }
    let (mut src, mut dst): (&mut [u64], &mut [u64]) = (keys, &mut scratch[..]);
    let mut swapped = false;
    for p in 0..passes {
        let shift = lo + p * width;
        let w = width.min(hi - shift);
        let digit = |k: u64| ((k >> shift) & ((1u64 << w) - 1)) as usize;
        counts[..1 << w].fill(0);
        for &k in src.iter() {
            counts[digit(k)] += 1;
        }
        if counts[..1 << w].contains(&n) {
            continue;
        }
        let mut at = 0;
        for c in &mut counts[..1 << w] {
            let here = *c;
            *c = at;
            at += here;
        }
        for &k in src.iter() {
            let d = digit(k);
            dst[counts[d]] = k;
            counts[d] += 1;
        }
        std::mem::swap(&mut src, &mut dst);
        swapped = !swapped;
    }
    if swapped {
        // The sorted keys are in `scratch`.
        dst.copy_from_slice(src);
    }
}

/// `sort_bits` by least significant digits first, every pass through
/// all the keys.
fn lsd(keys: &mut Vec<u64>, lo: u32, hi: u32) {
    let n = keys.len();
    let bits = hi - lo;
    let passes = bits.div_ceil(MAX_DIGIT);
    let width = bits.div_ceil(passes);
    let chunks = if n < PAR_MIN {
        1
    } else {
        rayon::current_num_threads().clamp(1, 64)
    };
    let chunk = n.div_ceil(chunks);
    // (Not zeroed: the first pass that runs writes every position before
    // anything reads it.)
    let (mut src, mut dst) = (std::mem::take(keys), Vec::<u64>::with_capacity(n));
    for p in 0..passes {
        let shift = lo + p * width;
        let w = width.min(hi - shift);
        let mask = (1u64 << w) - 1;
        let digit = |k: u64| ((k >> shift) & mask) as usize;
        let count = |c: &[u64]| {
            let mut h = vec![0usize; 1 << w];
            for &k in c {
                h[digit(k)] += 1;
            }
            h
        };
        let hists: Vec<Vec<usize>> = if chunks == 1 {
            vec![count(&src)]
        } else {
            src.par_chunks(chunk).map(count).collect()
        };
        // One digit holding every key: this pass would copy them as they
        // are.
        if (0..1 << w).any(|d| hists.iter().map(|h| h[d]).sum::<usize>() == n) {
            continue;
        }
        // Where each chunk's keys of each digit go: digits in order, and
        // within a digit the chunks in order (stable).
        let mut offsets = vec![vec![0usize; 1 << w]; hists.len()];
        let mut at = 0;
        for d in 0..1 << w {
            for (o, h) in offsets.iter_mut().zip(&hists) {
                o[d] = at;
                at += h[d];
            }
        }
        // SAFETY: `dst` is left alone until the pass is over, and each
        // position belongs to one chunk's run of one digit.
        let out = unsafe { Disjoint::new(&mut dst, n) };
        let place = |(c, mut o): (&[u64], Vec<usize>)| {
            for &k in c {
                let d = digit(k);
                out.write(o[d], k);
                o[d] += 1;
            }
        };
        if chunks == 1 {
            place((&src, offsets.pop().expect("one chunk")));
        } else {
            src.par_chunks(chunk).zip(offsets).for_each(place);
        }
        // SAFETY: the pass wrote all `n` positions (the offsets cover
        // 0..n, each once).
        unsafe { dst.set_len(n) };
        std::mem::swap(&mut src, &mut dst);
    }
    *keys = src;
}

/// Sorts each run of `keys` that agree above bit `shift` (`k >> shift`
/// equal) by the whole key: after `sort_bits(keys, shift, 64)` this
/// completes a full sort, at the cost of the runs alone (where the high
/// bits already separate most keys, a pass or two less). In parallel over
/// pieces cut between runs; the result does not depend on the thread
/// count (a sort has one answer).
pub fn sort_runs(keys: &mut [u64], shift: u32) {
    let n = keys.len();
    if n < 2 || shift == 0 {
        return;
    }
    let top = |k: u64| k.checked_shr(shift).unwrap_or(0);
    let sort = |c: &mut [u64]| {
        let mut s = 0;
        while s < c.len() {
            let mut e = s + 1;
            while e < c.len() && top(c[e]) == top(c[s]) {
                e += 1;
            }
            if e - s > 1 {
                c[s..e].sort_unstable();
            }
            s = e;
        }
    };
    if n < PAR_MIN {
        return sort(keys);
    }
    // Pieces of about n / (4 threads), each cut moved on to a run's start.
    let parts = 4 * rayon::current_num_threads().clamp(1, 64);
    let mut cuts = vec![0];
    for p in 1..parts {
        let mut c = (p * n / parts).max(*cuts.last().expect("one cut"));
        while c > 0 && c < n && top(keys[c - 1]) == top(keys[c]) {
            c += 1;
        }
        cuts.push(c);
    }
    cuts.push(n);
    let mut pieces = Vec::with_capacity(parts);
    let mut rest = keys;
    for w in cuts.windows(2) {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(w[1] - w[0]);
        pieces.push(head);
        rest = tail;
    }
    pieces.into_par_iter().for_each(sort);
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::RngCore;

    fn keys(n: usize, seed: u64, bits: u32) -> Vec<u64> {
        let mut rng = rand_pcg::Pcg32::new(seed, 7);
        (0..n).map(|_| rng.next_u64() >> (64 - bits)).collect()
    }

    #[test]
    fn full_sort_equals_sort_unstable() {
        for n in [0, 1, 2, 100, 5000, 100_000] {
            for bits in [1, 7, 40, 64] {
                let mut a = keys(n, n as u64 + bits as u64, bits);
                let mut b = a.clone();
                sort_bits(&mut a, 0, 64);
                b.sort_unstable();
                assert_eq!(a, b, "n {n} bits {bits}");
            }
        }
    }

    #[test]
    fn high_bits_then_runs_is_a_full_sort() {
        // Few distinct high parts (long runs), many (short runs), and
        // runs across the parallel pieces' first cuts.
        for (n, code_bits) in [
            (10, 2),
            (5000, 3),
            (100_000, 4),
            (100_000, 30),
            (300_000, 1),
        ] {
            let mut a = keys(n, 3 + code_bits as u64, 40);
            let mut b = a.clone();
            // (The top 40 - shift bits: `code_bits` of them vary.)
            let shift = 40 - code_bits;
            sort_bits(&mut a, shift, 64);
            sort_runs(&mut a, shift);
            b.sort_unstable();
            assert_eq!(a, b, "n {n} code bits {code_bits}");
        }
    }

    #[test]
    fn top_digit_first_sorts_like_sort_unstable_and_stably() {
        // Past MSD_MIN: buckets of every size (uniform keys: a few
        // hundred each; a narrow spread: one bucket of them all; a few
        // keys far apart: tiny buckets beside a huge one), sorted by the
        // full key and, with the index below the code, stably.
        let n = MSD_MIN + 12_345;
        let mut rng = rand_pcg::Pcg32::new(3, 3);
        let cases: Vec<(&str, Vec<u64>)> = vec![
            ("uniform", keys(n, 1, 64)),
            ("narrow", keys(n, 2, 13)),
            (
                "skewed",
                (0..n)
                    .map(|i| {
                        if i % 1000 == 0 {
                            rng.next_u64()
                        } else {
                            rng.next_u64() >> 50
                        }
                    })
                    .collect(),
            ),
        ];
        for (name, k) in cases {
            let mut a = k.clone();
            let mut b = k;
            sort_bits(&mut a, 0, 64);
            b.sort_unstable();
            assert_eq!(a, b, "{name}");
        }
        for code_bits in [12, 16, 27, 40] {
            assert_sorts_codes_stably(&keys(n, code_bits as u64, code_bits), code_bits);
        }
        // Buckets of a few equal codes (sorted by insertion) beside one
        // of all the rest.
        let codes: Vec<u64> = (0..n)
            .map(|i| {
                if i % 50 == 0 {
                    (((i / 50) % 2000 + 1) as u64) << 9
                } else {
                    rng.next_u64() >> 55
                }
            })
            .collect();
        assert_sorts_codes_stably(&codes, 20);
    }

    /// `code << 20 | index`, sorted by the code's bits only, must come
    /// out in full order: codes in order, equal codes by index.
    fn assert_sorts_codes_stably(codes: &[u64], code_bits: u32) {
        let mut a: Vec<u64> = codes
            .iter()
            .enumerate()
            .map(|(i, c)| c << 20 | i as u64)
            .collect();
        let mut b = a.clone();
        sort_bits(&mut a, 20, 20 + code_bits);
        b.sort_unstable();
        assert_eq!(a, b, "{} keys, code bits {code_bits}", codes.len());
    }

    #[test]
    fn sorting_high_bits_is_stable() {
        // Codes with many repeats.
        for n in [3000, 200_000] {
            assert_sorts_codes_stably(&keys(n, 7, 9), 9);
        }
    }
}
