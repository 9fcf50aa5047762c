//! Each stage's command line and what it does with it, from reading its
//! input to writing its output: the binaries in `src/bin/` call these,
//! and so does the Python module (`python/`), which hands a stage its
//! input and takes its output in memory ([`super::IoArgs::memory`]).

pub mod facet;
pub mod filter;
pub mod follow;
pub mod illum;
pub mod measure;
pub mod pctile;
pub mod promote;
pub mod render;
pub mod scatter;
pub mod ssmulti;
pub mod sssingle;
pub mod texture;
