//! `ssmulti`: multiple scattering `ssM` at every cloud point.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("ssmulti", pcsss::cli::stages::ssmulti::run)
}
