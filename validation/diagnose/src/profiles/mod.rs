//! One diagnostic profile per effect kind: its laws, its parameters with their physical ranges,
//! its starting values (typical values scaled by the campaign's data range), how it is added to
//! and taken out of a model, whether fitted values still describe it, and the words for it (the
//! evidence sentence, and what it does to the response, for the words that tell two
//! explanations apart). A new effect is one file here and one arm in [`profile`].

use crate::fit::{Fit, Free};
use crate::observe::Observation;
use crate::structure::{Candidate, Law};
use crate::words::Evidence;
use zmp_models::{Axis, Binding, EffectInstance, EffectKind, ModelSpec};

mod backlash;
mod coulomb_friction;
mod cross_coupling;
mod operating_point;
mod saturation;
mod sensor_drift;
mod sensor_lowpass;
mod structural_mode;
mod time_delay;

pub use saturation::demanded_acceleration;
pub use sensor_drift::per_record as drift_per_record;

/// A starting point of a fit: the model with the effect added, and the parameters a first,
/// short fit from it moves (the effect's own).
pub type Start = (ModelSpec, Vec<Free>);

/// What every kind of effect tells the diagnosis about itself.
pub trait Profile: Sync {
    /// The model kind it adds (a mode under the servo law adds `flexible_trunk`, see
    /// [`Profile::model_kinds`]).
    fn kind(&self) -> EffectKind;

    /// Its name in the catalogue (`zmp-diagnosis/1`).
    fn name(&self) -> &'static str {
        self.kind().name()
    }

    /// Every model kind it may add, the first its own.
    fn model_kinds(&self) -> &'static [EffectKind];

    /// Its laws.
    fn laws(&self) -> &'static [Law] {
        &[Law::Only]
    }

    /// Whether it is added plane by plane (one candidate per excited axis).
    fn per_plane(&self) -> bool {
        false
    }

    /// Whether `c` can be added to `spec` on this campaign (the structure's own rules, one law
    /// per kind and one mode per plane, are [`crate::structure::Structure::admits`]).
    fn addable(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> bool {
        let _ = (c, r);
        !self.model_kinds().iter().any(|k| spec.has(*k))
    }

    /// The model with the effect added, from each of its starts; the first is its typical
    /// values (where every fit "from typical values" starts it).
    fn starts(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> Vec<Start>;

    /// The free parameters of the effect as `spec` holds it, within its physical ranges (empty
    /// when `spec` has none): what every joint fit moves.
    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<Free>;

    /// Whether the effect's fitted values in `spec` describe the effect (a mode that ended at
    /// its damping cap is a well-damped filter, not a mode).
    fn physical(&self, spec: &ModelSpec) -> bool {
        let _ = spec;
        true
    }

    /// Whether its predictions simulate the servo (describing functions from simulation):
    /// seconds per fit where a linear effect takes milliseconds.
    fn costly(&self, c: &Candidate) -> bool {
        let _ = c;
        false
    }

    /// Takes the effect `c` out of `spec`.
    fn remove(&self, spec: &mut ModelSpec, c: &Candidate) {
        match c.plane {
            Some(p) => spec
                .effects
                .retain(|e| !(self.model_kinds().contains(&e.info.kind) && e.binding == axis(p))),
            None => {
                for k in self.model_kinds() {
                    spec.remove(*k);
                }
            }
        }
    }

    /// The fitted parameters that carry the effect in `fit`, each with its standard error:
    /// the records determine the effect when one of them lies more than the criterion's z
    /// standard errors from zero (a Wald test; a parameter whose absence lies at infinity, a
    /// cutoff or a force limit, is tested the same way, as its reciprocal is to first
    /// order). Default: every fitted parameter of the profile's model kinds (on its plane).
    fn strength(&self, fit: &Fit, c: &Candidate) -> Vec<(f64, f64)> {
        fit.frees
            .iter()
            .zip(&fit.std_err)
            .filter(|(f, _)| self.model_kinds().contains(&f.kind))
            .filter(|(f, _)| c.plane.is_none_or(|p| f.bindings.contains(&axis(p))))
            .map(|(f, e)| (f.bounds.value, *e))
            .collect()
    }

    /// What the effect does to the response, in a few words ("adds phase lag growing with
    /// frequency"): where two explanations part.
    fn signature(&self, c: &Candidate) -> &'static str;

    /// The evidence sentence: what the measurements show against the model without it.
    fn evidence(&self, c: &Candidate, e: &Evidence) -> String;
}

/// The profile of a kind (a flexible trunk's is the structural mode's; the pendulum's is its
/// coupling terms'). Panics on a kind the catalogue does not search (the core's low-pass, the
/// uncertainty weights): a programming error, every caller passes catalogue kinds.
pub fn profile(kind: EffectKind) -> &'static dyn Profile {
    match kind {
        EffectKind::TimeDelay => &time_delay::TimeDelay,
        EffectKind::Backlash => &backlash::Backlash,
        EffectKind::CoulombFriction => &coulomb_friction::CoulombFriction,
        EffectKind::AccelerationSaturation => &saturation::Saturation,
        EffectKind::StructuralMode | EffectKind::FlexibleTrunk => &structural_mode::Mode,
        EffectKind::SensorLowpass => &sensor_lowpass::SensorLowpass,
        EffectKind::OperatingPointDependence => &operating_point::OperatingPoint,
        EffectKind::SensorDrift => &sensor_drift::SensorDrift,
        EffectKind::Pendulum => &cross_coupling::CrossCoupling,
        EffectKind::TrackingLowpass | EffectKind::Uncertainty => {
            panic!("{kind} is not in the diagnosis's catalogue")
        }
    }
}

/// The catalogue's kinds, in the order of the diagnosis spec.
pub const CATALOGUE: [EffectKind; 9] = [
    EffectKind::TimeDelay,
    EffectKind::Backlash,
    EffectKind::CoulombFriction,
    EffectKind::AccelerationSaturation,
    EffectKind::StructuralMode,
    EffectKind::SensorLowpass,
    EffectKind::OperatingPointDependence,
    EffectKind::SensorDrift,
    EffectKind::Pendulum,
];

/// The catalogue's names (`time_delay`, ..., `cross_coupling`).
pub fn catalogue_names() -> Vec<&'static str> {
    CATALOGUE.iter().map(|k| profile(*k).name()).collect()
}

/// The catalogue kind named `name` (`cross_coupling` is the pendulum's coupling terms).
pub fn kind_named(name: &str) -> Option<EffectKind> {
    CATALOGUE
        .iter()
        .copied()
        .find(|k| profile(*k).name() == name)
}

/// Every candidate the catalogue offers on top of `spec` on this campaign: each kind under
/// each law (per excited plane for a mode) that can be added.
pub fn candidates(spec: &ModelSpec, r: &DataRange) -> Vec<Candidate> {
    let mut out = Vec::new();
    for kind in CATALOGUE {
        let p = profile(kind);
        for &law in p.laws() {
            let planes: Vec<Option<Axis>> = if p.per_plane() {
                Axis::BOTH
                    .into_iter()
                    .filter(|a| r.axes_excited[a.index()])
                    .map(Some)
                    .collect()
            } else {
                vec![None]
            };
            for plane in planes {
                let c = Candidate { kind, law, plane };
                if p.addable(spec, &c, r) {
                    out.push(c);
                }
            }
        }
    }
    out
}

/// The free parameters of every catalogue effect `spec` has (each profile's).
pub fn effect_frees(spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
    let mut out = Vec::new();
    for kind in CATALOGUE {
        out.extend(profile(kind).frees(spec, r));
    }
    out
}

/// Whether every catalogue effect `spec` has still describes its effect.
pub fn physical(spec: &ModelSpec) -> bool {
    CATALOGUE.iter().all(|k| profile(*k).physical(spec))
}

/// Data ranges the profiles scale their starting values and bounds from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DataRange {
    /// Lowest excitation frequency of the records, rad/s.
    pub omega_min: f64,
    /// Highest excitation frequency of the records, rad/s.
    pub omega_max: f64,
    /// Smallest measured input amplitude, m.
    pub amplitude_min: f64,
    /// Largest measured input amplitude, m.
    pub amplitude_max: f64,
    /// Spread of the operating points along `x` and `y`, m.
    pub op_span: [f64; 2],
    /// The unit direction of the line the operating points lie on, when they lie on one
    /// (`words::op_line`); `None` when they span the plane or there is only one.
    pub op_line: Option<[f64; 2]>,
    /// Whether any record excites `x` and `y` (indexed by `Axis::index`).
    pub axes_excited: [bool; 2],
    /// The distinct excitation frequencies, ascending.
    pub omegas: [f64; 16],
    /// How many of `omegas` are used (at most 16, spread over the band).
    pub n_omegas: usize,
    /// Per output axis, the records' trends ([`trend_spread`]): their mean rate and the spread
    /// of the rates beyond their noise, m/s.
    pub trend: [[f64; 2]; 2],
}

/// The records' trends on output `i` weighted by `w = 1 / (var(s) + tau2)`: their weighted
/// mean `m` and Cochran's `Q = sum w (s - m)^2` (`tau2 = 0`: the test of one rate, `Q` on
/// `n - 1` degrees of freedom).
pub fn trend_q(obs: &[&Observation], i: usize, tau2: f64) -> (f64, f64) {
    let w: Vec<f64> = obs
        .iter()
        .map(|o| 1.0 / (o.slope_var[i].max(1e-300) + tau2))
        .collect();
    let sw: f64 = w.iter().sum::<f64>().max(1e-300);
    let m = obs.iter().zip(&w).map(|(o, w)| w * o.slope[i]).sum::<f64>() / sw;
    let q = obs
        .iter()
        .zip(&w)
        .map(|(o, w)| w * (o.slope[i] - m).powi(2))
        .sum();
    (m, q)
}

/// The mean of the records' trends on output `i` and the spread of their rates beyond each
/// one's noise, by Paule and Mandel's estimate of the between-record variance `tau^2`: with
/// weights `w = 1 / (var(s) + tau^2)` and the weighted mean `m`, `sum w (s - m)^2 = n - 1`
/// (Cochran's `Q` at its expectation), `tau^2 = 0` when `Q` is below it already. Where the
/// spread dominates every record's noise the weights are nearly equal, as they should be: a
/// precise record measures its own rate well, not the others'. `(0, 0)` without records.
pub fn trend_spread(obs: &[&Observation], i: usize) -> [f64; 2] {
    let at = |tau2: f64| trend_q(obs, i, tau2);
    if obs.len() < 2 {
        return [obs.first().map_or(0.0, |o| o.slope[i]), 0.0];
    }
    let target = obs.len() as f64 - 1.0;
    let (m0, q0) = at(0.0);
    if q0 <= target {
        return [m0, 0.0];
    }
    // Q falls as tau^2 grows; bracket, then bisect (in logarithm: tau^2 spans decades).
    let spread2 = obs.iter().map(|o| o.slope[i].powi(2)).sum::<f64>() / obs.len() as f64;
    let (mut lo, mut hi) = (1e-30_f64, spread2.max(1e-30) * 4.0);
    while at(hi).1 > target && hi < 1e30 {
        hi *= 4.0;
    }
    for _ in 0..80 {
        let mid = (lo * hi).sqrt();
        if at(mid).1 > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let tau2 = (lo * hi).sqrt();
    [at(tau2).0, tau2.sqrt()]
}

impl DataRange {
    /// A range for naming parameters only (their bounds unused): one frequency and one
    /// amplitude, nothing excited. Bounds scaled from an empty campaign's range would be
    /// `[inf, 0]`.
    pub fn for_names() -> DataRange {
        DataRange {
            omega_min: 1.0,
            omega_max: 1.0,
            amplitude_min: 1e-3,
            amplitude_max: 1e-3,
            ..DataRange::of(&[])
        }
    }

    /// The range the records `obs` cover.
    pub fn of(obs: &[&Observation]) -> DataRange {
        let mut r = DataRange {
            omega_min: f64::INFINITY,
            omega_max: 0.0,
            amplitude_min: f64::INFINITY,
            amplitude_max: 0.0,
            op_span: [0.0; 2],
            op_line: crate::words::op_line(obs),
            axes_excited: [false; 2],
            omegas: [0.0; 16],
            n_omegas: 0,
            trend: [trend_spread(obs, 0), trend_spread(obs, 1)],
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
        let w = crate::criterion::distinct_omegas(obs);
        // Sixteen kept at most, spread over the band (starts only: more add nothing).
        let step = w.len().div_ceil(16).max(1);
        for v in w.iter().step_by(step) {
            r.omegas[r.n_omegas] = *v;
            r.n_omegas += 1;
        }
        r
    }

    /// The excited axes.
    pub fn excited(&self) -> Vec<Axis> {
        Axis::BOTH
            .into_iter()
            .filter(|a| self.axes_excited[a.index()])
            .collect()
    }

    /// The sweep's frequencies.
    pub fn sweep(&self) -> &[f64] {
        &self.omegas[..self.n_omegas]
    }
}

/// The binding of an axis.
pub fn axis(a: Axis) -> Binding {
    Binding::Axis(a)
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

/// An effect with one parameter on every excited axis, each axis its own value, from each of
/// `scan` (the first its typical value).
pub(crate) fn per_axis(
    spec: &ModelSpec,
    r: &DataRange,
    kind: EffectKind,
    values: &[f64],
    param: &'static str,
    scan: &[f64],
    range: (f64, f64),
) -> Vec<Start> {
    let axes: Vec<Binding> = r.excited().into_iter().map(axis).collect();
    scan.iter()
        .map(|&v| {
            let mut s = spec.clone();
            let mut vals = values.to_vec();
            if let Some(i) = kind.info().param_index(param) {
                vals[i] = v;
            }
            add_effect(&mut s, kind, &axes, &vals);
            let frees = axes
                .iter()
                .map(|b| Free::new(kind, vec![*b], param, v, range.0, range.1))
                .collect();
            (s, frees)
        })
        .collect()
}

/// The frees of parameter `param` of every instance of `kind` in `spec`, each its own, within
/// `range`.
pub(crate) fn instance_frees(
    spec: &ModelSpec,
    kind: EffectKind,
    param: &'static str,
    range: (f64, f64),
) -> Vec<Free> {
    spec.effects
        .iter()
        .filter(|e| e.info.kind == kind)
        .filter_map(|e| {
            let v = e.value(param)?;
            Some(Free::new(kind, vec![e.binding], param, v, range.0, range.1))
        })
        .collect()
}

/// The servo's tracking low-pass `(omega_n, zeta)` of input axis `b` (the seed's where the
/// model has none).
pub fn servo_of(spec: &ModelSpec, b: Binding) -> (f64, f64) {
    (
        spec.value(EffectKind::TrackingLowpass, b, "omega_n")
            .unwrap_or(SEED_SERVO.0),
        spec.value(EffectKind::TrackingLowpass, b, "zeta")
            .unwrap_or(SEED_SERVO.1),
    )
}

/// The seed's servo tracking low-pass `(omega_n, zeta)`: 30 rad/s, critically damped (seed 1,
/// section 5).
pub const SEED_SERVO: (f64, f64) = (30.0, 1.0);

/// The tests' campaign: sines of 3-8 mm from 0.5 to 15 rad/s on both axes.
#[cfg(test)]
pub(crate) fn test_range() -> DataRange {
    let mut omegas = [0.0; 16];
    let w = zmp_models::logspace(0.5, 15.0, 9);
    omegas[..9].copy_from_slice(&w);
    DataRange {
        omega_min: 0.5,
        omega_max: 15.0,
        amplitude_min: 0.003,
        amplitude_max: 0.008,
        op_span: [0.06, 0.04],
        op_line: Some([0.83205, 0.5547]),
        axes_excited: [true, true],
        omegas,
        n_omegas: 9,
        trend: [[0.0; 2]; 2],
    }
}

/// The seed's model with a force limit per axis.
#[cfg(test)]
pub(crate) fn paper_with_limits(x: f64, y: f64) -> ModelSpec {
    let mut spec = ModelSpec::parse(
        include_str!("../../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap();
    add_effect(
        &mut spec,
        EffectKind::AccelerationSaturation,
        &[axis(Axis::X)],
        &[x],
    );
    add_effect(
        &mut spec,
        EffectKind::AccelerationSaturation,
        &[axis(Axis::Y)],
        &[y],
    );
    spec
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every kind of the catalogue has its profile, its name reads back, and on a model with
    /// force limits the campaign offers every law of every kind but the limit it has; every
    /// start of every candidate builds a plant and keeps the effect physical.
    #[test]
    fn every_candidate_starts_from_models_that_build() {
        let r = test_range();
        let spec = paper_with_limits(1.0, 1.2);
        for k in CATALOGUE {
            assert_eq!(kind_named(profile(k).name()), Some(k));
        }
        let cands = candidates(&spec, &r);
        let names: Vec<String> = cands.iter().map(|c| c.label()).collect();
        assert!(!names.iter().any(|n| n == "acceleration_saturation"));
        // Delay, two plays, friction, four modes, low-pass, operating point (common and per
        // channel), drift (one rate and per record); the paper model has its coupling terms.
        assert_eq!(cands.len(), 13, "{names:?}");
        for c in &cands {
            let starts = profile(c.kind).starts(&spec, c, &r);
            assert!(!starts.is_empty(), "{c}");
            for (s, frees) in &starts {
                assert!(zmp_models::Plant::new(s, 0.001).is_ok(), "{c}: {s:?}");
                assert!(physical(s), "{c}");
                // A drift per record has nothing to fit: each record's trend is its own.
                assert!(!frees.is_empty() || c.law == Law::PerRecord, "{c}");
                // The start's own parameters are among what a joint fit moves.
                let all = effect_frees(s, &r);
                for f in frees
                    .iter()
                    .filter(|f| f.kind != EffectKind::AccelerationSaturation)
                {
                    assert!(
                        all.iter().any(|g| g.name() == f.name()),
                        "{c}: {} not refitted",
                        f.name()
                    );
                }
            }
            // Taken out again: the model it started from.
            let mut back = starts[0].0.clone();
            profile(c.kind).remove(&mut back, c);
            if c.kind != EffectKind::Pendulum {
                assert_eq!(back.to_toml(), spec.to_toml(), "{c}");
            }
        }
    }
}
