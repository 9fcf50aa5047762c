//! `illum`: direct irradiance at every point from a lights file, with
//! shadows from a mesh.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("illum", pcsss::cli::stages::illum::run)
}
