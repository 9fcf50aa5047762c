//! PLY: header parsing and the naming convention ([`header`]), a streaming
//! reader ([`read`]) and a writer ([`write`](mod@write)). The conventions are written
//! down in `formats/PLY.md`.

pub mod header;
pub mod read;
pub mod write;

pub use header::Encoding;
pub use read::{read_ply, Select};
pub use write::write_ply;
