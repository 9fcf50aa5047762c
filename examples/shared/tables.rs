//! How `medium_table` and `medium_slab_table` write their tables: a
//! directory with a `mod.rs` (the nodes, and each table as one slice per
//! node of `g`) and one file per node of `g` holding its rows, so no file
//! is longer than a node's walks.

use std::fmt::Write;
use std::path::Path;

/// One table of a node file: its name, its row width, and its rows (a
/// label, the cells).
pub struct Rows {
    pub name: &'static str,
    pub width: usize,
    pub rows: Vec<(String, Vec<f64>)>,
}

/// The cells of a walk's histogram: its bins' shares as f32, then the
/// survivors' when `survivors` is given.
pub fn cells(bins: &[f64], survivors: Option<f64>) -> Vec<f64> {
    bins.iter().copied().chain(survivors).collect()
}

/// A list of nodes as Rust literals.
pub fn list(v: &[f64]) -> String {
    v.iter()
        .map(|x| format!("{x:?}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Writes `dir/g{k}.rs` for the `k`-th node of `g`, holding `tables`.
pub fn write_node(dir: &Path, what: &str, k: usize, g: f64, tables: &[Rows]) {
    let mut s = format!(
        "//! {what}: the rows of the node g = {g:?} (written by its example; do not edit).\n\n\
         #![cfg_attr(rustfmt, rustfmt_skip)]\n"
    );
    for t in tables {
        write!(
            s,
            "\npub static {}: [[f32; {}]; {}] = [\n",
            t.name,
            t.width,
            t.rows.len()
        )
        .unwrap();
        for (label, row) in &t.rows {
            let cells: Vec<String> = row.iter().map(|&p| format!("{:?}", p as f32)).collect();
            writeln!(s, "    // {label}\n    [{}],", cells.join(", ")).unwrap();
        }
        s.push_str("];\n");
    }
    std::fs::write(dir.join(format!("g{k}.rs")), s).unwrap();
}

/// The `mod` lines of the node files, and each table as the slices of
/// its nodes: `pub static NAME: [&[[f32; WIDTH]; ROWS]; NODES]`.
pub fn node_index(nodes: usize, tables: &[(&str, usize, usize, &str)]) -> String {
    let mut s = String::new();
    for k in 0..nodes {
        writeln!(s, "mod g{k};").unwrap();
    }
    for (name, width, rows, doc) in tables {
        let refs: Vec<String> = (0..nodes).map(|k| format!("&g{k}::{name}")).collect();
        write!(
            s,
            "\n/// {doc}\npub static {name}: [&[[f32; {width}]; {rows}]; {nodes}] = [{}];\n",
            refs.join(", ")
        )
        .unwrap();
    }
    s
}
