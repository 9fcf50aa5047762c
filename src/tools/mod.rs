//! The toolkit's helpers beside the stages: `pcinfo` ([`info`]) and
//! `pcdiff` ([`diff`]).

pub mod diff;
pub mod info;
