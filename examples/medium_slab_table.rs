//! Writes `src/stages/medium/slab_table.rs`, the physical medium's table
//! for thin parts (`docs/DESIGN.md#thickness`): a random walk
//! (`pcsss::stages::medium::walk::walk_in`) into a slab of each thickness
//! in [`THICKNESS`] mean free paths, lit along its normal, at each node of
//! phase asymmetry `g` and relative index `eta` (those of
//! `src/stages/medium/table.rs`), its histograms of scattering events of
//! the light that leaves through either face, and through the far one.
//!
//!     cargo run --release --example medium_slab_table > src/stages/medium/slab_table.rs
//!
//! Seeded (the nodes of `(g, eta)` pair `k` by seed `k`, as the main
//! table's), so the table is the same on any machine and thread count;
//! progress goes to stderr.

use std::fmt::Write;
use std::time::Instant;

use pcsss::stages::medium::table::{ETA, G};
use pcsss::stages::medium::walk::{edges, walk_faces};

/// Slab thicknesses in mean free paths (thicker: the semi-infinite
/// medium of the main table).
const THICKNESS: [f64; 12] = [
    0.03, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 30.0,
];
const PATHS: u64 = 200_000;

fn main() {
    let nb = edges().len() - 1;
    let (mut rows, mut through_rows) = (String::new(), String::new());
    let start = Instant::now();
    for (i, &g) in G.iter().enumerate() {
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
                let cells: Vec<String> = h
                    .bins
                    .iter()
                    .chain([&h.survivors])
                    .map(|&p| format!("{:?}", p as f32))
                    .collect();
                writeln!(
                    rows,
                    "    // g {g}, eta {eta}, thickness {t}\n    [{}],",
                    cells.join(", ")
                )
                .unwrap();
                let cells: Vec<String> = through
                    .bins
                    .iter()
                    .map(|&p| format!("{:?}", p as f32))
                    .collect();
                writeln!(
                    through_rows,
                    "    // g {g}, eta {eta}, thickness {t}\n    [{}],",
                    cells.join(", ")
                )
                .unwrap();
            }
        }
    }
    eprintln!("all: {:.0} s", start.elapsed().as_secs_f64());
    let list = |v: &[f64]| {
        v.iter()
            .map(|x| format!("{x:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    print!(
        "//! The physical medium's table for thin parts, written by `cargo run --release\n\
//! --example medium_slab_table > src/stages/medium/slab_table.rs` (do not edit):\n\
//! at each node of `table::G` and `table::ETA` and each slab thickness in\n\
//! [`THICKNESS`] mean free paths (`g` major, thickness minor), a random walk of\n\
//! [`PATHS`] paths along the normal into a slab that absorbs nothing, the share\n\
//! of the light refracted in that leaves through either face after `n`\n\
//! scattering events in each bin of `walk::edges()`, the survivors' share last\n\
//! (the light that crosses unscattered is in no bin).\n\n\
#![cfg_attr(rustfmt, rustfmt_skip)]\n\n\
/// Slab thicknesses, in mean free paths.\npub const THICKNESS: [f64; {}] = [{}];\n\
/// Paths walked at each node.\npub const PATHS: u64 = {PATHS};\n\
/// Per node, the shares of each bin and the survivors'.\n\
pub static SHARES: [[f32; {}]; {}] = [\n{rows}];\n\n\
/// Per node, the shares of each bin that leave through the far face.\n\
pub static THROUGH: [[f32; {}]; {}] = [\n{through_rows}];\n",
        THICKNESS.len(),
        list(&THICKNESS),
        nb + 1,
        G.len() * ETA.len() * THICKNESS.len(),
        nb,
        G.len() * ETA.len() * THICKNESS.len(),
    );
}
