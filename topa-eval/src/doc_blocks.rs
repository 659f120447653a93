//! Generated blocks of Markdown pages: the text between `<!-- generated: REPORT SECTION -->` and
//! `<!-- end generated -->` is a section of a report written by `topa ablate` (REPORT: its ablation.json, relative to
//! the page's folder; SECTION: one of [`crate::ablate::section`]'s). `topa docs` rewrites such blocks from
//! their reports, so that a page's numbers come from the report and nowhere else; `--check` only compares.

use std::ops::Range;
use std::path::{Path, PathBuf};

use crate::ablate::{self, Ablation};
use crate::error::{bad_file, invalid, Error, Result};

const OPEN: &str = "<!-- generated: ";
const CLOSE: &str = "<!-- end generated -->";

/// One generated block: the report and section it shows, and where its body lies in the page.
#[derive(Debug, Clone, PartialEq)]
pub struct Block {
    pub report: String,
    pub section: String,
    /// Byte range of the body (between the opening marker's line and the closing marker).
    pub body: Range<usize>,
    /// 1-based line of the opening marker, for messages.
    pub line: usize,
}

/// The generated blocks of a page, in order; markers start a line. A marker that does not close, names no report or section, or a
/// block opened inside another is an error naming its line.
pub fn blocks(text: &str) -> Result<Vec<Block>> {
    let line_of = |at: usize| text[..at].matches('\n').count() + 1;
    let mut out = Vec::new();
    let mut from = 0;
    while let Some(i) = find_line(text, from, OPEN) {
        let line = line_of(i);
        let head_end = text[i..].find("-->").map(|e| i + e).ok_or_else(|| {
            Error::bad_file(format!(
                "line {line}: the marker `{OPEN}…` has no closing `-->`; write `{OPEN}REPORT SECTION -->`"
            ))
        })?;
        let words: Vec<&str> = text[i + OPEN.len()..head_end].split_whitespace().collect();
        let [report, section] = words[..] else {
            bad_file!("line {line}: a generated block names a report and a section, e.g. `{OPEN}docs/results/current/ablation.json headline -->`")
        };
        let body_start = text[head_end..].find('\n').map_or(text.len(), |n| head_end + n + 1);
        let end = find_line(text, body_start, CLOSE).ok_or_else(|| {
            Error::bad_file(format!("line {line}: the generated block has no `{CLOSE}` line after it"))
        })?;
        if let Some(inner) = find_line(text, body_start, OPEN).filter(|&o| o < end) {
            bad_file!(
                "line {}: a generated block opens inside the one of line {line}; close that one first",
                line_of(inner)
            );
        }
        out.push(Block { report: report.into(), section: section.into(), body: body_start..end, line });
        from = end + CLOSE.len();
    }
    Ok(out)
}

/// The first `marker` at or after `from` that starts a line (one quoted inside a sentence is not a marker).
fn find_line(text: &str, from: usize, marker: &str) -> Option<usize> {
    text[from..].match_indices(marker).map(|(i, _)| from + i).find(|&i| i == 0 || text.as_bytes()[i - 1] == b'\n')
}

/// The page with every generated block's body rendered again from its report (reports resolved from `dir`, the
/// page's folder). Each report is read once.
pub fn render(text: &str, dir: &Path) -> Result<String> {
    render_blocks(text, &blocks(text)?, dir)
}

/// As [`render`], with the page's blocks already found.
fn render_blocks(text: &str, blocks: &[Block], dir: &Path) -> Result<String> {
    let mut reports: Vec<(String, Ablation)> = Vec::new();
    let mut out = String::with_capacity(text.len());
    let mut at = 0;
    for b in blocks {
        if !reports.iter().any(|(r, _)| *r == b.report) {
            reports.push((b.report.clone(), load(&dir.join(&b.report), b.line)?));
        }
        let a = &reports.iter().find(|(r, _)| *r == b.report).expect("loaded above").1;
        let body =
            ablate::section(a, &b.section).map_err(|e| Error::file(format!("line {}: {}", b.line, b.report), e))?;
        out.push_str(&text[at..b.body.start]);
        out.push_str(body.trim());
        out.push('\n');
        at = b.body.end;
    }
    out.push_str(&text[at..]);
    Ok(out)
}

fn load(path: &Path, line: usize) -> Result<Ablation> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::file(format!("line {line}: cannot read the report {}", path.display()), e))?;
    serde_json::from_str(&text).map_err(|e| {
        Error::file(format!("line {line}: {} is not an ablation.json written by `topa ablate`", path.display()), e)
    })
}

/// `topa docs`: rewrites the generated blocks of each page (atomically, only when they changed); with `check`,
/// fails naming every page whose blocks differ from their reports instead.
pub fn run(pages: &[PathBuf], check: bool) -> Result<()> {
    let mut stale = Vec::new();
    for page in pages {
        let text = std::fs::read_to_string(page).map_err(Error::io("cannot read", page))?;
        let dir = page.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let in_page = |e: Error| Error::file(page.display().to_string(), e);
        let found = blocks(&text).map_err(in_page)?;
        let new = render_blocks(&text, &found, dir).map_err(in_page)?;
        let n = found.len();
        if new == text {
            println!("{}: {n} generated block(s), up to date", page.display());
        } else if check {
            stale.push(page.display().to_string());
        } else {
            trainer::tensorfile::write_atomic(page, new.as_bytes())?;
            println!("{}: {n} generated block(s), rewritten from their reports", page.display());
        }
    }
    if !stale.is_empty() {
        invalid!(
            "generated blocks differ from their reports in {}: run `topa docs {}`",
            stale.join(", "),
            stale.join(" ")
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blocks_are_found_with_their_report_section_and_body() {
        let t = "intro\n<!-- generated: a/r.json headline -->\nold\n<!-- end generated -->\nmid\n\
                 <!-- generated: b.json summary -->\n<!-- end generated -->\n";
        let b = blocks(t).unwrap();
        assert_eq!(b.len(), 2);
        assert_eq!((b[0].report.as_str(), b[0].section.as_str(), b[0].line), ("a/r.json", "headline", 2));
        assert_eq!(&t[b[0].body.clone()], "old\n");
        assert_eq!((b[1].report.as_str(), b[1].section.as_str(), b[1].line), ("b.json", "summary", 6));
        assert_eq!(&t[b[1].body.clone()], "");
        // A marker quoted inside a sentence is text, not a block.
        let quoted = "Blocks sit between `<!-- generated: REPORT SECTION -->` and `<!-- end generated -->`.\n";
        assert!(blocks(quoted).unwrap().is_empty());
    }

    #[test]
    fn malformed_markers_name_their_line() {
        let unclosed = "x\n\n<!-- generated: r.json headline -->\ntable\n";
        let e = crate::error::chain(&blocks(unclosed).unwrap_err());
        assert!(e.contains("line 3") && e.contains("end generated"), "{e}");
        let no_section = "<!-- generated: r.json -->\n<!-- end generated -->\n";
        let e = crate::error::chain(&blocks(no_section).unwrap_err());
        assert!(e.contains("line 1") && e.contains("report and a section"), "{e}");
        let nested = "<!-- generated: r.json a -->\n<!-- generated: r.json b -->\n<!-- end generated -->\n";
        let e = crate::error::chain(&blocks(nested).unwrap_err());
        assert!(e.contains("line 2") && e.contains("inside"), "{e}");
    }

    #[test]
    fn a_missing_report_is_an_error_naming_it() {
        let t = "<!-- generated: nowhere/ablation.json headline -->\n<!-- end generated -->\n";
        let e = crate::error::chain(&render(t, Path::new("/nonexistent")).unwrap_err());
        assert!(e.contains("nowhere/ablation.json") && e.contains("line 1"), "{e}");
    }
}
