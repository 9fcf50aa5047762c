//! Writes `src/stages/medium/table/`, the physical medium's reflectance
//! table (`docs/DESIGN.md#physical-medium`): a random walk
//! (`pcsss::medium::walk`) at each node of phase asymmetry `g`,
//! relative index `eta` and cosine `mu` of the light's arrival outside, its
//! histogram of scattering events; one file per node of `g`.
//!
//!     cargo run --release --example medium_table -- src/stages/medium/table
//!
//! The walks are seeded (the nodes of `(g, eta)` pair `k` by seed `k`, at
//! every cosine: their histograms share their random streams), so the
//! table is the same on any machine and thread count; progress goes to
//! stderr.

use std::path::PathBuf;
use std::time::Instant;

use pcsss::medium::walk::{edges, walk_from};

#[path = "shared/tables.rs"]
mod tables;
use tables::{cells, list, node_index, write_node, Rows};

const G: [f64; 9] = [-0.6, -0.3, 0.0, 0.2, 0.4, 0.6, 0.7, 0.8, 0.9];
const ETA: [f64; 8] = [1.0, 1.15, 1.3, 1.45, 1.6, 2.0, 2.5, 3.0];
/// Nodes of the arrival's cosine: along the normal first.
const MU: [f64; 8] = [1.0, 0.85, 0.7, 0.5, 0.3, 0.15, 0.05, 0.0];
/// Paths along the normal, and at the other cosines (fewer: what they
/// give is a correction to the normal's).
const PATHS: u64 = 100_000;
const PATHS_OBLIQUE: u64 = 40_000;

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).expect("the table's directory"));
    std::fs::create_dir_all(&dir).unwrap();
    let nb = edges().len() - 1;
    let start = Instant::now();
    for (i, &g) in G.iter().enumerate() {
        let mut rows = Vec::new();
        for (j, &eta) in ETA.iter().enumerate() {
            for &mu in &MU {
                let k = i * ETA.len() + j;
                let t = Instant::now();
                let paths = if mu == 1.0 { PATHS } else { PATHS_OBLIQUE };
                let h = walk_from(g, eta, mu, paths, k as u64);
                eprintln!(
                    "g {g} eta {eta} mu {mu}: {:.1} s, R(0.9) {:.5}, survivors {:.5}",
                    t.elapsed().as_secs_f64(),
                    h.reflectance(0.9, 1),
                    h.survivors
                );
                rows.push((
                    format!("eta {eta}, mu {mu}"),
                    cells(&h.bins, Some(h.survivors)),
                ));
            }
        }
        let shares = Rows {
            name: "SHARES",
            width: nb + 1,
            rows,
        };
        write_node(
            &dir,
            "The physical medium's reflectance table",
            i,
            g,
            &[shares],
        );
    }
    eprintln!("all: {:.0} s", start.elapsed().as_secs_f64());
    let per_g = ETA.len() * MU.len();
    let index = node_index(
        G.len(),
        &[(
            "SHARES",
            nb + 1,
            per_g,
            "Per node of `G`, its rows (`eta` major, `mu` minor): the shares of each bin and the survivors'.",
        )],
    );
    let text = format!(
        "//! The physical medium's reflectance table, written by `cargo run --release\n\
//! --example medium_table -- src/stages/medium/table` (do not edit): at each node\n\
//! of [`G`], [`ETA`] and [`MU`], a random walk of [`PATHS`] paths along the normal,\n\
//! [`PATHS_OBLIQUE`] at the other cosines, into a medium that absorbs nothing, the\n\
//! share of the light refracted in that leaves after `n` scattering events in each\n\
//! bin of `walk::edges()`, the survivors' share last; one file per node of `g`.\n\n\
#![cfg_attr(rustfmt, rustfmt_skip)]\n\n\
/// Nodes of the Henyey-Greenstein asymmetry.\npub const G: [f64; {}] = [{}];\n\
/// Nodes of the relative index of refraction.\npub const ETA: [f64; {}] = [{}];\n\
/// Nodes of the cosine of the light's arrival with the normal, outside.\npub const MU: [f64; {}] = [{}];\n\
/// Paths walked at each node along the normal, and at the others.\npub const PATHS: u64 = {PATHS};\npub const PATHS_OBLIQUE: u64 = {PATHS_OBLIQUE};\n\n{index}",
        G.len(),
        list(&G),
        ETA.len(),
        list(&ETA),
        MU.len(),
        list(&MU),
    );
    std::fs::write(dir.join("mod.rs"), text).unwrap();
}
