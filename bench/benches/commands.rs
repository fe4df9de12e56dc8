//! The commands as a user runs them: `xtask identify`, `xtask compare` and `xtask diagnose` as
//! processes of the release-built binary (what `cargo xtask <verb>` runs once built) on the
//! reference virtual SILO2 campaign (168 records, ~683k rows, ~25 MB of CSV), from process start
//! to exit, files written included. Beside them, in the same run and interleaved, the numpy
//! peer of the identification (`peers/identify_numpy.py`: pyarrow CSV reading, vectorised fits,
//! 2 threads like ours) against `xtask identify`.
//!
//! The binary is `$ZMP_XTASK_BIN` (set by `cargo xtask bench`), else `<target>/release/xtask`
//! (build it with `cargo build --release -p xtask`). Python: `$ZMP_PYTHON`, else the venv of
//! `cargo xtask setup`. Peer results are appended to `$ZMP_BENCH_RESULTS` when set.
//!
//! `command/loop_168` runs the user's loop (`xtask loop`: identify, diagnose, augment until the
//! model explains the data) on a 168-record campaign of the independent simulator
//! (`zmp-indep-sim`, which shares no physics code with `zmp-models`): the seed's acceleration
//! limit acting on the fastest records plus two hidden effects, a servo delay and a drifting ZMP
//! sensor. Before timing, one run must find both and end within 2x the noise floor (`--json`),
//! so the bench times a loop that works.
//!
//! Targets: `xtask identify` <= 0.15 s and >= 15x the numpy peer; `xtask loop` <= 20 s
//! (issue 10); one diagnosis <= 10 s (`benches/diagnose.rs`).

use criterion::measurement::WallTime;
use criterion::{criterion_group, BatchSize, BenchmarkGroup, Criterion};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};
use zmp_bench::identify::write_reference_campaign;
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions};

/// Development seed and scenario of the loop bench's robot (a pair the loop finds on the
/// blind suite's 108-record design: `indep_draw 3 pair:time_delay,sensor_drift`).
const LOOP_SEED: u64 = 3;
const LOOP_SCENARIO: &str = "pair:time_delay,sensor_drift";

/// Writes the loop bench's campaign: the blind suite's design with 14 frequencies instead of 9
/// (0.5-15 rad/s, log-spaced): 3 operating points x 2 axes x 2 amplitudes x 14 = 168 records.
fn write_loop_campaign(dir: &Path) -> PathBuf {
    let design = Design {
        omegas: (0..14).map(|k| 0.5 * 30f64.powf(k as f64 / 13.0)).collect(),
        ..Design::default()
    };
    assert_eq!(design.records().len(), 168);
    let robot = draw_with(
        LOOP_SEED,
        &LOOP_SCENARIO.parse().expect("scenario"),
        &design,
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    let camp = dir.join("loop-campaign");
    write_campaign(&robot, &design, &camp, true).expect("write the loop campaign");
    camp
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            // <target>/release/deps/<bench binary>
            let exe = std::env::current_exe().expect("current exe");
            exe.ancestors().nth(3).expect("target dir").to_path_buf()
        })
}

fn xtask_bin() -> PathBuf {
    let p = std::env::var_os("ZMP_XTASK_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| target_dir().join("release/xtask"));
    assert!(
        p.exists(),
        "the xtask binary is not at {}: run `cargo build --release -p xtask` first, or the \
         benches through `cargo xtask bench` (or set ZMP_XTASK_BIN)",
        p.display()
    );
    p
}

fn python() -> PathBuf {
    std::env::var_os("ZMP_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let home = std::env::var_os("HOME").unwrap_or_default();
            PathBuf::from(home).join(".cache/zmp-toolkit/venv/bin/python")
        })
}

/// Runs `xtask args...` to the end, output discarded; panics naming the command on failure.
fn xtask(bin: &Path, args: &[&std::ffi::OsStr]) {
    run_xtask(bin, args, Stdio::null());
}

/// Runs `xtask args... --json` to the end and returns what it prints.
fn xtask_json(bin: &Path, args: &[&std::ffi::OsStr]) -> serde_json::Value {
    let mut args = args.to_vec();
    args.push("--json".as_ref());
    let out = run_xtask(bin, &args, Stdio::piped());
    serde_json::from_slice(&out).unwrap_or_else(|e| panic!("xtask {args:?}: not JSON: {e}"))
}

/// [`xtask`] with its standard output going to `stdout` (returned when piped).
fn run_xtask(bin: &Path, args: &[&std::ffi::OsStr], stdout: Stdio) -> Vec<u8> {
    let out = Command::new(bin)
        .args(args)
        .stdin(Stdio::null())
        .stdout(stdout)
        .stderr(Stdio::piped())
        .output()
        .expect("starting xtask");
    assert!(
        out.status.success(),
        "xtask {:?} failed: {}",
        args,
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The loop on the reference robot of [`LOOP_SCENARIO`]: checked once (it must find both
/// effects and explain the campaign), then timed; each run replaces its own output folder in
/// `dir`.
fn bench_loop(g: &mut BenchmarkGroup<'_, WallTime>, bin: &Path, dir: &Path) {
    // The loop: checked once, then timed (each run replaces its own output folder).
    let loop_camp = write_loop_campaign(dir);
    let loop_out = dir.join("loop-out");
    let lp = [
        "loop".as_ref(),
        loop_camp.as_os_str(),
        "--out".as_ref(),
        loop_out.as_os_str(),
        "--force".as_ref(),
    ];
    let v = xtask_json(bin, &lp);
    let found: Vec<&str> = v["found"]
        .as_array()
        .expect("found")
        .iter()
        .filter_map(|e| e.as_str())
        .collect();
    assert!(
        found.contains(&"time_delay")
            && found.contains(&"sensor_drift")
            && v["outcome"] == "explained",
        "the loop bench's robot: found {found:?} ({}), want time_delay and sensor_drift, \
         explained: {v}",
        v["outcome"]
    );
    g.warm_up_time(Duration::from_millis(1))
        .measurement_time(Duration::from_secs(100));
    g.bench_function("loop_168", |b| b.iter(|| xtask(bin, &lp)));
}

/// `xtask identify` on the reference campaign `camp` against the numpy peer: reports the
/// ratio of their medians.
fn numpy_peer(bin: &Path, camp: &Path, ledger: &Path, identify: &[&std::ffi::OsStr]) {
    // The numpy peer against `xtask identify`, interleaved (five rounds of three of ours and one
    // of the peer) so that both see the same phases of a shared machine; medians.
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("peers/identify_numpy.py");
    let (mut ours, mut peer) = (Vec::new(), Vec::new());
    for _ in 0..5 {
        for _ in 0..3 {
            let _ = std::fs::remove_file(ledger);
            let t = Instant::now();
            xtask(bin, identify);
            ours.push(t.elapsed().as_secs_f64());
        }
        let out = match Command::new(python())
            .arg(&script)
            .arg(camp)
            .args(["--threads", "2"])
            .output()
        {
            Ok(o) if o.status.success() => o,
            Ok(o) => panic!("numpy peer failed: {}", String::from_utf8_lossy(&o.stderr)),
            Err(e) => panic!(
                "numpy peer not run ({}: {e}): run `cargo xtask setup` or set ZMP_PYTHON",
                python().display()
            ),
        };
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("peer prints JSON");
        peer.push(v["wall_s"].as_f64().expect("wall_s"));
    }
    let (o, p) = (median(ours), median(peer));
    println!(
        "command/identify_168: ours {o:.3} s per process (start to exit), numpy peer {p:.3} s \
         (read + fit, imports excluded), ratio {:.1}x (target >= 15x; ours <= 0.15 s)",
        p / o
    );
    zmp_bench::report_peer(
        "identify_168/numpy_vs_command",
        o,
        p,
        "run",
        "`xtask identify` process (start to exit) against the numpy/pyarrow peer (read + fit), \
         2 threads each, medians of 15 and 5 interleaved",
    );
}

fn bench(c: &mut Criterion) {
    let bin = xtask_bin();
    let tmp = tempfile::tempdir().expect("tempdir");
    let camp = write_reference_campaign(tmp.path());
    let model = tmp.path().join("identified.toml");
    let ledger = tmp.path().join("zmp-ledger.jsonl");
    let report = tmp.path().join("compare-report");
    let identify_args = [
        camp.as_os_str(),
        "--out".as_ref(),
        model.as_os_str(),
        "--force".as_ref(),
    ];
    let mut identify = vec!["identify".as_ref()];
    identify.extend(identify_args);
    // The model compare and diagnose start from.
    xtask(&bin, &identify);
    let compare = [
        "compare".as_ref(),
        camp.as_os_str(),
        "--model".as_ref(),
        model.as_os_str(),
        "--report".as_ref(),
        report.as_os_str(),
        "--force".as_ref(),
    ];
    let diagnose = [
        "diagnose".as_ref(),
        camp.as_os_str(),
        "--model".as_ref(),
        model.as_os_str(),
    ];

    let mut g = c.benchmark_group("command");
    g.sample_size(10).warm_up_time(Duration::from_secs(1));
    // Each identify starts without a ledger, as a user's first run does (a rerun with --force
    // appends to the ledger beside the model).
    g.measurement_time(Duration::from_secs(8));
    g.bench_function("identify_168", |b| {
        b.iter_batched(
            || {
                let _ = std::fs::remove_file(&ledger);
            },
            |_| xtask(&bin, &identify),
            BatchSize::PerIteration,
        )
    });
    g.measurement_time(Duration::from_secs(10));
    g.bench_function("compare_168", |b| b.iter(|| xtask(&bin, &compare)));
    g.measurement_time(Duration::from_secs(30));
    g.bench_function("diagnose_168", |b| b.iter(|| xtask(&bin, &diagnose)));

    bench_loop(&mut g, &bin, tmp.path());
    g.finish();
    // `cargo test --benches` runs each bench once: skip the peer there.
    if std::env::args().any(|a| a == "--test" || a == "--list") {
        return;
    }

    numpy_peer(&bin, &camp, &ledger, &identify);
}

criterion_group!(benches, bench);

fn main() {
    benches();
    Criterion::default().configure_from_args().final_summary();
}
