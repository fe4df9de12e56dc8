//! `design-next` on a case of known answer, and its errors on bad input.

use zmp_campaign::Campaign;
use zmp_diagnose::design::{
    design_next, design_next_observed, to_toml, DesignError, DesignOptions, Rival,
};
use zmp_diagnose::run::observe_campaign;
use zmp_diagnose::DiagnoseError;
use zmp_models::{logspace, Axis, Binding, EffectInstance, EffectKind, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn paper() -> ModelSpec {
    ModelSpec::parse(
        include_str!("../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap()
}

fn with_delay(delay: f64) -> ModelSpec {
    let mut s = paper();
    for a in Axis::BOTH {
        s.insert(EffectInstance {
            info: EffectKind::TimeDelay.info(),
            binding: Binding::Axis(a),
            values: vec![delay],
        });
    }
    s
}

/// The delay of the known-answer case, s.
const DELAY: f64 = 0.01;
/// Top of its campaign, rad/s.
const TOP: f64 = 4.0;

/// A campaign of the paper's plant with a 10 ms delay on both axes, swept from 0.5 to
/// 4 rad/s at one operating point, 3 and 8 mm, both axes (32 records).
fn delay_campaign() -> Campaign {
    let design = ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.003, 0.008],
        omegas: logspace(0.5, TOP, 8),
        excited: vec![Axis::X, Axis::Y],
        ..ExperimentDesign::reference()
    };
    simulate_campaign(&with_delay(DELAY), &design).unwrap()
}

fn rival(label: &str, spec: ModelSpec) -> Rival {
    Rival {
        label: label.into(),
        spec,
    }
}

fn delay_rivals() -> Vec<Rival> {
    vec![
        rival("plain.toml", paper()),
        rival("delay.toml", with_delay(DELAY)),
    ]
}

fn options(max_records: usize, target_sigma: f64) -> DesignOptions {
    DesignOptions {
        campaign_path: "delay-campaign".into(),
        max_records,
        target_sigma,
        threads: 2,
        ..DesignOptions::default()
    }
}

/// Known answer: the same plant with and without a 10 ms delay. Below 4 rad/s the plain
/// plant's refitted low-pass absorbs the delay's phase (about 1 noise standard deviation
/// apart over the campaign); a delay's lag grows linearly with frequency and a low-pass's does
/// not, so the records that separate them lie at the top of the allowed band (twice the
/// campaign's top here, below the servo's 30 rad/s). The plain plant is nested in the delayed
/// one (a delay refitted to zero): that direction is reported nested, never counted. The
/// predicted separation grows with every record (a refit on more records cannot fit better);
/// with the default target the design stops as soon as it is reached.
#[test]
fn a_delay_is_separated_at_the_top_of_the_band_and_separation_grows() {
    let camp = delay_campaign();
    let d = design_next(&camp, &delay_rivals(), &options(8, 20.0), &|_| {}).unwrap();
    assert_eq!(d.limits.omega_max, 2.0 * TOP);
    assert_eq!(d.records.len(), 8, "{:?}", d.path);
    let first = d.records[0];
    assert!(
        (first.omega - d.limits.omega_max).abs() < 1e-9,
        "first record at {} rad/s, not the top {}",
        first.omega,
        d.limits.omega_max
    );
    let above = d.records.iter().filter(|r| r.omega > TOP).count();
    assert!(
        2 * above >= d.records.len(),
        "{above} of {} records above the campaign's band: {:?}",
        d.records.len(),
        d.records
    );
    assert_eq!(d.path.len(), d.records.len() + 1);
    for w in d.path.windows(2) {
        assert!(w[1] >= w[0] * (1.0 - 1e-9), "separation fell: {:?}", d.path);
    }
    let plain_true = d.separations.iter().find(|s| s.truth == 0).unwrap();
    let delay_true = d.separations.iter().find(|s| s.truth == 1).unwrap();
    assert!(plain_true.nested, "{plain_true:?}");
    assert!(!delay_true.nested);
    assert!(
        delay_true.campaign_sigma < 2.0,
        "the campaign already separates them: {delay_true:?}"
    );
    assert!(delay_true.total_sigma > 10.0, "{delay_true:?}");
    assert!((d.min_sigma() - delay_true.total_sigma).abs() < 1e-12);

    // The default target (5 noise standard deviations) is reached by the first record.
    let d = design_next(&camp, &delay_rivals(), &options(24, 5.0), &|_| {}).unwrap();
    assert_eq!(d.records.len(), 1, "{:?}", d.path);
    assert!(d.decided() && d.min_sigma() >= 5.0);
    // The design file lists it, with the campaign's timing read back from its records.
    let text = to_toml(&d);
    assert!(
        text.contains("[[records]]") && text.contains("transient_s = 3.0"),
        "{text}"
    );
    assert!(text.contains("periods = 4"), "{text}");
}

#[test]
fn fewer_than_two_models_is_an_error() {
    let camp = delay_campaign();
    let one = vec![rival("plain.toml", paper())];
    let e = design_next(&camp, &one, &options(4, 5.0), &|_| {}).unwrap_err();
    assert!(matches!(e, DesignError::ModelCount(1)), "{e}");
    assert!(e.to_string().contains("two or three"), "{e}");
    let four: Vec<Rival> = (0..4).map(|_| rival("m.toml", paper())).collect();
    let e = design_next(&camp, &four, &options(4, 5.0), &|_| {}).unwrap_err();
    assert!(matches!(e, DesignError::ModelCount(4)), "{e}");
}

/// A model of another robot (its pendulum a twentieth of the campaign's) is refused by the
/// diagnosis's own check, naming its file; two models of one structure are refused too.
#[test]
fn a_model_of_another_robot_and_twin_structures_are_named() {
    let camp = delay_campaign();
    let mut other = paper();
    for p in ["a11", "a22", "b11", "b22", "a12", "a21", "b12", "b21"] {
        let v = other
            .value(EffectKind::Pendulum, Binding::Global, p)
            .unwrap();
        other.set_value(EffectKind::Pendulum, Binding::Global, p, v / 20.0);
    }
    let rivals = vec![
        rival("plain.toml", paper()),
        rival("other-robot.toml", other),
    ];
    let e = design_next(&camp, &rivals, &options(4, 5.0), &|_| {}).unwrap_err();
    match &e {
        DesignError::Input(DiagnoseError::Model { model, message }) => {
            assert_eq!(model, "other-robot.toml");
            assert!(
                message.contains("does not describe this campaign"),
                "{message}"
            );
        }
        other => panic!("not a model error: {other}"),
    }
    let mut slower = with_delay(0.02);
    slower.set_value(
        EffectKind::TrackingLowpass,
        Binding::Axis(Axis::X),
        "omega_n",
        25.0,
    );
    let twins = vec![rival("a.toml", with_delay(0.01)), rival("b.toml", slower)];
    let e = design_next(&camp, &twins, &options(4, 5.0), &|_| {}).unwrap_err();
    assert!(
        matches!(&e, DesignError::SameStructure { first, second, .. } if first == "a.toml" && second == "b.toml"),
        "{e}"
    );
}

/// Records whose analysis gave no noise estimate (variance zero or undefined) cannot weigh
/// a design: the error names the campaign and the output.
#[test]
fn a_campaign_without_noise_estimate_is_named() {
    let camp = delay_campaign();
    let (mut obs, _) = observe_campaign(&camp, 2);
    for (k, o) in obs.iter_mut().enumerate() {
        o.y1_var[1] = if k % 2 == 0 { 0.0 } else { f64::NAN };
    }
    let e =
        design_next_observed(&camp, &obs, &delay_rivals(), &options(4, 5.0), &|_| {}).unwrap_err();
    match &e {
        DesignError::NoNoise { campaign, output } => {
            assert_eq!(campaign, "delay-campaign");
            assert_eq!(output, "zmp_y");
        }
        other => panic!("not a noise error: {other}"),
    }
    assert!(
        e.to_string().contains("no record has a noise estimate"),
        "{e}"
    );
}
