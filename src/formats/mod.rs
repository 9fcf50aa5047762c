//! On-disk formats: detection by magic bytes, reading and writing clouds.
//!
//! PLY ([`ply`]) is read and written in all three encodings; OBJ ([`obj`])
//! is read as a mesh; OpenEXR ([`exr`]) is read and written as point clouds
//! and shade-point images. The written specs are in the repository's `formats/`.

pub mod exr;
pub mod obj;
pub mod ply;
pub mod texture;
pub mod usd;

use std::io::{BufRead, Read, Write};
use std::path::Path;
use std::str::FromStr;

use crate::cloud::Cloud;
use crate::error::{Error, Result};
pub use ply::{Encoding, Select};

/// An output format.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// PLY with the given body encoding.
    Ply(Encoding),
    /// OpenEXR point cloud.
    Exr,
    /// A USD text layer with one `UsdGeomPoints` (written only).
    Usda,
    /// The same layer in Pixar's binary crate format (written only).
    Usdc,
    /// The crate layer in a `.usdz` package (written only).
    Usdz,
}

impl Format {
    /// The default: binary little-endian PLY.
    pub const DEFAULT: Format = Format::Ply(Encoding::BinaryLe);

    /// The format a file name asks for, by its extension.
    pub fn from_path(p: &Path) -> Option<Format> {
        let ext = p.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "ply" => Some(Format::DEFAULT),
            "exr" => Some(Format::Exr),
            "usda" => Some(Format::Usda),
            // (`.usd` is either; Pixar's library writes crate under it.)
            "usdc" | "usd" => Some(Format::Usdc),
            "usdz" => Some(Format::Usdz),
            _ => None,
        }
    }

    /// The format an output file's name asks for: by its extension, PLY
    /// when it has none. An extension the writers do not know (`.usdc`,
    /// `.bgeo`) is an error, not PLY under that name.
    pub fn for_output(p: &Path) -> std::result::Result<Format, String> {
        match (p.extension(), Format::from_path(p)) {
            (_, Some(f)) => Ok(f),
            (None, None) => Ok(Format::DEFAULT),
            (Some(ext), None) => Err(format!(
                "{}: the writers do not know '.{}' (they write .ply, .exr, .usda, .usdc, .usd and .usdz): \
                 name one of them, or give the format to write one under this name",
                p.display(),
                ext.to_string_lossy()
            )),
        }
    }

    /// The names accepted by `--format`.
    pub const NAMES: &'static str = "ply, ply-ascii, ply-be, exr, usda, usdc, usdz";
}

impl FromStr for Format {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        Ok(match s {
            "ply" | "ply-le" | "ply-binary" => Format::DEFAULT,
            "ply-be" => Format::Ply(Encoding::BinaryBe),
            "ply-ascii" | "ascii" => Format::Ply(Encoding::Ascii),
            "exr" => Format::Exr,
            "usda" => Format::Usda,
            "usdc" => Format::Usdc,
            "usdz" => Format::Usdz,
            _ => return Err(format!("unknown format '{s}' (one of: {})", Format::NAMES)),
        })
    }
}

/// What an input's first bytes say it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Ply,
    Exr,
    Obj,
}

/// OpenEXR's magic number.
pub const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Identifies a format from the first bytes of a file.
pub fn sniff(head: &[u8]) -> Option<Kind> {
    if head.starts_with(b"ply\n") || head.starts_with(b"ply\r\n") {
        return Some(Kind::Ply);
    }
    if head.starts_with(&EXR_MAGIC) {
        return Some(Kind::Exr);
    }
    let text = String::from_utf8_lossy(&head[..head.len().min(4096)]);
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .and_then(|l| l.split_whitespace().next());
    match first {
        Some("v" | "vn" | "vt" | "f" | "o" | "g" | "s" | "mtllib" | "usemtl") => Some(Kind::Obj),
        None if text.trim_start().starts_with('#') => Some(Kind::Obj),
        _ => None,
    }
}

/// Reads a cloud or mesh of any supported format, sniffed from its bytes.
pub fn read_cloud<R: BufRead>(mut r: R, select: &Select) -> Result<Cloud> {
    let head = r.fill_buf()?;
    if head.is_empty() {
        return Err(Error::invalid("empty file"));
    }
    if usd::is_usd(head) {
        return Err(Error::unsupported(
            "a USD stage is read from a file, not a stream (its layers may refer to files beside it)",
        ));
    }
    match sniff(head) {
        Some(Kind::Ply) => ply::read_ply(r, select),
        Some(Kind::Obj) => obj::read_obj(r),
        Some(Kind::Exr) => {
            // The crate reads from a seekable source: the whole input.
            let mut bytes = Vec::new();
            r.read_to_end(&mut bytes)?;
            exr::read_exr(&bytes)
        }
        None => Err(Error::invalid(
            "not a PLY, OBJ or OpenEXR file (unrecognised first bytes)",
        )),
    }
}

/// Reads a cloud or mesh from a file: a regular file is read whole into
/// memory first, so that properties a stage does not decode are never
/// copied again (they keep a range of the file's bytes).
pub fn read_cloud_file(path: &Path, select: &Select) -> Result<Cloud> {
    read_cloud_file_with(path, select, true)
}

/// [`read_cloud_file`], read whole only when `whole` (else streamed).
///
/// The file is read with `read(2)`, not mapped: a mapped file cut short
/// by another program while a stage reads it (`cp` or `>` over it) kills
/// the process with SIGBUS, and one rewritten in place changes under the
/// stage's feet. Read, a file cut short gives a truncated read, and one
/// changed while it was read (its size or modification time differ
/// after) is an error naming it.
pub fn read_cloud_file_with(path: &Path, select: &Select, whole: bool) -> Result<Cloud> {
    read_cloud_file_noting(path, select, whole, &mut |_| {})
}

/// [`read_cloud_file_with`], telling `note` what a reader chose to say
/// (a USD stage's prims it skipped, a subdivision surface read as its
/// cage). A USD stage is read from its path (`scene.usda`, or
/// `scene.usda:/World/Bunny` for the meshes under one prim): its layers
/// may refer to others beside it.
pub fn read_cloud_file_noting(
    path: &Path,
    select: &Select,
    whole: bool,
    note: &mut dyn FnMut(&str),
) -> Result<Cloud> {
    if let Some(file_path) = usd::stage_file(path) {
        let prim = usd::split_prim(path).1;
        let m = usd::read_mesh(file_path, prim)?;
        for w in &m.warnings {
            note(w);
        }
        return Ok(m.cloud);
    }
    let mut file = crate::files::open_input(path)?;
    let meta = file.metadata()?;
    if meta.is_dir() {
        return Err(Error::invalid("is a directory"));
    }
    if !(whole && meta.is_file() && meta.len() > 0) {
        return read_cloud(std::io::BufReader::with_capacity(1 << 16, file), select);
    }
    // The size is what the file system says the file holds, not what a
    // header claims: reserving it is safe, and a file that grows is read
    // to its end all the same.
    let mut buf = Vec::new();
    buf.try_reserve_exact(meta.len() as usize)
        .map_err(|_| Error::unsupported(format!("{} bytes: more than memory holds", meta.len())))?;
    file.read_to_end(&mut buf)?;
    unchanged_since(&file, &meta)?;
    let buf = std::sync::Arc::new(buf);
    match sniff(&buf) {
        Some(Kind::Ply) => ply::read::read_ply_from(ply::read::Whole::new(buf), select),
        Some(Kind::Exr) => exr::read_exr(&buf),
        _ => read_cloud(&buf[..], select),
    }
}

/// An error when `file` changed since `before` was taken (its size or its
/// modification time): read while another program wrote it, its bytes
/// may mix two versions.
fn unchanged_since(file: &std::fs::File, before: &std::fs::Metadata) -> Result<()> {
    let now = file.metadata()?;
    if now.len() != before.len() || now.modified().ok() != before.modified().ok() {
        return Err(Error::invalid(format!(
            "changed while it was read ({} bytes, then {}): read it again when it is complete",
            before.len(),
            now.len()
        )));
    }
    Ok(())
}

/// Writes a cloud in `format` (OpenEXR with the default options).
pub fn write_cloud<W: Write + ?Sized>(w: &mut W, cloud: &Cloud, format: Format) -> Result<()> {
    write_cloud_with(w, cloud, format, &exr::ExrOptions::default())
}

/// Writes a cloud in `format`, OpenEXR with `exr_opt`.
pub fn write_cloud_with<W: Write + ?Sized>(
    w: &mut W,
    cloud: &Cloud,
    format: Format,
    exr_opt: &exr::ExrOptions,
) -> Result<()> {
    match format {
        Format::Ply(enc) => ply::write_ply(w, cloud, enc),
        Format::Exr => exr::write_exr(w, cloud, exr_opt),
        Format::Usda => usd::write_usda(w, cloud),
        Format::Usdc => usd::write_usdc(w, cloud),
        Format::Usdz => usd::write_usdz(w, cloud),
    }
}
