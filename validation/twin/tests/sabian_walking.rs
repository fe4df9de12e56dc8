//! The second seed's walking comparison on the twin, short (one run per model; the full five
//! runs are `cargo xtask calibrate-com`).

use zmp_models::walking::Gait;
use zmp_twin::sabian::calibrate::FOOT_SPACING;
use zmp_twin::sabian::experiment::{calibrate, virtual_models, walk_models, Options};

#[test]
fn every_model_walks_and_model_r_is_the_best_of_the_seeds_four() {
    let mut opt = Options::quick();
    opt.draws = 3;
    let cal = calibrate(&opt).unwrap();
    let models = virtual_models(&cal);
    let gait = Gait::seed(FOOT_SPACING);
    let out = walk_models(&models, &opt, &gait).unwrap();
    for m in &out {
        let r = &m.traces[0];
        assert_eq!(m.falls, 0, "model {} fell at {:?} s", m.name, r.fall_time_s);
        // It really walks: the feet lift and the robot ends 1.4 m ahead.
        assert!(
            m.min_clearance_m > 0.02,
            "model {}: feet reach {} m",
            m.name,
            m.min_clearance_m
        );
        assert!(
            (r.final_pelvis[0] - 1.4).abs() < 0.1,
            "model {} ended at x = {}",
            m.name,
            r.final_pelvis[0]
        );
    }
    let seed4: Vec<_> = out.iter().filter(|m| m.name != "e").collect();
    let rms = |m: &&zmp_twin::sabian::experiment::ModelOutcome| m.mean.rms_pos[2];
    let bias =
        |m: &&zmp_twin::sabian::experiment::ModelOutcome| m.mean.bias[0].hypot(m.mean.bias[1]);
    let best_rms = seed4
        .iter()
        .min_by(|a, b| rms(a).total_cmp(&rms(b)))
        .unwrap();
    let best_bias = seed4
        .iter()
        .min_by(|a, b| bias(a).total_cmp(&bias(b)))
        .unwrap();
    assert_eq!(best_rms.name, "r", "lowest XY RMS: {}", best_rms.name);
    assert_eq!(best_bias.name, "r", "lowest bias: {}", best_bias.name);
    // The model whose CoM is the calibrated one (e) removes most of the bias.
    let e = out.iter().find(|m| m.name == "e").unwrap();
    assert!(
        bias(&e) < 0.5 * bias(best_bias),
        "e {} vs r {}",
        bias(&e),
        bias(best_bias)
    );
}
