//! The modules of `pn-drivers` depend on each other one way only: the graph of `crate::…`
//! and `super::…` references (and of child modules a file declares and uses) between the
//! files of `src/` has no cycle. Comments and `#[cfg(test)]` sections are ignored.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)] // test code

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// Module path (`fld_method::plot`; "" for the crate root) → source text.
fn modules(dir: &Path, prefix: &[String], out: &mut BTreeMap<String, String>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if path.is_dir() {
            let mut p = prefix.to_vec();
            p.push(name);
            modules(&path, &p, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            let mut p = prefix.to_vec();
            if !matches!(name.as_str(), "lib" | "main" | "mod") {
                p.push(name);
            }
            out.insert(p.join("::"), std::fs::read_to_string(&path).unwrap());
        }
    }
}

/// The code of a file without comments and without its `#[cfg(test)]` tail.
fn code(text: &str) -> String {
    let text = text.split("#[cfg(test)]").next().unwrap_or("");
    text.lines()
        .filter(|l| !l.trim_start().starts_with("//"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Paths following `keyword::` in `text` (`crate::a::b` → `["a", "b"]`), not preceded by
/// another path segment.
fn paths_after(text: &str, keyword: &str) -> Vec<Vec<String>> {
    let needle = format!("{keyword}::");
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(i) = rest.find(&needle) {
        let before = rest[..i].chars().last();
        let after = &rest[i + needle.len()..];
        rest = after;
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let end = after
            .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
            .unwrap_or(after.len());
        let segs: Vec<String> = after[..end]
            .split("::")
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect();
        found.push(segs);
    }
    found
}

/// The longest prefix of `segs` that names a module.
fn module_of(segs: &[String], names: &BTreeSet<String>) -> Option<String> {
    (0..=segs.len())
        .rev()
        .map(|k| segs[..k].join("::"))
        .find(|c| names.contains(c))
}

fn edges(mods: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let names: BTreeSet<String> = mods.keys().cloned().collect();
    let mut edges = BTreeMap::new();
    for (m, text) in mods {
        let text = code(text);
        let parent: Vec<String> = m
            .split("::")
            .filter(|s| !s.is_empty())
            .map(str::to_string)
            .collect::<Vec<_>>()
            .split_last()
            .map(|(_, p)| p.to_vec())
            .unwrap_or_default();
        let mut to = BTreeSet::new();
        for segs in paths_after(&text, "crate") {
            to.extend(module_of(&segs, &names));
        }
        for segs in paths_after(&text, "super") {
            let mut full = parent.clone();
            full.extend(segs);
            to.extend(module_of(&full, &names));
        }
        // Child modules that the file declares and then uses by name.
        for line in text.lines() {
            let l = line.trim().trim_start_matches("pub ");
            if let Some(child) = l.strip_prefix("mod ").and_then(|r| r.strip_suffix(';')) {
                let full = if m.is_empty() {
                    child.to_string()
                } else {
                    format!("{m}::{child}")
                };
                if names.contains(&full) && !paths_after(&text, child).is_empty() {
                    to.insert(full);
                }
            }
        }
        to.remove(m);
        edges.insert(m.clone(), to);
    }
    edges
}

/// A cycle through `u`, if the depth-first search from it finds one.
fn find_cycle(
    u: &str,
    edges: &BTreeMap<String, BTreeSet<String>>,
    state: &mut BTreeMap<String, u8>,
    stack: &mut Vec<String>,
) -> Option<Vec<String>> {
    state.insert(u.to_string(), 1);
    stack.push(u.to_string());
    for v in &edges[u] {
        match state.get(v) {
            Some(1) => {
                let i = stack.iter().position(|s| s == v).unwrap();
                let mut c = stack[i..].to_vec();
                c.push(v.clone());
                return Some(c);
            }
            Some(_) => {}
            None => {
                if let Some(c) = find_cycle(v, edges, state, stack) {
                    return Some(c);
                }
            }
        }
    }
    stack.pop();
    state.insert(u.to_string(), 2);
    None
}

#[test]
fn module_dependencies_are_acyclic() {
    let mut mods = BTreeMap::new();
    modules(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("src"),
        &[],
        &mut mods,
    );
    assert!(mods.contains_key("solve") && mods.contains_key("fld_method::plot"));
    let edges = edges(&mods);
    // The graph is what the crate documentation describes, e.g. solve uses the set-up below.
    assert!(edges["solve"].contains("scene_setup"));
    assert!(edges["fld_method"].contains("fld_method::plot"));
    let mut state = BTreeMap::new();
    for m in edges.keys() {
        if !state.contains_key(m) {
            let cycle = find_cycle(m, &edges, &mut state, &mut Vec::new());
            assert!(
                cycle.is_none(),
                "module cycle: {}",
                cycle.unwrap_or_default().join(" -> ")
            );
        }
    }
}

/// The check itself finds a cycle: two modules that name each other.
#[test]
fn a_cycle_is_found() {
    let mods: BTreeMap<String, String> = [
        ("".to_string(), "mod a;\nmod b;\n".to_string()),
        ("a".to_string(), "use crate::b::f;\n".to_string()),
        ("b".to_string(), "fn f() { super::a::g() }\n".to_string()),
    ]
    .into_iter()
    .collect();
    let edges = edges(&mods);
    let cycle = find_cycle("a", &edges, &mut BTreeMap::new(), &mut Vec::new());
    assert_eq!(cycle.unwrap(), ["a", "b", "a"]);
}
