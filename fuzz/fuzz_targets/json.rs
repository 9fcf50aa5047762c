//! The lights file (with light masks) and the camera file.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::json(data);
});
