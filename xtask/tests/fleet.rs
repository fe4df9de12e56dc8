//! `cargo xtask fleet` on 8 campaign folders: 7 drawn by the independent simulator
//! (zmp-indep-sim; clean robots and robots whose only effect is the saturation the seed's
//! structure carries, each loop a few seconds), one malformed. The 7 loops run and end
//! explained, the malformed campaign is one failed unit whose error names its file, line and
//! column, and once fixed it is re-run alone and the merge is complete; the fleet as 3 shards
//! merges to the same table and JSON.

mod support;

use support::{ok, xtask};
use zmp_indep_sim::{draw_with, write_campaign, CouplingForm, Design, DrawOptions};

#[test]
fn a_fleet_of_eight_campaigns_gives_seven_loops_and_one_clear_error() {
    let d = tempfile::tempdir().unwrap();
    let fleet = d.path().join("fleet");
    let design = Design::default();
    for k in 0..8u64 {
        let scenario = if k % 2 == 0 {
            "clean"
        } else {
            "single:acceleration_saturation"
        };
        let robot = draw_with(
            100 + k,
            &scenario.parse().unwrap(),
            &design,
            &DrawOptions {
                coupling_form: Some(CouplingForm::Pendulum),
            },
        );
        write_campaign(&robot, &design, &fleet.join(format!("robot-{k}")), true).unwrap();
    }
    // Robot 5's third record loses a number.
    let bad = fleet.join("robot-5/records/r002.csv");
    let good = std::fs::read_to_string(&bad).unwrap();
    let mut lines: Vec<String> = good.lines().map(String::from).collect();
    lines[3] = lines[3].replacen(|c: char| c.is_ascii_digit(), "x", 1);
    std::fs::write(&bad, lines.join("\n") + "\n").unwrap();

    let out = d.path().join("night");
    let (f, o) = (fleet.to_str().unwrap(), out.to_str().unwrap());
    let run = xtask(&["fleet", f, "--out", o, "--json"], d.path());
    assert!(!run.status.success(), "a failed unit makes the fleet fail");
    let v: serde_json::Value = serde_json::from_slice(&run.stdout).unwrap();
    let loops = v["result"]["loops"].as_array().unwrap();
    assert_eq!(loops.len(), 7, "{v:#}");
    for l in loops {
        assert_eq!(l["loop"]["outcome"], "explained", "{l:#}");
        let id = l["campaign"].as_str().unwrap();
        assert!(out.join("loops").join(id).join("identified.toml").is_file());
    }
    let failed = v["result"]["failed"].as_array().unwrap();
    assert_eq!(failed.len(), 1);
    assert_eq!(failed[0]["campaign"], "robot-5");
    let e = failed[0]["error"].as_str().unwrap();
    assert!(e.contains("records/r002.csv:4: column t"), "{e}");
    assert!(!out.join("loops/robot-5/identified.toml").exists());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("failed unit robot-5"), "{err}");
    let table = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert_eq!(table.matches("| explained |").count(), 7, "{table}");

    // Fixed, robot 5 is re-run alone; the merge is complete and counts each robot once.
    std::fs::write(&bad, good).unwrap();
    ok(
        xtask(&["fleet", f, "--out", o, "--unit", "robot-5"], d.path()),
        "fleet --unit robot-5",
    );
    let m: serde_json::Value =
        serde_json::from_str(&ok(xtask(&["merge", o, "--json"], d.path()), "merge")).unwrap();
    assert_eq!(m["result"]["loops"].as_array().unwrap().len(), 8);
    assert_eq!(m["units"]["failed"].as_array().unwrap().len(), 0);
    assert_eq!(m["cost"]["units"], 8);

    // The same fleet as 3 shards, merged: the one-process run's table and JSON (its loops'
    // paths aside, which name the job folder).
    let sharded = d.path().join("night-3");
    let s = sharded.to_str().unwrap();
    for i in 1..=3 {
        let shard = format!("{i}/3");
        ok(
            xtask(&["fleet", f, "--out", s, "--shard", &shard], d.path()),
            "fleet --shard",
        );
    }
    ok(xtask(&["merge", s], d.path()), "merge of 3 shards");
    for file in ["table.md", "result.json"] {
        let one = std::fs::read_to_string(out.join(file)).unwrap();
        let three = std::fs::read_to_string(sharded.join(file)).unwrap();
        assert_eq!(three.replace(s, o), one, "{file}");
    }
}
