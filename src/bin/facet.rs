//! `facet`: normals `N` from a mesh, on a cloud's points or the mesh's own
//! vertices.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("facet", pcsss::cli::stages::facet::run)
}
