//! The shape the code must keep (issue 22): no import cycle between the files of a crate, and no
//! file over 500 lines before its tests, in the daemon, the client, the protocol and the demo.
//! A file's imports are its `crate::…`, `super::…` and `self::…` paths and its `use child::…`
//! (outside its `#[cfg(test)]` part), resolved to the deepest module file they name; a file's
//! own ancestors (`mod.rs` above it) do not count, their child modules being theirs.
#![allow(clippy::unwrap_used, clippy::expect_used, missing_docs)]

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The crates held to these rules, as directories beside this one's.
const CRATES: [&str; 4] = ["daemon", "ctl", "api", "demo"];
/// Longest file, lines before its `#[cfg(test)]` part.
const MAX_LINES: usize = 500;

type Module = Vec<String>;

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// The module a file is (`service/cycle/mod.rs` → `service::cycle`; the crate root is empty).
fn module_of(src: &Path, file: &Path) -> Module {
    let rel = file.strip_prefix(src).unwrap().with_extension("");
    let mut m: Module = rel
        .iter()
        .map(|s| s.to_string_lossy().into_owned())
        .collect();
    if matches!(m.last().map(String::as_str), Some("mod" | "lib" | "main")) {
        m.pop();
    }
    m
}

/// The code before the file's tests.
fn code(text: &str) -> &str {
    text.find("#[cfg(test)]").map_or(text, |i| &text[..i])
}

/// The paths starting with `crate`, `super` or `self` in `text`, as segments.
fn paths(text: &str) -> Vec<Vec<String>> {
    let bytes = text.as_bytes();
    let mut out = Vec::new();
    for start in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(i) = text[from..].find(start) {
            let at = from + i;
            from = at + start.len();
            let word_before =
                at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_');
            if word_before {
                continue;
            }
            let end = text[at..]
                .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
                .map_or(text.len(), |e| at + e);
            out.push(
                text[at..end]
                    .split("::")
                    .filter(|s| !s.is_empty())
                    .map(str::to_owned)
                    .collect(),
            );
        }
    }
    // `use child::…` (a path relative to the file's own module, as a `mod.rs` re-exports its
    // children's items): read as `self::child::…`; an external crate's name resolves to no
    // module of this crate and drops out.
    for line in text.lines() {
        let line = line.trim_start();
        let line = ["pub(crate) ", "pub(super) ", "pub "]
            .iter()
            .find_map(|p| line.strip_prefix(p))
            .unwrap_or(line);
        let Some(rest) = line.strip_prefix("use ") else {
            continue;
        };
        let end = rest
            .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_' || c == ':'))
            .unwrap_or(rest.len());
        let segments: Vec<String> = rest[..end]
            .split("::")
            .filter(|s| !s.is_empty())
            .map(str::to_owned)
            .collect();
        if segments
            .first()
            .is_some_and(|s| !["crate", "super", "self"].contains(&s.as_str()))
        {
            out.push(std::iter::once("self".to_owned()).chain(segments).collect());
        }
    }
    out
}

/// The deepest module file `path` (written in `current`) names.
fn resolve(current: &Module, path: &[String], modules: &BTreeSet<Module>) -> Option<Module> {
    let (mut base, mut rest): (Module, &[String]) = match path.first().map(String::as_str) {
        Some("crate") => (Vec::new(), &path[1..]),
        Some("self") => (current.clone(), &path[1..]),
        Some("super") => (current.clone(), path),
        _ => return None,
    };
    while rest.first().is_some_and(|s| s == "super") {
        base.pop();
        rest = &rest[1..];
    }
    (0..=rest.len()).rev().find_map(|n| {
        let mut m = base.clone();
        m.extend(rest[..n].iter().cloned());
        modules.contains(&m).then_some(m)
    })
}

/// Strongly connected groups of more than one module (Tarjan).
fn cycles(edges: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct State<'a> {
        edges: &'a BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'a Module, usize>,
        low: BTreeMap<&'a Module, usize>,
        stack: Vec<&'a Module>,
        on_stack: BTreeSet<&'a Module>,
        found: Vec<Vec<Module>>,
    }
    fn visit<'a>(s: &mut State<'a>, v: &'a Module) {
        let n = s.index.len();
        s.index.insert(v, n);
        s.low.insert(v, n);
        s.stack.push(v);
        s.on_stack.insert(v);
        for w in &s.edges[v] {
            if !s.index.contains_key(w) {
                visit(s, w);
                let low = s.low[v].min(s.low[w]);
                s.low.insert(v, low);
            } else if s.on_stack.contains(w) {
                let low = s.low[v].min(s.index[w]);
                s.low.insert(v, low);
            }
        }
        if s.low[v] == s.index[v] {
            let mut group = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                group.push(w.clone());
                if w == v {
                    break;
                }
            }
            if group.len() > 1 {
                s.found.push(group);
            }
        }
    }
    let mut s = State {
        edges,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        found: Vec::new(),
    };
    for v in edges.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.found
}

fn src_of(krate: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(krate)
        .join("src")
}

#[test]
fn no_import_cycle_between_the_files_of_a_crate() {
    let mut found = Vec::new();
    for krate in CRATES {
        let src = src_of(krate);
        let mut files = Vec::new();
        rust_files(&src, &mut files);
        let texts: BTreeMap<Module, String> = files
            .iter()
            .map(|f| (module_of(&src, f), std::fs::read_to_string(f).unwrap()))
            .collect();
        let modules: BTreeSet<Module> = texts.keys().cloned().collect();
        let edges: BTreeMap<Module, BTreeSet<Module>> = texts
            .iter()
            .map(|(m, text)| {
                let targets = paths(code(text))
                    .iter()
                    .filter_map(|p| resolve(m, p, &modules))
                    .filter(|t| t != m && !m.starts_with(t))
                    .collect();
                (m.clone(), targets)
            })
            .collect();
        for group in cycles(&edges) {
            let names: Vec<String> = group.iter().map(|m| m.join("::")).collect();
            found.push(format!("{krate}: {}", names.join(" ↔ ")));
        }
    }
    assert!(found.is_empty(), "import cycles: {found:#?}");
}

#[test]
fn no_file_is_longer_than_500_lines_before_its_tests() {
    let mut long = Vec::new();
    for krate in CRATES {
        let mut files = Vec::new();
        rust_files(&src_of(krate), &mut files);
        for f in files {
            let text = std::fs::read_to_string(&f).unwrap();
            let lines = code(&text).lines().count();
            if lines > MAX_LINES {
                long.push(format!("{} ({lines} lines)", f.display()));
            }
        }
    }
    assert!(long.is_empty(), "files over {MAX_LINES} lines: {long:#?}");
}

#[test]
fn the_rules_see_a_cycle_and_resolve_paths_to_files() {
    let m = |s: &str| -> Module { s.split("::").map(str::to_owned).collect() };
    let modules: BTreeSet<Module> = [m("a"), m("a::b"), m("c")].into_iter().collect();
    let p = |s: &str| paths(s).remove(0);
    assert_eq!(
        resolve(&m("a::b"), &p("super::super::c::f"), &modules),
        Some(m("c"))
    );
    assert_eq!(
        resolve(&m("c"), &p("crate::a::b::Thing"), &modules),
        Some(m("a::b"))
    );
    assert_eq!(
        resolve(&m("c"), &p("crate::a::Other"), &modules),
        Some(m("a"))
    );
    let edges: BTreeMap<Module, BTreeSet<Module>> = [
        (m("a"), [m("c")].into_iter().collect()),
        (m("a::b"), BTreeSet::new()),
        (m("c"), [m("a")].into_iter().collect()),
    ]
    .into_iter()
    .collect();
    assert_eq!(cycles(&edges).len(), 1);
}
