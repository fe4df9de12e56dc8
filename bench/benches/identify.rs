//! The whole identification pipeline as `cargo xtask identify` runs it (read the campaign from
//! disk, each record analysed as it is read, then identify) on the reference virtual SILO2
//! campaign (168 records, ~680k rows, ~25 MB of CSV, acceleration limit
//! 1.2 m/s2), and the same pipeline written with numpy and pyarrow (`bench/peers/identify_numpy.py`:
//! multithreaded CSV reading, vectorised fits, 2 threads like ours) timed in the same run. The peer runs with `$ZMP_PYTHON` (default
//! `~/.cache/zmp-toolkit/venv/bin/python`); it is skipped with a note if that is missing.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use zmp_bench::identify::{pipeline, write_reference_campaign};

fn python() -> PathBuf {
    std::env::var_os("ZMP_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let home = std::env::var_os("HOME").unwrap_or_default();
            PathBuf::from(home).join(".cache/zmp-toolkit/venv/bin/python")
        })
}

fn bench(c: &mut Criterion) {
    let tmp = tempfile::tempdir().expect("tempdir");
    let dir = write_reference_campaign(tmp.path());
    let mut g = c.benchmark_group("identify");
    g.sample_size(10).measurement_time(Duration::from_secs(8));
    g.bench_function("read_and_fit_168", |b| b.iter(|| black_box(pipeline(&dir))));
    g.finish();

    // Same run, interleaved so that both sides see the same phases of a shared machine: three
    // rounds of five runs of ours (each a whole read + identify) and one run of the numpy peer
    // (a fresh interpreter timing its own read + fit); medians over the 15 and the 3.
    let py = python();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("peers/identify_numpy.py");
    let mut ours: Vec<f64> = Vec::new();
    let mut peer = Vec::new();
    let mut peer_ok = true;
    for _ in 0..3 {
        ours.extend((0..5).map(|_| {
            let t = Instant::now();
            black_box(pipeline(&dir));
            t.elapsed().as_secs_f64()
        }));
        if !peer_ok {
            continue;
        }
        match std::process::Command::new(&py)
            .arg(&script)
            .arg(&dir)
            .args(["--threads", "2"])
            .output()
        {
            Ok(o) if o.status.success() => {
                let v: serde_json::Value =
                    serde_json::from_slice(&o.stdout).expect("peer prints JSON");
                peer.push(v["wall_s"].as_f64().expect("wall_s"));
            }
            Ok(o) => {
                eprintln!("numpy peer failed: {}", String::from_utf8_lossy(&o.stderr));
                peer_ok = false;
            }
            Err(e) => {
                eprintln!("numpy peer not run ({}: {e}); set ZMP_PYTHON", py.display());
                peer_ok = false;
            }
        }
    }
    ours.sort_by(|a, b| a.total_cmp(b));
    let ours = ours[ours.len() / 2];
    if peer.is_empty() {
        println!("identify/read_and_fit_168: ours {ours:.3} s; numpy peer not run");
    } else {
        peer.sort_by(|a, b| a.total_cmp(b));
        let p = peer[peer.len() / 2];
        println!(
            "identify/read_and_fit_168: ours {ours:.3} s, numpy peer {p:.3} s, ratio {:.1}x",
            p / ours
        );
        zmp_bench::report_peer(
            "identify_168/numpy_vs_library",
            ours,
            p,
            "run",
            "library read + identify (in process) against the numpy/pyarrow peer (read + fit), \
             2 threads each, medians of 15 and 3 interleaved",
        );
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
