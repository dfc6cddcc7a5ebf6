//! The protocol's modules import each other in layers, never in a circle: geometry, ids and
//! errors at the bottom; keys, maps, plans above them; the operator's API on top. A `crate::x`
//! path in code (comments and tests aside) is an import of module `x`.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

type Graph = BTreeMap<String, BTreeSet<String>>;

/// Module `name`'s imports of other modules, from its source.
fn imports(source: &str, name: &str, modules: &BTreeSet<String>) -> BTreeSet<String> {
    let code = source.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = BTreeSet::new();
    for line in code.lines().map(str::trim).filter(|l| !l.starts_with("//")) {
        for (i, _) in line.match_indices("crate::") {
            let rest = &line[i + "crate::".len()..];
            if let Some(rest) = rest.strip_prefix('{') {
                // `use crate::{a::X, b};`
                for part in rest.split([',', '}']) {
                    let m: String = part.trim().chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect();
                    out.insert(m);
                }
            } else {
                out.insert(rest.chars().take_while(|c| c.is_ascii_lowercase() || *c == '_').collect());
            }
        }
    }
    out.retain(|m| m != name && modules.contains(m));
    out
}

fn graph(src: &Path) -> Graph {
    let mut files: BTreeMap<String, String> = BTreeMap::new();
    for e in std::fs::read_dir(src).expect("proto/src").flatten() {
        let p = e.path();
        let name = p.file_stem().map(|s| s.to_string_lossy().to_string()).unwrap_or_default();
        if name == "lib" {
            continue;
        }
        let text = if p.is_dir() {
            let mut all = String::new();
            for f in std::fs::read_dir(&p).expect("module dir").flatten() {
                if f.path().file_name().is_some_and(|n| n != "tests.rs") {
                    all += &std::fs::read_to_string(f.path()).unwrap_or_default();
                }
            }
            all
        } else {
            std::fs::read_to_string(&p).unwrap_or_default()
        };
        files.insert(name, text);
    }
    let modules: BTreeSet<String> = files.keys().cloned().collect();
    files.iter().map(|(m, text)| (m.clone(), imports(text, m, &modules))).collect()
}

/// A circle of imports, if there is one.
fn circle(g: &Graph) -> Option<Vec<String>> {
    fn visit(g: &Graph, m: &str, path: &mut Vec<String>, done: &mut BTreeSet<String>) -> Option<Vec<String>> {
        if let Some(at) = path.iter().position(|p| p == m) {
            let mut c = path[at..].to_vec();
            c.push(m.to_string());
            return Some(c);
        }
        if done.contains(m) {
            return None;
        }
        path.push(m.to_string());
        for next in g.get(m).into_iter().flatten() {
            if let Some(c) = visit(g, next, path, done) {
                return Some(c);
            }
        }
        path.pop();
        done.insert(m.to_string());
        None
    }
    let mut done = BTreeSet::new();
    g.keys().find_map(|m| visit(g, m, &mut Vec::new(), &mut done))
}

#[test]
fn the_protocol_modules_import_each_other_in_no_circle() {
    let g = graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(g.len() > 15 && g["operator"].contains("plan"), "the walk read the modules: {g:?}");
    assert_eq!(circle(&g), None);
}

#[test]
fn a_circle_is_found() {
    let modules: BTreeSet<String> = ["error", "operator", "map"].map(String::from).into();
    let mut g = Graph::new();
    g.insert("error".into(), imports("use crate::{operator::ErrorReply, ids};\n", "error", &modules));
    g.insert("operator".into(), imports("// crate::map in words only\npub x: crate::map::MapRef,\n", "operator", &modules));
    g.insert("map".into(), imports("use crate::error::ProtoError;\n#[cfg(test)]\nuse crate::operator::X;\n", "map", &modules));
    assert_eq!(circle(&g), Some(["error", "operator", "map", "error"].map(String::from).to_vec()));
    g.get_mut("map").map(BTreeSet::clear);
    assert_eq!(circle(&g), None);
}
