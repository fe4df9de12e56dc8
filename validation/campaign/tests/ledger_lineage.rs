//! The ledger links versions by content (issue 53, defect 5): each entry records the hash of
//! its model file and of its parent, and the history follows the hashes. Before, a parent
//! rewritten with `--force`, or a second `loop --force` run into the same folder, joined the
//! chain by file name alone and the history mixed the runs ("+6989.6 %") without a word.

use std::path::Path;
use zmp_campaign::ledger::{append, history, read, Entry, LEDGER_FILE};

fn write(p: &Path, text: &str) {
    std::fs::write(p, text).unwrap();
}

/// Defect 5: a parent rewritten after its child was made, and a rerun that wrote fewer
/// versions into the same folder, do not join another run's chain.
#[test]
fn defect_5_history_follows_contents_not_names() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Run 1 on campaign one: identified -> +a -> +a+b.
    let (i, ia, iab) = (
        d.join("identified.toml"),
        d.join("identified+a.toml"),
        d.join("identified+a+b.toml"),
    );
    write(&i, "run 1 identified");
    append(&i, None, "identified", "one", 0.20, 0.01).unwrap();
    write(&ia, "run 1 +a");
    append(&ia, Some(&i), "+a", "one", 0.05, 0.01).unwrap();
    write(&iab, "run 1 +a+b");
    append(&iab, Some(&ia), "+b", "one", 0.011, 0.01).unwrap();
    // Run 2 (--force, campaign two) rewrites identified and identified+a, and stops there.
    write(&i, "run 2 identified");
    append(&i, None, "identified", "two", 9.0, 0.2).unwrap();
    write(&ia, "run 2 +a");
    append(&ia, Some(&i), "+a", "two", 0.8, 0.2).unwrap();

    // Run 1's last version still leads back through run 1 only.
    let h = history(&iab).unwrap();
    let campaigns: Vec<&str> = h.chain.iter().map(|e| e.campaign.as_str()).collect();
    assert_eq!(campaigns, ["one", "one", "one"], "{:#?}", h.chain);
    let errors: Vec<f64> = h.chain.iter().map(|e| e.error).collect();
    assert_eq!(errors, [0.20, 0.05, 0.011]);
    assert!(!h.edited);
    // Run 2's versions lead back through run 2 only.
    let h = history(&ia).unwrap();
    let campaigns: Vec<&str> = h.chain.iter().map(|e| e.campaign.as_str()).collect();
    assert_eq!(campaigns, ["two", "two"]);
    // Each entry records its parent's contents.
    let entries = read(&i).unwrap().entries;
    assert!(entries.iter().all(|e| e.hash.len() == 64), "{entries:#?}");
    let run1_ab = &entries[2];
    assert_eq!(run1_ab.parent.as_deref(), Some("identified+a.toml"));
    assert_eq!(
        run1_ab.parent_hash.as_deref(),
        Some(entries[1].hash.as_str())
    );

    // A parent rewritten by hand after the child was made: the child's history keeps the
    // parent as it was.
    let child = d.join("child.toml");
    write(&child, "child of run 2's identified");
    append(&child, Some(&i), "+c", "two", 0.3, 0.2).unwrap();
    write(&i, "identified, edited by hand");
    let h = history(&child).unwrap();
    assert_eq!(h.chain.len(), 2);
    assert_eq!(
        (h.chain[0].campaign.as_str(), h.chain[0].error),
        ("two", 9.0)
    );
    assert!(
        h.notes
            .iter()
            .any(|n| n.contains("identified.toml on disk no longer matches")),
        "{:?}",
        h.notes
    );
}

/// A ledger written before content lineage (FNV-1a hashes, no `parent_hash`) still reads:
/// its history is linked by name, the file check still works, and the history says how it
/// was linked.
#[test]
fn ledgers_written_before_content_hashes_still_read() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(&d.join("robot.toml"), "a");
    write(&d.join("robot+time_delay.toml"), "b");
    // FNV-1a 64 of "a" and of "b", as the earlier ledger recorded them.
    let old = "{\"model\":\"robot.toml\",\"hash\":\"af63dc4c8601ec8c\",\"parent\":null,\
        \"change\":\"identified\",\"campaign\":\"camp\",\"error\":0.2,\"noise_floor\":0.01,\
        \"date\":\"2025-01-01T00:00:00Z\",\"tool\":\"zmp-validation 0.1.0\"}\n\
        {\"model\":\"robot+time_delay.toml\",\"hash\":\"af63df4c8601f1a5\",\
        \"parent\":\"robot.toml\",\"change\":\"+time_delay\",\"campaign\":\"camp\",\
        \"error\":0.011,\"noise_floor\":0.01,\"date\":\"2025-01-01T00:00:01Z\",\
        \"tool\":\"zmp-validation 0.1.0\"}\n";
    write(&d.join(LEDGER_FILE), old);
    let h = history(&d.join("robot+time_delay.toml")).unwrap();
    assert_eq!(h.chain.len(), 2);
    assert!(h.warnings.is_empty(), "{:?}", h.warnings);
    assert!(!h.edited, "the FNV hash of the file still matches");
    assert!(
        h.notes.iter().any(|n| n.contains("file name only")),
        "{:?}",
        h.notes
    );
    // A new entry after them is appended with content hashes; old ones read as before.
    write(&d.join("next.toml"), "c");
    append(
        &d.join("next.toml"),
        Some(&d.join("robot+time_delay.toml")),
        "refit",
        "camp",
        0.01,
        0.01,
    )
    .unwrap();
    let all: Vec<Entry> = read(&d.join("next.toml")).unwrap().entries;
    assert_eq!(all.len(), 3);
    assert_eq!(all[0].parent_hash, None);
    assert_eq!(history(&d.join("next.toml")).unwrap().chain.len(), 3);
    // An entry without any hash reads too.
    std::fs::write(
        d.join(LEDGER_FILE),
        "{\"model\":\"robot.toml\",\"parent\":null,\"change\":\"identified\",\
         \"campaign\":\"camp\",\"error\":0.2,\"noise_floor\":0.01,\"date\":\"d\",\"tool\":\"t\"}\n",
    )
    .unwrap();
    let h = history(&d.join("robot.toml")).unwrap();
    assert!(
        !h.edited && h.notes.iter().any(|n| n.contains("no content hash")),
        "{h:?}"
    );
}
