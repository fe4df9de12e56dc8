//! Blind draws for testing the diagnosis: from a seed, a robot (the SILO2 paper model with its
//! parameters perturbed), a hidden effect or two (or none) with random parameters, and a noise
//! level. The diagnosis sees only the campaign simulated from the draw and a model identified
//! from that campaign.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use zmp_diagnose::profiles::add_effect;
use zmp_models::logspace;
use zmp_models::{Axis, Binding, EffectKind, ModelSpec};
use zmp_virtual_robot::ExperimentDesign;

/// The model effect a draw names (`effect` is a catalogue name that is also a model kind).
fn kind(effect: &str) -> EffectKind {
    EffectKind::parse(effect).expect("a model effect")
}

/// The effects a draw can hide (the diagnosis catalogue).
pub const EFFECTS: [&str; 9] = [
    "time_delay",
    "backlash",
    "coulomb_friction",
    "acceleration_saturation",
    "structural_mode",
    "sensor_lowpass",
    "operating_point_dependence",
    "sensor_drift",
    "cross_coupling",
];

/// One blind draw.
#[derive(Debug, Clone)]
pub struct Draw {
    /// The seed that drew the effects, the robot and the noise.
    pub seed: u64,
    /// Hidden effects (empty: clean data).
    pub effects: Vec<String>,
    /// The robot that made the data.
    pub truth: ModelSpec,
    /// The campaign simulated on the robot.
    pub design: ExperimentDesign,
    /// Whether the model handed to the diagnosis is identified without coupling terms (the
    /// user's structure names none): only for a hidden `cross_coupling`.
    pub diagonal_model: bool,
    /// Human-readable parameters of the hidden effects.
    pub description: String,
}

/// The paper model, parsed.
pub fn paper() -> ModelSpec {
    ModelSpec::parse(
        include_str!("../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .expect("the bundled paper model parses")
}

/// A smaller campaign than the reference (so that a suite of draws runs in minutes): 3
/// operating points x 2 amplitudes x 9 frequencies x 2 channels.
pub fn design(seed: u64, noise: f64) -> ExperimentDesign {
    ExperimentDesign {
        name: format!("blind-{seed}"),
        omegas: logspace(0.5, 15.0, 9),
        zmp_noise_std: noise,
        seed,
        ..ExperimentDesign::reference()
    }
}

fn axes(rng: &mut ChaCha8Rng) -> Vec<Binding> {
    match rng.gen_range(0..3) {
        0 => vec![Binding::Axis(Axis::X)],
        1 => vec![Binding::Axis(Axis::Y)],
        _ => vec![Binding::Axis(Axis::X), Binding::Axis(Axis::Y)],
    }
}

fn names(b: &[Binding]) -> String {
    b.iter()
        .filter_map(|b| b.key())
        .collect::<Vec<_>>()
        .join("+")
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo * (hi / lo).powf(rng.gen::<f64>())
}

/// Adds one hidden effect with random parameters; returns its description.
pub fn hide(
    spec: &mut ModelSpec,
    effect: &str,
    rng: &mut ChaCha8Rng,
    design: &ExperimentDesign,
) -> String {
    let (wn, zeta) = (
        spec.value(
            EffectKind::TrackingLowpass,
            Binding::Axis(Axis::X),
            "omega_n",
        )
        .unwrap_or(30.0),
        spec.value(EffectKind::TrackingLowpass, Binding::Axis(Axis::X), "zeta")
            .unwrap_or(1.0),
    );
    match effect {
        "time_delay" => {
            let b = axes(rng);
            let d = log_uniform(rng, 0.015, 0.08);
            add_effect(spec, kind(effect), &b, &[d]);
            format!("time_delay {} {:.1} ms", names(&b), d * 1e3)
        }
        "backlash" => {
            let b = axes(rng);
            let w = log_uniform(rng, 0.0006, 0.002);
            add_effect(spec, kind(effect), &b, &[w]);
            format!("backlash {} {:.2} mm", names(&b), w * 1e3)
        }
        "coulomb_friction" => {
            let b = axes(rng);
            let f = log_uniform(rng, 0.15, 0.8);
            add_effect(spec, kind(effect), &b, &[f]);
            format!("coulomb_friction {} {:.3} m/s2", names(&b), f)
        }
        "acceleration_saturation" => {
            // Between a third and two thirds of the largest linear demand of the campaign.
            let w = design.omegas.iter().copied().fold(0.0, f64::max);
            let a = design.amplitudes.iter().copied().fold(0.0, f64::max);
            let h = wn * wn / ((wn * wn - w * w).powi(2) + (2.0 * zeta * wn * w).powi(2)).sqrt();
            let peak = w * w * h * a;
            let b = vec![Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
            let l = peak * rng.gen_range(0.35..0.7);
            add_effect(spec, kind(effect), &b, &[l]);
            format!("acceleration_saturation {} {:.3} m/s2", names(&b), l)
        }
        "structural_mode" => {
            let b = axes(rng);
            let w = log_uniform(rng, 3.0, 20.0);
            let z = log_uniform(rng, 0.1, 0.35);
            add_effect(spec, kind(effect), &b, &[w, z]);
            format!("structural_mode {} {:.2} rad/s zeta {:.3}", names(&b), w, z)
        }
        "sensor_lowpass" => {
            let b = axes(rng);
            let c = log_uniform(rng, 6.0, 40.0);
            add_effect(spec, kind(effect), &b, &[c]);
            format!("sensor_lowpass {} {:.1} rad/s", names(&b), c)
        }
        "operating_point_dependence" => {
            let s = |rng: &mut ChaCha8Rng| if rng.gen::<bool>() { 1.0 } else { -1.0 };
            let v = [
                s(rng) * log_uniform(rng, 2.0, 6.0),
                s(rng) * log_uniform(rng, 2.0, 6.0),
                s(rng) * log_uniform(rng, 1.0, 3.0),
                s(rng) * log_uniform(rng, 1.0, 3.0),
            ];
            add_effect(spec, kind(effect), &[Binding::Global], &v);
            format!(
                "operating_point_dependence da_dx {:.2} da_dy {:.2} db_dx {:.2} db_dy {:.2}",
                v[0], v[1], v[2], v[3]
            )
        }
        "sensor_drift" => {
            let b = axes(rng);
            let s = if rng.gen::<bool>() { 1.0 } else { -1.0 };
            let r = s * log_uniform(rng, 1e-5, 6e-5);
            add_effect(spec, kind(effect), &b, &[0.0, r]);
            format!("sensor_drift {} {:.3} mm/s", names(&b), r * 1e3)
        }
        "cross_coupling" => {
            // The coupling terms of the pendulum, scaled.
            let k = log_uniform(rng, 0.7, 2.0);
            for p in ["a12", "a21", "b12", "b21"] {
                let v = paper()
                    .value(EffectKind::Pendulum, Binding::Global, p)
                    .unwrap_or(0.0);
                spec.set_value(EffectKind::Pendulum, Binding::Global, p, v * k);
            }
            format!("cross_coupling x{k:.2} of the paper's coupling")
        }
        other => panic!("unknown blind effect {other}"),
    }
}

/// Draw `seed` with the given hidden effects.
pub fn draw_with(seed: u64, effects: &[&str]) -> Draw {
    let mut rng = ChaCha8Rng::seed_from_u64(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let mut truth = paper();
    truth.name = Some(format!("blind draw {seed}"));
    // Another robot of the same family.
    for p in ["a11", "a22", "b11", "b22"] {
        let v = truth
            .value(EffectKind::Pendulum, Binding::Global, p)
            .unwrap_or(0.0);
        truth.set_value(
            EffectKind::Pendulum,
            Binding::Global,
            p,
            v * rng.gen_range(0.8..1.2),
        );
    }
    let diagonal_model = effects.contains(&"cross_coupling");
    if diagonal_model {
        for p in ["a12", "a21", "b12", "b21"] {
            truth.set_value(EffectKind::Pendulum, Binding::Global, p, 0.0);
        }
    }
    let wn = rng.gen_range(22.0..40.0);
    let zeta = rng.gen_range(0.75..1.1);
    for a in Axis::BOTH {
        truth.set_value(EffectKind::TrackingLowpass, Binding::Axis(a), "omega_n", wn);
        truth.set_value(EffectKind::TrackingLowpass, Binding::Axis(a), "zeta", zeta);
    }
    let noise = log_uniform(&mut rng, 0.0002, 0.0008);
    let design = design(seed, noise);
    let mut description = vec![format!("noise {:.2} mm", noise * 1e3)];
    for e in effects {
        description.push(hide(&mut truth, e, &mut rng, &design));
    }
    Draw {
        seed,
        effects: effects.iter().map(|s| s.to_string()).collect(),
        truth,
        design,
        diagonal_model,
        description: description.join("; "),
    }
}

/// The suite's draws: every catalogued effect `per_effect` times, `pairs` pairs and `clean`
/// clean campaigns, seeds from `first_seed` on.
pub fn suite(first_seed: u64, per_effect: usize, pairs: usize, clean: usize) -> Vec<Draw> {
    let mut out = Vec::new();
    let mut seed = first_seed;
    for k in 0..per_effect {
        for e in EFFECTS {
            let _ = k;
            out.push(draw_with(seed, &[e]));
            seed += 1;
        }
    }
    let pair_list = [
        ("time_delay", "sensor_drift"),
        ("backlash", "sensor_lowpass"),
        ("structural_mode", "operating_point_dependence"),
        ("coulomb_friction", "time_delay"),
        ("sensor_lowpass", "sensor_drift"),
        ("time_delay", "operating_point_dependence"),
    ];
    for k in 0..pairs {
        let (a, b) = pair_list[k % pair_list.len()];
        out.push(draw_with(seed, &[a, b]));
        seed += 1;
    }
    for _ in 0..clean {
        out.push(draw_with(seed, &[]));
        seed += 1;
    }
    out
}

/// What the diagnosis made of one draw.
#[derive(Debug, Clone)]
pub struct Outcome {
    /// The draw diagnosed.
    pub draw: Draw,
    /// The diagnosis's verdict by name.
    pub verdict: String,
    /// Effects selected, in order.
    pub selected: Vec<String>,
    /// The identified model's error on the campaign.
    pub baseline_error: f64,
    /// The campaign's noise floor.
    pub noise_floor: f64,
    /// Error (all records) after adding the first hidden effect to the identified model with
    /// `augment`, if the verdict named it.
    pub error_after_adding: Option<f64>,
}

/// Simulates the draw's campaign, identifies a model from it, diagnoses that model, and (when
/// the verdict is right) adds the effect and measures the error.
pub fn run(draw: Draw, threads: usize) -> anyhow::Result<Outcome> {
    use zmp_diagnose::{augment::augment, diagnose, DiagnoseOptions};
    use zmp_identify::{identify, IdentifyOptions};
    let camp = zmp_virtual_robot::simulate_campaign(&draw.truth, &draw.design)?;
    let mut opts = IdentifyOptions {
        threads: Some(threads),
        ..IdentifyOptions::default()
    };
    if draw.diagonal_model {
        let mut m = paper();
        for p in ["a12", "a21", "b12", "b21"] {
            m.set_value(EffectKind::Pendulum, Binding::Global, p, 0.0);
        }
        opts.start_model = Some(m);
    }
    let ident = identify(&camp, &opts)?;
    let dopts = DiagnoseOptions {
        campaign_path: draw.design.name.clone(),
        model_path: "identified.toml".into(),
        threads,
        ..DiagnoseOptions::default()
    };
    let d = diagnose(&camp, &ident.model, &dopts, &|_| {})?;
    let error_after_adding = match draw.effects.first() {
        Some(e) if *e == d.verdict.name() => {
            Some(augment(&camp, &ident.model, e, &dopts)?.error_after)
        }
        _ => None,
    };
    Ok(Outcome {
        verdict: d.verdict.name().to_string(),
        selected: d.selected.iter().map(|s| s.0.name().to_string()).collect(),
        baseline_error: d.baseline_error,
        noise_floor: d.noise_floor,
        error_after_adding,
        draw,
    })
}
