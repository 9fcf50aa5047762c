//! Interop with readers and writers nobody here wrote: Python's `plyfile`
//! and `trimesh` (installed by `make test` from tests/requirements.txt).

use std::path::Path;
use std::process::Command;

use crate::util::*;
use pcsss::formats::ply::header::component_names;
use pcsss::{AttrData, Cloud, Column, ListColumn};
use serde_json::Value;

/// The Python interpreter with plyfile, numpy and trimesh.
fn python() -> String {
    python_with(&["plyfile", "numpy", "trimesh"])
}

fn script() -> String {
    format!("{}/tests/py/plyfile_interop.py", env!("CARGO_MANIFEST_DIR"))
}

fn dump(py: &str, file: &Path) -> Value {
    let out = Command::new(py)
        .arg(script())
        .arg("dump")
        .arg(file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "plyfile could not read {}: {}",
        file.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

enum Prop<'a> {
    Col(&'a Column),
    List(&'a ListColumn),
}

/// Our element as PLY properties, in file order.
fn props(el: &pcsss::Element) -> Vec<(String, Prop<'_>)> {
    let mut v = Vec::new();
    for a in el.attrs() {
        match &a.data {
            AttrData::Scalar(c) => v.push((a.name.clone(), Prop::Col(c.column()))),
            AttrData::Vec3(role, c) => {
                for (n, c) in component_names(&a.name, *role).into_iter().zip(c.iter()) {
                    v.push((n, Prop::Col(c.column())));
                }
            }
            AttrData::List(l) => v.push((a.name.clone(), Prop::List(l))),
        }
    }
    v
}

fn same_values(what: &str, ours: &Column, range: std::ops::Range<usize>, theirs: &Value) {
    let kind = theirs["kind"].as_str().unwrap();
    let vals = theirs["v"].as_array().unwrap();
    assert_eq!(vals.len(), range.len(), "{what}: count");
    for (i, tv) in range.zip(vals) {
        let x = ours.get_f64(i);
        if kind == "f" {
            let y = f64::from_bits(tv.as_u64().unwrap());
            assert!(
                x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()),
                "{what}[{i}]: ours {x:e}, plyfile {y:e}"
            );
        } else {
            let y = tv.as_i64().unwrap() as f64;
            assert_eq!(x, y, "{what}[{i}]");
        }
    }
}

/// Our reading of a file equals plyfile's, property by property, in order.
fn assert_matches(cloud: &Cloud, theirs: &Value, label: &str) {
    let els = theirs["elements"].as_array().unwrap();
    assert_eq!(els.len(), cloud.elements.len(), "{label}: elements");
    for (te, oe) in els.iter().zip(&cloud.elements) {
        assert_eq!(te["name"], oe.name.as_str());
        assert_eq!(
            te["count"].as_u64().unwrap() as usize,
            oe.len(),
            "{label}: {} count",
            oe.name
        );
        let ours = props(oe);
        let tp = te["props"].as_array().unwrap();
        let names: Vec<&str> = tp.iter().map(|p| p["name"].as_str().unwrap()).collect();
        let our_names: Vec<&str> = ours.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, our_names, "{label}: {} properties", oe.name);
        for (p, (name, op)) in tp.iter().zip(&ours) {
            let what = format!("{label}: {}.{name}", oe.name);
            match op {
                Prop::Col(c) => same_values(&what, c, 0..c.len(), &p["values"]),
                Prop::List(l) => {
                    let rows = p["rows"].as_array().unwrap();
                    assert_eq!(rows.len(), l.len());
                    for (r, row) in rows.iter().enumerate() {
                        same_values(&what, &l.items, l.range(r), row);
                    }
                }
            }
        }
    }
}

#[test]
#[ignore = "interop: needs Python's plyfile and trimesh; `make test` runs it"]
fn plyfile_reads_what_we_write() {
    let py = python();
    let d = tempdir();
    let cloud = every_type_cloud();
    for (name, f) in [("le", LE), ("be", BE), ("ascii", ASCII)] {
        let path = d.path().join(format!("ours_{name}.ply"));
        std::fs::write(&path, to_bytes(&cloud, f)).unwrap();
        let theirs = dump(&py, &path);
        assert_matches(&cloud, &theirs, &format!("ours_{name}"));
        // Detail attributes ride in comments plyfile keeps and skips.
        let comments: Vec<&str> = theirs["comments"]
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_str().unwrap())
            .collect();
        assert!(
            comments
                .iter()
                .any(|c| c.starts_with("pcsss detail Tarea f64 12.566370614359172")),
            "{comments:?}"
        );
        assert!(comments.contains(&"a comment with   inner  spaces"));
    }
}

#[test]
#[ignore = "interop: needs Python's plyfile and trimesh; `make test` runs it"]
fn we_read_what_plyfile_and_trimesh_write() {
    let py = python();
    let d = tempdir();
    let out = Command::new(&py)
        .arg(script())
        .arg("write")
        .arg(d.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut n = 0;
    for entry in std::fs::read_dir(d.path()).unwrap() {
        let path = entry.unwrap().path();
        let bytes = std::fs::read(&path).unwrap();
        let label = path.file_name().unwrap().to_string_lossy().into_owned();
        let cloud = from_bytes(&bytes);
        assert_matches(&cloud, &dump(&py, &path), &label);
        if label.starts_with("plyfile") {
            assert_eq!(cloud.comments, vec!["written by plyfile"]);
            assert_eq!(cloud.obj_info, vec!["interop"]);
            assert!(cloud
                .points()
                .attr("illum")
                .is_some_and(|a| a.role() == Some(pcsss::Role::Color)));
            assert!(cloud.points().vec3_f64("P").unwrap()[0][0] == 1e6 + 0.1);
        } else {
            let polys = pcsss::geom::mesh::Polygons::of(&cloud).unwrap();
            assert_eq!(
                (cloud.len(), polys.len()),
                (162, 320),
                "{label}: icosphere(2)"
            );
        }
        // And what we write back, plyfile reads the same.
        let back = d.path().join(format!("back_{label}"));
        std::fs::write(&back, to_bytes(&cloud, LE)).unwrap();
        assert_matches(&cloud, &dump(&py, &back), &format!("back_{label}"));
        n += 1;
    }
    assert_eq!(n, 5);
}
