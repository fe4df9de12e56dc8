//! Documentation sections written by the tests that measure them: the text between
//! `<!-- TAG -->` and `<!-- /TAG -->` is replaced when `ZMP_UPDATE_README=1`, and otherwise
//! must equal what the test measured (a page can never quote a stale run).

#![allow(dead_code)]

use std::path::PathBuf;

/// The repository's root: the nearest folder above the crate with `Cargo.lock`.
fn repo_root() -> PathBuf {
    let mut p = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    while !p.join("Cargo.lock").is_file() {
        assert!(
            p.pop(),
            "no Cargo.lock above {}",
            env!("CARGO_MANIFEST_DIR")
        );
    }
    p
}

/// Replaces (with `ZMP_UPDATE_README=1`) or checks the section `tag` of the page `page`
/// (a path from the repository's root, e.g. `docs/src/robust-stability.md`).
pub fn doc_section(page: &str, tag: &str, text: &str) {
    let path = repo_root().join(page);
    let doc = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: cannot read: {e}", path.display()));
    let open = format!("<!-- {tag} -->\n");
    let close = format!("<!-- /{tag} -->");
    let (Some(a), Some(b)) = (doc.find(&open), doc.find(&close)) else {
        panic!("{page} has no {open:?} ... {close:?} section");
    };
    let current = &doc[a + open.len()..b];
    if std::env::var("ZMP_UPDATE_README").is_ok_and(|v| v == "1") {
        let new = format!("{}{open}{text}{}", &doc[..a], &doc[b..]);
        std::fs::write(&path, new).unwrap();
    } else {
        assert_eq!(
            current, text,
            "{page}'s {tag} section is not what this run measured; run the test with \
             ZMP_UPDATE_README=1 to write it"
        );
    }
}

/// Replaces (with `ZMP_UPDATE_README=1`) or checks the README section `tag`.
pub fn readme_section(tag: &str, text: &str) {
    doc_section("README.md", tag, text);
}
