//! The shard contract end to end on the smoke range of the out-of-sample suite (5 quick draws
//! of the development range, `zmp_suites::sharded::SMOKE_SEEDS`; the CI subset, with its
//! ambiguous pairs and their designed experiments, is asserted draw by draw in
//! `validation/suites/tests/ci_subset.rs`): run in one process, as 4 shards through the Slurm array script run by hand, and through the Ray driver on a local cluster
//! with one worker killed mid-run; every merge must give the one-process run's files byte for
//! byte (the draws are deterministic: one thread each, far from their time limit).

mod support;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use support::{ok, xtask};

const MERGED: [&str; 3] = ["table.md", "report.md", "result.json"];

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn merged(dir: &Path) -> BTreeMap<&'static str, Vec<u8>> {
    MERGED
        .iter()
        .map(|f| (*f, std::fs::read(dir.join(f)).unwrap_or_default()))
        .collect()
}

fn unit_files(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir.join("units"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    v.sort();
    v
}

/// The smoke range's unit files (`zmp_suites::sharded::SMOKE_SEEDS`), in file-name order.
const CI_UNITS: [&str; 5] = [
    "draw-1.json",
    "draw-209.json",
    "draw-210.json",
    "draw-4.json",
    "draw-9.json",
];

/// The one-process run's merged files (run once for the tests of this file).
fn one_process() -> &'static BTreeMap<&'static str, Vec<u8>> {
    static REF: OnceLock<BTreeMap<&'static str, Vec<u8>>> = OnceLock::new();
    REF.get_or_init(|| {
        let d = tempfile::tempdir().unwrap();
        let out = d.path().join("one");
        let o = out.to_str().unwrap();
        ok(
            xtask(&["suite", "--range", "smoke", "--out", o], d.path()),
            "suite",
        );
        let mut expected: Vec<String> = zmp_suites::sharded::SMOKE_SEEDS
            .iter()
            .map(|s| format!("draw-{s}.json"))
            .collect();
        expected.sort();
        assert_eq!(expected, CI_UNITS);
        assert_eq!(unit_files(&out), CI_UNITS);
        let m = merged(&out);
        let table = String::from_utf8_lossy(&m["table.md"]).into_owned();
        assert!(table.contains("| time_delay | 1 |"), "{table}");
        m
    })
}

fn assert_same(dir: &Path, what: &str) {
    let m = merged(dir);
    for f in MERGED {
        assert!(
            m[f] == one_process()[f],
            "{what}: {f} differs from the one-process run:\n{}\n---\n{}",
            String::from_utf8_lossy(&m[f]),
            String::from_utf8_lossy(&one_process()[f])
        );
    }
}

fn slurm_command(script: &str, args: &[&str], id: Option<(usize, usize, usize)>) -> Command {
    let mut c = Command::new("bash");
    c.arg(repo().join("xtask/scale/slurm").join(script))
        .args(args)
        .env("ZMP_XTASK", env!("CARGO_BIN_EXE_xtask"))
        .env("ZMP_ROOT", repo())
        .env("SLURM_CPUS_PER_TASK", "1");
    if let Some((task, min, count)) = id {
        c.env("SLURM_ARRAY_TASK_ID", task.to_string())
            .env("SLURM_ARRAY_TASK_MIN", min.to_string())
            .env("SLURM_ARRAY_TASK_COUNT", count.to_string());
    }
    c
}

fn slurm_task(script: &str, args: &[&str], id: Option<(usize, usize, usize)>) -> Output {
    slurm_command(script, args, id).output().unwrap()
}

#[test]
fn four_shards_by_the_slurm_array_script_merge_to_the_one_process_files() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("job");
    let o = out.to_str().unwrap();
    let cmd = ["suite", "--range", "smoke", "--out", o];
    // An array submitted as --array=5-8: task ids 5..8, shards 1/4..4/4, started at once.
    let tasks: Vec<_> = (5..=8)
        .map(|task| {
            slurm_command("suite.sbatch", &cmd, Some((task, 5, 4)))
                .stdout(std::process::Stdio::piped())
                .stderr(std::process::Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for t in tasks {
        ok(t.wait_with_output().unwrap(), "array task");
    }
    // Each unit was claimed by the task that ran it (a task done early takes other parts'
    // units: the script passes --steal).
    let mut claimed: Vec<String> = std::fs::read_dir(out.join("claims"))
        .unwrap()
        .map(|e| {
            let text = std::fs::read_to_string(e.unwrap().path()).unwrap();
            let c: serde_json::Value = serde_json::from_str(&text).unwrap();
            c["shard"].as_str().unwrap().to_string()
        })
        .collect();
    claimed.sort();
    assert_eq!(claimed.len(), CI_UNITS.len(), "{claimed:?}");
    assert!(claimed.iter().all(|s| s.ends_with("/4")), "{claimed:?}");
    // The same task again (a resubmitted shard): its units replaced, none added.
    ok(
        slurm_task("suite.sbatch", &cmd, Some((8, 5, 4))),
        "array task again",
    );
    assert_eq!(unit_files(&out), CI_UNITS);
    let m = slurm_task("merge.sbatch", &[o], None);
    let text = ok(m, "merge job");
    assert!(text.contains("predicted wall time"), "{text}");
    assert!(text.contains("critical path: unit draw-"), "{text}");
    assert_same(&out, "4 shards (Slurm script)");
    // Outside an array the script says so.
    let e = slurm_task("suite.sbatch", &cmd, None);
    assert!(!e.status.success());
    assert!(String::from_utf8_lossy(&e.stderr).contains("not an array task"));

    // A lost unit file: merge names it and fails; the unit re-run alone restores the result.
    std::fs::remove_file(out.join("units/draw-9.json")).unwrap();
    let e = xtask(&["merge", o], d.path());
    assert!(!e.status.success());
    let err = String::from_utf8_lossy(&e.stderr);
    assert!(err.contains("missing units (1): draw-9"), "{err}");
    assert!(err.contains("--unit ID"), "{err}");
    ok(
        xtask(
            &["suite", "--range", "smoke", "--out", o, "--unit", "draw-9"],
            d.path(),
        ),
        "unit",
    );
    ok(xtask(&["merge", o], d.path()), "merge");
    assert_same(&out, "after re-running one unit");

    // A folder holding another job is refused.
    let e = xtask(
        &[
            "suite",
            "--range",
            "development",
            "--out",
            o,
            "--shard",
            "1/9",
        ],
        d.path(),
    );
    assert!(!e.status.success());
    assert!(String::from_utf8_lossy(&e.stderr).contains("holds another job"));
}

/// The pids of processes whose command line has every one of `words`.
fn processes_with(words: &[&str]) -> Vec<u32> {
    let mut out = Vec::new();
    for e in std::fs::read_dir("/proc").unwrap().flatten() {
        let Ok(pid) = e.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(cmd) = std::fs::read(e.path().join("cmdline")) else {
            continue;
        };
        let args: Vec<String> = cmd
            .split(|&b| b == 0)
            .map(|a| String::from_utf8_lossy(a).into_owned())
            .collect();
        if words.iter().all(|w| args.iter().any(|a| a == w)) {
            out.push(pid);
        }
    }
    out
}

/// The shards (`i/n`) holding a claim on a unit without a result in job folder `out`.
fn begun_unfinished(out: &Path) -> Vec<String> {
    let Ok(claims) = std::fs::read_dir(out.join("claims")) else {
        return Vec::new();
    };
    claims
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            let id = name
                .strip_suffix(".json")
                .filter(|_| !name.starts_with('.'))?;
            if out.join("units").join(format!("{id}.json")).is_file() {
                return None;
            }
            let claim: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(e.path()).ok()?).ok()?;
            claim["shard"].as_str().map(String::from)
        })
        .collect()
}

fn parent(pid: u32) -> Option<u32> {
    let s = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    s.lines()
        .find_map(|l| l.strip_prefix("PPid:"))
        .and_then(|v| v.trim().parse().ok())
}

#[test]
fn ray_local_cluster_with_a_killed_worker_merges_to_the_one_process_files() {
    let Some(python) = std::env::var_os("ZMP_PYTHON") else {
        eprintln!("SKIPPED: ZMP_PYTHON is not set (cargo xtask ci sets it; or . env.sh)");
        return;
    };
    let has_ray = Command::new(&python)
        .args(["-c", "import ray"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_ray {
        eprintln!("SKIPPED: ray is not importable by {python:?} (cargo xtask setup installs it)");
        return;
    }
    let reference = one_process();
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("job");
    let mut driver = Command::new(&python)
        .arg(repo().join("xtask/scale/ray_driver.py"))
        .args(["--shards", "4", "--cpus-per-task", "1", "--xtask"])
        .arg(env!("CARGO_BIN_EXE_xtask"))
        .args(["--", "suite", "--range", "smoke", "--out"])
        .arg(&out)
        .stdout(std::fs::File::create(d.path().join("driver.out")).unwrap())
        .stderr(std::fs::File::create(d.path().join("driver.err")).unwrap())
        .spawn()
        .unwrap();
    // As soon as a shard has begun a unit (its claim written, no result yet), kill the Ray
    // worker running that shard, mid-unit. Every shard steals (the driver's default), so which
    // shard runs which unit depends on timing: the claim says.
    let started = std::time::Instant::now();
    let mut killed: Option<String> = None;
    while killed.is_none() && started.elapsed().as_secs() < 600 {
        for shard in begun_unfinished(&out) {
            let procs = processes_with(&[env!("CARGO_BIN_EXE_xtask"), "--shard", &shard]);
            if let Some(worker) = procs.first().and_then(|&p| parent(p)) {
                let k = Command::new("kill")
                    .args(["-9", &worker.to_string()])
                    .status();
                assert!(k.unwrap().success());
                killed = Some(shard);
                break;
            }
        }
        if driver.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let status = driver.wait().unwrap();
    let err = std::fs::read_to_string(d.path().join("driver.err")).unwrap();
    let Some(killed) = killed else {
        panic!("no worker was killed:\n{err}");
    };
    assert!(status.success(), "the driver failed:\n{err}");
    // The killed shard ran twice (the retry took back the unit it had begun), every unit has
    // one file, and the merge is the one-process run's.
    let (i, n) = killed.split_once('/').unwrap();
    assert!(
        err.contains(&format!(
            "re-run after a worker died: {{'shard-{i}-of-{n}': 2}}"
        )),
        "{err}"
    );
    let attempts = std::fs::read_dir(d.path().join("job.ray-attempts"))
        .unwrap()
        .count();
    assert_eq!(attempts, 5, "{err}");
    assert_eq!(unit_files(&out), CI_UNITS);
    assert_same(&out, "Ray with a killed worker");
    assert_eq!(merged(&out), *reference);
}

/// A private single-node Slurm cluster (slurm-wlm's slurmctld and slurmd, no munge: auth/none)
/// whose configuration, state and logs live in a temporary folder; its daemons are this test's
/// children, stopped when it is dropped.
struct LocalSlurm {
    dir: tempfile::TempDir,
    daemons: Vec<std::process::Child>,
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

impl LocalSlurm {
    /// Why a private cluster cannot be started here, if it cannot.
    fn unavailable() -> Option<String> {
        for prog in ["slurmctld", "slurmd", "sbatch", "squeue"] {
            let found = Command::new(prog).arg("-V").output().is_ok();
            if !found {
                return Some(format!(
                    "{prog} is not installed (apt-get install slurm-wlm)"
                ));
            }
        }
        let uid = Command::new("id").arg("-u").output().unwrap().stdout;
        (String::from_utf8_lossy(&uid).trim() != "0")
            .then(|| "slurmd runs jobs as their users: it needs root".into())
    }

    fn start() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path().display().to_string();
        let host =
            String::from_utf8(Command::new("hostname").arg("-s").output().unwrap().stdout).unwrap();
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::fs::create_dir_all(dir.path().join("state")).unwrap();
        std::fs::create_dir_all(dir.path().join("spool")).unwrap();
        let conf = format!(
            "ClusterName=zmptest\nSlurmctldHost={host}\nSlurmctldPort={}\nSlurmdPort={}\n\
             AuthType=auth/none\nCredType=cred/none\nSlurmUser=root\nSlurmdUser=root\n\
             StateSaveLocation={d}/state\nSlurmdSpoolDir={d}/spool\n\
             SlurmctldPidFile={d}/slurmctld.pid\nSlurmdPidFile={d}/slurmd.pid\n\
             SlurmctldLogFile={d}/slurmctld.log\nSlurmdLogFile={d}/slurmd.log\n\
             ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\n\
             SelectType=select/cons_tres\nSelectTypeParameters=CR_CPU\n\
             ReturnToService=2\nMpiDefault=none\nJobCompType=jobcomp/none\n\
             AccountingStorageType=accounting_storage/none\n\
             NodeName={} CPUs={cpus} State=UNKNOWN\n\
             PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP\n",
            free_port(),
            free_port(),
            host.trim(),
            host = host.trim(),
        );
        std::fs::write(dir.path().join("slurm.conf"), conf).unwrap();
        let mut s = LocalSlurm {
            dir,
            daemons: Vec::new(),
        };
        for args in [&["-D", "-i"][..], &["-D"][..]] {
            let prog = if args.len() == 2 {
                "slurmctld"
            } else {
                "slurmd"
            };
            let child = s
                .command(prog)
                .args(args)
                .stdout(std::process::Stdio::null())
                .stderr(std::process::Stdio::null())
                .spawn()
                .unwrap();
            s.daemons.push(child);
        }
        // The node registers within seconds; sinfo then shows it idle.
        let started = std::time::Instant::now();
        loop {
            let o = s
                .command("sinfo")
                .args(["-h", "-o", "%t"])
                .output()
                .unwrap();
            if String::from_utf8_lossy(&o.stdout).trim() == "idle" {
                return s;
            }
            assert!(
                started.elapsed().as_secs() < 60,
                "the private Slurm cluster did not come up: {}",
                std::fs::read_to_string(s.dir.path().join("slurmctld.log")).unwrap_or_default()
            );
            std::thread::sleep(std::time::Duration::from_millis(250));
        }
    }

    fn command(&self, prog: &str) -> Command {
        let mut c = Command::new(prog);
        c.env("SLURM_CONF", self.dir.path().join("slurm.conf"));
        c
    }
}

impl Drop for LocalSlurm {
    fn drop(&mut self) {
        // SIGTERM first: the daemons stop their helpers (slurmscriptd) and save their state.
        for d in &mut self.daemons {
            let _ = Command::new("kill").arg(d.id().to_string()).status();
            let asked = std::time::Instant::now();
            while matches!(d.try_wait(), Ok(None)) && asked.elapsed().as_secs() < 10 {
                std::thread::sleep(std::time::Duration::from_millis(100));
            }
            let _ = d.kill();
            let _ = d.wait();
        }
    }
}

#[test]
#[ignore = "long: needs slurm-wlm and root; starts a private single-node Slurm cluster"]
fn a_real_single_node_slurm_runs_the_array_and_the_dependent_merge() {
    if let Some(why) = LocalSlurm::unavailable() {
        eprintln!("SKIPPED: {why}");
        return;
    }
    let reference = one_process();
    let slurm = LocalSlurm::start();
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("job");
    let o = out.to_str().unwrap();
    let script = repo().join("xtask/scale/slurm/suite.sbatch");
    // sbatch checks the script's directives and the array against the cluster, runs nothing.
    let t = slurm
        .command("sbatch")
        .args(["--test-only", "--array=1-4"])
        .arg(&script)
        .args(["suite", "--range", "smoke", "--out", o])
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&t.stderr);
    assert!(t.status.success() && said.contains("to start at"), "{said}");
    assert!(!out.exists(), "--test-only ran something");
    // submit.sh: the array of 4 shards (one CPU each, two at a time on this machine) and the
    // merge job after it.
    let log = format!("--output={}/slurm-%j.out", d.path().display());
    let s = slurm
        .command("bash")
        .arg(repo().join("xtask/scale/slurm/submit.sh"))
        .args(["4", "suite", "--range", "smoke", "--out", o, "--"])
        .args(["--cpus-per-task=1", &log])
        .env("ZMP_XTASK", env!("CARGO_BIN_EXE_xtask"))
        .env("ZMP_ROOT", repo())
        .current_dir(d.path())
        .output()
        .unwrap();
    let submitted = ok(s, "submit.sh");
    assert!(submitted.contains("(4 shards), merge job"), "{submitted}");
    let started = std::time::Instant::now();
    loop {
        let q = slurm.command("squeue").args(["-h"]).output().unwrap();
        if q.stdout.is_empty() {
            break;
        }
        assert!(started.elapsed().as_secs() < 900, "the jobs did not end");
        std::thread::sleep(std::time::Duration::from_secs(1));
    }
    let logs: String = std::fs::read_dir(d.path())
        .unwrap()
        .flatten()
        .filter(|e| e.file_name().to_string_lossy().starts_with("slurm-"))
        .map(|e| std::fs::read_to_string(e.path()).unwrap())
        .collect();
    assert!(
        logs.contains("predicted wall time"),
        "the merge job:\n{logs}"
    );
    assert_eq!(unit_files(&out), CI_UNITS);
    assert_same(&out, "a real Slurm array and merge job");
    assert_eq!(merged(&out), *reference);
}
