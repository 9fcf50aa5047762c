//! The physical medium's table for thin parts, written by `cargo run --release
//! --example medium_slab_table -- src/medium/slab_table` (do not edit): at
//! each node of `table::G` and `table::ETA` and each slab thickness in
//! [`THICKNESS`] mean free paths, a random walk of [`PATHS`] paths along the
//! normal into a slab that absorbs nothing, the share of the light refracted in
//! that leaves through either face after `n` scattering events in each bin of
//! `walk::edges()`, the survivors' share last (the light that crosses unscattered
//! is in no bin), and the share that leaves through the far face; one file per
//! node of `g`.

#![cfg_attr(rustfmt, rustfmt_skip)]

/// Slab thicknesses, in mean free paths.
pub const THICKNESS: [f64; 12] = [0.03, 0.1, 0.2, 0.3, 0.5, 1.0, 2.0, 3.0, 5.0, 10.0, 20.0, 30.0];
/// Paths walked at each node.
pub const PATHS: u64 = 200000;

mod g0;
mod g1;
mod g2;
mod g3;
mod g4;
mod g5;
mod g6;
mod g7;
mod g8;

/// Per node of `G`, its rows (`eta` major, thickness minor): the shares of each bin and the survivors'.
pub static SHARES: [&[[f32; 69]; 96]; 9] = [&g0::SHARES, &g1::SHARES, &g2::SHARES, &g3::SHARES, &g4::SHARES, &g5::SHARES, &g6::SHARES, &g7::SHARES, &g8::SHARES];

/// Per node of `G`, its rows: the shares of each bin that leave through the far face.
pub static THROUGH: [&[[f32; 68]; 96]; 9] = [&g0::THROUGH, &g1::THROUGH, &g2::THROUGH, &g3::THROUGH, &g4::THROUGH, &g5::THROUGH, &g6::THROUGH, &g7::THROUGH, &g8::THROUGH];
