//! The layering the design promises, checked on the sources: the learner depends on no robot crate, and no
//! module of any crate imports, directly or through others, a module that imports it back — whatever the path
//! form (`crate::`, `super::`, `self::`, nested `use` groups) and whether parent or child.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The library crates, each a folder at the root; the command line is the root package (`src/`).
const LIBRARIES: [&str; 12] = [
    "topa-control",
    "mujoco-sys",
    "mujoco",
    "trainer",
    "topa-env",
    "topa-train",
    "topa-eval",
    "topa-sysid",
    "topa-tools",
    "topa-robot",
    "topa-sim-robot",
    "topa-view",
];

/// A crate's path dependencies (the workspace's own crates), from its manifest.
fn own_dependencies(manifest_dir: &str) -> BTreeSet<String> {
    let manifest = std::fs::read_to_string(root().join(manifest_dir).join("Cargo.toml")).unwrap();
    let t: toml::Table = toml::from_str(&manifest).unwrap();
    let deps = t.get("dependencies").and_then(|d| d.as_table()).cloned().unwrap_or_default();
    deps.keys().filter(|k| LIBRARIES.contains(&k.as_str()) || k.as_str() == "topa").cloned().collect()
}

/// The layers, lowest first: a crate may depend only on crates before it in this list.
#[test]
fn crates_depend_only_on_the_layers_below_them() {
    for (i, c) in LIBRARIES.iter().enumerate() {
        for d in own_dependencies(c) {
            let at = LIBRARIES.iter().position(|l| *l == d);
            assert!(at.is_some_and(|at| at < i), "{c} depends on {d}, which is not a layer below it");
        }
    }
}

/// The command line is a binary (no library target, checked below), so a library can reach it only through a
/// dependency on its package: none may have one.
#[test]
fn no_library_imports_the_command_line() {
    for c in LIBRARIES {
        assert!(!own_dependencies(c).contains("topa"), "{c} depends on the command-line crate");
    }
}

/// The command line is a binary with no library target and nothing public: flags and dispatch only.
#[test]
fn the_command_line_is_a_binary_with_no_public_items() {
    assert!(!root().join("src/lib.rs").exists(), "src/lib.rs makes the command line a library");
    let manifest: toml::Table = toml::from_str(&std::fs::read_to_string(root().join("Cargo.toml")).unwrap()).unwrap();
    assert!(!manifest.contains_key("lib"), "a [lib] target makes the command line a library");
    let code = all_code(&root().join("src"));
    for line in code.lines() {
        let t = line.trim_start();
        assert!(!t.starts_with("pub ") && !t.contains(" pub "), "a public item in the command line: {line}");
    }
}

/// Every library says what can go wrong in its own error type (thiserror): anyhow, which erases the type, is the
/// binary's alone, and no function answers with a bare `String` for its error.
#[test]
fn libraries_have_typed_errors() {
    for c in LIBRARIES {
        let manifest: toml::Table =
            toml::from_str(&std::fs::read_to_string(root().join(c).join("Cargo.toml")).unwrap()).unwrap();
        let deps = manifest.get("dependencies").and_then(|d| d.as_table()).cloned().unwrap_or_default();
        assert!(!deps.contains_key("anyhow"), "{c} depends on anyhow: give it an error type of its own");
        let code = all_code(&root().join(c).join("src"));
        for line in code.lines() {
            assert!(!string_error(line), "{c}: an error as a bare String: {line}");
        }
    }
}

/// Whether `line` names a `Result<…, String>`: the last type argument of a `Result<` is `String`.
fn string_error(line: &str) -> bool {
    let s: String = line.chars().filter(|ch| !ch.is_whitespace()).collect();
    s.match_indices("Result<").any(|(at, m)| {
        // Only a second argument is an error type: `Result<String>` is an alias's Ok value.
        let (mut depth, mut last_arg) = (0, None);
        for (i, ch) in s[at + m.len()..].char_indices() {
            match ch {
                '<' | '(' | '[' => depth += 1,
                ',' if depth == 0 => last_arg = Some(at + m.len() + i + 1),
                '>' | ')' | ']' if depth == 0 => return last_arg.is_some_and(|a| s[a..at + m.len() + i] == *"String"),
                '>' | ')' | ']' => depth -= 1,
                _ => {}
            }
        }
        false
    })
}

#[test]
fn a_string_error_is_told_from_a_string_value() {
    assert!(string_error("fn f() -> Result<(), String> {"));
    assert!(string_error("fn f() -> std::result::Result<Vec<(u8, String)>, String>;"));
    assert!(!string_error("fn f() -> Result<String> {"));
    assert!(!string_error("fn f(m: Option<HashMap<String, String>>) -> Result<Vec<u8>> {"));
}

/// `unsafe` code and the raw FFI stay in the FFI crates (mujoco-sys, and mujoco, the safe layer over it) and the
/// learner's matrix kernels; the one exception is the binary's reset of SIGPIPE at start-up.
#[test]
fn unsafe_code_and_the_raw_ffi_stay_in_their_crates() {
    let allowed = |p: &Path| {
        let rel = p.strip_prefix(root()).unwrap();
        // This file names what it looks for.
        let this = rel == Path::new("tests/architecture.rs");
        this || rel.starts_with("mujoco-sys") || rel.starts_with("mujoco") || rel.starts_with("trainer/src/nn")
    };
    let mut files = Vec::new();
    let mut stack = vec![root().to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            let name = p.file_name().unwrap().to_string_lossy();
            if p.is_dir() && !name.starts_with('.') && name != "target" && !allowed(&p) {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") && !allowed(&p) {
                files.push(p);
            }
        }
    }
    assert!(files.len() > 50, "too few sources found: {}", files.len());
    for f in files {
        for (i, line) in std::fs::read_to_string(&f).unwrap().lines().enumerate() {
            let code = line.split("//").next().unwrap();
            if f.ends_with("src/main.rs") && code.contains("libc::signal(libc::SIGPIPE, libc::SIG_DFL)") {
                continue;
            }
            let words = code.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).collect::<Vec<_>>();
            assert!(
                !words.contains(&"unsafe") && !code.contains("ffi::") && !words.contains(&"mujoco_sys"),
                "{}:{}: unsafe code or the raw FFI outside the FFI crates and the kernels: {line}",
                f.display(),
                i + 1
            );
        }
    }
}

/// Every `.rs` file's code under a folder, comments and tests left out.
fn all_code(dir: &Path) -> String {
    modules(dir).into_values().collect::<Vec<_>>().join("\n")
}

#[test]
fn the_learner_depends_on_no_robot_crate() {
    let manifest = std::fs::read_to_string(root().join("trainer/Cargo.toml")).unwrap();
    let deps: toml::Table = toml::from_str(&manifest).unwrap();
    let deps = deps["dependencies"].as_table().unwrap();
    for robot_crate in ["topa-env", "mujoco", "mujoco-sys"] {
        assert!(!deps.contains_key(robot_crate), "trainer depends on {robot_crate}");
    }
}

/// Every `.rs` file under `src` as its module path (`eval/mod.rs` → `eval`, `eval/push.rs` → `eval::push`,
/// `lib.rs` → `""`) and its code with tests and comments left out.
fn modules(src: &Path) -> BTreeMap<String, String> {
    let mut out = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
                continue;
            }
            if p.extension().is_none_or(|x| x != "rs") {
                continue;
            }
            let rel = p.strip_prefix(src).unwrap().with_extension("");
            let mut parts: Vec<String> = rel.iter().map(|s| s.to_string_lossy().into_owned()).collect();
            if rel == Path::new("main") {
                continue; // the binary: another crate, which uses this one from outside
            }
            if parts.last().is_some_and(|l| l == "mod" || l == "lib") {
                parts.pop();
            }
            let text = std::fs::read_to_string(&p).unwrap();
            out.insert(parts.join("::"), without_tests_and_comments(&text));
        }
    }
    out
}

/// The code with comments and `#[cfg(test)]` items (a `mod tests { … }` to the end of the file, or a single
/// `mod tests;` line) left out, and `super::` inside an inline `mod x { … }` read as the file's own module.
fn without_tests_and_comments(text: &str) -> String {
    let mut kept = Vec::new();
    let mut inline_depth = 0i64;
    let mut lines = text.lines();
    while let Some(line) = lines.next() {
        if line.trim() == "#[cfg(test)]" {
            match lines.next() {
                Some(item) if item.contains("mod ") && item.trim_end().ends_with('{') => break,
                _ => continue,
            }
        }
        let code = line.split("//").next().unwrap();
        // Inside an inline `mod x { … }`, `super` is this file's module.
        if inline_depth > 0 {
            kept.push(code.replace("super::", "self::"));
            inline_depth += code.matches('{').count() as i64 - code.matches('}').count() as i64;
            continue;
        }
        if code.trim_start().starts_with("mod ") && code.trim_end().ends_with('{') {
            inline_depth = 1;
        }
        kept.push(code.to_string());
    }
    kept.join("\n")
}

/// Expands one `use` tree (`super::{a, b::{c, d}}`) into its paths.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else { return vec![tree.to_string()] };
    let prefix = tree[..open].trim_end_matches("::");
    let inner = &tree[open + 1..tree.rfind('}').unwrap()];
    let (mut items, mut depth, mut start) = (Vec::new(), 0, 0);
    for (i, ch) in inner.char_indices() {
        match ch {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                items.push(&inner[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    items.push(&inner[start..]);
    items
        .into_iter()
        .filter(|s| !s.trim().is_empty())
        .flat_map(expand)
        .map(|s| if s == "self" { prefix.to_string() } else { format!("{prefix}::{s}") })
        .collect()
}

/// The paths a module's code names: its `use` trees expanded, and every inline `crate::`/`super::`/`self::` path.
fn paths(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    for stmt in code.split(';') {
        let s = stmt.trim_start();
        let s = s.strip_prefix("pub(crate) ").or_else(|| s.strip_prefix("pub ")).unwrap_or(s);
        if let Some(tree) = s.strip_prefix("use ") {
            out.extend(expand(tree).into_iter().map(|p| p.split(" as ").next().unwrap().trim().to_string()));
        }
    }
    // Inline paths (`super::report::label(…)`, `child::f(…)`): every `name::…` that does not continue another.
    let bytes = code.as_bytes();
    for (i, _) in code.match_indices("::") {
        let start = code[..i].rfind(|c: char| !(c.is_ascii_alphanumeric() || c == '_')).map_or(0, |j| j + 1);
        if start == i || (start > 0 && bytes[start - 1] == b':') {
            continue;
        }
        let p: String =
            code[start..].chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_' || *c == ':').collect();
        out.push(p.trim_end_matches(':').to_string());
    }
    out
}

/// The module a path in module `m` leads to: the longest known module prefix of its absolute form.
fn resolve(path: &str, m: &str, known: &BTreeSet<String>) -> Option<String> {
    let mut segs: Vec<&str> = path.split("::").collect();
    let mut base: Vec<&str> = if m.is_empty() { vec![] } else { m.split("::").collect() };
    match segs.first().copied() {
        Some("crate") => base.clear(),
        Some("self") => {}
        Some("super") => {
            while segs.get(1) == Some(&"super") {
                base.pop();
                segs.remove(0);
            }
            base.pop();
        }
        // A 2018-edition relative path into a child module of `m` (else an external crate or a local name).
        Some(first) if known.contains(&join(m, first)) => segs.insert(0, "self"),
        _ => return None,
    }
    segs.remove(0);
    let full: Vec<&str> = base.into_iter().chain(segs).filter(|s| !s.is_empty()).collect();
    (0..=full.len()).rev().map(|n| full[..n].join("::")).find(|c| known.contains(c))
}

fn join(m: &str, name: &str) -> String {
    if m.is_empty() {
        name.to_string()
    } else {
        format!("{m}::{name}")
    }
}

/// Module → the modules it imports (itself left out).
fn graph(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mods = modules(src);
    let known: BTreeSet<String> = mods.keys().cloned().collect();
    let mut g: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (m, code) in &mods {
        let entry = g.entry(m.clone()).or_default();
        for p in paths(code) {
            if let Some(t) = resolve(&p, m, &known) {
                if &t != m {
                    entry.insert(t);
                }
            }
        }
    }
    g
}

/// A cycle through `from`, if any, as the list of modules along it.
fn cycle_through(g: &BTreeMap<String, BTreeSet<String>>, from: &str) -> Option<Vec<String>> {
    let mut prev: BTreeMap<String, String> = BTreeMap::new();
    let mut todo = vec![from.to_string()];
    while let Some(m) = todo.pop() {
        for n in g.get(&m).into_iter().flatten() {
            if n == from {
                let mut path = vec![m.clone()];
                while let Some(p) = prev.get(path.last().unwrap()) {
                    path.push(p.clone());
                }
                path.reverse();
                return Some(path);
            }
            if n != from && !prev.contains_key(n) {
                prev.insert(n.clone(), m.clone());
                todo.push(n.clone());
            }
        }
    }
    None
}

fn cycles(src: &Path) -> Vec<Vec<String>> {
    let g = graph(src);
    g.keys().filter(|m| !m.is_empty()).filter_map(|m| cycle_through(&g, m)).collect()
}

#[test]
fn no_crate_has_an_import_cycle_between_its_modules() {
    for src in LIBRARIES.iter().map(|c| format!("{c}/src")).chain(["src".to_string()]) {
        let src = src.as_str();
        let g = graph(&root().join(src));
        assert!(g.len() >= 3, "{src}: too few modules found ({g:?})");
        let found = cycles(&root().join(src));
        assert!(found.is_empty(), "{src}: import cycles (each a chain of modules that leads back): {found:?}");
    }
}

#[test]
fn a_planted_cycle_is_found_in_every_path_form() {
    let dir = std::env::temp_dir().join(format!("topa-arch-{}", std::process::id()));
    let write = |rel: &str, text: &str| {
        let p = dir.join(rel);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, text).unwrap();
    };
    write("lib.rs", "pub mod a;\npub mod b;\n");
    write("a/mod.rs", "pub mod x;\npub mod y;\npub struct A;\n");
    write("a/x.rs", "use super::y::Y;\npub struct X;\n");
    write("b.rs", "pub struct B;\n");
    // No cycle yet: a::x → a::y only.
    write("a/y.rs", "pub struct Y;\n");
    assert!(cycles(&dir).is_empty(), "{:?}", cycles(&dir));
    // A child importing its parent's item while the parent uses the child.
    write("a/mod.rs", "pub mod x;\npub mod y;\npub use self::x::X;\npub struct A;\n");
    write("a/y.rs", "use super::A;\npub struct Y;\n");
    assert!(!cycles(&dir).is_empty());
    // A parent using its child by a relative path, the child using the parent's item.
    write("a/mod.rs", "pub mod x;\npub mod y;\npub struct A;\nfn f() { x::g(); }\n");
    write("a/x.rs", "use super::A;\npub fn g() {}\n");
    write("a/y.rs", "pub struct Y;\n");
    assert!(!cycles(&dir).is_empty());
    write("a/x.rs", "use super::y::Y;\npub struct X;\n");
    // Through a nested use group and a crate path.
    write("a/mod.rs", "pub mod x;\npub mod y;\npub struct A;\n");
    write("a/y.rs", "use crate::{b::{self, B}};\npub struct Y;\n");
    write("b.rs", "pub struct B;\nfn f() { let _ = crate::a::x::X; }\n");
    let found = cycles(&dir);
    assert!(found.iter().any(|c| c.contains(&"b".to_string()) && c.contains(&"a::x".to_string())), "{found:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn use_groups_expand_to_their_paths() {
    assert_eq!(expand("super::{self, a::{b, c as d}, e}"), ["super", "super::a::b", "super::a::c as d", "super::e"]);
}
