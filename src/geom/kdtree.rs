//! Neighbour search over points: one k-d tree (kiddo's immutable one) for
//! every stage that needs the nearest points or those within a radius.
//!
//! Positions are stored relative to an origin the caller chooses (a point
//! of the cloud, or its box's centre), so the tree's f64 arithmetic keeps
//! its precision for a cloud far from the origin.

use std::num::NonZero;

use glam::DVec3;
use kiddo::immutable::float::kdtree::ImmutableKdTree;
use kiddo::SquaredEuclidean;

/// A point found: its index in the tree's points and its squared
/// distance to the query.
pub use kiddo::NearestNeighbour as Neighbour;

/// A k-d tree over points.
pub struct PointTree {
    tree: ImmutableKdTree<f64, u32, 3, 32>,
    origin: DVec3,
    len: usize,
}

impl PointTree {
    /// The tree of `points`, stored relative to `origin`.
    pub fn new(points: impl IntoIterator<Item = DVec3>, origin: DVec3) -> PointTree {
        let rel: Vec<[f64; 3]> = points
            .into_iter()
            .map(|p| (p - origin).to_array())
            .collect();
        PointTree {
            tree: ImmutableKdTree::new_from_slice(&rel),
            origin,
            len: rel.len(),
        }
    }

    /// The tree of points already in the caller's frame (queries are in
    /// that frame too).
    pub fn from_relative(rel: &[[f64; 3]]) -> PointTree {
        PointTree {
            tree: ImmutableKdTree::new_from_slice(rel),
            origin: DVec3::ZERO,
            len: rel.len(),
        }
    }

    /// The number of points.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True without points.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The `k` points nearest `p` (fewer when the tree holds fewer),
    /// nearest first; nothing when `k` is 0.
    pub fn nearest(&self, p: DVec3, k: usize) -> Vec<Neighbour<f64, u32>> {
        match NonZero::new(k.min(self.len)) {
            Some(k) => self
                .tree
                .nearest_n::<SquaredEuclidean>(&(p - self.origin).to_array(), k),
            None => Vec::new(),
        }
    }

    /// The point nearest `p` (the tree must not be empty).
    pub fn nearest_one(&self, p: DVec3) -> Neighbour<f64, u32> {
        self.tree
            .nearest_one::<SquaredEuclidean>(&(p - self.origin).to_array())
    }

    /// The points within distance `r` of `p`, in no particular order.
    pub fn within(&self, p: DVec3, r: f64) -> Vec<Neighbour<f64, u32>> {
        self.tree
            .within_unsorted::<SquaredEuclidean>(&(p - self.origin).to_array(), r * r)
    }
}
