//! The user's loop on one draw of the independent simulator (`zmp-indep-sim`, which shares
//! no physics code with `zmp-models`), as a test sees it.

use zmp_campaign::{read_campaign, Campaign};
use zmp_diagnose::iterate::{run_loop, LoopResult};
use zmp_diagnose::DiagnoseOptions;
use zmp_identify::IdentifyOptions;
use zmp_indep_sim::{
    draw_with, write_campaign, CouplingForm, Design, DrawOptions, Robot, Scenario,
};
use zmp_models::EffectKind;

/// The loop on draw `seed` of `scenario` from the independent simulator.
#[allow(dead_code)] // not every test that includes this module uses both entry points
pub fn loop_on(seed: u64, scenario: &str) -> LoopResult {
    loop_from(seed, scenario, None)
}

/// [`loop_on`] from a start model whose structure the identification refits (`--model`).
#[allow(dead_code)]
pub fn loop_from(seed: u64, scenario: &str, start: Option<zmp_models::ModelSpec>) -> LoopResult {
    loop_with(seed, scenario, start, &IdentifyOptions::default())
}

/// [`loop_from`] with the identification's options.
#[allow(dead_code)]
pub fn loop_with(
    seed: u64,
    scenario: &str,
    start: Option<zmp_models::ModelSpec>,
    iopts: &IdentifyOptions,
) -> LoopResult {
    loop_drawn(seed, scenario, start, iopts).0
}

/// [`loop_on`] and the drawn robot (its parameters, to check the fitted ones against).
#[allow(dead_code)]
pub fn loop_and_robot(seed: u64, scenario: &str) -> (LoopResult, Robot) {
    loop_drawn(seed, scenario, None, &IdentifyOptions::default())
}

fn loop_drawn(
    seed: u64,
    scenario: &str,
    start: Option<zmp_models::ModelSpec>,
    iopts: &IdentifyOptions,
) -> (LoopResult, Robot) {
    let drawn = drawn_campaign(seed, scenario);
    let (camp, camp_dir) = (drawn.campaign, drawn.dir.path().join("campaign"));
    let opts = DiagnoseOptions {
        campaign_path: camp_dir.display().to_string(),
        model_path: "identified.toml".into(),
        threads: 2,
        ..DiagnoseOptions::default()
    };
    let r = run_loop(&camp, start, iopts, &opts, &|_| {}).unwrap();
    (r, drawn.robot)
}

/// The frequency (rad/s) of the structural mode a model puts on `b`: a flexible link of that
/// input axis or a mode on that output axis's ZMP path.
#[allow(dead_code)]
pub fn mode_frequency(m: &zmp_models::ModelSpec, b: zmp_models::Binding) -> Option<f64> {
    m.value(EffectKind::FlexibleTrunk, b, "omega_n")
        .or_else(|| m.value(EffectKind::StructuralMode, b, "omega_n"))
}

/// Asserts that each plane's mode of the loop's final model lies within `tol[k]` (relative)
/// of the drawn robot's first mode on that axis.
#[allow(dead_code)]
pub fn assert_modes_within(r: &LoopResult, robot: &Robot, tol: [f64; 2], seed: u64) {
    use zmp_models::{Axis, Binding};
    for (k, axis) in robot.axes.iter().enumerate() {
        let b = Binding::Axis([Axis::X, Axis::Y][k]);
        let want = axis.modes[0].omega;
        let got = mode_frequency(&r.final_model, b)
            .unwrap_or_else(|| panic!("draw {seed}: no mode on axis {k}"));
        assert!(
            (got - want).abs() <= tol[k] * want,
            "draw {seed}, axis {k}: mode at {got:.2} rad/s against the drawn {want:.2}"
        );
    }
}

/// A draw of the independent simulator written as a campaign and read back.
#[allow(dead_code)]
pub struct Drawn {
    /// The drawn robot.
    pub robot: Robot,
    /// Its campaign as read back from the files.
    pub campaign: Campaign,
    /// Holds the campaign's files (`campaign/` inside it) while it lives.
    pub dir: tempfile::TempDir,
}

/// Draw `seed` of `scenario` (coupling in the pendulum's form, as the blind suite draws it).
pub fn drawn_campaign(seed: u64, scenario: &str) -> Drawn {
    let design = Design::default();
    let dir = tempfile::tempdir().unwrap();
    let scenario: Scenario = scenario.parse().unwrap();
    let robot = draw_with(
        seed,
        &scenario,
        &design,
        &DrawOptions {
            coupling_form: Some(CouplingForm::Pendulum),
        },
    );
    let camp_dir = dir.path().join("campaign");
    write_campaign(&robot, &design, &camp_dir, true).unwrap();
    let campaign = read_campaign(&camp_dir).unwrap();
    Drawn {
        robot,
        campaign,
        dir,
    }
}

/// Asserts that the loop's last model leaves at most `ratio` times the noise floor.
#[allow(dead_code)]
pub fn assert_final_within(r: &LoopResult, ratio: f64) {
    assert!(
        r.final_error <= ratio * r.noise_floor,
        "final {:.2}x the floor (at most {ratio}x)",
        r.final_error / r.noise_floor
    );
}
