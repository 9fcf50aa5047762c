//! `pcdiff`: compares two clouds attribute by attribute with tolerances.
//!
//! Two values `a` and `b` agree when both are NaN, or when
//! `|a - b| <= max(abs, rel * max(|a|, |b|))`. Elements, attributes and
//! detail attributes present on one side only are differences; a different
//! storage type (float against double) is reported but is not one. List
//! attributes (face vertex lists) must have equal row lengths.

use std::collections::HashMap;
use std::fmt::Write as _;

use crate::cloud::{AttrData, Attribute, Cloud, DetailValue, Element};
use crate::column::Column;

/// Absolute and relative tolerance.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tol {
    pub abs: f64,
    pub rel: f64,
}

impl Tol {
    /// Exact equality.
    pub const EXACT: Tol = Tol { abs: 0.0, rel: 0.0 };

    /// True when `a` and `b` agree.
    pub fn agree(&self, a: f64, b: f64) -> bool {
        if a.is_nan() || b.is_nan() {
            return a.is_nan() && b.is_nan();
        }
        if a == b {
            return true;
        }
        let d = (a - b).abs();
        d <= self.abs.max(self.rel * a.abs().max(b.abs()))
    }
}

/// What to compare and how closely.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Tolerance for attributes without their own.
    pub tol: Tol,
    /// Per-attribute tolerances, by attribute name.
    pub per_attr: HashMap<String, Tol>,
    /// Attributes not compared (of any element, or detail).
    pub ignore: Vec<String>,
    /// When not empty, only these attributes are compared.
    pub only: Vec<String>,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            tol: Tol::EXACT,
            per_attr: HashMap::new(),
            ignore: Vec::new(),
            only: Vec::new(),
        }
    }
}

impl Options {
    fn compared(&self, name: &str) -> bool {
        !self.ignore.iter().any(|n| n == name)
            && (self.only.is_empty() || self.only.iter().any(|n| n == name))
    }

    fn tol(&self, name: &str) -> Tol {
        self.per_attr.get(name).copied().unwrap_or(self.tol)
    }
}

/// The names `opt` refers to (`only`, `ignore`, per-attribute tolerances)
/// that no attribute of either cloud has, with the option that named them:
/// a golden test that names nothing would compare nothing.
pub fn unknown_names(a: &Cloud, b: &Cloud, opt: &Options) -> Vec<(&'static str, String)> {
    let known = |n: &str| {
        [a, b]
            .iter()
            .any(|c| c.elements.iter().any(|e| e.attr(n).is_some()) || c.detail(n).is_some())
    };
    let mut out = Vec::new();
    for (flag, names) in [("only", &opt.only), ("ignore", &opt.ignore)] {
        out.extend(
            names
                .iter()
                .filter(|n| !known(n))
                .map(|n| (flag, n.clone())),
        );
    }
    let mut tols: Vec<&String> = opt.per_attr.keys().filter(|n| !known(n)).collect();
    tols.sort();
    out.extend(tols.into_iter().map(|n| ("tol", n.clone())));
    out
}

/// The outcome of a comparison.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Report {
    /// One line per difference.
    pub differences: Vec<String>,
    /// One line per compared attribute (with its largest deviation).
    pub details: Vec<String>,
    /// Notes that are not differences (type changes).
    pub notes: Vec<String>,
    /// Number of attributes compared.
    pub compared: usize,
}

impl Report {
    /// True when no difference exceeds its tolerance.
    pub fn same(&self) -> bool {
        self.differences.is_empty()
    }
}

/// Largest deviation of one component.
struct Worst {
    abs: f64,
    rel: f64,
    row: usize,
    a: f64,
    b: f64,
    bad: usize,
}

fn compare_columns(a: &Column, b: &Column, tol: Tol) -> Worst {
    let mut w = Worst {
        abs: 0.0,
        rel: 0.0,
        row: 0,
        a: 0.0,
        b: 0.0,
        bad: 0,
    };
    let mut worst_bad = false;
    for i in 0..a.len().min(b.len()) {
        let (x, y) = (a.get_f64(i), b.get_f64(i));
        let ok = tol.agree(x, y);
        let d = if x.is_nan() || y.is_nan() {
            if ok {
                0.0
            } else {
                f64::INFINITY
            }
        } else if x == y {
            0.0
        } else {
            (x - y).abs()
        };
        let r = if d == 0.0 {
            0.0
        } else {
            d / x.abs().max(y.abs())
        };
        if !ok {
            w.bad += 1;
        }
        // Report the worst failing value; among passing ones the largest.
        if (!ok && (!worst_bad || d > w.abs)) || (!worst_bad && ok && d > w.abs) {
            worst_bad |= !ok;
            w.abs = d;
            w.row = i;
            w.a = x;
            w.b = y;
        }
        w.rel = w.rel.max(r);
    }
    w
}

/// Compares `a` against `b`.
pub fn compare(a: &Cloud, b: &Cloud, opt: &Options) -> Report {
    let mut rep = Report::default();
    // (Maps by name, not scans: linear in the elements and attributes.)
    let (ma, mb) = (
        by_name(&a.elements, |e| &e.name),
        by_name(&b.elements, |e| &e.name),
    );
    for ea in &a.elements {
        match mb.get(ea.name.as_str()) {
            None => rep
                .differences
                .push(format!("element '{}' only in A", ea.name)),
            Some(eb) => compare_elements(ea, eb, opt, &mut rep),
        }
    }
    for eb in &b.elements {
        if !ma.contains_key(eb.name.as_str()) {
            rep.differences
                .push(format!("element '{}' only in B", eb.name));
        }
    }
    compare_detail(a, b, opt, &mut rep);
    rep
}

/// The first item of each name.
fn by_name<T>(items: &[T], name: impl Fn(&T) -> &String) -> HashMap<&str, &T> {
    let mut m = HashMap::with_capacity(items.len());
    for it in items {
        m.entry(name(it).as_str()).or_insert(it);
    }
    m
}

fn compare_elements(ea: &Element, eb: &Element, opt: &Options, rep: &mut Report) {
    if ea.len() != eb.len() {
        rep.differences.push(format!(
            "element '{}': {} rows in A, {} in B",
            ea.name,
            ea.len(),
            eb.len()
        ));
        return;
    }
    let (ma, mb) = (
        by_name(ea.attrs(), |x| &x.name),
        by_name(eb.attrs(), |x| &x.name),
    );
    for aa in ea.attrs().iter().filter(|x| opt.compared(&x.name)) {
        match mb.get(aa.name.as_str()) {
            None => rep
                .differences
                .push(format!("{}.{} only in A", ea.name, aa.name)),
            Some(ab) => compare_attrs(&ea.name, aa, ab, opt.tol(&aa.name), rep),
        }
    }
    for ab in eb.attrs().iter().filter(|x| opt.compared(&x.name)) {
        if !ma.contains_key(ab.name.as_str()) {
            rep.differences
                .push(format!("{}.{} only in B", eb.name, ab.name));
        }
    }
}

fn compare_attrs(el: &str, a: &Attribute, b: &Attribute, tol: Tol, rep: &mut Report) {
    rep.compared += 1;
    let name = format!("{el}.{}", a.name);
    if a.type_name() != b.type_name() {
        rep.notes.push(format!(
            "{name}: type {} in A, {} in B",
            a.type_name(),
            b.type_name()
        ));
    }
    let pairs: Vec<(String, &Column, &Column)> = match (&a.data, &b.data) {
        (AttrData::List(la), AttrData::List(lb)) => {
            if la.offsets != lb.offsets {
                rep.differences.push(format!("{name}: list lengths differ"));
                return;
            }
            vec![(name.clone(), &la.items, &lb.items)]
        }
        (AttrData::Scalar(x), AttrData::Scalar(y)) => vec![(name.clone(), x.column(), y.column())],
        (AttrData::Vec3(_, x), AttrData::Vec3(_, y)) => (0..3)
            .map(|k| (format!("{name}[{k}]"), x[k].column(), y[k].column()))
            .collect(),
        _ => {
            rep.differences.push(format!(
                "{name}: {} in A, {} in B",
                a.type_name(),
                b.type_name()
            ));
            return;
        }
    };
    for (label, x, y) in pairs {
        let w = compare_columns(x, y, tol);
        let line = format!(
            "{label}: max abs {:.3e}, max rel {:.3e}, worst at row {} (A {}, B {})",
            w.abs, w.rel, w.row, w.a, w.b
        );
        if w.bad > 0 {
            rep.differences.push(format!(
                "{line}; {} values past tolerance (abs {:e}, rel {:e})",
                w.bad, tol.abs, tol.rel
            ));
        } else {
            rep.details.push(line);
        }
    }
}

fn compare_detail(a: &Cloud, b: &Cloud, opt: &Options, rep: &mut Report) {
    let (ma, mb) = (
        by_name(&a.detail, |d| &d.name),
        by_name(&b.detail, |d| &d.name),
    );
    for da in a.detail.iter().filter(|d| opt.compared(&d.name)) {
        let Some(vb) = mb.get(da.name.as_str()).map(|d| &d.value) else {
            rep.differences
                .push(format!("detail.{} only in A", da.name));
            continue;
        };
        rep.compared += 1;
        let tol = opt.tol(&da.name);
        let same = match (&da.value, vb) {
            (DetailValue::Str(x), DetailValue::Str(y)) => x == y,
            (x, y) => {
                let (cx, cy) = (x.components(), y.components());
                cx.len() == cy.len() && cx.iter().zip(&cy).all(|(p, q)| tol.agree(*p, *q))
            }
        };
        let mut line = String::new();
        let _ = write!(line, "detail.{}: A {:?}, B {:?}", da.name, da.value, vb);
        if same {
            rep.details.push(line);
        } else {
            rep.differences.push(line);
        }
    }
    for db in b.detail.iter().filter(|d| opt.compared(&d.name)) {
        if !ma.contains_key(db.name.as_str()) {
            rep.differences
                .push(format!("detail.{} only in B", db.name));
        }
    }
}
