//! `pctile`: spatial tiles of a cloud with halos (split), and the owned
//! points of baked tiles back in the input's order (merge).

use std::process::ExitCode;

pcsss::global_allocator!();

fn main() -> ExitCode {
    pcsss::cli::stages::pctile::main()
}
