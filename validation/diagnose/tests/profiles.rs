//! Profiles, one effect at a time: the effect simulated alone on the virtual robot (the
//! seed's model plus the effect; the standard test campaign: 3 and 8 mm sines, 8 frequencies
//! from 0.5 to 15 rad/s, both axes, at the origin; at three operating points for the
//! operating-point dependence), diagnosed against the seed's model (with its coupling terms
//! at zero for the coupling's), must be named alone with its parameters within stated
//! tolerances and the diagnosis end explained. The delay's is in `diagnose_core.rs`. A
//! profile the diagnosis does not name as it should keeps its test, ignored as a known
//! failure with what the diagnosis said.

use zmp_diagnose::{diagnose, Candidate, DiagnoseOptions, Law, Verdict};
use zmp_models::effects::sensor_drift::record_rate;
use zmp_models::{logspace, Axis, Binding, EffectKind, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

const PAPER: &str = include_str!("../../../models/params/silo2-paper.toml");

fn design() -> ExperimentDesign {
    ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, 15.0, 8),
        excited: vec![Axis::X, Axis::Y],
        ..ExperimentDesign::reference()
    }
}

/// Diagnoses the seed's model on a campaign of the seed's model plus `extra` (TOML) on the
/// standard design; the verdict must name `kind` under `law`, and every fitted parameter whose
/// dotted name ends with `param` must lie within `rel` of `truth`.
fn named(extra: &str, kind: EffectKind, law: Law, param: &str, truth: f64, rel: f64) {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let truth_spec = seed_plus(extra);
    named_as(
        &paper,
        &truth_spec,
        &design(),
        Candidate::new(kind, law),
        &[(param, truth, rel)],
    );
}

/// The seed's model plus `extra` (TOML).
fn seed_plus(extra: &str) -> ModelSpec {
    ModelSpec::parse(&format!("{PAPER}\n{extra}"), "truth.toml").unwrap()
}

/// Diagnoses `model` on a campaign of `truth` simulated on `design`; the verdict must name
/// `expected` alone and the diagnosis end explained, and for each `(param, truth, rel)` every
/// fitted parameter of the finding whose dotted name ends with `param` (`level`, `y.omega_n`,
/// `a12`) must lie within `rel` of `truth` (at least one must).
fn named_as(
    model: &ModelSpec,
    truth: &ModelSpec,
    design: &ExperimentDesign,
    expected: Candidate,
    params: &[(&str, f64, f64)],
) -> zmp_diagnose::Diagnosis {
    let camp = simulate_campaign(truth, design).unwrap();
    let opts = DiagnoseOptions {
        threads: 2,
        ..DiagnoseOptions::default()
    };
    let d = diagnose(&camp, model, &opts, &|_| {}).unwrap();
    println!("{}", d.to_text());
    for t in &d.tried {
        println!(
            "tried {}: held-out error {:.4}, z {:.1}",
            t.structure, t.held_out_error, t.z
        );
    }
    assert_eq!(d.verdict, Verdict::Effect(expected), "{}", d.to_text());
    assert_eq!(d.selected.len(), 1, "the effect alone: {}", d.to_text());
    let f = &d.findings[0];
    println!(
        "fitted {:?}\nstandard errors {:?}",
        f.parameters, f.std_errors
    );
    for &(param, truth, rel) in params {
        let fitted: Vec<f64> = f
            .parameters
            .iter()
            .filter(|(n, _)| n.ends_with(param))
            .map(|(_, v)| *v)
            .collect();
        assert!(!fitted.is_empty(), "no {param} in {:?}", f.parameters);
        for v in fitted {
            assert!(
                (v / truth - 1.0).abs() < rel,
                "{param} = {v}, truth {truth}"
            );
        }
    }
    assert!(d.explained, "{}", d.to_text());
    d
}

/// A ZMP sensor filtered at 20 rad/s (37 degrees of lag at the top of the sweep): its cutoff
/// within 5 % (the lag is measured to a fraction of a degree on every record).
#[test]
fn a_sensor_lowpass_is_named_with_its_cutoff() {
    named(
        "[sensor_lowpass]\ncutoff = 20.0\n",
        EffectKind::SensorLowpass,
        Law::Only,
        "cutoff",
        20.0,
        0.05,
    );
}

/// A ZMP sensor whose offset drifts at 0.02 mm/s (1.2 mm over a minute-long record): its rate
/// within 10 % (the trend of each record is fitted with its own standard error).
#[test]
fn a_sensor_drift_is_named_with_its_rate() {
    named(
        "[sensor_drift]\noffset = 0.0\nrate = 2e-5\n",
        EffectKind::SensorDrift,
        Law::Only,
        "rate",
        2e-5,
        0.10,
    );
}

/// A ZMP sensor re-zeroed at every record whose drift rate changes from record to record:
/// 0.02 mm/s on average, 0.05 mm/s from record to record (the 32 records' rates drawn by the
/// model's own generator). Named per record, alone and explained; the model keeps the mean and
/// the spread of the rates the records drifted at within 10 % of that spread (each record's
/// trend is measured to about a tenth of it).
#[test]
fn a_sensor_drift_per_record_is_named_with_its_rates() {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let (rate, spread, seed) = (2e-5, 5e-5, 7);
    let truth = seed_plus(&format!(
        "[sensor_drift]\noffset = 0.0\nrate = {rate:e}\nrate_spread = {spread:e}\nrate_seed = {seed}\n"
    ));
    let d = named_as(
        &paper,
        &truth,
        &design(),
        Candidate::new(EffectKind::SensorDrift, Law::PerRecord),
        &[],
    );
    // The words say on which outputs the rates differ beyond their noise: both here.
    assert!(
        d.findings[0]
            .evidence
            .contains("beyond their noise on x and y"),
        "{}",
        d.findings[0].evidence
    );
    let records = simulate_campaign(&truth, &design()).unwrap().records.len();
    for a in [Axis::X, Axis::Y] {
        let drawn: Vec<f64> = (0..records as u64)
            .map(|k| record_rate(rate, spread, seed, a.index(), k))
            .collect();
        let n = drawn.len() as f64;
        let mean = drawn.iter().sum::<f64>() / n;
        let sd = (drawn.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let got = |p| {
            d.final_model
                .value(EffectKind::SensorDrift, Binding::Axis(a), p)
                .unwrap()
        };
        println!(
            "{a:?}: drawn mean {mean:e} sd {sd:e}; model {:e} {:e}",
            got("rate"),
            got("rate_spread")
        );
        assert!((got("rate") - mean).abs() < 0.1 * spread, "{a:?}");
        assert!((got("rate_spread") - sd).abs() < 0.1 * spread, "{a:?}");
    }
}

/// A play of 0.6 mm on the CoM command (a fifth of the small sine): its width within 15 %
/// (the play's lag and gain loss on the 3 mm sines carry it; the 8 mm ones barely see it).
#[test]
#[ignore = "known failure (found 2026-12-07, the same at 0e673f4): named alone, widths 0.601 and 0.606 mm (within 1 %), but not explained: 1.3x the floor, a trend in every record on the x ZMP changing from record to record (mean 0.001 mm/s, spread 0.056 mm/s) is left; the run was ignored as long, never as failing"]
fn a_play_on_the_command_is_named_with_its_width() {
    named(
        "[backlash]\nwidth = 0.0006\n",
        EffectKind::Backlash,
        Law::OnCommand,
        "width",
        0.0006,
        0.15,
    );
}

/// Coulomb friction of 0.3 m/s^2 on both servos: it shifts the servo by about
/// `level / wn^2` = 0.33 mm, a ninth of the 3 mm sine and a twenty-fourth of the 8 mm one, so
/// the small sines lag and shrink where the large ones barely do. Its level within 15 %: each
/// record's amplitude is measured to about 0.02 mm (0.5 mm sample noise over more than 1,600
/// samples), a few per cent of the friction's 0.3 mm; the margin is for the refitted core
/// absorbing part of the gain the friction takes from every sine.
#[test]
#[ignore = "known failure, and long (63 s on 2 cores, 2026-12-07): named alone, levels 0.302 and 0.305, but not explained (1.2x the floor; the G11 8 mm cell at 2.1-3.5 rad/s stays at 3.7x its floor, as the true model's own prediction leaves it)"]
fn a_coulomb_friction_is_named_with_its_level() {
    named(
        "[coulomb_friction]\nlevel = 0.3\n",
        EffectKind::CoulombFriction,
        Law::Only,
        "level",
        0.3,
        0.15,
    );
}

/// A force limit of 0.8 m/s^2 on both servos: the steady sines demand `w^2 |H(w)| A` of the
/// CoM, at most 0.54 m/s^2 on the 3 mm records (15 rad/s) and 1.44 m/s^2 on the 8 mm ones, so
/// only the 8 mm sines at the top of the sweep clip (1.8 times the limit) and every 3 mm sine
/// stays linear (a margin of 1.5). Its limit within 10 %: at 1.8 times overdrive the clipped
/// records lose a large part of their gain and carry a third harmonic, each measured to a
/// fraction of a per cent, and the limit is the one parameter that sets them.
#[test]
fn an_acceleration_saturation_is_named_with_its_limit() {
    named(
        "[acceleration_saturation]\nlimit = 0.8\n",
        EffectKind::AccelerationSaturation,
        Law::Only,
        "limit",
        0.8,
        0.10,
    );
}

/// A force limit of 0.58 m/s^2, the one window of the standard design where the 8 mm sines
/// clip at two sweep frequencies (they demand 0.62 m/s^2 at 9.2 rad/s and 1.44 at 15) and the
/// 3 mm ones at none (0.54 at most, 93 % of the limit): each of the two frequency folds then
/// holds a clipped record and determines the limit, which a limit acting at the top frequency
/// alone is not (the test above). Its limit within 10 %, for the reason above.
#[test]
fn an_acceleration_saturation_at_two_frequencies_is_named_with_its_limit() {
    named(
        "[acceleration_saturation]\nlimit = 0.58\n",
        EffectKind::AccelerationSaturation,
        Law::Only,
        "limit",
        0.58,
        0.10,
    );
}

/// A trunk mode at 8 rad/s with damping ratio 0.08 on the sagittal ZMP path (the whole path
/// rings): inside the band, between the sweep's 5.7 and 9.2 rad/s, where it raises the gain
/// to 2.0 and 2.6 with 13 and 151 degrees of lag. Its frequency within 3 %: a 3 % shift moves
/// the phase at 9.2 rad/s by 6 degrees, while each record's phase is measured to a fraction
/// of a degree.
#[test]
#[ignore = "known failure: names structural_mode (in_servo, y) at 3.57 rad/s, zeta 0.005, 86x the floor left; the mode on the y ZMP path scores 0.452 held-out against 0.468 without it; refitted from the truth it ends at 8.000 rad/s, 0.9x the floor"]
fn a_structural_mode_is_named_with_its_frequency() {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let truth = seed_plus("[structural_mode.y]\nomega_n = 8.0\nzeta = 0.08\n");
    named_as(
        &paper,
        &truth,
        &design(),
        Candidate::on(EffectKind::StructuralMode, Law::OnZmpPath, Axis::Y),
        &[("y.omega_n", 8.0, 0.03)],
    );
}

/// The pendulum's `a` and `b` moving with the CoM position, the same relative slopes for every
/// channel (the catalogue's law): `da_dx` 4, `da_dy` 5, `db_dx` -5, `db_dy` 6 per metre, so
/// the operating points 2 cm off the origin along x and y change `a` by 8-10 % and `b` by
/// 10-12 %. The standard design at those three points (the reference's), 96 records. Each
/// slope within 10 %, a change of the gain of about 1 %: each record's gain is measured to
/// about 1 % and some 30 records at each operating point away from the origin carry it.
#[test]
fn an_operating_point_dependence_is_named_with_its_slopes() {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let truth = seed_plus(
        "[operating_point_dependence]\nda_dx = 4.0\nda_dy = 5.0\ndb_dx = -5.0\ndb_dy = 6.0\n",
    );
    let design = ExperimentDesign {
        operating_points: vec![[0.0, 0.0], [0.02, 0.0], [0.0, 0.02]],
        ..design()
    };
    named_as(
        &paper,
        &truth,
        &design,
        Candidate::new(EffectKind::OperatingPointDependence, Law::Only),
        &[
            ("da_dx", 4.0, 0.10),
            ("da_dy", 5.0, 0.10),
            ("db_dx", -5.0, 0.10),
            ("db_dy", 6.0, 0.10),
        ],
    );
}

/// The same dependence with each channel its own slopes (issue 55, item 6): the lateral
/// channel `G11` moving with x only (`da_dx` 4, `db_dx` -5 per metre), the sagittal `G22` with
/// y only (`da_dy` 5, `db_dy` 6 per metre), the coupling channels not at all; named under the
/// per-channel law (the common law cannot give two channels different slopes), the design and
/// the tolerances as for the common slopes (the same gains move by the same amounts).
#[test]
fn an_operating_point_dependence_per_channel_is_named_with_its_slopes() {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let truth = seed_plus(
        "[operating_point_dependence.G11]\nda_dx = 4.0\ndb_dx = -5.0\n\
         [operating_point_dependence.G22]\nda_dy = 5.0\ndb_dy = 6.0\n",
    );
    let design = ExperimentDesign {
        operating_points: vec![[0.0, 0.0], [0.02, 0.0], [0.0, 0.02]],
        ..design()
    };
    named_as(
        &paper,
        &truth,
        &design,
        Candidate::new(EffectKind::OperatingPointDependence, Law::PerChannel),
        &[
            ("G11.da_dx", 4.0, 0.10),
            ("G11.db_dx", -5.0, 0.10),
            ("G22.da_dy", 5.0, 0.10),
            ("G22.db_dy", 6.0, 0.10),
        ],
    );
}

/// One channel's slopes (`G11` moving with x: `da_dx` 4, `db_dx` -5 per metre) on operating
/// points along one line, as the standard campaigns of `zmp-indep-sim` lie ((0, 0) and
/// +-(3, 2) cm): the records carry the slopes along the line only, and the per-channel law
/// frees each channel's along x (the axis the line runs most along), which for slopes along x
/// are the truth's; the tolerances as above.
#[test]
fn an_operating_point_dependence_per_channel_on_a_line_is_named_with_its_slopes() {
    let paper = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let truth = seed_plus("[operating_point_dependence.G11]\nda_dx = 4.0\ndb_dx = -5.0\n");
    let design = ExperimentDesign {
        operating_points: vec![[0.0, 0.0], [0.03, 0.02], [-0.03, -0.02]],
        ..design()
    };
    named_as(
        &paper,
        &truth,
        &design,
        Candidate::new(EffectKind::OperatingPointDependence, Law::PerChannel),
        &[("G11.da_dx", 4.0, 0.10), ("G11.db_dx", -5.0, 0.10)],
    );
}

/// The seed's coupling terms (`a12` 0.075, `a21` 0.19, `b12` 0.0054, `b21` 0.10) in the
/// truth, diagnosed against the seed's model with all four at zero: the unexcited ZMP axis
/// answers, the lateral one to a sagittal 8 mm sine by 0.6 mm at low frequency (`a12`) and by
/// up to 1 mm at the top of the sweep (`b12 w^2`). Each term within 10 %: each record's
/// cross response is measured to about 0.02 mm, a few per cent of the smallest (`a12` on the
/// 3 mm sines), and tens of records carry each term.
#[test]
fn a_cross_coupling_is_named_with_its_terms() {
    let truth = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    let mut model = truth.clone();
    for p in ["a12", "a21", "b12", "b21"] {
        assert!(model.set_value(EffectKind::Pendulum, Binding::Global, p, 0.0));
    }
    named_as(
        &model,
        &truth,
        &design(),
        Candidate::new(EffectKind::Pendulum, Law::Coupling),
        &[
            ("a12", 0.07455, 0.10),
            ("a21", 0.1895, 0.10),
            ("b12", 0.005428, 0.10),
            ("b21", 0.09979, 0.10),
        ],
    );
}
