//! The second seed's walking comparison on the twin as `cargo xtask calibrate-com` runs it: the
//! calibration (200 noise draws), the virtual models n, r, s, v (and e), 5 walks each open loop
//! and 5 with the seed's Torso Position Control. It writes the numbers of
//! `docs/src/com-calibration.md` (with `ZMP_UPDATE_DOCS=1`; otherwise the page must hold what
//! this run measured). About 10-40 s on 2 cores.

use zmp_models::walking::Gait;
use zmp_twin::sabian::calibrate::FOOT_SPACING;
use zmp_twin::sabian::effort::claim_of;
use zmp_twin::sabian::experiment::{calibrate, virtual_models, walk_models, ModelOutcome, Options};
use zmp_twin::sabian::report::{sections, Outcome};

fn bias(w: &zmp_twin::sabian::experiment::Walks) -> f64 {
    w.mean.bias[0].hypot(w.mean.bias[1])
}

#[test]
fn the_seeds_walks_open_loop_and_with_torso_position_control() {
    let opt = Options::full();
    let cal = calibrate(&opt).unwrap();
    let models = virtual_models(&cal);
    let gait = Gait::seed(FOOT_SPACING);
    let out = walk_models(&models, &opt, &gait).unwrap();
    let end_x = gait.strides_m.iter().sum::<f64>() / 2.0;
    for m in &out {
        for (what, w) in [("open loop", &m.open_loop), ("TPC", &m.with_tpc)] {
            assert_eq!(w.traces.len(), opt.runs);
            for r in &w.traces {
                // It really walks and ends standing 1.4 m ahead (Run::finished_standing: no
                // fall, pelvis at its height and upright, both soles on the floor).
                assert!(
                    r.finished_standing(end_x),
                    "model {} ({what}) did not finish standing: fell {} at {:?} s, pelvis at \
                     ({:.3}, {:.3}) m, tilt {:.2} deg, soles {:?} m",
                    m.name,
                    r.fell,
                    r.fall_time_s,
                    r.final_pelvis[0],
                    r.final_pelvis_height_m,
                    r.final_tilt_deg,
                    r.final_sole_heights_m
                );
            }
            assert!(
                w.min_clearance_m > 0.02,
                "model {} feet reach {} m",
                m.name,
                w.min_clearance_m
            );
            assert_eq!(w.finished_standing, opt.runs);
        }
        check_steady_torso_shift(m);
        // The integral action removes each model's static ZMP error: what is left with TPC is
        // under 1 mm (4 x the calibration's horizontal accuracy) for every model, and for the
        // models with a CoM error of more than 1 cm under a fifth of the open-loop bias.
        let (open, closed) = (bias(&m.open_loop), bias(&m.with_tpc));
        assert!(closed < 1e-3, "model {}: bias with TPC {closed} m", m.name);
        if m.com_error_m[0].hypot(m.com_error_m[1]) > 0.01 {
            assert!(
                closed < 0.2 * open,
                "model {}: {open} -> {closed} m",
                m.name
            );
        }
    }
    check_open_loop_ranking(&out);
    // With the control the models differ less: the spread of the XY RMS (root-sum-square) over
    // the five models is less than half of the open loop's (the control removes the static part
    // of each model's error, which is what sets them apart).
    let spread = |f: &dyn Fn(&ModelOutcome) -> f64| {
        let v: Vec<f64> = out.iter().map(f).collect();
        v.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - v.iter().cloned().fold(f64::INFINITY, f64::min)
    };
    let rss = |w: &zmp_twin::sabian::experiment::Walks| w.mean.rms_pos[0].hypot(w.mean.rms_pos[1]);
    let (so, st) = (
        spread(&|m| rss(&m.open_loop)),
        spread(&|m| rss(&m.with_tpc)),
    );
    assert!(st < 0.5 * so, "spread open loop {so} m, with TPC {st} m");
    // The seed's claim is tested and reported either way (the docs say which); here only that
    // the models could be ranked.
    let claim = claim_of(&out).unwrap();
    assert!(claim.ranked_pairs >= 4, "{claim:?}");
    let outcome = Outcome {
        format: "zmp-com-calibration/1".into(),
        command: "cargo xtask calibrate-com".into(),
        runs_per_model: opt.runs,
        calibration: cal,
        walking: out,
    };
    for (tag, text) in sections(&outcome) {
        zmp_files::sections::check_page("docs/src/com-calibration.md", tag, &text);
    }
}

/// While the robot still stands (phase 70, 2.13 s: the preview controller starts moving the CoM
/// 1.6 s before the first step at 3.84 s), the torso shift follows the closed-form response of
/// the cart-table loop (`zmp_models::walking::torso`, critically damped, poles at -2/tau_c) to
/// the model's static error: shift = (model CoM - real CoM without control) / (real CoM shift
/// per torso shift) x (1 - (1 + 2t/tau_c) e^(-2t/tau_c)), with MuJoCo's true CoM of the
/// open-loop run with the same perturbation (so the servos' sag is in it). 0.5 mm: the closed
/// form is of the cart-table plant; the twin adds the servos' and contacts' dynamics and the
/// robot's settling on the floor in its first 0.2 s.
fn check_steady_torso_shift(m: &ModelOutcome) {
    const STANDING: usize = 70;
    let mut worst: f64 = 0.0;
    let plan = m.plan.as_ref().unwrap();
    let tau = m.tpc.unwrap().closed_loop_s;
    for (open, tpc) in m.open_loop.traces.iter().zip(&m.with_tpc.traces) {
        let t = (STANDING + 1) as f64 * 0.03;
        let x = 2.0 * t / tau;
        let reached = 1.0 - (1.0 + x) * (-x).exp();
        let c_real = open.com[STANDING];
        let shift = tpc.torso_shift[STANDING];
        for c in 0..2 {
            let expect = (plan.com_at_start[c] - c_real[c]) / m.real_com_per_shift[c] * reached;
            worst = worst.max((shift[c] - expect).abs());
            assert!(
                (shift[c] - expect).abs() < 5e-4,
                "model {} axis {c}: shift {:.3} mm, expected {:.3} mm",
                m.name,
                shift[c] * 1e3,
                expect * 1e3
            );
        }
    }
    eprintln!(
        "model {}: torso shift against the closed form, largest deviation {:.3} mm",
        m.name,
        worst * 1e3
    );
}

/// Open loop (the twin's earlier result, unchanged): model r has the lowest XY RMS and ZMP bias
/// of the seed's four, and e (the model whose CoM is the calibrated one) removes most of the
/// bias.
fn check_open_loop_ranking(out: &[ModelOutcome]) {
    let seed4: Vec<&ModelOutcome> = out.iter().filter(|m| m.name != "e").collect();
    let rms = |m: &&ModelOutcome| m.open_loop.mean.rms_pos[2];
    let ob = |m: &&ModelOutcome| bias(&m.open_loop);
    let best_rms = seed4
        .iter()
        .min_by(|a, b| rms(a).total_cmp(&rms(b)))
        .unwrap();
    let best_bias = seed4.iter().min_by(|a, b| ob(a).total_cmp(&ob(b))).unwrap();
    assert_eq!(best_rms.name, "r", "lowest XY RMS: {}", best_rms.name);
    assert_eq!(best_bias.name, "r", "lowest bias: {}", best_bias.name);
    let e = out.iter().find(|m| m.name == "e").unwrap();
    assert!(
        ob(&e) < 0.5 * ob(best_bias),
        "e {} vs r {}",
        ob(&e),
        ob(best_bias)
    );
}
