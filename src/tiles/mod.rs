//! Spatial tiles of a cloud, for bakes past one machine (`pctile`).
//!
//! Every kernel of the chain is truncated at a known reach, so a cloud cut
//! into tiles, each with a halo of the points within that reach of it,
//! bakes tile by tile to what the whole cloud bakes to: a tile's own
//! points see every source they would have seen. [`split()`] cuts a PLY
//! file into such tiles in three streaming passes (memory bounded by a
//! chunk and a sample, whatever the file's size); a stage run on a tile
//! computes its own points and treats the halo as sources only
//! ([`crate::halo::halo_mask`]); [`merge()`] puts the owned points of every tile back in
//! the input's order, streaming too. The manifest, the tile files'
//! attributes and the checks are written down in `formats/TILES.md`.
//!
//! Tiles are the leaves of a k-d split of the points' bounding box: each
//! cut halves the tiles to make along the box's longest side, at the
//! quantile of a sample of the points (every k-th, at most 2^20) that
//! balances the counts. A point belongs to the leaf whose half-open box
//! holds it (`x < cut` goes low), and is in the halo of every other leaf
//! whose closed box is within the halo width of it.

pub mod merge;
pub mod reach;
pub mod request;
pub mod split;

use std::io::Read;
use std::path::{Path, PathBuf};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

pub use merge::merge;
pub use request::{ForRequest, Request};
pub use split::{split, SplitOptions, TileCount};

pub use crate::names::{D_HALO, D_SPLIT, D_TILE, HALO, INDEX};

/// The manifest's `format` value.
pub const FORMAT: &str = "pcsss-tiles 2";
/// The manifest's file name in the tile directory.
pub const MANIFEST: &str = "manifest.json";
/// The file of a split's other elements (faces, ...), which no tile
/// holds, in the tile directory.
pub const REST: &str = "rest.ply";
/// The most tiles a split makes (each is an open file while it is
/// written).
pub const MAX_TILES: usize = 4096;
/// The largest manifest read: one of [`MAX_TILES`] tiles takes well
/// under a megabyte, so a file that goes on (`/dev/zero`) is refused, not
/// read until memory runs out.
pub const MAX_MANIFEST_BYTES: u64 = 16 << 20;

/// One tile of the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tile {
    pub index: u32,
    /// The file, relative to the manifest's directory.
    pub file: String,
    /// The tile's box (its owned points are inside, `hi` excluded on
    /// inner cuts).
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// Points the tile owns, and halo points.
    pub owned: u64,
    pub halo: u64,
}

/// An input element other than `vertex`, kept aside in `rest` and put
/// back in its place by the merge.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElementEntry {
    pub name: String,
    pub count: u64,
}

/// The stage a halo was computed for (`pctile split --for`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForStage {
    pub stage: String,
    pub args: Vec<String>,
    /// The stage's reach with those arguments.
    pub reach: f64,
}

/// `manifest.json`: what a split made, checked by the merge.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    pub format: String,
    /// The split's id: a checksum of everything else in the manifest,
    /// also written into every tile file (detail `pctile_split`).
    pub split: String,
    /// The input's name as given, for people (not checked).
    pub input: String,
    /// The input's bytes' XXH3-128, in 32 hex digits: two splits of
    /// different data never share an id.
    pub input_hash: String,
    /// Points in the input.
    pub points: u64,
    pub halo: f64,
    #[serde(rename = "for")]
    pub for_stage: Option<ForStage>,
    /// The points' bounding box.
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// The input's elements in order (`vertex` among them).
    pub elements: Vec<ElementEntry>,
    /// The file holding the elements other than `vertex`, if any.
    pub rest: Option<String>,
    pub tiles: Vec<Tile>,
}

impl Manifest {
    /// The tile files the manifest lists, in tile order, in `dir` (or in
    /// `from`, where a stage wrote its output tiles under the same names).
    pub fn tile_files(&self, dir: &Path) -> Vec<PathBuf> {
        self.tiles.iter().map(|t| dir.join(&t.file)).collect()
    }

    /// The checksum of everything but `split`: 64-bit FNV-1a of the
    /// manifest's JSON with `split` empty, in hex.
    pub fn checksum(&self) -> String {
        let mut m = self.clone();
        m.split = String::new();
        let text = serde_json::to_string(&m).expect("a manifest serialises");
        let mut h: u64 = 0xcbf29ce484222325;
        for b in text.bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
        format!("{h:016x}")
    }

    /// Reads and checks `DIR/manifest.json`: its format, its checksum
    /// (a manifest edited by hand is refused) and its tiles' numbering.
    pub fn read(dir: &std::path::Path) -> Result<Manifest> {
        let path = dir.join(MANIFEST);
        let name = path.display().to_string();
        let io = |e: std::io::Error| Error::from(e).about(&name);
        let mut bytes = Vec::new();
        crate::files::open_input(&path)
            .map_err(|e| e.about(&name))?
            .take(MAX_MANIFEST_BYTES + 1)
            .read_to_end(&mut bytes)
            .map_err(io)?;
        Manifest::parse(&bytes).map_err(|e| e.about(&name))
    }

    /// A manifest's bytes, checked as [`Manifest::read`] checks them.
    pub fn parse(bytes: &[u8]) -> Result<Manifest> {
        if bytes.len() as u64 > MAX_MANIFEST_BYTES {
            let what = format!(
                "larger than {} MiB: not a manifest pctile split wrote",
                MAX_MANIFEST_BYTES >> 20
            );
            return Err(Error::invalid(what));
        }
        let bad = |what: String| Error::invalid(what);
        let text = std::str::from_utf8(bytes).map_err(|_| bad("not UTF-8 text".into()))?;
        let m: Manifest = serde_json::from_str(text).map_err(|e| bad(e.to_string()))?;
        if m.format != FORMAT {
            return Err(bad(format!("format '{}', not '{FORMAT}'", m.format)));
        }
        let sum = m.checksum();
        if sum != m.split {
            return Err(bad(format!(
                "its checksum is {sum} but it says split {}: the manifest was edited after the split (split again)",
                m.split
            )));
        }
        for (i, t) in m.tiles.iter().enumerate() {
            if t.index as usize != i {
                return Err(bad(format!("tile {i} is numbered {}", t.index)));
            }
        }
        let owned = m.tiles.iter().try_fold(0u64, |a, t| a.checked_add(t.owned));
        if owned != Some(m.points) {
            return Err(bad(format!(
                "the tiles own {owned:?} points, the input had {}",
                m.points
            )));
        }
        m.check_consistent().map_err(bad)?;
        Ok(m)
    }

    /// What the checksum cannot catch in a manifest edited with its id
    /// recomputed: file names that leave the folder, a `vertex` count that
    /// is not `points` (the merged file's header would disagree with its
    /// body), a rest file with no elements to hold or elements without
    /// one, more tiles than a split makes, a halo that is not a width.
    fn check_consistent(&self) -> std::result::Result<(), String> {
        let plain = |f: &str| {
            let p = std::path::Path::new(f);
            let mut parts = p.components();
            matches!(
                (parts.next(), parts.next()),
                (Some(std::path::Component::Normal(_)), None)
            )
        };
        for t in &self.tiles {
            if !plain(&t.file) {
                return Err(format!(
                    "tile {} is '{}': a tile is a plain file name in the split's folder",
                    t.index, t.file
                ));
            }
        }
        if let Some(r) = &self.rest {
            if !plain(r) {
                return Err(format!(
                    "rest is '{r}': a plain file name in the split's folder"
                ));
            }
        }
        if self.tiles.is_empty() || self.tiles.len() > MAX_TILES {
            return Err(format!(
                "{} tiles: a split makes 1 to {MAX_TILES}",
                self.tiles.len()
            ));
        }
        let vertices: Vec<u64> = self
            .elements
            .iter()
            .filter(|e| e.name == crate::cloud::POINTS)
            .map(|e| e.count)
            .collect();
        if vertices != [self.points] {
            return Err(format!(
                "its elements list {vertices:?} '{}' rows, not one of {} points",
                crate::cloud::POINTS,
                self.points
            ));
        }
        let others = self.elements.len() > 1;
        if others != self.rest.is_some() {
            return Err(format!(
                "rest is {:?} with {} elements besides the points",
                self.rest,
                self.elements.len() - 1
            ));
        }
        if !(self.halo.is_finite() && self.halo >= 0.0) {
            return Err(format!("halo {}: not a width >= 0", self.halo));
        }
        Ok(())
    }
}

/// A k-d split of a box into tiles.
#[derive(Clone, Debug)]
pub struct Plan {
    nodes: Vec<Node>,
    /// Each tile's box.
    pub boxes: Vec<(DVec3, DVec3)>,
}

#[derive(Clone, Copy, Debug)]
enum Node {
    Leaf(u32),
    /// Points below `cut` on `axis` go to node `lo`, the others to node
    /// `hi` (indices into `nodes`).
    Cut {
        axis: u8,
        cut: f64,
        lo: u32,
        hi: u32,
    },
}

impl Plan {
    /// `tiles` tiles of the box `lo..hi`, cut at the quantiles of `sample`
    /// (reordered) that balance the points among them.
    pub fn new(sample: &mut [DVec3], lo: DVec3, hi: DVec3, tiles: usize) -> Plan {
        let mut plan = Plan {
            nodes: Vec::with_capacity(2 * tiles),
            boxes: vec![(lo, hi); tiles],
        };
        plan.build(sample, lo, hi, 0, tiles.max(1));
        plan
    }

    fn build(&mut self, sample: &mut [DVec3], lo: DVec3, hi: DVec3, first: usize, n: usize) -> u32 {
        let me = self.nodes.len() as u32;
        if n == 1 {
            self.nodes.push(Node::Leaf(first as u32));
            self.boxes[first] = (lo, hi);
            return me;
        }
        self.nodes.push(Node::Leaf(0));
        let left = n / 2;
        let ext = hi - lo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z {
            0
        } else if ext.y >= ext.z {
            1
        } else {
            2
        };
        let cut = if sample.is_empty() {
            0.5 * (lo[axis] + hi[axis])
        } else {
            let m = (sample.len() * left / n).min(sample.len() - 1);
            sample.select_nth_unstable_by(m, |a, b| a[axis].total_cmp(&b[axis]));
            sample[m][axis]
        };
        // The sample's points below the cut first, as the points go.
        let mut k = 0;
        for i in 0..sample.len() {
            if sample[i][axis] < cut {
                sample.swap(i, k);
                k += 1;
            }
        }
        let (a, b) = sample.split_at_mut(k);
        let mut mid_hi = hi;
        mid_hi[axis] = cut;
        let mut mid_lo = lo;
        mid_lo[axis] = cut;
        let l = self.build(a, lo, mid_hi, first, left);
        let h = self.build(b, mid_lo, hi, first + left, n - left);
        self.nodes[me as usize] = Node::Cut {
            axis: axis as u8,
            cut,
            lo: l,
            hi: h,
        };
        me
    }

    /// The tile that owns `p`.
    pub fn owner(&self, p: DVec3) -> u32 {
        let mut at = 0;
        loop {
            match self.nodes[at] {
                Node::Leaf(t) => return t,
                Node::Cut { axis, cut, lo, hi } => {
                    at = if p[axis as usize] < cut { lo } else { hi } as usize;
                }
            }
        }
    }

    /// Calls `f` with every tile other than `owner` whose box is within
    /// `h` of `p` (closed boxes: a point at the distance is in).
    pub fn halo_of(&self, p: DVec3, owner: u32, h: f64, mut f: impl FnMut(u32)) {
        // Depth first, the far child pushed below the near one: the stack
        // holds at most one node a level, and MAX_TILES leaves take 12.
        let mut stack = [0u32; 64];
        let mut len = 1;
        while len > 0 {
            len -= 1;
            let at = stack[len];
            match self.nodes[at as usize] {
                Node::Leaf(t) => {
                    if t != owner {
                        let (lo, hi) = self.boxes[t as usize];
                        let d = (lo - p).max(p - hi).max(DVec3::ZERO);
                        if d.length_squared() <= h * h {
                            f(t)
                        }
                    }
                }
                Node::Cut { axis, cut, lo, hi } => {
                    let x = p[axis as usize];
                    if x - cut <= h {
                        stack[len] = lo;
                        len += 1;
                    }
                    if cut - x <= h {
                        stack[len] = hi;
                        len += 1;
                    }
                }
            }
        }
    }
}
