//! ARCHITECTURE.md's invariants that can be checked by reading the source:
//! the code map names every module and only paths that exist; no module
//! outside `src/space/` (and the compiler's settings and the command line)
//! names a concrete space or a kind of segment; the stages' modules import
//! each other without a cycle.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Every `.rs` file under `src/`, relative to the repository's root.
fn source_files() -> Vec<String> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }
    let mut files = Vec::new();
    walk(&root().join("src"), &mut files);
    let mut names: Vec<String> = files
        .iter()
        .map(|p| {
            p.strip_prefix(root())
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/")
        })
        .collect();
    names.sort();
    assert!(names.len() > 20, "found only {names:?}");
    names
}

/// A file's code, without comments and without its `#[cfg(test)]` module
/// (tests may reach anywhere).
fn code_of(file: &str) -> String {
    let text = std::fs::read_to_string(root().join(file)).unwrap();
    let mut out = String::new();
    for line in text.lines() {
        if line.trim_start().starts_with("#[cfg(test)]") {
            break;
        }
        let code = match line.find("//") {
            // Not inside a string literal: good enough for this code base,
            // whose strings hold no `//` before a space name.
            Some(i) if !line[..i].contains('"') => &line[..i],
            _ => line,
        };
        out.push_str(code);
        out.push('\n');
    }
    out
}

/// The paths ARCHITECTURE.md's code map names, one table row's first cell
/// each (several paths in a cell are separated by commas).
fn code_map_paths() -> Vec<String> {
    let doc = std::fs::read_to_string(root().join("ARCHITECTURE.md")).unwrap();
    let map = doc
        .split("## Code map")
        .nth(1)
        .expect("ARCHITECTURE.md has a code map")
        .split("\n## ")
        .next()
        .unwrap();
    let mut paths = Vec::new();
    for line in map.lines().filter(|l| l.starts_with("| `")) {
        let cell = line.split('|').nth(1).unwrap();
        for part in cell.split(',') {
            let path = part.trim().trim_matches('`');
            if !path.is_empty() {
                paths.push(path.to_string());
            }
        }
    }
    assert!(paths.len() > 20, "the code map names only {paths:?}");
    paths
}

#[test]
fn the_code_map_names_every_module_and_only_paths_that_exist() {
    let named = code_map_paths();
    for path in &named {
        assert!(
            root().join(path).exists(),
            "ARCHITECTURE.md's code map names `{path}`, which does not exist"
        );
    }
    for file in source_files() {
        let covered = named
            .iter()
            .any(|p| *p == file || (p.ends_with('/') && file.starts_with(p.as_str())));
        assert!(covered, "ARCHITECTURE.md's code map omits `{file}`");
    }
}

/// Names that only the space module, the compiler's settings (which read
/// a space block) and the command line (`--space`) may use.
const CONCRETE_SPACE_NAMES: [&str; 10] = [
    "SpaceKind::Sphere",
    "SpaceKind::Torus",
    "SpaceKind::Euclidean",
    "SphereSpace",
    "TorusSpace",
    "PathMode",
    "DenseStep",
    "Segment::Line",
    "Segment::Arc",
    "Segment::Dense",
];

#[test]
fn no_module_outside_the_space_names_a_concrete_space() {
    let allowed = |f: &str| {
        f.starts_with("src/space/") || f == "src/compile/settings.rs" || f.starts_with("src/cli/")
    };
    let mut offences = Vec::new();
    for file in source_files().into_iter().filter(|f| !allowed(f)) {
        let code = code_of(&file);
        for name in CONCRETE_SPACE_NAMES {
            if code.contains(name) {
                offences.push(format!("{file} names {name}"));
            }
        }
    }
    assert!(offences.is_empty(), "{offences:#?}");
}

/// The top-level module a file belongs to (`src/trace/intersect.rs` is in
/// `trace`); `None` for the crate root and the binary.
fn module_of(file: &str) -> Option<String> {
    let rest = file.strip_prefix("src/")?;
    let first = rest.split('/').next()?;
    let name = first.strip_suffix(".rs").unwrap_or(first);
    (!matches!(name, "lib" | "main")).then(|| name.to_string())
}

/// The modules each module's code refers to through `crate::`.
fn module_graph() -> BTreeMap<String, BTreeSet<String>> {
    let files = source_files();
    let modules: BTreeSet<String> = files.iter().filter_map(|f| module_of(f)).collect();
    // What the crate root re-exports, by the module that defines it.
    let reexports = [
        ("compile_source", "compile"),
        ("compile_source_at", "compile"),
        ("SceneError", "diagnostic"),
        ("Scene", "scene"),
        ("Image", "render"),
        ("RenderStats", "render"),
    ];
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for file in &files {
        let Some(module) = module_of(file) else {
            continue;
        };
        let code = code_of(file);
        let uses = graph.entry(module.clone()).or_default();
        for (i, _) in code.match_indices("crate::") {
            let rest = &code[i + "crate::".len()..];
            // `crate::{a, b::c}` names several.
            let names: Vec<&str> = if let Some(group) = rest.strip_prefix('{') {
                let end = group.find('}').unwrap_or(group.len());
                group[..end]
                    .split(',')
                    .map(|n| n.trim().split("::").next().unwrap_or(""))
                    .collect()
            } else {
                let end = rest
                    .find(|c: char| !(c.is_alphanumeric() || c == '_'))
                    .unwrap_or(rest.len());
                vec![&rest[..end]]
            };
            for name in names {
                let target = if modules.contains(name) {
                    Some(name.to_string())
                } else {
                    reexports
                        .iter()
                        .find(|(n, _)| *n == name)
                        .map(|(_, m)| m.to_string())
                };
                if let Some(target) = target.filter(|t| *t != module) {
                    uses.insert(target);
                }
            }
        }
    }
    graph
}

#[test]
fn the_modules_import_each_other_without_a_cycle() {
    let graph = module_graph();
    // The stages in pipeline order must at least see these edges, or the
    // reading of the source is broken.
    for (from, to) in [("render", "shade"), ("shade", "trace"), ("trace", "space")] {
        assert!(
            graph.get(from).is_some_and(|u| u.contains(to)),
            "{from} should use {to}: {graph:#?}"
        );
    }
    // Depth-first search for a back edge.
    fn visit<'g>(
        node: &'g str,
        graph: &'g BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<&'g str, bool>,
        path: &mut Vec<&'g str>,
    ) {
        match state.get(node) {
            Some(true) => return,
            Some(false) => {
                let start = path.iter().position(|n| *n == node).unwrap();
                panic!("import cycle: {} -> {node}", path[start..].join(" -> "));
            }
            None => {}
        }
        state.insert(node, false);
        path.push(node);
        for next in graph.get(node).into_iter().flatten() {
            visit(next, graph, state, path);
        }
        path.pop();
        state.insert(node, true);
    }
    let mut state = BTreeMap::new();
    for node in graph.keys() {
        visit(node, &graph, &mut state, &mut Vec::new());
    }
}

/// The pipeline's stages sit below the tools, live mode and the command
/// line: no stage refers to any of them.
#[test]
fn no_stage_depends_on_a_tool_live_mode_or_the_command_line() {
    let graph = module_graph();
    let beside = ["tools", "live", "cli"];
    for (module, uses) in &graph {
        if beside.contains(&module.as_str()) {
            continue;
        }
        for b in beside {
            assert!(!uses.contains(b), "the stage `{module}` uses `{b}`");
        }
    }
}
