//! `scatter`: points on a mesh, stratified by area, reproducible by seed.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("scatter", pcsss::cli::stages::scatter::run)
}
