//! USD (formats/USD.md): clouds and meshes out as text layers, and meshes,
//! lights and cameras in from a stage (`.usda`, `.usdc`, `.usdz`).

mod gf;
mod mesh;
mod primvars;
mod scene;
pub mod stage;
mod write;

pub use mesh::{read_mesh, StageMesh};
pub use scene::{camera_json, lights_json};
pub use stage::{at_time, is_usd, split_prim, stage_file, stage_time_codes};
pub use write::{write_usda, write_usdc, write_usdz};
