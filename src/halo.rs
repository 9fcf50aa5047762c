//! The points of a tile a stage computes (`pctile split`,
//! `formats/TILES.md`): a tile holds the points it owns and a halo of
//! other tiles' points within the stage's reach, which are sources only.
//! A stage asks [`halo_mask`] which points to compute, after it checks
//! that the halo is wide enough for its reach.

use crate::cloud::Cloud;
use crate::error::{Error, Result};
use crate::names::{D_HALO, HALO};

/// For a stage run on a tile: which points it computes (the owned ones,
/// `true`), or `None` for a cloud that is not a tile. Checks first that
/// the tile's halo is at least `reach`, the farthest a source can be from
/// a receiver in the stage (`what` says whose reach it is, for the error).
pub fn halo_mask(cloud: &Cloud, reach: Option<f64>, what: &str) -> Result<Option<Vec<bool>>> {
    let pts = cloud.points();
    if !pts.has(HALO) {
        return Ok(None);
    }
    let width = cloud.detail(D_HALO).and_then(|d| d.as_f64());
    match (reach, width) {
        (_, None) => {
            return Err(Error::invalid(format!(
                "the cloud has '{HALO}' but no detail '{D_HALO}': not a tile pctile split made"
            )))
        }
        (None, Some(_)) => {
            return Err(Error::invalid(format!(
                "{what} has no bounded reach, so a tile's halo cannot hold its sources: run it on the whole cloud"
            )))
        }
        (_, Some(w)) if !(w.is_finite() && w >= 0.0) => {
            return Err(Error::invalid(format!(
                "the tile's {D_HALO} is {w}: not a width (a tile pctile split made has one)"
            )))
        }
        (Some(r), Some(w)) if w < r => {
            return Err(Error::invalid(format!(
                "the tile's halo ({D_HALO} {w}) is narrower than {what} ({r}): split again with a halo of {r} or more"
            )))
        }
        _ => {}
    }
    owned(cloud)
}

/// Which points of a tile it owns (`pctile_halo` 0), or `None` for a
/// cloud that is not a tile.
pub fn owned(cloud: &Cloud) -> Result<Option<Vec<bool>>> {
    let pts = cloud.points();
    if !pts.has(HALO) {
        return Ok(None);
    }
    let col = pts.scalar_column(HALO)?.column();
    Ok(Some(match col.as_slice::<u8>() {
        Some(h) => h.iter().map(|&h| h == 0).collect(),
        None => (0..col.len()).map(|i| col.get_f64(i) == 0.0).collect(),
    }))
}
