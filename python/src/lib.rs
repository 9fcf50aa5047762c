//! `pcsss` for Python: clouds as NumPy arrays, and every stage as a
//! function over the library (not the binaries), with the command line's
//! parameters as keywords.
//!
//! A stage function builds the stage's own command line from its keywords
//! (`sd=0.6` is `--sd 0.6`, `rd=(0.9, 0.5, 0.3)` is `--rd 0.9,0.5,0.3`,
//! `rgb=True` is `--rgb`), parses it with the binary's parser, and runs
//! the binary's code on the cloud in memory, with the GIL released. So a
//! stage checks, records and computes exactly what its binary does, and an
//! error is the binary's one line, raised as `pcsss.ParameterError` (a
//! `ValueError`: the binary's exit status 2) or `pcsss.Error` (1).

use std::path::PathBuf;
use std::sync::Arc;

use numpy::ndarray::ArrayView1;
use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pcsss::cli::{self, stages, Failure, Memory};
use pcsss::cloud::{AttrData, Attribute, Cloud, DetailValue, Element, ListColumn, Role, FACES};
use pcsss::column::{Bytes, Column, RawBlock, RawRef, Scalar, ScalarType, Values};
use pcsss::formats::{self, Format, Select};
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

// The binaries' allocator (src/alloc.rs) for the module's own Rust
// allocations, keeping freed memory while a stage runs: a stage from
// Python allocates its big vectors as its binary does (with glibc's,
// each big vector is mapped and zeroed afresh, and a stage ran a few per
// cent slower than its binary: benches/results/HISTORY.md). Python and
// NumPy keep their own allocators.
#[global_allocator]
static GLOBAL: pcsss::alloc::MiMalloc = pcsss::alloc::MiMalloc;

create_exception!(
    pcsss,
    Error,
    pyo3::exceptions::PyException,
    "A stage or file failed (the binary's exit status 1)."
);
create_exception!(
    pcsss,
    ParameterError,
    PyValueError,
    "A bad parameter (the binary's exit status 2)."
);

/// A point cloud: elements of rows with typed attributes, and a detail.
/// `cloud["ssM"]` is an N x 3 NumPy array, `cloud["ptarea"]` a length-N
/// one; `cloud["x"] = array` sets an attribute.
///
/// The cloud is shared, not copied, with the NumPy views of its columns:
/// setting an attribute while a view exists gives the Python object a
/// cloud of its own (copy on write), so a view never outlives its memory.
#[pyclass(name = "Cloud", module = "pcsss", frozen)]
struct PyCloud {
    inner: std::sync::RwLock<Arc<Cloud>>,
}

/// What a view of a column keeps alive: the cloud it was taken from.
#[pyclass(frozen)]
struct Keep(#[allow(dead_code)] Arc<Cloud>);

impl PyCloud {
    fn new(mut c: Cloud) -> PyCloud {
        interleave(&mut c);
        PyCloud {
            inner: std::sync::RwLock::new(Arc::new(c)),
        }
    }

    fn get(&self) -> Arc<Cloud> {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).clone()
    }
}

fn failure(f: Failure) -> PyErr {
    if f.param {
        ParameterError::new_err(f.line)
    } else {
        Error::new_err(f.line)
    }
}

fn lib_err(e: impl std::fmt::Display) -> PyErr {
    Error::new_err(e.to_string())
}

macro_rules! scalar_from {
    ($arr:expr, $name:expr, $($t:ty => $v:ident),*) => {{
        $(
            if let Ok(a) = $arr.cast::<PyArray1<$t>>() {
                let a = a.readonly();
                return Ok(Attribute::scalar($name, Column::$v(a.as_array().to_vec())));
            }
            if let Ok(a) = $arr.cast::<PyArray2<$t>>() {
                let a = a.readonly();
                let a = a.as_array();
                if a.ncols() != 3 {
                    let hint = if a.nrows() == 3 { " (transpose it: .T)" } else { "" };
                    return Err(PyValueError::new_err(format!(
                        "{}: an array of shape ({}, {}); an attribute is N or N x 3{hint}",
                        $name, a.nrows(), a.ncols()
                    )));
                }
                // Straight into the rows the module keeps a 3-vector in
                // (one copy; see `interleaved`).
                let size = std::mem::size_of::<$t>();
                let big = cfg!(target_endian = "big");
                let mut bytes = vec![0u8; a.nrows() * 3 * size];
                for (x, out) in a.iter().zip(bytes.chunks_exact_mut(size)) {
                    x.write(out, big);
                }
                return Ok(rows_attribute($name, Role::of_attribute($name), ScalarType::$v, bytes));
            }
        )*
    }};
}

/// An array as an attribute. Positions, normals and colours (by name,
/// `Role::of_attribute`) are floats: integer ones are converted to float64, which
/// holds every integer up to 2^53 exactly, rather than kept as whole
/// numbers the stages would read as int32. Other integers keep their
/// dtype up to 32 bits; wider ones become int32 when every value fits and
/// are refused when one does not. Floats of another width (float16,
/// longdouble) become float32 or float64.
fn attribute(name: &str, v: &Bound<'_, PyAny>) -> PyResult<Attribute> {
    let np = v.py().import("numpy")?;
    let mut arr = np.call_method1("asarray", (v,))?;
    let dtype = arr.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    let size: usize = dtype.getattr("itemsize")?.extract()?;
    let integral = kind == "i" || kind == "u" || kind == "b";
    if integral && Role::of_attribute(name) != Role::Vector {
        arr = arr.call_method1("astype", ("float64",))?;
    } else if integral && size > 4 {
        let fits = if arr.getattr("size")?.extract::<usize>()? == 0 {
            true
        } else {
            let lo: i128 = arr.call_method0("min")?.extract()?;
            let hi: i128 = arr.call_method0("max")?.extract()?;
            lo >= i32::MIN as i128 && hi <= i32::MAX as i128
        };
        if !fits {
            return Err(PyValueError::new_err(format!(
                "{name}: integers past int32's range (the formats' widest integer); \
                 give them as floats (astype(float64)) if that is what they are"
            )));
        }
        arr = arr.call_method1("astype", ("int32",))?;
    }
    scalar_from!(arr, name,
        f32 => F32, f64 => F64, u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32);
    let cast = match (kind.as_str(), size) {
        ("b", _) => "uint8",
        ("f", s) if s > 4 => "float64",
        ("f", _) => "float32",
        _ => return Err(PyTypeError::new_err(format!("{name}: not a numeric array"))),
    };
    let arr = arr.call_method1("astype", (cast,))?;
    scalar_from!(arr, name, f32 => F32, f64 => F64, u8 => U8);
    Err(PyTypeError::new_err(format!("{name}: not a numeric array")))
}

fn detail_value(py: Python<'_>, v: &DetailValue) -> PyResult<Py<PyAny>> {
    Ok(match v {
        DetailValue::I32(x) => x.into_pyobject(py)?.into_any().unbind(),
        DetailValue::F32(x) => x.into_pyobject(py)?.into_any().unbind(),
        DetailValue::F64(x) => x.into_pyobject(py)?.into_any().unbind(),
        DetailValue::V3F(x) => PyTuple::new(py, x)?.into_any().unbind(),
        DetailValue::V3D(x) => PyTuple::new(py, x)?.into_any().unbind(),
        DetailValue::Str(s) => s.into_pyobject(py)?.into_any().unbind(),
    })
}

/// A 3-vector whose three columns the toolkit owns, as one block of rows
/// (x, y, z; the machine's byte order), which the library reads as it
/// reads a binary file's records (decoded when a stage uses it, copied
/// through by the writers) and NumPy views as N x 3. The module holds
/// every 3-vector it owns this way, so that `cloud[name]` is a view, not
/// a gather; columns still in a file's bytes are left there.
fn interleaved(a: &Attribute) -> Option<Attribute> {
    let AttrData::Vec3(role, cols) = &a.data else {
        return None;
    };
    let ty = cols[0].ty();
    if cols.iter().any(|c| c.raw().is_some() || c.ty() != ty) {
        return None;
    }
    let (n, size) = (a.len(), ty.size());
    let mut bytes = vec![0u8; n * 3 * size];
    for (k, c) in cols.iter().enumerate() {
        c.column().scatter_into(
            0..n,
            &mut bytes,
            3 * size,
            k * size,
            cfg!(target_endian = "big"),
        );
    }
    Some(rows_attribute(&a.name, *role, ty, bytes))
}

/// A 3-vector of `ty` from its rows (x, y, z; the machine's byte order).
fn rows_attribute(name: &str, role: Role, ty: ScalarType, bytes: Vec<u8>) -> Attribute {
    let size = ty.size();
    let block = Arc::new(RawBlock {
        bytes: Bytes::Owned(bytes),
        stride: 3 * size,
        big_endian: cfg!(target_endian = "big"),
    });
    let part = |k: usize| {
        Values::lazy(
            ty,
            RawRef {
                block: block.clone(),
                offset: k * size,
            },
        )
    };
    Attribute {
        name: name.to_string(),
        data: AttrData::Vec3(role, Box::new([part(0), part(1), part(2)])),
    }
}

/// [`interleaved`] for every point attribute of `c`.
fn interleave(c: &mut Cloud) {
    let new: Vec<Attribute> = c.points().attrs().iter().filter_map(interleaved).collect();
    for a in new {
        c.points_mut().set(a).expect("the same rows");
    }
}

/// A 3-vector as a read-only N x 3 NumPy view of the block of records
/// its columns are in (rows of [`interleaved`], or a binary file's
/// records where x, y, z are neighbours), or `None` where they are not.
/// A file's records need not be aligned for the type (a PLY header is
/// any length): NumPy reads an unaligned array as it reads any other.
fn vec3_view<'py>(
    py: Python<'py>,
    cloud: &Arc<Cloud>,
    cols: &[Values; 3],
) -> PyResult<Option<Bound<'py, PyAny>>> {
    let ty = cols[0].ty();
    let size = ty.size();
    let Some(r0) = cols[0].raw() else {
        return Ok(None);
    };
    let block = &r0.block;
    let neighbours = cols.iter().enumerate().all(|(k, c)| {
        c.ty() == ty
            && c.raw()
                .is_some_and(|r| Arc::ptr_eq(&r.block, block) && r.offset == r0.offset + k * size)
    });
    let n = cols[0].len();
    if !neighbours || block.big_endian != cfg!(target_endian = "big") || n == 0 {
        return Ok(None);
    }
    let base = block.bytes[r0.offset..].as_ptr();
    let owner = Bound::new(py, Keep(cloud.clone()))?.into_any();
    macro_rules! view {
        ($($v:ident => $t:ty),*) => {
            match ty {
                // SAFETY: row i's x, y, z are at i * stride + 0, size,
                // 2 size bytes from `base`, within the block's n * stride
                // bytes; the block is in the cloud that `owner` (the
                // array's base) holds, an Arc no one changes (a setitem
                // copies the cloud while another holder exists).
                $(ScalarType::$v => unsafe { strided::<$t>(py, n, block.stride, base, owner) },)*
            }
        };
    }
    view!(I8 => i8, U8 => u8, I16 => i16, U16 => u16, I32 => i32, U32 => u32, F32 => f32, F64 => f64)
        .map(Some)
}

/// A read-only n x 3 array of `T` whose row i starts `i * row` bytes
/// from `base`, its components `size_of::<T>()` bytes apart, kept alive
/// by `owner`.
///
/// # Safety
/// The n rows must lie in memory that `owner` keeps unchanged.
unsafe fn strided<'py, T: numpy::Element>(
    py: Python<'py>,
    n: usize,
    row: usize,
    base: *const u8,
    owner: Bound<'py, PyAny>,
) -> PyResult<Bound<'py, PyAny>> {
    use numpy::npyffi::{get_type_object, npy_intp, NpyTypes, PyArrayObject, PY_ARRAY_API};
    use numpy::PyArrayDescrMethods;
    let mut dims = [n as npy_intp, 3];
    let mut strides = [row as npy_intp, std::mem::size_of::<T>() as npy_intp];
    // SAFETY: the descriptor is a new reference the call steals; no
    // flags: read-only, and NumPy works out alignment and contiguity.
    let ptr = unsafe {
        PY_ARRAY_API.PyArray_NewFromDescr(
            py,
            get_type_object(py, NpyTypes::PyArray_Type),
            T::get_dtype(py).into_dtype_ptr(),
            2,
            dims.as_mut_ptr(),
            strides.as_mut_ptr(),
            base as *mut std::ffi::c_void,
            0,
            std::ptr::null_mut(),
        )
    };
    if ptr.is_null() {
        return Err(PyErr::fetch(py));
    }
    // SAFETY: `ptr` is the new array (a reference we own).
    let arr = unsafe { Bound::from_owned_ptr(py, ptr) };
    // SAFETY: SetBaseObject steals the reference `into_ptr` gives.
    if unsafe {
        PY_ARRAY_API.PyArray_SetBaseObject(py, ptr as *mut PyArrayObject, owner.into_ptr())
    } < 0
    {
        return Err(PyErr::fetch(py));
    }
    Ok(arr)
}

/// The point attribute `name`, or Python's KeyError.
fn point_attr<'c>(cloud: &'c Cloud, name: &str) -> PyResult<&'c Attribute> {
    cloud
        .points()
        .attr(name)
        .ok_or_else(|| PyKeyError::new_err(format!("no attribute '{name}'")))
}

/// A column of `cloud` as a read-only NumPy view of its memory.
fn column_view<'py>(
    py: Python<'py>,
    cloud: &Arc<Cloud>,
    v: &pcsss::column::Values,
) -> PyResult<Bound<'py, PyAny>> {
    let owner = Bound::new(py, Keep(cloud.clone()))?.into_any();
    macro_rules! view {
        ($($v:ident),*) => {
            match v.column() {
                $(Column::$v(x) => {
                    let view = ArrayView1::from(&x[..]);
                    // SAFETY: the column is in the cloud that `Keep`, the
                    // array's base, holds: an Arc no one changes (a setitem
                    // copies the cloud while another holder exists), so the
                    // memory stays while the view exists. The view is
                    // read-only: Python cannot write the cloud.
                    let arr = unsafe { PyArray1::borrow_from_array(&view, owner) };
                    arr.readwrite().make_nonwriteable();
                    Ok(arr.into_any())
                })*
            }
        };
    }
    view!(I8, U8, I16, U16, I32, U32, F32, F64)
}

#[pymethods]
impl PyCloud {
    /// A cloud of points from arrays: `{"P": N x 3, "N": N x 3, "ptarea": N}`.
    /// Each array is copied into the toolkit's columns (three columns of a
    /// 3-vector, one of a scalar), keeping its dtype. `faces` makes it a
    /// mesh: an F x k array of point indices, or a list of index lists
    /// (polygons of any size).
    #[staticmethod]
    #[pyo3(signature = (arrays, faces=None))]
    fn from_arrays(
        arrays: &Bound<'_, PyDict>,
        faces: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<PyCloud> {
        let mut attrs = Vec::new();
        for (k, v) in arrays.iter() {
            let name: String = k.extract()?;
            attrs.push(attribute(&name, &v)?);
        }
        let n = attrs.first().map_or(0, Attribute::len);
        let mut c = Cloud::with_points(n);
        for a in attrs {
            c.points_mut()
                .set(a)
                .map_err(|e| PyValueError::new_err(e.to_string()))?;
        }
        if let Some(f) = faces {
            let mut list = ListColumn::new(ScalarType::U8, ScalarType::I32);
            let mut items: Vec<i32> = Vec::new();
            for (k, face) in f.try_iter()?.enumerate() {
                let face: Vec<i64> = face?.extract()?;
                if face.len() < 3 || face.iter().any(|&i| i < 0 || i as usize >= n) {
                    return Err(PyValueError::new_err(format!(
                        "faces[{k}]: a face is 3 or more indices of the {n} points"
                    )));
                }
                if face.len() > 255 {
                    list.count_ty = ScalarType::I32;
                }
                items.extend(face.iter().map(|&i| i as i32));
                list.offsets.push(items.len());
            }
            list.items = Column::I32(items);
            let mut e = Element::new(FACES, list.len());
            e.set(Attribute {
                name: "vertex_indices".into(),
                data: AttrData::List(list),
            })
            .map_err(lib_err)?;
            c.elements.push(e);
        }
        Ok(PyCloud::new(c))
    }

    /// The number of points.
    fn __len__(&self) -> usize {
        self.get().len()
    }

    fn __contains__(&self, name: &str) -> bool {
        self.get().points().has(name)
    }

    /// The points' attribute names, in order.
    fn keys(&self) -> Vec<String> {
        self.get()
            .points()
            .attrs()
            .iter()
            .map(|a| a.name.clone())
            .collect()
    }

    /// The detail (parameters the stages recorded), as a dict.
    #[getter]
    fn detail<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for x in &self.get().detail {
            d.set_item(&x.name, detail_value(py, &x.value)?)?;
        }
        Ok(d)
    }

    /// The cloud's elements other than points (`face`, ...), by name and rows.
    fn elements(&self) -> Vec<(String, usize)> {
        self.get()
            .elements
            .iter()
            .map(|e| (e.name.clone(), e.len()))
            .collect()
    }

    /// An attribute as a read-only NumPy view of the toolkit's own
    /// memory (no copy): a scalar's column; a 3-vector as N x 3 (the rows
    /// the module keeps a 3-vector in, or a binary file's records where
    /// its x, y, z are neighbours; gathered into a new array only where
    /// they are not).
    fn __getitem__<'py>(slf: &Bound<'py, Self>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        let cloud = slf.get().get();
        let a = point_attr(&cloud, name)?;
        match &a.data {
            AttrData::Scalar(v) => column_view(py, &cloud, v),
            AttrData::Vec3(_, cols) => {
                if let Some(view) = vec3_view(py, &cloud, cols)? {
                    return Ok(view);
                }
                let n = a.len();
                macro_rules! gather {
                    ($($v:ident),*) => {
                        match (cols[0].column(), cols[1].column(), cols[2].column()) {
                            $((Column::$v(x), Column::$v(y), Column::$v(z)) => {
                                let mut out = Vec::with_capacity(n * 3);
                                for i in 0..n {
                                    out.extend_from_slice(&[x[i], y[i], z[i]]);
                                }
                                let arr = PyArray1::from_vec(py, out).reshape([n, 3])?;
                                Ok(arr.into_any())
                            })*
                            _ => Err(PyTypeError::new_err(format!("{name}: components of mixed types"))),
                        }
                    };
                }
                gather!(I8, U8, I16, U16, I32, U32, F32, F64)
            }
            AttrData::List(_) => Err(PyTypeError::new_err(format!("{name}: a list attribute"))),
        }
    }

    /// A 3-vector's three component columns as read-only NumPy views of
    /// the toolkit's own memory (x, y, z, each decoded once into a column
    /// of its own); a scalar's column alone.
    fn components<'py>(slf: &Bound<'py, Self>, name: &str) -> PyResult<Vec<Bound<'py, PyAny>>> {
        let py = slf.py();
        let cloud = slf.get().get();
        let a = point_attr(&cloud, name)?;
        a.components()
            .iter()
            .map(|v| column_view(py, &cloud, v))
            .collect()
    }

    /// Sets (or replaces) a point attribute from an array of N or N x 3.
    fn __setitem__(&self, name: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        let a = attribute(name, value)?;
        let a = interleaved(&a).unwrap_or(a);
        let mut c = self.inner.write().unwrap_or_else(|e| e.into_inner());
        Arc::make_mut(&mut c)
            .points_mut()
            .set(a)
            .map_err(|e| PyValueError::new_err(e.to_string()))
    }

    fn __repr__(&self) -> String {
        let c = self.get();
        format!(
            "<pcsss.Cloud: {} points, attributes {}>",
            c.len(),
            self.keys().join(", ")
        )
    }
}

/// Reads a cloud or mesh (PLY, OBJ, OpenEXR, or a USD stage). A binary
/// PLY's attributes are decoded when first used (by a stage, or by
/// `cloud[name]`), as the binaries do: one a stage does not read goes
/// through to the output as the bytes it was.
#[pyfunction]
fn read(py: Python<'_>, path: PathBuf) -> PyResult<PyCloud> {
    let name = path.display().to_string();
    pcsss::files::begin_run();
    py.detach(|| formats::read_cloud_file(&path, &Select::only(&[])))
        .map(PyCloud::new)
        .map_err(|e| Error::new_err(format!("{name}: {e}")))
}

/// Writes a cloud, atomically; the format from `format` (ply, ply-ascii,
/// ply-be, exr, usda) or the file's extension.
#[pyfunction]
#[pyo3(signature = (cloud, path, format=None))]
fn write(py: Python<'_>, cloud: &PyCloud, path: PathBuf, format: Option<&str>) -> PyResult<()> {
    let f = match format {
        Some(f) => f.parse::<Format>().map_err(ParameterError::new_err)?,
        None => Format::for_output(&path).map_err(ParameterError::new_err)?,
    };
    let c = cloud.get();
    let name = path.display().to_string();
    // A call is a run of its own: what an earlier call read is not this
    // one's input (its inode may be a new file's by now).
    pcsss::files::begin_run();
    py.detach(|| pcsss::files::write_output(Some(&path), |w| formats::write_cloud(w, &c, f)))
        .map_err(|e| lib_err(format!("{name}: {e}")))
}

/// A call's command line from its Python keywords, and the files the
/// clouds it was given in memory were written to (removed with it).
struct Argv {
    args: Vec<String>,
    /// Each temporary file's path, and the argument errors name for it.
    names: Vec<(String, String)>,
    /// The temporary folder, made for the first cloud given.
    dir: Option<tempfile::TempDir>,
}

impl Argv {
    /// `f`'s line with each temporary file named by its argument.
    fn failure(&self, mut f: Failure) -> PyErr {
        for (path, name) in &self.names {
            f.line = f.line.replace(path.as_str(), name);
        }
        failure(f)
    }
}

/// The stage's command line from Python keywords: `None` left out, a
/// bool a flag, a list, tuple or NumPy array joined with commas, a NumPy
/// number as the number, and a `Cloud` (a mesh or cloud in memory) as a
/// temporary binary PLY file, named in errors by its keyword.
fn argv(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Argv> {
    let mut out = Argv {
        args: Vec::new(),
        names: Vec::new(),
        dir: None,
    };
    let Some(kw) = kwargs else {
        out.args.push("-q".into());
        return Ok(out);
    };
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        let flag = format!("--{}", key.replace('_', "-"));
        if v.is_none() {
            continue;
        }
        if let Ok(c) = v.cast::<PyCloud>() {
            let dir = match &out.dir {
                Some(d) => d,
                None => out.dir.insert(tempfile::tempdir().map_err(lib_err)?),
            };
            let path = dir.path().join(format!("{key}.ply"));
            // (The Python object, then its cloud.)
            let cloud = c.get().get();
            pcsss::files::write_output(Some(&path), |w| {
                formats::write_cloud(w, &cloud, Format::DEFAULT)
            })
            .map_err(|e| lib_err(format!("{key}: {e}")))?;
            let p = path.display().to_string();
            out.names.push((p.clone(), format!("{key}=<Cloud>")));
            out.args.push(flag);
            out.args.push(p);
            continue;
        }
        // NumPy arrays and numbers as Python's own.
        let v = if v.hasattr("tolist")? && v.hasattr("dtype")? {
            v.call_method0("tolist")?
        } else {
            v
        };
        if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
            if b.is_true() {
                out.args.push(flag);
            }
            continue;
        }
        let text = if v.is_instance_of::<PyTuple>() || v.is_instance_of::<PyList>() {
            let items: Vec<String> = v
                .try_iter()?
                .map(|x| x.and_then(|x| x.str().map(|s| s.to_string())))
                .collect::<PyResult<_>>()?;
            items.join(",")
        } else {
            v.str()?.to_string()
        };
        out.args.push(flag);
        out.args.push(text);
    }
    // Messages off: Python reports by exceptions.
    out.args.push("-q".into());
    Ok(out)
}

/// Runs a stage's code on `cloud` in memory.
fn stage<T: clap::Parser + Send>(
    py: Python<'_>,
    name: &'static str,
    cloud: Option<&PyCloud>,
    kwargs: Option<&Bound<'_, PyDict>>,
    run: fn(T) -> anyhow::Result<()>,
    io: fn(&mut T) -> &mut cli::IoArgs,
) -> PyResult<PyCloud> {
    let argv = argv(kwargs)?;
    let input = cloud.map(|c| Cloud::clone(&c.get())).unwrap_or_default();
    let memory = Memory::with_input(input);
    let m = memory.clone();
    let args = argv.args.clone();
    py.detach(move || {
        pcsss::alloc::keeping_freed_memory(|| {
            cli::call::<T>(name, &args, move |mut args: T| {
                io(&mut args).memory = Some(m);
                run(args)
            })
        })
    })
    .map_err(|f| argv.failure(f))?;
    memory
        .take_output()
        .map(PyCloud::new)
        .ok_or_else(|| Error::new_err(format!("{name}: wrote no cloud")))
}

/// render(cloud, mesh=PATH or Cloud, camera=PATH, output=None, png=None,
/// **options): the picture of `cloud` on the mesh through the camera, as
/// `render --help` says. Writes `output` (OpenEXR) and `png` where given,
/// and returns the image as a Cloud (a point a pixel: beauty, ssM, ssS,
/// P, N, A and the pixel's x, y, as the OpenEXR holds them).
#[pyfunction]
#[pyo3(signature = (cloud, /, **kwargs))]
fn render(
    py: Python<'_>,
    cloud: Bound<'_, PyCloud>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<PyCloud> {
    let kw = match kwargs {
        Some(k) => k.copy()?,
        None => PyDict::new(py),
    };
    kw.set_item("cloud", cloud)?;
    let dir = tempfile::tempdir().map_err(lib_err)?;
    let image = match kw.get_item("output")?.filter(|v| !v.is_none()) {
        Some(v) => PathBuf::from(v.str()?.to_string()),
        None => {
            let p = dir.path().join("image.exr");
            kw.set_item("output", p.display().to_string())?;
            p
        }
    };
    let argv = argv(Some(&kw))?;
    let args = argv.args.clone();
    pcsss::files::begin_run();
    py.detach(move || cli::call::<stages::render::Args>("render", &args, stages::render::run))
        .map_err(|f| argv.failure(f))?;
    let name = image.display().to_string();
    py.detach(|| formats::read_cloud_file(&image, &Select::All))
        .map(PyCloud::new)
        .map_err(|e| Error::new_err(format!("{name}: {e}")))
}

macro_rules! stages {
    ($($name:ident: $doc:literal),* $(,)?) => {
        $(
            #[doc = $doc]
            #[pyfunction]
            #[pyo3(signature = (input, /, **kwargs))]
            fn $name(py: Python<'_>, input: &PyCloud, kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<PyCloud> {
                stage(py, stringify!($name), Some(input), kwargs, stages::$name::run, |a| &mut a.io)
            }
        )*
        fn add_stages(m: &Bound<'_, PyModule>) -> PyResult<()> {
            $(m.add_function(wrap_pyfunction!($name, m)?)?;)*
            Ok(())
        }
    };
}

stages! {
    measure: "measure(mesh, **options): the mesh with its faces' area and perimeter and its total area (Tarea). Options as `measure --help`.",
    scatter: "scatter(mesh, count=..., **options): points on the mesh (P, N, ptarea, sourceprim, sourceuv). Options as `scatter --help`.",
    facet: "facet(cloud, mesh=PATH, **options): normals from the mesh. Options as `facet --help`.",
    follow: "follow(cloud, rest=PATH, frame=PATH, **options): the cloud moved onto another frame. Options as `follow --help`.",
    texture: "texture(cloud, mesh=PATH, image=PATH, **options): a texture sampled at each point. Options as `texture --help`.",
    promote: "promote(cloud, **options): attributes between classes. Options as `promote --help`.",
    illum: "illum(cloud, lights=PATH, **options): direct irradiance. Options as `illum --help`.",
    ssmulti: "ssmulti(cloud, rd=(r, g, b), sd=..., **options): multiple scattering ssM. Options as `ssmulti --help`.",
    sssingle: "sssingle(cloud, **options): single scattering ssS. Options as `sssingle --help`.",
    filter: "filter(cloud, mesh=PATH, **options): the cloud's light onto a mesh's vertices. Options as `filter --help`.",
}

/// The module.
#[pymodule]
fn _pcsss(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCloud>()?;
    m.add_function(wrap_pyfunction!(read, m)?)?;
    m.add_function(wrap_pyfunction!(write, m)?)?;
    m.add_function(wrap_pyfunction!(render, m)?)?;
    add_stages(m)?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("ParameterError", m.py().get_type::<ParameterError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
