//! The link check of `cargo xtask ci`: every relative link and image of the repository's
//! Markdown (README.md, the book in docs/, the crates' READMEs, CHANGELOG.md) must point to a
//! file or folder that exists in the clone, and every `#anchor` to a heading of its page.
//! Links to the web (`http:`, `https:`, `mailto:`) are not fetched.
//!
//! Anchors follow the slug rule GitHub and mdBook share: the heading's text lower-cased,
//! characters other than letters, digits, `-`, `_` and spaces dropped, spaces made `-`; a
//! repeated heading gets `-1`, `-2`, ...

use anyhow::{bail, Result};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A broken link: the file, its line, the target as written and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct Broken {
    pub file: PathBuf,
    pub line: usize,
    pub target: String,
    pub why: String,
}

/// The slug of a heading's text.
pub fn slug(heading: &str) -> String {
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

/// The anchors of a Markdown text: its headings' slugs (outside code fences), numbered when
/// repeated, and the ids of `<a id="...">` / `<a name="...">` tags.
pub fn anchors(text: &str) -> Vec<String> {
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = Vec::new();
    let mut fence = false;
    for line in text.lines() {
        if line.trim_start().starts_with("```") {
            fence = !fence;
            continue;
        }
        if fence {
            continue;
        }
        let t = line.trim_start();
        if t.starts_with('#') {
            let title = t.trim_start_matches('#');
            if title.starts_with(' ') {
                let base = slug(title);
                let n = seen.entry(base.clone()).or_insert(0);
                out.push(if *n == 0 {
                    base.clone()
                } else {
                    format!("{base}-{n}")
                });
                *n += 1;
            }
        }
        for key in ["id=\"", "name=\""] {
            let mut rest = line;
            while let Some(k) = rest.find(key) {
                rest = &rest[k + key.len()..];
                if let Some(end) = rest.find('"') {
                    out.push(rest[..end].to_string());
                }
            }
        }
    }
    out
}

/// The relative links of a Markdown text with their line numbers: `[text](target)` and
/// `![alt](target)` outside code fences and inline code, web links left out.
pub fn links(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut fence = false;
    for (k, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fence = !fence;
            continue;
        }
        if fence {
            continue;
        }
        // Drop inline code spans so that `a](b)` inside backticks is not a link.
        let mut plain = String::with_capacity(line.len());
        let mut code = false;
        for c in line.chars() {
            if c == '`' {
                code = !code;
            } else if !code {
                plain.push(c);
            }
        }
        let mut rest = plain.as_str();
        while let Some(i) = rest.find("](") {
            rest = &rest[i + 2..];
            let Some(end) = rest.find(')') else { break };
            let target = rest[..end].split_whitespace().next().unwrap_or("");
            let web = ["http://", "https://", "mailto:"]
                .iter()
                .any(|p| target.starts_with(p));
            if !target.is_empty() && !web {
                out.push((k + 1, target.to_string()));
            }
            rest = &rest[end..];
        }
    }
    out
}

/// Checks every link of the Markdown file `file` (inside the repository at `root`).
pub fn check_file(root: &Path, file: &Path) -> Result<Vec<Broken>> {
    let text = std::fs::read_to_string(file)?;
    let dir = file.parent().unwrap_or(root);
    let mut broken = Vec::new();
    let mut cache: HashMap<PathBuf, Vec<String>> = HashMap::new();
    for (line, target) in links(&text) {
        let (path, anchor) = match target.split_once('#') {
            Some((p, a)) => (p, Some(a)),
            None => (target.as_str(), None),
        };
        let resolved = if path.is_empty() {
            file.to_path_buf()
        } else {
            dir.join(path)
        };
        let bad = |why: String| Broken {
            file: file.strip_prefix(root).unwrap_or(file).to_path_buf(),
            line,
            target: target.clone(),
            why,
        };
        if !resolved.exists() {
            broken.push(bad("no such file or folder".into()));
            continue;
        }
        // Inside the clone: a link that climbs out of the repository resolves nowhere there.
        match (resolved.canonicalize(), root.canonicalize()) {
            (Ok(r), Ok(base)) if !r.starts_with(&base) => {
                broken.push(bad("points outside the repository".into()));
                continue;
            }
            _ => {}
        }
        if let Some(anchor) = anchor {
            if resolved.extension().is_some_and(|e| e == "md") {
                let list = cache.entry(resolved.clone()).or_insert_with(|| {
                    std::fs::read_to_string(&resolved)
                        .map(|t| anchors(&t))
                        .unwrap_or_default()
                });
                if !list.iter().any(|a| a == anchor) {
                    broken.push(bad(format!("no heading with the anchor #{anchor}")));
                }
            }
        }
    }
    Ok(broken)
}

/// The Markdown files the check covers: README.md, CHANGELOG.md, everything under docs/, and
/// the README.md of every crate folder (bench/, models/, validation/*/, fmu/...).
pub fn markdown_files(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        let mut entries: Vec<_> = entries.flatten().map(|e| e.path()).collect();
        entries.sort();
        for p in entries {
            let name = p.file_name().and_then(|n| n.to_str()).unwrap_or("");
            if name.starts_with('.') || name == "target" || name == "out" || name == "book" {
                continue;
            }
            if p.is_dir() {
                walk(&p, out);
            } else if name.ends_with(".md") {
                out.push(p);
            }
        }
    }
    let mut out = Vec::new();
    walk(root, &mut out);
    out
}

/// Checks every Markdown file of the repository; the error lists every broken link with its
/// file and line.
pub fn check_repository(root: &Path) -> Result<()> {
    let mut broken = Vec::new();
    let files = markdown_files(root);
    for f in &files {
        broken.extend(check_file(root, f)?);
    }
    if broken.is_empty() {
        eprintln!(
            "links: {} Markdown files, every relative link resolves",
            files.len()
        );
        return Ok(());
    }
    let list: Vec<String> = broken
        .iter()
        .map(|b| format!("{}:{}: ({}) {}", b.file.display(), b.line, b.target, b.why))
        .collect();
    bail!("{} broken links:\n{}", broken.len(), list.join("\n"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slugs_follow_the_shared_rule() {
        assert_eq!(
            slug("The two commands: demo and tests"),
            "the-two-commands-demo-and-tests"
        );
        assert_eq!(
            slug("Model file format (`zmp-model/1`)"),
            "model-file-format-zmp-model1"
        );
        assert_eq!(slug(" Effects"), "effects");
        let a = anchors("# A\n## B\n```\n# not\n```\n## B\n<a id=\"x\"></a>\n");
        assert_eq!(a, vec!["a", "b", "b-1", "x"]);
    }

    #[test]
    fn links_skip_the_web_code_and_fences() {
        let t = "see [a](b.md#c) and ![i](f.svg \"t\")\n`[x](y)` [w](https://e.org)\n```\n[q](r)\n```\n";
        assert_eq!(links(t), vec![(1, "b.md#c".into()), (1, "f.svg".into())]);
    }

    #[test]
    fn broken_files_and_anchors_are_named_with_their_line() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("docs")).unwrap();
        std::fs::write(d.path().join("docs/p.md"), "# Page\n## Part one\n").unwrap();
        std::fs::write(
            d.path().join("README.md"),
            "[ok](docs/p.md#part-one)\n[gone](docs/q.md)\n\n[bad](docs/p.md#part-two)\n\
             [self](#readme)\n[up](../outside.md)\n",
        )
        .unwrap();
        let b = check_file(d.path(), &d.path().join("README.md")).unwrap();
        let got: Vec<(usize, &str)> = b.iter().map(|b| (b.line, b.target.as_str())).collect();
        assert_eq!(
            got,
            vec![
                (2, "docs/q.md"),
                (4, "docs/p.md#part-two"),
                (5, "#readme"),
                (6, "../outside.md")
            ],
            "{b:?}"
        );
        assert!(check_repository(d.path()).is_err());
    }
}
