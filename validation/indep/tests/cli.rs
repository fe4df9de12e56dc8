//! The `zmp-indep-sim` binary: campaign and truth written, overwrite refused, errors named.

use std::fs;
use std::process::Command;

const DESIGN: &str = r#"
name = "cli test"
operating_points = [[0.0, 0.0], [0.02, 0.01]]
amplitudes = [0.004]
omegas = [1.0, 6.0, 12.0]
excited = ["x", "y"]
sample_rate_hz = 200.0
transient_s = 1.0
periods = 2
min_steady_s = 2.0
quantisation = 0.0001
seed = 4
"#;

fn run(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_zmp-indep-sim"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn the_binary_writes_a_campaign_and_its_truth_apart() {
    let dir = tempfile::tempdir().unwrap();
    let design = dir.path().join("design.toml");
    fs::write(&design, DESIGN).unwrap();
    let out = dir.path().join("camp");
    let truth = dir.path().join("truth.json");
    let (o, d, t) = (
        out.to_str().unwrap(),
        design.to_str().unwrap(),
        truth.to_str().unwrap(),
    );
    let args = [
        "--seed",
        "9",
        "--scenario",
        "pair:time_delay,sensor_drift",
        "--out",
        o,
        "--design",
        d,
        "--truth",
        t,
    ];
    let res = run(&[&args[..], &["--json"]].concat());
    assert!(
        res.status.success(),
        "{}",
        String::from_utf8_lossy(&res.stderr)
    );
    let summary: serde_json::Value = serde_json::from_slice(&res.stdout).unwrap();
    assert_eq!(summary["records"], 12);
    assert!(
        !String::from_utf8_lossy(&res.stdout).contains("time_delay"),
        "the summary leaks the truth"
    );
    let robot = zmp_indep_sim::Robot::from_json(&fs::read_to_string(&truth).unwrap()).unwrap();
    assert_eq!(robot.hidden_names(), ["time_delay", "sensor_drift"]);
    let doc: toml::Table = fs::read_to_string(out.join("campaign.toml"))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(doc["records"].as_array().unwrap().len(), 12);
    assert_eq!(fs::read_dir(out.join("records")).unwrap().count(), 12);

    // Again without --force: refused, both files untouched.
    let before = fs::read_to_string(&truth).unwrap();
    let res = run(&args);
    assert!(!res.status.success());
    assert!(String::from_utf8_lossy(&res.stderr).contains("already exists"));
    assert_eq!(fs::read_to_string(&truth).unwrap(), before);
    // With --force and another seed: replaced.
    let mut forced = args.to_vec();
    forced[1] = "10";
    forced.push("--force");
    assert!(run(&forced).status.success());
    assert_ne!(fs::read_to_string(&truth).unwrap(), before);
}

#[test]
fn bad_input_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camp");
    let o = out.to_str().unwrap();
    let res = run(&["--seed", "1", "--scenario", "single:gravity", "--out", o]);
    assert!(!res.status.success());
    assert!(String::from_utf8_lossy(&res.stderr).contains("unknown effect `gravity`"));
    let design = dir.path().join("bad.toml");
    fs::write(
        &design,
        DESIGN.replace(
            "sample_rate_hz = 200.0",
            "sample_rate_hz = 200.0\nsample_rate = 1",
        ),
    )
    .unwrap();
    let res = run(&[
        "--seed",
        "1",
        "--out",
        o,
        "--design",
        design.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&res.stderr);
    assert!(
        !res.status.success() && err.contains("bad.toml") && err.contains("sample_rate"),
        "{err}"
    );
    assert!(!out.exists());
}
