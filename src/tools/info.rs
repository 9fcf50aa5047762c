//! `pcinfo`: a cloud's summary, like `exrheader` for point clouds.

use std::fmt::Write as _;

use crate::cloud::{AttrData, Cloud, DetailValue};
use crate::column::{Column, Scalar};
use crate::geom::mesh::Polygons;
use crate::with_column as pcsss_with_column;

/// Minimum, maximum, mean and NaN count of a column (NaNs excluded).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stats {
    pub min: f64,
    pub max: f64,
    pub mean: f64,
    pub nan: usize,
}

/// Statistics of a column.
pub fn stats(c: &Column) -> Stats {
    fn typed<T: Scalar>(v: &[T]) -> Stats {
        let (mut min, mut max, mut sum, mut n) = (f64::INFINITY, f64::NEG_INFINITY, 0.0, 0usize);
        for x in v {
            let x = x.to_f64();
            if x.is_nan() {
                continue;
            }
            min = min.min(x);
            max = max.max(x);
            sum += x;
            n += 1;
        }
        Stats {
            min,
            max,
            mean: if n > 0 { sum / n as f64 } else { f64::NAN },
            nan: v.len() - n,
        }
    }
    pcsss_with_column!(c, v => typed(v))
}

fn g(v: f64) -> String {
    if v == 0.0 || (1e-4..1e7).contains(&v.abs()) {
        format!("{}", (v * 1e6).round() / 1e6)
    } else {
        format!("{v:.6e}")
    }
}

fn tuple(v: &[f64]) -> String {
    if v.len() == 1 {
        g(v[0])
    } else {
        format!(
            "({})",
            v.iter().map(|&x| g(x)).collect::<Vec<_>>().join(", ")
        )
    }
}

/// Describes a detail value.
pub fn detail_text(v: &DetailValue) -> String {
    match v {
        DetailValue::Str(s) => serde_json::to_string(s).unwrap_or_default(),
        other => tuple(&other.components()),
    }
}

/// The text `pcinfo` prints for `cloud`.
pub fn summary(cloud: &Cloud) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "points: {}", cloud.len());
    if cloud.faces().is_some() {
        match Polygons::of(cloud) {
            Ok(p) => {
                let _ = writeln!(
                    s,
                    "faces: {} polygons, {} triangles",
                    p.len(),
                    p.triangle_count()
                );
            }
            Err(e) => {
                let _ = writeln!(s, "faces: not a valid mesh ({e})");
            }
        }
    }
    for el in &cloud.elements {
        let _ = writeln!(s, "element {}: {} rows", el.name, el.len());
        let w = el.attrs().iter().map(|a| a.name.len()).max().unwrap_or(0);
        for a in el.attrs() {
            let ty = a.type_name();
            let _ = write!(s, "  {:w$}  {:22}", a.name, ty);
            match &a.data {
                AttrData::List(l) => {
                    let lens: Vec<usize> = (0..l.len()).map(|i| l.range(i).len()).collect();
                    let (lo, hi) = (lens.iter().min(), lens.iter().max());
                    if let (Some(lo), Some(hi)) = (lo, hi) {
                        let st = stats(&l.items);
                        let _ =
                            write!(s, "  {lo}..{hi} items, values {}..{}", g(st.min), g(st.max));
                    }
                }
                _ if el.is_empty() => {}
                _ => {
                    let st: Vec<Stats> = a.components().iter().map(|c| stats(c.column())).collect();
                    let pick = |f: fn(&Stats) -> f64| st.iter().map(f).collect::<Vec<_>>();
                    let _ = write!(
                        s,
                        "  min {}  max {}  mean {}",
                        tuple(&pick(|x| x.min)),
                        tuple(&pick(|x| x.max)),
                        tuple(&pick(|x| x.mean))
                    );
                    let nan: usize = st.iter().map(|x| x.nan).sum();
                    if nan > 0 {
                        let _ = write!(s, "  NaN x{nan}");
                    }
                }
            }
            s.push('\n');
        }
    }
    if !cloud.detail.is_empty() {
        let _ = writeln!(s, "detail:");
        let w = cloud.detail.iter().map(|d| d.name.len()).max().unwrap_or(0);
        for d in &cloud.detail {
            let _ = writeln!(
                s,
                "  {:w$}  {:4}  {}",
                d.name,
                d.value.tag(),
                detail_text(&d.value)
            );
        }
    }
    for c in &cloud.comments {
        let _ = writeln!(s, "comment: {c}");
    }
    for c in &cloud.obj_info {
        let _ = writeln!(s, "obj_info: {c}");
    }
    s
}

/// The most frames [`frames`] lists: a range past it is a stage's
/// mistake (or a time code per tick), not frames to bake one by one.
pub const MAX_FRAMES: f64 = 100_000.0;

/// A USD stage's frames: the whole time codes from its `startTimeCode`
/// to its `endTimeCode` (both included; a stage that states neither is
/// an error naming them, one too long a range is refused).
pub fn frames(stage_file: &std::path::Path) -> crate::error::Result<Vec<i64>> {
    use crate::error::Error;
    let Some((a, b)) = crate::formats::usd::stage_time_codes(stage_file)? else {
        return Err(Error::invalid(
            "the stage states no startTimeCode or endTimeCode: no frames to list",
        ));
    };
    let (first, last) = (a.ceil(), b.floor());
    if last - first + 1.0 > MAX_FRAMES {
        return Err(Error::invalid(format!(
            "startTimeCode {a} to endTimeCode {b}: more than {MAX_FRAMES} frames"
        )));
    }
    Ok((first as i64..=last as i64).collect())
}
