//! Nothing clobbered (issue 53): the output path of every command, as a user meets it.
//! One test per defect of the issue that the command line shows: 1 (`history --plot` over
//! anything), 2 (special files and symbolic links), 5 (`loop --force` reruns and the history
//! by content), 10 (a failed ledger write).

mod support;

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;
use support::{campaign, delayed_model, fails, hidden, is_root, ok, xtask};

/// Defect 1: `history --plot zmp-ledger.jsonl` replaced the ledger with an SVG (exit 0), and
/// `--plot m.toml` the model. Now nothing is replaced without --force, and with it only an SVG.
#[test]
fn defect_1_history_plot_never_replaces_the_ledger_or_a_model() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    campaign(d, "camp", None);
    ok(
        xtask(&["identify", "camp", "--out", "m.toml"], d),
        "identify",
    );
    let ledger = std::fs::read(d.join("zmp-ledger.jsonl")).unwrap();
    let model = std::fs::read(d.join("m.toml")).unwrap();
    for force in [false, true] {
        for target in ["zmp-ledger.jsonl", "m.toml"] {
            let mut args = vec!["history", "m.toml", "--plot", target];
            if force {
                args.push("--force");
            }
            let err = fails(xtask(&args, d), "history --plot");
            assert!(err.contains(target), "{err}");
            if force {
                assert!(err.contains("even with --force"), "{err}");
            } else {
                assert!(err.contains("--force"), "{err}");
            }
        }
    }
    assert_eq!(std::fs::read(d.join("zmp-ledger.jsonl")).unwrap(), ledger);
    assert_eq!(std::fs::read(d.join("m.toml")).unwrap(), model);
    // A plot replaces a plot, with --force only.
    ok(
        xtask(&["history", "m.toml", "--plot", "w.svg"], d),
        "history",
    );
    fails(
        xtask(&["history", "m.toml", "--plot", "w.svg"], d),
        "history again",
    );
    ok(
        xtask(&["history", "m.toml", "--plot", "w.svg", "--force"], d),
        "history --force",
    );
    assert!(hidden(d).is_empty(), "{:?}", hidden(d));
}

/// Defect 2: as root, `identify --out /dev/null --force` replaced /dev/null with a regular
/// file (and wrote a ledger into /dev); FIFOs likewise; a symbolic link given as --out was
/// replaced instead of written through. Now a character device or a FIFO is written into and
/// stays what it is (no ledger beside it), and a link is followed: its target is judged and
/// written, the link stays. (Device nodes are made in a temporary folder, never /dev's.)
#[test]
fn defect_2_special_files_are_written_into_and_links_followed() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    campaign(d, "camp", None);
    links_are_followed(d);
    let dev = d.join("dev");
    std::fs::create_dir(&dev).unwrap();
    a_fifo_gets_the_model(d, &dev);
    if !is_root() {
        eprintln!("not root: no device node can be made; the FIFO and the links were checked");
        return;
    }
    device_nodes_stay_what_they_are(d, &dev);
}

/// A symbolic link to a model is written through with --force, the link kept; a link to a
/// file of another kind is refused even with --force, the file kept.
fn links_are_followed(d: &Path) {
    ok(
        xtask(&["identify", "camp", "--out", "real.toml"], d),
        "identify",
    );
    std::os::unix::fs::symlink("real.toml", d.join("link.toml")).unwrap();
    std::fs::write(
        d.join("real.toml"),
        "format = \"zmp-model/1\"\n# an older model\n",
    )
    .unwrap();
    fails(
        xtask(&["identify", "camp", "--out", "link.toml"], d),
        "identify over a link",
    );
    ok(
        xtask(&["identify", "camp", "--out", "link.toml", "--force"], d),
        "identify --force over a link",
    );
    assert!(std::fs::symlink_metadata(d.join("link.toml"))
        .unwrap()
        .file_type()
        .is_symlink());
    let written = std::fs::read_to_string(d.join("real.toml")).unwrap();
    assert!(written.contains("[pendulum]"), "{written}");
    // A link to a file of another kind: refused even with --force, the file kept.
    std::fs::write(d.join("notes.txt"), "mine").unwrap();
    std::os::unix::fs::symlink("notes.txt", d.join("n.toml")).unwrap();
    fails(
        xtask(&["identify", "camp", "--out", "n.toml", "--force"], d),
        "identify over a link to notes",
    );
    assert_eq!(
        std::fs::read_to_string(d.join("notes.txt")).unwrap(),
        "mine"
    );
}

/// A FIFO with a reader gets the model and stays a FIFO, no ledger beside it.
fn a_fifo_gets_the_model(d: &Path, dev: &Path) {
    let fifo = dev.join("pipe");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(&fifo).unwrap())
    };
    // Until the reader has opened the FIFO the write is refused at once (no one reads it).
    let mut got = None;
    for _ in 0..200 {
        let out = xtask(&["identify", "camp", "--out", "dev/pipe", "--force"], d);
        if out.status.success() {
            got = Some(out);
            break;
        }
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("no process is reading"), "{err}");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert!(got.is_some(), "the FIFO never got the model");
    assert!(reader.join().unwrap().contains("[pendulum]"));
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    assert!(
        !dev.join("zmp-ledger.jsonl").exists(),
        "a ledger beside a FIFO"
    );
}

/// A character device (a null device of our own) is written into and stays one, no ledger
/// beside it; a block device node is refused (nothing is opened).
fn device_nodes_stay_what_they_are(d: &Path, dev: &Path) {
    // A null device of our own (major 1, minor 3), as `--out /dev/null --force` meets it.
    let null = dev.join("null");
    assert!(Command::new("mknod")
        .arg(&null)
        .args(["c", "1", "3"])
        .status()
        .unwrap()
        .success());
    for force in [false, true] {
        let mut args = vec!["identify", "camp", "--out", "dev/null"];
        if force {
            args.push("--force");
        }
        ok(xtask(&args, d), "identify --out dev/null");
        assert!(std::fs::symlink_metadata(&null)
            .unwrap()
            .file_type()
            .is_char_device());
    }
    assert!(
        !dev.join("zmp-ledger.jsonl").exists(),
        "a ledger beside a device"
    );
    // A block device node is refused (nothing is opened).
    let disk = dev.join("disk");
    assert!(Command::new("mknod")
        .arg(&disk)
        .args(["b", "7", "0"])
        .status()
        .unwrap()
        .success());
    let err = fails(
        xtask(&["identify", "camp", "--out", "dev/disk", "--force"], d),
        "identify --out a block device",
    );
    assert!(err.contains("block device"), "{err}");
    assert!(std::fs::symlink_metadata(&disk)
        .unwrap()
        .file_type()
        .is_block_device());
    let mut names: Vec<String> = std::fs::read_dir(dev)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["disk", "null", "pipe"]);
}

/// Defect 5: after `loop --force` reran into the same folder, the earlier run's versions
/// stayed and `history` mixed the runs by file name. Now the rerun removes its own earlier
/// versions (those its marker lists, unchanged since), and the history follows hashes and
/// says when a version's file changed since its entry.
#[test]
fn defect_5_a_rerun_removes_its_earlier_versions_and_history_follows_contents() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    let delayed = delayed_model(d);
    campaign(d, "slow", Some(&delayed));
    campaign(d, "camp", None);
    // Run 1 finds an effect: a version beside the identified model.
    let run1: serde_json::Value = serde_json::from_str(&ok(
        xtask(&["loop", "slow", "--out", "lp", "--json"], d),
        "loop",
    ))
    .unwrap();
    let v1: Vec<String> = run1["versions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["model"].as_str().unwrap().to_string())
        .collect();
    assert!(v1.len() >= 2, "the first run found no effect: {run1}");
    // A file of the user's in the folder stays.
    std::fs::write(d.join("lp/notes.txt"), "mine").unwrap();
    // Run 2 (--force, a clean robot): only the identified model.
    let run2: serde_json::Value = serde_json::from_str(&ok(
        xtask(&["loop", "camp", "--out", "lp", "--force", "--json"], d),
        "loop --force",
    ))
    .unwrap();
    assert_eq!(run2["versions"].as_array().unwrap().len(), 1, "{run2}");
    for v in &v1[1..] {
        assert!(!d.join(v).exists(), "{v}: the earlier run's version stayed");
    }
    assert!(!d.join("lp/diagnosis-2").exists());
    assert_eq!(
        std::fs::read_to_string(d.join("lp/notes.txt")).unwrap(),
        "mine"
    );
    let h: serde_json::Value = serde_json::from_str(&ok(
        xtask(&["history", "lp/identified.toml", "--json"], d),
        "history",
    ))
    .unwrap();
    let chain = h["versions"].as_array().unwrap();
    assert_eq!(chain.len(), 1, "{h}");
    assert_eq!(chain[0]["campaign"], "camp");

    // A parent rewritten with --force after its child was made from it: the child's history
    // keeps the parent it was made from and says the file changed.
    ok(
        xtask(&["identify", "camp", "--out", "a.toml"], d),
        "identify",
    );
    ok(
        xtask(
            &["identify", "camp", "--model", "a.toml", "--out", "b.toml"],
            d,
        ),
        "identify --model",
    );
    ok(
        xtask(&["identify", "slow", "--out", "a.toml", "--force"], d),
        "identify --force",
    );
    let h: serde_json::Value = serde_json::from_str(&ok(
        xtask(&["history", "b.toml", "--json", "--plot", "b.svg"], d),
        "history b",
    ))
    .unwrap();
    let chain = h["versions"].as_array().unwrap();
    assert_eq!(chain.len(), 2, "{h}");
    assert_eq!(chain[0]["model"], "a.toml");
    assert_eq!(
        chain[0]["campaign"], "camp",
        "the rewritten parent joined the chain: {h}"
    );
    let notes = h["notes"].to_string();
    assert!(notes.contains("a.toml on disk no longer matches"), "{h}");
}

/// Defect 10: when the ledger could not be written, `identify` warned and exited 0, leaving a
/// model without its entry. Now that is a failure (exit 1) that names the model, which is
/// kept; --no-ledger writes the model without one.
#[test]
fn defect_10_a_failed_ledger_write_fails_the_run() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    campaign(d, "camp", None);
    std::fs::create_dir(d.join("out")).unwrap();
    // A folder where the ledger should be: the entry cannot be appended.
    std::fs::create_dir(d.join("out/zmp-ledger.jsonl")).unwrap();
    let err = fails(
        xtask(&["identify", "camp", "--out", "out/m.toml"], d),
        "identify with an unwritable ledger",
    );
    assert!(
        err.contains("out/m.toml") && err.contains("kept") && err.contains("ledger"),
        "{err}"
    );
    assert!(std::fs::read_to_string(d.join("out/m.toml"))
        .unwrap()
        .contains("[pendulum]"));
    ok(
        xtask(
            &["identify", "camp", "--out", "out/n.toml", "--no-ledger"],
            d,
        ),
        "identify --no-ledger",
    );
    assert!(d.join("out/n.toml").is_file());
    // augment likewise.
    let err = fails(
        xtask(
            &[
                "augment",
                "out/m.toml",
                "--add",
                "time_delay",
                "--campaign",
                "camp",
            ],
            d,
        ),
        "augment with an unwritable ledger",
    );
    assert!(err.contains("kept") && err.contains("--no-ledger"), "{err}");
    assert!(d.join("out/m+time_delay.toml").is_file());
}
