//! `promote` (Houdini's Attribute Promote SOP): a point or face attribute
//! reduced to a detail attribute, and the `ptarea` normalisation of
//! `docs/DESIGN.md#promote`: `ptarea *= Tarea / Tptarea`.
//!
//! Sums are compensated (Neumaier) in f64; detail values are f64 (`v3d`
//! for 3-vectors). The sum over no rows is 0; mean, min and max over no
//! rows are errors. NaN in the attribute is an error naming the row.

use crate::cloud::{AttrData, Cloud, DetailValue, FACES, POINTS};
use crate::error::{Error, Result};
use crate::geom::Sum;

/// Which element to read.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Class {
    Point,
    Face,
}

/// How to reduce.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum Method {
    Sum,
    Mean,
    Min,
    Max,
}

fn reduce(vals: &[f64], method: Method, what: &str) -> Result<f64> {
    if let Some(i) = vals.iter().position(|v| v.is_nan()) {
        return Err(Error::invalid(format!("{what} is NaN at row {i}")));
    }
    if vals.is_empty() && method != Method::Sum {
        return Err(Error::invalid(format!(
            "{what}: no rows to take the {method:?} of"
        )));
    }
    Ok(match method {
        Method::Sum => vals.iter().copied().collect::<Sum>().value(),
        Method::Mean => vals.iter().copied().collect::<Sum>().value() / vals.len() as f64,
        Method::Min => vals.iter().copied().fold(f64::INFINITY, f64::min),
        Method::Max => vals.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    })
}

/// A reduction is over the whole cloud: a tile of `pctile split` (part of
/// the points, and a halo of others' points) is refused.
fn whole(cloud: &Cloud) -> Result<()> {
    if cloud.points().has(crate::names::HALO) {
        return Err(Error::invalid(format!(
            "a tile of pctile split ('{}'): promote reduces the whole cloud; run it before the split or after the merge",
            crate::names::HALO
        )));
    }
    Ok(())
}

/// Sets detail attribute `as_name` to `method` of `class` attribute `attr`.
pub fn promote(
    cloud: &mut Cloud,
    class: Class,
    attr: &str,
    method: Method,
    as_name: &str,
) -> Result<DetailValue> {
    let el_name = match class {
        Class::Point => POINTS,
        Class::Face => FACES,
    };
    whole(cloud)?;
    let el = cloud
        .element(el_name)
        .ok_or_else(|| Error::invalid(format!("no {el_name} element to promote from")))?;
    let a = el.attr(attr).ok_or_else(|| el.missing(attr))?;
    let what = format!("{el_name} attribute '{attr}'");
    let value = match &a.data {
        AttrData::Scalar(v) => DetailValue::F64(reduce(&v.column().to_f64_vec(), method, &what)?),
        AttrData::Vec3(_, c) => {
            let mut out = [0.0; 3];
            for k in 0..3 {
                out[k] = reduce(&c[k].column().to_f64_vec(), method, &what)?;
            }
            DetailValue::V3D(out)
        }
        AttrData::List(_) => {
            return Err(Error::invalid(format!(
                "{what} is a list; only scalars and 3-vectors promote"
            )))
        }
    };
    cloud.set_detail(as_name, value.clone());
    Ok(value)
}

/// The normalisation: `ptarea *= Tarea / Tptarea`, with `Tptarea` summed
/// afresh; afterwards `Tptarea` is set to the new sum (equal to `Tarea` to
/// float precision). Returns `(Tarea, Tptarea before)`.
pub fn normalize(cloud: &mut Cloud) -> Result<(f64, f64)> {
    whole(cloud)?;
    let tarea = cloud.detail_f64("Tarea").map_err(|_| {
        Error::invalid(
            "missing detail attribute 'Tarea' (run 'measure' and 'promote --class face --attr area --as Tarea' on the mesh before 'scatter')",
        )
    })?;
    if !(tarea.is_finite() && tarea > 0.0) {
        return Err(Error::invalid(format!(
            "detail attribute 'Tarea' is {tarea}: it must be finite and > 0"
        )));
    }
    let pts = cloud.points_mut();
    let ptarea = pts.scalar_f64("ptarea")?;
    let before = reduce(&ptarea, Method::Sum, "point attribute 'ptarea'")?;
    if !(before.is_finite() && before > 0.0) {
        return Err(Error::invalid(format!(
            "the sum of 'ptarea' is {before}: it must be finite and > 0 to normalise"
        )));
    }
    let k = tarea / before;
    let scaled: Vec<f64> = ptarea.iter().map(|a| a * k).collect();
    match &pts.attr("ptarea").map(|a| a.type_name()).as_deref() {
        Some("double") => pts.set_scalar("ptarea", scaled.clone())?,
        _ => pts.set_scalar("ptarea", scaled.iter().map(|&a| a as f32).collect())?,
    }
    let after = pts
        .scalar_f64("ptarea")?
        .into_iter()
        .collect::<Sum>()
        .value();
    cloud.set_detail("Tptarea", DetailValue::F64(after));
    Ok((tarea, before))
}
