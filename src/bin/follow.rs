//! `follow`: a cloud scattered on a rest mesh, moved onto another frame of
//! the same mesh.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("follow", pcsss::cli::stages::follow::run)
}
