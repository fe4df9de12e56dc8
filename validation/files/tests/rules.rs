//! The rules of the crate docs, one test each: no replacement without force, kinds, atomic
//! replacement, special files written into, symbolic links followed, folders.

use std::os::unix::fs::FileTypeExt;
use std::path::Path;
use std::process::Command;
use zmp_files::{
    append_locked, claim_dir, write_dir, write_file, FileError, Kind, LEDGER_FILE, REPORT_MARKER,
};

const MODEL: &[u8] = b"format = \"zmp-model/1\"\n[pendulum]\na11 = 1.0\n";
const MODEL2: &[u8] = b"format = \"zmp-model/1\"\n[pendulum]\na11 = 2.0\n";
const SVG: &[u8] = b"<svg xmlns=\"http://www.w3.org/2000/svg\"></svg>\n";

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn force_replaces_only_the_kind_written() {
    let d = tempfile::tempdir().unwrap();
    let m = d.path().join("m.toml");
    write_file(&m, Kind::Model, MODEL, false).unwrap();
    let e = write_file(&m, Kind::Model, MODEL2, false).unwrap_err();
    assert!(e.is_exists() && e.to_string().contains("--force"), "{e}");
    write_file(&m, Kind::Model, MODEL2, true).unwrap();
    assert_eq!(std::fs::read(&m).unwrap(), MODEL2);
    // An SVG over the model, a model over the ledger: refused with force, files kept.
    let e = write_file(&m, Kind::Svg, SVG, true).unwrap_err();
    assert!(matches!(e, FileError::Refused { .. }), "{e}");
    assert!(e.to_string().contains("is a model file"), "{e}");
    let ledger = d.path().join(LEDGER_FILE);
    std::fs::write(&ledger, b"{\"model\":\"m.toml\"}\n").unwrap();
    for kind in [Kind::Svg, Kind::Model] {
        let e = write_file(&ledger, kind, SVG, true).unwrap_err();
        assert!(e.to_string().contains("a model ledger"), "{e}");
    }
    assert_eq!(std::fs::read(&ledger).unwrap(), b"{\"model\":\"m.toml\"}\n");
    // A user's file of no kind, with force: refused.
    let notes = d.path().join("notes.toml");
    std::fs::write(&notes, "my notes").unwrap();
    let e = write_file(&notes, Kind::Model, MODEL, true).unwrap_err();
    assert!(e.to_string().contains("did not write"), "{e}");
    // An empty file holds nothing to lose: replaced with force.
    let empty = d.path().join("empty.toml");
    std::fs::write(&empty, "").unwrap();
    write_file(&empty, Kind::Model, MODEL, true).unwrap();
    // A folder is not a file name; no temporary file is left anywhere.
    let e = write_file(d.path(), Kind::Model, MODEL, true).unwrap_err();
    assert!(e.to_string().contains("is a folder"), "{e}");
    assert_eq!(
        names(d.path()),
        ["empty.toml", "m.toml", "notes.toml", LEDGER_FILE]
    );
}

#[test]
fn symbolic_links_are_followed_and_their_target_judged() {
    let d = tempfile::tempdir().unwrap();
    let target = d.path().join("real.toml");
    write_file(&target, Kind::Model, MODEL, false).unwrap();
    let link = d.path().join("link.toml");
    std::os::unix::fs::symlink("real.toml", &link).unwrap();
    let chain = d.path().join("chain.toml");
    std::os::unix::fs::symlink(&link, &chain).unwrap();
    // Exists (through the link): refused without force.
    assert!(write_file(&chain, Kind::Model, MODEL2, false)
        .unwrap_err()
        .is_exists());
    let w = write_file(&chain, Kind::Model, MODEL2, true).unwrap();
    assert_eq!(w.path, target);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read(&target).unwrap(), MODEL2);
    // A link to a file of another kind: refused, the file kept.
    let ledger = d.path().join(LEDGER_FILE);
    std::fs::write(&ledger, b"{\"model\":\"x\"}\n").unwrap();
    let to_ledger = d.path().join("plot.svg");
    std::os::unix::fs::symlink(&ledger, &to_ledger).unwrap();
    assert!(write_file(&to_ledger, Kind::Svg, SVG, true).is_err());
    assert_eq!(std::fs::read(&ledger).unwrap(), b"{\"model\":\"x\"}\n");
    // A dangling link creates its target.
    let dangling = d.path().join("new.toml");
    std::os::unix::fs::symlink("sub/made.toml", &dangling).unwrap();
    std::fs::create_dir(d.path().join("sub")).unwrap();
    write_file(&dangling, Kind::Model, MODEL, false).unwrap();
    assert_eq!(
        std::fs::read(d.path().join("sub/made.toml")).unwrap(),
        MODEL
    );
}

#[test]
fn a_fifo_is_written_into_and_never_replaced() {
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("pipe");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    // Nobody reads it: an error at once (not a wait), the FIFO left as it is.
    let e = write_file(&fifo, Kind::Model, MODEL, true).unwrap_err();
    assert!(e.to_string().contains("no process is reading"), "{e}");
    // With a reader: the bytes arrive, without --force too, and it stays a FIFO.
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read(&fifo).unwrap())
    };
    let mut w = None;
    for _ in 0..500 {
        match write_file(&fifo, Kind::Model, MODEL, false) {
            Ok(x) => {
                w = Some(x);
                break;
            }
            // The reader has not opened it yet.
            Err(FileError::Special { .. }) => {
                std::thread::sleep(std::time::Duration::from_millis(10))
            }
            Err(e) => panic!("{e}"),
        }
    }
    assert!(w.expect("the reader opened the FIFO").special);
    assert_eq!(reader.join().unwrap(), MODEL);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    assert_eq!(names(d.path()), ["pipe"]);
}

#[test]
fn a_character_device_is_written_into_and_a_block_device_refused() {
    if !is_root() {
        eprintln!("not root: device nodes cannot be made here; the FIFO test covers special files");
        return;
    }
    let d = tempfile::tempdir().unwrap();
    // A null device of our own (major 1, minor 3), in a temporary folder.
    let null = d.path().join("null");
    assert!(Command::new("mknod")
        .arg(&null)
        .args(["c", "1", "3"])
        .status()
        .unwrap()
        .success());
    let w = write_file(&null, Kind::Model, MODEL, true).unwrap();
    assert!(w.special);
    let w = write_file(&null, Kind::Model, MODEL, false).unwrap();
    assert!(w.special);
    assert!(std::fs::symlink_metadata(&null)
        .unwrap()
        .file_type()
        .is_char_device());
    // Through a link, as `--out link-to-null`.
    let link = d.path().join("out.toml");
    std::os::unix::fs::symlink(&null, &link).unwrap();
    assert!(
        write_file(&link, Kind::Model, MODEL, false)
            .unwrap()
            .special
    );
    assert!(std::fs::symlink_metadata(&null)
        .unwrap()
        .file_type()
        .is_char_device());
    // A block device node (a loop device's numbers; nothing is opened): refused.
    let disk = d.path().join("disk");
    assert!(Command::new("mknod")
        .arg(&disk)
        .args(["b", "7", "0"])
        .status()
        .unwrap()
        .success());
    let e = write_file(&disk, Kind::Model, MODEL, true).unwrap_err();
    assert!(e.to_string().contains("block device"), "{e}");
    assert!(std::fs::symlink_metadata(&disk)
        .unwrap()
        .file_type()
        .is_block_device());
    assert_eq!(names(d.path()), ["disk", "null", "out.toml"]);
}

#[test]
fn folders_are_swapped_in_whole_and_only_over_their_kind() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("camp");
    let manifest = b"format = \"zmp-campaign/1\"\n";
    let fill = |tag: &'static str| {
        move |s: &zmp_files::Staging| -> Result<(), FileError> {
            s.write(Path::new("campaign.toml"), manifest)?;
            s.write(Path::new("records/r0.csv"), tag.as_bytes())
        }
    };
    write_dir(&out, Kind::Campaign, false, fill("one")).unwrap();
    let e = write_dir(&out, Kind::Campaign, false, fill("two")).unwrap_err();
    assert!(e.is_exists(), "{e}");
    std::fs::write(out.join("stray.txt"), "x").unwrap();
    write_dir(&out, Kind::Campaign, true, fill("two")).unwrap();
    assert_eq!(std::fs::read(out.join("records/r0.csv")).unwrap(), b"two");
    assert!(!out.join("stray.txt").exists());
    // A report folder's kind is not a campaign's: refused with force.
    let e = write_dir(&out, Kind::Report, true, |_| Ok::<_, FileError>(())).unwrap_err();
    assert!(e.to_string().contains("not written by zmp-toolkit"), "{e}");
    // A failing fill leaves nothing behind and the old folder as it was.
    let e = write_dir(&out, Kind::Campaign, true, |s| {
        s.write(Path::new("campaign.toml"), manifest)?;
        Err::<(), _>(FileError::Exists {
            path: "boom".into(),
        })
    })
    .unwrap_err();
    assert_eq!(e.path(), Path::new("boom"));
    assert_eq!(std::fs::read(out.join("records/r0.csv")).unwrap(), b"two");
    assert_eq!(names(d.path()), ["camp"]);
    // A user's folder: refused, untouched.
    let mine = d.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("thesis.tex"), "precious").unwrap();
    for force in [false, true] {
        assert!(write_dir(&mine, Kind::Campaign, force, fill("x")).is_err());
        assert!(claim_dir(&mine, Kind::Report, force).is_err());
    }
    assert_eq!(names(&mine), ["thesis.tex"]);
}

#[test]
fn claimed_folders_get_their_marker_at_once() {
    let d = tempfile::tempdir().unwrap();
    let rep = d.path().join("a/report");
    claim_dir(&rep, Kind::Report, false).unwrap();
    assert!(rep.join(REPORT_MARKER).is_file());
    assert!(claim_dir(&rep, Kind::Report, false)
        .unwrap_err()
        .is_exists());
    claim_dir(&rep, Kind::Report, true).unwrap();
    assert!(claim_dir(&rep, Kind::LoopOutput, true).is_err());
    // Through a link to it.
    let link = d.path().join("link");
    std::os::unix::fs::symlink(&rep, &link).unwrap();
    assert_eq!(claim_dir(&link, Kind::Report, true).unwrap(), rep);
    assert_eq!(names(&d.path().join("a")), ["report"]);
}

#[test]
fn appends_go_only_to_a_regular_file_of_their_kind() {
    let d = tempfile::tempdir().unwrap();
    let ledger = d.path().join(LEDGER_FILE);
    let line = |_: &[u8]| Some(b"{\"model\":\"a\"}\n".to_vec());
    assert!(append_locked(&ledger, Kind::Ledger, 1 << 20, line).unwrap());
    assert!(append_locked(&ledger, Kind::Ledger, 1 << 20, line).unwrap());
    assert_eq!(std::fs::read_to_string(&ledger).unwrap().lines().count(), 2);
    std::fs::write(&ledger, SVG).unwrap();
    let e = append_locked(&ledger, Kind::Ledger, 1 << 20, line).unwrap_err();
    assert!(e.to_string().contains("an SVG plot"), "{e}");
    assert_eq!(std::fs::read(&ledger).unwrap(), SVG);
    std::fs::remove_file(&ledger).unwrap();
    std::fs::create_dir(&ledger).unwrap();
    assert!(append_locked(&ledger, Kind::Ledger, 1 << 20, line).is_err());
}

/// The tests of the module this crate replaced (`zmp_validation::io`), with their assertions.
mod ported_from_validation_io {
    use super::*;

    #[test]
    fn refuses_to_overwrite_unless_asked() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("a/b.txt");
        write_file(&p, Kind::Marker, b"one", false).unwrap();
        let e = write_file(&p, Kind::Marker, b"two", false).unwrap_err();
        assert!(e.to_string().contains("--force"));
        assert_eq!(std::fs::read(&p).unwrap(), b"one");
        // (A marker-named file: `b.txt` is of no kind, so an empty one stands in.)
        let q = d.path().join("a/.zmp-b");
        write_file(&q, Kind::Marker, b"one", false).unwrap();
        write_file(&q, Kind::Marker, b"two", true).unwrap();
        assert_eq!(std::fs::read(&q).unwrap(), b"two");
        // No temporary files left behind.
        assert_eq!(std::fs::read_dir(p.parent().unwrap()).unwrap().count(), 2);
        // A folder is not a file name, even with --force.
        let e = write_file(d.path(), Kind::Marker, b"x", true).unwrap_err();
        assert!(e.to_string().contains("is a folder"), "{e}");
    }

    #[test]
    fn claim_dir_replaces_only_marked_folders() {
        let d = tempfile::tempdir().unwrap();
        let new = d.path().join("report");
        claim_dir(&new, Kind::Report, false).unwrap();
        assert!(new.join(REPORT_MARKER).is_file());
        let e = claim_dir(&new, Kind::Report, false).unwrap_err();
        assert!(e.to_string().contains("--force"), "{e}");
        claim_dir(&new, Kind::Report, true).unwrap();

        let users = d.path().join("mine");
        std::fs::create_dir(&users).unwrap();
        std::fs::write(users.join("thesis.tex"), "precious").unwrap();
        for force in [false, true] {
            let e = claim_dir(&users, Kind::Report, force).unwrap_err();
            assert!(e.to_string().contains("not written by zmp-toolkit"), "{e}");
        }
        assert_eq!(std::fs::read_dir(&users).unwrap().count(), 1);
        assert_eq!(
            std::fs::read_to_string(users.join("thesis.tex")).unwrap(),
            "precious"
        );
        let file = d.path().join("file");
        std::fs::write(&file, "x").unwrap();
        assert!(claim_dir(&file, Kind::Report, true).is_err());
    }

    #[test]
    fn only_a_folder_or_file_of_the_kind_is_removed() {
        let d = tempfile::tempdir().unwrap();
        let rep = d.path().join("rep");
        claim_dir(&rep, Kind::Report, false).unwrap();
        std::fs::write(rep.join("x.svg"), SVG).unwrap();
        let mine = d.path().join("mine");
        std::fs::create_dir(&mine).unwrap();
        std::fs::write(mine.join("a"), "keep").unwrap();
        let notes = d.path().join("n.toml");
        std::fs::write(&notes, "keep").unwrap();
        let m = d.path().join("m.toml");
        std::fs::write(&m, MODEL).unwrap();
        assert!(!zmp_files::remove(&mine, Kind::Report).unwrap());
        assert!(!zmp_files::remove(&notes, Kind::Model).unwrap());
        assert!(zmp_files::remove(&rep, Kind::Report).unwrap());
        assert!(zmp_files::remove(&m, Kind::Model).unwrap());
        assert!(!zmp_files::remove(&m, Kind::Model).unwrap());
        assert_eq!(names(d.path()), ["mine", "n.toml"]);
    }
}
