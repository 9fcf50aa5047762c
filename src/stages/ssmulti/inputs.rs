//! `ssmulti`'s inputs: `P`, `N`, `ptarea` and `illum` read and checked
//! in parallel into one record a point.

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::Cloud;
use crate::column::Column;
use crate::error::{Error, Result};

/// A point as the pair loop's columns are built from it (40 bytes: its
/// normal is kept apart, and only when `bounce` reads it).
#[derive(Clone, Copy, Default)]
pub(super) struct PointRecord {
    pub pos: [f64; 3],
    pub area: f32,
    pub illum: [f32; 3],
}

impl PointRecord {
    #[inline(always)]
    pub(super) fn pos_v(&self) -> DVec3 {
        DVec3::from_array(self.pos)
    }
}

pub(super) struct Inputs<'a> {
    pub pts: Vec<PointRecord>,
    /// Unit normals, or nothing (no `bounce`).
    pub nrm: Vec<[f32; 3]>,
    /// The positions as read (the Morton codes come from these).
    pub p: [ReadColumn<'a>; 3],
    /// The positions' box.
    pub lo: DVec3,
    pub hi: DVec3,
    /// Every point's `illum` has three equal channels.
    pub grey: bool,
    /// What `ptarea` is multiplied by in the sums: the power of two that
    /// brings the cloud's total area into [0.5, 1). A cloud scaled by
    /// 1e-4 then sums numbers of the same size as the unscaled one
    /// (by a power of two: the same bits); unscaled, its `illum * ptarea`
    /// (~1e-13 at 1M points) times a weight near `e^-60` would be
    /// subnormal and slow (`BENCH_SCALE=1e-4` in benches/ssmulti.rs).
    /// Exact (a power of two), undone in the normaliser (`Local` divides
    /// it out); `r_min` is taken from the areas as read.
    pub area_scale: f64,
}

/// A column read as f64, with the common types read directly.
#[derive(Clone, Copy)]
pub(super) enum ReadColumn<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
    Other(&'a Column),
}

impl<'a> ReadColumn<'a> {
    fn of(c: &'a Column) -> ReadColumn<'a> {
        if let Some(v) = c.as_slice::<f32>() {
            ReadColumn::F32(v)
        } else if let Some(v) = c.as_slice::<f64>() {
            ReadColumn::F64(v)
        } else {
            ReadColumn::Other(c)
        }
    }

    #[inline(always)]
    pub(super) fn get(self, i: usize) -> f64 {
        match self {
            ReadColumn::F32(v) => v[i] as f64,
            ReadColumn::F64(v) => v[i],
            ReadColumn::Other(c) => c.get_f64(i),
        }
    }

    /// Values `start..start + out.len()` as f64 (one type dispatch a
    /// block, not a value).
    fn f64s(self, start: usize, out: &mut [f64]) {
        let end = start + out.len();
        match self {
            ReadColumn::F32(v) => {
                for (o, &x) in out.iter_mut().zip(&v[start..end]) {
                    *o = x as f64;
                }
            }
            ReadColumn::F64(v) => out.copy_from_slice(&v[start..end]),
            ReadColumn::Other(c) => {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = c.get_f64(start + k);
                }
            }
        }
    }

    /// `f64s` as f32 (a value beyond f32's range becomes infinite).
    fn f32s(self, start: usize, out: &mut [f32]) {
        let end = start + out.len();
        match self {
            ReadColumn::F32(v) => out.copy_from_slice(&v[start..end]),
            ReadColumn::F64(v) => {
                for (o, &x) in out.iter_mut().zip(&v[start..end]) {
                    *o = x as f32;
                }
            }
            ReadColumn::Other(c) => {
                for (k, o) in out.iter_mut().enumerate() {
                    *o = c.get_f64(start + k) as f32;
                }
            }
        }
    }
}

/// Reads and checks the inputs, in parallel, into one record a point
/// (the Morton ordering gathers them at random: one cache line a point).
/// The first bad point (lowest index) is reported.
/// The normals are checked always, kept only when `normals`.
pub(super) fn inputs(cloud: &Cloud, normals: bool) -> Result<Inputs<'_>> {
    let pts = cloud.points();
    for name in ["N", "ptarea", "illum"] {
        if !pts.has(name) {
            return Err(pts.missing(name));
        }
    }
    let v3 = |name: &str| -> Result<[ReadColumn; 3]> {
        let c = pts.vec3_columns(name)?;
        Ok([0, 1, 2].map(|k| ReadColumn::of(c[k].column())))
    };
    let (p, nm, e) = (v3("P")?, v3("N")?, v3("illum")?);
    let area = ReadColumn::of(pts.scalar_column("ptarea")?.column());
    // Positions in f64 (leaf origins keep their precision); the rest as
    // the f32 the pair loop uses (an f64 value beyond f32's range is
    // reported as not finite).
    let read = |i: usize| -> Result<(PointRecord, [f32; 3])> {
        let pos = [p[0].get(i), p[1].get(i), p[2].get(i)];
        if !pos.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid(format!(
                "point {i}: P is {pos:?}, not finite"
            )));
        }
        let illum = [e[0].get(i), e[1].get(i), e[2].get(i)].map(|x| x as f32);
        if !illum.iter().all(|x| x.is_finite()) {
            return Err(Error::invalid(format!(
                "point {i}: illum is {illum:?}, not finite"
            )));
        }
        let a = area.get(i) as f32;
        if !(a.is_finite() && a >= 0.0) {
            return Err(Error::invalid(format!(
                "point {i}: ptarea is {a}, not a finite number >= 0"
            )));
        }
        let n32 = [nm[0].get(i), nm[1].get(i), nm[2].get(i)].map(|x| x as f32);
        let v = DVec3::new(n32[0] as f64, n32[1] as f64, n32[2] as f64);
        // (Squares of f32 values do not overflow or underflow in f64: a
        // finite, non-zero N has a direction. Normalised only when kept.)
        let u = if !(v.is_finite() && v.length_squared() > 0.0) {
            DVec3::ZERO
        } else if normals {
            v.normalize()
        } else {
            v
        };
        if u == DVec3::ZERO {
            return Err(Error::invalid(format!(
                "point {i}: N is {n32:?}, which has no direction"
            )));
        }
        Ok((
            PointRecord {
                pos,
                area: a,
                illum,
            },
            u.as_vec3().to_array(),
        ))
    };
    // Filled in place in parallel, chunk by chunk, with the positions'
    // box; the first bad point (lowest index) is then read again for its
    // message.
    let n = pts.len();
    let first_bad = std::sync::atomic::AtomicUsize::new(usize::MAX);
    let (mut all, mut nrm) = (Vec::<PointRecord>::with_capacity(n), Vec::<[f32; 3]>::new());
    if normals {
        nrm.reserve_exact(n);
    }
    const CHUNK: usize = 4096;
    // The normals' chunks beside the records' (none without normals).
    let nrm_chunks: Vec<Option<&mut [std::mem::MaybeUninit<[f32; 3]>]>> = if normals {
        nrm.spare_capacity_mut()[..n]
            .chunks_mut(CHUNK)
            .map(Some)
            .collect()
    } else {
        (0..n.div_ceil(CHUNK)).map(|_| None).collect()
    };
    // (The zip below must not cut the records' chunks short: every slot
    // is then written, as `set_len` needs.)
    assert_eq!(nrm_chunks.len(), n.div_ceil(CHUNK));
    let empty = (
        DVec3::splat(f64::INFINITY),
        DVec3::splat(f64::NEG_INFINITY),
        true,
        0.0f64,
    );
    let boxes = all.spare_capacity_mut()[..n]
        .par_chunks_mut(CHUNK)
        .zip(nrm_chunks)
        .enumerate()
        .map(|(ci, (slots, mut nslots))| {
            let (mut lo, mut hi, mut grey, mut atot) = empty;
            // The columns a block at a time, checked as `read` does (a
            // bad point gets a default record and is read again below).
            const BLOCK: usize = 256;
            let (mut pb, mut nb, mut eb) =
                ([[0f64; BLOCK]; 3], [[0f32; BLOCK]; 3], [[0f32; BLOCK]; 3]);
            let mut ab = [0f32; BLOCK];
            for (bi, bslots) in slots.chunks_mut(BLOCK).enumerate() {
                let (start, m) = (ci * CHUNK + bi * BLOCK, bslots.len());
                for k in 0..3 {
                    p[k].f64s(start, &mut pb[k][..m]);
                    nm[k].f32s(start, &mut nb[k][..m]);
                    e[k].f32s(start, &mut eb[k][..m]);
                }
                area.f32s(start, &mut ab[..m]);
                for (j, slot) in bslots.iter_mut().enumerate() {
                    let pos = [pb[0][j], pb[1][j], pb[2][j]];
                    let illum = [eb[0][j], eb[1][j], eb[2][j]];
                    let a = ab[j];
                    let v = DVec3::new(nb[0][j] as f64, nb[1][j] as f64, nb[2][j] as f64);
                    let ok = pos.iter().all(|x| x.is_finite())
                        && illum.iter().all(|x| x.is_finite())
                        && a.is_finite()
                        && a >= 0.0
                        && v.is_finite()
                        && v.length_squared() > 0.0;
                    let (pt, nn) = if ok {
                        let u = if normals { v.normalize() } else { v };
                        (
                            PointRecord {
                                pos,
                                area: a,
                                illum,
                            },
                            u.as_vec3().to_array(),
                        )
                    } else {
                        first_bad.fetch_min(start + j, std::sync::atomic::Ordering::Relaxed);
                        Default::default()
                    };
                    let q = DVec3::from_array(pt.pos);
                    (lo, hi) = (lo.min(q), hi.max(q));
                    grey &= pt.illum[0] == pt.illum[1] && pt.illum[1] == pt.illum[2];
                    atot += pt.area as f64;
                    slot.write(pt);
                    if let Some(ns) = nslots.as_deref_mut() {
                        ns[bi * BLOCK + j].write(nn);
                    }
                }
            }
            (lo, hi, grey, atot)
        })
        .reduce(
            || empty,
            |a, b| (a.0.min(b.0), a.1.max(b.1), a.2 && b.2, a.3 + b.3),
        );
    // SAFETY: every slot of the first `n` was written above (bad points
    // with a default record).
    unsafe {
        all.set_len(n);
        if normals {
            nrm.set_len(n);
        }
    }
    let bad = first_bad.into_inner();
    if bad != usize::MAX {
        read(bad)?;
    }
    Ok(Inputs {
        pts: all,
        nrm,
        p,
        lo: boxes.0,
        hi: boxes.1,
        grey: boxes.2,
        area_scale: area_scale(boxes.3),
    })
}

/// The power of two that brings a total area `atot` into [0.5, 1) (1
/// for 0), within 2^+-100 (beyond, tiny areas would flush to 0). Read
/// from `atot`'s exponent bits: `atot = m 2^e`, `m` in [0.5, 1) (a sum of
/// f32 areas is a normal f64).
fn area_scale(atot: f64) -> f64 {
    if !(atot >= f64::MIN_POSITIVE && atot.is_finite()) {
        return 1.0;
    }
    let e = ((atot.to_bits() >> 52) & 0x7ff) as i32 - 1022;
    2f64.powi((-e).clamp(-100, 100))
}

/// The physical model's light by where it came from and what lies
/// behind (`docs/DESIGN.md#incidence`, `#thickness`): each point's
/// `illum` times, per channel, the medium's multiple-scattering
/// reflectance at the point's `illum_cos` over the one along the normal
/// (`illum_cos` clamped to `[0, 1]`), and the light a slab of the point's
/// `thickness` returns over a thick part's. Without either attribute
/// that weight is 1 (the light along the normal, a thick part). Then the
/// single scattering of the light between surfaces ([`indirect_single`]).
/// Returns which of the three were there.
pub(super) fn weigh_light(
    cloud: &Cloud,
    medium: &crate::medium::Medium,
    kernel: (f64, [f64; 3]),
    inp: &mut Inputs,
) -> Result<(bool, bool, bool)> {
    let pts = cloud.points();
    let column = |name: &str| -> Result<Option<ReadColumn>> {
        if !pts.has(name) {
            return Ok(None);
        }
        let c = ReadColumn::of(pts.scalar_column(name)?.column());
        let n = inp.pts.len();
        if let Some(i) = (0..n).into_par_iter().find_first(|&i| c.get(i).is_nan()) {
            return Err(Error::invalid(format!("point {i}: {name} is NaN")));
        }
        Ok(Some(c))
    };
    let (cos, thick) = (column("illum_cos")?, column("thickness")?);
    let spread = spread_light(cloud)?;
    if cos.is_none() && thick.is_none() && spread.is_none() {
        let indirect = indirect_single(cloud, medium, inp)?;
        if indirect {
            inp.grey = is_grey(inp);
        }
        return Ok((false, false, indirect));
    }
    let inc = cos.map(|c| (c, medium.incidence()));
    let thin = thick.map(|c| (c, medium.thinness()));
    let diffuse = medium.diffuse_incidence();
    inp.pts.par_iter_mut().enumerate().for_each(|(i, pt)| {
        let mut f = [1.0f64; 3];
        if let Some((c, inc)) = &inc {
            f = inc.factor(c.get(i));
        }
        let mut k = [1.0f64; 3];
        if let Some((c, thin)) = &thin {
            k = thin.factor(c.get(i));
        }
        for c in 0..3 {
            // The light spread over the hemisphere weighs as light from
            // the whole sky, the rest by its cosine.
            let e = pt.illum[c] as f64;
            let v = match &spread {
                None => (e * (f[c] * k[c])) as f32,
                Some(d) => {
                    let d = d[i][c].min(e);
                    (((e - d) * f[c] + d * diffuse[c]) * k[c]) as f32
                }
            };
            // (Flushed below the normal floats: a part a hair's breadth
            // thick returns next to nothing, and subnormal light would
            // slow every pair it is in.)
            pt.illum[c] = if v.abs() < f32::MIN_POSITIVE { 0.0 } else { v };
        }
    });
    if let Some((c, thin)) = &thin {
        through_the_far_face(cloud, c, thin, kernel, inp)?;
    }
    // After the weights: the single scattering of light from every side
    // needs neither.
    let indirect = indirect_single(cloud, medium, inp)?;
    inp.grey = is_grey(inp);
    Ok((inc.is_some(), thin.is_some(), indirect))
}

/// `illum_diffuse` (the part of `illum` spread over the hemisphere: a
/// constant dome's, light between surfaces), where the cloud has it,
/// checked.
pub(super) fn spread_light(cloud: &Cloud) -> Result<Option<Vec<[f64; 3]>>> {
    let pts = cloud.points();
    if !pts.has("illum_diffuse") {
        return Ok(None);
    }
    let d = pts.vec3_f64("illum_diffuse")?;
    if let Some(i) = d
        .iter()
        .position(|c| !c.iter().all(|x| x.is_finite() && *x >= 0.0))
    {
        return Err(Error::invalid(format!(
            "point {i} has illum_diffuse {:?}: light is finite and not negative",
            d[i]
        )));
    }
    Ok(Some(d))
}

/// Whether every point's light is grey (one channel's sums serve all).
fn is_grey(inp: &Inputs) -> bool {
    inp.pts
        .par_iter()
        .all(|p| p.illum[0] == p.illum[1] && p.illum[1] == p.illum[2])
}

/// Light between surfaces arrives from every side, and the single
/// scattering it gives leaves nearly as evenly: where the cloud has
/// `illum_indirect` (illum --indirect), a point's light gains that light
/// times `rs_diffuse / rm` per channel, so that ssM returns its single
/// scattering too (sssingle follows the lights alone). Returns whether it
/// was there.
fn indirect_single(
    cloud: &Cloud,
    medium: &crate::medium::Medium,
    inp: &mut Inputs,
) -> Result<bool> {
    let pts = cloud.points();
    if !pts.has("illum_indirect") {
        return Ok(false);
    }
    let ind = pts.vec3_f64("illum_indirect")?;
    if let Some(i) = ind
        .iter()
        .position(|c| !c.iter().all(|v| v.is_finite() && *v >= 0.0))
    {
        return Err(Error::invalid(format!(
            "point {i} has illum_indirect {:?}: light is finite and not negative",
            ind[i]
        )));
    }
    let rs = medium.rs_diffuse();
    let k = [0, 1, 2].map(|c| {
        if medium.rm[c] > 0.0 {
            rs[c] / medium.rm[c]
        } else {
            0.0
        }
    });
    inp.pts.par_iter_mut().zip(&ind).for_each(|(pt, e)| {
        for c in 0..3 {
            pt.illum[c] = (pt.illum[c] as f64 + e[c] * k[c]) as f32;
        }
    });
    Ok(true)
}

/// A thin part's light leaves through both faces (`docs/DESIGN.md#thickness`):
/// a share of a source's light is moved to the cloud point nearest where
/// `-N` leaves the mesh, `P - thickness N`, when that point faces the
/// other way (its normal within 25 degrees of the source's reversed) and
/// lies nearer the exit than the source does (a far face sampled there);
/// else it stays. The kernel then spreads it from the far
/// face as it spreads the rest from the near one; since each spreads a
/// share `s` of its light on its own face and `1 - s` across (on two
/// parallel planes `thickness` apart, in closed form: [`own_face`]), the
/// share moved is `(f - (1 - s)) / (2 s - 1)` (clamped to `[0, 1]`) for
/// the far face to get the share `f` a slab walk sends out of it. Moves
/// in point order: the same bits for any thread count. Only parts
/// thinner than the longest kernel distance move light. `kernel`: the
/// Burley `kappa` and each channel's distance `D`.
fn through_the_far_face(
    cloud: &Cloud,
    thick: &ReadColumn,
    thin: &crate::medium::Thinness,
    kernel: (f64, [f64; 3]),
    inp: &mut Inputs,
) -> Result<()> {
    let nrm = cloud.points().vec3_f64("N")?;
    let n = inp.pts.len();
    let unit = |i: usize| DVec3::from_array(nrm[i]).normalize_or_zero();
    let origin = if n > 0 {
        inp.pts[0].pos_v()
    } else {
        DVec3::ZERO
    };
    let tree = crate::geom::kdtree::PointTree::new(inp.pts.iter().map(|q| q.pos_v()), origin);
    let ld1 = kernel.1.iter().copied().fold(0.0, f64::max);
    let moves: Vec<(usize, u32, [f32; 3])> = (0..n)
        .into_par_iter()
        .filter_map(|i| {
            let q = &inp.pts[i];
            let t = thick.get(i);
            // (A part thicker than the kernel's longest distance `D` sends
            // little through, and a move no longer than `D` keeps a source
            // whose moved light reaches a point within `2 D` of it: in a
            // tile's halo, which the source normalisation already needs.)
            if q.illum == [0.0; 3] || !(t > 0.0 && t < ld1) {
                return None;
            }
            let f = thin.through(t);
            if f.iter().all(|&s| s <= 0.0) {
                return None;
            }
            let share = [0, 1, 2].map(|c| {
                let s = own_face(kernel.0, kernel.1[c], t);
                if 2.0 * s - 1.0 > 1e-3 {
                    ((f[c] - (1.0 - s)) / (2.0 * s - 1.0)).clamp(0.0, 1.0)
                } else {
                    // (Both faces get half whatever is moved.)
                    f[c]
                }
            });
            let ni = unit(i);
            let exit = q.pos_v() - ni * t;
            let j = tree.nearest_one(exit).item;
            let far = inp.pts[j as usize].pos_v().distance_squared(exit) < t * t;
            // The slab's model holds where the far face is near parallel
            // (within 25 degrees of facing the other way): not across
            // an ear's rim, where `-N` runs along the part.
            if j as usize == i || !far || unit(j as usize).dot(ni) > -0.9 {
                return None;
            }
            let moved = [0, 1, 2].map(|c| (q.illum[c] as f64 * share[c]) as f32);
            Some((i, j, moved))
        })
        .collect();
    for (i, j, moved) in moves {
        for c in 0..3 {
            inp.pts[i].illum[c] -= moved[c];
            inp.pts[j as usize].illum[c] += moved[c];
        }
    }
    Ok(())
}

/// The share of a source's light the Burley kernel of shape `kappa` and
/// reach `reach` puts on the source's own plane, with a parallel plane
/// `gap` away: `I(0) / (I(0) + I(gap))`, `I(h) = int W(sqrt(rho^2 + h^2))
/// 2 pi rho drho` over the disk within reach `= 2 pi (d (e^(-h/d) -
/// e^-kappa) + 3d (e^(-h/3d) - e^(-kappa/3)))`, `d = reach / kappa`
/// (`r dr = rho drho`). 1 when the gap is beyond reach.
pub(super) fn own_face(kappa: f64, reach: f64, gap: f64) -> f64 {
    if reach.is_nan() || reach <= 0.0 || gap >= reach {
        return 1.0;
    }
    let d = reach / kappa;
    let i = |h: f64| {
        d * ((-h / d).exp() - (-kappa).exp())
            + 3.0 * d * ((-h / (3.0 * d)).exp() - (-kappa / 3.0).exp())
    };
    let (own, across) = (i(0.0), i(gap.max(0.0)));
    own / (own + across)
}

#[cfg(test)]
mod tests {
    use super::own_face;
    use std::f64::consts::PI;

    /// The closed form against a quadrature of the truncated Burley
    /// kernel over the two planes; half and half with no gap, all on its
    /// own plane beyond reach.
    #[test]
    fn the_kernels_own_face_share_is_its_integral() {
        let (kappa, reach) = (12.95, 0.4);
        let d = reach / kappa;
        let w = |r: f64| ((-r / d).exp() + (-r / (3.0 * d)).exp()) / r;
        // int over the disk of the plane h away, in rho (midpoints, dense
        // near the axis where the own plane's 1/r core lives).
        let plane = |h: f64| {
            let m = 200_000;
            let top = (reach * reach - h * h).max(0.0).sqrt();
            (0..m)
                .map(|k| {
                    let rho = top * ((k as f64 + 0.5) / m as f64).powi(2);
                    let drho = top * 2.0 * (k as f64 + 0.5) / (m as f64 * m as f64);
                    w((rho * rho + h * h).sqrt()) * 2.0 * PI * rho * drho
                })
                .sum::<f64>()
        };
        for gap in [0.005, 0.03, 0.2] {
            let want = plane(0.0) / (plane(0.0) + plane(gap));
            let got = own_face(kappa, reach, gap);
            assert!((got - want).abs() < 1e-4, "gap {gap}: {got} against {want}");
        }
        assert!((own_face(kappa, reach, 0.0) - 0.5).abs() < 1e-12);
        assert_eq!(own_face(kappa, reach, 0.5), 1.0);
        assert_eq!(own_face(kappa, 0.0, 0.1), 1.0);
    }
}
