//! The physical medium's reflectance table, written by `cargo run --release
//! --example medium_table -- src/medium/table` (do not edit): at each node
//! of [`G`], [`ETA`] and [`MU`], a random walk of [`PATHS`] paths along the normal,
//! [`PATHS_OBLIQUE`] at the other cosines, into a medium that absorbs nothing, the
//! share of the light refracted in that leaves after `n` scattering events in each
//! bin of `walk::edges()`, the survivors' share last; one file per node of `g`.

#![cfg_attr(rustfmt, rustfmt_skip)]

/// Nodes of the Henyey-Greenstein asymmetry.
pub const G: [f64; 9] = [-0.6, -0.3, 0.0, 0.2, 0.4, 0.6, 0.7, 0.8, 0.9];
/// Nodes of the relative index of refraction.
pub const ETA: [f64; 8] = [1.0, 1.15, 1.3, 1.45, 1.6, 2.0, 2.5, 3.0];
/// Nodes of the cosine of the light's arrival with the normal, outside.
pub const MU: [f64; 8] = [1.0, 0.85, 0.7, 0.5, 0.3, 0.15, 0.05, 0.0];
/// Paths walked at each node along the normal, and at the others.
pub const PATHS: u64 = 100000;
pub const PATHS_OBLIQUE: u64 = 40000;

mod g0;
mod g1;
mod g2;
mod g3;
mod g4;
mod g5;
mod g6;
mod g7;
mod g8;

/// Per node of `G`, its rows (`eta` major, `mu` minor): the shares of each bin and the survivors'.
pub static SHARES: [&[[f32; 69]; 64]; 9] = [&g0::SHARES, &g1::SHARES, &g2::SHARES, &g3::SHARES, &g4::SHARES, &g5::SHARES, &g6::SHARES, &g7::SHARES, &g8::SHARES];
