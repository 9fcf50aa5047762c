//! One integration-test binary: the real stage binaries and the library,
//! against fixtures and independent truth. One module per area.

mod util;

mod bvh;
mod cli;
mod exr_format;
mod filter_render;
mod geometry;
mod illum;
mod mesh_input;
mod pcdiff;
mod ply_bad_input;
mod ply_roundtrip;
mod python_interop;
mod ssmulti;
