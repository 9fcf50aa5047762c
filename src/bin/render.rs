//! `render`: ray-cast a mesh from a pinhole camera, filter the cloud's
//! `ssM` at the hit points, write an OpenEXR image (and a PNG preview).

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("render", pcsss::cli::stages::render::run)
}
