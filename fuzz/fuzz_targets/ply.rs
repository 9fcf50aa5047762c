//! PLY header and body (any encoding), then the mesh and a round trip of
//! whatever reads: no input may panic, hang or over-allocate.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::ply(data);
});
