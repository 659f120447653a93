//! An MJCF document as an XML tree (xmltree): read, searched, edited and written back with its attribute order,
//! so that a derived file reads like its source.

use std::path::Path;

use xmltree::{Element, EmitterConfig, XMLNode};

use crate::error::{Error, Result};

pub(crate) fn parse(path: &Path) -> Result<Element> {
    let text = std::fs::read_to_string(path).map_err(Error::read(path))?;
    Element::parse(lenient_comments(&text).as_bytes()).map_err(|e| Error::malformed(path, "well-formed XML", e))
}

/// MuJoCo's parser accepts `--` inside a comment (command lines in model comments have it); XML does not. Inside
/// comments it becomes `- -`.
fn lenient_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("<!--") {
        let body = &rest[start + 4..];
        let Some(end) = body.find("-->") else { break };
        out.push_str(&rest[..start + 4]);
        out.push_str(&body[..end].replace("--", "- -"));
        out.push_str("-->");
        rest = &body[end + 3..];
    }
    out.push_str(rest);
    out
}

/// The document as text.
pub(crate) fn write(root: &Element) -> String {
    let mut out = Vec::new();
    root.write_with_config(&mut out, EmitterConfig::new().perform_indent(true).write_document_declaration(false))
        .expect("writing XML into memory cannot fail");
    String::from_utf8(out).expect("xmltree writes UTF-8")
}

/// Every element below `e` (depth first, `e` itself excluded), mutably, to `f`.
pub(crate) fn for_each_mut(e: &mut Element, f: &mut dyn FnMut(&mut Element)) {
    for c in e.children.iter_mut() {
        if let XMLNode::Element(child) = c {
            f(child);
            for_each_mut(child, f);
        }
    }
}

/// Every element below `e` named `tag`.
pub(crate) fn all<'a>(e: &'a Element, tag: &str, out: &mut Vec<&'a Element>) {
    for c in &e.children {
        if let XMLNode::Element(child) = c {
            if child.name == tag {
                out.push(child);
            }
            all(child, tag, out);
        }
    }
}

/// Removes every element below `e` for which `drop` holds; returns how many went.
pub(crate) fn remove_where(e: &mut Element, drop: &dyn Fn(&Element) -> bool) -> usize {
    let before = e.children.len();
    e.children.retain(|c| c.as_element().is_none_or(|x| !drop(x)));
    let mut n = before - e.children.len();
    for c in e.children.iter_mut() {
        if let XMLNode::Element(child) = c {
            n += remove_where(child, drop);
        }
    }
    n
}

/// The first element below `e` for which `pick` holds, mutably.
pub(crate) fn find_mut<'a>(e: &'a mut Element, pick: &dyn Fn(&Element) -> bool) -> Option<&'a mut Element> {
    for c in e.children.iter_mut() {
        if let XMLNode::Element(child) = c {
            if pick(child) {
                return Some(child);
            }
            if let Some(found) = find_mut(child, pick) {
                return Some(found);
            }
        }
    }
    None
}

/// The root's child section `tag` (`<actuator>`, `<sensor>`, …), made at the end if the document has none.
pub(crate) fn section<'a>(root: &'a mut Element, tag: &str) -> &'a mut Element {
    let at = root.children.iter().position(|c| c.as_element().is_some_and(|e| e.name == tag));
    let at = at.unwrap_or_else(|| {
        root.children.push(XMLNode::Element(Element::new(tag)));
        root.children.len() - 1
    });
    root.children[at].as_mut_element().expect("an element was found or made here")
}

/// A new element with attributes in the given order.
pub(crate) fn element(tag: &str, attributes: &[(&str, String)]) -> Element {
    let mut e = Element::new(tag);
    for (k, v) in attributes {
        e.attributes.insert((*k).to_string(), v.clone());
    }
    e
}

/// Numbers as MJCF text: each the shortest form that reads back as the same double.
pub(crate) fn numbers(v: &[f64]) -> String {
    v.iter().map(|x| format!("{x}")).collect::<Vec<_>>().join(" ")
}
