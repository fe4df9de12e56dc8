//! Running the `xtask` binary from the command-line tests, and what they share (a tiny
//! campaign, the checks of a failed run).
#![allow(dead_code)] // each test binary uses its own part

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs `xtask ARGS` in `dir`.
pub fn xtask(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("xtask runs")
}

/// Its standard output, after asserting that it succeeded (`what` names it in the failure).
pub fn ok(out: Output, what: &str) -> String {
    assert!(
        out.status.success(),
        "{what} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("utf-8")
}

/// A design of 8 short records (one operating point, four frequencies, both channels, 100 Hz):
/// every command on it takes a fraction of a second.
pub const DESIGN: &str = "operating_points = [[0.0, 0.0]]\namplitudes = [0.005]\n\
    omegas = [0.8, 2.0, 5.0, 12.0]\nexcited = [\"x\", \"y\"]\nsample_rate_hz = 100.0\n\
    transient_s = 1.0\nperiods = 3\nmin_steady_s = 3.0\nzmp_noise_std = 0.0005\n\
    quantisation = 0.0001\nseed = 7\n";

/// Standard error of a run that must fail with exit code 1 (an error, not a panic or a usage
/// error).
pub fn fails(out: Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(
        out.status.code(),
        Some(1),
        "{what}: expected an error, got {:?}: {}{err}",
        out.status,
        String::from_utf8_lossy(&out.stdout)
    );
    assert!(!err.contains("panicked"), "{what}: {err}");
    err
}

pub fn paper() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/params/silo2-paper.toml")
}

/// Simulates the tiny campaign `name` in `dir` (on `model`, default the paper's).
pub fn campaign(dir: &Path, name: &str, model: Option<&Path>) {
    let design = dir.join("design.toml");
    std::fs::write(&design, DESIGN).unwrap();
    let m = model.map_or_else(paper, Path::to_path_buf);
    ok(
        xtask(
            &[
                "simulate",
                "--model",
                m.to_str().unwrap(),
                "--design",
                "design.toml",
                "--out",
                name,
            ],
            dir,
        ),
        "simulate",
    );
}

/// The paper's model with a servo latency added (the loop finds an effect on its campaign).
pub fn delayed_model(dir: &Path) -> PathBuf {
    let p = dir.join("delayed.toml");
    let mut text = std::fs::read_to_string(paper()).unwrap();
    text.push_str("\n[time_delay]\ndelay = 0.04\n");
    std::fs::write(&p, text).unwrap();
    p
}

/// Hidden entries (temporaries) in `dir`, markers aside.
pub fn hidden(dir: &Path) -> Vec<String> {
    let Ok(rd) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    rd.filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && !n.starts_with(".zmp-"))
        .collect()
}

pub fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}
