//! The loop's last step: effects that do nothing in the final model are taken out of it.
//!
//! A candidate is fitted with every parameter of the model it joins, so a step can pass on
//! what the refit of the others gained while its own parameters end at their "off" value (a
//! delay of zero, a play of zero width): development seed 11 (a lone play of 0.3 mm) named a
//! delay of 0 ms in its third round, whose evidence then read "the fitted delay (y.delay = 0)
//! explains what the other parameters do not". Such an effect's predictions are the model's
//! without it, so it is no finding: it is removed from the model and the list of effects
//! found, and the rest refitted (change `without-EFFECT`).

use super::super::augment::{version_from_diagnosis, Augmented};
use super::super::candidates::model_kinds;
use super::super::engine;
use super::super::measure::{chi2_total, predict};
use super::super::observe::Observation;
use super::super::DiagnoseOptions;
use super::LoopError;
use zmp_models::ModelSpec;

/// Relative change of the chi-square below which removing an effect changes nothing.
const SAME: f64 = 1e-9;

/// `current` without the effects of `found` whose removal leaves every prediction's chi-square
/// the same, refitted, with what is left of `found`; `None` when every effect acts.
pub(super) fn take_out(
    current: &ModelSpec,
    found: &[String],
    obs: &[&Observation],
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Option<(Vec<String>, Augmented)>, LoopError> {
    let chi2_of =
        |s: &ModelSpec| -> Result<f64, LoopError> { Ok(chi2_total(obs, &predict(s, obs)?)) };
    let now = chi2_of(current)?;
    let mut spec = current.clone();
    let mut gone: Vec<&String> = Vec::new();
    // The seed's own structure (the force limit, the pendulum's coupling) is not an addition.
    for e in found
        .iter()
        .filter(|e| !matches!(e.as_str(), "acceleration_saturation" | "cross_coupling"))
    {
        if gone.contains(&e) {
            continue;
        }
        let mut without = spec.clone();
        for &k in model_kinds(e) {
            without.remove(k);
        }
        if without.effects.len() == spec.effects.len() {
            continue;
        }
        if (chi2_of(&without)? - now).abs() <= SAME * now.max(1.0) {
            spec = without;
            gone.push(e);
        }
    }
    if gone.is_empty() {
        return Ok(None);
    }
    let label = gone
        .iter()
        .map(|e| format!("without-{e}"))
        .collect::<Vec<_>>()
        .join("+");
    progress(&format!(
        "taking out what does nothing in the model ({label})"
    ));
    let Some(fitted) = engine::refit_all_from(std::slice::from_ref(&spec), &[], obs) else {
        return Ok(None);
    };
    let names = found
        .iter()
        .filter(|e| !gone.contains(e))
        .cloned()
        .collect();
    let aug = version_from_diagnosis(obs, current, &fitted, &label, opts)?;
    Ok(Some((names, aug)))
}
