//! Findings of the twin written into `docs/src/twin-silo2.md`: why the closed loop takes 52 s,
//! and whether the structural mode the diagnosis names is the stance resonance.

use super::super::campaign;
use super::super::default_mjcf;
use super::super::props::{mass_properties, predict};
use super::super::validate::{validate, Frames, Summary, ValidateOptions};
use super::{short_run, twin};
use zmp_files::sections::check_page as doc_section;

/// The docs page of the twin's findings.
const PAGE: &str = "docs/src/twin-silo2.md";

/// The paper model's step response, simulated as the README's table does, and its first
/// reach time without the pendulum's `b` (the staircase's acceleration no longer reaches the
/// ZMP).
fn paper_model_step(
    seed: zmp_models::controller::CascadeParams,
) -> (zmp_models::closed_loop::StepMetrics, f64) {
    use zmp_models::closed_loop::{run, StepExperiment};
    use zmp_models::controller::CascadeController;
    let paper_spec = zmp_models::ModelSpec::parse(
        include_str!("../../../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap();
    let exp = StepExperiment::silo2();
    let mut plant = zmp_models::Plant::new(&paper_spec, zmp_models::DEFAULT_STEP).unwrap();
    let mut c = CascadeController::new(seed, exp.controller_period);
    let paper = run(&mut plant, &mut c, &exp).metrics(0, &exp);
    // The same without the pendulum's b (the staircase's acceleration no longer reaches the ZMP).
    let mut flat = paper_spec.clone();
    let mut pendulum = flat.pendulum().expect("the paper model's pendulum");
    pendulum.b = [[0.0; 2]; 2];
    flat.set_pendulum(&pendulum);
    let mut plant = zmp_models::Plant::new(&flat, zmp_models::DEFAULT_STEP).unwrap();
    let mut c = CascadeController::new(seed, exp.controller_period);
    let flat_reach = run(&mut plant, &mut c, &exp).metrics(0, &exp).reach_time;
    (paper, flat_reach)
}

/// The twin's closed loop on `exp` with a noise-free sensor (no force noise, quantisation or
/// delay), and its metrics on the true ZMP.
fn quiet_twin_step(
    t: &super::super::Silo2,
    p: &super::super::props::MassProperties,
    exp: &zmp_models::closed_loop::StepExperiment,
) -> super::closed_loop::Metrics {
    use super::closed_loop::{run_twin, Metrics};
    use crate::zmp::ZmpSensorSpec;
    let quiet = ZmpSensorSpec {
        force_noise_std: 0.0,
        quantisation: 0.0,
        delay: 0.0,
        seed: 0,
    };
    let run = run_twin(t, p, exp, quiet, &[], &mut |_, _| Ok(())).unwrap();
    Metrics::of(&run.true_trace(), exp)
}

/// One row of the loop-time table: the dominant poles, damping and predicted first reach of
/// the cascade `ctrl` on a plant of static gain `lever`, beside what the run `how` measured.
fn loop_time_row(
    ctrl: &zmp_models::controller::CascadeParams,
    what: &str,
    lever: f64,
    measured: f64,
    settle: f64,
    how: &str,
) -> String {
    let (re, im) = ctrl.dominant_poles(lever);
    format!(
        "| {what} | {lever:.4} | {re:.3} ± {im:.4}j | {:.2} | {:.1} s | {measured:.1} s \
         ({how}) | {settle:.1} s |\n",
        -re / re.hypot(im),
        ctrl.first_reach_time(lever)
    )
}

/// Why the twin's loop takes 52 s where the seed's takes 20 s. The cascade on a plant seen at
/// its static gain (`lever` m of ZMP per radian of trunk) has the dominant poles
/// `-K2/2 +- j sqrt(K2 kappa - K2^2/4)`, `kappa = e_s K1 lever`
/// (`CascadeParams::dominant_poles`): the twin's lever (0.052 m/rad against the paper model's
/// 0.092) leaves the envelope alone and brings the loop close to critical damping, where the
/// first crossing of the reference comes late. Checked against runs: the paper model
/// (`zmp_models::closed_loop`), the twin with a tenth of the step (linear: 0.06 rad of trunk),
/// and the twin with the whole step (0.6 rad: the CoM moves with `sin(theta)`, the lever falls
/// to `cos(theta)` of itself at the reference).
#[test]
fn the_loops_reach_time_follows_from_its_dominant_pole() {
    use super::closed_loop::{controller_params, seed_zmp_per_radian};
    use zmp_models::closed_loop::StepExperiment;
    use zmp_models::controller::CascadeParams;
    let (_, s) = short_run();
    let t = twin();
    let p = mass_properties(&t).unwrap();
    let up = predict(&t, &p, [p.com_upright[0], p.com_upright[1]]).unwrap();
    let ctrl = controller_params(&p);
    let seed = CascadeParams::silo2();
    // Only e_s K1 K2 and the lever enter: the twin's m_t/m_r, l_t change nothing but the lever.
    assert_eq!(
        (ctrl.k1, ctrl.k2, ctrl.error_scale),
        (seed.k1, seed.k2, seed.error_scale)
    );
    let lever_paper = seed_zmp_per_radian();
    let lever_twin = up.servo.a[0][0] * p.reference_gain();
    let e = &s.closed_loop.experiment;
    let step = e.zmp_ref_after[0] - e.zmp_ref_before[0];
    let theta_ref = (step / lever_twin).asin();
    let lever_tilted = lever_twin * theta_ref.cos();

    // The paper model, simulated as the README's table does.
    let (paper, flat_reach) = paper_model_step(seed);
    let paper_reach = paper.reach_time;
    // The twin with a tenth of the step, noise-free, no load.
    let small = StepExperiment {
        zmp_ref_after: [e.zmp_ref_before[0] + 0.1 * step, e.zmp_ref_before[1]],
        zmp_ref_before: e.zmp_ref_before,
        load_time: f64::INFINITY,
        duration: 100.0,
        load_mass: e.load_mass,
        robot_mass: p.total_mass,
        load_position: e.load_position,
        controller_period: e.controller_period,
    };
    let small_m = quiet_twin_step(&t, &p, &small);
    let small_reach = small_m.reach_time_s;
    let full_reach = s.closed_loop.comparison.twin.reach_time_s;
    let settle = [
        paper.settling_time_2pct,
        small_m.settling_time_2pct_s,
        s.closed_loop.comparison.twin.settling_time_2pct_s,
    ];
    // The envelope -K2/2 is the lever's: the 2 % settling times agree within 20 % (the time
    // to enter the band depends on the damping too: 4/(K2/2) = 40 s is the envelope's).
    for t in settle {
        assert!((t / settle[0] - 1.0).abs() < 0.2, "{settle:?}");
    }

    let pred = |lever: f64| ctrl.first_reach_time(lever);
    // Linear regime: within 10 % of the prediction. The paper model within 20 %: the 100 Hz
    // controller's staircase reaches the ZMP through the pendulum's -b s^2 (the servo passes
    // the steps' acceleration on) and damps the loop a little; b11 is 0.28 s^2 there, 0.12 on
    // the twin (the docs page gives the simulation with b = 0).
    assert!(
        (small_reach / pred(lever_twin) - 1.0).abs() < 0.1,
        "{small_reach}"
    );
    assert!(
        (paper_reach / pred(lever_paper) - 1.0).abs() < 0.2,
        "{paper_reach}"
    );
    // The whole step lies between the upright lever's prediction and the tilted one's.
    assert!(
        full_reach > pred(lever_twin) && full_reach < 1.05 * pred(lever_tilted),
        "{full_reach}: {} .. {}",
        pred(lever_twin),
        pred(lever_tilted)
    );
    let mut text = String::from(
        "| loop | lever (m/rad) | dominant poles (1/s) | zeta | first reach, predicted | \
         measured | 2 % settling, measured |\n| --- | --- | --- | --- | --- | --- | --- |\n",
    );
    text += &loop_time_row(
        &ctrl,
        "paper model",
        lever_paper,
        paper_reach,
        settle[0],
        "zmp_models::closed_loop",
    );
    text += &loop_time_row(
        &ctrl,
        "twin, a tenth of the step",
        lever_twin,
        small_reach,
        settle[1],
        &format!("{:.1} mm, MuJoCo", 100.0 * step),
    );
    text += &loop_time_row(
        &ctrl,
        &format!("twin, the whole step, at its {theta_ref:.2} rad"),
        lever_tilted,
        full_reach,
        settle[2],
        &format!("{:.1} mm, MuJoCo", 1e3 * step),
    );
    text += &format!(
        "\nPredicted ratio twin/paper: {:.2} with the upright lever, {:.2} with the tilted one; \
         measured {:.2}. The paper model with `b = 0`: {flat_reach:.1} s.\n",
        pred(lever_twin) / pred(lever_paper),
        pred(lever_tilted) / pred(lever_paper),
        full_reach / paper_reach
    );
    doc_section(PAGE, "twin-silo2:loop-time", &text);
}

/// The stance resonance swept on the model file, and what the short run's diagnosis named.
/// The sagittal stance resonates near 45 rad/s, well damped (zeta about 0.2); the lateral one
/// lies above 60 rad/s (the legs are a wide frame). A campaign ending at 12 rad/s, a quarter
/// of the lower resonance, cannot place either: whatever mode its diagnosis names is judged an
/// in-band surrogate (its frequency is not the swept one), and an axis with none named says
/// so. (The short campaign's five frequencies per axis leave each fold of the diagnosis's
/// cross-validation two or three: too few to carry a mode's three parameters, and the search
/// names none there.)
#[test]
fn the_stance_resonance_is_swept_and_a_named_mode_judged_against_it() {
    let (_, s) = short_run();
    let axis = |a: zmp_models::Axis| s.stance.iter().find(|x| x.axis == a).unwrap();
    let y = axis(zmp_models::Axis::Y);
    let x = axis(zmp_models::Axis::X);
    assert!((40.0..50.0).contains(&y.fitted.omega_n), "{y:?}");
    assert!(y.fitted.zeta > 0.1 && y.fitted.zeta < 0.4, "{:?}", y.fitted);
    assert!(x.fitted.omega_n > 60.0, "{:?}", x.fitted);
    for a in &s.stance {
        let expected = if a.named.is_some() {
            "in-band surrogate"
        } else {
            "none named"
        };
        assert_eq!(a.verdict, expected, "{}", a.why);
    }
    let mut text = String::from(
        "| axis | swept stance resonance: wm, zeta, share (fit RMS) | peak factor | named by the \
         short run | verdict |\n| --- | --- | --- | --- | --- |\n",
    );
    for a in &s.stance {
        let f = a.fitted;
        text += &format!(
            "| {} | {:.1} rad/s, {:.3}, {:.2} ({:.3}) | {:.2} at {:.1} rad/s | {} | {} |\n",
            a.axis,
            f.omega_n,
            f.zeta,
            f.share,
            a.fit_rms,
            a.peak_magnitude,
            a.peak_omega,
            a.named.map_or("none".into(), |m| format!(
                "`{}` {:.1} rad/s, zeta {:.3}, share {:.3}; share/wm² {:.2e} s² (swept {:.2e} s²)",
                a.named_effect.as_deref().unwrap_or(""),
                m.omega_n,
                m.zeta,
                m.share,
                m.curvature(),
                f.curvature()
            )),
            a.verdict
        );
    }
    doc_section(PAGE, "twin-silo2:stance", &text);
}

/// The extended campaign can run: its most demanding records (0.2 mm of CoM at the two highest
/// frequencies, near and past the sagittal stance resonance, at the outer operating points)
/// keep all eight sole corners loaded and the ZMP at least 40 mm inside the support polygon.
#[test]
fn the_extended_bands_records_keep_the_feet_flat() {
    let t = twin();
    let p = mass_properties(&t).unwrap();
    let design = campaign::TwinDesign::extended();
    design.check().unwrap();
    let band = design.high_band.clone().unwrap();
    let top: Vec<f64> = band.omegas[band.omegas.len() - 2..].to_vec();
    let amp = band.amplitudes.iter().copied().fold(0.0, f64::max);
    let metas: Vec<_> = design
        .records()
        .into_iter()
        .filter(|m| m.amplitude == amp && top.contains(&m.omega) && m.operating_point != [0.0, 0.0])
        .collect();
    assert_eq!(metas.len(), 8);
    assert_eq!(design.records().len(), 240);
    for (k, m) in metas.iter().enumerate() {
        let r = campaign::simulate_record(&t, &p, &design, m, k).unwrap();
        let s = p.support;
        for (x, y) in r.zmp_x.iter().zip(&r.zmp_y) {
            let inside = (x - s[0]).min(s[1] - x).min(y - s[2]).min(s[3] - y);
            assert!(
                inside > 0.04,
                "{m:?}: ZMP ({x}, {y}) within {inside} m of the edge"
            );
        }
    }
}

/// The campaign extended to 50 rad/s decides what the mode is: validate on the full campaign
/// (0.5-12 rad/s) and on the extended one, and compare what each names on the sagittal axis
/// with the swept stance resonance. The guard in CI is the short run's verdict above and the
/// records' check just above.
#[test]
#[ignore = "long: two full validations of the twin, about 6 minutes on 2 cores"]
fn extended_campaign_finds_the_stance_resonance() {
    let dir = tempfile::tempdir().unwrap();
    let run = |extended: bool| {
        validate(&ValidateOptions {
            model: default_mjcf(),
            out: dir.path().join(if extended { "extended" } else { "full" }),
            short: false,
            extended,
            force: false,
            threads: 2,
            quiet: true,
            frames: Frames::Skip("frames not rendered: tests".into()),
            zmp_delay: 0.0,
        })
        .unwrap()
    };
    let full = run(false);
    let ext = run(true);
    let y = |s: &Summary| {
        s.stance
            .iter()
            .find(|a| a.axis == zmp_models::Axis::Y)
            .unwrap()
            .clone()
    };
    // A campaign ending at 12 rad/s cannot place the 45 rad/s resonance (whatever it names is
    // a surrogate, or it names none); the one reaching past it names the resonance itself.
    assert_ne!(y(&full).verdict, "physical", "{}", y(&full).why);
    assert_eq!(y(&ext).verdict, "physical", "{}", y(&ext).why);
    let mut text = String::from(
        "| campaign | records | axis | named mode | \\|G\\| at its frequency: model, twin | swept \
         resonance | verdict |\n| --- | --- | --- | --- | --- | --- | --- |\n",
    );
    for (name, s) in [
        ("0.5-12 rad/s (full)", &full),
        ("0.5-50 rad/s (extended)", &ext),
    ] {
        for a in &s.stance {
            text += &format!(
                "| {name} | {} | {} | {} | {} | {:.1} rad/s, zeta {:.3} | {} |\n",
                s.campaign.records,
                a.axis,
                a.named.map_or("none".into(), |m| format!(
                    "`{}` {:.1} rad/s, zeta {:.3}, share {:.3}",
                    a.named_effect.as_deref().unwrap_or(""),
                    m.omega_n,
                    m.zeta,
                    m.share
                )),
                a.at_named
                    .map_or("".into(), |(twin, model)| format!("{model:.1}, {twin:.1}")),
                a.fitted.omega_n,
                a.fitted.zeta,
                a.verdict
            );
        }
    }
    text += &format!(
        "\nDiagnosis error against the noise floor, before and after the loop: full {:.2}x -> \
         {:.2}x, extended {:.2}x -> {:.2}x.\n",
        full.diagnosis.baseline_error / full.diagnosis.noise_floor,
        full.diagnosis.final_error / full.diagnosis.noise_floor,
        ext.diagnosis.baseline_error / ext.diagnosis.noise_floor,
        ext.diagnosis.final_error / ext.diagnosis.noise_floor
    );
    doc_section(PAGE, "twin-silo2:stance-campaigns", &text);
}
