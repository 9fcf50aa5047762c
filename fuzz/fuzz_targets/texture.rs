//! Texture images (PNG, OpenEXR) read for `texture --image`.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::texture(data);
});
