//! The module graph of every crate has no cycles (issue 12): a module may use its children,
//! siblings and the crate root's items, but no two modules may import each other, directly or
//! through others.
//!
//! The graph is read from the sources: every `crate::a::b`, `super::a`, `self::a` path and
//! every `use crate::{a, b}` / `use super::{a, b}` group outside `mod tests`, resolved to the
//! longest module path that exists. Edges to the crate root (its items, e.g. the plugin type)
//! are not counted: the root declares every module.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `src`, keyed by its module path (`crate`, `crate::a::b`).
fn modules(src: &Path) -> BTreeMap<String, String> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(rd) = std::fs::read_dir(dir) else { return };
        for e in rd.filter_map(Result::ok) {
            let p = e.path();
            if p.is_dir() {
                walk(&p, out);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    let mut files = Vec::new();
    walk(src, &mut files);
    let mut out = BTreeMap::new();
    for f in files {
        let rel = f.strip_prefix(src).expect("under src").with_extension("");
        let rel = rel.to_string_lossy().replace(['/', '\\'], "::");
        // Binaries under src/bin are their own crates.
        if rel.starts_with("bin::") {
            continue;
        }
        let name = match rel.as_str() {
            "lib" | "main" => "crate".to_string(),
            r => format!("crate::{}", r.strip_suffix("::mod").unwrap_or(r)),
        };
        let text = std::fs::read_to_string(&f).expect("readable source");
        out.insert(name, text);
    }
    out
}

/// The source without comments and without a trailing `#[cfg(test)] mod tests { … }`.
fn code(text: &str) -> String {
    let body = match text.find("#[cfg(test)]") {
        Some(i) if text[i..].contains("mod tests") => &text[..i],
        _ => text,
    };
    body.lines().map(|l| l.split("//").next().unwrap_or("")).collect::<Vec<_>>().join("\n")
}

/// Paths starting with `crate`, `super` or `self` in `src`, as lists of segments; `{a, b}`
/// groups give one path per name.
fn paths(src: &str) -> Vec<(String, Vec<String>)> {
    let bytes: Vec<char> = src.chars().collect();
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if !ident(bytes[i]) || (i > 0 && (ident(bytes[i - 1]) || bytes[i - 1] == ':')) {
            i += 1;
            continue;
        }
        let start = i;
        while i < bytes.len() && ident(bytes[i]) {
            i += 1;
        }
        let head: String = bytes[start..i].iter().collect();
        if !matches!(head.as_str(), "crate" | "super" | "self") {
            continue;
        }
        let mut segs = Vec::new();
        loop {
            if i + 1 < bytes.len() && bytes[i] == ':' && bytes[i + 1] == ':' {
                i += 2;
                if i < bytes.len() && bytes[i] == '{' {
                    let end = bytes[i..].iter().position(|&c| c == '}').map_or(bytes.len(), |e| i + e);
                    let group: String = bytes[i + 1..end].iter().collect();
                    for name in group.split(',') {
                        let name: String = name.trim().chars().take_while(|&c| ident(c)).collect();
                        if !name.is_empty() {
                            let mut p = segs.clone();
                            p.push(name);
                            out.push((head.clone(), p));
                        }
                    }
                    i = end;
                    segs.clear();
                    break;
                }
                let s = i;
                while i < bytes.len() && ident(bytes[i]) {
                    i += 1;
                }
                segs.push(bytes[s..i].iter().collect());
            } else {
                break;
            }
        }
        if !segs.is_empty() {
            out.push((head, segs));
        }
    }
    out
}

/// Module → modules it uses.
fn graph(mods: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, text) in mods {
        let parent = m.rsplit_once("::").map_or("crate", |(p, _)| p).to_string();
        for (head, segs) in paths(&code(text)) {
            let mut path = match head.as_str() {
                "crate" => "crate".to_string(),
                "super" => parent.clone(),
                _ => m.clone(),
            };
            let mut target = None;
            for s in &segs {
                path = format!("{path}::{s}");
                if mods.contains_key(&path) {
                    target = Some(path.clone());
                }
            }
            if let Some(t) = target.filter(|t| t != m && t != "crate") {
                edges.entry(m.clone()).or_default().insert(t);
            }
        }
    }
    edges
}

/// A cycle in `edges`, if any (depth-first search).
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        v: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        stack: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        state.insert(v.to_string(), 1);
        stack.push(v.to_string());
        for w in edges.get(v).into_iter().flatten() {
            match state.get(w.as_str()).copied().unwrap_or(0) {
                1 => {
                    let at = stack.iter().position(|s| s == w).unwrap_or(0);
                    let mut cycle = stack[at..].to_vec();
                    cycle.push(w.clone());
                    return Some(cycle);
                }
                0 => {
                    if let Some(c) = visit(w, edges, state, stack) {
                        return Some(c);
                    }
                }
                _ => {}
            }
        }
        stack.pop();
        state.insert(v.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for v in edges.keys() {
        if state.get(v.as_str()).copied().unwrap_or(0) == 0 {
            if let Some(c) = visit(v, edges, &mut state, &mut Vec::new()) {
                return Some(c);
            }
        }
    }
    None
}

#[test]
fn the_checker_finds_a_cycle_it_is_shown() {
    let mods: BTreeMap<String, String> = [
        ("crate", "mod a; mod b; mod c;"),
        ("crate::a", "use super::b::thing;"),
        ("crate::b", "use crate::{c, d};\n// use crate::a; in a comment is no edge"),
        ("crate::c", "fn f() { super::a::g() }"),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect();
    let cycle = find_cycle(&graph(&mods)).expect("a → b → c → a");
    assert_eq!(cycle.len(), 4, "{cycle:?}");
    let mut acyclic = mods.clone();
    acyclic.insert("crate::c".into(), "fn f() {}".into());
    assert_eq!(find_cycle(&graph(&acyclic)), None);
}

#[test]
fn no_crate_has_an_import_cycle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root");
    let mut found = Vec::new();
    for krate in ["dsp", "estimator", "presets", "presets/fem", "plugin", "plugin/cli"] {
        let mods = modules(&root.join(krate).join("src"));
        assert!(mods.len() > 1, "{krate}: no modules found");
        if let Some(c) = find_cycle(&graph(&mods)) {
            found.push(format!("{krate}: {}", c.join(" → ")));
        }
    }
    assert!(found.is_empty(), "import cycles:\n{}", found.join("\n"));
}
