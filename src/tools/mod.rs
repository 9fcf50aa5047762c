//! The toolkit's helpers beside the stages: `pcinfo` ([`info`]),
//! `pcdiff` ([`diff`]), and what the fuzz targets run ([`fuzz`]).

pub mod diff;
pub mod fuzz;
pub mod info;
