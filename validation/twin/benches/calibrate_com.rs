//! The whole second-seed experiment as a user runs it: `zmp-twin sabian calibrate-com` (what
//! `cargo xtask calibrate-com` runs once built) as a process, from start to exit, files written:
//! the calibrations (14 postures held, 200 noise draws of each design), 5 plans, 5 walks per
//! model open loop and 5 with the Torso Position Control (50 walks of 15.36 s), the report.
//! And `--quick` (40 draws, one walk per model and control), the demo's step. Two threads, as on
//! the 2-core machine the targets are set for: the full run within 10 minutes, `--quick` within
//! 1 minute (issue 56).

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use std::process::Command;
use std::time::Duration;

fn run(args: &[&str]) {
    let dir = tempfile::tempdir().expect("temporary folder");
    let out = Command::new(env!("CARGO_BIN_EXE_zmp-twin"))
        .args(["sabian", "calibrate-com", "--force", "--out"])
        .arg(dir.path())
        .args(args)
        .output()
        .expect("run zmp-twin");
    assert!(
        out.status.success(),
        "zmp-twin sabian calibrate-com {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(dir.path().join("report.html").exists());
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("calibrate_com_process");
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1));
    g.measurement_time(Duration::from_secs(60));
    g.bench_function("quick", |b| b.iter(|| run(&["--quick"])));
    g.measurement_time(Duration::from_secs(300));
    g.bench_function("full_with_tpc", |b| b.iter(|| run(&[])));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
