//! Book sections written by the suites that measure them (see `zmp_files::sections`): a
//! suite renders its table and calls [`doc_section`] with the page it belongs to.

use std::path::Path;

/// Checks (or, with `ZMP_UPDATE_DOCS=1`, writes) the section `tag` of the book page `page`
/// (a path from the repository root, e.g. `docs/src/suites.md`); panics with the difference.
pub fn doc_section(page: &str, tag: &str, text: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .join(page);
    if let Err(e) = zmp_files::sections::check_or_update(&path, tag, text) {
        panic!("{e}");
    }
}
