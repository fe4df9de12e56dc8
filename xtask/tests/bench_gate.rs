//! The instruction-count gate of `cargo xtask bench` as CI uses it, end to end: on the plant
//! step with every effect on, a baseline saved by one run is met by three more runs with
//! identical counts, and the test-only planted regression of `Plant::step` (about 6 % more
//! instructions, feature `bench-planted-regression` of zmp-models) fails the gate with a
//! message naming the bench, the old and the new count.
//!
//! Needs valgrind (installed by `cargo xtask setup`) and builds the real-time count binary
//! (release; with the planted feature only `zmp-models` and `zmp-bench` are recompiled). The
//! baseline is a temporary one, so this tests the gate's mechanism on any machine; the
//! committed `bench/baseline.toml` is checked by the gate step of `cargo xtask ci`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BENCH: &str = "plant_step/all_effects";

fn xtask(args: &[&str], baseline: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .arg("bench")
        .args(["--counts-only", "--json", "--only", BENCH, "--baseline"])
        .arg(baseline)
        .args(args)
        .output()
        .expect("running xtask bench")
}

/// The instruction count of `BENCH` in the JSON that `xtask bench --json` printed.
fn count(out: &Output) -> u64 {
    let stdout = String::from_utf8_lossy(&out.stdout);
    let v: serde_json::Value = serde_json::from_str(stdout.trim()).unwrap_or_else(|e| {
        panic!(
            "xtask bench printed no JSON ({e}):\n{stdout}\n{}",
            String::from_utf8_lossy(&out.stderr)
        )
    });
    let counts = v["counts"].as_array().expect("counts");
    assert_eq!(counts.len(), 1, "{v}");
    assert_eq!(counts[0]["name"], BENCH);
    counts[0]["instructions"].as_u64().expect("instructions")
}

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("zmp-bench-gate-test-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("scratch dir");
    d
}

#[test]
fn gate_holds_three_runs_and_catches_the_planted_regression() {
    let dir = scratch();
    let baseline = dir.join("baseline.toml");

    let saved = xtask(&["--save-baseline"], &baseline);
    assert!(
        saved.status.success(),
        "saving the baseline failed:\n{}",
        String::from_utf8_lossy(&saved.stderr)
    );
    let c0 = count(&saved);
    assert!(c0 > 0);
    assert!(std::fs::read_to_string(&baseline)
        .expect("baseline written")
        .contains(&c0.to_string()));

    for run in 1..=3 {
        let out = xtask(&[], &baseline);
        assert!(
            out.status.success(),
            "run {run} of the gate failed without any change:\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        assert_eq!(
            count(&out),
            c0,
            "run {run}: the count moved without a change"
        );
    }

    let planted = xtask(&["--planted-regression"], &baseline);
    let stderr = String::from_utf8_lossy(&planted.stderr);
    assert!(
        !planted.status.success(),
        "the gate passed the planted regression:\n{stderr}"
    );
    let c1 = count(&planted);
    let change = c1 as f64 / c0 as f64 - 1.0;
    assert!(
        (0.04..0.09).contains(&change),
        "the planted regression should add about 6 % instructions, it added {:.2} %",
        100.0 * change
    );
    let failure = stderr
        .lines()
        .find(|l| l.contains("REGRESSED"))
        .unwrap_or_else(|| panic!("no REGRESSED line in:\n{stderr}"));
    for needle in [BENCH, &c0.to_string(), &c1.to_string()] {
        assert!(failure.contains(needle), "{needle:?} not in {failure:?}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
