//! The catalogue of candidate effects the diagnosis fits. Each candidate says how to add its
//! effect to a model and which parameters the fit may move; the core parameters are refitted
//! with it.

use super::lm::Bounded;
use super::observe::Observation;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, Channel, EffectInstance, ModelSpec};

mod modes;
mod play;
mod saturation;

use modes::structural_mode;
pub use modes::{
    add_typical_link, mode_bindings, mode_free_axes, plausible, trunk_in_servo, trunk_law_starts,
    trunk_own_frees, typical_links, upper_mode_starts,
};
pub use play::{play_in_servo_starts, plays_on_command};
use saturation::acceleration_saturation;
pub use saturation::{demanded_acceleration, inactive_limits};

/// One scalar the fit moves; it sets `param` of `kind` at every binding listed.
#[derive(Debug, Clone)]
pub struct Free {
    pub kind: EffectKind,
    pub bindings: Vec<Binding>,
    pub param: &'static str,
    pub bounds: Bounded,
}

impl Free {
    pub(super) fn new(
        kind: EffectKind,
        bindings: Vec<Binding>,
        param: &'static str,
        value: f64,
        min: f64,
        max: f64,
    ) -> Free {
        Free {
            kind,
            bindings,
            param,
            bounds: Bounded {
                value: value.clamp(min, max),
                min,
                max,
            },
        }
    }

    /// Dotted name for reports: `time_delay.delay`, `sensor_drift.x.rate`.
    pub fn name(&self) -> String {
        if self.bindings.len() == 1 {
            if let Some(k) = self.bindings[0].key() {
                return format!("{}.{}.{}", self.kind, k, self.param);
            }
        }
        format!("{}.{}", self.kind, self.param)
    }
}

/// Sets every free parameter of `frees` to `theta` in `spec`.
pub fn apply(spec: &mut ModelSpec, frees: &[Free], theta: &[f64]) {
    for (f, v) in frees.iter().zip(theta) {
        for b in &f.bindings {
            spec.set_value(f.kind, *b, f.param, *v);
        }
    }
}

/// Data ranges the candidates scale their starting values and bounds from.
#[derive(Debug, Clone, Copy)]
pub struct DataRange {
    pub omega_min: f64,
    pub omega_max: f64,
    pub amplitude_min: f64,
    pub amplitude_max: f64,
    pub op_span: [f64; 2],
    pub axes_excited: [bool; 2],
}

impl DataRange {
    pub fn of(obs: &[&Observation]) -> DataRange {
        let mut r = DataRange {
            omega_min: f64::INFINITY,
            omega_max: 0.0,
            amplitude_min: f64::INFINITY,
            amplitude_max: 0.0,
            op_span: [0.0; 2],
            axes_excited: [false; 2],
        };
        let mut op_lo = [f64::INFINITY; 2];
        let mut op_hi = [f64::NEG_INFINITY; 2];
        for o in obs {
            r.omega_min = r.omega_min.min(o.omega);
            r.omega_max = r.omega_max.max(o.omega);
            r.amplitude_min = r.amplitude_min.min(o.amplitude());
            r.amplitude_max = r.amplitude_max.max(o.amplitude());
            r.axes_excited[o.excited.index()] = true;
            for k in 0..2 {
                op_lo[k] = op_lo[k].min(o.operating_point[k]);
                op_hi[k] = op_hi[k].max(o.operating_point[k]);
            }
        }
        r.op_span = [op_hi[0] - op_lo[0], op_hi[1] - op_lo[1]];
        r
    }
}

const AXES: [Binding; 2] = [Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];

/// The core parameters refitted with every candidate: the diagonal pendulum, the off-diagonal
/// terms the model already has, and the tracking low-pass (shared by the axes).
pub fn core_frees(spec: &ModelSpec, bandwidth: bool) -> Vec<Free> {
    let mut out = Vec::new();
    for ch in Channel::ALL {
        let diag = ch.output == ch.input;
        for (p, lim) in [("a", 10.0), ("b", 10.0)] {
            let name: &'static str = match (p, ch.suffix()) {
                ("a", "11") => "a11",
                ("a", "12") => "a12",
                ("a", "21") => "a21",
                ("a", "22") => "a22",
                ("b", "11") => "b11",
                ("b", "12") => "b12",
                ("b", "21") => "b21",
                _ => "b22",
            };
            let v = spec
                .value(EffectKind::Pendulum, Binding::Global, name)
                .unwrap_or(0.0);
            if diag || v != 0.0 {
                out.push(Free::new(
                    EffectKind::Pendulum,
                    vec![Binding::Global],
                    name,
                    v,
                    -lim,
                    lim,
                ));
            }
        }
    }
    if !bandwidth {
        return out;
    }
    let wn = spec
        .value(EffectKind::TrackingLowpass, AXES[0], "omega_n")
        .unwrap_or(30.0);
    let zeta = spec
        .value(EffectKind::TrackingLowpass, AXES[0], "zeta")
        .unwrap_or(1.0);
    out.push(Free::new(
        EffectKind::TrackingLowpass,
        AXES.to_vec(),
        "omega_n",
        wn,
        1.0,
        1e3,
    ));
    // A position servo is at least moderately damped (the seed's is critically damped): a
    // low-pass below 0.3 would be a structural mode, which the catalogue names separately.
    out.push(Free::new(
        EffectKind::TrackingLowpass,
        AXES.to_vec(),
        "zeta",
        zeta,
        0.3,
        5.0,
    ));
    out
}

/// A starting point of a fit: the model with the effect added, and what the fit may move.
pub type Start = (ModelSpec, Vec<Free>);

/// A candidate: the effect it adds, its starting points and free parameters.
pub struct Candidate {
    /// Name in the diagnosis catalogue (`zmp-diagnosis/1`).
    pub effect: &'static str,
    /// Adds the effect to `spec`; returns the starting points (each a model and its frees).
    pub prepare: fn(&ModelSpec, &DataRange) -> Vec<Start>,
}

/// Adds the registered effect `kind` with `values` at every binding listed.
pub fn add_effect(spec: &mut ModelSpec, kind: EffectKind, bindings: &[Binding], values: &[f64]) {
    let info = kind.info();
    for b in bindings {
        spec.insert(EffectInstance {
            info,
            binding: *b,
            values: values.to_vec(),
        });
    }
}

fn with(spec: &ModelSpec, kind: EffectKind, bindings: &[Binding], values: &[f64]) -> ModelSpec {
    let mut s = spec.clone();
    add_effect(&mut s, kind, bindings, values);
    s
}

/// Axis variants of an effect bound to input or output axes: both (one shared value), x, y.
fn axis_variants(r: &DataRange) -> Vec<Vec<Binding>> {
    let mut v = vec![AXES.to_vec()];
    if r.axes_excited[0] && r.axes_excited[1] {
        v.push(vec![AXES[0]]);
        v.push(vec![AXES[1]]);
    }
    v
}

/// An effect bound to input or output axes from each of the `starts`: on every excited axis,
/// each with its own value (two servos, two sensors: their latencies and filters differ), and
/// on each axis alone.
fn one_param(
    spec: &ModelSpec,
    r: &DataRange,
    kind: EffectKind,
    param: &'static str,
    starts: &[f64],
    min: f64,
    max: f64,
) -> Vec<Start> {
    let mut out = per_axis(spec, r, kind, param, starts, min, max);
    if r.axes_excited[0] && r.axes_excited[1] {
        for b in AXES {
            for &v in starts {
                let s = with(spec, kind, &[b], &[v]);
                out.push((s, vec![Free::new(kind, vec![b], param, v, min, max)]));
            }
        }
    }
    out
}

fn time_delay(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    // Up to 3 rad of phase at the highest frequency (150 ms at 20 rad/s).
    let tmax = (3.0 / r.omega_max).min(0.45);
    let mut out = one_param(
        spec,
        r,
        EffectKind::TimeDelay,
        "delay",
        &[0.1 / r.omega_max, 0.5 / r.omega_max, 1.5 / r.omega_max],
        0.0,
        tmax,
    );
    // A servo low-pass slower than the seed's may have absorbed the delay: also start from the
    // seed's servo with the delay taking the difference of the lags.
    if let Some(absorbed) = absorbed_lag(spec, r) {
        let mut seed = spec.clone();
        for b in AXES {
            seed.set_value(EffectKind::TrackingLowpass, b, "omega_n", SEED_SERVO.0);
            seed.set_value(EffectKind::TrackingLowpass, b, "zeta", SEED_SERVO.1);
        }
        out.extend(per_axis(
            &seed,
            r,
            EffectKind::TimeDelay,
            "delay",
            &[absorbed.min(tmax)],
            0.0,
            tmax,
        ));
    }
    out
}

/// The seed's servo tracking low-pass `(omega_n, zeta)`: 30 rad/s, critically damped.
pub const SEED_SERVO: (f64, f64) = (30.0, 1.0);

/// How much more the model's servo low-pass lags than the seed's below their bandwidths,
/// `2 zeta / omega_n` against `2 / 30` s (what a delay of that length lags too), when the
/// model has a low-pass and the difference is more than the delay candidate's shortest start
/// (a tenth of a radian at the top frequency); `None` otherwise.
pub fn absorbed_lag(spec: &ModelSpec, r: &DataRange) -> Option<f64> {
    let wn = spec.value(EffectKind::TrackingLowpass, AXES[0], "omega_n")?;
    let zeta = spec.value(EffectKind::TrackingLowpass, AXES[0], "zeta")?;
    let lag = 2.0 * zeta / wn - 2.0 * SEED_SERVO.1 / SEED_SERVO.0;
    (lag > 0.1 / r.omega_max).then_some(lag)
}

/// The effect on every excited axis, each axis with its own free parameter (an axis without
/// the effect fits to the parameter's "off" end), from each of the `scan` starting values.
fn per_axis(
    spec: &ModelSpec,
    r: &DataRange,
    kind: EffectKind,
    param: &'static str,
    scan: &[f64],
    min: f64,
    max: f64,
) -> Vec<Start> {
    let axes: Vec<Binding> = AXES
        .iter()
        .zip(r.axes_excited)
        .filter(|(_, e)| *e)
        .map(|(b, _)| *b)
        .collect();
    scan.iter()
        .map(|&v| {
            let s = with(spec, kind, &axes, &[v]);
            let frees = axes
                .iter()
                .map(|b| Free::new(kind, vec![*b], param, v, min, max))
                .collect();
            (s, frees)
        })
        .collect()
}

fn servo_params(spec: &ModelSpec) -> (f64, f64) {
    servo_params_of(spec, AXES[0])
}

/// The tracking low-pass `(omega_n, zeta)` of the input axis `b` (the seed's 30 rad/s and 1
/// where the model has none).
pub fn servo_params_of(spec: &ModelSpec, b: Binding) -> (f64, f64) {
    (
        spec.value(EffectKind::TrackingLowpass, b, "omega_n")
            .unwrap_or(30.0),
        spec.value(EffectKind::TrackingLowpass, b, "zeta")
            .unwrap_or(1.0),
    )
}

fn backlash(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    let a = r.amplitude_min;
    per_axis(
        spec,
        r,
        EffectKind::Backlash,
        "width",
        &[0.1 * a, 0.5 * a],
        0.0,
        (1.9 * r.amplitude_min).min(0.1),
    )
}

fn coulomb_friction(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    // Friction level F shifts the servo by about F / wn^2: comparable with the smallest
    // amplitude at F ~ A wn^2.
    let (wn, _) = servo_params(spec);
    let f0 = r.amplitude_min * wn * wn;
    per_axis(
        spec,
        r,
        EffectKind::CoulombFriction,
        "level",
        &[0.01 * f0, 0.1 * f0],
        0.0,
        // Beyond A_min wn^2 the smallest sines barely move: a stuck servo, not friction.
        (r.amplitude_min * wn * wn).min(100.0),
    )
}

fn sensor_lowpass(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    let starts = [0.5, 1.0, 4.0].map(|f| f * r.omega_max);
    one_param(
        spec,
        r,
        EffectKind::SensorLowpass,
        "cutoff",
        &starts,
        0.2 * r.omega_min,
        100.0 * r.omega_max,
    )
}

fn sensor_drift(spec: &ModelSpec, _r: &DataRange) -> Vec<Start> {
    let s = with(spec, EffectKind::SensorDrift, &AXES, &[0.0, 0.0]);
    let frees = AXES
        .iter()
        .map(|b| Free::new(EffectKind::SensorDrift, vec![*b], "rate", 0.0, -0.1, 0.1))
        .collect();
    vec![(s, frees)]
}

fn operating_point_dependence(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    let s = with(
        spec,
        EffectKind::OperatingPointDependence,
        &[Binding::Global],
        &[0.0; 4],
    );
    let mut frees = Vec::new();
    for (k, (pa, pb)) in [("da_dx", "db_dx"), ("da_dy", "db_dy")]
        .into_iter()
        .enumerate()
    {
        if r.op_span[k] > 1e-9 {
            let lim = (2.0 / r.op_span[k]).min(100.0);
            frees.push(Free::new(
                EffectKind::OperatingPointDependence,
                vec![Binding::Global],
                pa,
                0.0,
                -lim,
                lim,
            ));
            frees.push(Free::new(
                EffectKind::OperatingPointDependence,
                vec![Binding::Global],
                pb,
                0.0,
                -lim,
                lim,
            ));
        }
    }
    if frees.is_empty() {
        return Vec::new();
    }
    vec![(s, frees)]
}

fn cross_coupling(spec: &ModelSpec, _r: &DataRange) -> Vec<Start> {
    let mut frees = Vec::new();
    for name in ["a12", "a21", "b12", "b21"] {
        if spec.value(EffectKind::Pendulum, Binding::Global, name) == Some(0.0) {
            frees.push(Free::new(
                EffectKind::Pendulum,
                vec![Binding::Global],
                name,
                0.0,
                -10.0,
                10.0,
            ));
        }
    }
    if frees.is_empty() {
        return Vec::new();
    }
    vec![(spec.clone(), frees)]
}

/// Every catalogued candidate, in the order of the diagnosis spec.
pub static CATALOGUE: &[Candidate] = &[
    Candidate {
        effect: "time_delay",
        prepare: time_delay,
    },
    Candidate {
        effect: "backlash",
        prepare: backlash,
    },
    Candidate {
        effect: "coulomb_friction",
        prepare: coulomb_friction,
    },
    Candidate {
        effect: "acceleration_saturation",
        prepare: acceleration_saturation,
    },
    Candidate {
        effect: "structural_mode",
        prepare: structural_mode,
    },
    Candidate {
        effect: "sensor_lowpass",
        prepare: sensor_lowpass,
    },
    Candidate {
        effect: "operating_point_dependence",
        prepare: operating_point_dependence,
    },
    Candidate {
        effect: "sensor_drift",
        prepare: sensor_drift,
    },
    Candidate {
        effect: "cross_coupling",
        prepare: cross_coupling,
    },
];

/// The model-file effect a catalogue name adds (`cross_coupling` frees pendulum terms); the
/// first of [`model_kinds`].
pub fn model_kind(effect: &str) -> Option<EffectKind> {
    model_kinds(effect).first().copied()
}

/// Every model-file effect a catalogue name may add: a structural mode is either on the ZMP
/// path (`structural_mode`) or a flexible link of the trunk inside the servo loop
/// (`flexible_trunk`); the diagnosis tries both and names either `structural_mode`.
pub fn model_kinds(effect: &str) -> &'static [EffectKind] {
    match effect {
        "cross_coupling" => &[EffectKind::Pendulum],
        "structural_mode" => &[EffectKind::StructuralMode, EffectKind::FlexibleTrunk],
        "time_delay" => &[EffectKind::TimeDelay],
        "backlash" => &[EffectKind::Backlash],
        "coulomb_friction" => &[EffectKind::CoulombFriction],
        "acceleration_saturation" => &[EffectKind::AccelerationSaturation],
        "sensor_lowpass" => &[EffectKind::SensorLowpass],
        "operating_point_dependence" => &[EffectKind::OperatingPointDependence],
        "sensor_drift" => &[EffectKind::SensorDrift],
        _ => &[],
    }
}

/// The tests' campaign: sines of 3-8 mm from 0.5 to 15 rad/s on both axes.
#[cfg(test)]
pub(crate) fn test_range() -> DataRange {
    DataRange {
        omega_min: 0.5,
        omega_max: 15.0,
        amplitude_min: 0.003,
        amplitude_max: 0.008,
        op_span: [0.06, 0.04],
        axes_excited: [true, true],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    pub(super) fn paper_with_limits(x: f64, y: f64) -> ModelSpec {
        let mut spec = ModelSpec::parse(
            include_str!("../../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .unwrap();
        add_effect(
            &mut spec,
            EffectKind::AccelerationSaturation,
            &[AXES[0]],
            &[x],
        );
        add_effect(
            &mut spec,
            EffectKind::AccelerationSaturation,
            &[AXES[1]],
            &[y],
        );
        spec
    }

    pub(super) fn range() -> DataRange {
        test_range()
    }

    /// A refit moves a play's width, and its drive share only inside the servo; the
    /// transmission's shape stays the model file's.
    #[test]
    fn a_refit_frees_the_drive_share_of_a_play_inside_the_servo_only() {
        let mut s = paper_with_limits(1.0, 1.2);
        add_effect(&mut s, EffectKind::Backlash, &[AXES[0]], &[0.001, 1.0]);
        add_effect(&mut s, EffectKind::Backlash, &[AXES[1]], &[0.001]);
        let frees: Vec<String> = super::super::engine::structure_frees(&s)
            .iter()
            .filter(|f| f.kind == EffectKind::Backlash)
            .map(|f| f.name())
            .collect();
        assert_eq!(
            frees,
            ["backlash.x.width", "backlash.x.drive", "backlash.y.width"],
            "{frees:?}"
        );
    }

    /// A limit that no record reaches has no gradient: the candidate restarts it from below
    /// the campaign's largest demand and keeps the limit that acts; with both acting it has
    /// nothing to offer.
    #[test]
    fn saturation_restarts_only_a_limit_that_never_acts() {
        let r = range();
        // The seed's servo (30 rad/s, zeta 1) at 15 rad/s, 8 mm: 1.44 m/s2 demanded.
        let demand = 225.0 * 0.008 * 900.0 / ((900.0f64 - 225.0).powi(2) + 900.0f64 * 900.0).sqrt();
        let starts = acceleration_saturation(&paper_with_limits(1.0, 2.0 * demand), &r);
        assert_eq!(starts.len(), 2);
        for (k, (spec, frees)) in starts.iter().enumerate() {
            let fac = [0.4, 0.8][k];
            let y = spec
                .value(EffectKind::AccelerationSaturation, AXES[1], "limit")
                .unwrap();
            assert!((y / (fac * demand) - 1.0).abs() < 1e-9, "y limit {y}");
            assert_eq!(
                spec.value(EffectKind::AccelerationSaturation, AXES[0], "limit"),
                Some(1.0)
            );
            assert_eq!(frees.len(), 2);
            assert_eq!(frees[1].bounds.value, y);
            assert_eq!(frees[0].bounds.value, 1.0);
        }
        assert!(acceleration_saturation(&paper_with_limits(1.0, 0.9 * demand), &r).is_empty());
        // Without a limit: both axes from each start.
        let plain = ModelSpec::parse(
            include_str!("../../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .unwrap();
        let fresh = acceleration_saturation(&plain, &r);
        assert_eq!(fresh.len(), 2);
        assert!(fresh.iter().all(|(_, f)| f.len() == 2));
    }

    /// A servo low-pass that lags more than the seed's may stand for a delay: the delay
    /// candidate also starts from the seed's servo with the difference of the lags as the
    /// delay, on each excited axis; a servo as fast as the seed's adds no start.
    #[test]
    fn a_slow_servo_gives_the_delay_a_start_from_the_seeds_servo() {
        let r = range();
        let with_servo = |wn: f64, zeta: f64| {
            let mut s = paper_with_limits(1.0, 1.2);
            for b in AXES {
                s.set_value(EffectKind::TrackingLowpass, b, "omega_n", wn);
                s.set_value(EffectKind::TrackingLowpass, b, "zeta", zeta);
            }
            s
        };
        // Held-out draw 1160027's loop: 13.17 rad/s, damping 0.509 (lag 77.3 ms against 66.7).
        let slow = with_servo(13.17, 0.509);
        let lag = absorbed_lag(&slow, &r).unwrap();
        assert!((lag - (2.0 * 0.509 / 13.17 - 2.0 / 30.0)).abs() < 1e-12);
        let plain = time_delay(&with_servo(30.0, 1.0), &r);
        let starts = time_delay(&slow, &r);
        assert_eq!(starts.len(), plain.len() + 1);
        let (spec, frees) = starts.last().unwrap();
        for b in AXES {
            assert_eq!(
                spec.value(EffectKind::TrackingLowpass, b, "omega_n"),
                Some(30.0)
            );
            assert_eq!(
                spec.value(EffectKind::TrackingLowpass, b, "zeta"),
                Some(1.0)
            );
            assert_eq!(spec.value(EffectKind::TimeDelay, b, "delay"), Some(lag));
        }
        assert_eq!(frees.len(), 2);
        // The seed's own servo, a faster one, and one lagging by less than the shortest start
        // (0.1 rad at 15 rad/s: 6.7 ms) have none.
        for (wn, zeta) in [(30.0, 1.0), (40.0, 0.8), (28.0, 1.0)] {
            assert!(
                absorbed_lag(&with_servo(wn, zeta), &r).is_none(),
                "{wn} {zeta}"
            );
        }
    }
}
