//! The layering the design promises, checked on the sources: the learner depends on no robot crate, and no
//! crate's top-level modules import each other in a cycle.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn the_learner_depends_on_no_robot_crate() {
    let manifest = std::fs::read_to_string(root().join("trainer/Cargo.toml")).unwrap();
    let deps: toml::Table = toml::from_str(&manifest).unwrap();
    let deps = deps["dependencies"].as_table().unwrap();
    for robot_crate in ["topa-env", "mujoco-sys"] {
        assert!(!deps.contains_key(robot_crate), "trainer depends on {robot_crate}");
    }
}

/// `crate::x` references of each top-level module of a crate's `src/` (tests left out).
fn module_imports(src: &Path) -> BTreeMap<String, BTreeSet<String>> {
    let mut deps: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
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
            let rel = p.strip_prefix(src).unwrap();
            let module = rel.iter().next().unwrap().to_string_lossy().trim_end_matches(".rs").to_string();
            if module == "lib" || module == "main" {
                continue;
            }
            let text = std::fs::read_to_string(&p).unwrap();
            let code = text.split("#[cfg(test)]").next().unwrap();
            for part in code.split("crate::").skip(1) {
                let name: String = part.chars().take_while(|c| c.is_ascii_alphanumeric() || *c == '_').collect();
                if !name.is_empty() && name != module {
                    deps.entry(module.clone()).or_default().insert(name);
                }
            }
        }
    }
    deps
}

fn reaches(deps: &BTreeMap<String, BTreeSet<String>>, from: &str, to: &str) -> bool {
    let mut seen = BTreeSet::new();
    let mut todo = vec![from.to_string()];
    while let Some(m) = todo.pop() {
        for n in deps.get(&m).into_iter().flatten() {
            if n == to {
                return true;
            }
            if seen.insert(n.clone()) {
                todo.push(n.clone());
            }
        }
    }
    false
}

#[test]
fn no_crate_has_an_import_cycle_between_its_modules() {
    for src in ["src", "topa-env/src", "trainer/src", "mujoco-sys/src"] {
        let deps = module_imports(&root().join(src));
        assert!(deps.len() > 3, "{src}: too few modules found ({deps:?})");
        for (m, uses) in &deps {
            for u in uses {
                assert!(!reaches(&deps, u, m), "{src}: {m} imports {u}, which leads back to {m}");
            }
        }
    }
}
