//! Bounded inputs and limits (issue 53): reads within a size limit, also under a memory limit
//! (defect 7, and defect 6's crafted file as `identify` meets it), and `--time-limit` as a
//! bounded duration (defect 8).

mod support;

use std::path::Path;
use std::process::{Command, Output};
use support::{campaign, fails, ok, xtask};

/// `xtask ARGS` in `dir` under a 1 GiB limit on the process's memory (`ulimit -v`), two
/// worker threads, killed after two minutes if it has not ended.
fn under_memory_limit(args: &[&str], dir: &Path) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1048576 && exec timeout -s KILL 120 \"$@\"")
        .arg("sh")
        .arg(env!("CARGO_BIN_EXE_xtask"))
        .args(["--threads", "2"])
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

/// Defect 7: a record or `campaign.toml` symbolically linked to /dev/zero grew memory without
/// bound (under a memory limit: an abort, rc 134). Now each input is read within its limit and
/// the error names the file and the limit; the process exits 1. Defect 6's crafted record (a
/// wide header over 3 MB of blank lines) likewise, as `identify` meets it.
#[test]
fn defect_7_reads_stop_at_their_limit_with_a_named_error() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    campaign(d, "camp", None);
    // Each limit still lets the ordinary campaign through under the memory limit.
    let out = under_memory_limit(&["identify", "camp", "--out", "m.toml", "--json"], d);
    ok(out, "identify under the memory limit");

    let copy = |name: &str| {
        let c = d.join(name);
        std::fs::create_dir_all(c.join("records")).unwrap();
        for e in std::fs::read_dir(d.join("camp/records")).unwrap() {
            let e = e.unwrap();
            std::fs::copy(e.path(), c.join("records").join(e.file_name())).unwrap();
        }
        std::fs::copy(d.join("camp/campaign.toml"), c.join("campaign.toml")).unwrap();
        c
    };
    // A record that never ends.
    let c = copy("zero-record");
    std::fs::remove_file(c.join("records/r003.csv")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", c.join("records/r003.csv")).unwrap();
    let err = fails(
        under_memory_limit(&["identify", "zero-record", "--out", "z1.toml"], d),
        "a record from /dev/zero",
    );
    assert!(
        err.contains("records/r003.csv") && err.contains("the limit for a record"),
        "{err}"
    );
    // A campaign.toml that never ends.
    let c = copy("zero-manifest");
    std::fs::remove_file(c.join("campaign.toml")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", c.join("campaign.toml")).unwrap();
    let err = fails(
        under_memory_limit(&["identify", "zero-manifest", "--out", "z2.toml"], d),
        "campaign.toml from /dev/zero",
    );
    assert!(
        err.contains("campaign.toml") && err.contains("the limit for campaign.toml"),
        "{err}"
    );
    // A model file that never ends.
    std::os::unix::fs::symlink("/dev/zero", d.join("zero.toml")).unwrap();
    let err = fails(
        under_memory_limit(
            &[
                "identify",
                "camp",
                "--model",
                "zero.toml",
                "--out",
                "z3.toml",
            ],
            d,
        ),
        "a model from /dev/zero",
    );
    assert!(err.contains("zero.toml") && err.contains("limit"), "{err}");
    // The crafted record: 10 000 columns over 3 MB of blank lines.
    let c = copy("crafted");
    let mut b = b"t,x_cr,y_cr,zmp_x,zmp_y".to_vec();
    for k in 0..10_000 {
        b.extend_from_slice(format!(",e{k}").as_bytes());
    }
    b.push(b'\n');
    b.resize(b.len() + 3_000_000, b'\n');
    std::fs::write(c.join("records/r000.csv"), b).unwrap();
    let err = fails(
        under_memory_limit(&["identify", "crafted", "--out", "z4.toml"], d),
        "the crafted record",
    );
    assert!(
        err.contains("records/r000.csv") && err.contains("at least 2 data rows"),
        "{err}"
    );
    for m in ["z1.toml", "z2.toml", "z3.toml", "z4.toml"] {
        assert!(!d.join(m).exists(), "{m} written from bad input");
    }
}

/// Defect 8: `loop --time-limit 9223372036854775807` panicked with a backtrace (rc 101). Now
/// the limit is parsed as a duration of at most 7 days: past it a usage error that names the
/// option and the maximum; a duration with a unit is accepted; 0 is no limit.
#[test]
fn defect_8_the_time_limit_is_a_bounded_duration() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    campaign(d, "camp", None);
    for huge in ["9223372036854775807", "604801", "169h", "1e30"] {
        let out = xtask(&["loop", "camp", "--time-limit", huge], d);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{huge}: {:?} {err}", out.status);
        assert!(
            err.contains("--time-limit") && err.contains("7 days") && !err.contains("panicked"),
            "{huge}: {err}"
        );
    }
    let out = xtask(&["loop", "camp", "--time-limit", "ten"], d);
    assert_eq!(out.status.code(), Some(2));
    for (limit, out) in [("15min", "l1"), ("604800", "l2"), ("0", "l3")] {
        let v: serde_json::Value = serde_json::from_str(&ok(
            xtask(
                &[
                    "loop",
                    "camp",
                    "--time-limit",
                    limit,
                    "--out",
                    out,
                    "--json",
                ],
                d,
            ),
            limit,
        ))
        .unwrap();
        assert_eq!(v["time_limit_reached"], false, "{limit}");
    }
}
