//! `calibrate-com --shard i/n` and `sabian merge` against the one-process run, on the quick
//! version (40 noise draws, one walk per model and control): 6 units as 3 shards. The merge
//! assembles the units with the one-process run's own functions, so its tables (`tables.md`,
//! what `--markdown` prints), its figures and every number of com-calibration.toml but the
//! wall-clock ones must be the same, byte for byte.

use std::path::Path;
use std::process::{Command, Output};

fn twin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_zmp-twin"))
        .args(args)
        .output()
        .unwrap()
}

fn ok(o: Output, what: &str) -> String {
    assert!(
        o.status.success(),
        "{what} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8(o.stdout).unwrap()
}

/// com-calibration.toml without the lines that hold wall-clock times (`wall_s`, the real-time
/// factor: how fast this machine was, not what was computed).
fn toml_numbers(dir: &Path) -> String {
    std::fs::read_to_string(dir.join("com-calibration.toml"))
        .unwrap()
        .lines()
        .filter(|l| !l.contains("wall_s") && !l.contains("real_time_factor"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn three_shards_merge_to_the_one_process_tables_and_figures() {
    let d = tempfile::tempdir().unwrap();
    let one = d.path().join("one");
    let job = d.path().join("job");
    let (o, j) = (one.to_str().unwrap(), job.to_str().unwrap());
    let tables = ok(
        twin(&[
            "sabian",
            "calibrate-com",
            "--quick",
            "--markdown",
            "--out",
            o,
        ]),
        "one-process run",
    );
    // One after the other with --steal: shard 1 runs its part, then takes every unit of the
    // others; shards 2 and 3 find their units claimed and run none.
    for i in 1..=3 {
        let s = format!("{i}/3");
        let args = [
            "sabian",
            "calibrate-com",
            "--quick",
            "--shard",
            &s,
            "--steal",
            "--out",
            j,
        ];
        let said = ok(twin(&args), "shard");
        if i == 1 {
            assert!(said.contains("ran 6 units (0 failed), "), "{said}");
        } else {
            assert!(
                said.contains("ran 0 units (0 failed), 0 from other parts"),
                "{said}"
            );
        }
    }
    let units = std::fs::read_dir(job.join("units")).unwrap().count();
    assert_eq!(
        units, 6,
        "one block of 40 draws and one walk unit per model"
    );
    let merged = ok(twin(&["sabian", "merge", j]), "merge");
    assert!(merged.contains("predicted wall time"), "{merged}");
    let md = std::fs::read_to_string(job.join("tables.md")).unwrap();
    assert!(md.contains("| ours: D-optimal | 12 |"), "{md}");
    assert!(
        md == tables,
        "tables.md differs from --markdown:\n{md}\n---\n{tables}"
    );
    assert_eq!(toml_numbers(&job), toml_numbers(&one));
    for f in std::fs::read_dir(&one).unwrap() {
        let name = f.unwrap().file_name();
        if name.to_string_lossy().ends_with(".svg") {
            let a = std::fs::read(one.join(&name)).unwrap();
            let b = std::fs::read(job.join(&name)).unwrap();
            assert!(a == b, "{name:?} differs");
        }
    }
    // A job of other options in the same folder is refused.
    let e = twin(&[
        "sabian",
        "calibrate-com",
        "--runs",
        "2",
        "--shard",
        "1/3",
        "--out",
        j,
    ]);
    assert!(!e.status.success());
    assert!(String::from_utf8_lossy(&e.stderr).contains("holds another job"));
}
