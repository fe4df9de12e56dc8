//! Concurrent writers of one folder lose nothing: the ledger (append under a lock) and the
//! no-clobber model write (exactly one of two writers of one path wins). Real processes, as
//! with several `cargo xtask identify` runs at once: the test binary re-runs itself as the
//! writers (`ZMP_TEST_WRITER` set).

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use zmp_campaign::ledger;
use zmp_files::{write_file, Kind};

const WRITERS: usize = 16;
/// Entries each writer appends besides its model's own.
const EXTRA: usize = 10;

/// Starts the `role` writer test of this binary in a child process.
fn spawn(role: &str, dir: &Path, k: usize) -> Child {
    Command::new(std::env::current_exe().unwrap())
        .args([role, "--exact", "--nocapture", "--test-threads=1"])
        .env("ZMP_TEST_WRITER", format!("{}|{k}", dir.display()))
        .stdout(Stdio::null())
        .spawn()
        .expect("spawning a writer")
}

/// `(folder, writer number)` in a writer process; `None` in the normal test run.
fn writer_args() -> Option<(PathBuf, usize)> {
    let v = std::env::var("ZMP_TEST_WRITER").ok()?;
    let (d, k) = v.rsplit_once('|')?;
    Some((PathBuf::from(d), k.parse().ok()?))
}

/// Writer role: writes its model file (no-clobber) and its ledger entries, as `identify` does.
#[test]
fn ledger_writer() {
    let Some((dir, k)) = writer_args() else {
        return;
    };
    let model = dir.join(format!("model{k:02}.toml"));
    write_file(
        &model,
        Kind::Model,
        format!("name = \"model {k}\"\n").as_bytes(),
        false,
    )
    .unwrap();
    ledger::append(&model, None, "identified", "campaign", 0.1 * k as f64, 0.01).unwrap();
    for j in 0..EXTRA {
        ledger::append(&model, None, &format!("refit {j}"), "campaign", 0.1, 0.01).unwrap();
    }
}

#[test]
fn sixteen_concurrent_writers_lose_no_entry() {
    if writer_args().is_some() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let children: Vec<Child> = (0..WRITERS)
        .map(|k| spawn("ledger_writer", dir.path(), k))
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success(), "a writer failed");
    }
    let text = std::fs::read_to_string(dir.path().join(ledger::LEDGER_FILE)).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), WRITERS * (1 + EXTRA), "entries lost or split");
    for (i, l) in lines.iter().enumerate() {
        serde_json::from_str::<ledger::Entry>(l)
            .unwrap_or_else(|e| panic!("line {}: {e}: {l}", i + 1));
    }
    let any = dir.path().join("model00.toml");
    let contents = ledger::read(&any).unwrap();
    assert!(contents.warnings.is_empty(), "{:?}", contents.warnings);
    for k in 0..WRITERS {
        let model = dir.path().join(format!("model{k:02}.toml"));
        let name = format!("model{k:02}.toml");
        let mine: Vec<_> = contents
            .entries
            .iter()
            .filter(|e| e.model == name)
            .collect();
        assert_eq!(mine.len(), 1 + EXTRA, "{name}");
        assert!(mine.iter().any(|e| e.change == "identified"), "{name}");
        let h = ledger::history(&model).unwrap();
        assert!(!h.edited, "{name}: hash recorded for other contents");
    }
}

/// Writer role: one of two no-clobber writes of the same path; prints `won` or the error.
#[test]
fn clobber_writer() {
    let Some((dir, k)) = writer_args() else {
        return;
    };
    let path = dir.join("model.toml");
    // Both writers pass any "does it exist" look before either renames: the race the
    // no-clobber rename must settle.
    let bytes = vec![b'a' + k as u8; 1 << 20];
    match write_file(&path, Kind::Model, &bytes, false) {
        Ok(_) => std::fs::write(dir.join(format!("won{k}")), "").unwrap(),
        Err(e) => std::fs::write(dir.join(format!("lost{k}")), format!("{e:#}")).unwrap(),
    }
}

#[test]
fn two_concurrent_no_clobber_writes_one_wins() {
    if writer_args().is_some() {
        return;
    }
    for round in 0..5 {
        let dir = tempfile::tempdir().unwrap();
        let children: Vec<Child> = (0..2)
            .map(|k| spawn("clobber_writer", dir.path(), k))
            .collect();
        for mut c in children {
            assert!(c.wait().unwrap().success(), "a writer crashed");
        }
        let won: Vec<usize> = (0..2)
            .filter(|k| dir.path().join(format!("won{k}")).exists())
            .collect();
        assert_eq!(won.len(), 1, "round {round}: winners {won:?}");
        let loser = 1 - won[0];
        let why = std::fs::read_to_string(dir.path().join(format!("lost{loser}"))).unwrap();
        assert!(why.contains("--force"), "round {round}: {why}");
        let bytes = std::fs::read(dir.path().join("model.toml")).unwrap();
        assert_eq!(bytes.len(), 1 << 20);
        assert!(
            bytes.iter().all(|b| *b == b'a' + won[0] as u8),
            "round {round}: the file mixes the writers' bytes or holds the loser's"
        );
        // No temporary files left behind.
        let stray: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .filter_map(|e| e.ok())
            .map(|e| e.file_name().to_string_lossy().into_owned())
            .filter(|n| n.starts_with(".tmp"))
            .collect();
        assert!(stray.is_empty(), "round {round}: {stray:?}");
    }
}
