//! A material that travels: the physical model's medium written once, in
//! a JSON file (`formats/MATERIAL.md`) or named by a preset, and read by
//! every stage that takes the material options (`ssmulti`, `sssingle`,
//! `illum`, `filter`, `render`).
//!
//! The presets are the media Jensen, Marschner, Levoy and Hanrahan
//! measured ("A Practical Model for Subsurface Light Transport", SIGGRAPH
//! 2001, table 2: reduced scattering and absorption coefficients per
//! millimetre, relative index 1.3), as RenderMan's `ptfilter -material`
//! offers them. The reduced scattering coefficient is taken as the
//! scattering one with `g = 0` (what the measurement by diffusion gives):
//! single-scattering albedo `s / (s + a)`, mean free path `1 / (s + a)`
//! millimetres, divided by `unit_length` (the length of the scene's unit
//! in millimetres).

use std::path::Path;

use serde::Deserialize;

use super::spec::Spec;
use crate::error::{Error, Result};

/// The most levels a per-point value may be rounded to.
pub const MAX_LEVELS: u32 = 64;

/// Jensen et al. 2001, table 2: name, reduced scattering and absorption
/// coefficients (R, G, B) per millimetre.
pub const PRESETS: [(&str, [f64; 3], [f64; 3]); 11] = [
    ("apple", [2.29, 2.39, 1.97], [0.0030, 0.0034, 0.046]),
    ("chicken1", [0.15, 0.21, 0.38], [0.015, 0.077, 0.19]),
    ("chicken2", [0.19, 0.25, 0.32], [0.018, 0.088, 0.20]),
    ("cream", [7.38, 5.47, 3.15], [0.0002, 0.0028, 0.0163]),
    ("ketchup", [0.18, 0.07, 0.03], [0.061, 0.97, 1.45]),
    ("marble", [2.19, 2.62, 3.00], [0.0021, 0.0041, 0.0071]),
    ("potato", [0.68, 0.70, 0.55], [0.0024, 0.0090, 0.12]),
    ("skimmilk", [0.70, 1.22, 1.90], [0.0014, 0.0025, 0.0142]),
    ("wholemilk", [2.55, 3.21, 3.77], [0.0011, 0.0024, 0.014]),
    ("skin1", [0.74, 0.88, 1.01], [0.032, 0.17, 0.48]),
    ("skin2", [1.09, 1.59, 1.79], [0.013, 0.070, 0.145]),
];

/// The measured media's relative index.
pub const PRESET_ETA: f64 = 1.3;

/// The preset `name` (any case) for a scene whose unit is `unit_length`
/// millimetres long; `None` for an unknown name.
pub fn preset(name: &str, unit_length: f64) -> Option<Spec> {
    let (n, s, a) = PRESETS
        .iter()
        .find(|(n, _, _)| n.eq_ignore_ascii_case(name))?;
    Some(Spec {
        source: format!("preset {n}"),
        albedo: Some([0, 1, 2].map(|c| s[c] / (s[c] + a[c]))),
        mfp: Some([0, 1, 2].map(|c| 1.0 / (s[c] + a[c]) / unit_length)),
        eta: Some(PRESET_ETA),
        g: Some(0.0),
        ..Spec::default()
    })
}

/// A colour: one number for all three channels, or three.
#[derive(Deserialize)]
#[serde(untagged)]
enum Rgb {
    One(f64),
    Three([f64; 3]),
}

impl Rgb {
    fn get(self) -> [f64; 3] {
        match self {
            Rgb::One(x) => [x; 3],
            Rgb::Three(v) => v,
        }
    }
}

/// The file's keys (`formats/MATERIAL.md`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    #[serde(default)]
    model: Option<String>,
    #[serde(default)]
    preset: Option<String>,
    #[serde(default)]
    unit_length: Option<f64>,
    #[serde(default)]
    albedo: Option<Rgb>,
    #[serde(default, alias = "colour")]
    color: Option<Rgb>,
    #[serde(default)]
    mfp: Option<Rgb>,
    #[serde(default)]
    dmfp: Option<Rgb>,
    #[serde(default)]
    eta: Option<f64>,
    #[serde(default)]
    g: Option<f64>,
    #[serde(default)]
    per_point: Option<std::collections::BTreeMap<String, String>>,
    #[serde(default)]
    levels: Option<u32>,
}

/// The bytes a material file may have: a few keys, not megabytes.
const MAX_FILE: u64 = 1 << 20;

/// The material `arg` names: a JSON file when one is there, else a
/// preset. An error names the file and the key at fault, or lists the
/// presets. A preset's lengths are millimetres until
/// [`Spec::in_scene`] puts them in the scene's unit.
pub fn load(arg: &str) -> Result<Spec> {
    let path = Path::new(arg);
    if path.exists() {
        return read(path);
    }
    let found = preset(arg, 1.0).map(|m| Spec { in_mm: true, ..m });
    found.ok_or_else(|| {
        let names: Vec<&str> = PRESETS.iter().map(|p| p.0).collect();
        Error::param(
            "material",
            format!(
                "'{arg}' is neither a file nor a preset ({})",
                names.join(", ")
            ),
        )
    })
}

/// A material file.
fn read(path: &Path) -> Result<Spec> {
    let name = path.display().to_string();
    // (What is read is capped, not what the file says its size is: a
    // device's is 0.)
    let bytes = crate::files::read_input(path, MAX_FILE, "a material file (a few keys)")
        .map_err(|e| e.about(&name))?;
    let text = String::from_utf8(bytes)
        .map_err(|_| Error::invalid("not UTF-8 text: not a material file").about(&name))?;
    parse(&text, &name)
}

/// A material file's text; `name` for its `source`. A preset without
/// `unit_length` keeps its millimetres ([`Spec::in_mm`]).
pub fn parse(text: &str, name: &str) -> Result<Spec> {
    let de = &mut serde_json::Deserializer::from_str(text);
    let f: File = serde_path_to_error::deserialize(de).map_err(|e| {
        let key = e.path().to_string();
        Error::invalid(format!("{name}: {key}: {}", e.inner()))
    })?;
    let bad = |key: &str, why: String| Error::invalid(format!("{name}: {key}: {why}"));
    if let Some(m) = &f.model {
        if m != "physical" {
            return Err(bad(
                "model",
                format!("'{m}': a material file holds the physical model's medium"),
            ));
        }
    }
    let unit = f.unit_length.unwrap_or(1.0);
    if !(unit.is_finite() && unit > 0.0) {
        return Err(bad(
            "unit_length",
            format!("{unit}: a length > 0 (millimetres)"),
        ));
    }
    let mut m = match &f.preset {
        Some(p) => preset(p, unit).ok_or_else(|| {
            let names: Vec<&str> = PRESETS.iter().map(|p| p.0).collect();
            bad(
                "preset",
                format!("'{p}' is not one of {}", names.join(", ")),
            )
        })?,
        None => {
            if f.unit_length.is_some() {
                return Err(bad(
                    "unit_length",
                    "scales a preset's millimetres; give lengths in the scene's units without a preset".into(),
                ));
            }
            Spec::default()
        }
    };
    m.in_mm = f.preset.is_some() && f.unit_length.is_none();
    m.source = match &f.preset {
        Some(p) => format!("{name} (preset {p})"),
        None => name.to_string(),
    };
    if f.albedo.is_some() && f.color.is_some() {
        return Err(bad("color", "give albedo or color, not both".into()));
    }
    if f.mfp.is_some() && f.dmfp.is_some() {
        return Err(bad("dmfp", "give mfp or dmfp, not both".into()));
    }
    // Keys given override the preset's.
    if f.albedo.is_some() || f.color.is_some() {
        m.albedo = f.albedo.map(Rgb::get);
        m.color = f.color.map(Rgb::get);
    }
    if f.mfp.is_some() || f.dmfp.is_some() {
        // (In the scene's units: no longer a preset's millimetres.)
        m.mfp = f.mfp.map(Rgb::get);
        m.dmfp = f.dmfp.map(Rgb::get);
        m.in_mm = false;
    }
    m.eta = f.eta.or(m.eta);
    m.g = f.g.or(m.g);
    for (key, attr) in f.per_point.unwrap_or_default() {
        let at = format!("per_point.{key}");
        // The per-point value is of the kind the material gives (a colour
        // per point where the material gives a colour).
        let (pair, kinds) = match key.as_str() {
            "albedo" | "color" => ([m.albedo.is_some(), m.color.is_some()], ["albedo", "color"]),
            "mfp" | "dmfp" => ([m.mfp.is_some(), m.dmfp.is_some()], ["mfp", "dmfp"]),
            _ => {
                return Err(bad(
                    &at,
                    "a per-point parameter is one of albedo, color, mfp, dmfp".into(),
                ))
            }
        };
        let mine = kinds.iter().position(|k| *k == key).expect("listed");
        if pair[1 - mine] {
            return Err(bad(
                &at,
                format!(
                    "the material gives {}: a per-point value replaces it in the same kind",
                    kinds[1 - mine]
                ),
            ));
        }
        if attr.is_empty() {
            return Err(bad(&at, "names no attribute".into()));
        }
        m.per_point.push((key, attr));
    }
    if let Some(l) = f.levels {
        if !(2..=MAX_LEVELS).contains(&l) {
            return Err(bad("levels", format!("{l}: not in 2..={MAX_LEVELS}")));
        }
        if m.per_point.is_empty() {
            return Err(bad(
                "levels",
                "rounds per-point values: give per_point".into(),
            ));
        }
        m.levels = Some(l);
    }
    if m.mfp.is_none() && m.dmfp.is_none() {
        return Err(bad(
            "mfp",
            "the medium needs mfp or dmfp (or a preset)".into(),
        ));
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::medium::Medium;

    /// The presets against RenderMan's own chart of them (its surface
    /// colours and diffuse mean free paths in millimetres, for the same
    /// measured media under its own model): its mean free paths are the
    /// classical diffusion's `1 / sqrt(3 sigma_a sigma_t')` of the
    /// preset's coefficients (1%: the table is transcribed right, in
    /// millimetres); its colours come from another model of the same
    /// medium (0.03).
    #[test]
    fn presets_agree_with_renderman_s_chart() {
        // RenderMan's PxrSurface documentation, "Subsurface": albedo and
        // mean free path colour (mm).
        let chart = [
            ("apple", [0.846, 0.841, 0.528], [6.96, 6.40, 1.90]),
            ("chicken1", [0.314, 0.156, 0.126], [11.61, 3.88, 1.75]),
            ("ketchup", [0.164, 0.006, 0.002], [4.76, 0.58, 0.39]),
        ];
        for (name, colour, dmfp) in chart {
            let p = preset(name, 1.0).unwrap();
            let (albedo, mfp) = (p.albedo.unwrap(), p.mfp.unwrap());
            let m = Medium::new(albedo, mfp, p.eta.unwrap(), 0.0).unwrap();
            for c in 0..3 {
                let (st, sa) = (1.0 / mfp[c], (1.0 - albedo[c]) / mfp[c]);
                let classical = 1.0 / (3.0 * sa * st).sqrt();
                assert!(
                    // (1%, and the chart's rounding to two decimals.)
                    (classical - dmfp[c]).abs() < 0.01 * dmfp[c] + 0.005,
                    "{name}: dmfp {classical} against {dmfp:?}"
                );
                assert!(
                    (m.colour()[c] - colour[c]).abs() < 0.03,
                    "{name}: colour {:?} against {colour:?}",
                    m.colour()
                );
            }
        }
        // In centimetres: a tenth of the lengths.
        let cm = preset("Skin1", 10.0).unwrap();
        let mm = preset("skin1", 1.0).unwrap();
        assert_eq!(cm.albedo, mm.albedo);
        for c in 0..3 {
            assert!((cm.mfp.unwrap()[c] * 10.0 - mm.mfp.unwrap()[c]).abs() < 1e-12);
        }
        assert!(preset("jelly", 1.0).is_none());
    }

    #[test]
    fn files_give_a_medium_or_name_the_key_at_fault() {
        let m = parse(
            r#"{"color": [0.8, 0.5, 0.3], "dmfp": 0.2, "eta": 1.4}"#,
            "m.json",
        )
        .unwrap();
        assert_eq!(m.color, Some([0.8, 0.5, 0.3]));
        assert_eq!(m.dmfp, Some([0.2; 3]));
        assert_eq!((m.eta, m.g, m.albedo, m.mfp), (Some(1.4), None, None, None));
        // A preset with a key of its own: the key wins.
        let m = parse(
            r#"{"preset": "marble", "unit_length": 10, "eta": 1.5, "model": "physical"}"#,
            "m.json",
        )
        .unwrap();
        assert_eq!(m.eta, Some(1.5));
        assert_eq!(m.albedo, preset("marble", 10.0).unwrap().albedo);
        assert_eq!(m.source, "m.json (preset marble)");
        for (text, key) in [
            (r#"{"albdo": 0.5, "mfp": 1}"#, "albdo"),
            (r#"{"albedo": "red", "mfp": 1}"#, "albedo"),
            (r#"{"albedo": 0.5}"#, "mfp"),
            (r#"{"albedo": 0.5, "color": 0.5, "mfp": 1}"#, "color"),
            (r#"{"mfp": 1, "dmfp": 1}"#, "dmfp"),
            (r#"{"preset": "jelly"}"#, "jelly"),
            (r#"{"preset": "apple", "unit_length": 0}"#, "unit_length"),
            (r#"{"mfp": 1, "unit_length": 10}"#, "unit_length"),
            (r#"{"mfp": 1, "model": "seed"}"#, "model"),
            ("[1, 2", "m.json"),
        ] {
            let e = parse(text, "m.json").unwrap_err().to_string();
            assert!(e.contains(key) && e.contains("m.json"), "{text}: {e}");
        }
        let e = load("no such material").unwrap_err().to_string();
        assert!(e.contains("skin1") && e.contains("no such material"), "{e}");
        // A preset by name with no scene unit takes millimetres, and says so.
        let ketchup = load("ketchup").unwrap().in_scene(None);
        assert!(ketchup.unit_assumed);
        assert_eq!(
            ketchup,
            Spec {
                unit_assumed: true,
                ..preset("ketchup", 1.0).unwrap()
            }
        );
        let cm = load("ketchup").unwrap().in_scene(Some(10.0));
        assert!(!cm.unit_assumed);
        assert_eq!(cm.mfp, preset("ketchup", 10.0).unwrap().mfp);
        // A file's preset likewise; its own lengths are the scene's.
        let file = parse(r#"{"preset": "ketchup"}"#, "m.json").unwrap();
        assert_eq!(file.in_scene(Some(10.0)).mfp, cm.mfp);
        let own = parse(r#"{"preset": "ketchup", "mfp": 2}"#, "m.json").unwrap();
        assert_eq!(own.in_scene(Some(10.0)).mfp, Some([2.0; 3]));
    }
}
