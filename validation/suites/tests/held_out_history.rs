//! The book's held-out history (`docs/src/held-out-history.md`) is generated from the record
//! (`validation/suites/held-out-ranges.csv`): the page's table is what the record renders to,
//! and every row of the record parses.

use zmp_files::sections::check_page as doc_section;
use zmp_suites::history::{parse, record_path, render};

#[test]
fn the_history_page_is_the_record_rendered() {
    let text = std::fs::read_to_string(record_path()).unwrap();
    let rows = parse(&text).unwrap_or_else(|e| panic!("{e}"));
    assert!(rows.len() >= 30, "the record lost rows: {}", rows.len());
    // Ranges are distinct: each is run once.
    let mut ranges: Vec<u64> = rows.iter().map(|r| r.range).collect();
    ranges.sort_unstable();
    ranges.dedup();
    assert_eq!(ranges.len(), rows.len(), "a range is recorded twice");
    doc_section(
        "docs/src/held-out-history.md",
        "held-out-history",
        &render(&rows),
    );
}
