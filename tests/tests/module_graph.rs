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

/// The source without comments and without its `#[cfg(test)] mod tests { … }` (from that
/// attribute on; other `#[cfg(test)]` items stay).
fn code(text: &str) -> String {
    let lines: Vec<&str> = text.lines().map(|l| l.split("//").next().unwrap_or("")).collect();
    let mut end = lines.len();
    for (i, l) in lines.iter().enumerate() {
        if l.trim() == "#[cfg(test)]" {
            let next = lines[i + 1..].iter().map(|l| l.trim()).find(|l| !l.is_empty() && !l.starts_with("#["));
            if next.is_some_and(|n| n.starts_with("mod tests")) {
                end = i;
                break;
            }
        }
    }
    lines[..end].join("\n")
}

/// The paths of a `use` tree or expression starting at `chars[i]` (just after a `::`), each
/// as segments appended to `prefix`: `a::b`, `{a, b::{c, d}}`, `*` (the module itself).
fn tree(chars: &[char], i: &mut usize, prefix: &[String], out: &mut Vec<Vec<String>>) {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let skip_ws = |i: &mut usize| {
        while *i < chars.len() && chars[*i].is_whitespace() {
            *i += 1;
        }
    };
    skip_ws(i);
    if *i < chars.len() && chars[*i] == '{' {
        *i += 1;
        loop {
            skip_ws(i);
            if *i >= chars.len() || chars[*i] == '}' {
                *i += 1;
                return;
            }
            tree(chars, i, prefix, out);
            skip_ws(i);
            // Skip `as name` and anything else up to the next item or the group's end.
            let mut depth = 0;
            while *i < chars.len() && !(depth == 0 && (chars[*i] == ',' || chars[*i] == '}')) {
                match chars[*i] {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    _ => {}
                }
                *i += 1;
            }
            if *i < chars.len() && chars[*i] == ',' {
                *i += 1;
            }
        }
    }
    if *i < chars.len() && chars[*i] == '*' {
        *i += 1;
        out.push(prefix.to_vec());
        return;
    }
    let s = *i;
    while *i < chars.len() && ident(chars[*i]) {
        *i += 1;
    }
    let mut path = prefix.to_vec();
    if *i > s {
        path.push(chars[s..*i].iter().collect());
    }
    if *i + 1 < chars.len() && chars[*i] == ':' && chars[*i + 1] == ':' {
        *i += 2;
        tree(chars, i, &path, out);
    } else {
        out.push(path);
    }
}

/// Paths in `src` that start with `crate`, `super`, `self` or one of `children` (the
/// module's own submodules), as (head, segments).
fn paths(src: &str, children: &[String]) -> Vec<(String, Vec<String>)> {
    let chars: Vec<char> = src.chars().collect();
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let mut out = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        if !ident(chars[i]) || (i > 0 && (ident(chars[i - 1]) || chars[i - 1] == ':')) {
            i += 1;
            continue;
        }
        let start = i;
        while i < chars.len() && ident(chars[i]) {
            i += 1;
        }
        let head: String = chars[start..i].iter().collect();
        let known = matches!(head.as_str(), "crate" | "super" | "self") || children.contains(&head);
        if !(known && i + 1 < chars.len() && chars[i] == ':' && chars[i + 1] == ':') {
            continue;
        }
        i += 2;
        let mut found = Vec::new();
        tree(&chars, &mut i, &[], &mut found);
        for segs in found {
            if children.contains(&head) {
                let mut p = vec![head.clone()];
                p.extend(segs);
                out.push(("self".to_string(), p));
            } else {
                out.push((head.clone(), segs));
            }
        }
    }
    out
}

/// Module → modules it uses. A path to a module's item is an edge to that module (`super::X`
/// to the parent); edges to the crate root are not counted (it declares every module).
fn graph(mods: &BTreeMap<String, String>) -> BTreeMap<String, BTreeSet<String>> {
    let mut edges: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, text) in mods {
        let parent = m.rsplit_once("::").map_or("crate", |(p, _)| p).to_string();
        let children: Vec<String> = mods
            .keys()
            .filter_map(|k| k.strip_prefix(&format!("{m}::")))
            .filter(|rest| !rest.contains("::"))
            .map(str::to_string)
            .collect();
        for (head, segs) in paths(&code(text), &children) {
            let base = match head.as_str() {
                "crate" => "crate".to_string(),
                "super" => parent.clone(),
                _ => m.clone(),
            };
            let mut path = base.clone();
            let mut target = mods.contains_key(&base).then(|| base.clone());
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
    // A parent using its child and the child using the parent's item; a nested group; a
    // glob; test modules do not count, other `#[cfg(test)]` items do.
    let parent_child: BTreeMap<String, String> = [
        ("crate", "mod p;"),
        ("crate::p", "mod q;\npub use q::Thing;\npub struct Item;"),
        ("crate::p::q", "use super::Item;\npub struct Thing;"),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect();
    assert!(find_cycle(&graph(&parent_child)).is_some(), "{:?}", graph(&parent_child));
    let nested: BTreeMap<String, String> = [
        ("crate", "mod a; mod b; mod c;"),
        ("crate::a", "use crate::{b::{self, X}, c};"),
        ("crate::b", "fn f() {}"),
        ("crate::c", "#[cfg(test)]\nfn helper() { crate::a::g() }\n#[cfg(test)]\nmod tests { use super::*; }"),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v.to_string()))
    .collect();
    let g = graph(&nested);
    assert_eq!(g.get("crate::a").map(|e| e.len()), Some(2), "{g:?}");
    assert!(find_cycle(&g).is_some(), "c's test helper uses a, which uses c: {g:?}");
    let glob: BTreeMap<String, String> =
        [("crate", "mod a; mod b;"), ("crate::a", "use super::b::*;"), ("crate::b", "use crate::a::*;")]
            .into_iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect();
    assert!(find_cycle(&graph(&glob)).is_some(), "{:?}", graph(&glob));
}

#[test]
fn no_crate_has_an_import_cycle() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root");
    let mut found = Vec::new();
    // `plugin` and `plugin/resonator` are one module each (the exports of `plugin/core`).
    for krate in ["dsp", "estimator", "presets", "presets/fem", "plugin/core", "plugin/cli"] {
        let mods = modules(&root.join(krate).join("src"));
        assert!(mods.len() > 1, "{krate}: no modules found");
        if let Some(c) = find_cycle(&graph(&mods)) {
            found.push(format!("{krate}: {}", c.join(" → ")));
        }
    }
    assert!(found.is_empty(), "import cycles:\n{}", found.join("\n"));
}
