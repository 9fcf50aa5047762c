//! Writes `src/stages/medium/slab_table/`, the physical medium's table
//! for thin parts (`docs/DESIGN.md#thickness`): a random walk
//! (`pcsss::medium::walk::walk_faces`) into a slab of each
//! thickness in [`THICKNESS`] mean free paths, lit along its normal, at
//! each node of phase asymmetry `g` and relative index `eta` (those of
//! `src/stages/medium/table/`), its histograms of scattering events of the
//! light that leaves through either face, and through the far one; one
//! file per node of `g`.
//!
//!     cargo run --release --example medium_slab_table -- src/stages/medium/slab_table
//!
//! Seeded (the nodes of `(g, eta)` pair `k` by seed `k`, as the main
//! table's), so the table is the same on any machine and thread count;
//! progress goes to stderr.

use std::path::PathBuf;
use std::time::Instant;

use pcsss::medium::table::{ETA, G};
use pcsss::medium::walk::{edges, walk_faces};

#[path = "shared/tables.rs"]
mod tables;
use tables::{cells, list, node_index, write_node, Rows};

/// Slab thicknesses in mean free paths (thicker: the semi-infinite
/// medium of the main table).
const THICKNESS: [f64; 12] = [
    0.03, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 30.0,
];
const PATHS: u64 = 200_000;

fn main() {
    let dir = PathBuf::from(std::env::args().nth(1).expect("the table's directory"));
    std::fs::create_dir_all(&dir).unwrap();
    let nb = edges().len() - 1;
    let start = Instant::now();
    for (i, &g) in G.iter().enumerate() {
        let (mut both, mut far) = (Vec::new(), Vec::new());
        for (j, &eta) in ETA.iter().enumerate() {
            for &t in &THICKNESS {
                let k = i * ETA.len() + j;
                let s = Instant::now();
                let (h, through) = walk_faces(g, eta, 1.0, t, PATHS, k as u64);
                eprintln!(
                    "g {g} eta {eta} thickness {t}: {:.1} s, R+T(0.9) {:.5}, survivors {:.5}",
                    s.elapsed().as_secs_f64(),
                    h.reflectance(0.9, 1),
                    h.survivors
                );
                let label = format!("eta {eta}, thickness {t}");
                both.push((label.clone(), cells(&h.bins, Some(h.survivors))));
                far.push((label, cells(&through.bins, None)));
            }
        }
        let tables = [
            Rows {
                name: "SHARES",
                width: nb + 1,
                rows: both,
            },
            Rows {
                name: "THROUGH",
                width: nb,
                rows: far,
            },
        ];
        write_node(
            &dir,
            "The physical medium's table for thin parts",
            i,
            g,
            &tables,
        );
    }
    eprintln!("all: {:.0} s", start.elapsed().as_secs_f64());
    let per_g = ETA.len() * THICKNESS.len();
    let index = node_index(
        G.len(),
        &[
            ("SHARES", nb + 1, per_g, "Per node of `G`, its rows (`eta` major, thickness minor): the shares of each bin and the survivors'."),
            ("THROUGH", nb, per_g, "Per node of `G`, its rows: the shares of each bin that leave through the far face."),
        ],
    );
    let text = format!(
        "//! The physical medium's table for thin parts, written by `cargo run --release\n\
//! --example medium_slab_table -- src/stages/medium/slab_table` (do not edit): at\n\
//! each node of `table::G` and `table::ETA` and each slab thickness in\n\
//! [`THICKNESS`] mean free paths, a random walk of [`PATHS`] paths along the\n\
//! normal into a slab that absorbs nothing, the share of the light refracted in\n\
//! that leaves through either face after `n` scattering events in each bin of\n\
//! `walk::edges()`, the survivors' share last (the light that crosses unscattered\n\
//! is in no bin), and the share that leaves through the far face; one file per\n\
//! node of `g`.\n\n\
#![cfg_attr(rustfmt, rustfmt_skip)]\n\n\
/// Slab thicknesses, in mean free paths.\npub const THICKNESS: [f64; {}] = [{}];\n\
/// Paths walked at each node.\npub const PATHS: u64 = {PATHS};\n\n{index}",
        THICKNESS.len(),
        list(&THICKNESS),
    );
    std::fs::write(dir.join("mod.rs"), text).unwrap();
}
