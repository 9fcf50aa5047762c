//! PLY headers: parsing, writing, and the attribute naming convention.
//!
//! The convention (formats/PLY.md): `P` is `x y z`, `N` is `nx ny nz`, a
//! colour `A` is `A_r A_g A_b`, any other 3-vector `A` is `A_x A_y A_z`, a
//! scalar `A` is `A`. Detail attributes and roles that the names cannot
//! carry travel in `comment pcsss ...` lines, which other readers skip.

use std::collections::{HashMap, HashSet};
use std::io::BufRead;

use crate::cloud::{Detail, DetailValue, Role};
use crate::column::ScalarType;
use crate::error::{Error, Result};

/// Body encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    Ascii,
    BinaryLe,
    BinaryBe,
}

impl Encoding {
    /// The `format` line's keyword.
    pub fn keyword(self) -> &'static str {
        match self {
            Encoding::Ascii => "ascii",
            Encoding::BinaryLe => "binary_little_endian",
            Encoding::BinaryBe => "binary_big_endian",
        }
    }
}

/// A property declaration.
#[derive(Clone, Debug, PartialEq)]
pub enum PropKind {
    Scalar(ScalarType),
    /// `property list COUNT ITEM name`.
    List(ScalarType, ScalarType),
}

/// `property ...`
#[derive(Clone, Debug, PartialEq)]
pub struct PropDef {
    pub name: String,
    pub kind: PropKind,
}

/// `element name count` and its properties.
#[derive(Clone, Debug, PartialEq)]
pub struct ElementDef {
    pub name: String,
    pub count: u64,
    pub props: Vec<PropDef>,
}

impl ElementDef {
    /// Bytes per row when no property is a list.
    pub fn fixed_stride(&self) -> Option<usize> {
        self.props
            .iter()
            .map(|p| match p.kind {
                PropKind::Scalar(t) => Some(t.size()),
                PropKind::List(..) => None,
            })
            .sum()
    }
}

/// A parsed header.
#[derive(Clone, Debug, PartialEq)]
pub struct Header {
    pub encoding: Encoding,
    pub elements: Vec<ElementDef>,
    /// Plain comments (not the toolkit's own `pcsss` lines).
    pub comments: Vec<String>,
    pub obj_info: Vec<String>,
    /// Detail attributes from `comment pcsss detail` lines.
    pub detail: Vec<Detail>,
    /// Roles from `comment pcsss role ELEMENT ATTR ROLE` lines.
    pub roles: Vec<(String, String, Role)>,
}

/// The prefix of the toolkit's own comment lines.
pub const TAG: &str = "pcsss";
const MAX_LINE: u64 = 1 << 20;

/// Reads a header, leaving `r` at the first byte of the body.
pub fn read_header<R: BufRead>(r: &mut R) -> Result<Header> {
    let mut h = Header {
        encoding: Encoding::Ascii,
        elements: Vec::new(),
        comments: Vec::new(),
        obj_info: Vec::new(),
        detail: Vec::new(),
        roles: Vec::new(),
    };
    let mut have_format = false;
    let (mut element_names, mut prop_names) = (HashSet::new(), HashSet::new());
    let mut buf = Vec::new();
    let mut lineno = 0usize;
    loop {
        buf.clear();
        let n = std::io::Read::take(&mut *r, MAX_LINE).read_until(b'\n', &mut buf)?;
        lineno += 1;
        if n == 0 {
            return Err(if lineno == 1 {
                Error::invalid("empty file")
            } else {
                Error::truncated(format!("header ends at line {lineno} without 'end_header'"))
            });
        }
        if buf.last() != Some(&b'\n') {
            return Err(if n as u64 >= MAX_LINE {
                Error::invalid(format!("header line {lineno} is longer than 1 MiB"))
            } else if lineno == 1 {
                Error::invalid("not a PLY file (no 'ply' line)")
            } else {
                Error::truncated(format!("header ends at line {lineno} without 'end_header'"))
            });
        }
        let text = std::str::from_utf8(&buf)
            .map_err(|_| Error::invalid(format!("header line {lineno} is not valid UTF-8")))?;
        let line = text.trim_end_matches(['\n', '\r']);
        if lineno == 1 {
            if line != "ply" {
                return Err(Error::invalid("not a PLY file (first line is not 'ply')"));
            }
            continue;
        }
        let (kw, raw_rest) = match line.trim_start().split_once([' ', '\t']) {
            Some((k, r)) => (k, r),
            None => (line.trim(), ""),
        };
        let rest = raw_rest.trim();
        let bad = |what: &str| Error::invalid(format!("header line {lineno}: {what}: '{line}'"));
        match kw {
            "format" => {
                let f: Vec<&str> = rest.split_whitespace().collect();
                if f.len() != 2 {
                    return Err(bad("malformed format line"));
                }
                h.encoding = match f[0] {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::BinaryLe,
                    "binary_big_endian" => Encoding::BinaryBe,
                    other => return Err(bad(&format!("unknown format '{other}'"))),
                };
                if f[1] != "1.0" && f[1] != "1" {
                    return Err(Error::unsupported(format!(
                        "header line {lineno}: PLY version {} (only 1.0)",
                        f[1]
                    )));
                }
                have_format = true;
            }
            "comment" => {
                if let Some(body) = rest.strip_prefix(TAG).filter(|b| b.starts_with(' ')) {
                    parse_tag_comment(body.trim(), &mut h)
                        .map_err(|what| bad(&format!("bad '{TAG}' comment ({what})")))?;
                } else {
                    h.comments.push(raw_rest.to_string());
                }
            }
            "obj_info" => h.obj_info.push(raw_rest.to_string()),
            "element" => {
                let f: Vec<&str> = rest.split_whitespace().collect();
                if f.len() != 2 {
                    return Err(bad("malformed element line"));
                }
                let count: u64 = f[1]
                    .parse()
                    .map_err(|_| bad("element count is not a non-negative integer"))?;
                // (Sets, not scans: a header of many elements or
                // properties parses in linear time.)
                if !element_names.insert(f[0].to_string()) {
                    return Err(bad("element declared twice"));
                }
                prop_names.clear();
                h.elements.push(ElementDef {
                    name: f[0].to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            "property" => {
                let f: Vec<&str> = rest.split_whitespace().collect();
                let ty = |s: &str| {
                    ScalarType::from_ply_name(s)
                        .ok_or_else(|| bad(&format!("unknown property type '{s}'")))
                };
                let prop = match f.as_slice() {
                    ["list", c, i, name] => {
                        let c = ty(c)?;
                        if c.is_float() {
                            return Err(bad("list count type must be an integer type"));
                        }
                        PropDef {
                            name: name.to_string(),
                            kind: PropKind::List(c, ty(i)?),
                        }
                    }
                    [t, name] => PropDef {
                        name: name.to_string(),
                        kind: PropKind::Scalar(ty(t)?),
                    },
                    _ => return Err(bad("malformed property line")),
                };
                let el = h
                    .elements
                    .last_mut()
                    .ok_or_else(|| bad("property before any element"))?;
                if !prop_names.insert(prop.name.clone()) {
                    return Err(bad("property declared twice"));
                }
                el.props.push(prop);
            }
            "end_header" => break,
            "" => return Err(bad("empty header line")),
            other => return Err(bad(&format!("unknown keyword '{other}'"))),
        }
    }
    if !have_format {
        return Err(Error::invalid("header has no 'format' line"));
    }
    Ok(h)
}

/// Parses the part after `comment pcsss `.
fn parse_tag_comment(body: &str, h: &mut Header) -> std::result::Result<(), String> {
    let mut it = body.splitn(2, ' ');
    let what = it.next().unwrap_or("");
    let rest = it.next().unwrap_or("").trim();
    match what {
        "detail" => {
            let mut f = rest.splitn(3, ' ');
            let (name, tag, val) = (
                f.next().unwrap_or(""),
                f.next().unwrap_or(""),
                f.next().unwrap_or("").trim(),
            );
            if name.is_empty() {
                return Err("detail without a name".into());
            }
            let value = parse_detail_value(tag, val)?;
            h.detail.push(Detail {
                name: name.to_string(),
                value,
            });
            Ok(())
        }
        "role" => {
            let f: Vec<&str> = rest.split_whitespace().collect();
            match f.as_slice() {
                [el, attr, role] => {
                    let role =
                        Role::from_name(role).ok_or_else(|| format!("unknown role '{role}'"))?;
                    h.roles.push((el.to_string(), attr.to_string(), role));
                    Ok(())
                }
                _ => Err("role needs ELEMENT ATTRIBUTE ROLE".into()),
            }
        }
        "comment" => {
            let text: String =
                serde_json::from_str(rest).map_err(|e| format!("comment value: {e}"))?;
            h.comments.push(text);
            Ok(())
        }
        other => Err(format!("unknown kind '{other}'")),
    }
}

/// True when the plain comment `c` would read back as one of the
/// toolkit's own `pcsss` lines (the writer then quotes it).
pub fn is_tag_comment(c: &str) -> bool {
    c.trim()
        .strip_prefix(TAG)
        .is_some_and(|b| b.starts_with(' '))
}

fn parse_detail_value(tag: &str, val: &str) -> std::result::Result<DetailValue, String> {
    fn num<T: std::str::FromStr>(s: &str) -> std::result::Result<T, String> {
        s.parse()
            .map_err(|_| format!("'{s}' is not a number of its type"))
    }
    fn three<T: std::str::FromStr>(s: &str) -> std::result::Result<[T; 3], String> {
        let v: Vec<&str> = s.split_whitespace().collect();
        if v.len() != 3 {
            return Err("a 3-vector needs three values".into());
        }
        Ok([num(v[0])?, num(v[1])?, num(v[2])?])
    }
    Ok(match tag {
        "i32" => DetailValue::I32(num(val)?),
        "f32" => DetailValue::F32(num(val)?),
        "f64" => DetailValue::F64(num(val)?),
        "v3f" => DetailValue::V3F(three(val)?),
        "v3d" => DetailValue::V3D(three(val)?),
        "str" => {
            DetailValue::Str(serde_json::from_str(val).map_err(|e| format!("string value: {e}"))?)
        }
        other => return Err(format!("unknown detail type '{other}'")),
    })
}

/// Formats a detail attribute as the text after `comment `.
pub fn detail_comment(d: &Detail) -> String {
    fn f<T: crate::column::Scalar>(x: T) -> String {
        let mut s = String::new();
        x.fmt_ascii(&mut s);
        s
    }
    let v = match &d.value {
        DetailValue::I32(x) => f(*x),
        DetailValue::F32(x) => f(*x),
        DetailValue::F64(x) => f(*x),
        DetailValue::V3F(a) => format!("{} {} {}", f(a[0]), f(a[1]), f(a[2])),
        DetailValue::V3D(a) => format!("{} {} {}", f(a[0]), f(a[1]), f(a[2])),
        DetailValue::Str(s) => ascii_json(s),
    };
    format!("{TAG} detail {} {} {v}", d.name, d.value.tag())
}

/// A JSON string literal in ASCII only (`\uXXXX` escapes), since PLY
/// headers are ASCII and readers such as plyfile refuse anything else.
pub fn ascii_json(s: &str) -> String {
    let json = serde_json::to_string(s).expect("strings serialise");
    let mut out = String::with_capacity(json.len());
    for c in json.chars() {
        if c.is_ascii() {
            out.push(c);
        } else {
            let mut buf = [0u16; 2];
            for u in c.encode_utf16(&mut buf) {
                out.push_str(&format!("\\u{u:04x}"));
            }
        }
    }
    out
}

/// The three PLY property names of a 3-vector attribute.
pub fn component_names(name: &str, role: Role) -> [String; 3] {
    match (name, role) {
        ("P", _) => ["x".into(), "y".into(), "z".into()],
        ("N", _) => ["nx".into(), "ny".into(), "nz".into()],
        (_, Role::Color) => [
            format!("{name}_r"),
            format!("{name}_g"),
            format!("{name}_b"),
        ],
        _ => [
            format!("{name}_x"),
            format!("{name}_y"),
            format!("{name}_z"),
        ],
    }
}

/// The role a reader infers from the names alone.
pub fn default_role(name: &str, role: Role) -> Role {
    match (name, role) {
        ("P", _) => Role::Point,
        ("N", _) => Role::Normal,
        (_, Role::Color) => Role::Color,
        _ => Role::Vector,
    }
}

/// How an element's properties map to attributes.
#[derive(Clone, Debug, PartialEq)]
pub enum Layout {
    Scalar {
        name: String,
        prop: usize,
    },
    Vec3 {
        name: String,
        role: Role,
        props: [usize; 3],
    },
    List {
        name: String,
        prop: usize,
    },
}

impl Layout {
    /// The attribute name.
    pub fn name(&self) -> &str {
        match self {
            Layout::Scalar { name, .. } | Layout::Vec3 { name, .. } | Layout::List { name, .. } => {
                name
            }
        }
    }
}

/// The role comments of a header by (element, attribute): the roles
/// given, in order.
pub type Roles = HashMap<(String, String), Vec<Role>>;

/// The header's role comments as [`Roles`] (made once, not searched for
/// each attribute).
pub fn roles(h: &Header) -> Roles {
    let mut m: Roles = HashMap::new();
    for (e, a, r) in &h.roles {
        m.entry((e.clone(), a.clone())).or_default().push(*r);
    }
    m
}

/// Groups an element's properties into attributes by the naming convention.
/// A group is formed only when all three components exist as scalars of one
/// type and its name does not clash; it takes the place of its first
/// component.
pub fn layout(el: &ElementDef, roles: &Roles) -> Vec<Layout> {
    // (Maps, not scans: linear in the element's properties.)
    let index: HashMap<&str, usize> = el
        .props
        .iter()
        .enumerate()
        .map(|(i, p)| (p.name.as_str(), i))
        .collect();
    let find = |n: &str| index.get(n).copied();
    let mut named: HashSet<String> = HashSet::new();
    let mut used = vec![false; el.props.len()];
    let mut out: Vec<Layout> = Vec::new();
    for (i, p) in el.props.iter().enumerate() {
        if used[i] {
            continue;
        }
        let ty = match p.kind {
            PropKind::List(..) => {
                used[i] = true;
                out.push(Layout::List {
                    name: p.name.clone(),
                    prop: i,
                });
                continue;
            }
            PropKind::Scalar(t) => t,
        };
        let group = triple_of(&p.name).and_then(|(name, role, names)| {
            let idx = [find(&names[0])?, find(&names[1])?, find(&names[2])?];
            let same = idx
                .iter()
                .all(|&k| !used[k] && el.props[k].kind == PropKind::Scalar(ty));
            let clash = find(&name).is_some() || named.contains(&name);
            // A role comment may refine the role, never rename the components.
            let role = roles
                .get(&(el.name.clone(), name.clone()))
                .and_then(|rs| {
                    rs.iter()
                        .copied()
                        .find(|r| component_names(&name, *r) == names)
                })
                .unwrap_or(role);
            (same && !clash).then_some((name, role, idx))
        });
        match group {
            Some((name, role, idx)) => {
                for k in idx {
                    used[k] = true;
                }
                named.insert(name.clone());
                out.push(Layout::Vec3 {
                    name,
                    role,
                    props: idx,
                });
            }
            None => {
                used[i] = true;
                out.push(Layout::Scalar {
                    name: p.name.clone(),
                    prop: i,
                });
            }
        }
    }
    out
}

/// When `prop` names a component of a 3-vector: the vector's name, default
/// role and the three component names.
fn triple_of(prop: &str) -> Option<(String, Role, [String; 3])> {
    let (name, role) = match prop {
        "x" | "y" | "z" => ("P".to_string(), Role::Point),
        "nx" | "ny" | "nz" => ("N".to_string(), Role::Normal),
        _ => {
            let (base, suffix) = prop.rsplit_once('_')?;
            if base.is_empty() {
                return None;
            }
            let role = match suffix {
                "x" | "y" | "z" => Role::Vector,
                "r" | "g" | "b" => Role::Color,
                _ => return None,
            };
            (base.to_string(), role)
        }
    };
    let names = component_names(&name, role);
    Some((name, role, names))
}
