//! `cargo xtask design-next` and `simulate --append` as a user runs them: the design file
//! written and refused without `--force`, `--json` for scripts, named errors, and the
//! designed records appended to the campaign.

mod support;

use std::path::Path;
use support::{ok, xtask};

/// A campaign of the paper's plant with a 10 ms delay, up to 4 rad/s (where a refitted
/// low-pass absorbs it), and the two rival models: without and with the delay.
fn setup(dir: &Path) {
    std::fs::write(
        dir.join("design.toml"),
        "operating_points = [[0.0, 0.0]]\namplitudes = [0.003, 0.008]\n\
         omegas = [0.5, 0.9, 1.6, 2.4, 4.0]\nexcited = [\"x\", \"y\"]\n\
         sample_rate_hz = 200.0\ntransient_s = 3.0\nperiods = 4\nmin_steady_s = 8.0\n\
         zmp_noise_std = 0.0005\nquantisation = 0.0001\nseed = 3\n",
    )
    .unwrap();
    let paper = std::fs::read_to_string(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/params/silo2-paper.toml"),
    )
    .unwrap();
    std::fs::write(dir.join("plain.toml"), &paper).unwrap();
    std::fs::write(
        dir.join("delay.toml"),
        paper + "\n[time_delay]\ndelay = 0.01\n",
    )
    .unwrap();
    ok(
        xtask(
            &[
                "simulate",
                "--model",
                "delay.toml",
                "--design",
                "design.toml",
                "--out",
                "camp",
            ],
            dir,
        ),
        "simulate",
    );
}

#[test]
fn design_next_writes_a_design_that_simulate_appends() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    setup(dir);
    let args = [
        "design-next",
        "camp",
        "--model",
        "plain.toml",
        "--model",
        "delay.toml",
        "--json",
    ];
    let out = ok(xtask(&args, dir), "design-next");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    let records = v["records"].as_array().unwrap();
    assert!(!records.is_empty(), "{out}");
    assert_eq!(v["design"], "camp-design-next.toml");
    assert!(v["decided"].as_bool().unwrap(), "{out}");
    assert_eq!(v["separations"].as_array().unwrap().len(), 2);
    assert!(v["total_time_s"].as_f64().unwrap() > 0.0);
    let text = std::fs::read_to_string(dir.join("camp-design-next.toml")).unwrap();
    assert_eq!(text.matches("[[records]]").count(), records.len());

    // Not overwritten without --force, and nothing changed.
    let again = xtask(&args, dir);
    assert!(!again.status.success());
    assert!(
        String::from_utf8_lossy(&again.stderr).contains("--force"),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    assert_eq!(
        std::fs::read_to_string(dir.join("camp-design-next.toml")).unwrap(),
        text
    );

    let append = [
        "simulate",
        "--model",
        "delay.toml",
        "--design",
        "camp-design-next.toml",
        "--append",
        "camp",
        "--out",
        "extended",
        "--json",
    ];
    let out = ok(xtask(&append, dir), "simulate --append");
    let v: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(v["records"], 20 + records.len());
    assert_eq!(v["simulated"], records.len());
    let manifest = std::fs::read_to_string(dir.join("extended/campaign.toml")).unwrap();
    assert!(manifest.contains("records/r020.csv"), "{manifest}");
}

#[test]
fn design_next_names_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    setup(dir);
    let one = xtask(&["design-next", "camp", "--model", "plain.toml"], dir);
    assert!(!one.status.success());
    let err = String::from_utf8_lossy(&one.stderr);
    assert!(err.contains("two or three rival models; got 1"), "{err}");
    let same = xtask(
        &[
            "design-next",
            "camp",
            "--model",
            "plain.toml",
            "--model",
            "plain.toml",
        ],
        dir,
    );
    let err = String::from_utf8_lossy(&same.stderr);
    assert!(err.contains("have the same structure"), "{err}");
    let missing = xtask(
        &[
            "design-next",
            "nowhere",
            "--model",
            "plain.toml",
            "--model",
            "delay.toml",
        ],
        dir,
    );
    let err = String::from_utf8_lossy(&missing.stderr);
    assert!(err.contains("nowhere"), "{err}");
    assert!(!dir.join("nowhere-design-next.toml").exists());
}
