//! Writes `src/stages/medium/table.rs`, the physical medium's reflectance
//! table (`docs/DESIGN.md#physical-medium`): a random walk
//! (`pcsss::stages::medium::walk`) at each node of phase asymmetry `g` and
//! relative index `eta` and cosine `mu` of the light's arrival outside, its
//! histogram of scattering events.
//!
//!     cargo run --release --example medium_table > src/stages/medium/table.rs
//!
//! The walks are seeded (the nodes of `(g, eta)` pair `k` by seed `k`, at
//! every cosine: their histograms share their random streams), so the
//! table is the same on any machine and thread count; progress goes to
//! stderr.

use std::fmt::Write;
use std::time::Instant;

use pcsss::stages::medium::walk::{edges, walk_from};

const G: [f64; 9] = [-0.6, -0.3, 0.0, 0.2, 0.4, 0.6, 0.7, 0.8, 0.9];
const ETA: [f64; 8] = [1.0, 1.15, 1.3, 1.45, 1.6, 2.0, 2.5, 3.0];
/// Nodes of the arrival's cosine: along the normal first.
const MU: [f64; 8] = [1.0, 0.85, 0.7, 0.5, 0.3, 0.15, 0.05, 0.0];
/// Paths along the normal, and at the other cosines (fewer: what they
/// give is a correction to the normal's).
const PATHS: u64 = 100_000;
const PATHS_OBLIQUE: u64 = 40_000;

fn main() {
    let nb = edges().len() - 1;
    let mut rows = String::new();
    let start = Instant::now();
    for (i, &g) in G.iter().enumerate() {
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
                let cells: Vec<String> = h
                    .bins
                    .iter()
                    .chain([&h.survivors])
                    .map(|&p| format!("{:?}", p as f32))
                    .collect();
                writeln!(
                    rows,
                    "    // g {g}, eta {eta}, mu {mu}\n    [{}],",
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
        "//! The physical medium's reflectance table, written by `cargo run \
--release --example\n//! medium_table > src/stages/medium/table.rs` (do not edit): \
at each node of\n//! [`G`], [`ETA`] and [`MU`] (`g` major, `mu` minor), a random walk of [`PATHS`]\n//! paths along the normal, [`PATHS_OBLIQUE`] at the other cosines, into a\n//! medium that absorbs nothing, the share of the light refracted in that \
leaves\n//! after `n` scattering events in each bin of `walk::edges()`, the \
survivors'\n//! share last.\n\n\
#![cfg_attr(rustfmt, rustfmt_skip)]\n\n\
/// Nodes of the Henyey-Greenstein asymmetry.\npub const G: [f64; {}] = [{}];\n\
/// Nodes of the relative index of refraction.\npub const ETA: [f64; {}] = [{}];\n\
/// Nodes of the cosine of the light's arrival with the normal, outside.\npub const MU: [f64; {}] = [{}];\n\
/// Paths walked at each node along the normal, and at the others.\npub const PATHS: u64 = {PATHS};\npub const PATHS_OBLIQUE: u64 = {PATHS_OBLIQUE};\n\
/// Per node, the shares of each bin and the survivors'.\n\
pub static SHARES: [[f32; {}]; {}] = [\n{rows}];\n",
        G.len(),
        list(&G),
        ETA.len(),
        list(&ETA),
        MU.len(),
        list(&MU),
        nb + 1,
        G.len() * ETA.len() * MU.len(),
    );
}
