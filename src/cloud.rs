//! The point cloud: elements of typed attribute columns, detail attributes,
//! faces.
//!
//! A [`Cloud`] holds elements in file order. The `vertex` element is the
//! points; the `face` element, when present, makes the cloud a mesh. Each
//! element is a count and a list of [`Attribute`]s, each attribute a scalar
//! column, a 3-vector of three columns with a [`Role`], or a list column.
//! Storage is column-wise (struct of arrays): passing an attribute through
//! a stage costs nothing, and undecoded columns stay in their file bytes.
//! Detail attributes ([`Detail`]) hold for the whole cloud.

use crate::column::{Column, Scalar, ScalarType, Values};
use crate::error::{Error, Result};
use crate::frame::{Frame, UpAxis, D_METERS_PER_UNIT, D_UP_AXIS};
use rayon::prelude::*;

/// What a 3-vector means (Houdini's attribute type info).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Role {
    /// A position: transforms as a point.
    Point,
    /// A direction or offset.
    Vector,
    /// A surface normal.
    Normal,
    /// An RGB colour.
    Color,
}

impl Role {
    /// The name used in files and messages.
    pub fn name(self) -> &'static str {
        match self {
            Role::Point => "point",
            Role::Vector => "vector",
            Role::Normal => "normal",
            Role::Color => "color",
        }
    }

    /// The role of a well-known 3-vector attribute by its name: `P` a
    /// point, `N` a normal, the stages' colours ([`crate::names::COLOURS`])
    /// colours; any other a vector.
    pub fn of_attribute(name: &str) -> Role {
        match name {
            "P" => Role::Point,
            "N" => Role::Normal,
            n if crate::names::COLOURS.contains(&n) => Role::Color,
            _ => Role::Vector,
        }
    }

    /// Parses [`Role::name`].
    pub fn from_name(s: &str) -> Option<Self> {
        Some(match s {
            "point" => Role::Point,
            "vector" => Role::Vector,
            "normal" => Role::Normal,
            "color" | "colour" => Role::Color,
            _ => return None,
        })
    }
}

/// A list property (PLY `property list`): per-row variable-length values.
#[derive(Clone, Debug, PartialEq)]
pub struct ListColumn {
    /// The type of the per-row count in files (`uchar` for faces, usually).
    pub count_ty: ScalarType,
    /// Row `i` holds `items[offsets[i]..offsets[i + 1]]`; `len + 1` entries.
    pub offsets: Vec<usize>,
    /// The concatenated items.
    pub items: Column,
}

impl ListColumn {
    /// An empty list column.
    pub fn new(count_ty: ScalarType, item_ty: ScalarType) -> Self {
        ListColumn {
            count_ty,
            offsets: vec![0],
            items: Column::empty(item_ty),
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Item range of row `i`.
    pub fn range(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i]..self.offsets[i + 1]
    }
}

/// An attribute's values.
#[derive(Clone, Debug, PartialEq)]
pub enum AttrData {
    /// One value per row.
    Scalar(Values),
    /// Three values per row, one column per component.
    Vec3(Role, Box<[Values; 3]>),
    /// A variable-length list per row.
    List(ListColumn),
}

/// A named attribute of an element.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// Attribute name (`P`, `N`, `ptarea`, `illum`, ...).
    pub name: String,
    /// Its values.
    pub data: AttrData,
}

impl Attribute {
    /// A scalar attribute.
    pub fn scalar(name: &str, col: Column) -> Self {
        Attribute {
            name: name.to_string(),
            data: AttrData::Scalar(col.into()),
        }
    }

    /// A 3-vector attribute from three component columns of one type.
    pub fn vec3(name: &str, role: Role, cols: [Column; 3]) -> Self {
        let [a, b, c] = cols;
        Attribute {
            name: name.to_string(),
            data: AttrData::Vec3(role, Box::new([a.into(), b.into(), c.into()])),
        }
    }

    /// A 3-vector attribute from rows.
    pub fn vec3_from<T: Scalar>(name: &str, role: Role, rows: &[[T; 3]]) -> Self {
        let comp = |k: usize| T::wrap(rows.iter().map(|r| r[k]).collect());
        Attribute::vec3(name, role, [comp(0), comp(1), comp(2)])
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        match &self.data {
            AttrData::Scalar(v) => v.len(),
            AttrData::Vec3(_, c) => c[0].len(),
            AttrData::List(l) => l.len(),
        }
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The component columns (1 for a scalar, 3 for a vector, 0 for a list).
    pub fn components(&self) -> &[Values] {
        match &self.data {
            AttrData::Scalar(v) => std::slice::from_ref(v),
            AttrData::Vec3(_, c) => &c[..],
            AttrData::List(_) => &[],
        }
    }

    /// The role, for a 3-vector.
    pub fn role(&self) -> Option<Role> {
        match &self.data {
            AttrData::Vec3(r, _) => Some(*r),
            _ => None,
        }
    }

    /// A short type description: `float`, `float[3] normal`, `list uchar int`.
    pub fn type_name(&self) -> String {
        match &self.data {
            AttrData::Scalar(v) => v.ty().ply_name().to_string(),
            AttrData::Vec3(r, c) => format!("{}[3] {}", c[0].ty().ply_name(), r.name()),
            AttrData::List(l) => {
                format!("list {} {}", l.count_ty.ply_name(), l.items.ty().ply_name())
            }
        }
    }

    /// The rows at `idx`, in that order.
    pub fn gather(&self, idx: &[usize]) -> Attribute {
        let g = |v: &Values| Values::owned(v.column().gather(idx));
        let data = match &self.data {
            AttrData::Scalar(v) => AttrData::Scalar(g(v)),
            AttrData::Vec3(r, c) => AttrData::Vec3(*r, Box::new([g(&c[0]), g(&c[1]), g(&c[2])])),
            AttrData::List(l) => {
                let mut offsets = Vec::with_capacity(idx.len() + 1);
                offsets.push(0);
                let mut items_idx = Vec::new();
                for &i in idx {
                    items_idx.extend(l.range(i));
                    offsets.push(items_idx.len());
                }
                AttrData::List(ListColumn {
                    count_ty: l.count_ty,
                    offsets,
                    items: l.items.gather(&items_idx),
                })
            }
        };
        Attribute {
            name: self.name.clone(),
            data,
        }
    }
}

/// A set of rows with attributes: PLY's element (`vertex`, `face`, ...).
#[derive(Clone, Debug, PartialEq)]
pub struct Element {
    /// Element name.
    pub name: String,
    len: usize,
    attrs: Vec<Attribute>,
}

static EMPTY_POINTS: Element = Element {
    name: String::new(),
    len: 0,
    attrs: Vec::new(),
};

impl Element {
    /// An element of `len` rows and no attributes yet.
    pub fn new(name: &str, len: usize) -> Self {
        Element {
            name: name.to_string(),
            len,
            attrs: Vec::new(),
        }
    }

    /// Number of rows.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when there are no rows.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// The attributes in order.
    pub fn attrs(&self) -> &[Attribute] {
        &self.attrs
    }

    /// The attribute called `name`.
    pub fn attr(&self, name: &str) -> Option<&Attribute> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// True when the element has an attribute called `name`.
    pub fn has(&self, name: &str) -> bool {
        self.attr(name).is_some()
    }

    /// Adds `attr`, replacing an attribute of the same name in place.
    pub fn set(&mut self, attr: Attribute) -> Result<()> {
        if attr.len() != self.len {
            return Err(Error::invalid(format!(
                "attribute '{}' has {} rows, element '{}' has {}",
                attr.name,
                attr.len(),
                self.name,
                self.len
            )));
        }
        match self.attrs.iter_mut().find(|a| a.name == attr.name) {
            Some(slot) => *slot = attr,
            None => self.attrs.push(attr),
        }
        Ok(())
    }

    /// Adds `attr`, whose name no attribute of the element has (a reader
    /// that made the names unique): no search, so building an element of
    /// many attributes takes linear time.
    pub(crate) fn push_unique(&mut self, attr: Attribute) -> Result<()> {
        if attr.len() != self.len {
            return Err(Error::invalid(format!(
                "attribute '{}' has {} rows, element '{}' has {}",
                attr.name,
                attr.len(),
                self.name,
                self.len
            )));
        }
        debug_assert!(self.attr(&attr.name).is_none(), "{} twice", attr.name);
        self.attrs.push(attr);
        Ok(())
    }

    /// Removes the attribute called `name`, returning it.
    pub fn remove(&mut self, name: &str) -> Option<Attribute> {
        let i = self.attrs.iter().position(|a| a.name == name)?;
        Some(self.attrs.remove(i))
    }

    fn class(&self) -> &'static str {
        match self.name.as_str() {
            "vertex" => "point",
            "face" => "face",
            _ => "element",
        }
    }

    fn require(&self, name: &str) -> Result<&Attribute> {
        self.attr(name).ok_or_else(|| self.missing(name))
    }

    /// The error for an attribute `name` this element lacks: "missing"
    /// (naming the stage that makes it), unless some of its components
    /// are here as scalars (`nx ny` without `nz`, or `x y z` of two
    /// types: the readers group only three of one type), when the
    /// message names them.
    pub fn missing(&self, name: &str) -> Error {
        self.missing_as(self.class(), name)
    }

    /// [`Element::missing`], the element called `class` in the message
    /// ("shade point").
    pub fn missing_as(&self, class: &'static str, name: &str) -> Error {
        let found: Vec<String> = component_candidates(name)
            .iter()
            .filter_map(|c| match self.attr(c).map(|a| &a.data) {
                Some(AttrData::Scalar(v)) => Some(format!("{c} ({})", v.ty().ply_name())),
                _ => None,
            })
            .collect();
        if found.is_empty() {
            return Error::missing(class, name);
        }
        Error::invalid(format!(
            "{class} attribute '{name}' cannot be formed from {}: a 3-vector needs all three components, of one type",
            found.join(", ")
        ))
    }

    /// Decodes the named attributes now (when they are lazily held), a
    /// column a thread.
    pub fn decode(&self, names: &[&str]) {
        let cols: Vec<&Values> = self
            .attrs
            .iter()
            .filter(|a| names.contains(&a.name.as_str()))
            .flat_map(|a| a.components())
            .collect();
        cols.into_par_iter().for_each(|c| {
            c.column();
        });
    }

    /// A scalar attribute's values as f64.
    pub fn scalar_f64(&self, name: &str) -> Result<Vec<f64>> {
        match &self.require(name)?.data {
            AttrData::Scalar(v) => Ok(v.column().to_f64_vec()),
            _ => Err(self.wrong_kind(name, "a scalar")),
        }
    }

    /// A scalar attribute's values as f32.
    pub fn scalar_f32(&self, name: &str) -> Result<Vec<f32>> {
        match &self.require(name)?.data {
            AttrData::Scalar(v) => Ok(v.column().to_f32_vec()),
            _ => Err(self.wrong_kind(name, "a scalar")),
        }
    }

    /// A 3-vector attribute's rows as f64.
    pub fn vec3_f64(&self, name: &str) -> Result<Vec<[f64; 3]>> {
        let c = self.vec3_columns(name)?;
        let (x, y, z) = (c[0].column(), c[1].column(), c[2].column());
        Ok((0..self.len)
            .into_par_iter()
            .map(|i| [x.get_f64(i), y.get_f64(i), z.get_f64(i)])
            .collect())
    }

    /// A 3-vector attribute's rows as f32.
    pub fn vec3_f32(&self, name: &str) -> Result<Vec<[f32; 3]>> {
        let c = self.vec3_columns(name)?;
        let (x, y, z) = (c[0].column(), c[1].column(), c[2].column());
        if let (Some(x), Some(y), Some(z)) = (x.as_slice::<f32>(), y.as_slice(), z.as_slice()) {
            return Ok((0..self.len).map(|i| [x[i], y[i], z[i]]).collect());
        }
        Ok((0..self.len)
            .map(|i| {
                [
                    x.get_f64(i) as f32,
                    y.get_f64(i) as f32,
                    z.get_f64(i) as f32,
                ]
            })
            .collect())
    }

    /// The column of a scalar attribute.
    pub fn scalar_column(&self, name: &str) -> Result<&Values> {
        match &self.require(name)?.data {
            AttrData::Scalar(v) => Ok(v),
            _ => Err(self.wrong_kind(name, "a scalar")),
        }
    }

    /// The three component columns of a 3-vector attribute.
    pub fn vec3_columns(&self, name: &str) -> Result<&[Values; 3]> {
        match &self.require(name)?.data {
            AttrData::Vec3(_, c) => Ok(c),
            _ => Err(self.wrong_kind(name, "a 3-vector")),
        }
    }

    /// A list attribute.
    pub fn list(&self, name: &str) -> Result<&ListColumn> {
        match &self.require(name)?.data {
            AttrData::List(l) => Ok(l),
            _ => Err(self.wrong_kind(name, "a list")),
        }
    }

    fn wrong_kind(&self, name: &str, want: &str) -> Error {
        Error::invalid(format!(
            "{} attribute '{}' is not {want}",
            self.class(),
            name
        ))
    }

    /// Sets a scalar attribute.
    pub fn set_scalar<T: Scalar>(&mut self, name: &str, v: Vec<T>) -> Result<()> {
        self.set(Attribute::scalar(name, T::wrap(v)))
    }

    /// Sets a 3-vector attribute.
    pub fn set_vec3<T: Scalar>(&mut self, name: &str, role: Role, rows: &[[T; 3]]) -> Result<()> {
        self.set(Attribute::vec3_from(name, role, rows))
    }

    /// The rows at `idx`, in that order, as a new element.
    pub fn gather(&self, idx: &[usize]) -> Element {
        Element {
            name: self.name.clone(),
            len: idx.len(),
            attrs: self.attrs.iter().map(|a| a.gather(idx)).collect(),
        }
    }
}

impl Element {
    /// The attributes' names and types, in order: elements of one schema
    /// can be gathered from together ([`Element::gather_from`]).
    pub fn schema(&self) -> Vec<(String, String)> {
        self.attrs
            .iter()
            .map(|a| (a.name.clone(), a.type_name()))
            .collect()
    }

    /// Rows taken from several elements of one schema (the first's name
    /// and attributes): row `k` is row `idx[k].1` of `parts[idx[k].0]`.
    /// Panics when the schemas differ: compare [`Element::schema`] first.
    pub fn gather_from(parts: &[&Element], idx: &[(u32, u32)]) -> Element {
        let first = parts[0];
        let attrs = first
            .attrs
            .iter()
            .enumerate()
            .map(|(k, a)| {
                let of = |c: usize| -> Values {
                    let cols: Vec<&Column> = parts
                        .iter()
                        .map(|p| p.attrs[k].components()[c].column())
                        .collect();
                    Values::owned(Column::gather_from(&cols, idx))
                };
                let data = match &a.data {
                    AttrData::Scalar(_) => AttrData::Scalar(of(0)),
                    AttrData::Vec3(r, _) => AttrData::Vec3(*r, Box::new([of(0), of(1), of(2)])),
                    AttrData::List(l) => {
                        let lists: Vec<&ListColumn> = parts
                            .iter()
                            .map(|p| match &p.attrs[k].data {
                                AttrData::List(l) => l,
                                _ => panic!("elements of one schema"),
                            })
                            .collect();
                        let mut offsets = Vec::with_capacity(idx.len() + 1);
                        offsets.push(0);
                        let mut items = Vec::new();
                        for &(p, r) in idx {
                            items
                                .extend(lists[p as usize].range(r as usize).map(|i| (p, i as u32)));
                            offsets.push(items.len());
                        }
                        let cols: Vec<&Column> = lists.iter().map(|l| &l.items).collect();
                        AttrData::List(ListColumn {
                            count_ty: l.count_ty,
                            offsets,
                            items: Column::gather_from(&cols, &items),
                        })
                    }
                };
                Attribute {
                    name: a.name.clone(),
                    data,
                }
            })
            .collect();
        Element {
            name: first.name.clone(),
            len: idx.len(),
            attrs,
        }
    }
}

/// The scalar names that would make the 3-vector `name` in PLY (`x y z`
/// for `P`, `nx ny nz` for `N`, `A_x`, `A_r`) and in OpenEXR (`A.x`,
/// `A.R`, `A.r`).
fn component_candidates(name: &str) -> Vec<String> {
    let mut v: Vec<String> = match name {
        "P" => ["x", "y", "z"].map(String::from).to_vec(),
        "N" => ["nx", "ny", "nz"].map(String::from).to_vec(),
        _ => vec![],
    };
    for (sep, comps) in [('_', "xyzrgb"), ('.', "xyzXYZRGBrgb")] {
        v.extend(comps.chars().map(|c| format!("{name}{sep}{c}")));
    }
    v
}

/// A detail attribute's value.
#[derive(Clone, Debug, PartialEq)]
pub enum DetailValue {
    I32(i32),
    F32(f32),
    F64(f64),
    V3F([f32; 3]),
    V3D([f64; 3]),
    Str(String),
}

impl DetailValue {
    /// The type tag used in files: `i32 f32 f64 v3f v3d str`.
    pub fn tag(&self) -> &'static str {
        match self {
            DetailValue::I32(_) => "i32",
            DetailValue::F32(_) => "f32",
            DetailValue::F64(_) => "f64",
            DetailValue::V3F(_) => "v3f",
            DetailValue::V3D(_) => "v3d",
            DetailValue::Str(_) => "str",
        }
    }

    /// The value as f64 when it is a number.
    pub fn as_f64(&self) -> Option<f64> {
        match self {
            DetailValue::I32(v) => Some(*v as f64),
            DetailValue::F32(v) => Some(*v as f64),
            DetailValue::F64(v) => Some(*v),
            _ => None,
        }
    }

    /// The components as f64 (1 for scalars, 3 for vectors, 0 for strings).
    pub fn components(&self) -> Vec<f64> {
        match self {
            DetailValue::V3F(v) => v.iter().map(|&x| x as f64).collect(),
            DetailValue::V3D(v) => v.to_vec(),
            other => other.as_f64().into_iter().collect(),
        }
    }
}

/// A detail attribute: one value for the whole cloud.
#[derive(Clone, Debug, PartialEq)]
pub struct Detail {
    pub name: String,
    pub value: DetailValue,
}

/// A point cloud, or a mesh when it has faces.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Cloud {
    /// Elements in file order; `vertex` holds the points.
    pub elements: Vec<Element>,
    /// Detail attributes, in order.
    pub detail: Vec<Detail>,
    /// Free-text comments carried from the input.
    pub comments: Vec<String>,
    /// PLY `obj_info` lines carried from the input.
    pub obj_info: Vec<String>,
}

/// Name of the element holding the points.
pub const POINTS: &str = "vertex";
/// Name of the element holding the faces.
pub const FACES: &str = "face";

impl Cloud {
    /// A cloud of `n` points with no attributes.
    pub fn with_points(n: usize) -> Self {
        Cloud {
            elements: vec![Element::new(POINTS, n)],
            ..Default::default()
        }
    }

    /// The element called `name`.
    pub fn element(&self, name: &str) -> Option<&Element> {
        self.elements.iter().find(|e| e.name == name)
    }

    /// The element called `name`, mutably.
    pub fn element_mut(&mut self, name: &str) -> Option<&mut Element> {
        self.elements.iter_mut().find(|e| e.name == name)
    }

    /// The points (an empty element when the cloud has none).
    pub fn points(&self) -> &Element {
        self.element(POINTS).unwrap_or(&EMPTY_POINTS)
    }

    /// The points, mutably; creates an empty `vertex` element if missing.
    pub fn points_mut(&mut self) -> &mut Element {
        if self.element(POINTS).is_none() {
            self.elements.insert(0, Element::new(POINTS, 0));
        }
        self.element_mut(POINTS).expect("inserted above")
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points().len()
    }

    /// True when there are no points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The faces, when the cloud is a mesh.
    pub fn faces(&self) -> Option<&Element> {
        self.element(FACES)
    }

    /// The faces, mutably.
    pub fn faces_mut(&mut self) -> Option<&mut Element> {
        self.element_mut(FACES)
    }

    /// Replaces the points with `points` (any other element is kept).
    pub fn set_points(&mut self, mut points: Element) {
        points.name = POINTS.to_string();
        *self.points_mut() = points;
    }

    /// A detail attribute's value.
    pub fn detail(&self, name: &str) -> Option<&DetailValue> {
        self.detail
            .iter()
            .find(|d| d.name == name)
            .map(|d| &d.value)
    }

    /// A numeric detail attribute, or an error naming the stage that makes it.
    pub fn detail_f64(&self, name: &str) -> Result<f64> {
        match self.detail(name) {
            None => Err(Error::missing("detail", name)),
            Some(v) => v.as_f64().ok_or_else(|| {
                Error::invalid(format!("detail attribute '{name}' is not a number"))
            }),
        }
    }

    /// Records what a stage ran with: the detail attributes `values`
    /// (names starting with `prefix`, the stage's: `ssmulti_`), after
    /// removing every other detail of that prefix an earlier run left, so
    /// that what a cloud says of a stage is its last run, whole.
    pub fn record(&mut self, prefix: &str, values: Vec<(&str, DetailValue)>) {
        self.detail.retain(|d| !d.name.starts_with(prefix));
        for (name, value) in values {
            debug_assert!(name.starts_with(prefix), "{name}");
            self.set_detail(name, value);
        }
    }

    /// The frame of the cloud's coordinates, as `scatter` recorded it
    /// (details `up_axis` and `meters_per_unit`; a part not recorded is
    /// unknown). A recorded value that is not one is an error naming it.
    pub fn frame(&self) -> Result<Frame> {
        let up = match self.detail(D_UP_AXIS) {
            None => None,
            Some(DetailValue::Str(s)) => Some(UpAxis::from_name(s).ok_or_else(|| {
                Error::invalid(format!(
                    "detail attribute '{D_UP_AXIS}' is '{s}', not y or z"
                ))
            })?),
            Some(_) => {
                return Err(Error::invalid(format!(
                    "detail attribute '{D_UP_AXIS}' is not a string"
                )))
            }
        };
        let meters_per_unit = match self.detail(D_METERS_PER_UNIT) {
            None => None,
            Some(_) => Some(self.detail_f64(D_METERS_PER_UNIT)?),
        };
        let f = Frame {
            up,
            meters_per_unit,
        };
        f.check().map_err(|why| {
            Error::invalid(format!("detail attribute '{D_METERS_PER_UNIT}': {why}"))
        })?;
        Ok(f)
    }

    /// The frame the cloud records, with what an option states: a part
    /// stated by both must agree (an error names the option's parameter
    /// and the recorded value).
    pub fn frame_with(&self, stated: &Frame) -> Result<Frame> {
        let recorded = self.frame()?;
        if let (Some(a), Some(b)) = (recorded.up, stated.up) {
            if a != b {
                return Err(Error::param(
                    "up_axis",
                    format!(
                        "{} differs from the up_axis {} the input records",
                        b.name(),
                        a.name()
                    ),
                ));
            }
        }
        if let (Some(a), Some(b)) = (recorded.meters_per_unit, stated.meters_per_unit) {
            if a != b {
                return Err(Error::param(
                    "meters_per_unit",
                    format!("{b} differs from the meters_per_unit {a} the input records"),
                ));
            }
        }
        Ok(Frame {
            up: stated.up.or(recorded.up),
            meters_per_unit: stated.meters_per_unit.or(recorded.meters_per_unit),
        })
    }

    /// Records the stated parts of a frame in the detail.
    pub fn set_frame(&mut self, f: &Frame) {
        if let Some(up) = f.up {
            self.set_detail(D_UP_AXIS, DetailValue::Str(up.name().into()));
        }
        if let Some(m) = f.meters_per_unit {
            self.set_detail(D_METERS_PER_UNIT, DetailValue::F64(m));
        }
    }

    /// Removes a detail attribute, if there is one.
    pub fn remove_detail(&mut self, name: &str) {
        self.detail.retain(|d| d.name != name);
    }

    /// Sets a detail attribute, replacing one of the same name in place.
    pub fn set_detail(&mut self, name: &str, value: DetailValue) {
        match self.detail.iter_mut().find(|d| d.name == name) {
            Some(d) => d.value = value,
            None => self.detail.push(Detail {
                name: name.to_string(),
                value,
            }),
        }
    }
}
