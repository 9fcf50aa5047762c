//! OpenEXR point clouds and shade-point images, then a round trip.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::exr(data);
});
