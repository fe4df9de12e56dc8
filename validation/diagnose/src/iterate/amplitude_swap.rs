//! The loop's look at the other amplitude law: a friction where it named a play, a play where
//! it named a friction.
//!
//! Both make the small sines respond less and later than the large ones, and to first order
//! they are one law: a friction `F` in a servo of bandwidth `wn` holds the CoM until the
//! servo's error reaches `F / wn^2`, a dead band of about `2 F / wn^2`. What parts them is
//! second order (how the motion leaves the band, how the force limit shares the force with the
//! friction), so the search's choice between them depends on the laws it compares: a friction
//! in the servo against a play on the CoM command, the law that is cheap to fit. A play inside
//! its servo, tried only once a play is named, can fit far better: on the independent
//! simulator's development seed 20 (a lone play) the friction was named at 1.07x the noise
//! floor, and the play inside its servo reaches 0.54x. The other way, a friction whose
//! describing function is simulated with the force limit it shares the servo with can beat a
//! play named on the command (held-out draw 1180029, a friction beside a sensor low-pass).
//!
//! So once the loop has settled, a model with exactly one of the two has it taken out and the
//! other fitted in its place (a play both on the command and inside its servo), everything
//! refitted; it replaces the first when it wins by the search's swap rule
//! ([`replaces`](super::super::select::replaces): the two are alike, so by at least
//! [`CHI2_MIN`](super::super::select::CHI2_MIN) held-out chi-square).

use super::super::augment::{version_from_diagnosis, Augmented};
use super::super::candidates::{plausible, play_in_servo_starts, CATALOGUE};
use super::super::engine::{self, cross_validate, Scored};
use super::super::observe::Observation;
use super::super::select::replaces;
use super::super::DiagnoseOptions;
use super::LoopError;
use zmp_models::{EffectKind, ModelSpec};

/// The two amplitude laws of the catalogue.
const LAWS: [EffectKind; 2] = [EffectKind::Backlash, EffectKind::CoulombFriction];

/// The effects a version names, the effect it brings in (none: the named law fitted on), and
/// the version.
pub(super) type Swap = (Vec<String>, Option<String>, Augmented);

/// The effects the model that replaces `current` names (`found` with the law swapped, or as
/// it is when the named law, fitted on, predicts better), the effect it brings in, and that
/// version; `None` when the model has both laws or neither, or neither change wins.
pub(super) fn look(
    current: &ModelSpec,
    found: &[String],
    obs: &[&Observation],
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Option<Swap>, LoopError> {
    let named: Vec<EffectKind> = LAWS
        .into_iter()
        .filter(|law| found.iter().any(|e| e == law.name()) && current.has(*law))
        .collect();
    let [removed] = named[..] else {
        return Ok(None);
    };
    let other = LAWS
        .into_iter()
        .find(|law| *law != removed)
        .expect("two laws");
    progress(&format!("trying {other} in place of {removed}"));
    // Both laws fitted for as long as they descend: the choice is between the laws, not
    // between how far a fixed budget took each fit.
    let Some(as_is) = engine::score_as_it_is(current, obs) else {
        return Ok(None);
    };
    let now = engine::polish(&as_is, obs);
    // Where the other law does not win, the named one fitted on is the next version when it
    // predicts the held-out records better (the same law, further down its valley).
    let fitted_on = || -> Result<Option<Swap>, LoopError> {
        if now.chi2 >= as_is.chi2 {
            return Ok(None);
        }
        progress(&format!(
            "{removed} fitted on: held-out chi-square {:.0} against {:.0}",
            now.chi2, as_is.chi2
        ));
        let aug = version_from_diagnosis(obs, current, &now.fitted, "refit", opts)?;
        Ok(Some((found.to_vec(), None, aug)))
    };
    let mut spec = current.clone();
    spec.remove(removed);
    let Some(base) = engine::control(&spec, obs) else {
        return fitted_on();
    };
    let candidate = CATALOGUE
        .iter()
        .find(|c| c.effect == other.name())
        .expect("a catalogue effect");
    let Some(child) = engine::score_candidate_unscreened(candidate, &base.fitted.spec, obs)
        .filter(|c| plausible(&c.fitted.frees[..c.fitted.own]))
    else {
        return fitted_on();
    };
    let mut best = child;
    if other == EffectKind::Backlash {
        // The play inside its servo too, from the command law's fit.
        let inside = engine::refit_all_from(
            &play_in_servo_starts(&best.fitted.spec),
            &[EffectKind::Backlash, EffectKind::AccelerationSaturation],
            obs,
        );
        if let Some(f) = inside {
            let mut s: Scored = cross_validate(other.name(), f, obs);
            s.effect = other.to_string();
            if s.chi2 < best.chi2 {
                best = s;
            }
        }
    }
    let best = engine::polish(&best, obs);
    progress(&format!(
        "{other} in place of {removed}: held-out chi-square {:.0} against {:.0}",
        best.chi2, now.chi2
    ));
    if !replaces(&best, removed.name(), now.chi2) {
        return fitted_on();
    }
    progress(&format!("{other} replaces {removed}"));
    let names: Vec<String> = found
        .iter()
        .map(|e| {
            if e == removed.name() {
                other.to_string()
            } else {
                e.clone()
            }
        })
        .collect();
    let label = format!("{other}-for-{removed}");
    let aug = version_from_diagnosis(obs, current, &best.fitted, &label, opts)?;
    Ok(Some((names, Some(other.to_string()), aug)))
}
