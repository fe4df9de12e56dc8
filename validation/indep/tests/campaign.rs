//! The campaign folder: format, atomic write, overwrite rules, truth kept out.

mod common;
use common::*;
use std::fs;
use zmp_indep_sim::{draw_for_design, write_campaign, AxisName, Design, Scenario};

fn small_design() -> Design {
    Design {
        name: "test \"campaign\"".into(),
        operating_points: vec![[0.0, 0.0], [0.02, -0.01]],
        amplitudes: vec![0.004],
        omegas: vec![2.0, 9.0],
        excited: vec![AxisName::X, AxisName::Y],
        transient_s: 1.0,
        periods: 2.0,
        min_steady_s: 2.0,
        seed: 5,
        ..Design::default()
    }
}

#[test]
fn a_campaign_is_written_in_the_shared_format_and_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("nested").join("camp");
    let design = small_design();
    let robot = draw_for_design(
        3,
        &"single:time_delay".parse::<Scenario>().unwrap(),
        &design,
    );
    write_campaign(&robot, &design, &out, false).unwrap();

    let doc: toml::Table = fs::read_to_string(out.join("campaign.toml"))
        .unwrap()
        .parse()
        .unwrap();
    assert_eq!(doc["format"].as_str(), Some("zmp-campaign/1"));
    assert_eq!(doc["name"].as_str(), Some("test \"campaign\""));
    assert_eq!(doc["sample_rate_hz"].as_float(), Some(200.0));
    let records = doc["records"].as_array().unwrap();
    let specs = design.records();
    assert_eq!(records.len(), 8);
    assert_eq!(specs.len(), 8);
    for (rec, spec) in records.iter().zip(&specs) {
        let file = rec["file"].as_str().unwrap();
        assert_eq!(file, format!("records/r{:03}.csv", spec.index));
        assert_eq!(rec["excited"].as_str(), Some(spec.excited.name()));
        assert_eq!(rec["omega"].as_float(), Some(spec.omega));
        assert_eq!(rec["amplitude"].as_float(), Some(spec.amplitude));
        let op = rec["operating_point"].as_table().unwrap();
        assert_eq!(op["x"].as_float(), Some(spec.operating_point[0]));
        assert_eq!(op["y"].as_float(), Some(spec.operating_point[1]));

        let text = fs::read_to_string(out.join(file)).unwrap();
        let mut lines = text.lines();
        assert_eq!(lines.next(), Some("t,x_cr,y_cr,zmp_x,zmp_y"));
        let rows: Vec<Vec<f64>> = lines
            .map(|l| l.split(',').map(|c| c.parse::<f64>().unwrap()).collect())
            .collect();
        assert_eq!(rows.len(), spec.n_samples);
        let e = spec.excited.index();
        for (k, row) in rows.iter().enumerate() {
            assert_eq!(row.len(), 5);
            assert!(row.iter().all(|v| v.is_finite()));
            let t = k as f64 / 200.0;
            assert!((row[0] - t).abs() < 1e-12);
            // The references are absolute and carry the sine on the excited axis only.
            let mut r = spec.operating_point;
            r[e] += spec.amplitude * (spec.omega * t).sin();
            assert!(
                (row[1] - r[0]).abs() < 1e-15 && (row[2] - r[1]).abs() < 1e-15,
                "row {k}: {row:?}"
            );
            // Quantised to 0.1 mm.
            for v in &row[3..] {
                assert!((v / 1e-4 - (v / 1e-4).round()).abs() < 1e-6);
            }
        }
    }
    // Only the campaign in the folder (no truth), and no temporary left beside it.
    let mut names: Vec<String> = fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["campaign.toml", "records"]);
    let siblings: Vec<_> = fs::read_dir(out.parent().unwrap()).unwrap().collect();
    assert_eq!(siblings.len(), 1, "temporary folders left: {siblings:?}");
    let text = fs::read_to_string(out.join("campaign.toml")).unwrap();
    assert!(
        !text.contains("time_delay") && !text.contains("delay"),
        "the truth leaked: {text}"
    );
}

#[test]
fn an_existing_folder_is_replaced_only_with_force_and_only_if_ours() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("camp");
    let design = Design {
        operating_points: vec![[0.0, 0.0]],
        excited: vec![AxisName::X],
        ..small_design()
    };
    let robot = linear_robot();
    write_campaign(&robot, &design, &out, false).unwrap();
    let before = fs::read_to_string(out.join("records/r000.csv")).unwrap();

    let err = write_campaign(
        &robot,
        &Design {
            seed: 99,
            ..design.clone()
        },
        &out,
        false,
    )
    .unwrap_err();
    assert!(err.to_string().contains("already exists"), "{err}");
    assert_eq!(
        fs::read_to_string(out.join("records/r000.csv")).unwrap(),
        before
    );

    // With force it is replaced (here by a campaign with one record fewer).
    let fewer = Design {
        omegas: vec![2.0],
        ..design.clone()
    };
    write_campaign(&robot, &fewer, &out, true).unwrap();
    assert!(!out.join("records/r001.csv").exists());
    assert_eq!(fs::read_dir(dir.path()).unwrap().count(), 1);

    // A folder this tool did not write is refused even with force, and left alone.
    let foreign = dir.path().join("mine");
    fs::create_dir_all(&foreign).unwrap();
    fs::write(foreign.join("notes.txt"), "keep me").unwrap();
    let err = write_campaign(&robot, &design, &foreign, true).unwrap_err();
    assert!(
        err.to_string()
            .contains("not a campaign written by zmp-indep-sim"),
        "{err}"
    );
    assert_eq!(
        fs::read_to_string(foreign.join("notes.txt")).unwrap(),
        "keep me"
    );
    // Nor one of ours with a file added by someone.
    fs::write(out.join("analysis.txt"), "results").unwrap();
    assert!(write_campaign(&robot, &design, &out, true).is_err());
    assert!(out.join("analysis.txt").exists());
}

#[test]
fn the_truth_round_trips_through_json_and_toml() {
    let robot = draw_for_design(
        8,
        &"pair:backlash,sensor_lowpass".parse::<Scenario>().unwrap(),
        &small_design(),
    );
    let back = zmp_indep_sim::Robot::from_json(&robot.to_json()).unwrap();
    assert_eq!(back, robot);
    // The TOML writer and reader of the `toml` crate round floats to within an ulp or so.
    let back = zmp_indep_sim::Robot::from_toml(&robot.to_toml()).unwrap();
    assert!(close(
        &serde_json::to_value(&back).unwrap(),
        &serde_json::to_value(&robot).unwrap()
    ));
    assert_eq!(robot.hidden_names(), ["backlash", "sensor_lowpass"]);
}

/// Equal JSON trees, numbers within 1e-15 relative.
fn close(a: &serde_json::Value, b: &serde_json::Value) -> bool {
    use serde_json::Value::*;
    match (a, b) {
        (Number(x), Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            (x - y).abs() <= 1e-15 * x.abs().max(y.abs())
        }
        (Array(x), Array(y)) => x.len() == y.len() && x.iter().zip(y).all(|(p, q)| close(p, q)),
        (Object(x), Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| close(v, w)))
        }
        _ => a == b,
    }
}
