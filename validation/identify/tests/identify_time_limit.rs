//! Identification honours the time limit of the work it serves (issue 53, defect 8): `loop
//! --time-limit 5` took 12-15 s on 10 000 records because identification ran outside the
//! limit. Now, past the deadline (`par::with_deadline`, which `loop` sets from the start of the
//! command), the records not yet analysed are left out with the reason, and identification
//! ends with those it analysed.

use std::time::{Duration, Instant};
use zmp_identify::{identify_with_progress, IdentifyOptions};
use zmp_models::logspace;
use zmp_models::ModelSpec;
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

#[test]
fn defect_8_identification_stops_at_the_time_limit() {
    let paper = ModelSpec::parse(
        include_str!("../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap();
    let d = ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.005],
        omegas: logspace(0.5, 15.0, 14),
        ..ExperimentDesign::reference()
    };
    let camp = simulate_campaign(&paper, &d).unwrap();
    let n = camp.records.len();
    // One thread: records are analysed in order, the progress called after each. After the
    // 20th the deadline is made to pass (the progress waits for it): the rest must be left out.
    let opts = IdentifyOptions {
        threads: Some(1),
        ..IdentifyOptions::default()
    };
    let deadline = Instant::now() + Duration::from_millis(200);
    let progress = |done: usize| {
        if done == 20 {
            while Instant::now() <= deadline {
                std::thread::sleep(Duration::from_millis(20));
            }
        }
    };
    let ident = zmp_campaign::par::with_deadline(Some(deadline), || {
        identify_with_progress(&camp, &opts, &progress)
    })
    .expect("identified from the records analysed in time");
    let left_out: Vec<usize> = ident
        .records
        .iter()
        .filter(|r| {
            r.excluded
                .as_deref()
                .is_some_and(|w| w.contains("time limit"))
        })
        .map(|r| r.index)
        .collect();
    assert_eq!(
        left_out,
        (20..n).collect::<Vec<_>>(),
        "{:?}",
        ident.warnings
    );
    // Without a deadline every record is analysed.
    let all = identify_with_progress(&camp, &opts, &|_| {}).unwrap();
    assert!(
        all.records.iter().all(|r| r.excluded.is_none()),
        "{:?}",
        all.warnings
    );
}
