//! The checks every HTML report of the toolkit passes (issue 54, item 5), in one place: the
//! report tests of `zmp-report`, of `xtask` (the loop's pages) and of the SILO2 twin include
//! this file (`#[path = ".../validation/report/tests/support/html.rs"] mod html;`).
//!
//! [`check_page`] parses a report with `scraper` and fails, listing every problem, when
//! - a cell, paragraph, heading or any other text shows markup as text (`<br>` escaped into
//!   `&lt;br&gt;` shows as a literal `<br>`; a double escape shows `&lt;`);
//! - a relative `<img src>`, `<object data>`, `<a href>` (and `link`, `source`, `embed`,
//!   `iframe`) names a file that is not beside the report, or a `#fragment` no element has;
//! - a referenced figure is not a non-empty SVG (well-formed XML, root `<svg>`, something
//!   drawn) or PNG (signature, `IHDR` with a size, chunks up to `IEND`);
//! - an inline `<svg>` is not such an SVG;
//! - a heading (h1-h4) has no content (text, table, figure, list) before the next heading of
//!   the same or a higher level;
//! - a table has no data cell with text.
#![allow(dead_code)] // each test crate uses its part

use scraper::{ElementRef, Html, Node, Selector};
use std::path::{Path, PathBuf};

/// A report that passed [`check_page`]: its file, its source and its parsed document.
pub struct Page {
    pub path: PathBuf,
    pub source: String,
    pub doc: Html,
}

/// Reads and checks the report at `path`; panics naming every problem.
pub fn check_page(path: &Path) -> Page {
    let source = std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("reading the report {}: {e}", path.display()));
    let dir = path.parent().unwrap_or(Path::new("."));
    let found = problems(&source, dir);
    assert!(
        found.is_empty(),
        "{} has {} problem(s):\n  {}",
        path.display(),
        found.len(),
        found.join("\n  ")
    );
    Page {
        path: path.to_path_buf(),
        doc: Html::parse_document(&source),
        source,
    }
}

/// Every problem of the HTML `source` whose relative references resolve in `dir`.
pub fn problems(source: &str, dir: &Path) -> Vec<String> {
    let doc = Html::parse_document(source);
    let mut out = Vec::new();
    escaped_markup(&doc, &mut out);
    references(&doc, dir, &mut out);
    inline_svgs(source, &mut out);
    headings(&doc, &mut out);
    tables(&doc, &mut out);
    out
}

fn sel(s: &str) -> Selector {
    Selector::parse(s).unwrap_or_else(|e| panic!("selector {s}: {e:?}"))
}

fn heading_level(name: &str) -> Option<usize> {
    match name {
        "h1" => Some(1),
        "h2" => Some(2),
        "h3" => Some(3),
        "h4" => Some(4),
        "h5" => Some(5),
        "h6" => Some(6),
        _ => None,
    }
}

/// Whether any of `nodes` (a node's ancestors) is an element named in `names`.
fn any_named<'a>(mut nodes: impl Iterator<Item = &'a Node>, names: &[&str]) -> bool {
    nodes.any(|n| n.as_element().is_some_and(|e| names.contains(&e.name())))
}

/// A tag written as text: `<` (or `</`), letters, then `>`, `/>` or attributes up to `>`.
fn tag_in_text(t: &str) -> Option<&str> {
    let b = t.as_bytes();
    for (i, _) in t.match_indices('<') {
        let mut j = i + 1;
        if b.get(j) == Some(&b'/') {
            j += 1;
        }
        let name = j;
        while b.get(j).is_some_and(u8::is_ascii_alphabetic) {
            j += 1;
        }
        if j == name {
            continue;
        }
        let end = t[j..].find(['>', '<']).map(|k| j + k);
        if let Some(e) = end.filter(|&e| b[e] == b'>') {
            if matches!(b[j], b'>' | b' ' | b'/') {
                return Some(&t[i..=e]);
            }
        }
    }
    None
}

fn escaped_markup(doc: &Html, out: &mut Vec<String>) {
    for node in doc.tree.root().descendants() {
        let Some(text) = node.value().as_text() else {
            continue;
        };
        if any_named(node.ancestors().map(|a| a.value()), &["style", "script"]) {
            continue;
        }
        let holder = node
            .parent()
            .and_then(|p| p.value().as_element().map(|e| e.name().to_string()))
            .unwrap_or_default();
        let t: &str = text;
        let short = || t.trim().chars().take(80).collect::<String>();
        if let Some(tag) = tag_in_text(t) {
            out.push(format!(
                "markup shown as text in <{holder}>: {tag:?} in {:?}",
                short()
            ));
        }
        for ent in ["&lt;", "&gt;", "&amp;"] {
            if t.contains(ent) {
                out.push(format!(
                    "escaped twice in <{holder}>: {ent:?} in {:?}",
                    short()
                ));
            }
        }
    }
}

/// `href` without scheme, query or fragment, `%XX` decoded; `None` for an external URL.
fn local_part(r: &str) -> Option<String> {
    let lower = r.to_ascii_lowercase();
    if lower.contains("://")
        || ["data:", "mailto:", "javascript:", "tel:"]
            .iter()
            .any(|s| lower.starts_with(s))
    {
        return None;
    }
    let path = r.split(['#', '?']).next().unwrap_or("");
    let mut bytes = Vec::new();
    let b = path.as_bytes();
    let mut i = 0;
    while i < b.len() {
        let hex = b
            .get(i + 1..i + 3)
            .and_then(|h| std::str::from_utf8(h).ok())
            .and_then(|h| u8::from_str_radix(h, 16).ok());
        match (b[i], hex) {
            (b'%', Some(v)) => {
                bytes.push(v);
                i += 3;
            }
            (c, _) => {
                bytes.push(c);
                i += 1;
            }
        }
    }
    Some(String::from_utf8_lossy(&bytes).into_owned())
}

fn references(doc: &Html, dir: &Path, out: &mut Vec<String>) {
    let ids: Vec<&str> = doc
        .tree
        .root()
        .descendants()
        .filter_map(|n| n.value().as_element().and_then(|e| e.id()))
        .collect();
    let attrs = [
        ("img", "src", true),
        ("object", "data", true),
        ("embed", "src", true),
        ("source", "src", true),
        ("iframe", "src", false),
        ("a", "href", false),
        ("link", "href", false),
    ];
    for (tag, attr, figure) in attrs {
        for el in doc.select(&sel(&format!("{tag}[{attr}]"))) {
            let r = el.value().attr(attr).unwrap_or("");
            let what = format!("<{tag} {attr}={r:?}>");
            if let Some(frag) = r.strip_prefix('#') {
                if !ids.contains(&frag) {
                    out.push(format!("{what}: no element has the id {frag:?}"));
                }
                continue;
            }
            let Some(local) = local_part(r) else {
                continue;
            };
            if local.is_empty() {
                out.push(format!("{what}: empty reference"));
                continue;
            }
            if Path::new(&local).is_absolute() {
                out.push(format!(
                    "{what}: an absolute path, not a file beside the report"
                ));
                continue;
            }
            let file = dir.join(&local);
            if !file.exists() {
                out.push(format!("{what}: {} does not exist", file.display()));
                continue;
            }
            let is_image = [".svg", ".png"].iter().any(|x| local.ends_with(x));
            if figure || is_image {
                if let Err(e) = check_figure(&file) {
                    out.push(format!("{what}: {e}"));
                }
            }
        }
    }
}

/// A figure file: a non-empty SVG or PNG that parses.
pub fn check_figure(path: &Path) -> Result<(), String> {
    let bytes = std::fs::read(path).map_err(|e| format!("reading {}: {e}", path.display()))?;
    let name = path.display();
    if bytes.is_empty() {
        return Err(format!("{name} is empty"));
    }
    match path.extension().and_then(|x| x.to_str()) {
        Some("svg") => {
            let text =
                std::str::from_utf8(&bytes).map_err(|e| format!("{name}: not UTF-8: {e}"))?;
            check_svg(text).map_err(|e| format!("{name}: {e}"))
        }
        Some("png") => check_png(&bytes).map_err(|e| format!("{name}: {e}")),
        _ => Err(format!("{name} is neither an SVG nor a PNG")),
    }
}

/// An SVG document: well-formed XML, root `<svg>` with a positive size, something drawn.
pub fn check_svg(text: &str) -> Result<(), String> {
    let doc = roxmltree::Document::parse(text).map_err(|e| format!("not well-formed XML: {e}"))?;
    let root = doc.root_element();
    if root.tag_name().name() != "svg" {
        return Err(format!(
            "root element <{}>, not <svg>",
            root.tag_name().name()
        ));
    }
    for dim in ["width", "height"] {
        if let Some(v) = root.attribute(dim) {
            let n: f64 = v
                .trim_end_matches("px")
                .parse()
                .map_err(|_| format!("{dim} {v:?} is not a length"))?;
            if n <= 0.0 {
                return Err(format!("{dim} {v:?} is not positive"));
            }
        }
    }
    let drawn = root.descendants().any(|n| {
        matches!(
            n.tag_name().name(),
            "path" | "line" | "polyline" | "polygon" | "rect" | "circle" | "ellipse" | "image"
        )
    });
    let texts = root
        .descendants()
        .filter(|n| n.tag_name().name() == "text")
        .count();
    if !drawn || texts == 0 {
        return Err(format!(
            "draws nothing readable ({} shapes, {texts} texts)",
            if drawn { "some" } else { "no" }
        ));
    }
    Ok(())
}

/// A PNG: signature, `IHDR` first with a non-zero size, whole chunks up to `IEND`.
pub fn check_png(b: &[u8]) -> Result<(), String> {
    const SIG: [u8; 8] = [0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
    if b.len() < 8 || b[..8] != SIG {
        return Err("no PNG signature".into());
    }
    let mut at = 8;
    let mut first = true;
    loop {
        let head = b
            .get(at..at + 8)
            .ok_or_else(|| format!("truncated at byte {at} (no IEND)"))?;
        let len = u32::from_be_bytes([head[0], head[1], head[2], head[3]]) as usize;
        let kind = &head[4..8];
        let data = b
            .get(at + 8..at + 8 + len + 4)
            .ok_or_else(|| format!("chunk {:?} truncated", String::from_utf8_lossy(kind)))?;
        if first {
            if kind != b"IHDR" || len < 8 {
                return Err("first chunk is not IHDR".into());
            }
            let w = u32::from_be_bytes([data[0], data[1], data[2], data[3]]);
            let h = u32::from_be_bytes([data[4], data[5], data[6], data[7]]);
            if w == 0 || h == 0 {
                return Err(format!("size {w} x {h}"));
            }
            first = false;
        }
        if kind == b"IEND" {
            return Ok(());
        }
        at += 12 + len;
    }
}

/// Every `<svg>..</svg>` written inline in the HTML source, checked as an SVG document.
fn inline_svgs(source: &str, out: &mut Vec<String>) {
    let mut rest = source;
    let mut k = 0;
    while let Some(start) = rest.find("<svg") {
        k += 1;
        let Some(len) = rest[start..].find("</svg>") else {
            out.push(format!("inline svg {k}: no </svg>"));
            return;
        };
        let end = start + len + "</svg>".len();
        if let Err(e) = check_svg(&rest[start..end]) {
            out.push(format!("inline svg {k}: {e}"));
        }
        rest = &rest[end..];
    }
}

/// What a page holds in document order: a heading (level, text) or some content.
enum Item {
    Heading(usize, String),
    Content,
}

fn headings(doc: &Html, out: &mut Vec<String>) {
    const CONTENT: [&str; 9] = [
        "table", "img", "svg", "object", "figure", "ul", "ol", "pre", "embed",
    ];
    let mut items = Vec::new();
    for node in doc.tree.root().descendants() {
        if any_named(
            node.ancestors().map(|a| a.value()),
            &["head", "style", "script"],
        ) {
            continue;
        }
        match node.value() {
            Node::Element(e) => {
                if let Some(l) = heading_level(e.name()) {
                    let text = ElementRef::wrap(node)
                        .map(|h| h.text().collect::<String>())
                        .unwrap_or_default();
                    items.push(Item::Heading(l, text.trim().to_string()));
                } else if CONTENT.contains(&e.name()) {
                    items.push(Item::Content);
                }
            }
            Node::Text(t) if !t.trim().is_empty() => {
                let headings = ["h1", "h2", "h3", "h4", "h5", "h6"];
                if !any_named(node.ancestors().map(|a| a.value()), &headings) {
                    items.push(Item::Content);
                }
            }
            _ => {}
        }
    }
    for (k, item) in items.iter().enumerate() {
        let Item::Heading(level, text) = item else {
            continue;
        };
        if *level > 4 {
            continue;
        }
        let has_content = items[k + 1..]
            .iter()
            .take_while(|i| !matches!(i, Item::Heading(l, _) if l <= level))
            .any(|i| matches!(i, Item::Content));
        if !has_content {
            out.push(format!(
                "<h{level}> {text:?} has no content before the next heading"
            ));
        }
    }
}

fn tables(doc: &Html, out: &mut Vec<String>) {
    let td = sel("td");
    for (k, t) in doc.select(&sel("table")).enumerate() {
        let filled = t
            .select(&td)
            .any(|c| !c.text().collect::<String>().trim().is_empty());
        if !filled {
            let head: String = t.text().collect::<String>().chars().take(60).collect();
            out.push(format!(
                "table {} has no data cell with text ({head:?})",
                k + 1
            ));
        }
    }
}

impl Page {
    /// The elements of the section under the heading whose text starts with `title`, up to
    /// the next heading of the same or a higher level; panics when there is no such heading.
    pub fn section(&self, title: &str) -> Vec<ElementRef<'_>> {
        let heading = self
            .doc
            .select(&sel("h1, h2, h3, h4"))
            .find(|h| h.text().collect::<String>().trim().starts_with(title))
            .unwrap_or_else(|| panic!("{}: no heading {title:?}", self.path.display()));
        let level = heading_level(heading.value().name()).unwrap_or(1);
        heading
            .next_siblings()
            .filter_map(ElementRef::wrap)
            .take_while(|e| heading_level(e.value().name()).is_none_or(|l| l > level))
            .collect()
    }

    /// The headings' texts (h1-h4), in order.
    pub fn headings(&self) -> Vec<String> {
        self.doc
            .select(&sel("h1, h2, h3, h4"))
            .map(|h| h.text().collect::<String>().trim().to_string())
            .collect()
    }

    /// The elements matching the CSS selector `css`.
    pub fn select(&self, css: &str) -> Vec<ElementRef<'_>> {
        self.doc.select(&sel(css)).collect()
    }
}

/// The elements matching `css` within `section` (themselves included).
pub fn within<'a>(section: &[ElementRef<'a>], css: &str) -> Vec<ElementRef<'a>> {
    let s = sel(css);
    section
        .iter()
        .flat_map(|e| {
            let me = s.matches(e).then_some(*e);
            me.into_iter().chain(e.select(&s))
        })
        .collect()
}

/// The text of `e` and its descendants, whitespace runs as one space.
pub fn text(e: &ElementRef<'_>) -> String {
    e.text()
        .collect::<String>()
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ")
}
