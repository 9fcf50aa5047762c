//! `sssingle`: single scattering `ssS` at every point, for one eye.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("sssingle", pcsss::cli::stages::sssingle::run)
}
