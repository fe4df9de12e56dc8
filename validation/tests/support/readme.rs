//! README sections written by the tests that measure them: the text between
//! `<!-- TAG -->` and `<!-- /TAG -->` is replaced when `ZMP_UPDATE_README=1`, and otherwise
//! must equal what the test measured (a README can never quote a stale run).

/// Replaces (with `ZMP_UPDATE_README=1`) or checks the README section `tag`.
pub fn readme_section(tag: &str, text: &str) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../README.md");
    let readme = std::fs::read_to_string(&path).unwrap();
    let open = format!("<!-- {tag} -->\n");
    let close = format!("<!-- /{tag} -->");
    let (Some(a), Some(b)) = (readme.find(&open), readme.find(&close)) else {
        panic!("README.md has no {open:?} ... {close:?} section");
    };
    let current = &readme[a + open.len()..b];
    if std::env::var("ZMP_UPDATE_README").is_ok_and(|v| v == "1") {
        let new = format!("{}{open}{text}{}", &readme[..a], &readme[b..]);
        std::fs::write(&path, new).unwrap();
    } else {
        assert_eq!(
            current, text,
            "README.md's {tag} section is not what this run measured; run the test with \
             ZMP_UPDATE_README=1 to write it"
        );
    }
}
