//! The layout rules of ARCHITECTURE.md, checked on the source: who may
//! import whom, no import cycle between modules, `unsafe` only in the
//! Vulkan layer, no source file with more than 700 lines of non-test code.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Top-level library modules and the modules each may import (besides
/// itself). Mirrors the table in ARCHITECTURE.md.
const MAY_IMPORT: &[(&str, &[&str])] = &[
    ("error", &[]),
    ("trace", &[]),
    ("geom", &[]),
    ("scene", &["error", "geom"]),
    ("gpu", &["error", "geom", "trace"]),
    ("mesh", &["error", "geom", "scene", "gpu", "trace"]),
    ("formfactor", &["error", "geom", "scene", "mesh"]),
    ("output", &["error", "mesh"]),
    (
        "solve",
        &[
            "error",
            "geom",
            "scene",
            "mesh",
            "formfactor",
            "gpu",
            "output",
            "trace",
        ],
    ),
    (
        "render",
        &[
            "error",
            "geom",
            "scene",
            "mesh",
            "formfactor",
            "gpu",
            "output",
            "solve",
            "trace",
        ],
    ),
    (
        "gather",
        &[
            "error",
            "geom",
            "scene",
            "mesh",
            "formfactor",
            "gpu",
            "output",
            "solve",
            "render",
            "trace",
        ],
    ),
    ("app", &[ANY_BUT_BENCH]),
    ("bench", &[ANY_BUT_BENCH]),
];

/// In [`MAY_IMPORT`]: every module but `bench` (which nothing imports).
const ANY_BUT_BENCH: &str = "*";

/// The only files of `mesh` that touch the Vulkan layer: the mesher's GPU
/// visibility oracle and the builder that runs it.
const MESH_FILES_USING_GPU: &[&str] = &[
    "mesh/build.rs",
    "mesh/display.rs",
    "mesh/discontinuity/visibility.rs",
];

const MAX_CODE_LINES: usize = 700;

struct Source {
    /// Path under `src/`, with `/`.
    rel: String,
    /// The module path, e.g. `formfactor::raytrace` (`mod.rs` is its folder).
    module: Vec<String>,
    /// Text before the first `#[cfg(test)]`; empty for test-only files.
    code: String,
}

fn sources() -> Vec<Source> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("src");
    let mut out = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("src is readable") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(source(&root, &path));
            }
        }
    }
    out.sort_by(|a, b| a.rel.cmp(&b.rel));
    out
}

fn source(root: &Path, path: &Path) -> Source {
    let rel = path
        .strip_prefix(root)
        .expect("under src")
        .to_string_lossy()
        .replace('\\', "/");
    let mut module: Vec<String> = rel
        .trim_end_matches(".rs")
        .split('/')
        .map(String::from)
        .collect();
    if module.last().is_some_and(|m| m == "mod") {
        module.pop();
    }
    let text = std::fs::read_to_string(path).expect("readable source");
    let test_only = module.last().is_some_and(|m| m == "tests");
    let code = if test_only {
        String::new()
    } else {
        match text.find("#[cfg(test)]") {
            Some(i) => text[..i].to_string(),
            None => text,
        }
    };
    Source { rel, module, code }
}

/// Lines that are not comments.
fn code_lines(code: &str) -> impl Iterator<Item = &str> {
    code.lines().filter(|l| !l.trim_start().starts_with("//"))
}

/// Every `crate::a::b` path named in the code, as its first two segments
/// (`super::x` resolved against the file's own module).
fn references(s: &Source) -> BTreeSet<Vec<String>> {
    let mut out = BTreeSet::new();
    for line in code_lines(&s.code) {
        let mut rest = line;
        while let Some(i) = rest.find("crate::") {
            let after = &rest[i + "crate::".len()..];
            let path: Vec<String> = after
                .split("::")
                .take(2)
                .map(|seg| {
                    seg.chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect()
                })
                .take_while(|seg: &String| !seg.is_empty())
                .collect();
            if !path.is_empty() {
                out.insert(path);
            }
            rest = after;
        }
    }
    out
}

fn is_library(s: &Source) -> bool {
    !matches!(s.module[0].as_str(), "main" | "cli" | "lib")
}

#[test]
fn modules_import_only_what_the_architecture_allows() {
    let allowed: BTreeMap<&str, &[&str]> = MAY_IMPORT.iter().copied().collect();
    let mut violations = Vec::new();
    for s in sources().iter().filter(|s| is_library(s)) {
        let top = s.module[0].as_str();
        let Some(may) = allowed.get(top) else {
            violations.push(format!("{}: module {top} is not in the table", s.rel));
            continue;
        };
        for path in references(s) {
            let target = path[0].as_str();
            // `crate::Error` / `crate::Result` are the error module's re-exports.
            let target = if matches!(target, "Error" | "Result") {
                "error"
            } else {
                target
            };
            if target == top {
                continue;
            }
            let permitted =
                may.contains(&target) || (may.contains(&ANY_BUT_BENCH) && target != "bench");
            if !permitted {
                violations.push(format!("{}: {top} imports {target}", s.rel));
            }
            if top == "mesh" && target == "gpu" && !MESH_FILES_USING_GPU.contains(&s.rel.as_str()) {
                violations.push(format!(
                    "{}: only {MESH_FILES_USING_GPU:?} of mesh may use gpu",
                    s.rel
                ));
            }
        }
    }
    assert!(
        violations.is_empty(),
        "layout violations:\n{}",
        violations.join("\n")
    );
}

#[test]
fn no_import_cycle_between_modules() {
    // Nodes are modules two levels deep (`formfactor::raytrace`), or top
    // level where a module has no children. `super::x` is resolved too.
    let sources = sources();
    let known: BTreeSet<Vec<String>> = sources
        .iter()
        .map(|s| s.module.iter().take(2).cloned().collect())
        .collect();
    let node = |path: &[String]| -> Vec<String> {
        let two: Vec<String> = path.iter().take(2).cloned().collect();
        if known.contains(&two) {
            two
        } else {
            path[..1].to_vec()
        }
    };
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for s in sources.iter().filter(|s| is_library(s)) {
        let from = node(&s.module);
        let mut targets: Vec<Vec<String>> = references(s).into_iter().collect();
        if s.module.len() >= 2 {
            for line in code_lines(&s.code) {
                if let Some(i) = line.find("use super::") {
                    let seg: String = line[i + "use super::".len()..]
                        .chars()
                        .take_while(|c| c.is_alphanumeric() || *c == '_')
                        .collect();
                    // From a file in folder a/b/, super:: is a/b's parent.
                    let mut parent = s.module.clone();
                    let is_folder_module = s.rel.ends_with("mod.rs");
                    if !is_folder_module {
                        parent.pop();
                    }
                    parent.pop();
                    if !seg.is_empty() && !parent.is_empty() {
                        parent.push(seg);
                        targets.push(parent);
                    }
                }
            }
        }
        for t in targets {
            let to = node(&t);
            if to != from && !from.starts_with(&to) && !to.starts_with(&from) {
                edges.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    // Depth-first search for a back edge.
    fn visit(
        n: &Vec<String>,
        edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>,
        state: &mut BTreeMap<Vec<String>, u8>,
        stack: &mut Vec<Vec<String>>,
    ) -> Option<Vec<Vec<String>>> {
        state.insert(n.clone(), 1);
        stack.push(n.clone());
        for m in edges.get(n).into_iter().flatten() {
            match state.get(m) {
                Some(1) => {
                    let i = stack.iter().position(|x| x == m).unwrap_or(0);
                    let mut cycle = stack[i..].to_vec();
                    cycle.push(m.clone());
                    return Some(cycle);
                }
                Some(_) => {}
                None => {
                    if let Some(c) = visit(m, edges, state, stack) {
                        return Some(c);
                    }
                }
            }
        }
        stack.pop();
        state.insert(n.clone(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in edges.keys() {
        if !state.contains_key(n) {
            if let Some(cycle) = visit(n, &edges, &mut state, &mut Vec::new()) {
                let names: Vec<String> = cycle.iter().map(|m| m.join("::")).collect();
                panic!("import cycle: {}", names.join(" -> "));
            }
        }
    }
}

#[test]
fn unsafe_only_in_the_vulkan_layer() {
    let offenders: Vec<String> = sources()
        .iter()
        .filter(|s| s.module[0] != "gpu")
        .filter(|s| code_lines(&s.code).any(|l| l.contains("unsafe ") || l.contains("unsafe{")))
        .map(|s| s.rel.clone())
        .collect();
    assert!(
        offenders.is_empty(),
        "unsafe outside src/gpu: {offenders:?}"
    );
}

#[test]
fn no_source_file_is_too_long() {
    let long: Vec<String> = sources()
        .iter()
        .map(|s| (s.rel.clone(), s.code.lines().count()))
        .filter(|(_, n)| *n > MAX_CODE_LINES)
        .map(|(rel, n)| format!("{rel}: {n} lines of non-test code"))
        .collect();
    assert!(long.is_empty(), "over {MAX_CODE_LINES} lines: {long:?}");
}
