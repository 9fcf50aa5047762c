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

/// Checks that a stage can hold its structures over a mesh of `triangles`
/// triangles, at `per_triangle` bytes each (what the stage measured at its
/// peak, with a margin): a mesh too large for the machine is one line
/// about the mesh, not an abort halfway.
pub fn check_mesh(triangles: usize, per_triangle: u64) -> Result<()> {
    let bytes = triangles as u64 * per_triangle;
    let mut probe: Vec<u8> = Vec::new();
    let ok = usize::try_from(bytes).is_ok_and(|b| probe.try_reserve_exact(b).is_ok());
    if ok {
        return Ok(());
    }
    Err(Error::unsupported(format!(
        "{triangles} triangles would need about {:.1} GiB of memory ({per_triangle} bytes a triangle), more than can be allocated here: a coarser mesh, or a machine with more memory",
        bytes as f64 / (1u64 << 30) as f64
    )))
}
