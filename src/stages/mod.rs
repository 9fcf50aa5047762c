//! The stages: pure functions from clouds to clouds, one module each.
//! The binaries in `src/bin/` only parse arguments, read, call, write.

pub mod facet;
pub mod filter;
pub mod follow;
pub mod illum;
pub mod measure;
pub mod promote;
pub mod render;
pub mod scatter;
pub mod ssmulti;
pub mod sssingle;
pub mod texture;
