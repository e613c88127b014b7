//! The top-level modules of `models/src` (and of the root crate's `src/`) import each other one way
//! only: the graph of `crate::<module>` references between them has no cycle.
//!
//! How the graph is read: every `.rs` file under the source folder belongs to its top-level module
//! (`camera/lens.rs` → `camera`, `world.rs` → `world`; `lib.rs` and `main.rs`, which only declare
//! and re-export, are left out). Each `crate::<name>` path in it, and each first-level name of a
//! `crate::{a::…, b, …}` use tree, is an edge to `<name>` (to itself ignored). Comments (`//`, `///`,
//! `//!`, `/* */`) are skipped; everything else counts, `#[cfg(test)]` modules included, so a unit
//! test cannot reach up the layers either (the layering is documented in `models/src/lib.rs`).
//! Paths through `super::` stay inside a module and are not edges.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Module → the modules it names, with one file per edge (for the failure message).
type Graph = BTreeMap<String, BTreeMap<String, String>>;

/// The source without comments (string literals are kept; a `//` inside one ends the line's scan,
/// which at worst drops a reference, never invents one).
fn strip_comments(src: &str) -> String {
    let mut out = String::with_capacity(src.len());
    let b = src.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
        } else if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
            let mut depth = 0;
            while i < b.len() {
                if b[i] == b'/' && b.get(i + 1) == Some(&b'*') {
                    depth += 1;
                    i += 2;
                } else if b[i] == b'*' && b.get(i + 1) == Some(&b'/') {
                    depth -= 1;
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    i += 1;
                }
            }
            out.push(' ');
        } else {
            let ch = src[i..].chars().next().expect("a char boundary");
            out.push(ch);
            i += ch.len_utf8();
        }
    }
    out
}

fn is_ident(c: u8) -> bool {
    c.is_ascii_alphanumeric() || c == b'_'
}

/// The top-level module names a source refers to through `crate::`.
fn referenced_modules(src: &str) -> BTreeSet<String> {
    let src = strip_comments(src);
    let b = src.as_bytes();
    let mut out = BTreeSet::new();
    let mut from = 0;
    while let Some(pos) = src[from..].find("crate::") {
        let at = from + pos;
        from = at + "crate::".len();
        if at > 0 && is_ident(b[at - 1]) {
            continue; // `my_crate::`, not `crate::`
        }
        let mut i = from;
        if b.get(i) == Some(&b'{') {
            // A use tree: the first name of each top-level item.
            let mut depth = 0usize;
            let mut expect_name = false;
            while i < b.len() {
                match b[i] {
                    b'{' => {
                        depth += 1;
                        expect_name = depth == 1;
                        i += 1;
                    }
                    b'}' => {
                        depth -= 1;
                        i += 1;
                        if depth == 0 {
                            break;
                        }
                    }
                    b',' if depth == 1 => {
                        expect_name = true;
                        i += 1;
                    }
                    c if expect_name && (c.is_ascii_alphabetic() || c == b'_') => {
                        let start = i;
                        while i < b.len() && is_ident(b[i]) {
                            i += 1;
                        }
                        out.insert(src[start..i].to_owned());
                        expect_name = false;
                    }
                    _ => i += 1,
                }
            }
        } else {
            let start = i;
            while i < b.len() && is_ident(b[i]) {
                i += 1;
            }
            if i > start {
                out.insert(src[start..i].to_owned());
            }
        }
    }
    out.remove("self");
    out.remove("super");
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("a directory entry").path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|e| e == "rs") {
            out.push(p);
        }
    }
}

/// The top-level module graph of a crate's source folder.
fn crate_graph(src_dir: &Path) -> Graph {
    let mut files = Vec::new();
    rust_files(src_dir, &mut files);
    assert!(
        !files.is_empty(),
        "no Rust files under {}",
        src_dir.display()
    );
    let mut graph = Graph::new();
    for path in files {
        let rel = path.strip_prefix(src_dir).expect("under the source folder");
        let first = rel
            .components()
            .next()
            .expect("a path component")
            .as_os_str()
            .to_string_lossy()
            .into_owned();
        let module = first.strip_suffix(".rs").unwrap_or(&first).to_owned();
        if module == "lib" || module == "main" {
            continue;
        }
        let src = std::fs::read_to_string(&path).expect("a UTF-8 source file");
        let edges = graph.entry(module.clone()).or_default();
        for to in referenced_modules(&src) {
            if to != module {
                edges.entry(to).or_insert_with(|| rel.display().to_string());
            }
        }
    }
    graph
}

/// A cycle of the graph (its modules in order, the first repeated at the end), if there is one.
fn find_cycle(graph: &Graph) -> Option<Vec<String>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        Open,
        Done,
    }
    fn visit<'g>(
        graph: &'g Graph,
        node: &'g str,
        marks: &mut BTreeMap<&'g str, Mark>,
        stack: &mut Vec<&'g str>,
    ) -> Option<Vec<String>> {
        match marks.get(node) {
            Some(Mark::Done) => return None,
            Some(Mark::Open) => {
                let start = stack.iter().position(|n| *n == node).expect("on the stack");
                let mut cycle: Vec<String> = stack[start..].iter().map(|s| s.to_string()).collect();
                cycle.push(node.to_owned());
                return Some(cycle);
            }
            None => {}
        }
        marks.insert(node, Mark::Open);
        stack.push(node);
        if let Some(edges) = graph.get(node) {
            for to in edges.keys() {
                if let Some(c) = visit(graph, to, marks, stack) {
                    return Some(c);
                }
            }
        }
        stack.pop();
        marks.insert(node, Mark::Done);
        None
    }
    let mut marks = BTreeMap::new();
    for node in graph.keys() {
        let mut stack = Vec::new();
        if let Some(c) = visit(graph, node, &mut marks, &mut stack) {
            return Some(c);
        }
    }
    None
}

/// The failure message for a cycle: each edge with a file that makes it.
fn describe(graph: &Graph, cycle: &[String]) -> String {
    let mut s = format!("module cycle: {}", cycle.join(" → "));
    for w in cycle.windows(2) {
        let file = &graph[&w[0]][&w[1]];
        s.push_str(&format!(
            "\n  {} → {}: crate::{} in {file}",
            w[0], w[1], w[1]
        ));
    }
    s
}

fn assert_acyclic(src_dir: &Path) {
    let graph = crate_graph(src_dir);
    if let Some(cycle) = find_cycle(&graph) {
        panic!("{}: {}", src_dir.display(), describe(&graph, &cycle));
    }
}

#[test]
fn models_modules_form_no_cycle() {
    assert_acyclic(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
}

#[test]
fn root_crate_modules_form_no_cycle() {
    // The workspace's root crate (`osiris`: cli, bench, export, package, master).
    let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("../src");
    assert!(
        src.join("lib.rs").is_file(),
        "{} is the root crate",
        src.display()
    );
    assert_acyclic(&src);
}

#[test]
fn the_models_layers_hold() {
    // The layering the restructuring set up (see `models/src/lib.rs`): the effect mechanism, the
    // frames, the model trait, the handshake, the output headers and the physical-sensor skeleton
    // name no model; recognition does not reach into the camera; only the registry names every
    // sensor.
    let graph = crate_graph(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    let imports = |m: &str| -> BTreeSet<&str> {
        graph
            .get(m)
            .map(|e| e.keys().map(String::as_str).collect())
            .unwrap_or_default()
    };
    for (module, forbidden) in [
        (
            "effects",
            &[
                "camera",
                "lidar",
                "radar",
                "environment",
                "space",
                "registry",
            ][..],
        ),
        (
            "frames",
            &["sensor", "camera", "lidar", "radar", "registry"][..],
        ),
        (
            "sensor",
            &["camera", "lidar", "radar", "ideal", "registry"][..],
        ),
        (
            "world",
            &["ideal", "camera", "lidar", "radar", "registry"][..],
        ),
        ("recognition", &["camera", "lidar", "radar", "registry"][..]),
        // The shared loop and what it fills name no sensor: a sensor plugs in by `Physics`.
        (
            "physical",
            &["camera", "lidar", "radar", "ideal", "registry"][..],
        ),
        (
            "output",
            &["camera", "lidar", "radar", "ideal", "physical", "registry"][..],
        ),
        (
            "handshake",
            &["world", "camera", "lidar", "radar", "ideal", "registry"][..],
        ),
    ] {
        let bad: Vec<&str> = imports(module)
            .into_iter()
            .filter(|m| forbidden.contains(m))
            .collect();
        assert!(bad.is_empty(), "`{module}` imports {bad:?}");
    }
    for (module, edges) in &graph {
        if module != "registry" {
            assert!(
                !edges.contains_key("registry"),
                "`{module}` imports the registry"
            );
        }
    }
}

#[test]
fn self_check_finds_a_fabricated_cycle() {
    let edge = |a: &str, b: &str| (a.to_owned(), b.to_owned());
    let mut graph = Graph::new();
    for (from, to) in [
        edge("a", "b"),
        edge("b", "c"),
        edge("c", "a"),
        edge("c", "d"),
        edge("e", "a"),
    ] {
        graph.entry(from).or_default().insert(to, "f.rs".to_owned());
    }
    let cycle = find_cycle(&graph).expect("a → b → c → a is found");
    assert_eq!(cycle.first(), cycle.last());
    let members: BTreeSet<&str> = cycle.iter().map(String::as_str).collect();
    assert_eq!(members, BTreeSet::from(["a", "b", "c"]));
    let msg = describe(&graph, &cycle);
    assert!(msg.starts_with("module cycle: a → b → c → a"), "{msg}");
    // Without the closing edge the graph is a DAG.
    graph.get_mut("c").expect("c").remove("a");
    assert_eq!(find_cycle(&graph), None);
}

#[test]
fn self_check_reads_references() {
    let src = r#"
        //! [`crate::registry`] in a doc comment is not an edge.
        use crate::{frames::{Pose, SensorFrame}, sensor::*, self};
        use crate::error::ModelError;
        /* crate::camera in a block comment */
        fn f() -> osiris_crate::X { crate::world::g(); $crate::space::h() }
    "#;
    let got = referenced_modules(src);
    let want: BTreeSet<String> = ["error", "frames", "sensor", "space", "world"]
        .map(str::to_owned)
        .into();
    assert_eq!(got, want);
}

#[test]
fn self_check_reads_a_fabricated_crate() {
    let dir = std::env::temp_dir().join(format!("osiris-module-graph-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(dir.join("alpha")).expect("a temporary folder");
    std::fs::write(dir.join("lib.rs"), "pub mod alpha; pub mod beta;").expect("written");
    std::fs::write(dir.join("alpha/mod.rs"), "mod inner;").expect("written");
    std::fs::write(dir.join("alpha/inner.rs"), "use crate::beta::B;").expect("written");
    std::fs::write(dir.join("beta.rs"), "pub struct B(crate::alpha::A);").expect("written");
    let graph = crate_graph(&dir);
    let cycle = find_cycle(&graph).expect("alpha ↔ beta");
    let msg = describe(&graph, &cycle);
    assert!(
        msg.contains("alpha → beta: crate::beta in alpha/inner.rs"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
