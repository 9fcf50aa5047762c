//! USD stages (text, crate, package) read for meshes, lights and cameras.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::usd(data);
});
