//! The Morton order: the points sorted along a Z curve and cut into
//! leaves of at most [`LEAF`] points, a binary tree over the leaves from
//! the same splits, what each node's sources add up to, and the walks
//! that find the leaves within reach of a receiver leaf.

use glam::DVec3;
use rayon::prelude::*;

use super::inputs::{Inputs, PointRecord};
use super::params::LEAF;
use crate::progress::Phases;

/// A leaf: points `start..start + len` of the sorted order, sources first
/// (`src` of them), columns padded to a multiple of `LANES` from
/// `col..col + padded(len)`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Leaf {
    pub col: usize,
    pub len: usize,
    pub src: usize,
    pub origin: DVec3,
    pub lo: DVec3,
    pub hi: DVec3,
    /// What its sources add up to (the tree's leaf node).
    pub sum: SourceSums,
}

/// What a set of sources adds up to: their box, areas, `illum *
/// ptarea`, area-weighted normals, area-weighted centroid and the largest
/// distance from it to a source.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct SourceSums {
    pub lo: DVec3,
    pub hi: DVec3,
    /// `sum ptarea` (times the inputs' `area_scale`).
    pub a: f64,
    /// `sum illum * ptarea`.
    pub q: [f64; 3],
    /// `sum N * ptarea`.
    pub n: DVec3,
    pub centre: DVec3,
    pub radius: f64,
    /// `sum ptarea |x - centre|^2`, the area's second moment about the
    /// centroid (times `area_scale`).
    pub m2: f64,
    pub sources: usize,
}

/// Interleaves the low 21 bits of `v` with two zero bits between each,
/// a byte at a time from a table (the shift-and-mask form is a chain of
/// fifteen dependent steps, and slower here).
#[inline(always)]
pub(super) fn spread(v: u64) -> u64 {
    const BYTE: [u64; 256] = {
        let mut t = [0u64; 256];
        let mut b = 0;
        while b < 256 {
            let mut k = 0;
            while k < 8 {
                t[b] |= ((b as u64 >> k) & 1) << (3 * k);
                k += 1;
            }
            b += 1;
        }
        t
    };
    let v = v & 0x1f_ffff;
    BYTE[(v & 0xff) as usize]
        | BYTE[(v >> 8 & 0xff) as usize] << 24
        | BYTE[(v >> 16) as usize] << 48
}

/// A node of the binary tree the Morton splits make over the leaves: its
/// first leaf (the leaf itself when it has no children), its children,
/// and (after `aggregate`) what its sources add up to.
#[derive(Clone, Debug, Default)]
pub(super) struct TreeNode {
    first: usize,
    /// (Two but for a run of equal codes: inline, no allocation a node.)
    kids: smallvec::SmallVec<[usize; 2]>,
    pub sum: SourceSums,
}

/// What the Morton keys are made of: `code << idx_bits | index`, codes
/// of `axis_bits` an axis.
struct MortonKeys<'a> {
    pts: &'a [PointRecord],
    idx_bits: u32,
    axis_bits: u32,
}

/// How many times a cell that holds more than a leaf of distinct points
/// is coded again within its own box (each time `axis_bits` more bits an
/// axis: four give about 100 bits, a range of 1e29).
const MAX_RECODE: u32 = 4;

impl MortonKeys<'_> {
    /// The highest code bit of a key.
    fn top(&self) -> i32 {
        (self.idx_bits + 3 * self.axis_bits) as i32 - 1
    }

    /// The Morton key of point `i` at `pos` within the cube from `lo`
    /// that `scale` maps onto the codes.
    #[inline(always)]
    fn key(&self, i: usize, pos: DVec3, lo: DVec3, scale: f64) -> u64 {
        let q = (pos - lo) * scale;
        // (Through i64: x86 converts f64 to u64 in many steps. A point of
        // the box codes within `axis_bits`; NaN, from a box too small for
        // a finite `scale`, as 0.)
        let c = |v: f64| spread(v as i64 as u64);
        let code = c(q.x) | c(q.y) << 1 | c(q.z) << 2;
        code << self.idx_bits | i as u64
    }

    /// Codes the points of `keys` (which share a code) again within
    /// their own box and sorts them by the new keys; false when they are
    /// all at one position (nothing to cut by) or within a box too small
    /// to scale (1e-304).
    fn recode(&self, keys: &mut [u64]) -> bool {
        let mask = (1u64 << self.idx_bits) - 1;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for &k in keys.iter() {
            let p = self.pts[(k & mask) as usize].pos_v();
            lo = lo.min(p);
            hi = hi.max(p);
        }
        let extent = (hi - lo).max_element();
        let scale = ((1u64 << self.axis_bits) - 1) as f64 / extent;
        if !(extent > 0.0 && scale.is_finite()) {
            return false;
        }
        for k in keys.iter_mut() {
            let i = (*k & mask) as usize;
            *k = self.key(i, self.pts[i].pos_v(), lo, scale);
        }
        keys.sort_unstable();
        true
    }
}

/// The leaves and the tree the Morton splits make: `ranges` of the
/// sorted order (one a leaf) and the `nodes` over them (children before
/// parents).
struct Splitter<'a> {
    keys: MortonKeys<'a>,
    ranges: Vec<(usize, usize)>,
    nodes: Vec<TreeNode>,
}

impl Splitter<'_> {
    /// Cuts the sorted `order[start..end]` at Morton bit `bit` and below
    /// into leaf ranges and tree nodes; returns the node's index. A cell
    /// that holds more than a leaf when the code bits run out (a cloud
    /// whose points are far apart in scale: an outlier far away, a small
    /// detailed part in a large scene) is coded again within its own box
    /// (`depth` times so far), so that its leaves stay small in space;
    /// points at one position are cut in runs of `LEAF`.
    fn split(
        &mut self,
        order: &mut [u64],
        start: usize,
        end: usize,
        bit: i32,
        depth: u32,
    ) -> usize {
        let first = self.ranges.len();
        let mut kids = smallvec::SmallVec::new();
        if end - start <= LEAF {
            self.ranges.push((start, end));
        } else if bit < self.keys.idx_bits as i32 {
            if depth < MAX_RECODE && self.keys.recode(&mut order[start..end]) {
                return self.split(order, start, end, self.keys.top(), depth + 1);
            }
            // Equal positions (duplicate points): runs of LEAF.
            let mut s = start;
            while s < end {
                let e = (s + LEAF).min(end);
                self.nodes.push(TreeNode {
                    first: self.ranges.len(),
                    ..TreeNode::default()
                });
                kids.push(self.nodes.len() - 1);
                self.ranges.push((s, e));
                s = e;
            }
        } else {
            let mask = 1u64 << bit;
            let mid = start + order[start..end].partition_point(|&o| o & mask == 0);
            if mid == start || mid == end {
                // One side empty: no node for this bit.
                return self.split(order, start, end, bit - 1, depth);
            }
            kids.push(self.split(order, start, mid, bit - 1, depth));
            kids.push(self.split(order, mid, end, bit - 1, depth));
        }
        self.nodes.push(TreeNode {
            first,
            kids,
            ..TreeNode::default()
        });
        self.nodes.len() - 1
    }
}

/// The points sorted along a Morton curve and cut into leaves of at most
/// `LEAF` points that share a prefix (equal codes are cut in runs).
pub(super) struct MortonOrder {
    /// The sorted keys; `key & idx_mask` is the point's index.
    pub order: Vec<u64>,
    pub idx_mask: u64,
    /// The leaves, as ranges of `order`.
    pub ranges: Vec<(usize, usize)>,
    /// The tree over the leaves (children before parents), sums not yet
    /// filled ([`aggregate`]).
    pub nodes: Vec<TreeNode>,
}

/// Sorts `inp`'s points along a Morton curve and cuts them into leaves.
pub(super) fn morton_order(inp: &Inputs<'_>, pb: &mut Phases) -> MortonOrder {
    let n = inp.pts.len();
    let (lo, hi) = (inp.lo, inp.hi);
    let extent = (hi - lo).max_element().max(f64::MIN_POSITIVE);
    // One u64 a point: the Morton code above, the point's index below (so
    // every key is distinct and the order is the same on any thread
    // count). 14 bits an axis (as 4M points leave room for) at every
    // size: points that share a code are cut into leaves in index order,
    // and 42 code bits sort in four radix passes.
    let idx_bits = (usize::BITS - n.max(2).saturating_sub(1).leading_zeros()).max(1);
    let axis_bits = ((64 - idx_bits) / 3).min(14);
    let scale = ((1u64 << axis_bits) - 1) as f64 / extent;
    let keys = MortonKeys {
        pts: &inp.pts,
        idx_bits,
        axis_bits,
    };
    // (From the columns as read: the records are wider.)
    let ps = &inp.p;
    let mut order: Vec<u64> = (0..n)
        .into_par_iter()
        .map(|i| {
            let pos = DVec3::new(ps[0].get(i), ps[1].get(i), ps[2].get(i));
            keys.key(i, pos, lo, scale)
        })
        .collect();
    pb.mark("codes");
    // The keys are in index order: only the code's bits need sorting;
    // the top 33 in three radix passes (11 levels: a cell 1/2048 of the
    // box wide, which mostly holds one point or none), then the points
    // that share a cell by their whole codes.
    let top = idx_bits + 3 * axis_bits;
    let rest = top - top.saturating_sub(idx_bits).min(33);
    crate::radix::sort_bits(&mut order, rest, top);
    crate::radix::sort_runs(&mut order, rest);
    pb.mark("sort");
    let top_bit = keys.top();
    // At most one leaf a point, fewer than two nodes a leaf.
    let mut s = Splitter {
        keys,
        ranges: Vec::with_capacity(2 * n / LEAF + 1),
        nodes: Vec::with_capacity(4 * n / LEAF + 1),
    };
    s.split(&mut order, 0, n, top_bit, 0);
    pb.mark("split");
    MortonOrder {
        order,
        idx_mask: (1u64 << idx_bits) - 1,
        ranges: s.ranges,
        nodes: s.nodes,
    }
}

/// Fills the nodes' sums, bottom-up (children come before parents).
pub(super) fn aggregate(nodes: &mut [TreeNode], leaves: &[Leaf]) {
    for t in 0..nodes.len() {
        // Children come before their parent.
        let (done, rest) = nodes.split_at_mut(t);
        let node = &mut rest[0];
        if node.kids.is_empty() {
            node.sum = leaves[node.first].sum;
        } else {
            let kids = &node.kids;
            let (mut a, mut q, mut n, mut ax, mut sources) =
                (0.0, [0.0; 3], DVec3::ZERO, DVec3::ZERO, 0);
            let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
            for &k in kids {
                let c = &done[k].sum;
                if c.sources == 0 {
                    continue;
                }
                a += c.a;
                ax += c.centre * c.a;
                for j in 0..3 {
                    q[j] += c.q[j];
                }
                n += c.n;
                lo = lo.min(c.lo);
                hi = hi.max(c.hi);
                sources += c.sources;
            }
            let centre = if a > 0.0 { ax / a } else { (lo + hi) * 0.5 };
            let (mut radius, mut m2): (f64, f64) = (0.0, 0.0);
            for &k in kids {
                let c = &done[k].sum;
                if c.sources > 0 {
                    radius = radius.max(c.radius + (c.centre - centre).length());
                    // (Parallel axes: each child's moment about its own
                    // centroid, moved to the parent's.)
                    m2 += c.m2 + c.a * (c.centre - centre).length_squared();
                }
            }
            node.sum = SourceSums {
                lo,
                hi,
                a,
                q,
                n,
                centre,
                radius,
                m2,
                sources,
            };
        }
    }
}

/// Squared distance between a node's box and a leaf's.
#[inline]
pub(super) fn gap2(w: &WalkNode, rl: &Leaf) -> f64 {
    (w.lo - rl.hi)
        .max(rl.lo - w.hi)
        .max(DVec3::ZERO)
        .length_squared()
}

/// The tree in pre-order for the searches: each node's sources' box and
/// radius, where its subtree ends, its leaf (`u32::MAX` for an inner
/// node) and its index in the tree (the rest of its sums). Subtrees
/// without sources are left out.
pub(super) struct WalkNode {
    pub lo: DVec3,
    pub hi: DVec3,
    pub radius: f64,
    pub skip: u32,
    pub leaf: u32,
    pub node: u32,
}

pub(super) fn walk_order(nodes: &[TreeNode]) -> Vec<WalkNode> {
    fn add(nodes: &[TreeNode], t: usize, out: &mut Vec<WalkNode>) {
        let node = &nodes[t];
        if node.sum.sources == 0 {
            return;
        }
        let at = out.len();
        out.push(WalkNode {
            lo: node.sum.lo,
            hi: node.sum.hi,
            radius: node.sum.radius,
            node: t as u32,
            skip: 0,
            leaf: if node.kids.is_empty() {
                node.first as u32
            } else {
                u32::MAX
            },
        });
        for &k in &node.kids {
            add(nodes, k, out);
        }
        out[at].skip = out.len() as u32;
    }
    let mut out = Vec::with_capacity(nodes.len());
    if let Some(root) = nodes.len().checked_sub(1) {
        add(nodes, root, &mut out);
    }
    out
}

/// The leaves with sources whose boxes come within `reach` of `rl`'s box,
/// in order (into `out`): the tree scanned in pre-order, skipping the
/// subtrees out of reach.
pub(super) fn near_leaves(walk: &[WalkNode], rl: &Leaf, reach: f64, out: &mut Vec<usize>) {
    out.clear();
    // (A margin for the f32 rounding of the pair loop's distances.)
    let reach = reach * (1.0 + 1e-6);
    let mut i = 0;
    while i < walk.len() {
        let w = &walk[i];
        if gap2(w, rl) > reach * reach {
            i = w.skip as usize;
            continue;
        }
        if w.leaf != u32::MAX {
            out.push(w.leaf as usize);
        }
        i += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Bit `j` of the input lands on bit `3 j`, nothing else is set.
    #[test]
    fn spread_puts_bit_j_at_3j() {
        let slow = |v: u64| (0..21).fold(0u64, |acc, j| acc | ((v >> j) & 1) << (3 * j));
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        for v in [0, 1, 0x1f_ffff, 0x15_5555, 0x0a_aaaa, 1 << 20, u64::MAX] {
            assert_eq!(spread(v), slow(v), "{v:#x}");
        }
        for _ in 0..10_000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            assert_eq!(spread(x), slow(x), "{x:#x}");
        }
    }
}
