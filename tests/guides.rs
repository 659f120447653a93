//! The guides (docs/*.md) read as guides: short pages, no machine's particulars, every term linked to its
//! definition in docs/concepts.md on first use, every link to a section names a heading that exists.

mod pages;

use std::path::{Path, PathBuf};

use pages::{link_targets, pages, root};

/// The guides: every Markdown page directly under docs/ but the generated configuration reference.
fn guides() -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(root().join("docs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "md") && !p.ends_with("configuration.md"))
        .collect();
    out.sort();
    out
}

fn name_of(page: &Path) -> String {
    page.strip_prefix(root()).unwrap().display().to_string()
}

const MAX_GUIDE_LINES: usize = 250;

#[test]
fn every_guide_fits_on_a_few_screens() {
    let pages = guides();
    let names: Vec<String> = pages.iter().map(|p| name_of(p)).collect();
    for must in ["docs/concepts.md", "docs/quick-start.md", "docs/training.md", "docs/evaluation.md"] {
        assert!(names.iter().any(|n| n == must), "{must} is a guide");
    }
    let long: Vec<String> = pages
        .iter()
        .map(|p| (name_of(p), std::fs::read_to_string(p).unwrap().lines().count()))
        .filter(|(_, n)| *n > MAX_GUIDE_LINES)
        .map(|(p, n)| format!("{p}: {n} lines"))
        .collect();
    assert!(long.is_empty(), "guides over {MAX_GUIDE_LINES} lines (move measurements to docs/results/): {long:?}");
}

fn is_word(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// What a guide must not hold, as (line, found): a CPU model (a machine's particulars belong in docs/results/),
/// a `perf` command line, a commit hash (a token of 7–40 hex digits with both digits and letters).
fn machine_particulars(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let lower = line.to_lowercase();
        for cpu in ["epyc", "xeon", "ryzen", "threadripper"] {
            if lower.contains(cpu) {
                out.push((i + 1, cpu.to_string()));
            }
        }
        let chars: Vec<char> = lower.chars().collect();
        let mut at = 0;
        while at < chars.len() {
            if !is_word(chars[at]) {
                at += 1;
                continue;
            }
            let start = at;
            while at < chars.len() && is_word(chars[at]) {
                at += 1;
            }
            let word: String = chars[start..at].iter().collect();
            let next: String = chars[at..].iter().take(12).collect();
            // "family 26" (an x86 CPU family number).
            if word == "family" && next.starts_with(' ') && next[1..].starts_with(|c: char| c.is_ascii_digit()) {
                out.push((i + 1, format!("family{}", next.split(',').next().unwrap())));
            }
            // `perf record`, `perf stat`: the profiler as a command.
            if word == "perf" && next.starts_with(' ') {
                out.push((i + 1, format!("perf{next}")));
            }
            let hex = word.chars().all(|c| c.is_ascii_hexdigit());
            let digits = word.chars().any(|c| c.is_ascii_digit());
            let letters = word.chars().any(|c| c.is_ascii_alphabetic());
            if hex && digits && letters && (7..=40).contains(&word.len()) {
                out.push((i + 1, word));
            }
        }
    }
    out
}

#[test]
fn no_guide_names_a_cpu_a_profiler_or_a_commit() {
    // The scanner finds each kind, and passes ordinary text.
    let bad = "on a 2 × AMD EPYC (family 26 model 2)\nan Intel Xeon\n(`perf record`, `perf annotate`)\n\
               at commit `b05f552` (git checkout b05f5524fffb3e142cb723e610e510b4a2464317)\n";
    let found: Vec<String> = machine_particulars(bad).into_iter().map(|(_, w)| w).collect();
    for w in
        ["epyc", "family 26 model 2)", "xeon", "perf record`", "b05f552", "b05f5524fffb3e142cb723e610e510b4a2464317"]
    {
        assert!(found.iter().any(|f| f.starts_with(w.trim_end_matches(['`', ')']))), "{w} is caught: {found:?}");
    }
    let good = "performance of 1500 iterations, 12.3 M samples, ckpt_0000025.json, CRC-32, deadbeef, #1f77b4, \
                a family of robots, perfect, 0.0025 s, seed1, e2e";
    assert_eq!(machine_particulars(good), vec![], "ordinary text passes");
    for page in guides() {
        let text = std::fs::read_to_string(&page).unwrap();
        let found = machine_particulars(&text);
        assert!(found.is_empty(), "{}: a machine's particulars belong in docs/results/: {found:?}", name_of(&page));
    }
}

/// A term of docs/concepts.md: its heading and the anchor GitHub gives it.
struct Concept {
    term: String,
    anchor: String,
}

/// GitHub's heading anchor: lower case, spaces to '-', punctuation but '-' and '_' dropped.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

fn concepts() -> Vec<Concept> {
    let text = std::fs::read_to_string(root().join("docs/concepts.md")).unwrap();
    text.lines()
        .filter_map(|l| l.strip_prefix("## "))
        .map(|h| Concept { term: h.trim().to_string(), anchor: anchor(h) })
        .collect()
}

/// A page's prose as characters, each with the target of the link it is part of (if any). Left out: fenced code
/// blocks, headings, HTML comments, code spans, images and link targets themselves. Line breaks become spaces.
fn prose(text: &str) -> Vec<(char, Option<String>)> {
    // Whole lines out first: code blocks and headings.
    let mut kept = String::new();
    let mut fenced = false;
    for line in text.lines() {
        let t = line.trim_start();
        if t.starts_with("```") {
            fenced = !fenced;
        } else if !fenced && !t.starts_with('#') {
            kept.push_str(line);
        }
        kept.push('\n');
    }
    let c: Vec<char> = kept.chars().collect();
    let mut out = Vec::new();
    // Index of the first char after a code span opened at `i` (the same run of backticks closes it).
    let skip_code = |i: usize| -> usize {
        let run = c[i..].iter().take_while(|&&x| x == '`').count();
        let mut j = i + run;
        while j < c.len() {
            if c[j] == '`' {
                let r = c[j..].iter().take_while(|&&x| x == '`').count();
                if r == run {
                    return j + r;
                }
                j += r;
            } else {
                j += 1;
            }
        }
        i + run
    };
    // For '[' at `i`: (end of the link text, the target, index after the link) when a `](target)` follows.
    let link = |i: usize| -> Option<(usize, String, usize)> {
        let (mut j, mut depth) = (i + 1, 1);
        while j < c.len() {
            match c[j] {
                '`' => {
                    j = skip_code(j);
                    continue;
                }
                '[' => depth += 1,
                ']' => {
                    depth -= 1;
                    if depth == 0 {
                        break;
                    }
                }
                '\n' if c.get(j + 1) == Some(&'\n') => return None,
                _ => {}
            }
            j += 1;
        }
        if c.get(j + 1) != Some(&'(') {
            return None;
        }
        let end = c[j + 2..].iter().position(|&x| x == ')' || x == '\n')? + j + 2;
        (c[end] == ')').then(|| (j, c[j + 2..end].iter().collect(), end + 1))
    };
    let mut target: Option<(String, usize)> = None; // the link we are inside, and where its text ends
    let mut i = 0;
    while i < c.len() {
        if let Some((_, end)) = &target {
            if i == *end {
                // Past the link text: skip "](target)".
                let close = c[i..].iter().position(|&x| x == ')').unwrap() + i;
                target = None;
                out.push((' ', None));
                i = close + 1;
                continue;
            }
        }
        let t = target.as_ref().map(|(t, _)| t.clone());
        if c[i..].starts_with(&['<', '!', '-', '-']) {
            let rest: String = c[i..].iter().collect();
            i += rest.find("-->").map_or(rest.chars().count(), |e| rest[..e + 3].chars().count());
            out.push((' ', None));
        } else if c[i] == '`' {
            i = skip_code(i);
            out.push((' ', t));
        } else if c[i] == '!' && c.get(i + 1) == Some(&'[') {
            match link(i + 1) {
                Some((_, _, after)) => i = after,
                None => i += 1,
            }
            out.push((' ', t));
        } else if c[i] == '[' && target.is_none() {
            match link(i) {
                Some((end, tgt, _)) => {
                    target = Some((tgt, end));
                    out.push((' ', None));
                }
                None => out.push(('[', None)),
            }
            i += 1;
        } else {
            out.push((if c[i].is_whitespace() { ' ' } else { c[i] }, t));
            i += 1;
        }
    }
    out
}

/// Where `term` occurs as a whole word (a trailing "s" or "es" allowed): case-blind unless the term has no
/// lower-case letter (O, C, C+A). A space in the term stands for any run of spaces. '+' and '-' join words, so
/// "C" is not found in "C+A" or "C-terrain".
fn occurrences(p: &[(char, Option<String>)], term: &str) -> Vec<usize> {
    let exact = !term.chars().any(|c| c.is_ascii_lowercase());
    let t: Vec<char> = term.chars().collect();
    let word = |c: char| c.is_alphanumeric() || matches!(c, '_' | '+' | '-');
    let same = |a: char, b: char| if exact { a == b } else { a.eq_ignore_ascii_case(&b) };
    let mut out = Vec::new();
    for start in 0..p.len() {
        if start > 0 && word(p[start - 1].0) {
            continue;
        }
        let (mut i, mut k) = (start, 0);
        while k < t.len() && i < p.len() {
            if t[k] == ' ' && p[i].0 == ' ' {
                while i < p.len() && p[i].0 == ' ' {
                    i += 1;
                }
                k += 1;
            } else if same(p[i].0, t[k]) {
                i += 1;
                k += 1;
            } else {
                break;
            }
        }
        if k < t.len() {
            continue;
        }
        let ends = |j: usize| j >= p.len() || !word(p[j].0);
        let plural = |s: &str| s.chars().enumerate().all(|(n, ch)| p.get(i + n).is_some_and(|x| x.0 == ch));
        if ends(i) || (plural("s") && ends(i + 1)) || (plural("es") && ends(i + 2)) {
            out.push(start);
        }
    }
    out
}

/// Every concept a page uses that is not linked to docs/concepts.md on its first use, or that is linked there
/// again later: (term, what is wrong).
fn unlinked_concepts(text: &str, concepts: &[Concept]) -> Vec<(String, String)> {
    let p = prose(text);
    let mut wrong = Vec::new();
    for k in concepts {
        let to = format!("concepts.md#{}", k.anchor);
        let linked = |i: usize| p[i].1.as_deref().is_some_and(|t| t.ends_with(&to));
        if let Some(&first) = occurrences(&p, &k.term).first() {
            if !linked(first) {
                let around: String =
                    p[first.saturating_sub(30)..(first + 40).min(p.len())].iter().map(|x| x.0).collect();
                wrong.push((k.term.clone(), format!("first use not linked to {to}: …{around}…")));
            }
        }
        // Links to the term: one per page (the first use), counted by link, not by character.
        let links =
            p.windows(2).filter(|w| w[1].1.as_deref().is_some_and(|t| t.ends_with(&to)) && w[0].1 != w[1].1).count()
                + usize::from(p.first().is_some_and(|x| x.1.as_deref().is_some_and(|t| t.ends_with(&to))));
        if links > 1 {
            wrong.push((k.term.clone(), format!("linked to {to} {links} times: only its first use is")));
        }
    }
    wrong
}

#[test]
fn the_concepts_page_defines_every_term_once_with_a_guide() {
    let all = concepts();
    let anchors: Vec<&str> = all.iter().map(|k| k.anchor.as_str()).collect();
    for must in [
        "closed-chain",
        "serial-model",
        "o",
        "c",
        "ca",
        "seed",
        "preset",
        "protocol",
        "sim2sim",
        "bars",
        "push-grid",
        "t_fall",
        "tracking-mae",
        "stand-still",
        "command-noise",
        "intervention",
        "adversary",
        "phase-1",
        "phase-2",
        "phase-3",
        "mirrored-minibatches",
        "symmetry-loss",
        "last-layer-decay",
        "policy-file",
        "sidecar",
        "run-folder",
        "checkpoint",
        "segments",
        "robot-spec",
        "linkage-map",
        "kinematic-loop",
        "passive-joint",
        "stand-keyframe",
        "gravity-feed-forward",
        "state-estimator",
        "concurrent-estimator",
        "velocity-free-policy",
        "terrain-curriculum",
        "course",
        "endurance-run",
        "physics-perturbation",
        "physics-score",
    ] {
        assert!(anchors.contains(&must), "docs/concepts.md defines `## …` with anchor #{must}");
    }
    let mut sorted = anchors.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), anchors.len(), "each term is defined once");
    // Each definition is short and links the guide that covers it.
    let text = std::fs::read_to_string(root().join("docs/concepts.md")).unwrap();
    for section in text.split("\n## ").skip(1) {
        let (head, body) = section.split_once('\n').unwrap();
        let body = body.trim();
        assert!(!body.is_empty() && body.lines().count() <= 6, "concepts.md `{head}`: 1–4 sentences");
        let guide = body.match_indices("](").any(|(i, _)| {
            let t = &body[i + 2..];
            let t = &t[..t.find(')').unwrap()];
            t.split('#').next().unwrap().ends_with(".md")
        });
        assert!(guide, "concepts.md `{head}` links the guide that covers it");
    }
    assert_eq!(anchor("C+A"), "ca");
    assert_eq!(anchor("t_fall"), "t_fall");
    assert_eq!(anchor("Gravity feed-forward"), "gravity-feed-forward");
}

#[test]
fn every_guide_links_each_term_on_its_first_use() {
    let all = concepts();
    // The rule itself: first use linked (not in code or a heading, not a link's target), later uses not.
    let page = "# Seed and C\n\n`C` and [C+A](x.md) go. A [seed](concepts.md#seed) is C's, not `seed`.\n\
                ```sh\nC seed\n```\nThe seed, [C+A](concepts.md#ca), [closed\nchain](concepts.md#closed-chain).\n";
    let found = unlinked_concepts(page, &all);
    let terms: Vec<&str> = found.iter().map(|(t, _)| t.as_str()).collect();
    assert_eq!(terms, ["C", "C+A"], "C is unlinked where first used, C+A first used in a link elsewhere: {found:?}");
    let twice = "A [seed](concepts.md#seed) and a [seed](concepts.md#seed).\n";
    assert_eq!(unlinked_concepts(twice, &all).len(), 1, "a second link to a term is one too many");
    // Every link to a term names one that exists, on every page (README and results included).
    let anchors: Vec<&str> = all.iter().map(|k| k.anchor.as_str()).collect();
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for (i, _) in text.match_indices("concepts.md#") {
            let a: String = text[i + 12..].chars().take_while(|&c| c != ')').collect();
            assert!(
                anchors.contains(&a.as_str()),
                "{}: concepts.md#{a} is no term of docs/concepts.md",
                name_of(&page)
            );
        }
    }
    let mut failures = Vec::new();
    for page in guides().into_iter().filter(|p| !p.ends_with("concepts.md")) {
        let text = std::fs::read_to_string(&page).unwrap();
        for (term, what) in unlinked_concepts(&text, &all) {
            failures.push(format!("{}: {term}: {what}", name_of(&page)));
        }
    }
    assert!(
        failures.is_empty(),
        "{} terms not linked as docs/concepts.md asks:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// The anchors GitHub gives a page's headings (outside code blocks; a repeated heading gets `-1`, `-2`, …).
fn heading_anchors(text: &str) -> Vec<String> {
    let mut seen = std::collections::HashMap::<String, usize>::new();
    let mut out = Vec::new();
    let mut fenced = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fenced = !fenced;
        } else if !fenced && line.starts_with('#') {
            let a = anchor(line.trim_start_matches('#'));
            let n = seen.entry(a.clone()).or_insert(0);
            out.push(if *n == 0 { a } else { format!("{a}-{n}") });
            *n += 1;
        }
    }
    out
}

#[test]
fn every_link_to_a_section_names_a_heading_that_exists() {
    assert_eq!(
        heading_anchors("# A b\n```sh\n# not a heading\n```\n## `topa ablate`: O, C and C+A\n## A b\n"),
        ["a-b", "topa-ablate-o-c-and-ca", "a-b-1"]
    );
    let mut n = 0;
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        for target in link_targets(&text) {
            let Some((file, section)) = target.split_once('#') else { continue };
            if !(file.is_empty() || file.ends_with(".md")) {
                continue;
            }
            let target = if file.is_empty() { page.clone() } else { dir.join(file) };
            let Ok(target_text) = std::fs::read_to_string(&target) else { continue }; // the link test reports it
            assert!(
                heading_anchors(&target_text).iter().any(|a| a == section),
                "{}: no heading of {} has the anchor #{section}",
                name_of(&page),
                target.strip_prefix(root()).unwrap_or(&target).display()
            );
            n += 1;
        }
    }
    assert!(n >= 50, "the guides link each other's sections ({n} links found)");
}

/// The intervals quoted in a page's prose, outside the blocks `topa docs` generates: "value [low, high]" as
/// written, e.g. "+1.17 s [+0.50, +1.91]" gives "[+0.50, +1.91]".
fn quoted_intervals(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut generated = false;
    for (n, line) in text.lines().enumerate() {
        if line.starts_with("<!-- generated:") {
            generated = true;
        } else if line.starts_with("<!-- end generated") {
            generated = false;
        }
        if generated {
            continue;
        }
        for (i, _) in line.match_indices('[') {
            let Some(end) = line[i..].find(']') else { continue };
            let inner = &line[i + 1..i + end];
            let Some((a, b)) = inner.split_once(", ") else { continue };
            let number = |s: &str| s.trim_start_matches(['+', '-', '−']).parse::<f64>().is_ok();
            // An interval follows the value it bounds ("+1.17 s [", "96 % ["): a number, maybe a unit.
            let mut before = line[..i].trim_end().rsplit(' ');
            let last = before.next().unwrap_or("");
            let value = if number(last) { Some(last) } else { before.next() };
            let is_unit = !last.is_empty() && last.len() <= 4 && !last.chars().any(|c| c.is_ascii_digit() || c == '`');
            if value.is_some_and(number) && (number(last) || is_unit) && number(a) && number(b) {
                out.push((n + 1, line[i..=i + end].to_string()));
            }
        }
    }
    out
}

#[test]
fn every_interval_the_prose_quotes_is_in_a_generated_report() {
    assert_eq!(
        quoted_intervals(
            "C+A − C: +1.17 s [+0.50, +1.91], 96 % [95, 98], M = [[1, 0], [−1, 1]], default [256, 128]\n\
             <!-- generated: x -->\n2 [1, 2]\n<!-- end generated -->"
        ),
        [(1, "[+0.50, +1.91]".to_string()), (1, "[95, 98]".to_string())]
    );
    // Every report under docs/results/, as generated text.
    let mut reports = String::new();
    let mut stack = vec![root().join("docs/results")];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "md" || x == "json") && !p.ends_with("notes.md") {
                reports.push_str(&std::fs::read_to_string(&p).unwrap());
            }
        }
    }
    let mut pages = guides();
    pages.push(root().join("README.md"));
    let (mut stale, mut n) = (Vec::new(), 0);
    for page in pages {
        for (line, interval) in quoted_intervals(&std::fs::read_to_string(&page).unwrap()) {
            n += 1;
            if !reports.contains(&interval) {
                stale.push(format!("{}:{line}: {interval}", name_of(&page)));
            }
        }
    }
    assert!(n >= 3, "the README's claims quote their intervals ({n} found)");
    assert!(
        stale.is_empty(),
        "intervals quoted in prose that no report under docs/results/ holds (stale?):\n{}",
        stale.join("\n")
    );
}
