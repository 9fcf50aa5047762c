//! What a stage was asked for of the medium, and the one place it is
//! decided: the model, a material file or preset ([`super::material`]),
//! the options given one by one, and what the cloud records of ssmulti's
//! run merge here into the medium the maths takes ([`Choice`]). Every
//! stage that takes the material (`ssmulti`, `sssingle`, `illum`,
//! `filter`, `render`, `pctile split --for`) and the Python module come
//! through [`Given::resolve`]; the command line only parses.
//!
//! The rules, `docs/DESIGN.md#physical-medium` and formats/MATERIAL.md:
//! - `--material` (or a record) gives the physical model; `--model seed`
//!   with it is an error.
//! - A value given one by one that the material gives otherwise is an
//!   error naming both; one it does not give is taken.
//! - Without `--material`, a cloud's record of ssmulti's medium is taken;
//!   options given beside it make a medium that must be the record's.
//! - What nobody gives is [`ALBEDO`], [`ETA`] and [`G`]; the mean free path
//!   has no default.

use super::{Medium, Model, Recipe};
use crate::error::{Error, Result};

/// The single-scattering albedo nobody gave (per channel).
pub const ALBEDO: f64 = 0.8;
/// The relative index nobody gave.
pub const ETA: f64 = 1.3;
/// The Henyey-Greenstein asymmetry nobody gave.
pub const G: f64 = 0.0;

/// A medium's parameters as given: by a material file, a preset, the
/// options one by one or a cloud's record; each `None` not given.
/// `albedo` or `color`, `mfp` or `dmfp`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spec {
    /// Where it came from: the file, `preset NAME`, `the options`.
    pub source: String,
    pub albedo: Option<[f64; 3]>,
    pub color: Option<[f64; 3]>,
    pub mfp: Option<[f64; 3]>,
    pub dmfp: Option<[f64; 3]>,
    pub eta: Option<f64>,
    pub g: Option<f64>,
    /// Parameters taken per point from the cloud's attributes: (`albedo`,
    /// `color`, `mfp` or `dmfp`, the attribute's name).
    pub per_point: Vec<(String, String)>,
    /// Per-point values rounded on a grid of this many levels (a
    /// texture's many values into few groups; `ssmulti::per_point`).
    pub levels: Option<u32>,
    /// The lengths are a preset's millimetres, not yet in the scene's
    /// unit ([`Spec::in_scene`]).
    pub in_mm: bool,
    /// A preset's millimetres were taken as the scene's units: neither the
    /// scene nor the material said how long a unit is.
    pub unit_assumed: bool,
}

impl Spec {
    /// The spec in a scene whose unit is `unit_mm` millimetres long (from
    /// the cloud's recorded `meters_per_unit`): a preset's millimetres
    /// are divided by it. With no unit, the millimetres are taken as the
    /// scene's units, and [`Spec::unit_assumed`] says so. Lengths already
    /// in the scene's units are kept.
    pub fn in_scene(&self, unit_mm: Option<f64>) -> Spec {
        let mut s = self.clone();
        if !s.in_mm {
            return s;
        }
        s.in_mm = false;
        match unit_mm {
            Some(u) => {
                s.mfp = s.mfp.map(|m| m.map(|x| x / u));
                s.dmfp = s.dmfp.map(|m| m.map(|x| x / u));
                s.source = format!("{} (a scene unit of {u} mm)", s.source);
            }
            None => s.unit_assumed = true,
        }
        s
    }

    /// True when any value of the medium is given.
    fn gives_any(&self) -> bool {
        self.albedo.is_some()
            || self.color.is_some()
            || self.mfp.is_some()
            || self.dmfp.is_some()
            || self.eta.is_some()
            || self.g.is_some()
    }

    /// Where the medium `m` differs from this whole spec (albedo, mean
    /// free path, eta and g, to 1e-9 relative; a record holds these): the
    /// first key that does, as `key spec-value against given-value`;
    /// `None` when they agree or the spec is not whole.
    pub fn mismatch(&self, m: &Medium) -> Option<String> {
        let close = |x: &[f64], y: &[f64]| {
            x.iter()
                .zip(y)
                .all(|(x, y)| (x - y).abs() <= 1e-9 * x.abs().max(y.abs()))
        };
        let (a, f, e, g) = (self.albedo?, self.mfp?, self.eta?, self.g?);
        [
            ("albedo", a.to_vec(), m.albedo.to_vec()),
            ("mfp", f.to_vec(), m.mfp.to_vec()),
            ("eta", vec![e], vec![m.eta]),
            ("g", vec![g], vec![m.g]),
        ]
        .into_iter()
        .find(|(_, have, want)| !close(have, want))
        .map(|(key, have, want)| format!("{key} {have:?} against {want:?}"))
    }
}

/// What a stage was given of the medium: the model asked for, the
/// material file or preset (read once, by the caller), and the values
/// given one by one ([`Spec::source`] `the options`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Given {
    pub model: Option<Model>,
    pub material: Option<Spec>,
    pub options: Spec,
}

/// The medium decided: the model, the index and asymmetry (the seed
/// model's sssingle takes them too), and for the physical model how the
/// medium was given ([`Recipe`], which per-point materials vary) and the
/// medium itself.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Choice {
    pub model: Model,
    pub eta: f64,
    pub g: f64,
    /// `Some` for the physical model.
    pub physical: Option<(Recipe, Medium)>,
}

impl Choice {
    /// The physical model's medium; `None` for the seed model.
    pub fn medium(&self) -> Option<Medium> {
        self.physical.map(|(_, m)| m)
    }

    /// How the physical model's medium was given; `None` for the seed
    /// model.
    pub fn recipe(&self) -> Option<Recipe> {
        self.physical.map(|(r, _)| r)
    }
}

/// The merged values before the medium is made.
struct Merged {
    model: Model,
    /// The single-scattering albedo or the surface colour (`true`).
    albedo: ([f64; 3], bool),
    /// The mean free path or the diffuse one (`true`); `None` not given.
    dist: Option<([f64; 3], bool)>,
    g: f64,
    eta: f64,
}

impl Given {
    /// The material's lengths in a scene whose unit is `unit_mm`
    /// millimetres long ([`Spec::in_scene`]). Returns the line to say when
    /// a preset is used and neither the scene nor the material says how
    /// long a unit is.
    pub fn in_scene(&mut self, unit_mm: Option<f64>) -> Option<String> {
        let m = self.material.as_mut()?;
        *m = m.in_scene(unit_mm);
        m.unit_assumed.then(|| {
            format!(
                "{}: the scene records no unit (meters_per_unit): the preset's lengths, in millimetres, are taken in the scene's units (1 unit = 1 mm); record the unit (scatter --meters-per-unit, or a USD stage's metersPerUnit) or give the material file's unit_length",
                m.source
            )
        })
    }

    /// [`Given::in_scene`] for a cloud in `frame` (its recorded unit).
    pub fn in_frame(&mut self, frame: &crate::frame::Frame) -> Option<String> {
        self.in_scene(frame.meters_per_unit.map(|m| m * 1000.0))
    }

    /// The options against the material alone, before any cloud is read:
    /// a conflict between them is an error naming both (what a record may
    /// fill in is not asked for yet).
    pub fn check(&self) -> Result<()> {
        self.merge(self.material.as_ref()).map(|_| ())
    }

    /// The medium decided, with `recorded` the medium a cloud's record of
    /// ssmulti's run holds (`ssmulti::Record`): taken when no material
    /// and no `--model seed` is given, the options then conflicting with
    /// it as with a material's; with a material too, the record must
    /// agree with the result. An error names the parameter at fault.
    pub fn resolve(&self, recorded: Option<&Spec>) -> Result<Choice> {
        let seed = self.model == Some(Model::Seed);
        let o = &self.options;
        let options = o.gives_any();
        // With options, the record's keys they give are theirs, and the
        // medium that makes is held against the record's.
        let over = |r: &Spec| {
            let mut f = r.clone();
            if o.albedo.is_some() || o.color.is_some() {
                (f.albedo, f.color) = (None, None);
            }
            if o.mfp.is_some() || o.dmfp.is_some() {
                (f.mfp, f.dmfp) = (None, None);
            }
            if o.eta.is_some() {
                f.eta = None;
            }
            if o.g.is_some() {
                f.g = None;
            }
            f
        };
        let (file, check) = match (&self.material, recorded) {
            _ if seed => (None, None),
            (Some(g), r) => (Some(g.clone()), r),
            (None, Some(r)) if options => (Some(over(r)), Some(r)),
            (None, Some(r)) => (Some(r.clone()), None),
            (None, None) => (None, None),
        };
        let choice = choose(self.merge(file.as_ref())?)?;
        if let (Some(r), Some(md)) = (check, choice.medium()) {
            if let Some(what) = r.mismatch(&md) {
                let first = [
                    ("albedo", o.albedo.is_some()),
                    ("color", o.color.is_some()),
                    ("mfp", o.mfp.is_some()),
                    ("dmfp", o.dmfp.is_some()),
                    ("eta", o.eta.is_some()),
                    ("g", o.g.is_some()),
                ]
                .into_iter()
                .find_map(|(f, given)| given.then_some(f))
                .unwrap_or("model");
                let (name, what_gave) = match &self.material {
                    Some(_) => ("material", "the material"),
                    None => (first, "the options"),
                };
                let why = format!(
                    "{what_gave} make another medium than {} has: {what} given",
                    r.source
                );
                return Err(Error::param(name, why));
            }
        }
        Ok(choice)
    }

    /// The options merged with `file` (a material, or a record taken as
    /// one) and the defaults set.
    fn merge(&self, file: Option<&Spec>) -> Result<Merged> {
        let o = &self.options;
        let Some(f) = file else {
            return Ok(Merged {
                model: self.model.unwrap_or(Model::Seed),
                albedo: match o.color {
                    Some(c) => (c, true),
                    None => (o.albedo.unwrap_or([ALBEDO; 3]), false),
                },
                dist: o.mfp.map(|m| (m, false)).or(o.dmfp.map(|d| (d, true))),
                g: o.g.unwrap_or(G),
                eta: o.eta.unwrap_or(ETA),
            });
        };
        if self.model == Some(Model::Seed) {
            let why = "seed conflicts with --material (the physical model's medium)";
            return Err(Error::param("model", why));
        }
        let clash = |name: &str, given: String, key: &str, theirs: String| {
            let why = format!(
                "{name} {given} conflicts with the material's {key} {theirs} ({})",
                f.source
            );
            Error::param(name, why)
        };
        let same = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .all(|(x, y)| (x - y).abs() <= 1e-12 * x.abs().max(y.abs()))
        };
        // Each pair of values against the material's pair.
        let pick = |keys: [&str; 2],
                    given: [Option<[f64; 3]>; 2],
                    theirs: [Option<[f64; 3]>; 2]|
         -> Result<Option<([f64; 3], bool)>> {
            let mine = given.iter().position(Option::is_some);
            let other = theirs.iter().position(Option::is_some);
            match (mine, other) {
                (Some(i), Some(j)) if i != j || !same(&given[i].unwrap(), &theirs[j].unwrap()) => {
                    Err(clash(
                        keys[i],
                        format!("{:?}", given[i].unwrap()),
                        keys[j],
                        format!("{:?}", theirs[j].unwrap()),
                    ))
                }
                (Some(i), _) => Ok(Some((given[i].unwrap(), i == 1))),
                (None, Some(j)) => Ok(Some((theirs[j].unwrap(), j == 1))),
                (None, None) => Ok(None),
            }
        };
        let albedo = pick(
            ["albedo", "color"],
            [o.albedo, o.color],
            [f.albedo, f.color],
        )?;
        let dist = pick(["mfp", "dmfp"], [o.mfp, o.dmfp], [f.mfp, f.dmfp])?;
        let scalar = |key: &str, given: Option<f64>, theirs: Option<f64>, default: f64| match (
            given, theirs,
        ) {
            (Some(x), Some(y)) if !same(&[x], &[y]) => {
                Err(clash(key, format!("{x}"), key, format!("{y}")))
            }
            (x, y) => Ok(x.or(y).unwrap_or(default)),
        };
        Ok(Merged {
            model: Model::Physical,
            albedo: albedo.unwrap_or(([ALBEDO; 3], false)),
            dist,
            g: scalar("g", o.g, f.g, G)?,
            eta: scalar("eta", o.eta, f.eta, ETA)?,
        })
    }

    /// The per-point parameters the material gives (none without one).
    pub fn per_point(&self) -> (Vec<(String, String)>, Option<u32>) {
        match &self.material {
            Some(m) => (m.per_point.clone(), m.levels),
            None => (Vec::new(), None),
        }
    }
}

/// The medium of the merged values: checked, made.
fn choose(m: Merged) -> Result<Choice> {
    let physical = match m.model {
        Model::Seed => None,
        Model::Physical => {
            let Some((dist, diffuse)) = m.dist else {
                return Err(Error::param(
                    "mfp",
                    "required by --model physical (the mean free path; or --dmfp, or --material)",
                ));
            };
            let recipe = Recipe {
                albedo: m.albedo.0,
                colour: m.albedo.1,
                dist,
                diffuse,
                eta: m.eta,
                g: m.g,
            };
            Some((recipe, recipe.medium()?))
        }
    };
    Ok(Choice {
        model: m.model,
        eta: m.eta,
        g: m.g,
        physical,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::material;

    fn options(f: impl FnOnce(&mut Spec)) -> Given {
        let mut g = Given::default();
        f(&mut g.options);
        g
    }

    #[test]
    fn defaults_conflicts_and_a_record_are_decided_here() {
        // Nothing given: the seed model, with the index and asymmetry.
        let c = Given::default().resolve(None).unwrap();
        assert_eq!(
            (c.model, c.eta, c.g, c.physical),
            (Model::Seed, ETA, G, None)
        );
        // A mean free path alone and the physical model: the default albedo.
        let mut g = options(|o| o.mfp = Some([1.0; 3]));
        g.model = Some(Model::Physical);
        let m = g.resolve(None).unwrap().medium().unwrap();
        assert_eq!(
            (m.albedo, m.mfp, m.eta, m.g),
            ([ALBEDO; 3], [1.0; 3], ETA, G)
        );
        // The physical model without a length: named.
        g.options.mfp = None;
        let e = g.resolve(None).unwrap_err();
        assert!(
            matches!(&e, Error::Param { name, .. } if name == "mfp"),
            "{e}"
        );
        // A preset and an option that gives another value: both named.
        let mut g = options(|o| o.eta = Some(1.4));
        g.material = Some(material::load("skin1").unwrap().in_scene(Some(1.0)));
        let e = g.check().unwrap_err().to_string();
        assert!(
            e.contains("eta 1.4 conflicts with the material's eta 1.3 (preset skin1"),
            "{e}"
        );
        // The same value is no conflict.
        g.options.eta = Some(1.3);
        assert_eq!(g.resolve(None).unwrap().model, Model::Physical);
        // A record is taken when nothing else gives the medium ...
        let record = Spec {
            source: "the cloud's ssmulti record".into(),
            albedo: Some([0.9; 3]),
            mfp: Some([2.0; 3]),
            eta: Some(1.3),
            g: Some(0.0),
            ..Spec::default()
        };
        let m = Given::default()
            .resolve(Some(&record))
            .unwrap()
            .medium()
            .unwrap();
        assert_eq!((m.albedo, m.mfp), ([0.9; 3], [2.0; 3]));
        // ... and an option that makes another medium is named against it.
        let e = options(|o| o.g = Some(0.5))
            .resolve(Some(&record))
            .unwrap_err();
        assert!(
            matches!(&e, Error::Param { name, .. } if name == "g"),
            "{e}"
        );
        assert!(e
            .to_string()
            .contains("another medium than the cloud's ssmulti record"));
        // --model seed leaves the record alone.
        let g = Given {
            model: Some(Model::Seed),
            ..Given::default()
        };
        assert_eq!(g.resolve(Some(&record)).unwrap().physical, None);
    }

    #[test]
    fn a_preset_s_millimetres_follow_the_scene_s_unit_once() {
        let mm = material::load("ketchup").unwrap();
        assert!(mm.in_mm);
        let cm = mm.in_scene(Some(10.0));
        let again = cm.in_scene(Some(10.0));
        assert_eq!(cm, again, "converted twice");
        for c in 0..3 {
            assert!((cm.mfp.unwrap()[c] * 10.0 - mm.mfp.unwrap()[c]).abs() < 1e-12);
        }
        assert!(!cm.unit_assumed);
        let mut g = Given {
            material: Some(mm),
            ..Given::default()
        };
        let line = g.in_scene(None).unwrap();
        assert!(line.contains("records no unit"), "{line}");
        assert!(g.material.unwrap().unit_assumed);
    }
}
