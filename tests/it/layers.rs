//! The library's layers (docs/ARCHITECTURE.md, "Layers"): the table there
//! is read, every path into the crate in `src/` is found, and a module
//! that uses one on a higher layer, two modules that use each other, or a
//! module the table does not place, fails; and inside every folder, two
//! files that use each other (`mod.rs` included) fail too.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Each module's layer, from the table under "## Layers" in
/// docs/ARCHITECTURE.md: rows `| N | `a`, `b` | ... |` (entries with a
/// `/`, such as `src/bin/`, are not modules of the library).
fn layers() -> BTreeMap<String, usize> {
    let text = std::fs::read_to_string(root().join("docs/ARCHITECTURE.md")).unwrap();
    let table = text
        .split("\n## Layers\n")
        .nth(1)
        .expect("docs/ARCHITECTURE.md has a section '## Layers'");
    let mut out = BTreeMap::new();
    for line in table.lines().skip_while(|l| !l.starts_with('|')) {
        if !line.starts_with('|') {
            break;
        }
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        let Ok(layer) = cells[1].parse::<usize>() else {
            continue;
        };
        for m in cells[2].split(',').map(|m| m.trim().trim_matches('`')) {
            if !m.contains('/') {
                assert!(out.insert(m.to_string(), layer).is_none(), "{m} twice");
            }
        }
    }
    assert!(out.len() > 5, "no layer table read: {out:?}");
    out
}

/// Names the crate root re-exports or defines (`pub use cloud::Cloud`,
/// a `#[macro_export]` macro), and the module each comes from.
fn root_names() -> BTreeMap<String, String> {
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).unwrap();
    let mut out = BTreeMap::new();
    for line in lib.lines() {
        let Some(rest) = line.strip_prefix("pub use ") else {
            continue;
        };
        let (module, names) = rest.split_once("::").unwrap();
        for n in names
            .trim_end_matches(';')
            .trim_matches(['{', '}'])
            .split(',')
        {
            out.insert(n.trim().to_string(), module.to_string());
        }
    }
    for (module, text) in sources() {
        let mut lines = text.lines();
        while let Some(line) = lines.next() {
            if line.trim() == "#[macro_export]" {
                let def = lines.find(|l| l.contains("macro_rules!")).unwrap();
                let name = def.split("macro_rules!").nth(1).unwrap();
                let name = name.trim().trim_end_matches('{').trim();
                out.insert(name.to_string(), module.clone());
            }
        }
    }
    out
}

/// Every source file of the library but `lib.rs` and the binaries, as
/// (its top module, text); with the module path of the file.
fn files() -> Vec<(Vec<String>, String)> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let src = root().join("src");
    let mut paths = Vec::new();
    walk(&src, &mut paths);
    paths.sort();
    let mut out = Vec::new();
    for p in paths {
        let rel = p.strip_prefix(&src).unwrap().with_extension("");
        let mut parts: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into()).collect();
        if parts[0] == "bin" || parts == ["lib"] {
            continue;
        }
        if parts.last().is_some_and(|l| l == "mod") {
            parts.pop();
        }
        out.push((parts, std::fs::read_to_string(&p).unwrap()));
    }
    out
}

fn sources() -> Vec<(String, String)> {
    files()
        .into_iter()
        .map(|(p, t)| (p[0].clone(), t))
        .collect()
}

/// The code of `text` without its line comments.
fn code(text: &str) -> String {
    text.lines()
        .map(|l| l.split("//").next().unwrap())
        .collect::<Vec<_>>()
        .join("\n")
}

/// The first identifier of `s`.
fn ident(s: &str) -> Option<String> {
    let id: String = s
        .trim_start()
        .chars()
        .take_while(|c| c.is_alphanumeric() || *c == '_')
        .collect();
    (!id.is_empty()).then_some(id)
}

/// The names `text` (a file of module path `path`) uses at the crate's
/// root: `crate::x`, each item of `use crate::{x, y::z}`, and `super::`
/// paths that climb to the root.
fn used_roots(path: &[String], text: &str) -> BTreeSet<String> {
    let code = code(text);
    let mut out = BTreeSet::new();
    for (i, _) in code.match_indices("crate::") {
        let rest = &code[i + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            // `use crate::{a, b::{c, d}}`: the first name of each item.
            for item in split_top(group) {
                out.extend(ident(&item));
            }
        } else {
            out.extend(ident(rest));
        }
    }
    // `super::super::x` from a module `depth` deep reaches the root when
    // it climbs `depth` times.
    for (i, _) in code.match_indices("super::") {
        if i >= "super::".len() && &code[i - "super::".len()..i] == "super::" {
            continue;
        }
        let mut rest = &code[i..];
        let mut up = 0;
        while let Some(r) = rest.strip_prefix("super::") {
            rest = r;
            up += 1;
        }
        if up >= path.len() {
            out.extend(ident(rest));
        }
    }
    out
}

/// The items of a `{...}` group (the text after its `{`), split at its
/// top-level commas.
fn split_top(group: &str) -> Vec<String> {
    let mut items = vec![String::new()];
    let mut depth = 0;
    for c in group.chars() {
        match c {
            '{' => depth += 1,
            '}' if depth == 0 => break,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(String::new());
                continue;
            }
            _ => {}
        }
        items.last_mut().unwrap().push(c);
    }
    items
}

/// Which top-level modules each module uses (itself left out).
fn imports() -> BTreeMap<String, BTreeSet<String>> {
    let modules = layers();
    let alias = root_names();
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (path, text) in files() {
        let me = path[0].clone();
        let set = out.entry(me.clone()).or_default();
        for name in used_roots(&path, &text) {
            let m = alias.get(&name).cloned().unwrap_or(name);
            if m != me && modules.contains_key(&m) {
                set.insert(m);
            }
        }
    }
    out
}

/// The upward imports of `graph` under `layers`, as lines.
fn upward(
    layers: &BTreeMap<String, usize>,
    graph: &BTreeMap<String, BTreeSet<String>>,
) -> Vec<String> {
    let mut bad = Vec::new();
    for (m, uses) in graph {
        let Some(&own) = layers.get(m) else {
            bad.push(format!("module {m} has no layer in docs/ARCHITECTURE.md"));
            continue;
        };
        for u in uses {
            if layers[u] > own {
                bad.push(format!(
                    "{m} (layer {own}) uses {u} (layer {}), a higher layer",
                    layers[u]
                ));
            }
        }
    }
    bad
}

/// A cycle of `graph`, if it has one.
fn cycle(graph: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        m: &str,
        graph: &BTreeMap<String, BTreeSet<String>>,
        stack: &mut Vec<String>,
        done: &mut BTreeSet<String>,
    ) -> Option<Vec<String>> {
        if let Some(i) = stack.iter().position(|s| s == m) {
            let mut c = stack[i..].to_vec();
            c.push(m.to_string());
            return Some(c);
        }
        if done.contains(m) {
            return None;
        }
        stack.push(m.to_string());
        for u in graph.get(m).into_iter().flatten() {
            if let Some(c) = visit(u, graph, stack, done) {
                return Some(c);
            }
        }
        stack.pop();
        done.insert(m.to_string());
        None
    }
    let mut done = BTreeSet::new();
    graph
        .keys()
        .find_map(|m| visit(m, graph, &mut Vec::new(), &mut done))
}

#[test]
fn every_module_uses_only_its_own_layer_or_lower_ones() {
    let bad = upward(&layers(), &imports());
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn no_modules_use_each_other() {
    let c = cycle(&imports());
    assert!(c.is_none(), "a cycle: {}", c.unwrap().join(" -> "));
}

#[test]
fn the_table_places_every_module_of_the_library_and_nothing_else() {
    let lib = std::fs::read_to_string(root().join("src/lib.rs")).unwrap();
    let declared: BTreeSet<String> = lib
        .lines()
        .filter_map(|l| l.split("mod ").nth(1).filter(|_| l.contains("mod ")))
        .map(|m| m.trim_end_matches(';').to_string())
        .collect();
    let placed: BTreeSet<String> = layers().into_keys().collect();
    assert_eq!(declared, placed);
}

#[test]
fn an_upward_import_or_a_cycle_is_caught() {
    // The checker itself, on sources made up for it: `error` using the
    // stages (the cycle this table once broke), through each kind of path.
    let layers = layers();
    for text in [
        "use crate::stages::made_by;",
        "fn f() { crate::stages::filter::srgb(0.5); }",
        "use crate::{cloud::Cloud, stages::{filter, ssmulti}};",
    ] {
        let uses: BTreeSet<String> = used_roots(&["error".into()], text)
            .into_iter()
            .filter(|u| u != "error")
            .collect();
        let graph = BTreeMap::from([("error".to_string(), uses)]);
        let bad = upward(&layers, &graph);
        assert!(
            bad.iter()
                .any(|b| b.contains("error (layer 2) uses stages")),
            "{text}: {bad:?}"
        );
    }
    // `super::super::` from two deep reaches the root; once does not.
    let path = ["geom".to_string(), "mesh".to_string()];
    assert!(used_roots(&path, "use super::super::stages::x;").contains("stages"));
    assert!(!used_roots(&path, "use super::kdtree::x;").contains("kdtree"));
    let graph = BTreeMap::from([
        ("cloud".to_string(), BTreeSet::from(["error".to_string()])),
        ("error".to_string(), BTreeSet::from(["cloud".to_string()])),
    ]);
    assert!(cycle(&graph).is_some());
}

/// The paths into the crate that `text` (a file of module path `path`)
/// names, as absolute module paths: `crate::a::b`, `super::x` and
/// `self::y` resolved, each item of a `{...}` group its own path. Its test
/// module (from `#[cfg(test)]` on) is left out.
fn paths_in(path: &[String], text: &str) -> Vec<Vec<String>> {
    let code = code(text);
    let code = match code.find("#[cfg(test)]") {
        Some(i) => &code[..i],
        None => &code[..],
    };
    let bytes = code.as_bytes();
    let mut out = Vec::new();
    for start in ["crate::", "super::", "self::"] {
        for (i, _) in code.match_indices(start) {
            // The middle of a longer path (`super::super::`, `a::self::`).
            if i >= 2 && &code[i - 2..i] == "::" {
                continue;
            }
            if i >= 1 && (bytes[i - 1].is_ascii_alphanumeric() || bytes[i - 1] == b'_') {
                continue;
            }
            let mut base: Vec<String> = match start {
                "crate::" => Vec::new(),
                _ => path.to_vec(),
            };
            let mut rest = &code[i..];
            if let Some(r) = rest.strip_prefix("crate::") {
                rest = r;
            } else if let Some(r) = rest.strip_prefix("self::") {
                rest = r;
            } else {
                while let Some(r) = rest.strip_prefix("super::") {
                    base.pop();
                    rest = r;
                }
            }
            loop {
                if let Some(group) = rest.strip_prefix('{') {
                    for item in split_top(group) {
                        let mut p = base.clone();
                        p.extend(ident(&item).filter(|id| id != "self"));
                        out.push(p);
                    }
                    break;
                }
                let Some(id) = ident(rest) else {
                    out.push(base.clone());
                    break;
                };
                rest = &rest.trim_start()[id.len()..];
                base.push(id);
                match rest.strip_prefix("::") {
                    Some(r) => rest = r,
                    None => {
                        out.push(base.clone());
                        break;
                    }
                }
            }
        }
    }
    out
}

/// Inside each folder of the library (a module with files of its own),
/// which of its files uses which: nodes are the folder's children (a
/// file, or a sub-folder as a whole) and `mod` (its `mod.rs`); a path
/// to an item of `mod.rs` (`super::Params` from a child) is an edge to
/// `mod`. A `mod x;` declaration is not a use.
fn folder_graphs(
    files: &[(Vec<String>, String)],
) -> BTreeMap<Vec<String>, BTreeMap<String, BTreeSet<String>>> {
    let mut folders: BTreeMap<Vec<String>, BTreeSet<String>> = BTreeMap::new();
    for (p, _) in files {
        for d in 1..p.len() {
            folders
                .entry(p[..d].to_vec())
                .or_default()
                .insert(p[d].clone());
        }
    }
    let mut out = BTreeMap::new();
    for (folder, children) in &folders {
        let n = folder.len();
        let node = |p: &[String]| -> String {
            match p.get(n) {
                Some(c) if children.contains(c) => c.clone(),
                _ => "mod".to_string(),
            }
        };
        let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
        for (p, text) in files.iter().filter(|(p, _)| p.starts_with(folder)) {
            let me = node(p);
            let uses = graph.entry(me.clone()).or_default();
            for a in paths_in(p, text) {
                if a.starts_with(folder) {
                    let target = node(&a);
                    if target != me {
                        uses.insert(target);
                    }
                }
            }
        }
        out.insert(folder.clone(), graph);
    }
    out
}

#[test]
fn no_two_files_of_a_folder_use_each_other() {
    let mut bad = Vec::new();
    for (folder, graph) in folder_graphs(&files()) {
        if let Some(c) = cycle(&graph) {
            bad.push(format!("src/{}: {}", folder.join("/"), c.join(" -> ")));
        }
    }
    assert!(
        bad.is_empty(),
        "files that use each other:\n{}",
        bad.join("\n")
    );
}

#[test]
fn a_cycle_between_the_files_of_a_folder_is_caught() {
    let file = |p: &str, text: &str| -> (Vec<String>, String) {
        (p.split('/').map(String::from).collect(), text.to_string())
    };
    // A child taking its parameters from `mod.rs`, which uses the child.
    let files = [
        file("stages/ssmulti", "use self::pairs::sum;\nmod pairs;"),
        file("stages/ssmulti/pairs", "use super::{Params, LEAF};"),
        file("stages/ssmulti/params", "pub struct Params;"),
    ];
    let graphs = folder_graphs(&files);
    let g = &graphs[&vec!["stages".to_string(), "ssmulti".to_string()]];
    assert!(cycle(g).is_some(), "{g:?}");
    // From the leaf file instead: none.
    let files = [
        file("stages/ssmulti", "use self::pairs::sum;"),
        file("stages/ssmulti/pairs", "use super::params::{Params, LEAF};"),
        file(
            "stages/ssmulti/params",
            "use crate::medium::{self, Medium};",
        ),
    ];
    let graphs = folder_graphs(&files);
    let g = &graphs[&vec!["stages".to_string(), "ssmulti".to_string()]];
    assert!(cycle(g).is_none(), "{g:?}");
    // `super::super::` and `crate::` paths name a sibling folder.
    let p = [
        "stages".to_string(),
        "ssmulti".to_string(),
        "pairs".to_string(),
    ];
    let got = paths_in(
        &p,
        "use super::super::filter::x; crate::stages::render::y();",
    );
    assert!(
        got.contains(&vec!["stages".into(), "filter".into(), "x".into()]),
        "{got:?}"
    );
    assert!(
        got.contains(&vec!["stages".into(), "render".into(), "y".into()]),
        "{got:?}"
    );
}
