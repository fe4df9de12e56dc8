//! The report checks of `support/html.rs` catch what they are for: a page with each defect
//! (the diagnosis report's escaped `<br>`, a missing or broken figure, a heading without
//! content, an empty table) is named, and a sound page passes.

#[path = "support/html.rs"]
mod html;

use std::path::Path;

const FIGURE: &str = "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"100\" height=\"50\">\
    <rect x=\"0\" y=\"0\" width=\"10\" height=\"10\"/><text x=\"1\" y=\"20\">G11</text></svg>";

/// A sound page around `body`, in `dir` with its figure `fig.svg`.
fn page(dir: &Path, body: &str) -> Vec<String> {
    std::fs::write(dir.join("fig.svg"), FIGURE).unwrap();
    let src = format!(
        "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>t &amp; u</title>\
         <style>td{{color:red}}</style></head><body><h1>Report</h1><p>Intro.</p>\
         <h2>Figures</h2><img src=\"fig.svg\" alt=\"f\"><div>{FIGURE}</div>\
         <h2>Table</h2><table><tr><th>a</th></tr><tr><td>1 &lt; 2</td></tr></table>\
         <p id=\"end\"><a href=\"#end\">here</a>, <a href=\"https://example.org/x.svg\">out</a>\
         </p>{body}</body></html>"
    );
    html::problems(&src, dir)
}

fn one(dir: &Path, body: &str, what: &str) {
    let p = page(dir, body);
    assert!(
        p.len() == 1 && p[0].contains(what),
        "{body}: expected one problem with {what:?}, got {p:?}"
    );
}

#[test]
fn a_sound_page_passes() {
    let d = tempfile::tempdir().unwrap();
    assert_eq!(page(d.path(), ""), Vec::<String>::new());
}

#[test]
fn markup_shown_as_text_is_named() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    // What the diagnosis report printed: each parameter joined by an escaped <br>.
    one(
        d,
        "<h2>F</h2><table><tr><td>a = 1&lt;br&gt;b = 2</td></tr></table>",
        "\"<br>\"",
    );
    one(d, "<p>x &lt;/td&gt; y</p>", "\"</td>\"");
    one(d, "<p>a &amp;lt; b</p>", "\"&lt;\"");
    one(d, "<ul><li>&lt;b class=\"x\"&gt;bold</li></ul>", "<b class");
}

#[test]
fn missing_and_broken_figures_are_named() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    one(d, "<p><img src=\"nope.svg\"></p>", "does not exist");
    one(
        d,
        "<p><a href=\"sub/report.html\">r</a></p>",
        "does not exist",
    );
    one(
        d,
        "<p><a href=\"#nowhere\">r</a></p>",
        "no element has the id",
    );
    one(d, "<p><img src=\"/abs/fig.svg\"></p>", "absolute path");
    std::fs::write(d.join("empty.svg"), "").unwrap();
    one(d, "<p><object data=\"empty.svg\"></object></p>", "is empty");
    std::fs::write(d.join("cut.svg"), "<svg><rect/>").unwrap();
    one(d, "<p><img src=\"cut.svg\"></p>", "not well-formed");
    std::fs::write(
        d.join("blank.svg"),
        "<svg width=\"10\" height=\"10\"></svg>",
    )
    .unwrap();
    one(d, "<p><img src=\"blank.svg\"></p>", "draws nothing");
    std::fs::write(d.join("html.svg"), "<html><text>x</text><rect/></html>").unwrap();
    one(d, "<p><img src=\"html.svg\"></p>", "not <svg>");
    std::fs::write(d.join("f.png"), b"\x89PNG\r\n\x1a\n\0\0\0\x0dIHDR").unwrap();
    one(d, "<p><img src=\"f.png\"></p>", "truncated");
    one(d, "<div><svg><rect/></svg></div>", "inline svg 2");
}

#[test]
fn a_png_that_parses_passes() {
    let d = tempfile::tempdir().unwrap();
    let chunk = |kind: &[u8], data: &[u8]| {
        let mut c = (data.len() as u32).to_be_bytes().to_vec();
        c.extend_from_slice(kind);
        c.extend_from_slice(data);
        c.extend_from_slice(&[0; 4]); // the CRC, not checked
        c
    };
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend(chunk(b"IHDR", &[0, 0, 0, 2, 0, 0, 0, 3, 8, 2, 0, 0, 0]));
    png.extend(chunk(b"IDAT", &[1, 2, 3]));
    png.extend(chunk(b"IEND", &[]));
    std::fs::write(d.path().join("f.png"), &png).unwrap();
    assert!(page(d.path(), "<p><img src=\"f.png\"></p>").is_empty());
    png[16..20].copy_from_slice(&[0; 4]);
    std::fs::write(d.path().join("f.png"), &png).unwrap();
    one(d.path(), "<p><img src=\"f.png\"></p>", "size 0 x 3");
}

#[test]
fn headings_without_content_and_empty_tables_are_named() {
    let d = tempfile::tempdir().unwrap();
    let d = d.path();
    // The diagnosis report's "Before and after" had a sentence; a bare heading is the
    // general case.
    one(
        d,
        "<h2>Before and after</h2><h2>Next</h2><p>x</p>",
        "\"Before and after\"",
    );
    one(d, "<h2>Last</h2>", "\"Last\"");
    let p = page(d, "<h3>Sub</h3><h4>Subsub</h4><h3>Other</h3><p>y</p>");
    assert!(
        p.len() == 2 && p[0].contains("\"Sub\"") && p[1].contains("\"Subsub\""),
        "{p:?}"
    );
    // A section whose content is in its subsections has content.
    assert!(page(d, "<h2>A</h2><h3>B</h3><p>x</p>").is_empty());
    one(
        d,
        "<h2>T</h2><table><tr><th>a</th></tr></table>",
        "no data cell",
    );
    one(
        d,
        "<h2>T</h2><table><tr><td> </td></tr></table>",
        "no data cell",
    );
}
