//! Fitting a model structure to records: the free parameters, the one optimiser (bounded
//! Levenberg-Marquardt on the records' chi-square, `lm`), and the one multi-start policy every
//! fit of the diagnosis follows ([`fit_starts`]).
//!
//! **The cost** is the chi-square: every record's first-harmonic, trend and (in band) third-
//! harmonic misfit over its own noise ([`whitened`]), the likelihood for Gaussian noise.
//!
//! **The multi-start policy.** A structure is fitted from a list of starts, each a model and
//! the parameters a first, short fit from it moves. Every start is evaluated as it is; the
//! [`KEEP`] best are fitted for [`ITERS_SHORT`] iterations (the effects they start, the rest
//! held). The starts of a structure (see `search`) are its parents' fits with
//! the missing effect at each of its profile's starts, and the identified model's core after
//! [`undo`] (a faster servo, the seed's, no force limit above the demand) with every effect of
//! the structure at its typical values. The best start after its short fit is then fitted with
//! every parameter free ([`ITERS_JOINT`] iterations, and on while it still descends): the
//! pendulum, the servo's low-pass and every effect's parameters.

use crate::lm::{minimise, Bounded};
use crate::measure::{predict_in_time, whitened, COMPONENTS};
use crate::observe::Observation;
use crate::profiles::{
    demanded_acceleration, effect_frees, physical, servo_of, DataRange, Start, SEED_SERVO,
};
use zmp_models::{Axis, Binding, Channel, EffectKind, ModelSpec};

/// Iterations of a start's short fit (its own effect's parameters only).
pub const ITERS_SHORT: usize = 6;
/// Starts fitted after each start is evaluated as it is (the nearest to the records).
pub const KEEP: usize = 2;
/// Iterations of the joint fit, every parameter free, from the best short fit.
pub const ITERS_JOINT: usize = 12;
/// A model written as a version is fitted on at most this many times [`ITERS_JOINT`] more
/// while it still descends (1 % over five iterations).
pub const DESCENT_FACTOR: usize = 2;

/// One scalar a fit moves; it sets `param` of `kind` at every binding listed.
#[derive(Debug, Clone, PartialEq)]
pub struct Free {
    /// The effect (or the core) the parameter belongs to.
    pub kind: EffectKind,
    /// Where the one value is written: an axis, an output, or the whole model.
    pub bindings: Vec<Binding>,
    /// The parameter's key in the model file.
    pub param: &'static str,
    /// Its current value and the bounds the fit keeps it within.
    pub bounds: Bounded,
}

impl Free {
    /// A free parameter starting at `value`, clamped into `[min, max]`.
    pub fn new(
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

    /// Dotted name for reports: `time_delay.x.delay`, `tracking_lowpass.omega_n`.
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

/// A fitted model.
#[derive(Debug, Clone)]
pub struct Fit {
    /// The model at the fitted values.
    pub spec: ModelSpec,
    /// Every parameter the joint fit moved, at its fitted value.
    pub frees: Vec<Free>,
    /// Standard error of each of `frees`, in the same order (not finite when undetermined).
    pub std_err: Vec<f64>,
    /// Chi-square on the records fitted.
    pub cost: f64,
}

impl Fit {
    /// The fitted parameters of the kinds listed, by dotted name: value and standard error.
    pub fn parameters_of(&self, kinds: &[EffectKind]) -> Vec<(String, f64, f64)> {
        self.frees
            .iter()
            .zip(&self.std_err)
            .filter(|(f, _)| kinds.contains(&f.kind))
            .map(|(f, e)| (f.name(), f.bounds.value, *e))
            .collect()
    }
}

/// The core refitted with every structure: the diagonal pendulum, the off-diagonal terms the
/// model has (a zero one is the coupling candidate's), and the servo's tracking low-pass
/// (shared by the axes: one servo design).
pub fn core_frees(spec: &ModelSpec) -> Vec<Free> {
    let mut out = Vec::new();
    let g = vec![Binding::Global];
    for ch in Channel::ALL {
        for name in [a_name(ch), b_name(ch)] {
            let v = spec
                .value(EffectKind::Pendulum, Binding::Global, name)
                .unwrap_or(0.0);
            if ch.output == ch.input || v != 0.0 {
                out.push(Free::new(
                    EffectKind::Pendulum,
                    g.clone(),
                    name,
                    v,
                    -10.0,
                    10.0,
                ));
            }
        }
    }
    if spec.has(EffectKind::TrackingLowpass) {
        let (wn, zeta) = servo_of(spec, Binding::Axis(Axis::X));
        let both = vec![Binding::Axis(Axis::X), Binding::Axis(Axis::Y)];
        let lp = EffectKind::TrackingLowpass;
        out.push(Free::new(lp, both.clone(), "omega_n", wn, 1.0, 1e3));
        // A position servo is at least moderately damped (the seed's is critically damped):
        // below 0.3 a low-pass would be a structural mode, which the catalogue names apart.
        out.push(Free::new(lp, both, "zeta", zeta, 0.3, 5.0));
    }
    out
}

fn a_name(ch: Channel) -> &'static str {
    ["a11", "a12", "a21", "a22"][2 * ch.output.index() + ch.input.index()]
}

fn b_name(ch: Channel) -> &'static str {
    ["b11", "b12", "b21", "b22"][2 * ch.output.index() + ch.input.index()]
}

/// Every parameter a joint fit of `spec` moves: the core's and every effect's.
pub fn all_frees(spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
    let mut out = core_frees(spec);
    out.extend(effect_frees(spec, r));
    out
}

/// Fits `frees` of `start` on `obs` in at most `iters` iterations (and on while it descends
/// when `extra`); `None` when the model cannot be evaluated or its fitted effects are no
/// longer physical.
pub fn fit_lm(
    start: &ModelSpec,
    frees: &[Free],
    obs: &[&Observation],
    iters: usize,
    extra: usize,
) -> Option<Fit> {
    if frees.is_empty() {
        return None;
    }
    let theta0: Vec<Bounded> = frees.iter().map(|f| f.bounds).collect();
    let mut work = start.clone();
    let mut r = |theta: &[f64]| -> Option<Vec<f64>> {
        // Past the time limit of the work it serves, no evaluation (and none finished,
        // `predict_in_time`): the fit ends with its best so far.
        if zmp_campaign::par::past_deadline() {
            return None;
        }
        apply(&mut work, frees, theta);
        let p = predict_in_time(&work, obs).ok()??;
        let mut out = Vec::with_capacity(obs.len() * COMPONENTS);
        for (o, pr) in obs.iter().zip(&p) {
            whitened(o, pr, &mut out);
        }
        out.iter().all(|v| v.is_finite()).then_some(out)
    };
    let (theta, cost, var) = minimise(
        &theta0,
        iters,
        extra,
        &mut r,
        &zmp_campaign::par::past_deadline,
    )?;
    let mut spec = start.clone();
    apply(&mut spec, frees, &theta);
    let mut frees = frees.to_vec();
    for (f, v) in frees.iter_mut().zip(&theta) {
        f.bounds.value = *v;
    }
    physical(&spec).then(|| Fit {
        spec,
        frees,
        std_err: var.iter().map(|v| v.sqrt()).collect(),
        cost,
    })
}

/// The one multi-start policy: every start evaluated as it is, the [`KEEP`] best with their
/// own parameters (if any) fitted for [`ITERS_SHORT`] iterations, then every parameter of the best
/// from there ([`ITERS_JOINT`]). `None` when no start can be fitted.
pub fn fit_starts(starts: &[Start], obs: &[&Observation], r: &DataRange) -> Option<Fit> {
    let mut ranked: Vec<(f64, &Start)> = starts
        .iter()
        .filter_map(|st| Some((cost_of(&st.0, obs)?, st)))
        .collect();
    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let best = ranked
        .iter()
        .take(KEEP)
        .filter_map(|(cost, (s, own))| {
            // A start with nothing of its own to fit (a drift per record) goes to the joint
            // fit as it is.
            if own.is_empty() {
                return physical(s).then(|| Fit {
                    spec: s.clone(),
                    frees: Vec::new(),
                    std_err: Vec::new(),
                    cost: *cost,
                });
            }
            fit_lm(s, own, obs, ITERS_SHORT, 0)
        })
        .min_by(|a, b| a.cost.total_cmp(&b.cost))?;
    Some(joint(best, obs, r, DESCENT_FACTOR * ITERS_JOINT))
}

/// The chi-square of `spec` on `obs` (`None` when it cannot be evaluated).
pub fn cost_of(spec: &ModelSpec, obs: &[&Observation]) -> Option<f64> {
    let p = predict_in_time(spec, obs).ok()??;
    let mut r = Vec::with_capacity(obs.len() * COMPONENTS);
    for (o, pr) in obs.iter().zip(&p) {
        whitened(o, pr, &mut r);
    }
    let c: f64 = r.iter().map(|x| x * x).sum();
    c.is_finite().then_some(c)
}

/// Every parameter of `fit` fitted on from its values for as long as it descends (a model
/// written as a version); the better of the two.
pub fn polish(fit: Fit, obs: &[&Observation], r: &DataRange) -> Fit {
    joint(fit, obs, r, DESCENT_FACTOR * ITERS_JOINT)
}

fn joint(fit: Fit, obs: &[&Observation], r: &DataRange, extra: usize) -> Fit {
    let frees = all_frees(&fit.spec, r);
    let joint = fit_lm(&fit.spec, &frees, obs, ITERS_JOINT, extra);
    match joint {
        Some(j) if j.cost <= fit.cost => j,
        _ => fit,
    }
}

/// The starts that undo what an identified model absorbs, each a model and the parameters its
/// short fit moves besides the effects': `spec` as it is; the servo's low-pass at the seed's
/// (30 rad/s, critically damped) and faster than it is (a delay or a filter the model lacks
/// is absorbed into a slower, more damped low-pass); every force limit no record reaches
/// restarted below the campaign's largest demand (a limit that never acts has no gradient: a
/// friction or a heavier drive moves the demand under it); a saturation's passive damping at a
/// tenth and a third of the servo's damping `2 zeta omega_n` (from near zero a fit stays
/// there). Variants that change nothing are left out.
pub fn undo(spec: &ModelSpec, r: &DataRange) -> Vec<Start> {
    let mut out: Vec<Start> = vec![(spec.clone(), Vec::new())];
    let x = Binding::Axis(Axis::X);
    let (wn, zeta) = servo_of(spec, x);
    let core = core_frees(spec);
    let servo: Vec<_> = core
        .iter()
        .filter(|f| f.kind == EffectKind::TrackingLowpass)
        .cloned()
        .collect();
    if spec.has(EffectKind::TrackingLowpass) {
        for (w, z) in [SEED_SERVO, (1.5 * wn, (0.7 * zeta).max(0.5))] {
            if (w / wn - 1.0).abs() < 0.1 && (z / zeta - 1.0).abs() < 0.1 {
                continue;
            }
            let mut s = spec.clone();
            for a in Axis::BOTH {
                s.set_value(EffectKind::TrackingLowpass, Binding::Axis(a), "omega_n", w);
                s.set_value(EffectKind::TrackingLowpass, Binding::Axis(a), "zeta", z);
            }
            let mut own = servo.clone();
            for f in &mut own {
                f.bounds.value = if f.param == "omega_n" { w } else { z };
            }
            out.push((s, own));
        }
    }
    let sat = EffectKind::AccelerationSaturation;
    let demand = demanded_acceleration(spec, r);
    let idle: Vec<Binding> = spec
        .effects
        .iter()
        .filter(|e| e.info.kind == sat && e.value("limit").is_some_and(|l| l >= demand))
        .map(|e| e.binding)
        .collect();
    if !idle.is_empty() {
        let mut s = spec.clone();
        let mut own = Vec::new();
        for b in &idle {
            s.set_value(sat, *b, "limit", 0.9 * demand);
            own.push(Free::new(sat, vec![*b], "limit", 0.9 * demand, 1e-3, 1e3));
        }
        out.push((s, own));
    }
    let damped: Vec<Binding> = spec
        .effects
        .iter()
        .filter(|e| e.info.kind == sat && e.value("passive_damping").is_some_and(|c| c > 0.0))
        .map(|e| e.binding)
        .collect();
    for share in [0.1, 0.3] {
        if damped.is_empty() {
            break;
        }
        let mut s = spec.clone();
        let mut own = Vec::new();
        for b in &damped {
            let (w, z) = servo_of(spec, *b);
            let c = share * 2.0 * z * w;
            s.set_value(sat, *b, "passive_damping", c);
            own.push(Free::new(
                sat,
                vec![*b],
                "passive_damping",
                c,
                0.0,
                2.0 * z * w,
            ));
        }
        out.push((s, own));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profiles::{paper_with_limits, test_range};

    /// The undo starts: the model as it is, the seed's servo and a faster one, the idle limit
    /// restarted below the demand (the active one kept), and nothing else.
    #[test]
    fn the_undo_starts_restart_what_an_identification_absorbs() {
        let r = test_range();
        let demand = demanded_acceleration(&paper_with_limits(1.0, 1.0), &r);
        let mut spec = paper_with_limits(0.5 * demand, 3.0 * demand);
        for a in Axis::BOTH {
            spec.set_value(
                EffectKind::TrackingLowpass,
                Binding::Axis(a),
                "omega_n",
                14.0,
            );
            spec.set_value(EffectKind::TrackingLowpass, Binding::Axis(a), "zeta", 0.9);
        }
        let v = undo(&spec, &r);
        assert_eq!(v.len(), 4, "as it is, two servos, the idle limit");
        let servo = |s: &ModelSpec| servo_of(s, Binding::Axis(Axis::Y));
        assert_eq!(servo(&v[1].0), SEED_SERVO);
        assert_eq!(servo(&v[2].0), (21.0, 0.63));
        assert!(v[1].1.iter().all(|f| f.kind == EffectKind::TrackingLowpass));
        let limit = |s: &ModelSpec, a| {
            s.value(
                EffectKind::AccelerationSaturation,
                Binding::Axis(a),
                "limit",
            )
            .unwrap()
        };
        let demand = demanded_acceleration(&spec, &r);
        assert_eq!(limit(&v[3].0, Axis::Y), 0.9 * demand);
        assert_eq!(limit(&v[3].0, Axis::X), limit(&spec, Axis::X));
        assert_eq!(v[3].1.len(), 1);
        // The seed's own servo and no idle limit: only the faster servo.
        let plain = paper_with_limits(0.1, 0.1);
        assert_eq!(undo(&plain, &r).len(), 2);
    }
}
