//! The documentation is checked against the code and the data: every `topa …` command in README.md and docs/
//! parses with the CLI's own parser and names files that exist, every relative link resolves, and the README's
//! result tables are the ones the committed report JSON renders to.

mod pages;

use pages::{link_targets, pages, root};

use clap::Parser;
use topa_eval::ablate::Ablation;

// The command line's clap tree, read from the binary's sources (the binary crate has no library to import).
#[allow(dead_code)]
#[path = "../src/cli/mod.rs"]
mod cli;
use cli::Cli;

/// The `topa` invocations in a page's shell code blocks, as (line number, argv without the program name). A line
/// may run the binary as `topa`, `./target/release/topa` or under `mpirun … ./target/release/topa`.
fn commands(text: &str) -> Vec<(usize, Vec<String>)> {
    let mut out = Vec::new();
    let mut in_shell = false;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim_start();
        if let Some(lang) = t.strip_prefix("```") {
            in_shell = !in_shell && matches!(lang.trim(), "sh" | "bash" | "shell" | "console");
            continue;
        }
        if !in_shell {
            continue;
        }
        // Comments after the command; `#` never appears inside our arguments.
        let code = t.split(" #").next().unwrap().trim();
        let words = shlex::split(code).unwrap_or_else(|| panic!("line {}: unbalanced quotes: {line}", i + 1));
        let Some(at) = words.iter().position(|w| w == "topa" || w.ends_with("/release/topa")) else { continue };
        // Prefixes (`nohup`, `mpirun -np 2`, `VAR=value`) and redirections, pipes or `&` are the shell's, not ours.
        let args: Vec<String> = words[at + 1..]
            .iter()
            .take_while(|w| !matches!(w.as_str(), "&" | "&&" | "|" | ";" | "2>&1") && !w.starts_with('>'))
            .cloned()
            .collect();
        out.push((i + 1, args));
    }
    out
}

/// Arguments that name files we ship (inputs), as opposed to outputs and run folders the command creates.
fn shipped_paths(args: &[String]) -> Vec<&String> {
    const OUTPUTS: [&str; 5] = ["--out", "--record", "--video", "--onnx", "--init-from"];
    let check = args.iter().any(|a| a == "--check");
    let mut out = Vec::new();
    for (i, a) in args.iter().enumerate() {
        let prev = if i > 0 { args[i - 1].as_str() } else { "" };
        let is_output = OUTPUTS.contains(&prev) && !(check && prev == "--onnx");
        let ours = ["assets/", "configs/", "data/", "docs/"].iter().any(|p| a.starts_with(p));
        if ours && !is_output {
            out.push(a);
        }
    }
    out
}

#[test]
fn every_documented_command_parses_and_names_existing_files() {
    let mut n = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let name = page.strip_prefix(root()).unwrap().display().to_string();
        for (line, args) in commands(&text) {
            let argv = std::iter::once("topa".to_string()).chain(args.iter().cloned());
            if let Err(e) = Cli::try_parse_from(argv) {
                panic!("{name}:{line}: `topa {}` does not parse:\n{e}", args.join(" "));
            }
            for p in shipped_paths(&args) {
                assert!(root().join(p).exists(), "{name}:{line}: `{p}` does not exist in the repository");
            }
            n += 1;
        }
    }
    assert!(n >= 20, "the README and the guide show how to use the CLI ({n} commands found)");
}

#[test]
fn the_command_scanner_catches_a_wrong_flag_and_a_missing_file() {
    // The check above is only as good as its scanner: a page with a typo'd flag and a removed policy is caught.
    let page = "```sh\ntopa eval tracking --polcy assets/policies/C/seed1.json\n\
                topa eval push --policy assets/policies/C.json   # a comment\n```\n";
    let found = commands(page);
    assert_eq!(found.len(), 2);
    let argv = |a: &[String]| std::iter::once("topa".to_string()).chain(a.iter().cloned()).collect::<Vec<_>>();
    assert!(Cli::try_parse_from(argv(&found[0].1)).is_err(), "an unknown flag is refused");
    assert!(Cli::try_parse_from(argv(&found[1].1)).is_ok());
    let paths = shipped_paths(&found[1].1);
    assert_eq!(paths, [&"assets/policies/C.json".to_string()]);
    assert!(!root().join(paths[0]).exists(), "the first single-seed policies are gone from the tree");
    // Outputs are not inputs.
    let out = commands("```sh\ntopa export --policy assets/policies/C/seed1.json --onnx docs/x.onnx\n```\n");
    assert_eq!(shipped_paths(&out[0].1), [&"assets/policies/C/seed1.json".to_string()]);
}

#[test]
fn every_relative_link_in_the_docs_resolves() {
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        // Anchors are the section test's (guides.rs).
        for target in link_targets(&text) {
            let target = target.split('#').next().unwrap();
            if !target.is_empty() {
                assert!(dir.join(target).exists(), "{}: link to {target} does not resolve", page.display());
            }
        }
    }
}

#[test]
fn the_readme_tables_are_the_committed_reports() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let blocks = topa_eval::doc_blocks::blocks(&text).unwrap();
    assert!(blocks.iter().any(|b| b.section == "headline"), "the README shows the headline table");
    let rendered = topa_eval::doc_blocks::render(&text, root()).unwrap();
    assert!(rendered == text, "README.md's generated tables differ from their reports: run `topa docs README.md`");
}

#[test]
fn topa_docs_rewrites_a_stale_number_from_the_report() {
    let text = std::fs::read_to_string(root().join("README.md")).unwrap();
    let b = topa_eval::doc_blocks::blocks(&text).unwrap().into_iter().find(|b| b.section == "headline").unwrap();
    // A table edited by hand (a group's t_fall changed) is what the rewriter must put back.
    let body = &text[b.body.clone()];
    let cell = body.find(" [").expect("the headline has intervals");
    let at = b.body.start + cell - 1;
    let digit = if &text[at..at + 1] == "7" { "8" } else { "7" };
    let mut stale = text.clone();
    stale.replace_range(at..at + 1, digit);
    assert_eq!(topa_eval::doc_blocks::render(&stale, root()).unwrap(), text);
    // Rendering the same page twice changes nothing.
    assert_eq!(topa_eval::doc_blocks::render(&text, root()).unwrap(), text);
}

#[test]
fn the_committed_report_is_what_its_json_renders_to() {
    let dir = root().join("docs/results/current");
    let a: Ablation = serde_json::from_str(&std::fs::read_to_string(dir.join("ablation.json")).unwrap()).unwrap();
    assert!(a.extent == topa_eval::ablate::Extent::full(), "the committed report is on the paper's protocol");
    let md = std::fs::read_to_string(dir.join("ablation.md")).unwrap();
    assert_eq!(md, topa_eval::ablate::markdown(&a).unwrap(), "ablation.md is stale: re-run `topa ablate --merge`");
    // Every shipped seed of the three groups is in it, and nothing else.
    let mut shipped: Vec<String> = Vec::new();
    for g in ["O", "C", "CA"] {
        for e in std::fs::read_dir(root().join("assets/policies").join(g)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "json") {
                shipped.push(format!("assets/policies/{g}/{}", p.file_name().unwrap().to_string_lossy()));
            }
        }
    }
    let mut reported: Vec<String> = a.results.iter().map(|r| r.policy.display().to_string()).collect();
    shipped.sort();
    reported.sort();
    assert_eq!(reported, shipped, "the report covers exactly the shipped seeds");
    // Results that record the weights they measured measured the shipped files' (a seed retrained in place
    // without a new ablation fails here).
    for r in a.results.iter().filter(|r| r.weights_crc32.is_some()) {
        let now = trainer::policy_file::Policy::load(&root().join(&r.policy)).unwrap().meta.weights_crc32;
        assert_eq!(r.weights_crc32, Some(now), "{} was retrained after its ablation", r.policy.display());
    }
}
