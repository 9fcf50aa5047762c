//! What every USD reader here shares: opening a stage (`.usda`, `.usdc`,
//! `.usdz`, through the `openusd` crate), its frame, a prim's world
//! transform, and attribute values at the one time the toolkit reads.
//!
//! Transforms are composed here, not by the crate: an `xformOp` the crate
//! does not know would be read as the identity, and a mesh moved by an
//! op that was skipped is a silently wrong mesh. Every op is named, and
//! one this reader does not know is an error naming the prim.

use std::path::Path;

use glam::{DMat3, DMat4, DVec3};
use openusd::{sdf, usd};

use crate::error::{Error, Result};
use crate::frame::{Frame, UpAxis};

use super::gf;

/// An error about `prim`.
pub(super) fn at(prim: &str, why: impl std::fmt::Display) -> Error {
    Error::invalid(format!("prim {prim}: {why}"))
}

/// The crate's error, as one line of ours.
pub(super) fn usd_err(e: anyhow::Error) -> Error {
    Error::invalid(format!("USD: {}", format!("{e:#}").replace('\n', " ")))
}

/// A USD file and, after `:`, a prim path in it: `scene.usda:/World/Bunny`
/// (the path alone when it names an existing file).
pub fn split_prim(path: &Path) -> (&Path, Option<&str>) {
    if path.exists() {
        return (path, None);
    }
    let Some(s) = path.to_str() else {
        return (path, None);
    };
    for ext in [".usda:/", ".usdc:/", ".usdz:/", ".usd:/"] {
        if let Some(i) = s.find(ext) {
            let cut = i + ext.len() - 2;
            return (Path::new(&s[..cut]), Some(&s[cut + 1..]));
        }
    }
    (path, None)
}

/// The stage's file when `path` names a USD stage (`scene.usda`, known by
/// its first bytes, or `scene.usda:/prim`); `None` for any other path
/// (whose reader then names what is wrong with it).
pub fn stage_file(path: &Path) -> Option<&Path> {
    let (file, prim) = split_prim(path);
    if prim.is_some() {
        return Some(file);
    }
    is_usd(&head(file)?).then_some(file)
}

/// The first 8 bytes of a regular file (fewer when it is shorter).
fn head(path: &Path) -> Option<Vec<u8>> {
    use std::io::Read;
    let f = std::fs::File::open(path).ok()?;
    if !f.metadata().is_ok_and(|m| m.is_file()) {
        return None;
    }
    let mut head = Vec::with_capacity(8);
    f.take(8).read_to_end(&mut head).ok()?;
    Some(head)
}

/// True when `path` is a text layer (`#usda`): its strings come with
/// their escapes.
pub fn is_text(path: &Path) -> bool {
    head(path).is_some_and(|h| h.starts_with(b"#usda"))
}

/// True when a file's first bytes are a USD layer (text, crate or a
/// package).
pub fn is_usd(head: &[u8]) -> bool {
    head.starts_with(b"#usda ") || head.starts_with(b"PXR-USDC") || head.starts_with(b"PK\x03\x04")
}

/// Runs a read through the `openusd` crate, a panic in it (a file it
/// was not written for) made an error naming the file's reader, so that
/// a bad stage is one line and an exit status, not an abort.
pub fn guarded<T: Send>(f: impl FnOnce() -> Result<T> + Send) -> Result<T> {
    // On a thread of its own, with a stack of known size: the reader
    // recurses once a level of nesting (bounded by the patched openusd),
    // whatever thread asks (a test's, Python's, a worker's).
    let t = time();
    std::thread::scope(|s| {
        let reader = std::thread::Builder::new()
            .name("usd".into())
            .stack_size(READ_STACK)
            .spawn_scoped(s, || at_time(t, || caught(f)));
        match reader {
            Ok(h) => h
                .join()
                .unwrap_or_else(|_| Err(Error::invalid("USD: the reader failed"))),
            Err(e) => Err(Error::Io(e)),
        }
    })
}

/// The stack a USD read runs on: the text parser's 512 levels of nesting
/// and the composition's recursion fit with room to spare.
const READ_STACK: usize = 256 << 20;

/// Runs `f`, a panic in it made an error.
fn caught<T>(f: impl FnOnce() -> Result<T>) -> Result<T> {
    quiet_panics();
    QUIET.with(|q| q.set(q.get() + 1));
    let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f));
    QUIET.with(|q| q.set(q.get() - 1));
    r.unwrap_or_else(|_| {
        PANICS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        Err(Error::invalid(
            "USD: the reader (openusd) failed on this file: not a stage it can read",
        ))
    })
}

thread_local! {
    /// The time code this thread's USD reads take values at
    /// ([`at_time`]).
    static TIME: std::cell::Cell<Option<f64>> = const { std::cell::Cell::new(None) };
}

/// Runs `f` with every USD read it makes on this thread (and the reader
/// threads [`guarded`] starts for it) taking attribute values at time
/// code `time`: a time-sampled attribute is resolved there as Pixar's
/// library resolves it (interpolated between samples, held past the
/// first and last), an attribute without samples gives its default.
/// `None`: the one time the toolkit reads without being told, see
/// [`value`]. The time read before is restored after, whatever `f` does.
pub fn at_time<T>(time: Option<f64>, f: impl FnOnce() -> T) -> T {
    struct Restore(Option<f64>);
    impl Drop for Restore {
        fn drop(&mut self) {
            TIME.with(|t| t.set(self.0));
        }
    }
    let _restore = Restore(TIME.with(|t| t.replace(time)));
    f()
}

/// The time code USD reads take values at on this thread ([`at_time`]).
pub fn time() -> Option<f64> {
    TIME.with(|t| t.get())
}

/// The stage's own range of time codes, `startTimeCode` to `endTimeCode`
/// as authored (either alone gives both; `None`: neither is).
pub fn time_codes(stage: &usd::Stage) -> Result<Option<(f64, f64)>> {
    let read = |k: &str| -> Result<Option<f64>> {
        match stage.stage_metadata(k).map_err(usd_err)? {
            None => Ok(None),
            Some(v) => scalar(&v)
                .filter(|x| x.is_finite())
                .map(Some)
                .ok_or_else(|| Error::invalid(format!("{k} is not a finite number"))),
        }
    };
    Ok(match (read("startTimeCode")?, read("endTimeCode")?) {
        (None, None) => None,
        (Some(a), None) => Some((a, a)),
        (None, Some(b)) => Some((b, b)),
        (Some(a), Some(b)) if a <= b => Some((a, b)),
        (Some(a), Some(b)) => {
            return Err(Error::invalid(format!(
                "startTimeCode {a} is after endTimeCode {b}"
            )))
        }
    })
}

/// The stage file's range of time codes ([`time_codes`]).
pub fn stage_time_codes(file: &Path) -> Result<Option<(f64, f64)>> {
    guarded(|| {
        let stage = open(file)?;
        let r = time_codes(&stage)?;
        finish(&stage)?;
        Ok(r)
    })
}

/// Panics [`guarded`] has caught in this process.
static PANICS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// How many panics of the reader [`guarded`] has caught in this process:
/// none is expected (the patched openusd returns errors), and the fuzz
/// replay checks it.
pub fn panics_caught() -> usize {
    PANICS.load(std::sync::atomic::Ordering::Relaxed)
}

thread_local! {
    /// How many [`guarded`] reads this thread is inside: a panic there is
    /// an error line of ours, so the panic's own message is not printed.
    static QUIET: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Installs, once, a panic hook that stays silent inside [`guarded`]
/// reads and is the hook there was everywhere else.
fn quiet_panics() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let before = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if QUIET.with(|q| q.get()) == 0 {
                before(info);
            }
        }));
    });
}

/// After a read: every layer the stage opened is one of the run's inputs
/// (an output may not be one: [`crate::files::note_input`]), and a layer
/// an arc names that is missing or unreadable (a sublayer, a reference,
/// a payload, or the prim or default prim a reference names) is an
/// error naming it: a stage read without it is not the scene.
pub fn finish(stage: &usd::Stage) -> Result<()> {
    use openusd::pcp::Error as Pcp;
    for e in stage.composition_errors() {
        if matches!(
            e,
            Pcp::UnresolvedLayer { .. }
                | Pcp::MalformedLayer { .. }
                | Pcp::UnresolvedSublayer { .. }
                | Pcp::MalformedSublayer { .. }
                | Pcp::UnresolvedPrimPath { .. }
                | Pcp::MissingDefaultPrim { .. }
                | Pcp::InvalidDefaultPrim { .. }
        ) {
            return Err(Error::invalid(format!(
                "USD: {e}: the stage is not whole without it"
            )));
        }
    }
    for id in stage.layer_identifiers() {
        // A package's inner layer (`a.usdz[b.usda]`): the package is the file.
        let file = id.split('[').next().unwrap_or(&id);
        let path = Path::new(file);
        if let Ok(meta) = std::fs::metadata(path) {
            crate::files::note_input(&meta, path)?;
        }
    }
    Ok(())
}

/// Opens a stage.
pub fn open(path: &Path) -> Result<usd::Stage> {
    let p = path
        .to_str()
        .ok_or_else(|| Error::invalid("a USD path must be UTF-8"))?;
    // The crate resolves a relative root against the working directory,
    // and its errors about a missing file are long: say it in our words.
    if !path.is_file() {
        return Err(Error::Io(std::io::Error::new(
            std::io::ErrorKind::NotFound,
            "no such file",
        )));
    }
    usd::Stage::open(p).map_err(usd_err)
}

/// The stage's frame; with `fallbacks`, USD's where it states none (Y up,
/// 0.01 metres per unit: centimetres, as Pixar's library reads a scene),
/// else only what it states (a cloud the toolkit wrote states what the
/// cloud recorded).
pub fn frame(stage: &usd::Stage, fallbacks: bool) -> Result<Frame> {
    let authored =
        |k: &str| -> Result<bool> { Ok(stage.stage_metadata(k).map_err(usd_err)?.is_some()) };
    let (has_up, has_mpu) = (authored("upAxis")?, authored("metersPerUnit")?);
    let up = match stage.stage_metadata("upAxis").map_err(usd_err)? {
        None => UpAxis::Y,
        Some(sdf::Value::Token(t)) => UpAxis::from_name(t.as_str())
            .ok_or_else(|| Error::invalid(format!("upAxis is '{}', not Y or Z", t.as_str())))?,
        Some(v) => return Err(Error::invalid(format!("upAxis is {v:?}, not a token"))),
    };
    let mpu = match stage.stage_metadata("metersPerUnit").map_err(usd_err)? {
        None => 0.01,
        Some(v) => scalar(&v).ok_or_else(|| Error::invalid("metersPerUnit is not a number"))?,
    };
    let f = Frame {
        up: (fallbacks || has_up).then_some(up),
        meters_per_unit: (fallbacks || has_mpu).then_some(mpu),
    };
    f.check()
        .map_err(|why| Error::invalid(format!("metersPerUnit: {why}")))?;
    Ok(f)
}

/// Every prim the stage composes (active, loaded, defined, not abstract),
/// in order, stopping at instances.
pub fn prims(stage: &usd::Stage) -> Result<Vec<sdf::Path>> {
    let mut out = Vec::new();
    stage
        .traverse(usd::PrimPredicate::DEFAULT, |p| out.push(p.clone()))
        .map_err(usd_err)?;
    Ok(out)
}

/// The prims at or under `root` (every prim when `None`); a root the
/// stage does not have is an error naming it.
pub fn prims_under(stage: &usd::Stage, root: Option<&str>) -> Result<Vec<sdf::Path>> {
    let all = prims(stage)?;
    let Some(root) = root else { return Ok(all) };
    let r = sdf::Path::new(root).map_err(|e| at(root, format!("not a prim path ({e})")))?;
    let under: Vec<_> = all.into_iter().filter(|p| p.has_prefix(&r)).collect();
    if under.is_empty() {
        return Err(at(root, "not on the stage (or inactive)"));
    }
    Ok(under)
}

/// The prim's type name (`Mesh`, `SphereLight`), empty when untyped.
pub fn type_name(stage: &usd::Stage, p: &sdf::Path) -> Result<String> {
    Ok(stage
        .prim(p.clone())
        .type_name()
        .map_err(usd_err)?
        .map(|t| t.as_str().to_string())
        .unwrap_or_default())
}

/// An attribute's value at the time this thread reads ([`at_time`]):
/// at a time code, its time samples resolved there (its default when it
/// has none). Without one, its default, or its time sample when it has
/// exactly one; more than one sample is an animation, whose frame is
/// the caller's to choose (`--frame`), not guessed.
pub fn value(stage: &usd::Stage, p: &sdf::Path, name: &str) -> Result<Option<sdf::Value>> {
    let ap = p
        .append_property(name)
        .map_err(|e| at(p.as_str(), format!("{name}: {e}")))?;
    let attr = stage.attribute(ap);
    let times = attr.time_sample_times().map_err(usd_err)?;
    match (time(), times.as_slice()) {
        (_, []) => attr.get::<sdf::Value>().map_err(usd_err),
        (Some(t), _) => attr
            .get_at::<sdf::Value>(usd::TimeCode::new(t))
            .map_err(usd_err),
        (None, [t]) => attr
            .get_at::<sdf::Value>(usd::TimeCode::new(*t))
            .map_err(usd_err),
        (None, [first, .., last]) => Err(at(
            p.as_str(),
            format!(
                "{name} has {} time samples ({first} to {last}): an animation; give the time code \
                 of the frame to read (--frame)",
                times.len()
            ),
        )),
    }
}

/// A number of any of USD's numeric types.
pub fn scalar(v: &sdf::Value) -> Option<f64> {
    Some(match v {
        sdf::Value::Double(d) => *d,
        sdf::Value::Float(f) => *f as f64,
        sdf::Value::Half(h) => h.to_f32() as f64,
        sdf::Value::Int(i) => *i as f64,
        sdf::Value::Int64(i) => *i as f64,
        sdf::Value::Uint(i) => *i as f64,
        _ => return None,
    })
}

/// A 3-vector of any precision.
pub fn vec3(v: &sdf::Value) -> Option<DVec3> {
    Some(match v {
        sdf::Value::Vec3d(a) => DVec3::new(a.x, a.y, a.z),
        sdf::Value::Vec3f(a) => DVec3::new(a.x as f64, a.y as f64, a.z as f64),
        sdf::Value::Vec3h(a) => DVec3::new(
            a.x.to_f32() as f64,
            a.y.to_f32() as f64,
            a.z.to_f32() as f64,
        ),
        _ => return None,
    })
}

/// An array of 3-vectors of any precision.
pub fn vec3s(v: &sdf::Value) -> Option<Vec<DVec3>> {
    Some(match v {
        sdf::Value::Vec3fVec(a) => a
            .iter()
            .map(|a| DVec3::new(a.x as f64, a.y as f64, a.z as f64))
            .collect(),
        sdf::Value::Vec3dVec(a) => a.iter().map(|a| DVec3::new(a.x, a.y, a.z)).collect(),
        sdf::Value::Vec3hVec(a) => a
            .iter()
            .map(|a| {
                DVec3::new(
                    a.x.to_f32() as f64,
                    a.y.to_f32() as f64,
                    a.z.to_f32() as f64,
                )
            })
            .collect(),
        _ => return None,
    })
}

/// An array of 2-vectors of any precision.
pub fn vec2s(v: &sdf::Value) -> Option<Vec<[f64; 2]>> {
    Some(match v {
        sdf::Value::Vec2fVec(a) => a.iter().map(|a| [a.x as f64, a.y as f64]).collect(),
        sdf::Value::Vec2dVec(a) => a.iter().map(|a| [a.x, a.y]).collect(),
        sdf::Value::Vec2hVec(a) => a
            .iter()
            .map(|a| [a.x.to_f32() as f64, a.y.to_f32() as f64])
            .collect(),
        _ => return None,
    })
}

/// A token or string.
pub fn token(v: &sdf::Value) -> Option<String> {
    match v {
        sdf::Value::Token(t) => Some(t.as_str().to_string()),
        sdf::Value::String(s) => Some(s.clone()),
        _ => None,
    }
}

/// Tokens of an array (`xformOpOrder`).
fn tokens(v: &sdf::Value) -> Option<Vec<String>> {
    match v {
        sdf::Value::TokenVec(t) => Some(t.iter().map(|t| t.as_str().to_string()).collect()),
        sdf::Value::StringVec(s) => Some(s.clone()),
        _ => None,
    }
}

/// A prim's local-to-parent transform (Pixar's, [`gf`]) and whether it
/// resets the stack (`!resetXformStack!`: its parents' transforms do not
/// apply).
fn local(stage: &usd::Stage, p: &sdf::Path) -> Result<(gf::Matrix4, bool)> {
    let Some(order) = value(stage, p, "xformOpOrder")? else {
        return Ok((gf::IDENTITY, false));
    };
    let order =
        tokens(&order).ok_or_else(|| at(p.as_str(), "xformOpOrder is not a token array"))?;
    // Each op's name, whether it is inverted, and its matrix.
    let mut ops: Vec<(&str, bool, gf::Matrix4)> = Vec::new();
    let mut reset = false;
    for (i, op) in order.iter().enumerate() {
        if op == "!resetXformStack!" {
            if i != 0 {
                return Err(at(
                    p.as_str(),
                    "!resetXformStack! is not first in xformOpOrder",
                ));
            }
            reset = true;
            continue;
        }
        let (inverse, name) = match op.strip_prefix("!invert!") {
            Some(n) => (true, n),
            None => (false, op.as_str()),
        };
        let bad = |why: &str| at(p.as_str(), format!("{name}: {why}"));
        let v = value(stage, p, name)?.ok_or_else(|| bad("in xformOpOrder but not authored"))?;
        let kind = name
            .strip_prefix("xformOp:")
            .and_then(|k| k.split(':').next())
            .ok_or_else(|| bad("not an xformOp"))?;
        let s = || scalar(&v).ok_or_else(|| bad("not a number"));
        let v3 = || vec3(&v).ok_or_else(|| bad("not a 3-vector"));
        // Pixar inverts an op by its value (the translation negated, the
        // scale's reciprocal, the angles negated), as here.
        let sign = if inverse { -1.0 } else { 1.0 };
        let turn = |axis: usize| -> Result<gf::Matrix4> {
            Ok(gf::Rotation::new(gf::AXES[axis], sign * s()?).matrix())
        };
        let unit = |axis: usize, x: f64| {
            let mut t = [0.0; 3];
            t[axis] = x;
            t
        };
        let scaled = |t: [f64; 3]| {
            if inverse {
                t.map(|c| 1.0 / c)
            } else {
                t
            }
        };
        let op_m = match kind {
            "translate" => gf::translate((v3()? * sign).to_array()),
            "translateX" => gf::translate(unit(0, sign * s()?)),
            "translateY" => gf::translate(unit(1, sign * s()?)),
            "translateZ" => gf::translate(unit(2, sign * s()?)),
            "scale" => gf::scale(scaled(v3()?.to_array())),
            "scaleX" => gf::scale(scaled([s()?, 1.0, 1.0])),
            "scaleY" => gf::scale(scaled([1.0, s()?, 1.0])),
            "scaleZ" => gf::scale(scaled([1.0, 1.0, s()?])),
            "rotateX" => turn(0)?,
            "rotateY" => turn(1)?,
            "rotateZ" => turn(2)?,
            // `rotateXYZ` turns about X first, then Y, then Z.
            "rotateXYZ" | "rotateXZY" | "rotateYXZ" | "rotateYZX" | "rotateZXY" | "rotateZYX" => {
                let order = kind["rotate".len()..]
                    .chars()
                    .map(|a| (a as u8 - b'X') as usize)
                    .collect::<Vec<_>>();
                gf::euler(v3()?.to_array(), [order[0], order[1], order[2]], inverse)
            }
            "orient" => {
                let (real, imaginary) = match &v {
                    sdf::Value::Quatf(q) => (q.w as f64, [q.x as f64, q.y as f64, q.z as f64]),
                    sdf::Value::Quatd(q) => (q.w, [q.x, q.y, q.z]),
                    sdf::Value::Quath(q) => (
                        q.w.to_f32() as f64,
                        [
                            q.x.to_f32() as f64,
                            q.y.to_f32() as f64,
                            q.z.to_f32() as f64,
                        ],
                    ),
                    _ => return Err(bad("not a quaternion")),
                };
                let length = (real * real + imaginary.iter().map(|c| c * c).sum::<f64>()).sqrt();
                if !length.is_finite() || length <= 0.0 {
                    return Err(bad("a zero quaternion"));
                }
                let r = gf::Rotation::from_quat(real, imaginary);
                if inverse { r.inverse() } else { r }.matrix()
            }
            // USD's matrices act on row vectors, as gf's.
            "transform" => match &v {
                sdf::Value::Matrix4d(t) => {
                    let mut m = [[0.0; 4]; 4];
                    for (k, x) in t.0.iter().enumerate() {
                        m[k / 4][k % 4] = *x;
                    }
                    if inverse {
                        let g = gf::to_glam(&m);
                        if g.determinant().abs() < f64::MIN_POSITIVE {
                            return Err(bad("inverted, but not invertible"));
                        }
                        g.inverse().to_cols_array_2d()
                    } else {
                        m
                    }
                }
                _ => return Err(bad("not a matrix4d")),
            },
            other => return Err(bad(&format!("the xformOp kind '{other}' is not read"))),
        };
        ops.push((name, inverse, op_m));
    }
    // An op next to its own inverse is skipped with it, as Pixar does.
    let mut kept = Vec::with_capacity(ops.len());
    let mut k = ops.len();
    while k > 0 {
        let (name, inverse, m) = ops[k - 1];
        if k > 1 && ops[k - 2].0 == name && ops[k - 2].1 != inverse {
            k -= 2;
            continue;
        }
        kept.push(m);
        k -= 1;
    }
    kept.reverse();
    let m = gf::compose(&kept);
    if !m.iter().flatten().all(|v| v.is_finite()) {
        return Err(at(p.as_str(), "its transform is not finite"));
    }
    Ok((m, reset))
}

/// A prim's local-to-world transform: its own and its ancestors' ops, up
/// to the root or a prim that resets the stack, composed from the root
/// down as Pixar's `UsdGeomXformCache` does (a prim's local times its
/// parent's world).
pub fn world(stage: &usd::Stage, p: &sdf::Path) -> Result<DMat4> {
    let mut chain = Vec::new();
    let mut cur = Some(p.clone());
    // A prim that resets the stack is its own world, not its local times
    // an identity (which can turn a -0 into a +0).
    let mut top = gf::IDENTITY;
    while let Some(c) = cur {
        if c.is_abs_root() {
            break;
        }
        let (l, reset) = local(stage, &c)?;
        if reset {
            top = l;
            break;
        }
        chain.push(l);
        cur = c.parent();
    }
    let mut m = top;
    for l in chain.iter().rev() {
        m = gf::mul(l, &m);
    }
    Ok(gf::to_glam(&m))
}

/// The world transform (column vectors) of the prim at `prim` in the
/// stage file `file`, as every reader here composes it.
pub fn world_transform(file: &Path, prim: &str) -> Result<DMat4> {
    guarded(|| {
        let stage = open(file)?;
        let p = sdf::Path::new(prim).map_err(|e| at(prim, format!("not a prim path ({e})")))?;
        let m = world(&stage, &p)?;
        finish(&stage)?;
        Ok(m)
    })
}

/// The matrix that carries normals: the inverse transpose of the upper
/// 3x3 (a singular one gives `None`).
pub fn normal_matrix(m: &DMat4) -> Option<DMat3> {
    let a = DMat3::from_mat4(*m);
    let d = a.determinant();
    (d.abs() > 1e-300 && d.is_finite()).then(|| a.inverse().transpose())
}
