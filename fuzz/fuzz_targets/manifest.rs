//! A tile manifest (`pctile merge`'s `manifest.json`).
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::manifest(data);
});
