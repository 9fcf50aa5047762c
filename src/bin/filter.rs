//! `filter`: `ssM` at shade points from a cloud (Houdini's `SsMulti` with
//! `pcfilter`).

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("filter", pcsss::cli::stages::filter::run)
}
