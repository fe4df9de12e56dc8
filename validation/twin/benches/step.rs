//! One physics step of the SILO2 twin (1 ms, `models/mjcf/silo2.xml`) and, in the same run, the
//! same model stepped by MuJoCo's own Python bindings (`bench/peers/mujoco_step.py`,
//! `mujoco==3.17.0`, the library version the twin links). Target: at least 30,000 steps/s on
//! one core.
//!
//! Work per step on both sides: set the trunk servo references (a 6 rad/s sine of 0.07 rad on
//! the lateral tilt) and `mj_step`, from the standing keyframe. `step_with_cells` also reads
//! the 8 load cells and forms the ZMP, as the campaign does every step. The peer runs with
//! `$ZMP_PYTHON` (default `~/.cache/zmp-toolkit/venv/bin/python`); it is skipped with a note if
//! that is missing.
//!
//! On a shared machine the wall clock measures the competition as much as the step, so the
//! comparison also reports steps per second of the stepping thread's own CPU time (Linux
//! `/proc/thread-self/schedstat` here, `time.thread_time()` in the peer): "on one core".

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use zmp_twin::silo2::{default_mjcf, Silo2, STEP};

fn python() -> PathBuf {
    std::env::var_os("ZMP_PYTHON")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let home = std::env::var_os("HOME").unwrap_or_default();
            PathBuf::from(home).join(".cache/zmp-toolkit/venv/bin/python")
        })
}

/// Runs `n` steps of the bench's work; returns the last lateral ZMP (to keep the work alive).
fn steps(twin: &Silo2, d: &mut zmp_twin::silo2::Data<'_>, k0: usize, n: usize, cells: bool) -> f64 {
    let mut z = 0.0;
    for k in k0..k0 + n {
        twin.set_trunk(d, [0.07 * (6.0 * k as f64 * STEP).sin(), 0.0]);
        d.step();
        if cells {
            z = twin.cells(d).zmp().map_or(f64::NAN, |p| p[0]);
        }
    }
    z
}

/// CPU time this thread has run, s (Linux; `None` elsewhere).
fn thread_cpu_s() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn bench(c: &mut Criterion) {
    let twin = Silo2::load(&default_mjcf()).expect("silo2.xml");
    let mut g = c.benchmark_group("silo2");
    g.sample_size(20).measurement_time(Duration::from_secs(5));
    for (name, cells) in [("step", false), ("step_with_cells", true)] {
        let mut d = twin.stand().expect("data");
        steps(&twin, &mut d, 0, 1000, cells);
        let mut k = 1000;
        g.bench_function(name, |b| {
            b.iter(|| {
                // 1000 steps per iteration: criterion's time / 1000 is one step.
                let z = steps(&twin, &mut d, k, 1000, cells);
                k += 1000;
                black_box(z)
            })
        });
    }
    g.finish();

    let mut rates = measure_against_peer(&twin);
    report(&mut rates);
}

/// Steps per second, one entry per timed run: ours and the Python peer's (its Python loop
/// and its `mj_step(nstep=10)`), by wall clock and by thread CPU time.
#[derive(Default)]
struct Rates {
    ours: Vec<f64>,
    ours_cpu: Vec<f64>,
    peer_loop: Vec<f64>,
    peer_nstep: Vec<f64>,
    peer_loop_cpu: Vec<f64>,
    peer_nstep_cpu: Vec<f64>,
}

/// Steps in each timed run.
const N: usize = 20_000;

/// Our stepping and the peer's, interleaved so that both sides see the same phases of a
/// shared machine: three rounds of ours (5 x 20,000 steps) and one peer run (20,000 steps in
/// each of its loops). A peer that fails or is missing is not run again.
fn measure_against_peer(twin: &Silo2) -> Rates {
    let py = python();
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../bench/peers/mujoco_step.py");
    let mut r = Rates::default();
    let mut peer_ok = true;
    for _ in 0..3 {
        for _ in 0..5 {
            let mut d = twin.stand().expect("data");
            steps(twin, &mut d, 0, 1000, false);
            let (t, c0) = (Instant::now(), thread_cpu_s());
            black_box(steps(twin, &mut d, 1000, N, false));
            r.ours.push(N as f64 / t.elapsed().as_secs_f64());
            if let (Some(c0), Some(c1)) = (c0, thread_cpu_s()) {
                r.ours_cpu.push(N as f64 / (c1 - c0));
            }
        }
        if peer_ok {
            peer_ok = run_peer(&py, &script, &mut r);
        }
    }
    r
}

/// One run of the Python peer `script`, its rates added to `r`; false if it failed or could
/// not be started (said on standard error).
fn run_peer(py: &Path, script: &Path, r: &mut Rates) -> bool {
    match std::process::Command::new(py)
        .arg(script)
        .arg(default_mjcf())
        .arg(N.to_string())
        .output()
    {
        Ok(o) if o.status.success() => {
            let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("peer prints JSON");
            r.peer_loop
                .push(N as f64 / v["python_loop_wall_s"].as_f64().expect("wall"));
            r.peer_nstep
                .push(N as f64 / v["nstep_wall_s"].as_f64().expect("wall"));
            r.peer_loop_cpu
                .push(N as f64 / v["python_loop_cpu_s"].as_f64().expect("cpu"));
            r.peer_nstep_cpu
                .push(N as f64 / v["nstep_cpu_s"].as_f64().expect("cpu"));
            true
        }
        Ok(o) => {
            eprintln!("python peer failed: {}", String::from_utf8_lossy(&o.stderr));
            false
        }
        Err(e) => {
            eprintln!(
                "python peer not run ({}: {e}); set ZMP_PYTHON",
                py.display()
            );
            false
        }
    }
}

/// Prints the medians and puts them into the history of `cargo xtask bench` (seconds per
/// step, ratio = peer / ours).
fn report(r: &mut Rates) {
    let median = |v: &mut Vec<f64>| {
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(f64::total_cmp);
        v[v.len() / 2]
    };
    for (what, o, pl, pn) in [
        (
            "wall clock",
            median(&mut r.ours),
            median(&mut r.peer_loop),
            median(&mut r.peer_nstep),
        ),
        (
            "thread CPU time",
            median(&mut r.ours_cpu),
            median(&mut r.peer_loop_cpu),
            median(&mut r.peer_nstep_cpu),
        ),
    ] {
        if pl.is_nan() {
            println!("silo2/step ({what}): ours {o:.0} steps/s; python peer not run");
        } else {
            // Into the history of `cargo xtask bench` (seconds per step, ratio = peer / ours).
            let slug = if what == "wall clock" { "" } else { "_cpu" };
            zmp_bench::report_peer(
                &format!("twin_step/mujoco_python{slug}"),
                1.0 / o,
                1.0 / pl,
                "step",
                &format!(
                    "SILO2 twin step (servo references + `mj_step`) against the same model \
                     stepped from a Python loop by MuJoCo's own bindings ({what}, medians of \
                     20,000-step runs)"
                ),
            );
            zmp_bench::report_peer(
                &format!("twin_step/mujoco_python_nstep{slug}"),
                1.0 / o,
                1.0 / pn,
                "step",
                &format!(
                    "the same against MuJoCo Python's `mj_step(m, d, nstep=10)` (no Python per \
                     step; {what})"
                ),
            );
            println!(
                "silo2/step ({what}): ours {o:.0} steps/s; MuJoCo Python bindings {pl:.0} \
                 steps/s (Python loop, ratio {:.2}x), {pn:.0} steps/s (mj_step nstep=10, \
                 ratio {:.2}x)",
                o / pl,
                o / pn
            );
        }
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
