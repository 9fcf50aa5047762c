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
use pcsss::column::{Column, ScalarType};
use pcsss::formats::{self, Format, Select};
use pyo3::create_exception;
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};

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
    fn new(c: Cloud) -> PyCloud {
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

/// The role a 3-column array takes by its name (as PLY's reader gives it).
fn role_of(name: &str) -> Role {
    match name {
        "P" => Role::Point,
        "N" => Role::Normal,
        // The colours the stages make and read (formats/PLY.md writes
        // them as `NAME_r NAME_g NAME_b`).
        "Cd" | "illum" | "ssM" | "ssS" | "beauty" | "Rd" | "albedo" => Role::Color,
        _ => Role::Vector,
    }
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
                    return Err(PyValueError::new_err(format!("{}: an N x {} array; an attribute is N or N x 3", $name, a.ncols())));
                }
                let col = |k: usize| Column::$v(a.column(k).to_vec());
                return Ok(Attribute::vec3($name, role_of($name), [col(0), col(1), col(2)]));
            }
        )*
    }};
}

fn attribute(name: &str, v: &Bound<'_, PyAny>) -> PyResult<Attribute> {
    let np = v.py().import("numpy")?;
    let arr = np.call_method1("asarray", (v,))?;
    scalar_from!(arr, name,
        f32 => F32, f64 => F64, u8 => U8, i8 => I8, u16 => U16, i16 => I16, u32 => U32, i32 => I32);
    // Python ints and other types: as int32 if integral, else float32.
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let cast = if kind == "i" || kind == "u" || kind == "b" {
        "int32"
    } else {
        "float32"
    };
    let arr = arr.call_method1("astype", (cast,))?;
    scalar_from!(arr, name, f32 => F32, i32 => I32);
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

    /// An attribute as NumPy: a scalar as a read-only view of the
    /// toolkit's own column (no copy); a 3-vector as an N x 3 array
    /// gathered from its three columns.
    fn __getitem__<'py>(slf: &Bound<'py, Self>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let py = slf.py();
        let cloud = slf.get().get();
        let a = point_attr(&cloud, name)?;
        match &a.data {
            AttrData::Scalar(v) => column_view(py, &cloud, v),
            AttrData::Vec3(_, cols) => {
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
    /// the toolkit's own memory (x, y, z: no copy; the toolkit keeps a
    /// 3-vector as three columns, so an N x 3 array of it is a gather);
    /// a scalar's column alone.
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
        None => Format::from_path(&path).unwrap_or(Format::DEFAULT),
    };
    let c = cloud.get();
    let name = path.display().to_string();
    py.detach(|| pcsss::files::write_output(Some(&path), |w| formats::write_cloud(w, &c, f)))
        .map_err(|e| lib_err(format!("{name}: {e}")))
}

/// The stage's command line from Python keywords.
fn argv(kwargs: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<String>> {
    let mut out = Vec::new();
    let Some(kw) = kwargs else { return Ok(out) };
    for (k, v) in kw.iter() {
        let key: String = k.extract()?;
        let flag = format!("--{}", key.replace('_', "-"));
        if v.is_none() {
            continue;
        }
        if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
            if b.is_true() {
                out.push(flag);
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
        out.push(flag);
        out.push(text);
    }
    // Messages off: Python reports by exceptions.
    out.push("-q".into());
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
    py.detach(move || {
        cli::call::<T>(name, &argv, move |mut args: T| {
            io(&mut args).memory = Some(m);
            run(args)
        })
    })
    .map_err(failure)?;
    memory
        .take_output()
        .map(PyCloud::new)
        .ok_or_else(|| Error::new_err(format!("{name}: wrote no cloud")))
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
    add_stages(m)?;
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("ParameterError", m.py().get_type::<ParameterError>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
