//! `pctile split` as it is asked for: the input a file or standard input
//! (spooled: the split reads it three times), the halo given or taken
//! from a stage's reach (or both, and checked), the tile count by number,
//! size or memory, and the directory made for the tiles removed again
//! when the split fails or a signal stops it.

use std::io::BufReader;
use std::path::{Path, PathBuf};

use super::reach::{reach_for, StageParams, MARGIN};
use super::split::{split, SplitOptions, TileCount};
use super::{ForStage, Manifest};
use crate::error::{Error, Result};
use crate::files::{MadeDir, Staged};
use crate::formats::ply::read::PlyChunks;
use crate::progress::Progress;

/// The stage a halo is for (`--for`), its words (`--stage-args`) and
/// the parameters they set; `in_unit`, the same words' parameters in a
/// scene whose unit is that many millimetres long (a preset's lengths
/// follow the cloud's recorded `meters_per_unit`, as the stage's own run
/// on each tile will take them).
#[derive(Clone)]
pub struct ForRequest {
    pub stage: super::reach::Stage,
    pub args: Vec<String>,
    pub params: StageParams,
    pub in_unit: Option<InUnit>,
}

/// [`ForRequest::in_unit`].
pub type InUnit = std::sync::Arc<dyn Fn(f64) -> Result<StageParams> + Send + Sync>;

impl std::fmt::Debug for ForRequest {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ForRequest")
            .field("stage", &self.stage)
            .field("args", &self.args)
            .field("params", &self.params)
            .finish_non_exhaustive()
    }
}

impl PartialEq for ForRequest {
    fn eq(&self, o: &Self) -> bool {
        (&self.stage, &self.args, &self.params) == (&o.stage, &o.args, &o.params)
    }
}

/// A split as asked for.
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// The input file; standard input when `None`.
    pub input: Option<PathBuf>,
    /// The input's name in messages and the manifest.
    pub input_name: String,
    /// The directory the tiles go to (made if missing).
    pub dir: PathBuf,
    pub tiles: TileCount,
    /// The halo's width; without it, the stage's reach with a margin
    /// ([`MARGIN`]). With both, the width must hold the reach.
    pub halo: Option<f64>,
    pub for_stage: Option<ForRequest>,
}

impl Request {
    /// Splits the input into tiles in the directory. On failure a
    /// directory this made is removed again: a failed split leaves
    /// nothing behind.
    pub fn run(&self, progress: &Progress) -> Result<Manifest> {
        let made = MadeDir::make(&self.dir)?;
        let m = self.split_into_dir(progress)?;
        if let Some(d) = made {
            d.keep();
        }
        Ok(m)
    }

    fn split_into_dir(&self, progress: &Progress) -> Result<Manifest> {
        let spool;
        let path: &Path = match self.input.as_deref() {
            Some(p) if p != Path::new("-") => p,
            _ => {
                spool = spool_stdin(&self.dir)?;
                spool.temp_path()
            }
        };
        let for_stage = match &self.for_stage {
            Some(f) => {
                let reach = self.stage_reach(path, f)?;
                if !reach.is_finite() {
                    let what = format!(
                        "{}'s reach with these arguments is {reach}: no halo holds it",
                        f.stage.name()
                    );
                    return Err(Error::param("stage_args", what));
                }
                Some(ForStage {
                    stage: f.stage.name().to_string(),
                    args: f.args.clone(),
                    reach,
                })
            }
            None => None,
        };
        let halo = match (self.halo, &for_stage) {
            (Some(h), Some(f)) if h < f.reach => {
                let what = format!(
                    "{h} is narrower than {}'s reach {} with those arguments",
                    f.stage, f.reach
                );
                return Err(Error::param("halo", what));
            }
            (Some(h), _) => h,
            (None, Some(f)) => f.reach * (1.0 + MARGIN),
            (None, None) => {
                let why = "give the halo's width, or the stage it is for";
                return Err(Error::param("halo", why));
            }
        };
        let opt = SplitOptions {
            tiles: self.tiles,
            halo,
            for_stage,
        };
        split(path, &self.input_name, &self.dir, &opt, progress)
    }

    /// The reach of the stage `f` asks for on the cloud at `path` (its
    /// header: the details a filter radius may come from, the scene's
    /// unit, and whether it has `ssM`).
    fn stage_reach(&self, path: &Path, f: &ForRequest) -> Result<f64> {
        let name = &self.input_name;
        let file = crate::files::open_input(path).map_err(|e| e.about(name))?;
        let head = PlyChunks::new(BufReader::new(file)).map_err(|e| e.about(name))?;
        let detail = &head.header().detail;
        let has_ssm = head.header().elements.iter().any(|e| {
            e.name == crate::cloud::POINTS
                && e.props.iter().any(|p| p.name == "ssM_r" || p.name == "ssM")
        });
        let frame = crate::cloud::Cloud {
            detail: detail.clone(),
            ..crate::cloud::Cloud::default()
        }
        .frame()
        .map_err(|e| e.about(name))?;
        let params = match (frame.meters_per_unit, &f.in_unit) {
            (Some(m), Some(in_unit)) => in_unit(m * 1000.0)?,
            _ => f.params.clone(),
        };
        reach_for(&params, detail, has_ssm)
    }
}

/// Standard input copied to a temp file in `dir`, removed when dropped
/// or by a signal (a staged file never committed).
fn spool_stdin(dir: &Path) -> Result<Staged> {
    let spool = Staged::create(&dir.join("stdin.ply"))?;
    let mut f = spool.file();
    std::io::copy(&mut std::io::stdin().lock(), &mut f)
        .map_err(|e| Error::from(e).about("<stdin>"))?;
    Ok(spool)
}
