//! The loop's last look at a model without a delay whose servo low-pass is slower than the
//! seed's: the delay that low-pass may have absorbed.
//!
//! Below the servo's bandwidth a delay `tau` and a slower low-pass both lag the phase by about
//! `omega` times a constant (`tau`, `2 zeta / omega_n`), so the identification and the early
//! rounds can give the delay's lag to the low-pass; beside a play on the CoM command the delay
//! candidate then removes nothing, and once the play is inside its servo the model is at the
//! noise, where the search adds nothing more. Held-out draw 1160027 (spent, examined after its
//! range: a 26 ms delay beside a 2.1 mm play, servo 24 rad/s and damping 0.96): the loop ended
//! with the play alone and the servo at 13.2 rad/s, damping 0.51, at 1.52 per component; the
//! delay fitted from the seed's servo (30 rad/s, critically damped) with the difference of the
//! two lags as its start reached 25-27 ms, the servo 20.6 rad/s and 0.79, at 0.92 per
//! component. So once the loop is done, a model without a delay whose low-pass lags more than
//! the seed's is given the delay candidate (its starts include that one), and takes it when it
//! passes the search's test and removes at least half of the excess held-out chi-square left
//! ([`removes_most`]: the search's own test past "explained" without its noise gate, as
//! `readd` uses it). The noise gate keeps the search from adding, to a model at the noise, the
//! best of the whole catalogue fitted to another robot's mismatch (a play beside friction and
//! low-pass took 53 % of the excess at 1.76 per component on development seed 38); here one
//! effect is tried, on the evidence of the servo's lag. On 1160027 it removes 67 %
//! (held-out chi-square 1445 -> 875 over 936 components).
//!
//! A mode fitted before the delay bends to the delay's phase, and the delay fitted beside it
//! finds little left to take: held-out draw 1200041 (spent, examined after its range: a mode
//! per plane at 31.9 rad/s, above the sweep, and 18.4, a 99 ms delay, drift; the servo at
//! 39.8 rad/s) ended with near-undamped links at 19.1 and 16.5 rad/s, the servo at 11.3 rad/s
//! and damping 0.80, and the delay beside them removed 8 % (9.1x the floor). So on a model with
//! a mode the delay is also fitted with the structure made typical ([`typical_start`] with the
//! seed's servo, the modes also at the upper starts, [`moved_starts`]) and the servo's extra lag
//! as the delay, every parameter refitted; the better of the two by held-out chi-square is
//! judged. On 1200041 it removes 99 % (107771 -> 2284: 92 ms, links at 32.8 and 18.3 rad/s),
//! and the loop then tries the trunk inside its servo again (0.80x the floor).
//!
//! The servo may also take a delay's lag without lagging more than the seed's: on a robot
//! whose servo is faster than the seed's, the sum of its lag and the delay's can be the seed's
//! own. Held-out draw 1210038 (spent: links at 22.2 and 17.2 rad/s, a 15 ms delay, the servo at
//! 29.0 rad/s, damping 0.83) ended with the servo at 21.8 and 0.78, no delay looked for, and
//! unexplained at 1.24x the floor. So a model with a mode that does not explain the data is
//! given the typical structure's delay even without an absorbed lag, from the delay
//! candidate's shortest start (a tenth of a radian at the top frequency). The typical starts
//! come under both laws (as filters of the reference and inside the servo) and with force
//! limits that never act restarted below the demand ([`revived_limits`]): on 1210038 the
//! delay then removes 98 % (4474 -> 892), servo, delays and links as drawn, 0.89x.

use super::super::augment::Augmented;
use super::super::candidates::{
    absorbed_lag, add_effect, mode_bindings, trunk_in_servo, DataRange, CATALOGUE,
};
use super::super::engine;
use super::super::measure::predict;
use super::super::observe::Observation;
use super::super::run::explains;
use super::super::select::MAX_EFFECTS;
use super::super::DiagnoseOptions;
use super::typical::{catalogue_kinds, moved_starts, revived_limits, typical_start};
use super::{keep_if_removes_most, LoopError};
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, ModelSpec};

/// The model with the delay its low-pass absorbed, when it has none and the delay (beside the
/// model's structure, or with it made typical) passes (see the module's documentation).
pub(super) fn look(
    current: &ModelSpec,
    found: &[String],
    obs: &[&Observation],
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Option<Augmented>, LoopError> {
    if current.has(EffectKind::TimeDelay) || found.len() >= MAX_EFFECTS {
        return Ok(None);
    }
    let r = DataRange::of(obs);
    let lag = absorbed_lag(current, &r);
    // Without an absorbed lag, only the typical structure's delay, and only where the model
    // has a mode and does not explain the data.
    // Nor on a model with a friction, whose every fit simulates every record (see
    // `with_typical_structure`).
    let light = !engine::heavy_base(current);
    if lag.is_none()
        && (!light || mode_bindings(current).is_empty() || explains(obs, &predict(current, obs)?))
    {
        return Ok(None);
    }
    progress("trying the delay a slow servo low-pass may have absorbed");
    let Some(now) = engine::score_as_it_is(current, obs) else {
        return Ok(None);
    };
    let Some(c) = CATALOGUE.iter().find(|c| c.effect == "time_delay") else {
        return Ok(None);
    };
    let beside = lag.and_then(|_| engine::score_candidate(c, current, obs));
    let typical = with_typical_structure(current, lag.unwrap_or(0.1 / r.omega_max), &r, obs);
    let Some(child) = [beside, typical]
        .into_iter()
        .flatten()
        .min_by(|a, b| a.chi2.total_cmp(&b.chi2))
    else {
        return Ok(None);
    };
    keep_if_removes_most("the delay", &now, &child, current, obs, opts, progress)
}

/// The delay of `lag` on each excited axis added to the model's structure made typical
/// ([`typical_start`] with the seed's servo; its modes also moved to the upper starts), every
/// parameter refitted and scored held-out; `None` without a mode.
fn with_typical_structure(
    current: &ModelSpec,
    lag: f64,
    r: &DataRange,
    obs: &[&Observation],
) -> Option<engine::Scored> {
    let mut s = typical_start(current, true)?;
    let axes: Vec<Binding> = Axis::BOTH
        .iter()
        .zip(r.axes_excited)
        .filter(|(_, e)| *e)
        .map(|(a, _)| Binding::Axis(*a))
        .collect();
    add_effect(&mut s, EffectKind::TimeDelay, &axes, &[lag]);
    // Under both laws and with idle limits revived, except on a model with a friction: its
    // fits simulate every record, and those starts would multiply them.
    let starts = if engine::heavy_base(current) {
        moved_starts(vec![s], r)
    } else {
        let laws: Vec<ModelSpec> = std::iter::once(s.clone())
            .chain(trunk_in_servo(&s))
            .collect();
        moved_starts(revived_limits(laws, r), r)
    };
    let fitted = engine::refit_all_from(&starts, &catalogue_kinds(), obs)?;
    Some(engine::cross_validate("time_delay", fitted, obs))
}
