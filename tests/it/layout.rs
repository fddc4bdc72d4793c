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

/// Every `crate::a::b` path named in the code, as its first two segments.
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

/// Every path a file names through `use` (trees expanded) or inline as
/// `crate::...`, `super::...` or `self::...`, resolved to an absolute
/// module path (without `crate`). `module` is the file's own module: for
/// `a/b/c.rs` it is `a::b::c`, for `a/b/mod.rs` it is `a::b`, so `super`
/// is always one step up from it.
fn resolved_paths(module: &[String], code: &str, children: &BTreeSet<String>) -> Vec<Vec<String>> {
    let mut raw: Vec<Vec<String>> = Vec::new();
    let code: String = code_lines(code).collect::<Vec<_>>().join("\n");
    // `use` statements, trees expanded; what is left is searched for
    // inline paths.
    let mut rest = code.as_str();
    let mut inline = String::new();
    while let Some(i) = find_use(rest) {
        let after = &rest[i..];
        let end = after.find(';').unwrap_or(after.len());
        expand_use_tree(after[..end].trim(), &mut Vec::new(), &mut raw);
        inline.push_str(&rest[..i]);
        rest = &after[end..];
    }
    inline.push_str(rest);
    for root in ["crate::", "super::", "self::"] {
        let mut rest = inline.as_str();
        while let Some(i) = rest.find(root) {
            let boundary = rest[..i]
                .chars()
                .last()
                .is_none_or(|c| !(c.is_alphanumeric() || c == '_' || c == ':'));
            let after = &rest[i..];
            if boundary {
                raw.push(path_at(after));
            }
            rest = &after[root.len()..];
        }
    }
    raw.into_iter()
        .filter_map(|p| resolve(module, &p, children))
        .collect()
}

/// The path `a::b::c` at the start of `text`, up to the first character
/// that is not part of it.
fn path_at(text: &str) -> Vec<String> {
    let mut path = Vec::new();
    let mut rest = text;
    loop {
        let ident: String = rest
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        if ident.is_empty() {
            break;
        }
        rest = &rest[ident.len()..];
        path.push(ident);
        match rest.strip_prefix("::") {
            Some(r) => rest = r,
            None => break,
        }
    }
    path
}

/// Where the next `use ` statement starts (at a line start, after `pub`
/// or `pub(...)`), as the offset of its path.
fn find_use(text: &str) -> Option<usize> {
    let mut offset = 0;
    for line in text.split_inclusive('\n') {
        let trimmed = line.trim_start();
        let lead = line.len() - trimmed.len();
        let body = trimmed
            .strip_prefix("pub(crate) ")
            .or_else(|| trimmed.strip_prefix("pub(super) "))
            .or_else(|| trimmed.strip_prefix("pub "))
            .unwrap_or(trimmed);
        if let Some(path) = body.strip_prefix("use ") {
            return Some(offset + lead + (trimmed.len() - path.len()));
        }
        offset += line.len();
    }
    None
}

/// `a::b::{c, d::{e, f as g}, self}` into `a::b::c`, `a::b::d::e`, ...
fn expand_use_tree(tree: &str, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let tree = tree.trim();
    if let Some(open) = tree.find('{') {
        let head: Vec<String> = tree[..open]
            .split("::")
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect();
        let close = tree.rfind('}').unwrap_or(tree.len());
        let inner = &tree[open + 1..close];
        let depth = prefix.len();
        prefix.extend(head);
        // Split the inner list at top-level commas.
        let (mut level, mut start) = (0, 0);
        for (i, c) in inner.char_indices() {
            match c {
                '{' => level += 1,
                '}' => level -= 1,
                ',' if level == 0 => {
                    expand_use_tree(&inner[start..i], prefix, out);
                    start = i + 1;
                }
                _ => {}
            }
        }
        expand_use_tree(&inner[start..], prefix, out);
        prefix.truncate(depth);
    } else if !tree.is_empty() {
        let name = tree.split(" as ").next().unwrap_or(tree).trim();
        let mut path = prefix.clone();
        path.extend(
            name.split("::")
                .map(|s| s.trim().to_string())
                .filter(|s| !s.is_empty() && s != "self" && s != "*"),
        );
        out.push(path);
    }
}

/// `path` as named in `module`, made absolute; `None` for paths outside
/// the crate (std, other crates).
fn resolve(module: &[String], path: &[String], children: &BTreeSet<String>) -> Option<Vec<String>> {
    let (first, rest) = path.split_first()?;
    let mut base: Vec<String> = match first.as_str() {
        "crate" => Vec::new(),
        "self" => module.to_vec(),
        "super" => {
            let mut up = module.to_vec();
            let mut rest = rest;
            up.pop()?;
            while rest.first().is_some_and(|s| s == "super") {
                up.pop()?;
                rest = &rest[1..];
            }
            up.extend(rest.iter().cloned());
            return Some(up);
        }
        // A child module named without `self::` (uniform paths).
        name if children.contains(name) => {
            let mut p = module.to_vec();
            p.push(name.to_string());
            p.extend(rest.iter().cloned());
            return Some(p);
        }
        _ => return None,
    };
    base.extend(rest.iter().cloned());
    Some(base)
}

/// The import graph between files: each file's module points at the
/// modules it names (the longest known module prefix of each path).
/// A module naming its own ancestors or descendants is left out: a parent
/// declares and re-exports its children, and they use its items.
fn import_graph(sources: &[Source]) -> BTreeMap<Vec<String>, BTreeSet<Vec<String>>> {
    let known: BTreeSet<Vec<String>> = sources.iter().map(|s| s.module.clone()).collect();
    let owner = |path: &[String]| -> Option<Vec<String>> {
        (1..=path.len())
            .rev()
            .map(|n| path[..n].to_vec())
            .find(|p| known.contains(p))
    };
    let mut edges: BTreeMap<Vec<String>, BTreeSet<Vec<String>>> = BTreeMap::new();
    for s in sources.iter().filter(|s| is_library(s)) {
        let children: BTreeSet<String> = known
            .iter()
            .filter(|m| m.len() == s.module.len() + 1 && m.starts_with(&s.module))
            .map(|m| m[m.len() - 1].clone())
            .collect();
        for path in resolved_paths(&s.module, &s.code, &children) {
            let Some(to) = owner(&path) else { continue };
            if !to.starts_with(&s.module) && !s.module.starts_with(&to) {
                edges.entry(s.module.clone()).or_default().insert(to);
            }
        }
    }
    edges
}

/// The first import cycle found, as the modules around it.
fn find_cycle(edges: &BTreeMap<Vec<String>, BTreeSet<Vec<String>>>) -> Option<Vec<String>> {
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
            if let Some(cycle) = visit(n, edges, &mut state, &mut Vec::new()) {
                return Some(cycle.iter().map(|m| m.join("::")).collect());
            }
        }
    }
    None
}

#[test]
fn no_import_cycle_between_modules() {
    if let Some(cycle) = find_cycle(&import_graph(&sources())) {
        panic!("import cycle: {}", cycle.join(" -> "));
    }
}

/// Sources made up for the checker's own tests.
fn planted(files: &[(&str, &str)]) -> Vec<Source> {
    files
        .iter()
        .map(|(rel, code)| {
            let mut module: Vec<String> = rel
                .trim_end_matches(".rs")
                .split('/')
                .map(String::from)
                .collect();
            if module.last().is_some_and(|m| m == "mod") {
                module.pop();
            }
            Source {
                rel: rel.to_string(),
                module,
                code: code.to_string(),
            }
        })
        .collect()
}

#[test]
fn the_cycle_check_finds_a_planted_cycle() {
    // The shape of the cycles this check missed: files of one folder
    // naming each other through `super::` from non-`mod.rs` files, and
    // through grouped `use` trees.
    let files = planted(&[
        ("gather/mod.rs", "mod clusters;\nmod point_gather;\n"),
        (
            "gather/clusters.rs",
            "use super::point_gather::{Gather, Linking};\n",
        ),
        (
            "gather/point_gather.rs",
            "use super::{clusters::Clusters, Other};\n",
        ),
    ]);
    let cycle = find_cycle(&import_graph(&files)).expect("the planted cycle is found");
    assert!(
        cycle.contains(&"gather::clusters".to_string())
            && cycle.contains(&"gather::point_gather".to_string()),
        "{cycle:?}"
    );
    // Without the back edge there is none, and the parent's own use of
    // its children is no cycle.
    let files = planted(&[
        (
            "gather/mod.rs",
            "mod clusters;\nuse self::clusters::Clusters;\n",
        ),
        ("gather/clusters.rs", "use super::Settings;\n"),
        ("gather/point_gather.rs", "use super::clusters::Clusters;\n"),
    ]);
    assert_eq!(find_cycle(&import_graph(&files)), None);
    // Across top-level modules too, through `crate::` paths.
    let files = planted(&[
        ("gpu/context.rs", "use crate::gpu::memory::Allocator;\n"),
        (
            "gpu/memory.rs",
            "fn f(d: &crate::gpu::context::Device) {}\n",
        ),
    ]);
    assert!(find_cycle(&import_graph(&files)).is_some());
}

#[test]
fn super_resolves_from_the_file_s_own_module() {
    let module: Vec<String> = ["a", "b", "c"].iter().map(|s| s.to_string()).collect();
    let none = BTreeSet::new();
    let got = resolved_paths(&module, "use super::d::X;\nuse super::super::e;\n", &none);
    let want: Vec<Vec<String>> = vec![
        vec!["a".into(), "b".into(), "d".into(), "X".into()],
        vec!["a".into(), "e".into()],
    ];
    assert_eq!(got, want);
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
