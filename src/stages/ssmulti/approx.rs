//! The approximate method (`tolerance > 0`): a cluster of the tree far
//! enough from a receiver leaf, and small beside the kernel's length
//! scale there, is summed as one pseudo-source at its centroid
//! (`docs/DESIGN.md#approximate-method`).

use std::f64::consts::PI;

use glam::DVec3;
use rayon::prelude::*;

use super::gather::{Gathered, PseudoSource};
use super::inputs::Inputs;
use super::kernel::{burley, disk_integral, falloff, reach, Falloff};
use super::params::{Distances, Params};
use super::tree::{gap2, Leaf, TreeNode, WalkNode};

/// The share of the mean weight a straddling cluster may misplace, see
/// [`jump_scale`]: well below the share at which the error of a shallow
/// exp falloff starts to grow, while most straddling clusters of steeper
/// kernels are still taken whole (`BENCH_CASE=1000000,20000,T
/// BENCH_FALLOFF=exp BENCH_SIGMA=S cargo bench --bench ssmulti`; the
/// figures in benches/results/HISTORY.md, "Measurements behind the
/// code").
const JUMP_K: f64 = 0.05;

/// The largest radius, divided by the tolerance, of a cluster that may be
/// summed at its centroid although it straddles the reach `d` of a
/// falloff that jumps to zero there (exp, Burley): `JUMP_K d mean / W(d)`,
/// `mean = I(d) / (pi d^2)` the falloff's mean over the disk. It bounds
/// the relative weight such clusters misplace by `4 JUMP_K T`
/// (`docs/DESIGN.md#approximate-method`). Where the falloff is 0 at `d`
/// (a steep exp) there is no jump: infinity.
fn jump_scale(f: Falloff, d: f64) -> f64 {
    let mean = disk_integral(f, d) / (PI * d * d);
    let edge = falloff(f, d, d, 0.0);
    if edge > 0.0 && d > 0.0 {
        JUMP_K * d * mean / edge
    } else {
        f64::INFINITY
    }
}

/// The approximate method's choices for a run: which clusters of the
/// tree stand in for their sources at each receiver leaf.
pub(super) struct Planner<'a> {
    walk: &'a [WalkNode],
    /// Each walk node as a pseudo-source, made once (not at every
    /// receiver leaf that takes it).
    clusters: Vec<Cluster>,
    p: Params,
    dist: Distances,
    /// The smallest channel distance in use (`ld1` without t_rgb).
    dmin: f64,
    /// How far a source can add anything ([`reach`]).
    far: f64,
    /// The largest radius of a cluster that straddles a jump to zero of
    /// the falloff ([`jump_scale`] times the tolerance).
    jump_ok: f64,
    /// Burley: each channel's profile in use, for [`burley_small`].
    profiles: Vec<Profile>,
}

/// A Burley channel's profile: shape `s = D / kappa`, truncation `D`,
/// and its mean over the disk `I(D) / (pi D^2)`.
#[derive(Clone, Copy, Debug)]
struct Profile {
    s: f64,
    d: f64,
    mean: f64,
}

impl Profile {
    /// The untruncated profile `W(r)` and a bound on its Hessian's
    /// largest eigenvalue beyond `r`, `W''(r)` (each of the profile's
    /// terms `e^(-r/a) / r` has a positive, falling second derivative
    /// `e^(-r/a) (1 / (a^2 r) + 2 / (a r^2) + 2 / r^3)`, at least its
    /// `|W'| / r`).
    fn at(&self, r: f64) -> (f64, f64) {
        let (mut w, mut h) = (0.0, 0.0);
        for a in [self.s, 3.0 * self.s] {
            let e = (-r / a).exp();
            w += e / r;
            h += e * (1.0 / (a * a * r) + 2.0 / (a * r * r) + 2.0 / (r * r * r));
        }
        (w, h)
    }
}

/// Burley's rule (`docs/DESIGN.md#approximate-method`): a cluster of
/// radius `radius` whose box is `gap` from the receiver leaf's is summed
/// whole when `radius <= T gap` (the profile's `1 / r` core, as
/// Barnes-Hut) and, for each channel's profile that reaches it, the
/// midpoint rule's error for each unit of its area evenly lit, at most
/// `spread2 W''(gap) / 2` (`spread2` the area's mean squared distance
/// from the centroid), is at most `T^2 / 2` times `W(gap)` plus the
/// profile's mean over its disk. Summed over the clusters, that error is
/// at most about `T^2` of the receiver's sum (the first term bounds it
/// where the profile is steep, the second spends a share of the whole
/// disk's weight in its tail, where the profile is small beside its
/// mean), so clusters grow with the distance into the tail rather than
/// stay a fraction of `d`.
fn burley_small(profiles: &[Profile], t: f64, radius: f64, spread2: f64, gap: f64) -> bool {
    if gap <= 0.0 || radius > t * gap {
        return false;
    }
    profiles.iter().all(|pr| {
        if gap >= pr.d {
            return true;
        }
        let (w, h) = pr.at(gap);
        spread2 * h <= t * t * (w + pr.mean)
    })
}

impl<'a> Planner<'a> {
    /// The plan for `p` over the tree's `walk` (`nodes` hold the sums).
    pub(super) fn new(
        walk: &'a [WalkNode],
        nodes: &[TreeNode],
        inp: &Inputs<'_>,
        p: &Params,
    ) -> Planner<'a> {
        let dist = Distances::of(p);
        let Distances { ld, ld1 } = dist;
        let dmin = if p.rgb {
            ld.iter().copied().filter(|&d| d > 0.0).fold(ld1, f64::min)
        } else {
            ld1
        };
        Planner {
            walk,
            clusters: walk_clusters(walk, nodes, inp.area_scale),
            p: *p,
            dist,
            dmin,
            far: reach(p.falloff, ld1),
            jump_ok: p.tolerance * jump_scale(p.falloff, dmin),
            profiles: match p.falloff {
                Falloff::Burley { kappa } => {
                    let used: Vec<f64> = if p.rgb { ld.to_vec() } else { vec![ld1] };
                    used.into_iter()
                        .filter(|&d| d > 0.0)
                        .map(|d| Profile {
                            s: d / kappa,
                            d,
                            mean: disk_integral(p.falloff, d) / (PI * d * d),
                        })
                        .collect()
                }
                _ => Vec::new(),
            },
        }
    }

    /// For receiver leaf `rl`: the source leaves to sum exactly (`exact`),
    /// and the clusters (tree nodes) that stand in for the rest as
    /// pseudo-sources in `rl`'s frame (`ps`). A cluster is used when its
    /// radius `s` (from its area-weighted centroid to its farthest
    /// source) is at most `tolerance` times the kernel's length scale
    /// where it lies: `D` for smooth, `D / max(sigma, 1)` for exp, `min(d,
    /// gap)` for Burley (`D` the smallest channel distance in use, `gap`
    /// the distance from `rl`'s box to the cluster's); and, for the
    /// falloffs that jump to zero at `D` (exp, Burley), when it does not
    /// straddle a channel's reach or is small enough beside the jump there
    /// ([`jump_scale`]). A cluster is summed as one source at its centroid
    /// with the sums of `illum * ptarea` and `ptarea`, and its mean normal
    /// (for `bounce`). Relative error against the exact method, measured
    /// in `benches/ssmulti.rs`, grows like `tolerance^2`
    /// (`docs/DESIGN.md#approximate-method`).
    pub(super) fn plan(&self, rl: &Leaf, exact: &mut Vec<usize>, ps: &mut Gathered) {
        let (p, walk, dmin) = (&self.p, self.walk, self.dmin);
        let Distances { ld, ld1 } = self.dist;
        let jumps = !matches!(p.falloff, Falloff::Smooth);
        exact.clear();
        ps.clear();
        // The tree in pre-order: a subtree out of reach or taken as one
        // cluster is skipped whole (the exact leaves come out in order).
        let mut i = 0;
        while i < walk.len() {
            let w = &walk[i];
            let gap2 = gap2(w, rl);
            if gap2 > self.far * self.far {
                i = w.skip as usize;
                continue;
            }
            let small = match p.falloff {
                Falloff::Smooth => w.radius <= p.tolerance * dmin,
                Falloff::Exp { sigma } => w.radius <= p.tolerance * dmin / sigma.max(1.0),
                Falloff::Burley { .. } => burley_small(
                    &self.profiles,
                    p.tolerance,
                    w.radius,
                    self.clusters[i].spread2,
                    gap2.sqrt(),
                ),
            };
            let straddles = jumps && {
                let gap = gap2.sqrt();
                let far = (w.hi - rl.lo).abs().max((rl.hi - w.lo).abs()).length();
                (0..3).any(|c| {
                    let d = if p.rgb { ld[c] } else { ld1 };
                    d > 0.0 && gap <= d && far > d
                })
            };
            let small = small && dmin > 0.0;
            if small && (!straddles || w.radius <= self.jump_ok) {
                let c = &self.clusters[i];
                ps.point(PseudoSource {
                    pos: (c.centre - rl.origin).as_vec3().to_array(),
                    n: c.n,
                    q: c.q,
                    a: c.a,
                    rmin: c.rmin,
                });
                i = w.skip as usize;
            } else {
                if w.leaf != u32::MAX {
                    exact.push(w.leaf as usize);
                }
                i += 1;
            }
        }
    }
}

/// A node as a pseudo-source (beside the walk, in its order): its sources'
/// area-weighted centroid and mean normal, `sum illum * ptarea`, `sum
/// ptarea`, and Burley's `r_min` for that whole area (a single-source
/// cluster gets exactly its source's).
struct Cluster {
    centre: DVec3,
    /// The area's mean squared distance from the centroid.
    spread2: f64,
    n: [f32; 3],
    q: [f32; 3],
    a: f32,
    rmin: f32,
}

/// Each walk node's `Cluster` (`area_scale`: what the nodes' areas were
/// multiplied by; `r_min` is taken from the areas as read).
fn walk_clusters(walk: &[WalkNode], nodes: &[TreeNode], area_scale: f64) -> Vec<Cluster> {
    walk.par_iter()
        .map(|w| {
            let node = &nodes[w.node as usize].sum;
            Cluster {
                centre: node.centre,
                spread2: if node.a > 0.0 {
                    node.m2 / node.a
                } else {
                    w.radius * w.radius
                },
                n: node.n.normalize_or_zero().as_vec3().to_array(),
                q: node.q.map(|v| v as f32),
                a: node.a as f32,
                rmin: burley::rmin(node.a / area_scale) as f32,
            }
        })
        .collect()
}
