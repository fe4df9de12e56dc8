//! Past one machine (issue 57, docs/src/scale-out.md): what sharding costs, as processes of the
//! release binary on the CI subset of the out-of-sample suite (5 draws; one draw's loop takes
//! 1-15 s on one thread), repeated and interleaved so the machine's load hits every variant
//! alike:
//!
//! - **sharding overhead**: 2 shards at once (`--shard 1/2 --steal`, `--shard 2/2 --steal`,
//!   one thread each) and the merge, against one process with 2 threads (target: within 10 %);
//! - **the Ray driver's overhead per unit**: `xtask/scale/ray_driver.py --shards 2` on a local
//!   cluster against the same 2 shards run directly, per unit, the cluster's start reported
//!   apart (target: under 1 s per unit);
//! - **the cost model**: its prediction for 1 and 2 workers from the unit times of a
//!   one-thread run, against the measured wall time with 1 and 2 threads (target: within 15 %);
//! - **a 300-draw suite on 8, 64 and 256 workers**: the cost model over the development
//!   range's 300 measured unit times (a complete `cargo xtask suite --range development` job
//!   folder in `$ZMP_SCALE_DEV_DIR`), and the suite as 2 shards, static and stealing, against
//!   one process's shared queue on those times.
//!
//! `cargo bench -p zmp-bench --bench scale` (not in `cargo xtask bench`: it needs the venv's
//! `ray` and a few minutes). The binary is `$ZMP_XTASK_BIN`, else `<target>/release/xtask`;
//! Python is `$ZMP_PYTHON`. With `ZMP_UPDATE_DOCS=1` the numbers (and with `$ZMP_SCALE_DEV_DIR`
//! the 300-draw prediction) are written into bench/README.md between `<!-- bench:scale -->`
//! markers.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;
use zmp_shard::cost::{cost_model, lpt_makespan};

const REPEATS: usize = 3;

fn xtask_bin() -> PathBuf {
    let p = std::env::var_os("ZMP_XTASK_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            let exe = std::env::current_exe().expect("current exe");
            exe.ancestors()
                .nth(3)
                .expect("target dir")
                .join("release/xtask")
        });
    assert!(
        p.exists(),
        "no xtask binary at {} (cargo build --release -p xtask, or set ZMP_XTASK_BIN)",
        p.display()
    );
    p
}

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn run(mut c: Command, what: &str) -> std::process::Output {
    let o = c.stdin(Stdio::null()).output().expect(what);
    assert!(
        o.status.success(),
        "{what} failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    o
}

fn suite(threads: usize, shard: Option<&str>, out: &Path) -> Command {
    let mut c = Command::new(xtask_bin());
    c.args([
        "--threads",
        &threads.to_string(),
        "suite",
        "--range",
        "smoke",
        "--out",
    ])
    .arg(out);
    if let Some(s) = shard {
        c.args(["--shard", s, "--steal"]);
    }
    c
}

/// Unit id and wall time of every unit file of a job folder.
fn unit_times(dir: &Path) -> Vec<(String, f64)> {
    let mut v: Vec<(String, f64)> = std::fs::read_dir(dir.join("units"))
        .expect("units")
        .map(|e| {
            let text = std::fs::read_to_string(e.expect("entry").path()).expect("unit file");
            let u: serde_json::Value = serde_json::from_str(&text).expect("unit json");
            (
                u["id"].as_str().unwrap_or("").to_string(),
                u["wall_s"].as_f64().unwrap_or(0.0),
            )
        })
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v
}

fn timed(f: impl FnOnce()) -> f64 {
    let t = Instant::now();
    f();
    t.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

#[derive(Default)]
struct Samples {
    one_process_2: Vec<f64>,
    one_process_1: Vec<f64>,
    two_shards: Vec<f64>,
    two_shards_tasks: Vec<f64>,
    ray_total: Vec<f64>,
    ray_start: Vec<f64>,
    ray_tasks: Vec<f64>,
    predicted_1: Vec<f64>,
    predicted_2: Vec<f64>,
}

fn ray_python() -> Option<PathBuf> {
    let py = PathBuf::from(std::env::var_os("ZMP_PYTHON")?);
    let ok = Command::new(&py)
        .args(["-c", "import ray"])
        .output()
        .is_ok_and(|o| o.status.success());
    ok.then_some(py)
}

fn one_round(s: &mut Samples, python: Option<&Path>) {
    let d = tempfile::tempdir().expect("tempdir");
    let p = |n: &str| d.path().join(n);
    s.one_process_2.push(timed(|| {
        drop(run(suite(2, None, &p("one2")), "one process, 2 threads"))
    }));
    s.one_process_1.push(timed(|| {
        drop(run(suite(1, None, &p("one1")), "one process, 1 thread"))
    }));
    let times: Vec<f64> = unit_times(&p("one1")).into_iter().map(|u| u.1).collect();
    s.predicted_1.push(lpt_makespan(&times, 1));
    s.predicted_2.push(lpt_makespan(&times, 2));
    let mut tasks = 0.0;
    s.two_shards.push(timed(|| {
        let t = Instant::now();
        let kids: Vec<_> = ["1/2", "2/2"]
            .iter()
            .map(|sh| {
                suite(1, Some(sh), &p("two"))
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .spawn()
                    .expect("shard")
            })
            .collect();
        for mut k in kids {
            assert!(k.wait().expect("shard").success());
        }
        tasks = t.elapsed().as_secs_f64();
        let mut m = Command::new(xtask_bin());
        m.arg("merge").arg(p("two"));
        run(m, "merge");
    }));
    s.two_shards_tasks.push(tasks);
    let same =
        |f: &str| std::fs::read(p("one2").join(f)).ok() == std::fs::read(p("two").join(f)).ok();
    assert!(
        same("table.md") && same("result.json"),
        "2 shards merged differently"
    );
    if let Some(py) = python {
        let mut c = Command::new(py);
        c.arg(repo().join("xtask/scale/ray_driver.py"))
            .args(["--shards", "2", "--cpus-per-task", "1", "--json", "--xtask"])
            .arg(xtask_bin())
            .args(["--", "suite", "--range", "smoke", "--out"])
            .arg(p("ray"));
        let mut out = None;
        s.ray_total.push(timed(|| out = Some(run(c, "ray driver"))));
        let v: serde_json::Value =
            serde_json::from_slice(&out.expect("ran").stdout).expect("driver json");
        s.ray_start
            .push(v["ray"]["start_s"].as_f64().expect("start_s"));
        s.ray_tasks
            .push(v["ray"]["tasks_s"].as_f64().expect("tasks_s"));
        assert!(same_dir(&p("one2"), &p("ray")), "Ray merged differently");
    }
}

fn same_dir(a: &Path, b: &Path) -> bool {
    ["table.md", "report.md", "result.json"]
        .iter()
        .all(|f| std::fs::read(a.join(f)).ok() == std::fs::read(b.join(f)).ok())
}

fn pct(a: f64, b: f64) -> String {
    format!("{:+.1} %", 100.0 * (a / b - 1.0))
}

/// The development range's measured unit times (`$ZMP_SCALE_DEV_DIR`, a complete `cargo xtask
/// suite --range development` job): the cost model on 8, 64 and 256 workers, and what 2
/// shards of the partition by today's expected costs (`Class::expected_cost`), each running
/// its part only or stealing (`shard_sequence`), cost against one process whose 2 threads
/// share a queue in the same expected-cost order, all on the measured times (the sharding
/// target's question for the suite itself, where the 5-draw rows above measure mostly the
/// granularity of 5 units).
fn dev_prediction(dir: &Path) -> String {
    let units = unit_times(dir);
    let job = zmp_shard::read_job(dir).expect("job.json of $ZMP_SCALE_DEV_DIR");
    assert_eq!(
        units.len(),
        job.units.len(),
        "{}: every unit of the job needs a result",
        dir.display()
    );
    let time = |id: &str| units.iter().find(|u| u.0 == id).map_or(0.0, |u| u.1);
    // The job as a run would make it today (the job folder's costs are those of its day).
    let (range, first) = zmp_suites::sharded::job_range(&job).expect("a suite job");
    let (today, _) = zmp_suites::sharded::job(range, first).expect("the range's job");
    assert!(
        today.units.len() == job.units.len()
            && today
                .units
                .iter()
                .zip(&job.units)
                .all(|(a, b)| a.id == b.id),
        "the range's draws changed"
    );
    let times: Vec<f64> = today.units.iter().map(|u| time(&u.id)).collect();
    let shards = |steal: bool| -> f64 {
        let seqs: Vec<Vec<usize>> = (1..=2)
            .map(|i| {
                let s = zmp_shard::Shard::new(i, 2).expect("shard");
                zmp_shard::shard_sequence(&today.units, s, steal)
                    .into_iter()
                    .map(|(k, _)| k)
                    .collect()
            })
            .collect();
        zmp_shard::cost::shards_makespan(&seqs, &times)
    };
    let (static_2, steal_2) = (shards(false), shards(true));
    let order: Vec<f64> = zmp_shard::lpt_order(&today.units)
        .into_iter()
        .map(|k| times[k])
        .collect();
    let queue_2 = zmp_shard::cost::list_makespan(&order, 2);
    let m = cost_model(&units, &[2, 8, 64, 256]);
    let c = m.critical_path.clone().expect("units");
    let mut t = format!(
        "From the development range's {} measured unit times ({} of work, each unit's wall \
         time as run two at a time; the longest draw {} ({})):\n\n\
         | workers | predicted wall time (LPT over the measured times) |\n| --- | --- |\n",
        units.len(),
        zmp_shard::cost::human(m.total_s),
        c.unit,
        zmp_shard::cost::human(c.seconds),
    );
    for p in &m.predicted {
        t.push_str(&format!(
            "| {} | {} |\n",
            p.workers,
            zmp_shard::cost::human(p.wall_s)
        ));
    }
    t.push_str(&format!(
        "\nOn those times, one process with 2 threads sharing its queue takes {}; the suite \
         as 2 shards of one thread each (the partition by expected cost) {} ({}) when each \
         runs its part only, {} ({}; target: within 10 %) when a shard done with its part \
         takes the longest unit no shard has begun (`--steal`, the Ray driver's and the Slurm \
         script's default). From 64 workers on the wall time is the longest draw's.\n",
        zmp_shard::cost::human(queue_2),
        zmp_shard::cost::human(static_2),
        pct(static_2, queue_2),
        zmp_shard::cost::human(steal_2),
        pct(steal_2, queue_2),
    ));
    t
}

fn main() {
    // `cargo bench` passes --bench; nothing else is taken.
    let python = ray_python();
    if python.is_none() {
        eprintln!("scale bench: ray is not importable by $ZMP_PYTHON: the Ray rows are left out");
    }
    let mut s = Samples::default();
    for r in 0..REPEATS {
        eprintln!("scale bench: round {}/{REPEATS}", r + 1);
        one_round(&mut s, python.as_deref());
    }
    let units = 5.0;
    let (w2, w1, sh) = (
        median(s.one_process_2.clone()),
        median(s.one_process_1.clone()),
        median(s.two_shards.clone()),
    );
    let (p1, p2) = (median(s.predicted_1.clone()), median(s.predicted_2.clone()));
    let st = median(s.two_shards_tasks.clone());
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let mut t = format!(
        "CI subset of the suite (5 draws), medians of {REPEATS} interleaved rounds, 2-core VM, \
         load {} at the end:\n\n| what | measured | against | target |\n| --- | --- | --- | --- |\n",
        load.split_whitespace().next().unwrap_or("?")
    );
    t.push_str(&format!(
        "| 2 shards at once (`--steal`) + merge vs one process (2 threads) | {sh:.1} s vs {w2:.1} s | {} | within 10 % |\n",
        pct(sh, w2)
    ));
    if !s.ray_total.is_empty() {
        let (rt, rs, rk) = (
            median(s.ray_total.clone()),
            median(s.ray_start.clone()),
            median(s.ray_tasks.clone()),
        );
        t.push_str(&format!(
            "| Ray driver, 2 shards: its tasks vs the same 2 shards run directly | {rk:.1} s vs {st:.1} s | {:.2} s per unit | under 1 s per unit |\n\
             | Ray driver: local cluster start and stop (once per job, not per unit) | {rs:.1} s of {rt:.1} s | | |\n",
            (rk - st) / units
        ));
    }
    t.push_str(&format!(
        "| cost model, 1 worker (from a one-thread run's unit times) | {p1:.1} s predicted, {w1:.1} s measured | {} | within 15 % |\n\
         | cost model, 2 workers | {p2:.1} s predicted, {w2:.1} s measured | {} | within 15 % |\n",
        pct(p1, w1),
        pct(p2, w2)
    ));
    if w2 >= 0.9 * w1 {
        // Said by the numbers themselves: the 2-worker rows then measure the machine's load.
        t.push_str(&format!(
            "\nA second thread gave no speed-up in this run ({w2:.1} s with 2 threads, {w1:.1} s \
             with 1): the machine's other load took the second core, so the 2-worker rows \
             measure that load, not the sharding or the cost model.\n"
        ));
    }
    t.push('\n');
    match std::env::var_os("ZMP_SCALE_DEV_DIR") {
        Some(dir) => t.push_str(&dev_prediction(Path::new(&dir))),
        None => t.push_str(
            "The prediction for a 300-draw suite on 8, 64 and 256 workers needs the measured \
             unit times of a merged development range (`ZMP_SCALE_DEV_DIR`); not run for this \
             table.\n",
        ),
    }
    println!("{t}");
    if std::env::var(zmp_files::sections::UPDATE_VAR).is_ok_and(|v| v == "1") {
        assert!(
            !s.ray_total.is_empty(),
            "writing bench/README.md needs the Ray rows: the venv's ray"
        );
        zmp_files::sections::replace_sections(
            &repo().join("bench/README.md"),
            &[("bench:scale", t)],
        )
        .expect("write bench/README.md");
    }
}
