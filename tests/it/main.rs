//! One integration-test binary: the real stage binaries and the library,
//! against fixtures and independent truth. One module per area.

mod usd;
mod usd_frames;
mod usd_in;
mod util;

mod bad_input_table;
// The tiled bakes mostly wait on make, Slurm and openjd: libtest starts
// tests in name order, and these start first so that the others fill
// their waits.
mod bake_tiled;
mod blue_noise;
mod bvh;
mod chain;
mod cli;
mod dome;
mod exr_format;
mod facet;
mod filter_render;
mod follow;
mod frames;
mod furnace;
mod fuzz_replay;
mod hostile;
mod hostile4;
mod illum;
mod inputs_kept;
mod layers;
mod material;
mod measure;
mod mesh_input;
mod pcdiff;
mod per_point;
mod pipelines_make;
mod ply_bad_input;
mod ply_roundtrip;
mod promote;
mod props;
mod python_interop;
mod python_module;
mod render_pixels;
mod scatter;
mod shadow_rays;
mod ssmulti;
mod sssingle;
mod texture;
mod tiles;
mod tiles_belong;
