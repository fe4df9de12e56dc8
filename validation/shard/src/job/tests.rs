//! The job folder's and the run's tests.
use super::*;
use crate::partition::shard_units;
use crate::unit::UNITS_DIR;

fn job(n: usize) -> Job {
    let units = (0..n)
        .map(|k| UnitSpec::new(format!("u{k}"), 1.0 + k as f64))
        .collect();
    Job::new(JobKind::Suite, serde_json::json!({"range": "test"}), units).unwrap()
}

fn opts(shard: Shard) -> RunOptions {
    RunOptions {
        shard,
        only: None,
        keep_done: false,
        steal: false,
        threads: 2,
        quiet: true,
    }
}

#[test]
fn shards_write_each_unit_once_and_a_rerun_replaces_only_its_own() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("job");
    let j = job(7);
    open_job(&dir, &j).unwrap();
    let calls = std::sync::Mutex::new(Vec::new());
    let run = |u: &UnitSpec| -> Result<Value> {
        calls.lock().unwrap().push(u.id.clone());
        if u.id == "u3" {
            bail!("bad campaign");
        }
        if u.id == "u5" {
            panic!("index out of range");
        }
        Ok(serde_json::json!({"id": u.id}))
    };
    let mut ran = Vec::new();
    for i in 1..=3 {
        let r = run_units(&dir, &j, &opts(Shard::new(i, 3).unwrap()), run).unwrap();
        ran.extend(r.ran);
    }
    ran.sort();
    assert_eq!(ran.len(), 7);
    ran.dedup();
    assert_eq!(ran.len(), 7, "a unit ran in two shards");
    let files = std::fs::read_dir(dir.join(UNITS_DIR)).unwrap().count();
    assert_eq!(files, 7);
    let u3 = read_unit(&unit_path(&dir, "u3")).unwrap();
    assert_eq!(
        u3.status,
        Status::Failed {
            error: "bad campaign".into()
        }
    );
    let u5 = read_unit(&unit_path(&dir, "u5")).unwrap();
    assert!(
        matches!(&u5.status, Status::Failed { error } if error.contains("panicked: index")),
        "{u5:?}"
    );
    // One unit alone, then a shard again: files replaced, none added.
    let before = std::fs::read(unit_path(&dir, "u0")).unwrap();
    calls.lock().unwrap().clear();
    let one = RunOptions {
        only: Some("u3".into()),
        ..opts(Shard::WHOLE)
    };
    let r = run_units(&dir, &j, &one, |u| Ok(serde_json::json!({"id": u.id}))).unwrap();
    assert_eq!(r.ran, vec!["u3".to_string()]);
    assert!(read_unit(&unit_path(&dir, "u3")).unwrap().is_ok());
    assert_eq!(std::fs::read(unit_path(&dir, "u0")).unwrap(), before);
    // Resuming with keep_done runs only what has no good result (u5).
    let resume = RunOptions {
        keep_done: true,
        ..opts(Shard::WHOLE)
    };
    let r = run_units(&dir, &j, &resume, |u| Ok(serde_json::json!({"id": u.id}))).unwrap();
    assert_eq!(r.ran, vec!["u5".to_string()]);
    assert_eq!(r.kept.len(), 6);
    assert_eq!(std::fs::read_dir(dir.join(UNITS_DIR)).unwrap().count(), 7);
    let bad = RunOptions {
        only: Some("nope".into()),
        ..opts(Shard::WHOLE)
    };
    let e = run_units(&dir, &j, &bad, run).unwrap_err().to_string();
    assert!(e.contains("--unit nope: no such unit"), "{e}");
}

/// Two shards of one folder with `--steal` and a part that runs far longer than expected:
/// the other shard takes its units; every unit runs once.
#[test]
fn stealing_shards_run_every_unit_once_and_balance_the_wall_time() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("job");
    let j = job(8);
    open_job(&dir, &j).unwrap();
    let slow: std::collections::BTreeSet<usize> = shard_units(&j.units, Shard::new(1, 2).unwrap())
        .into_iter()
        .collect();
    let runs = std::sync::Mutex::new(Vec::new());
    let run = |u: &UnitSpec| -> Result<Value> {
        runs.lock().unwrap().push(u.id.clone());
        let k = j.units.iter().position(|x| x.id == u.id).unwrap();
        // Shard 1's part takes 100 ms a unit, shard 2's 1 ms: a static split would end
        // with shard 1 running 4 x 100 ms alone.
        let ms = if slow.contains(&k) { 100 } else { 1 };
        std::thread::sleep(Duration::from_millis(ms));
        Ok(serde_json::json!({"id": u.id}))
    };
    let shard = |i: usize| RunOptions {
        steal: true,
        threads: 1,
        ..opts(Shard::new(i, 2).unwrap())
    };
    let (a, b) = std::thread::scope(|s| {
        let h1 = s.spawn(|| run_units(&dir, &j, &shard(1), run).unwrap());
        let h2 = s.spawn(|| run_units(&dir, &j, &shard(2), run).unwrap());
        (h1.join().unwrap(), h2.join().unwrap())
    });
    let mut all = runs.lock().unwrap().clone();
    all.sort();
    let mut ids: Vec<String> = j.units.iter().map(|u| u.id.clone()).collect();
    ids.sort();
    assert_eq!(all, ids, "each unit once");
    assert_eq!(a.ran.len() + b.ran.len(), 8);
    assert!(!b.taken.is_empty(), "the fast shard took none: {a:?} {b:?}");
    let mut left = a.left.clone();
    left.sort();
    let mut taken = b.taken.clone();
    taken.sort();
    assert_eq!(left, taken, "what shard 1 left is what shard 2 took");
    assert!(a.taken.is_empty(), "{a:?}");
    // Every claim names the shard that ran the unit.
    for id in &b.taken {
        let c = crate::claim::read_claim(&dir, id).unwrap();
        assert_eq!(c.shard, "2/2");
    }
    assert_eq!(crate::collect(&dir).unwrap().done.len(), 8);
}

/// A shard whose process died part-way (its claims stay, some without a result): the
/// other shard leaves those units, the shard's next attempt takes them back, own or stolen;
/// a run in another partition takes the units it owns there.
#[test]
fn a_stopped_shards_claims_go_to_its_next_attempt() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("job");
    let j = job(6);
    open_job(&dir, &j).unwrap();
    let dead = crate::claim::Claim {
        shard: "2/2".into(),
        process: "elsewhere:1:1".into(),
    };
    let part1 = shard_units(&j.units, Shard::new(1, 2).unwrap());
    let part2 = shard_units(&j.units, Shard::new(2, 2).unwrap());
    // The dead attempt of shard 2 had begun one of its own units and stolen one of shard 1.
    let begun = [j.units[part2[0]].id.clone(), j.units[part1[2]].id.clone()];
    for id in &begun {
        let text = serde_json::to_string(&dead).unwrap();
        std::fs::create_dir_all(dir.join(crate::claim::CLAIMS_DIR)).unwrap();
        std::fs::write(crate::claim::claim_path(&dir, id), text).unwrap();
    }
    let counts = std::sync::Mutex::new(std::collections::BTreeMap::<String, u32>::new());
    let run = |u: &UnitSpec| -> Result<Value> {
        *counts.lock().unwrap().entry(u.id.clone()).or_default() += 1;
        Ok(serde_json::json!({"id": u.id}))
    };
    let shard = |i: usize| RunOptions {
        steal: true,
        ..opts(Shard::new(i, 2).unwrap())
    };
    let r1 = run_units(&dir, &j, &shard(1), run).unwrap();
    assert_eq!(r1.left, vec![begun[1].clone()], "{r1:?}");
    assert!(!r1.ran.contains(&begun[0]), "{r1:?}");
    let c = crate::collect(&dir).unwrap();
    assert_eq!(c.missing.len(), 2, "{:?}", c.missing);
    assert_eq!(c.begun.len(), 2, "{:?}", c.begun);
    assert!(c.summary().begun.values().all(|s| s == "2/2"));
    let text = c.problems_text("cargo xtask suite");
    assert!(
        text.contains(&format!("unit {} was begun by shard 2/2", begun[0])),
        "{text}"
    );
    // The next attempt of shard 2 (another process) takes both back.
    let r2 = run_units(&dir, &j, &shard(2), run).unwrap();
    assert!(
        r2.ran.contains(&begun[0]) && r2.taken == vec![begun[1].clone()],
        "{r2:?}"
    );
    assert!(
        counts.lock().unwrap().values().all(|&n| n == 1),
        "{counts:?}"
    );
    assert_eq!(crate::collect(&dir).unwrap().done.len(), 6);
    // The job again in 3 shards: each owner re-takes its units from the 2-shard claims.
    counts.lock().unwrap().clear();
    for i in 1..=3 {
        let o = RunOptions {
            steal: true,
            ..opts(Shard::new(i, 3).unwrap())
        };
        run_units(&dir, &j, &o, run).unwrap();
    }
    let c = counts.lock().unwrap();
    assert_eq!(c.len(), 6, "{c:?}");
    assert!(c.values().all(|&n| n == 1), "{c:?}");
}

/// Units of another build: a resumed run refuses the folder, keeping its results; a
/// merge refuses to mix them with this build's; older files without a build count as none.
#[test]
fn one_job_holds_the_results_of_one_build() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("job");
    let j = job(3);
    open_job(&dir, &j).unwrap();
    let ok = |u: &UnitSpec| Ok(serde_json::json!({"id": u.id}));
    run_units(&dir, &j, &opts(Shard::WHOLE), ok).unwrap();
    let this = crate::unit::build_id();
    assert_eq!(this.len(), 16, "{this:?}");
    assert!(crate::collect(&dir).is_ok());
    let mut u1 = read_unit(&unit_path(&dir, "u1")).unwrap();
    assert_eq!(u1.build, this);
    u1.build = "0123456789abcdef".into();
    write_unit(&dir, &u1).unwrap();
    let resume = RunOptions {
        keep_done: true,
        ..opts(Shard::WHOLE)
    };
    let e = run_units(&dir, &j, &resume, ok).unwrap_err().to_string();
    assert!(e.contains("u1 (build 0123456789abcdef)"), "{e}");
    assert!(e.contains(&format!("than this one ({this})")), "{e}");
    assert_eq!(
        read_unit(&unit_path(&dir, "u1")).unwrap(),
        u1,
        "kept as it was"
    );
    let e = format!("{:#}", crate::collect(&dir).unwrap_err());
    assert!(e.contains("ran on 2 builds"), "{e}");
    assert!(
        e.contains("build 0123456789abcdef: 1 units (first u1)"),
        "{e}"
    );
    // A file from before builds were recorded: neither refused nor counted.
    u1.build.clear();
    write_unit(&dir, &u1).unwrap();
    let r = run_units(&dir, &j, &resume, ok).unwrap();
    assert_eq!(r.kept.len(), 3);
    assert!(crate::collect(&dir).is_ok());
    let text = std::fs::read_to_string(unit_path(&dir, "u1")).unwrap();
    let old: UnitResult = serde_json::from_str(&text.replace("\"build\": \"\",", "")).unwrap();
    assert_eq!(old.build, "");
}

#[test]
fn a_folder_holds_one_job() {
    let d = tempfile::tempdir().unwrap();
    let dir = d.path().join("job");
    open_job(&dir, &job(3)).unwrap();
    // The same job again (another shard, a resume): accepted.
    open_job(&dir, &job(3)).unwrap();
    let e = open_job(&dir, &job(4)).unwrap_err().to_string();
    assert!(e.contains("holds another job"), "{e}");
    // A folder the toolkit did not write is refused.
    let mine = d.path().join("mine");
    std::fs::create_dir(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), "x").unwrap();
    let e = open_job(&mine, &job(3)).unwrap_err().to_string();
    assert!(e.contains("not written by zmp-toolkit"), "{e}");
    assert_eq!(read_job(&dir).unwrap(), job(3));
}

#[test]
fn shards_starting_at_once_all_join_a_new_folder() {
    // The race of an array job's tasks: every shard sees a missing (or just made) folder.
    for round in 0..100 {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("job");
        let results: Vec<Result<()>> = std::thread::scope(|s| {
            let hs: Vec<_> = (0..8)
                .map(|_| s.spawn(|| open_job(&dir, &job(5))))
                .collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for r in results {
            r.unwrap_or_else(|e| panic!("round {round}: {e:#}"));
        }
        assert_eq!(read_job(&dir).unwrap(), job(5));
    }
    // A folder holding only a stale temporary file still is not the toolkit's after the wait
    // (checked without the wait: a non-temporary file ends it at once).
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join(".tmp-x"), "x").unwrap();
    std::fs::write(d.path().join("y"), "y").unwrap();
    assert!(!being_claimed(d.path()));
}
