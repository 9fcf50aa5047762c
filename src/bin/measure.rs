//! `measure`: adds face attributes `area` and `perimeter` to a mesh.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("measure", pcsss::cli::stages::measure::run)
}
