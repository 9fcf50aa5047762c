//! Memory a stage is about to need, asked for before the work: a count
//! from the command line or a file (`scatter -n`, a camera's size) that the
//! machine cannot hold is an error naming it, not an abort halfway.

use crate::error::{Error, Result};

/// Checks that `bytes` can be allocated now (by allocating and freeing
/// them: under `ulimit -v` or without the memory, the request fails);
/// `param` and `what` name the cause in the error.
pub fn check_available(bytes: u64, param: &str, what: &str) -> Result<()> {
    let mut probe: Vec<u8> = Vec::new();
    let ok = usize::try_from(bytes).is_ok_and(|b| probe.try_reserve_exact(b).is_ok());
    if ok {
        return Ok(());
    }
    Err(Error::param(
        param,
        format!(
            "{what} would need about {:.1} GiB of memory, more than can be allocated here",
            bytes as f64 / (1u64 << 30) as f64
        ),
    ))
}
