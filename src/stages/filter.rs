//! `filter`: `ssM` at shade points, reconstructed from the cloud (the
//! Houdini shader's `SsMulti` with `pcfilter`).
//!
//! At a shade point S the cloud points used are the `nfp` nearest, or all
//! within a radius (the slides' "better parameterisation": a fraction of
//! the scattering distance D, so it needs no retuning when the density
//! changes); with `facing`, only cloud points whose normal is on S's side
//! (`dot(N_i, N_S) > 0`, as Houdini's `pcopen` does when given N). They
//! are averaged with Houdini's `pcfilter` weights
//!
//! ```text
//! w_i = 1 - smoothstep(0, 1.1 maxd, d_i),   ssM(S) = sum w_i ssM_i / sum w_i
//! ```
//!
//! `maxd` the distance of the farthest point used (a single point, or
//! points all at S, get weight 1). The weights depend only on distance,
//! so a field linear in position is reproduced at the weighted centroid
//! `c = sum w_i P_i / sum w_i` of the points used: the bias is
//! `grad . (c - S)`, zero where the neighbourhood is balanced around S
//! (inside an even cloud), largest at open edges. A shade point with no
//! cloud point in reach gets `ssM = 0` and is counted.
//!
//! Lazy mode (Houdini's `pcunshaded`): when the cloud has `illum` but no
//! `ssM`, `ssM` is computed with `ssmulti`'s code only for the cloud points
//! some shade point reads (leaf by leaf: 64 points in a Morton run), each
//! once; the values are bit for bit those of a full `ssmulti` run.

use glam::DVec3;
use rayon::prelude::*;

use crate::cloud::{Cloud, DetailValue, Role};
use crate::error::{Error, Result};
use crate::geom::grid::bounds;
use crate::geom::grid::dense::RadiusGrid;
use crate::geom::kdtree::PointTree;
use crate::geom::mesh::TriMesh;
use crate::lights::Light;
use crate::maths::smoothstep;
use crate::progress::Progress;
use crate::stages::{ssmulti, sssingle};

/// Shade points whose neighbours are held at once.
const FILTER_CHUNK: usize = 1 << 15;

/// Which cloud points a shade point reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reach {
    /// The `n` nearest (facing ones, with `facing`).
    Nearest(usize),
    /// All within this distance (absolute; the stage turns a fraction of
    /// D into it).
    Radius(f64),
}

/// Parameters of `filter`.
#[derive(Clone, Debug, PartialEq)]
pub struct Params {
    pub reach: Reach,
    /// Only cloud points whose normal faces the shade point's side.
    pub facing: bool,
}

/// What `filter` did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    pub shade_points: usize,
    pub cloud_points: usize,
    /// Shade points with no cloud point in reach (given `ssM = 0`).
    pub empty: usize,
    /// Mean number of cloud points a shade point read.
    pub mean_used: f64,
    /// Lazy evaluation: per attribute computed, the cloud points read by
    /// some shade point and the cloud points it was computed at (ssM:
    /// whole leaves; ssS: those the eye sees).
    pub lazy: Vec<(String, usize, usize)>,
    /// What the lazy stages warned of (sssingle's points off the mesh...).
    pub warnings: Vec<String>,
}

/// The cloud's positions indexed for one kind of reach: a dense grid for
/// a radius (built on every thread, read without a search), a k-d tree
/// for the nearest (relative to the cloud's box's centre, so that a
/// cloud far from the origin keeps its precision).
pub struct CloudIndex {
    points: Index,
    nrm: Option<Vec<DVec3>>,
}

enum Index {
    Radius(RadiusGrid),
    /// The tree and how many are read.
    Nearest(PointTree, usize),
}

impl CloudIndex {
    /// Indexes `cloud`'s `P` (and `N` when `with_normals`) for `reach`.
    pub fn new(cloud: &Cloud, with_normals: bool, reach: Reach) -> Result<CloudIndex> {
        let p = cloud.points().vec3_f64("P")?;
        if let Some(i) = p.iter().position(|q| !q.iter().all(|x| x.is_finite())) {
            return Err(Error::invalid(format!(
                "cloud point {i}: P is {:?}, not finite",
                p[i]
            )));
        }
        let nrm = if with_normals {
            let n = cloud.points().vec3_f64("N")?;
            let unit: Vec<DVec3> = n
                .iter()
                .map(|v| DVec3::from_array(*v).normalize_or_zero())
                .collect();
            if let Some(i) = unit.iter().position(|v| *v == DVec3::ZERO) {
                return Err(Error::invalid(format!(
                    "cloud point {i}: N is {:?}, which has no direction (reading only facing points needs one)",
                    n[i]
                )));
            }
            Some(unit)
        } else {
            None
        };
        let pts: Vec<DVec3> = p.iter().map(|q| DVec3::from_array(*q)).collect();
        let points = match reach {
            Reach::Radius(r) => Index::Radius(RadiusGrid::new(&pts, r)),
            Reach::Nearest(k) => {
                let (lo, hi) = bounds(&pts);
                let centre = if pts.is_empty() {
                    DVec3::ZERO
                } else {
                    (lo + hi) * 0.5
                };
                Index::Nearest(PointTree::new(pts, centre), k)
            }
        };
        Ok(CloudIndex { points, nrm })
    }

    /// The cloud points a shade point at `s` with normal `n` reads, as
    /// (index, distance): with a radius, in the grid's order; the nearest,
    /// nearest first.
    pub fn neighbours(&self, s: DVec3, n: Option<DVec3>) -> Vec<(u32, f64)> {
        let mut out = Vec::new();
        self.neighbours_into(s, n, &mut out);
        out
    }

    /// [`CloudIndex::neighbours`] into `out` (cleared first): a caller
    /// that reuses one list saves growing a new one every shade point.
    pub fn neighbours_into(&self, s: DVec3, n: Option<DVec3>, out: &mut Vec<(u32, f64)>) {
        out.clear();
        let faces = |i: u32| match (&self.nrm, n) {
            (Some(nrm), Some(n)) => nrm[i as usize].dot(n) > 0.0,
            _ => true,
        };
        match &self.points {
            Index::Radius(grid) => {
                grid.for_each_within(s, |i, d2| {
                    if faces(i) {
                        out.push((i, d2.sqrt()));
                    }
                });
            }
            &Index::Nearest(ref tree, k) => {
                let total = tree.len();
                if total == 0 {
                    return;
                }
                // Nearest facing ones: ask for more until there are k.
                let mut ask = k.min(total);
                loop {
                    let near = tree.nearest(s, ask);
                    out.clear();
                    out.extend(
                        near.iter()
                            .filter(|nb| faces(nb.item))
                            .map(|nb| (nb.item, nb.distance.sqrt()))
                            .take(k),
                    );
                    if out.len() >= k || ask >= total {
                        break;
                    }
                    ask = (ask * 4).min(total);
                }
            }
        }
        // In the index's order, not sorted by point: the index depends
        // only on the cloud's points, so the sums are the same on any
        // thread count, and sorting every list would be a large part of
        // `render`'s time. A tile's index is another: its sums may differ
        // from the whole cloud's in the last bits.
    }
}

/// `1 - smoothstep(0, 1.1 maxd, d)` (1 when `maxd` is 0).
pub fn pcfilter_weight(d: f64, maxd: f64) -> f64 {
    let e = 1.1 * maxd;
    if e <= 0.0 {
        return 1.0;
    }
    1.0 - smoothstep(0.0, e, d)
}

/// Turns a shade point's neighbours' distances into their `pcfilter`
/// weights, in place: once for every attribute averaged with them.
pub fn weigh(nb: &mut [(u32, f64)]) {
    let maxd = nb.iter().map(|a| a.1).fold(0.0, f64::max);
    for a in nb {
        a.1 = pcfilter_weight(a.1, maxd);
    }
}

/// Weighted average of `values` over the neighbours and their weights
/// ([`weigh`]); `None` with no neighbour (or no weight).
pub fn average(nb: &[(u32, f64)], values: &[[f32; 3]]) -> Option<[f64; 3]> {
    let (mut s, mut ws) = ([0.0f64; 3], 0.0f64);
    for &(i, w) in nb {
        let v = values[i as usize];
        for c in 0..3 {
            s[c] += w * v[c] as f64;
        }
        ws += w;
    }
    (ws > 0.0).then(|| s.map(|x| x / ws))
}

/// The attributes `filter` gives shade points by default: the scattering
/// stages' (when the cloud has them or they can be computed).
pub const SCATTERING: [&str; 2] = ["ssM", "ssS"];

/// What `sssingle` needs to compute `ssS` lazily.
pub struct SingleSetup<'a> {
    pub mesh: &'a TriMesh,
    pub lights: &'a [Light],
    pub params: &'a sssingle::Params,
}

/// What the walk method needs to compute `ssM` lazily
/// (`ssmulti --method walk`): the closed mesh the points lie on, and the
/// walks.
pub struct WalkSetup<'a> {
    pub mesh: &'a TriMesh,
    pub walk: ssmulti::walk::WalkParams,
    /// The lights the walks sample (`ssmulti --lights`), if they do.
    pub lights: Option<&'a [crate::lights::Light]>,
}

/// How `ssM` and `ssS` a cloud lacks are computed (none: they are not).
#[derive(Clone, Copy, Default)]
pub struct Lazy<'a> {
    /// ssmulti's parameters.
    pub multi: Option<&'a ssmulti::Params>,
    /// With `multi`, by the walk method.
    pub walk: Option<&'a WalkSetup<'a>>,
    pub single: Option<&'a SingleSetup<'a>>,
}

/// Where one filtered attribute's values come from.
#[derive(Clone, Copy)]
pub enum Source<'a> {
    /// The cloud's colour or 3-vector attribute of this name.
    Stored(&'a str),
    /// `ssM`, computed with ssmulti's code for the points read: by the
    /// diffusion method, or with a walk setup by the walk method.
    Multi(&'a ssmulti::Params, Option<&'a WalkSetup<'a>>),
    /// `ssS`, computed with sssingle's code for the points read (those
    /// the eye sees: the others are 0).
    Single(&'a SingleSetup<'a>),
}

impl Source<'_> {
    /// The attribute it gives the shade points.
    pub fn name(&self) -> &str {
        match self {
            Source::Stored(n) => n,
            Source::Multi(..) => "ssM",
            Source::Single(_) => "ssS",
        }
    }
}

/// The sources for the attributes `names` (none: every scattering
/// attribute, [`SCATTERING`], the cloud has or can compute). An attribute
/// the cloud has is read; `ssM` and `ssS` it lacks are computed lazily
/// as `lazy` says; anything else is an error that says how to make it.
pub fn sources<'a>(cloud: &Cloud, names: &'a [String], lazy: Lazy<'a>) -> Result<Vec<Source<'a>>> {
    let Lazy {
        multi,
        walk,
        single,
    } = lazy;
    let pick = |name: &'a str| -> Option<Source<'a>> {
        if cloud.points().has(name) {
            return Some(Source::Stored(name));
        }
        match name {
            "ssM" => multi.map(|p| Source::Multi(p, walk)),
            "ssS" => single.map(Source::Single),
            _ => None,
        }
    };
    if names.is_empty() {
        let found: Vec<Source> = SCATTERING.iter().filter_map(|n| pick(n)).collect();
        if found.is_empty() {
            return Err(Error::invalid(
                "no point attribute 'ssM' (made by ssmulti) or 'ssS' (made by sssingle): run them, or give ssmulti's parameters (sd, rd, ...) to compute ssM for the points read",
            ));
        }
        return Ok(found);
    }
    names
        .iter()
        .map(|n| {
            pick(n).ok_or_else(|| match n.as_str() {
                "ssM" => Error::invalid(
                    "no point attribute 'ssM' (made by ssmulti): run ssmulti, or give its parameters (sd, rd, ...) to compute it for the points read",
                ),
                "ssS" => Error::invalid(
                    "no point attribute 'ssS' (made by sssingle): run sssingle, or give its mesh, lights and eye to compute it for the points read",
                ),
                _ => cloud.points().missing(n),
            })
        })
        .collect()
}

/// The scattering distance D that a filter radius is a fraction of:
/// `sd * max(Rd)` of the ssmulti parameters given, else of those ssmulti
/// recorded in the cloud (`ssmulti_sd`, `ssmulti_rd`), else sssingle's
/// (its seed model's `sd * max(Rd)`, its physical model's largest mean
/// free path), given or recorded.
pub fn distance(
    cloud: &Cloud,
    multi: Option<&ssmulti::Params>,
    single: Option<&sssingle::Params>,
) -> Result<f64> {
    let max = |v: [f64; 3]| v.iter().copied().fold(0.0, f64::max);
    let recorded = |sd: &str, rd: &str| -> Option<Result<f64>> {
        let sd_v = cloud.detail_f64(sd).ok()?;
        let rd_v = cloud.detail(rd).map_or(vec![1.0], |v| v.components());
        if !(sd_v.is_finite() && sd_v >= 0.0) || rd_v.iter().any(|x| !(x.is_finite() && *x >= 0.0))
        {
            return Some(Err(Error::invalid(format!(
                "the cloud records {sd} = {sd_v:?} and {rd} = {rd_v:?}: not a distance and reflectances >= 0"
            ))));
        }
        Some(Ok(sd_v * max3(&rd_v)))
    };
    let physical = cloud
        .detail("ssmulti_distances")
        .map(|v| max3(&v.components()));
    let d = if let Some(p) = multi {
        max(p.distances())
    } else if let Some(d) = physical.filter(|d| d.is_finite() && *d > 0.0) {
        d
    } else if let Some(d) = recorded("ssmulti_sd", "ssmulti_rd") {
        d?
    } else if let Some(p) = single {
        match p.model {
            sssingle::Model::Seed => p.sd * max(p.rd),
            sssingle::Model::Physical => max(p.mfp),
        }
    } else if let Some(d) = recorded("sssingle_sd", "sssingle_rd") {
        d?
    } else if let Some(v) = cloud.detail("sssingle_mfp") {
        max3(&v.components())
    } else {
        return Err(Error::invalid(
            "no scattering distance to take the filter radius from: the cloud records none (ssmulti_sd) and no sd is given; give nfp, or sd",
        ));
    };
    if d.is_finite() && d > 0.0 {
        Ok(d)
    } else {
        Err(Error::invalid(format!(
            "the scattering distance D = sd * max(Rd) is {d}: a filter radius needs D > 0"
        )))
    }
}

fn max3(v: &[f64]) -> f64 {
    v.iter().copied().fold(0.0, f64::max)
}

/// The filter radius a stage takes when given none: this fraction of D.
pub const DEFAULT_RADIUS: f64 = 0.25;
/// ... and never less than this many of the cloud's spacings
/// ([`spacing`]): about a dozen points read on an even cloud, so that a
/// short scattering distance does not leave shade points with none.
pub const SPACINGS: f64 = 2.0;

/// The cloud's point spacing, the side of a point's mean share of the
/// surface: `sqrt(Tarea / scatter_count)` from the details scatter and
/// promote recorded (a tile carries them too), else `sqrt(mean ptarea)`
/// of the points, except on a tile (its own points are not the cloud's
/// and pctile's halo is set from the details alone), else none.
pub fn spacing(cloud: &Cloud) -> Option<f64> {
    let ok = |x: f64| (x.is_finite() && x > 0.0).then_some(x);
    let recorded = cloud
        .detail_f64("Tarea")
        .ok()
        .zip(cloud.detail_f64("scatter_count").ok())
        .and_then(|(a, n)| ok((a / n).sqrt()));
    if recorded.is_some() {
        return recorded;
    }
    if cloud.detail(crate::names::D_TILE).is_some() {
        return None;
    }
    let a = cloud.points().scalar_f64("ptarea").ok()?;
    let (sum, n) = a
        .iter()
        .filter(|x| x.is_finite() && **x > 0.0)
        .fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
    ok((sum / n as f64).sqrt())
}

/// The cloud points a shade point reads: the `nfp` nearest, else all
/// within `radius`, a fraction of D ([`distance`]), finite and > 0;
/// without one, [`DEFAULT_RADIUS`] of D but at least [`SPACINGS`]
/// spacings, and for the physical model's ssM (given, or computed
/// lazily) [`SPACINGS`] spacings alone when the spacing is known. Also
/// says when the spacing raised the radius.
pub fn reach(
    cloud: &Cloud,
    nfp: Option<usize>,
    radius: Option<f64>,
    multi: Option<&ssmulti::Params>,
    single: Option<&sssingle::Params>,
) -> Result<(Reach, Option<String>)> {
    if let Some(n) = nfp {
        return Ok((Reach::Nearest(n), None));
    }
    if let Some(radius) = radius {
        if !(radius.is_finite() && radius > 0.0) {
            return Err(Error::param(
                "radius",
                format!("{radius}: must be a finite fraction > 0"),
            ));
        }
        return Ok((
            Reach::Radius(radius * distance(cloud, multi, single)?),
            None,
        ));
    }
    // The physical model's ssM is each point's exitance, its kernel sum
    // done: a shade point's filter need only interpolate between points,
    // and a wider one would blur sharp edges of light (a shadow's, a
    // crease's) that the path tracer keeps (docs/DESIGN.md#filter).
    let physical = match multi {
        Some(p) => p.medium.is_some(),
        None => matches!(
            cloud.detail("ssmulti_model"),
            Some(DetailValue::Str(m)) if m == "physical"
        ),
    };
    if physical {
        if let Some(h) = spacing(cloud) {
            return Ok((Reach::Radius(SPACINGS * h), None));
        }
    }
    let r = DEFAULT_RADIUS * distance(cloud, multi, single)?;
    match spacing(cloud).map(|h| SPACINGS * h) {
        Some(floor) if floor > r => Ok((
            Reach::Radius(floor),
            Some(format!(
                "filter radius {floor:.4e}: {SPACINGS} times the cloud's spacing, above {DEFAULT_RADIUS} of D ({r:.4e})"
            )),
        )),
        _ => Ok((Reach::Radius(r), None)),
    }
}

/// The farthest a cloud point can be from a shade point whose values
/// depend on it, reading `reach` with `sources`: the radius, plus
/// ssmulti's reach where `ssM` is computed lazily (the points read need
/// their own sources). `None` for the nearest, which have no bound. A
/// tile of the cloud needs a halo at least this wide.
pub fn halo_reach(reach: Reach, sources: &[Source]) -> Option<f64> {
    let lazy = |s: &Source| match s {
        Source::Multi(p, _) => p.reach(),
        // ssS at a point needs only the lights and the mesh.
        Source::Stored(_) | Source::Single(_) => 0.0,
    };
    match reach {
        Reach::Radius(r) => Some(r + sources.iter().map(lazy).fold(0.0, f64::max)),
        Reach::Nearest(_) => None,
    }
}

/// What `filter` and `render` read and how: the parameters and where
/// each attribute comes from, set up once from their options.
pub struct Setup<'a> {
    pub params: Params,
    pub sources: Vec<Source<'a>>,
    /// What set the radius, when the cloud's spacing did.
    pub note: Option<String>,
}

impl<'a> Setup<'a> {
    /// The sources of `attrs` on `cloud` ([`sources`]: with ssmulti's and
    /// sssingle's parameters when `ssM` or `ssS` is computed lazily), the
    /// reach ([`reach`]: the `nfp` nearest, or within `radius` of D, by
    /// default a quarter of it but at least two spacings), and whether
    /// only `facing` points are read.
    pub fn new(
        cloud: &Cloud,
        attrs: &'a [String],
        lazy: Lazy<'a>,
        nfp: Option<usize>,
        radius: Option<f64>,
        facing: bool,
    ) -> Result<Setup<'a>> {
        let sources = sources(cloud, attrs, lazy)?;
        let single = lazy.single.map(|s| s.params);
        let (reach, note) = reach(cloud, nfp, radius, lazy.multi, single)?;
        Ok(Setup {
            params: Params { reach, facing },
            sources,
            note,
        })
    }
}

impl Report {
    /// What a stage says of the run: information lines, and warnings.
    pub fn messages(&self) -> (Vec<String>, Vec<String>) {
        let mut info = vec![format!(
            "{} shade points from {} cloud points, {:.1} read each on average",
            self.shade_points, self.cloud_points, self.mean_used
        )];
        for (name, read, computed) in &self.lazy {
            info.push(format!(
                "lazy: {name} computed at {computed} of {} cloud points ({read} read)",
                self.cloud_points
            ));
        }
        let mut warn = self.warnings.clone();
        if self.empty > 0 {
            warn.push(format!(
                "{} shade points had no cloud point in reach: 0 there",
                self.empty
            ));
        }
        (info, warn)
    }
}

/// Gives the shade points `shade` each attribute of `sources` from
/// `cloud`, with one search for the cloud points each shade point reads.
/// An error about the cloud names it (`cloud_name`, [`Error::In`]).
pub fn filter(
    cloud: &Cloud,
    cloud_name: &str,
    shade: &mut Cloud,
    p: &Params,
    sources: &[Source],
    progress: &Progress,
) -> Result<Report> {
    match p.reach {
        Reach::Nearest(0) => return Err(Error::param("nfp", "must be at least 1")),
        Reach::Radius(r) if !(r.is_finite() && r > 0.0) => {
            return Err(Error::param(
                "radius",
                format!("{r:?}: must be a finite distance > 0"),
            ))
        }
        _ => {}
    }
    let sp = shade.points().vec3_f64("P")?;
    if let Some(i) = sp.iter().position(|q| !q.iter().all(|x| x.is_finite())) {
        return Err(Error::invalid(format!(
            "shade point {i}: P is {:?}, not finite",
            sp[i]
        )));
    }
    let sn: Option<Vec<DVec3>> = if p.facing {
        if !shade.points().has("N") {
            return Err(shade.points().missing_as("shade point", "N"));
        }
        if !cloud.points().has("N") {
            return Err(cloud
                .points()
                .missing_as("cloud point", "N")
                .about(cloud_name));
        }
        let n: Vec<DVec3> = shade
            .points()
            .vec3_f64("N")?
            .iter()
            .map(|v| DVec3::from_array(*v).normalize_or_zero())
            .collect();
        // (Facing needs a side: a point without one is named, not left
        // with nothing in reach.)
        if let Some(i) = n.iter().position(|v| *v == DVec3::ZERO) {
            return Err(Error::invalid(format!(
                "shade point {i}: N is {:?}, which has no direction (reading only facing points needs one)",
                shade.points().vec3_f64("N")?[i]
            )));
        }
        Some(n)
    } else {
        None
    };
    let about_cloud = |e: Error| e.about(cloud_name);
    // Tiles of `pctile split`: a cloud tile's halo must hold every source
    // a shade point reads (and, computed lazily, every source of those);
    // a shade tile's halo points are not computed (0).
    crate::halo::halo_mask(
        cloud,
        halo_reach(p.reach, sources),
        "filter's reach (radius, plus ssmulti's when computed lazily)",
    )
    .map_err(about_cloud)?;
    let own = crate::halo::owned(shade)?;
    let owns = |i: usize| own.as_ref().is_none_or(|o| o[i]);
    let index = CloudIndex::new(cloud, p.facing, p.reach).map_err(about_cloud)?;
    // Lazy sources need to know first which cloud points any shade point
    // reads: a first pass marks them, a chunk of shade points at a time
    // (their neighbour lists, 16 bytes a neighbour, would otherwise all be
    // held at once, 6 GB for 1M shade points reading 400 each), and the
    // neighbours are found again in the second.
    let lazy = sources.iter().any(|s| !matches!(s, Source::Stored(_)));
    let chunks: Vec<std::ops::Range<usize>> = (0..sp.len())
        .step_by(FILTER_CHUNK)
        .map(|a| a..(a + FILTER_CHUNK).min(sp.len()))
        .collect();
    let neighbours = |c: &std::ops::Range<usize>| -> Vec<Vec<(u32, f64)>> {
        let nb: Vec<Vec<(u32, f64)>> = c
            .clone()
            .into_par_iter()
            .map(|i| {
                if !owns(i) {
                    return Vec::new();
                }
                let q = DVec3::from_array(sp[i]);
                index.neighbours(q, sn.as_ref().map(|n| n[i]))
            })
            .collect();
        progress.inc(c.len() as u64);
        nb
    };
    let nc = cloud.len();
    let mut report = Report {
        shade_points: sp.len(),
        cloud_points: nc,
        ..Report::default()
    };
    let mut want = vec![false; nc];
    if lazy {
        progress.start("finding what is read", sp.len() as u64);
        for c in &chunks {
            for nb in neighbours(c) {
                for (i, _) in nb {
                    want[i as usize] = true;
                }
            }
        }
        progress.finish();
    }
    let read = want.iter().filter(|&&w| w).count();
    let mut values: Vec<Vec<[f32; 3]>> = Vec::with_capacity(sources.len());
    for source in sources {
        values.push(match *source {
            Source::Stored(name) => cloud.points().vec3_f32(name).map_err(about_cloud)?,
            Source::Multi(sp, None) => {
                let (v, rep) = ssmulti::ssmulti_values(cloud, sp, Some(&want), progress)
                    .map_err(about_cloud)?;
                report.lazy.push(("ssM".into(), read, rep.computed));
                v
            }
            Source::Multi(sp, Some(ws)) => {
                let (v, rep) = ssmulti::walk::walk_values(
                    cloud,
                    ws.mesh,
                    sp,
                    &ws.walk,
                    ws.lights,
                    Some(&want),
                    progress,
                )
                .map_err(about_cloud)?;
                report.lazy.push(("ssM".into(), read, rep.computed));
                report.warnings.extend(rep.warnings());
                v
            }
            Source::Single(ss) => {
                let (v, rep) = sssingle::sssingle_values(
                    cloud,
                    ss.mesh,
                    ss.lights,
                    ss.params,
                    Some(&want),
                    progress,
                )
                .map_err(about_cloud)?;
                report.lazy.push(("ssS".into(), read, rep.computed));
                report.warnings.extend(rep.warnings());
                v
            }
        });
    }
    drop(want);
    // Each shade point's values (one row of `width`) and how many cloud
    // points it read: its neighbours go into a list each thread reuses,
    // weighed once for every attribute.
    let width = sources.len().max(1);
    let mut rows = vec![[0.0f32; 3]; sp.len() * width];
    let mut counts = vec![0usize; sp.len()];
    progress.start("filtering", sp.len() as u64);
    for c in &chunks {
        rows[c.start * width..c.end * width]
            .par_chunks_mut(width)
            .zip(counts[c.clone()].par_iter_mut())
            .enumerate()
            .for_each_init(Vec::new, |nb, (j, (row, count))| {
                let i = c.start + j;
                if !owns(i) {
                    return;
                }
                let q = DVec3::from_array(sp[i]);
                index.neighbours_into(q, sn.as_ref().map(|n| n[i]), nb);
                weigh(nb);
                for (k, v) in values.iter().enumerate() {
                    row[k] = average(nb, v).map_or([0.0; 3], |x| x.map(|y| y as f32));
                }
                *count = nb.len();
            });
        progress.inc(c.len() as u64);
    }
    let (mut used, mut receivers) = (0usize, 0usize);
    for (i, &n) in counts.iter().enumerate() {
        if owns(i) {
            receivers += 1;
            used += n;
            report.empty += (n == 0) as usize;
        }
    }
    let out: Vec<Vec<[f32; 3]>> = (0..sources.len())
        .map(|k| rows.chunks(width).map(|r| r[k]).collect())
        .collect();
    progress.finish();
    for (source, rows) in sources.iter().zip(&out) {
        let role = cloud
            .points()
            .attr(source.name())
            .and_then(|a| a.role())
            .unwrap_or(Role::Color);
        shade.points_mut().set_vec3(source.name(), role, rows)?;
    }
    let reach = match p.reach {
        Reach::Nearest(n) => format!("nearest {n}"),
        Reach::Radius(r) => format!("radius {r:?}"),
    };
    shade.record(
        "filter_",
        vec![
            ("filter_reach", DetailValue::Str(reach)),
            ("filter_facing", DetailValue::I32(p.facing as i32)),
        ],
    );
    report.mean_used = if receivers == 0 {
        0.0
    } else {
        used as f64 / receivers as f64
    };
    Ok(report)
}

/// sRGB encoding of a linear value in [0, 1].
pub fn srgb(x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    if x <= 0.003_130_8 {
        12.92 * x
    } else {
        1.055 * x.powf(1.0 / 2.4) - 0.055
    }
}

/// What a source's values are multiplied by in the beauty, a radiance:
/// the physical model's `ssM` is an exitance (its radiance `ssM / pi`,
/// as ssmulti records in `ssmulti_radiance`); the seed model's `ssM`, as
/// Houdini's shader adds it, and `ssS`, a radiance, are taken as they
/// are.
pub fn radiance_scale(cloud: &Cloud, source: &Source) -> f64 {
    let physical = match source {
        Source::Multi(p, _) => p.medium.is_some(),
        Source::Stored("ssM") => matches!(
            cloud.detail("ssmulti_radiance"),
            Some(DetailValue::Str(s)) if s == crate::stages::ssmulti::RADIANCE
        ),
        _ => false,
    };
    if physical {
        std::f64::consts::FRAC_1_PI
    } else {
        1.0
    }
}

/// The physical medium whose multiple scattering a source's `ssM` is
/// (the lazy run's, or the cloud's ssmulti record), for the way its
/// radiance leaves ([`crate::stages::render::Exit`]); `None` for the
/// seed model, `ssS` and other attributes.
pub fn exit_medium(cloud: &Cloud, source: &Source) -> Option<crate::medium::Medium> {
    match source {
        // Walks from an eye's direction hold the light towards it.
        Source::Multi(_, Some(ws)) if ws.walk.eye.is_some() => None,
        Source::Multi(p, _) => p.medium,
        Source::Stored("ssM") if cloud.detail("ssmulti_eye").is_some() => None,
        Source::Stored("ssM") if radiance_scale(cloud, source) != 1.0 => {
            let s = ssmulti::Record::of(cloud).medium?;
            crate::medium::Medium::new(s.albedo?, s.mfp?, s.eta?, s.g?).ok()
        }
        _ => None,
    }
}

/// `red green blue` (uchar) on the points, the vertex colours MeshLab
/// and Blender show: sRGB of the beauty as `render` sums it (each of
/// `terms`, a name and its [`radiance_scale`]), tone mapped as render's
/// PNG, `1 - e^(-exposure x)`, with `exposure`, else clamped to [0, 1].
pub fn add_vertex_colours(
    shade: &mut Cloud,
    terms: &[(&str, f64)],
    exposure: Option<f64>,
) -> Result<()> {
    if let Some(e) = exposure {
        check_exposure(e)?;
    }
    let mut v = vec![[0.0f64; 3]; shade.len()];
    for (name, k) in terms {
        for (acc, x) in v.iter_mut().zip(shade.points().vec3_f64(name)?) {
            for c in 0..3 {
                acc[c] += k * x[c];
            }
        }
    }
    let tone = |x: f64| match exposure {
        Some(e) => 1.0 - (-e * x.max(0.0)).exp(),
        None => x,
    };
    for (c, name) in ["red", "green", "blue"].iter().enumerate() {
        let col: Vec<u8> = v
            .iter()
            .map(|x| (srgb(tone(x[c])) * 255.0 + 0.5) as u8)
            .collect();
        shade.points_mut().set(crate::cloud::Attribute::scalar(
            name,
            crate::column::Column::U8(col),
        ))?;
    }
    Ok(())
}
/// Checks a tone map's `exposure` (render's PNG, filter's vertex
/// colours): finite and above 0.
pub fn check_exposure(exposure: f64) -> Result<()> {
    if exposure.is_finite() && exposure > 0.0 {
        Ok(())
    } else {
        Err(Error::param("exposure", format!("{exposure}: must be > 0")))
    }
}
