//! The cloud as leaves of Morton-ordered columns: each leaf's points as
//! f32 relative to the leaf's own f64 origin (a cloud 1e6 from the origin
//! loses nothing), sources first, padded to whole groups of [`LANES`],
//! with a bounding sphere a group.

use std::mem::MaybeUninit;

use glam::DVec3;
use rayon::prelude::*;

use super::inputs::Inputs;
use super::kernel::burley;
use super::lanes::{Lanes, LANES};
use super::params::LEAF;
use super::tree::{aggregate, morton_order, Leaf, MortonOrder, SourceSums, TreeNode};
use crate::progress::Progress;

/// What the gather reads of a group of `LANES` points, together:
/// positions relative to the leaf origin and `illum[c] * ptarea`. The
/// same groups are the receivers' lanes.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct GroupLanes {
    pub x: Lanes,
    pub y: Lanes,
    pub z: Lanes,
    pub q: [Lanes; 3],
}

/// Source columns (f32, relative to the leaf origin), padded per leaf:
/// the hot part a group at a time, the rest a column each.
#[derive(Default)]
pub(super) struct Columns {
    pub hot: Vec<GroupLanes>,
    /// The groups' bounding spheres, a column each (centre in the leaf's
    /// frame, radius), one entry a group and `LANES` far away after the
    /// last (a leaf's groups are read eight at a time).
    pub sph: [Vec<f32>; 4],
    pub nx: Vec<f32>,
    pub ny: Vec<f32>,
    pub nz: Vec<f32>,
    /// `ptarea`.
    pub a: Vec<f32>,
    /// Burley's `r_min`.
    pub rmin: Vec<f32>,
    /// Original point index (u32::MAX for padding).
    pub id: Vec<u32>,
}

/// A padding lane: far away, carrying nothing.
pub(super) const FAR: f32 = 1e18;

pub(super) fn padded(n: usize) -> usize {
    n.div_ceil(LANES) * LANES
}

/// The points sorted along a Morton curve and cut into leaves of at most
/// `LEAF` points ([`morton_order`]), each leaf's columns written in
/// place. A point is a source when it has light, or (`all_sources`)
/// always.
/// `want`: the normals, areas and `r_min` columns (others left empty).
pub(super) fn build(
    inp: &Inputs<'_>,
    all_sources: bool,
    want: [bool; 3],
    progress: &Progress,
) -> (Vec<Leaf>, Columns, Vec<TreeNode>) {
    let mut pb = progress.phases("ssmulti build");
    let MortonOrder {
        order,
        idx_mask,
        ranges,
        mut nodes,
    } = morton_order(inp, &mut pb);
    // Every leaf's columns written in parallel, in place.
    let lens: Vec<usize> = ranges.iter().map(|&(s, e)| padded(e - s)).collect();
    let glens: Vec<usize> = lens.iter().map(|l| l / LANES).collect();
    let total: usize = lens.iter().sum();
    let ng = total / LANES;
    // Allocated, not written: every leaf writes every slot of its pieces
    // (fresh pages are first touched by the thread that fills them).
    let [normals, area, rmin] = want;
    let on = |w: bool| if w { total } else { 0 };
    let mut cols = Columns {
        hot: Vec::with_capacity(ng),
        sph: std::array::from_fn(|_| Vec::with_capacity(ng + LANES)),
        nx: Vec::with_capacity(on(normals)),
        ny: Vec::with_capacity(on(normals)),
        nz: Vec::with_capacity(on(normals)),
        a: Vec::with_capacity(on(area)),
        rmin: Vec::with_capacity(on(rmin)),
        id: Vec::with_capacity(total),
    };
    pb.mark("alloc");
    let mut leaves: Vec<Leaf> = {
        let Columns {
            hot,
            sph,
            nx,
            ny,
            nz,
            a,
            rmin: rm,
            id,
        } = &mut cols;
        let mut phot = pieces(&mut hot.spare_capacity_mut()[..ng], &glens);
        let mut psph = sph
            .each_mut()
            .map(|v| pieces(&mut v.spare_capacity_mut()[..ng], &glens));
        fn col<'a>(
            v: &'a mut Vec<f32>,
            len: usize,
            lens: &[usize],
        ) -> std::vec::IntoIter<&'a mut [MaybeUninit<f32>]> {
            pieces(&mut v.spare_capacity_mut()[..len], lens)
        }
        let (mut pnx, mut pny) = (col(nx, on(normals), &lens), col(ny, on(normals), &lens));
        let mut pnz = col(nz, on(normals), &lens);
        let (mut pa, mut prm) = (col(a, on(area), &lens), col(rm, on(rmin), &lens));
        let mut pid = pieces(&mut id.spare_capacity_mut()[..total], &lens);
        let mut shares = Vec::with_capacity(ranges.len());
        for _ in 0..ranges.len() {
            shares.push(LeafColumnsMut {
                hot: phot.next().expect("one piece a leaf"),
                sph: [0, 1, 2, 3].map(|a| psph[a].next().expect("one piece a leaf")),
                nx: pnx.next().expect("one piece a leaf"),
                ny: pny.next().expect("one piece a leaf"),
                nz: pnz.next().expect("one piece a leaf"),
                a: pa.next().expect("one piece a leaf"),
                rmin: prm.next().expect("one piece a leaf"),
                id: pid.next().expect("one piece a leaf"),
            });
        }
        shares
            .into_par_iter()
            .zip(ranges.par_iter())
            .map(|(cm, &(start, end))| {
                leaf_columns(cm, &order[start..end], idx_mask, inp, all_sources)
            })
            .collect()
    };
    // SAFETY: the pieces above cover the first `ng` groups and `total`
    // lanes of each column (`on` of the unused ones: none), and
    // `leaf_columns` wrote every slot of its pieces.
    unsafe {
        cols.hot.set_len(ng);
        for v in &mut cols.sph {
            v.set_len(ng);
        }
        for (v, w) in [
            (&mut cols.nx, normals),
            (&mut cols.ny, normals),
            (&mut cols.nz, normals),
            (&mut cols.a, area),
            (&mut cols.rmin, rmin),
        ] {
            v.set_len(on(w));
        }
        cols.id.set_len(total);
    }
    // The spheres after the last group: far away, radius 0.
    for (a, v) in cols.sph.iter_mut().enumerate() {
        v.resize(ng + LANES, if a < 3 { FAR } else { 0.0 });
    }
    pb.mark("cols");
    let mut col = 0;
    for (leaf, len) in leaves.iter_mut().zip(&lens) {
        leaf.col = col;
        col += len;
    }
    aggregate(&mut nodes, &leaves);
    pb.mark("aggregate");
    (leaves, cols, nodes)
}

/// One leaf's share of the columns, written in place: every slot (the
/// normals, areas and `r_min` when not empty).
struct LeafColumnsMut<'a> {
    hot: &'a mut [MaybeUninit<GroupLanes>],
    sph: [&'a mut [MaybeUninit<f32>]; 4],
    nx: &'a mut [MaybeUninit<f32>],
    ny: &'a mut [MaybeUninit<f32>],
    nz: &'a mut [MaybeUninit<f32>],
    a: &'a mut [MaybeUninit<f32>],
    rmin: &'a mut [MaybeUninit<f32>],
    id: &'a mut [MaybeUninit<u32>],
}

/// `v` cut into consecutive pieces of the given sizes (empty pieces when
/// `v` is empty: a column not in use).
fn pieces<'a, T>(v: &'a mut [T], sizes: &[usize]) -> std::vec::IntoIter<&'a mut [T]> {
    let mut out = Vec::with_capacity(sizes.len());
    if v.is_empty() {
        out.resize_with(sizes.len(), Default::default);
        return out.into_iter();
    }
    let mut rest = v;
    for &n in sizes {
        let (head, tail) = std::mem::take(&mut rest).split_at_mut(n);
        out.push(head);
        rest = tail;
    }
    out.into_iter()
}

/// One leaf's points (a run of the Morton order) into its columns:
/// sources first, f32 relative to the leaf's origin, padded to whole
/// groups, with the groups' bounding spheres.
fn leaf_columns(
    mut cm: LeafColumnsMut,
    run: &[u64],
    idx_mask: u64,
    inp: &Inputs<'_>,
    all_sources: bool,
) -> Leaf {
    // Sources first, each part in Morton order (a leaf holds at most
    // LEAF points: `split`).
    assert!(run.len() <= LEAF);
    let (mut all, mut unlit) = ([0u32; LEAF], [0u32; LEAF]);
    let (mut src, mut m) = (0, 0);
    for &k in run {
        let i = (k & idx_mask) as u32;
        if all_sources || inp.pts[i as usize].illum.iter().any(|&x| x != 0.0) {
            all[src] = i;
            src += 1;
        } else {
            unlit[m] = i;
            m += 1;
        }
    }
    all[src..src + m].copy_from_slice(&unlit[..m]);
    let ids = &all[..run.len()];
    // The leaf's box, and its sources' sums.
    let mut llo = DVec3::splat(f64::INFINITY);
    let mut lhi = DVec3::splat(f64::NEG_INFINITY);
    let mut sum = SourceSums {
        lo: llo,
        hi: lhi,
        sources: src,
        ..SourceSums::default()
    };
    let mut ax = DVec3::ZERO;
    for (k, &i) in ids.iter().enumerate() {
        let pt = &inp.pts[i as usize];
        let p = DVec3::from_array(pt.pos);
        llo = llo.min(p);
        lhi = lhi.max(p);
        if k < src {
            let w = pt.area as f64 * inp.area_scale;
            sum.a += w;
            ax += p * w;
            for c in 0..3 {
                sum.q[c] += (pt.illum[c] as f64 * w) as f32 as f64;
            }
            if let Some(nn) = inp.nrm.get(i as usize) {
                sum.n += DVec3::from_array(nn.map(f64::from)) * w;
            }
            sum.lo = sum.lo.min(p);
            sum.hi = sum.hi.max(p);
        }
    }
    sum.centre = if sum.a > 0.0 {
        ax / sum.a
    } else {
        (sum.lo + sum.hi) * 0.5
    };
    let origin = (llo + lhi) * 0.5;
    // The columns, and the sources' farthest distance from their centre.
    let (normals, area, rmin) = (!cm.nx.is_empty(), !cm.a.is_empty(), !cm.rmin.is_empty());
    let mut far2: f64 = 0.0;
    // A group at a time: its lanes, then its bounding sphere (sources and
    // receivers alike; padding lanes left out).
    for (gi, g) in (0..cm.id.len()).step_by(LANES).enumerate() {
        let m = (ids.len() - g).min(LANES);
        // Padding lanes: far away, carrying nothing.
        let mut h = GroupLanes {
            x: [FAR; LANES],
            y: [FAR; LANES],
            z: [FAR; LANES],
            q: [[0.0; LANES]; 3],
        };
        for l in 0..LANES {
            let k = g + l;
            let Some(&i) = ids.get(k) else {
                for v in [&mut cm.nx, &mut cm.ny, &mut cm.nz, &mut cm.a, &mut cm.rmin] {
                    if !v.is_empty() {
                        v[k].write(0.0);
                    }
                }
                cm.id[k].write(u32::MAX);
                continue;
            };
            let pt = &inp.pts[i as usize];
            let q = DVec3::from_array(pt.pos);
            if k < src {
                let d2 = (q - sum.centre).length_squared();
                far2 = far2.max(d2);
                sum.m2 += d2 * pt.area as f64 * inp.area_scale;
            }
            let p = q - origin;
            (h.x[l], h.y[l], h.z[l]) = (p.x as f32, p.y as f32, p.z as f32);
            let a = pt.area as f64 * inp.area_scale;
            let e = pt.illum;
            for c in 0..3 {
                h.q[c][l] = (e[c] as f64 * a) as f32;
            }
            if normals {
                let nn = inp.nrm[i as usize];
                cm.nx[k].write(nn[0]);
                cm.ny[k].write(nn[1]);
                cm.nz[k].write(nn[2]);
            }
            if area {
                cm.a[k].write(a as f32);
            }
            if rmin {
                cm.rmin[k].write(burley::rmin(pt.area as f64) as f32);
            }
            cm.id[k].write(i);
        }
        let (mut glo, mut ghi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for l in 0..m {
            for (a, v) in [h.x[l], h.y[l], h.z[l]].into_iter().enumerate() {
                glo[a] = glo[a].min(v);
                ghi[a] = ghi[a].max(v);
            }
        }
        let c = [0, 1, 2].map(|a| 0.5 * (glo[a] + ghi[a]));
        let mut r2: f32 = 0.0;
        for l in 0..m {
            let d = [h.x[l] - c[0], h.y[l] - c[1], h.z[l] - c[2]];
            r2 = r2.max(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
        }
        // Rounding of the receiver's offset and of this sum: a margin.
        let r = r2.sqrt() * (1.0 + 1e-5) + 1e-6 * (c[0].abs() + c[1].abs() + c[2].abs());
        for (a, v) in [c[0], c[1], c[2], r].into_iter().enumerate() {
            cm.sph[a][gi].write(v);
        }
        cm.hot[gi].write(h);
    }
    sum.radius = far2.sqrt();
    Leaf {
        col: 0,
        len: ids.len(),
        src,
        origin,
        lo: llo,
        hi: lhi,
        sum,
    }
}
