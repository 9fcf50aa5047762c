//! How a scan finds the runs of points of the 27 cells around a cell:
//! from a dense table per group of cells (`Table`), or, where a scan
//! visits too few of a group's cells for a table to pay, by galloping
//! search through the sorted keys from where the last cell's neighbours
//! were (`Cursor`).

use std::ops::Range;

use super::{coords, key, neighbour, PointGrid, BITS};

/// What `runs27` found for the last cell: where each neighbour was (a
/// hint for the next search), and the last cell's coordinates and runs,
/// which the next cell reuses for the neighbours the two share.
pub(super) struct Cursor {
    at: [usize; 27],
    last: Option<[u64; 3]>,
    runs: [Range<usize>; 27],
}

impl Cursor {
    /// No neighbour found yet.
    pub(super) fn new() -> Cursor {
        Cursor {
            at: [usize::MAX; 27],
            last: None,
            runs: std::array::from_fn(|_| 0..0),
        }
    }
}

/// Groups: aligned cubes of `2^GROUP` cells a side. A scan through a
/// group's cells reads their neighbours from a dense table of the group
/// and the layer of cells around it (`Table`), filled once from the
/// group's own cells and the facing cells of the 26 around it: a cell's
/// 27 runs are then array reads, where searching the sorted keys for
/// them cost more than the distance tests they serve.
pub(super) const GROUP: u32 = 4;
/// A group's side, in cells.
pub(super) const SIDE: usize = 1 << GROUP;
/// The table's side: the group and one cell on each side.
const TSIDE: usize = SIDE + 2;
/// Cells of a group a scan must visit for a table to pay: filling one
/// tests every cell of up to 27 groups (a few hundred on a surface, one
/// mask each), where a cell's 27 runs cost a few key searches each (a
/// judgement, not measured: the scans of scatter visit whole groups).
pub(super) const MIN_TABLE: usize = 24;
/// The key bits of one axis within a group (`x`; `y` and `z` are these
/// shifted down by 1 and 2).
const GROUP_X: u64 = 0b100_100_100_100;
const _: () = assert!(GROUP == 4, "GROUP_X has GROUP bits");

/// The runs of one group's cells and the layer around them, by
/// coordinates relative to the group's lower corner, less one.
pub(super) struct Table {
    runs: Vec<[u32; 2]>,
}

impl Table {
    pub(super) fn new() -> Table {
        Table {
            runs: vec![[0, 0]; TSIDE * TSIDE * TSIDE],
        }
    }

    /// The run of the cell at `i` (each coordinate `0..=SIDE + 1`): the
    /// coordinates relative to the group's lower corner, plus one.
    pub(super) fn run(&self, i: [usize; 3]) -> Range<usize> {
        let [a, b] = self.runs[(i[0] * TSIDE + i[1]) * TSIDE + i[2]];
        a as usize..b as usize
    }
}

impl PointGrid {
    /// The runs of the 27 cells around cell `c` (empty for an unoccupied
    /// one), indexed by `9 (dx + 1) + 3 (dy + 1) + (dz + 1)`. `cursor`
    /// keeps where each neighbour was found (start with `Cursor::new`):
    /// cells visited in order find their neighbours a few keys from the
    /// last ones, where a hash table's slot would be a cache miss.
    pub(super) fn runs27(&self, c: usize, cursor: &mut Cursor) -> [Range<usize>; 27] {
        let own = self.keys[c];
        let at = coords(own);
        // The step from the last cell, when it is one cell or none along
        // each axis: cells visited in Morton order mostly are neighbours,
        // and then 9 to 27 of the 27 runs are the last cell's.
        let step = cursor.last.and_then(|l| {
            let d = [0, 1, 2].map(|a| at[a] as i64 - l[a] as i64);
            d.iter().all(|x| x.abs() <= 1).then_some(d)
        });
        let last_runs = std::mem::replace(&mut cursor.runs, std::array::from_fn(|_| 0..0));
        let last_at = cursor.at;
        let cur = &mut cursor.at;
        let runs = std::array::from_fn(|k| {
            let d = [k / 9, k / 3 % 3, k % 3].map(|x| x as u64);
            if let Some(e) = step {
                // This cell's neighbour `d` is the last cell's `d + e`.
                let o = [0, 1, 2].map(|a| d[a] as i64 + e[a]);
                if o.iter().all(|x| (0..3).contains(x)) {
                    let j = (9 * o[0] + 3 * o[1] + o[2]) as usize;
                    cur[k] = last_at[j];
                    return last_runs[j].clone();
                }
            }
            let Some(q) = neighbour(at, d) else {
                return 0..0;
            };
            let kq = key(q);
            let from = if cur[k] == usize::MAX { c } else { cur[k] };
            match self.find_from(from, kq) {
                Ok(i) => {
                    cur[k] = i;
                    self.cell_points(i)
                }
                Err(i) => {
                    cur[k] = i.min(self.keys.len() - 1);
                    0..0
                }
            }
        });
        cursor.last = Some(at);
        cursor.runs = runs.clone();
        runs
    }

    /// The cells of group `g` (`key >> 3 GROUP`), empty if none.
    pub(super) fn group_cells(&self, g: u64) -> Range<usize> {
        match self.group_keys.binary_search(&g) {
            Ok(i) => self.group_start[i] as usize..self.group_start[i + 1] as usize,
            Err(_) => 0..0,
        }
    }

    /// Fills `t` with group `g`'s cells and the cells facing it in the 26
    /// groups around.
    pub(super) fn fill(&self, g: u64, t: &mut Table) {
        t.runs.fill([0, 0]);
        let at = coords(g);
        let top = ((1u64 << BITS) - 1) >> GROUP;
        let low = (1u64 << (3 * GROUP)) - 1;
        for d in 0..27 {
            let d = [d / 9, d / 3 % 3, d % 3].map(|x| x as i64 - 1);
            let mut n = [0u64; 3];
            // A neighbour `-1` along an axis shows its cells at local
            // coordinate SIDE - 1 there (all that axis's bits set), `+1`
            // its cells at 0 (none set), `0` all of them.
            let (mut mask, mut want) = (0u64, 0u64);
            let mut outside = false;
            for a in 0..3 {
                let x = at[a] as i64 + d[a];
                outside |= x < 0 || x > top as i64;
                n[a] = x.max(0) as u64;
                let bits = GROUP_X >> a;
                if d[a] != 0 {
                    mask |= bits;
                }
                if d[a] < 0 {
                    want |= bits;
                }
            }
            if outside {
                continue;
            }
            for c in self.group_cells(key(n)) {
                let k = self.keys[c];
                if k & mask != want {
                    continue;
                }
                let l = coords(k & low);
                let i = [0, 1, 2].map(|a| (d[a] * SIDE as i64 + l[a] as i64 + 1) as usize);
                t.runs[(i[0] * TSIDE + i[1]) * TSIDE + i[2]] = [self.start[c], self.start[c + 1]];
            }
        }
    }

    /// `runs27` from a table filled for cell `c`'s group.
    pub(super) fn runs_from(&self, c: usize, t: &Table) -> [Range<usize>; 27] {
        let low = (1u64 << (3 * GROUP)) - 1;
        let l = coords(self.keys[c] & low).map(|x| x as usize);
        std::array::from_fn(|k| t.run([l[0] + k / 9, l[1] + k / 3 % 3, l[2] + k % 3]))
    }

    /// The cell of key `k`, or where it would be, searched outwards from
    /// cell `from` (galloping, then binary search).
    fn find_from(&self, from: usize, k: u64) -> std::result::Result<usize, usize> {
        let keys = &self.keys;
        if keys[from] == k {
            Ok(from)
        } else if keys[from] < k {
            let mut step = 1;
            while from + step < keys.len() && keys[from + step] < k {
                step *= 2;
            }
            let lo = from + step / 2;
            let hi = (from + step + 1).min(keys.len());
            keys[lo..hi]
                .binary_search(&k)
                .map(|i| lo + i)
                .map_err(|i| lo + i)
        } else {
            let mut step = 1;
            while step <= from && keys[from - step] > k {
                step *= 2;
            }
            let lo = from.saturating_sub(step);
            let hi = from - step / 2 + 1;
            keys[lo..hi]
                .binary_search(&k)
                .map(|i| lo + i)
                .map_err(|i| lo + i)
        }
    }
}
