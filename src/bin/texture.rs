//! `texture`: an image sampled at every point into an attribute.

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::main("texture", pcsss::cli::stages::texture::run)
}
