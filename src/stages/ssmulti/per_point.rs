//! Per-point materials (formats/MATERIAL.md#per-point): a material's
//! albedo (or colour) and mean free path (or diffuse one) taken at each
//! point from the cloud's attributes.
//!
//! A pair uses the receiver's material: the points are grouped by their
//! values, and each group is summed as a run of its own over every source
//! (`ssmulti_values` with the group wanted), with the medium its values
//! make. Where the attributes are constant there is one group, and the
//! run is the constant material's, bit for bit. A texture's many values
//! are rounded to a material's `levels` first; without it, more than
//! [`MAX_GROUPS`] distinct values is an error.

use std::collections::HashMap;

use super::params::Params;
pub use super::params::{Base, PerPoint, PHYSICAL_KEYS, SEED_KEYS};
use super::{record, ssmulti, ssmulti_values, Report};
use crate::cloud::{Attribute, Cloud, DetailValue, Role};
use crate::column::Scalar;
use crate::error::{Error, Result};
use crate::medium::Recipe;
use crate::progress::Progress;

/// The most groups of distinct per-point values a run takes.
pub const MAX_GROUPS: usize = 256;

/// A point's values: albedo (or colour) then distance, per channel.
type Values = [f64; 6];

/// Reads the attributes the cloud has (a scalar gives its value to every
/// channel); those it lacks leave the constant. Returns per point values
/// (albedo or colour, or Rd; then the distance, or sd in every slot), the
/// recipe's kinds, and what came from where.
fn values(
    cloud: &Cloud,
    params: &Params,
    base: &Base,
    pp: &PerPoint,
) -> Result<(Vec<Values>, Base, Vec<String>)> {
    let pts = cloud.points();
    let n = pts.len();
    let (first, second, keys): ([f64; 3], [f64; 3], &[&str]) = match base {
        Base::Physical(r) => (r.albedo, r.dist, &PHYSICAL_KEYS),
        Base::Seed => (params.rd, [params.sd; 3], &SEED_KEYS),
    };
    let mut vals = vec![[first[0], first[1], first[2], second[0], second[1], second[2]]; n];
    let mut kinds = *base;
    let mut used = Vec::new();
    for (key, attr) in &pp.attrs {
        if !keys.contains(&key.as_str()) {
            return Err(Error::param(
                "per_point",
                format!(
                    "'{key}' is not one of this model's per-point parameters ({})",
                    keys.join(", ")
                ),
            ));
        }
        if !pts.has(attr) {
            continue;
        }
        let rows: Vec<[f64; 3]> = match pts.vec3_f64(attr) {
            Ok(v) => v,
            Err(_) => pts
                .scalar_f64(attr)
                .map_err(|_| {
                    Error::invalid(format!(
                        "attribute '{attr}' (the per-point {key}) is neither a scalar nor a 3-vector"
                    ))
                })?
                .into_iter()
                .map(|x| [x; 3])
                .collect(),
        };
        if let Some(i) = rows.iter().position(|r| !r.iter().all(|x| x.is_finite())) {
            return Err(Error::invalid(format!(
                "point {i}: attribute '{attr}' (the per-point {key}) is {:?}, not finite",
                rows[i]
            )));
        }
        let off = match (key.as_str(), &mut kinds) {
            ("albedo" | "color", Base::Physical(r)) => {
                r.colour = key == "color";
                0
            }
            ("mfp" | "dmfp", Base::Physical(r)) => {
                r.diffuse = key == "dmfp";
                3
            }
            ("rd", _) => 0,
            _ => 3,
        };
        for (v, r) in vals.iter_mut().zip(&rows) {
            if key == "sd" {
                // A scattering distance is one number: the first channel.
                v[3..6].copy_from_slice(&[r[0]; 3]);
            } else {
                v[off..off + 3].copy_from_slice(r);
            }
        }
        used.push(format!("{key} from {attr}"));
    }
    Ok((vals, kinds, used))
}

/// Rounds each value on a grid of its own, the same for every cloud (so
/// tiles of one bake round alike): an albedo, colour or Rd to steps of
/// `1 / (levels - 1)`, a distance to `levels` steps per doubling.
fn round_to_levels(vals: &mut [Values], levels: u32) {
    let steps = (levels - 1) as f64;
    for v in vals.iter_mut() {
        for x in &mut v[0..3] {
            *x = (*x * steps).round() / steps;
        }
        for x in &mut v[3..6] {
            if *x > 0.0 {
                *x = ((x.log2() * levels as f64).round() / levels as f64).exp2();
            }
        }
    }
}

/// The points grouped by their per-point values (in order of each
/// group's first point, the same on every run), with each group's
/// parameters.
pub struct Groups {
    pub params: Vec<Params>,
    pub members: Vec<Vec<usize>>,
    /// What the run records: what came from where (the same whatever
    /// groups a part of the cloud holds, so tiles of one bake agree).
    pub detail: String,
}

/// Groups the points of `cloud` by the per-point values `pp` gives them,
/// over the run's parameters `base` (its medium the constant material's,
/// given as `model`); `None` when the cloud has none of the attributes.
pub fn groups(cloud: &Cloud, base: &Params, model: &Base, pp: &PerPoint) -> Result<Option<Groups>> {
    let (mut vals, kinds, used) = values(cloud, base, model, pp)?;
    if used.is_empty() {
        return Ok(None);
    }
    if let Some(l) = pp.levels {
        round_to_levels(&mut vals, l);
    }
    let mut index: HashMap<[u64; 6], usize> = HashMap::new();
    let mut groups: Vec<(Values, Vec<usize>)> = Vec::new();
    for (i, v) in vals.iter().enumerate() {
        let key = v.map(|x| (x + 0.0).to_bits());
        let g = *index.entry(key).or_insert_with(|| {
            groups.push((*v, Vec::new()));
            groups.len() - 1
        });
        groups[g].1.push(i);
        if groups.len() > MAX_GROUPS {
            let how = match pp.levels {
                None => "give the material \"levels\" to round them",
                Some(_) => "give the material fewer \"levels\"",
            };
            return Err(Error::invalid(format!(
                "the per-point material ({}) has more than {MAX_GROUPS} distinct values: {how}",
                used.join(", ")
            )));
        }
    }
    let params_of = |v: &Values, first: usize| -> Result<Params> {
        let at = |e: Error| {
            Error::invalid(format!(
                "point {first}: its per-point parameters ({}): {e}",
                used.join(", ")
            ))
        };
        let p = match kinds {
            Base::Physical(r) => {
                let r = Recipe {
                    albedo: [v[0], v[1], v[2]],
                    dist: [v[3], v[4], v[5]],
                    ..r
                };
                Params {
                    medium: Some(r.medium().map_err(at)?),
                    ..*base
                }
            }
            Base::Seed => Params {
                rd: [v[0], v[1], v[2]],
                sd: v[3],
                ..*base
            },
        };
        super::params::validate(&p).map_err(at)?;
        Ok(p)
    };
    let params = groups
        .iter()
        .map(|(v, pts)| params_of(v, pts[0]))
        .collect::<Result<_>>()?;
    let detail = format!(
        "{}{}",
        used.join(", "),
        pp.levels
            .map(|l| format!("; {l} levels"))
            .unwrap_or_default()
    );
    Ok(Some(Groups {
        params,
        members: groups.into_iter().map(|(_, m)| m).collect(),
        detail,
    }))
}

/// `ssmulti` with per-point parameters: `base` the run's parameters (its
/// medium the constant material's), `model` how that medium was given
/// (or the seed model). Returns the report and the number of groups.
pub fn ssmulti_per_point(
    cloud: &mut Cloud,
    base: &Params,
    model: &Base,
    pp: &PerPoint,
    progress: &Progress,
) -> Result<(Report, usize)> {
    let Some(Groups {
        params,
        members,
        detail,
    }) = groups(cloud, base, model, pp)?
    else {
        return Ok((ssmulti(cloud, base, progress)?, 1));
    };
    if members.len() == 1 {
        let rep = ssmulti(cloud, &params[0], progress)?;
        let mut details = record(base, &rep);
        details.push(("ssmulti_per_point", DetailValue::Str(detail)));
        cloud.record("ssmulti_", details);
        return Ok((rep, 1));
    }
    let reach = params.iter().map(|p| p.reach()).fold(0.0, f64::max);
    let own = crate::halo::halo_mask(cloud, Some(reach), "ssmulti's reach")?;
    let n = cloud.len();
    let mut out = vec![[0f32; 3]; n];
    let mut report = Report::default();
    for (pts, p) in members.iter().zip(&params) {
        let mut want = vec![false; n];
        for &i in pts {
            want[i] = own.as_ref().is_none_or(|o| o[i]);
        }
        let (rows, rep) = ssmulti_values(cloud, p, Some(&want), progress)?;
        for &i in pts {
            if want[i] {
                out[i] = rows[i];
            }
        }
        report = Report {
            computed: report.computed + pts.len(),
            isolated: report.isolated + rep.isolated,
            pairs: report.pairs + rep.pairs,
            ..rep
        };
    }
    let cols = [0, 1, 2].map(|c| out.iter().map(|r| r[c]).collect::<Vec<f32>>());
    cloud
        .points_mut()
        .set(Attribute::vec3("ssM", Role::Color, cols.map(f32::wrap)))?;
    // The constant material's record, and what varied.
    let mut details = record(base, &report);
    details.push(("ssmulti_per_point", DetailValue::Str(detail)));
    cloud.record("ssmulti_", details);
    Ok((report, members.len()))
}
