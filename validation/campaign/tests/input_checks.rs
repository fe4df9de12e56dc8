//! Inputs checked against themselves (issue 53): a record's stated `omega` against the
//! dominant line of its command (defect 3), a record listed twice (defect 4), headers of any
//! width and records of any size read in linear time and memory, without a panic or an abort
//! under a memory limit (defect 6, with the crafted file that aborted the reader).

use proptest::prelude::*;
use std::f64::consts::PI;
use std::path::{Path, PathBuf};
use std::process::Command;
use zmp_campaign::{
    parse_manifest, parse_record, read_campaign, write_campaign, Campaign, CampaignError, Record,
    RecordMeta,
};
use zmp_models::{logspace, Axis};

/// A written campaign of the reference design's shape: 14 frequencies from 0.5 to 15 rad/s on
/// both channels, at 200 Hz, each record 3 s of transient and four periods (at least 8 s) of
/// steady state; the excited reference a 5 mm sine around the operating point (with the 0.1 mm
/// resolution of a real command), the ZMP 0.9 of the references.
fn written(dir: &Path) -> Campaign {
    let dt = 1.0 / 200.0;
    let mut records = Vec::new();
    for excited in [Axis::X, Axis::Y] {
        for omega in logspace(0.5, 15.0, 14) {
            let steady = (4.0 * 2.0 * PI / omega).max(8.0);
            let n = ((3.0 + steady) / dt).round() as usize + 1;
            let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
            let op = [0.0, 0.02];
            let reference = |axis: Axis| -> Vec<f64> {
                t.iter()
                    .map(|t| {
                        let sine = if axis == excited {
                            0.005 * (omega * t).sin()
                        } else {
                            0.0
                        };
                        ((op[axis.index()] + sine) / 1e-4).round() * 1e-4
                    })
                    .collect()
            };
            let (x_cr, y_cr) = (reference(Axis::X), reference(Axis::Y));
            records.push(Record {
                meta: RecordMeta {
                    file: PathBuf::from(format!("records/r{:03}.csv", records.len())),
                    excited,
                    omega,
                    amplitude: 0.005,
                    operating_point: op,
                },
                zmp_x: x_cr.iter().map(|v| 0.9 * v).collect(),
                zmp_y: y_cr.iter().map(|v| 0.9 * v).collect(),
                t,
                x_cr,
                y_cr,
                extra: Vec::new(),
            });
        }
    }
    let c = Campaign {
        name: Some("sines".into()),
        robot: None,
        sample_rate_hz: Some(200.0),
        records,
    };
    write_campaign(dir, &c, false).unwrap();
    c
}

/// `campaign.toml` with record `k`'s omega replaced by `omega`.
fn restate(dir: &Path, k: usize, omega: f64) {
    let path = dir.join("campaign.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    let mut out = String::new();
    let mut record = None::<usize>;
    for line in text.lines() {
        if line == "[[records]]" {
            record = Some(record.map_or(0, |r| r + 1));
        }
        if record == Some(k) && line.starts_with("omega = ") {
            out.push_str(&format!("omega = {omega:?}\n"));
        } else {
            out.push_str(line);
            out.push('\n');
        }
    }
    std::fs::write(&path, out).unwrap();
}

/// Defect 3: one record's omega stated wrong was read, fitted at that frequency, and inflated
/// the noise floor 40-1000x. Now: an error naming campaign.toml, the record and `omega`, when
/// the stated value is further from the command's dominant line than the record's frequency
/// resolution 2 pi / T; a value within it is accepted (the documented tolerance); every
/// record of a correct campaign reads (no false alarm, 0.5-15 rad/s).
#[test]
fn defect_3_a_stated_omega_is_checked_against_the_records_command() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("camp");
    let c = written(&dir);
    assert_eq!(read_campaign(&dir).unwrap().records.len(), c.records.len());
    for k in [3, 20, c.records.len() - 1] {
        let r = &c.records[k];
        let span = r.len() as f64 * r.dt();
        let resolution = 2.0 * PI / span;
        // Three resolutions off, and a factor 1.6 (the kind of slip that reaches a file):
        // refused, named.
        for wrong in [r.meta.omega + 3.0 * resolution, 1.6 * r.meta.omega] {
            restate(&dir, k, wrong);
            let e = read_campaign(&dir).unwrap_err();
            let msg = e.to_string();
            assert!(matches!(e, CampaignError::Invalid { .. }), "{msg}");
            assert_eq!(e.file(), dir.join("campaign.toml"), "{msg}");
            assert_eq!((e.record(), e.field()), (Some(k), Some("omega")), "{msg}");
            assert!(
                msg.contains(&format!("records[{k}].omega")) && msg.contains("dominant line"),
                "{msg}"
            );
        }
        // A third of a resolution off: within the record's resolution, accepted.
        restate(&dir, k, r.meta.omega + resolution / 3.0);
        read_campaign(&dir).unwrap();
        restate(&dir, k, r.meta.omega);
    }
    read_campaign(&dir).unwrap();
}

/// Defect 4: a record listed twice in campaign.toml was read twice and counted twice in every
/// fit (its confidence overstated). Now an error naming the second listing and the first.
#[test]
fn defect_4_a_record_listed_twice_is_an_error() {
    let record = |file: &str, omega: f64| {
        format!(
            "\n[[records]]\nfile = \"{file}\"\nexcited = \"x\"\nomega = {omega}\n\
             amplitude = 0.005\noperating_point = {{ x = 0.0, y = 0.0 }}\n"
        )
    };
    let head = "format = \"zmp-campaign/1\"\n";
    let ok = format!(
        "{head}{}{}",
        record("records/a.csv", 1.0),
        record("records/b.csv", 2.0)
    );
    assert_eq!(
        parse_manifest(&ok, Path::new("c/campaign.toml"))
            .unwrap()
            .records
            .len(),
        2
    );
    // The same file, written alike or another way (./, a/../), with the same or another omega.
    for second in ["records/a.csv", "./records/a.csv", "records/x/../a.csv"] {
        for omega in [1.0, 3.0] {
            let text = format!(
                "{head}{}{}{}",
                record("records/a.csv", 1.0),
                record("records/b.csv", 2.0),
                record(second, omega)
            );
            let e = parse_manifest(&text, Path::new("c/campaign.toml")).unwrap_err();
            let msg = e.to_string();
            assert_eq!((e.record(), e.field()), (Some(2), Some("file")), "{msg}");
            assert!(msg.contains("also the file of records[0]"), "{msg}");
        }
    }
    // Through the reader too (a campaign written, then a record listed again by hand).
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("camp");
    written(&dir);
    let path = dir.join("campaign.toml");
    let mut text = std::fs::read_to_string(&path).unwrap();
    let first = text.find("[[records]]").unwrap();
    let second = text[first + 1..].find("[[records]]").unwrap() + first + 1;
    let again = text[first..second].to_string();
    text.push('\n');
    text.push_str(&again);
    std::fs::write(&path, text).unwrap();
    let e = read_campaign(&dir).unwrap_err();
    assert!(e.to_string().contains("also the file of records[0]"), "{e}");
}

fn meta() -> RecordMeta {
    RecordMeta {
        file: PathBuf::from("r.csv"),
        excited: Axis::X,
        omega: 1.0,
        amplitude: 0.005,
        operating_point: [0.0, 0.0],
    }
}

/// The file that aborted the reader under a memory limit (rc 134): a header of 10 000 columns
/// and 3 MB of blank lines; each column's room was reserved for every line (230 GB).
fn crafted() -> Vec<u8> {
    let mut b = b"t,x_cr,y_cr,zmp_x,zmp_y".to_vec();
    for k in 0..10_000 {
        b.extend_from_slice(format!(",e{k}").as_bytes());
    }
    b.push(b'\n');
    b.resize(b.len() + 3_000_000, b'\n');
    b
}

/// Runs this test binary's `role` test in a child under `ulimit -v` (1 GiB), as a user's
/// shell with a memory limit would run a command; returns its exit status and output.
fn under_memory_limit(role: &str, arg: &str) -> std::process::Output {
    let exe = std::env::current_exe().unwrap();
    Command::new("sh")
        .arg("-c")
        .arg("ulimit -v 1048576 && exec \"$0\" \"$1\" --exact --nocapture --test-threads=1")
        .arg(exe)
        .arg(role)
        .env("ZMP_TEST_ROLE_ARG", arg)
        .output()
        .unwrap()
}

/// Role: parses the crafted file (run under the memory limit by the test below).
#[test]
fn role_parse_crafted() {
    if std::env::var("ZMP_TEST_ROLE_ARG").as_deref() != Ok("crafted") {
        return;
    }
    let e = parse_record(&crafted(), Path::new("r.csv"), 0, meta(), None).unwrap_err();
    println!("named: {e}");
}

/// Defect 6 (memory): under a 1 GiB memory limit the crafted 3 MB file aborted the process;
/// now it is an error naming the file (room is reserved for at most one value per byte of the
/// file, fallibly). The child's exit is asserted: 0 with the error printed, not 134.
#[test]
fn defect_6_a_crafted_header_neither_aborts_nor_takes_memory_beyond_the_file() {
    let out = under_memory_limit("role_parse_crafted", "crafted");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{:?}: {}{}",
        out.status,
        stdout,
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        stdout.contains("named: r.csv") && stdout.contains("at least 2 data rows"),
        "{stdout}"
    );
}

/// A header of `width` cells (names from a small alphabet: duplicates, empty names, the
/// required names at random places), then `rows` rows of `width` cells and `blank` blank
/// lines spread through them.
fn csv(names: &[String], rows: usize, blank: usize) -> Vec<u8> {
    let mut b = names.join(",").into_bytes();
    b.push(b'\n');
    for k in 0..rows {
        let row: Vec<String> = (0..names.len())
            .map(|j| format!("{}", (k * 7 + j) as f64 * 0.01))
            .collect();
        b.extend_from_slice(row.join(",").as_bytes());
        b.push(b'\n');
        if blank > 0 && k % 3 == 0 {
            b.resize(b.len() + blank, b'\n');
        }
    }
    b
}

fn header() -> impl Strategy<Value = Vec<String>> {
    let name = prop_oneof![
        4 => "[a-z_]{1,6}".prop_map(String::from),
        1 => prop::sample::select(vec!["t", "x_cr", "y_cr", "zmp_x", "zmp_y", ""]).prop_map(String::from),
    ];
    (prop::collection::vec(name, 0..3000), any::<bool>()).prop_map(|(mut v, required)| {
        if required {
            for (k, r) in ["t", "x_cr", "y_cr", "zmp_x", "zmp_y"].iter().enumerate() {
                let at = (k * 7919) % (v.len() + 1);
                v.insert(at, r.to_string());
            }
        }
        v
    })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any header (0-3000 cells, duplicates and empty names included) and any record size
    /// (0-200 rows, runs of blank lines): an Ok record of the header's required columns or an
    /// error naming the file; never a panic. (Under a memory limit, no abort: the role below
    /// runs these cases in a child under `ulimit -v`.)
    #[test]
    fn headers_and_record_sizes_never_panic(names in header(), rows in 0usize..200, blank in 0usize..5000) {
        let bytes = csv(&names, rows, blank);
        match parse_record(&bytes, Path::new("r.csv"), 0, meta(), None) {
            Ok(r) => {
                prop_assert_eq!(r.t.len(), r.zmp_y.len());
                prop_assert!(r.len() >= 2);
            }
            Err(e) => prop_assert_eq!(e.file(), Path::new("r.csv")),
        }
    }
}

/// Role: the property above under the memory limit.
#[test]
fn role_property_under_limit() {
    if std::env::var("ZMP_TEST_ROLE_ARG").as_deref() != Ok("property") {
        return;
    }
    let mut runner = proptest::test_runner::TestRunner::new(ProptestConfig::with_cases(64));
    runner
        .run(
            &(header(), 0usize..200, 0usize..200_000),
            |(names, rows, blank)| {
                let bytes = csv(&names, rows, blank);
                let _ = parse_record(&bytes, Path::new("r.csv"), 0, meta(), None);
                Ok(())
            },
        )
        .unwrap();
    println!("property held");
}

#[test]
fn headers_and_record_sizes_never_abort_under_a_memory_limit() {
    let out = under_memory_limit("role_property_under_limit", "property");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success() && stdout.contains("property held"),
        "{:?}: {stdout}{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The documented limits: a header wider than `MAX_COLUMNS` is an error naming the file and
/// the limit (read in linear time: the bench `campaign_header` parses a million columns).
#[test]
fn a_header_wider_than_the_limit_is_named() {
    use zmp_campaign::MAX_COLUMNS;
    let mut b = b"t,x_cr,y_cr,zmp_x,zmp_y".to_vec();
    for _ in 0..MAX_COLUMNS {
        b.extend_from_slice(b",a");
    }
    b.extend_from_slice(b"\n");
    let e = parse_record(&b, Path::new("wide.csv"), 0, meta(), None).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.starts_with("wide.csv:1") && msg.contains(&format!("limit of {MAX_COLUMNS} columns")),
        "{msg}"
    );
}
