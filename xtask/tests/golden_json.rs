//! The `--json` outputs of `identify`, `diagnose` and `loop` on a fixed campaign, byte for
//! byte against files recorded before the validation crate was split into crates by
//! responsibility (issue 54): a move of code must not move a number.
//!
//! The campaign: the seed's SILO2 model with a 40 ms servo delay, one operating point, two
//! amplitudes, five frequencies, seed 7 (20 records, about a second per command).
//!
//! A deliberate change of these outputs (a new field, a better fit) re-records them with
//! `ZMP_UPDATE_GOLDEN=1 cargo test --release -p xtask --test golden_json`; the commit says why.

mod support;

use std::path::Path;
use support::{ok, xtask};

/// Compares `got` with the golden file `name`, or writes it with `ZMP_UPDATE_GOLDEN=1`.
fn golden(name: &str, got: &str) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/golden")
        .join(name);
    if std::env::var("ZMP_UPDATE_GOLDEN").is_ok_and(|v| v == "1") {
        std::fs::write(&path, got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap();
    if want != got {
        let line = want
            .lines()
            .zip(got.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(want.lines().count().min(got.lines().count()));
        panic!(
            "{name} differs from the recorded output from line {}: recorded {:?}, now {:?}",
            line + 1,
            want.lines().nth(line),
            got.lines().nth(line)
        );
    }
}

#[test]
fn identify_diagnose_and_loop_print_the_recorded_json() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(
        dir.join("design.toml"),
        "operating_points = [[0.0, 0.0]]\namplitudes = [0.003, 0.008]\n\
         omegas = [0.5, 1.5, 4.0, 9.0, 14.0]\nexcited = [\"x\", \"y\"]\n\
         sample_rate_hz = 200.0\ntransient_s = 3.0\nperiods = 4\nmin_steady_s = 8.0\n\
         zmp_noise_std = 0.0005\nquantisation = 0.0001\nseed = 7\n",
    )
    .unwrap();
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/params/silo2-paper.toml");
    let truth = std::fs::read_to_string(paper).unwrap() + "\n[time_delay]\ndelay = 0.04\n";
    std::fs::write(dir.join("truth.toml"), truth).unwrap();
    ok(
        xtask(
            &[
                "simulate",
                "--model",
                "truth.toml",
                "--design",
                "design.toml",
                "--out",
                "camp",
            ],
            dir,
        ),
        "simulate",
    );
    let id = ok(
        xtask(&["identify", "camp", "--out", "id.toml", "--json"], dir),
        "identify",
    );
    golden("id.json", &id);
    let diag = ok(
        xtask(&["diagnose", "camp", "--model", "id.toml", "--json"], dir),
        "diagnose",
    );
    golden("diag.json", &diag);
    let lp = ok(
        xtask(&["loop", "camp", "--out", "lp", "--json"], dir),
        "loop",
    );
    golden("loop.json", &lp);
}
