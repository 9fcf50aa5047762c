//! Wavefront OBJ meshes, then their triangulation and measures.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    pcsss::tools::fuzz::obj(data);
});
