//! `promote`: reduces a point or face attribute to a detail attribute, or
//! normalises `ptarea` to the mesh's area.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("promote", pcsss::cli::stages::promote::run)
}
