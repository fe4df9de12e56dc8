//! Documentation sections written by the run that measures them.
//!
//! A page of the book (or any Markdown file) holds a measured section between the markers
//! `<!-- TAG -->` and `<!-- /TAG -->`. The code that measures the numbers renders the
//! section's text; [`replace_sections`] writes it into the page (atomically: a failure leaves
//! the page as it was) and [`check_or_update`] is what a test calls: with
//! `ZMP_UPDATE_DOCS=1` it writes, otherwise it fails when the page quotes anything but what
//! this run measured. So a page can never quote a stale run.

use std::path::Path;

/// The environment variable that makes [`check_or_update`] write instead of compare.
pub const UPDATE_VAR: &str = "ZMP_UPDATE_DOCS";

fn markers(tag: &str) -> (String, String) {
    (format!("<!-- {tag} -->\n"), format!("<!-- /{tag} -->"))
}

/// The byte range of the text between `tag`'s markers in `text`, or an error naming `path`
/// and the missing marker.
fn locate(text: &str, tag: &str, path: &Path) -> Result<(usize, usize), String> {
    let (open, close) = markers(tag);
    let a = text
        .find(&open)
        .ok_or_else(|| format!("{}: no marker `<!-- {tag} -->`", path.display()))?
        + open.len();
    let b = text[a..].find(&close).map(|k| a + k).ok_or_else(|| {
        format!(
            "{}: no marker `<!-- /{tag} -->` after its opening",
            path.display()
        )
    })?;
    Ok((a, b))
}

/// The text between `tag`'s markers in the file at `path`.
pub fn read_section(path: &Path, tag: &str) -> Result<String, String> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let (a, b) = locate(&text, tag, path)?;
    Ok(text[a..b].to_string())
}

/// Replaces each section's text in the file at `path`; every section's markers must be there
/// (an error names the file and the missing marker, and nothing is written). Written to a
/// temporary file beside it and renamed into place.
pub fn replace_sections(path: &Path, sections: &[(&str, String)]) -> Result<(), String> {
    let mut text = std::fs::read_to_string(path)
        .map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    for (tag, body) in sections {
        let (a, b) = locate(&text, tag, path)?;
        text = format!("{}{body}{}", &text[..a], &text[b..]);
    }
    crate::atomic_write(path, text.as_bytes(), true).map_err(|e| format!("{e:#}"))
}

/// What a test calls with the section it measured: with [`UPDATE_VAR`]` = 1` the section is
/// written; otherwise an error says that the page quotes another run (and how to write it).
pub fn check_or_update(path: &Path, tag: &str, text: &str) -> Result<(), String> {
    if std::env::var(UPDATE_VAR).is_ok_and(|v| v == "1") {
        return replace_sections(path, &[(tag, text.to_string())]);
    }
    let current = read_section(path, tag)?;
    if current == text {
        Ok(())
    } else {
        Err(format!(
            "{}: section `{tag}` is not what this run measured; run the test with {UPDATE_VAR}=1 \
             to write it.\n--- page ---\n{current}\n--- this run ---\n{text}",
            path.display()
        ))
    }
}

/// The repository's root, where this crate's sources lie (for the checks a test makes of the
/// book in the source tree).
pub fn repository_root() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// [`check_or_update`] for a test: the section `tag` of the page `page` (a path from the
/// repository's root, e.g. `docs/src/suites.md`); panics with the difference.
pub fn check_page(page: &str, tag: &str, text: &str) {
    if let Err(e) = check_or_update(&repository_root().join(page), tag, text) {
        panic!("{e}");
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sections_are_replaced_and_missing_markers_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("page.md");
        std::fs::write(
            &p,
            "head\n<!-- a -->\nold\n<!-- /a -->\nmiddle\n<!-- b -->\n<!-- /b -->\ntail\n",
        )
        .unwrap();
        replace_sections(&p, &[("a", "new\n".into()), ("b", "B\n".into())]).unwrap();
        assert_eq!(
            std::fs::read_to_string(&p).unwrap(),
            "head\n<!-- a -->\nnew\n<!-- /a -->\nmiddle\n<!-- b -->\nB\n<!-- /b -->\ntail\n"
        );
        assert_eq!(read_section(&p, "b").unwrap(), "B\n");
        let before = std::fs::read_to_string(&p).unwrap();
        let e = replace_sections(&p, &[("a", "x".into()), ("c", "x".into())]).unwrap_err();
        assert!(e.contains("page.md") && e.contains("<!-- c -->"), "{e}");
        // Nothing was written, not even the section that was found.
        assert_eq!(std::fs::read_to_string(&p).unwrap(), before);
    }

    #[test]
    fn a_stale_section_is_an_error_that_says_how_to_write_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("page.md");
        std::fs::write(&p, "<!-- t -->\n1.00\n<!-- /t -->\n").unwrap();
        // The variable is not set by the test harness for this process.
        if std::env::var(UPDATE_VAR).is_ok() {
            return;
        }
        check_or_update(&p, "t", "1.00\n").unwrap();
        let e = check_or_update(&p, "t", "1.01\n").unwrap_err();
        assert!(e.contains(UPDATE_VAR) && e.contains("1.01"), "{e}");
    }
}
