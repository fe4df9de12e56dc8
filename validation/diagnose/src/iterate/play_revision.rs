//! The loop's last look at a model with a play: the other effects judged again with the play
//! inside its servo.
//!
//! The search names effects on top of a play on the CoM command (the law that is cheap to fit);
//! the loop then tries the play inside its servo ([`super::play_law`]), keeping the other
//! effects. But an effect named beside the command law may stand for the difference between
//! the two laws rather than for the robot: on the independent simulator's delay-beside-play
//! draws (development draws 7100-7109 of `pair:time_delay,backlash`) a damped mode took the
//! delay's place (7100: mode and play at 0.6x the noise floor, delay and the play inside the
//! servo at 0.3x held-out), or the delay was not named at all because, beside the command law,
//! it removed too little (7108: 0.8x against 0.43x). So once the loop has settled, with the
//! play inside its servo, each other effect is taken out and every catalogue effect tried in
//! its place (the swap rule of the search, [`replaces`]: a simpler effect wins a near tie, a
//! more complex one must win by more than the tie's slack), and every catalogue
//! effect is tried on top (added when it removes most of what is left, [`dominates`], the
//! search's test past "explained"). The best of these, by held-out chi-square, replaces the
//! model. Each candidate fitted beside a play inside its servo costs seconds (the pass took
//! 150 s on development seed 28 for nothing, and 2-4 minutes on lone plays), so: effects are
//! tried on top only where the loop kept the play on the command (7108), and a model at the
//! noise gets nothing added and only its structural modes put in question (7100, 7105).
//!
//! A servo drives one link: a mode inside the servo keeps the play on the command
//! ([`plays_on_command`]). Taking such a mode out also lets the play go inside, and that
//! play alone is an option in the mode's place, winning a near tie against the best (one
//! effect fewer). Development seed 11 (a lone play of 0.3 mm in a stiff transmission): a mode
//! inside the servo was named first, the play stayed on the command, and the loop ended
//! unexplained at 1.06x the floor; without the mode the play inside its servo takes the
//! held-out chi-square from 16279 to 982 (0.39x).

use super::super::augment::{version_from_diagnosis, Augmented};
use super::super::candidates::{model_kinds, plausible, play_in_servo_starts, plays_on_command};
use super::super::engine::{self, cross_validate, Scored};
use super::super::observe::Observation;
use super::super::run::DiagnoseError;
use super::super::select::{beyond_noise, dominates, plausible as supported, replaces, CHI2_MIN};
use super::super::DiagnoseOptions;
use zmp_models::EffectKind;
use zmp_models::ModelSpec;

/// The effects the model that replaces `current` names (`found` with one effect replaced or
/// one added), the effect it brings in, and that version; `None` when nothing beats it.
pub(super) fn revise(
    current: &ModelSpec,
    found: &[String],
    obs: &[&Observation],
    opts: &DiagnoseOptions,
    progress: &(dyn Fn(&str) + Sync),
) -> Result<Option<(Vec<String>, String, Augmented)>, DiagnoseError> {
    if !current.has(EffectKind::Backlash) || !found.iter().any(|e| e == "backlash") {
        return Ok(None);
    }
    progress("judging the other effects again with the play inside its servo");
    // The model as it is (fitted by the loop: one joint fit from its values), scored
    // held-out: what a revision must beat.
    let Some(now) = engine::score_as_it_is(current, obs) else {
        return Ok(None);
    };
    // The same effects with the play inside its servo.
    let on_command = !plays_on_command(current).is_empty();
    let law = if !on_command {
        now.clone()
    } else {
        let Some(f) = engine::refit_all_from(
            &play_in_servo_starts(current),
            &[EffectKind::Backlash, EffectKind::AccelerationSaturation],
            obs,
        ) else {
            return Ok(None);
        };
        cross_validate("play_in_servo", f, obs)
    };
    let reference = if law.chi2 < now.chi2 { &law } else { &now };
    let threads = opts.threads;
    // (effect taken out, if any; the structure; whether it is the play alone in its place)
    let mut options: Vec<(Option<String>, Scored, bool)> = Vec::new();
    let children = |base: &Scored, exclude: &[String]| -> Vec<Scored> {
        let all = engine::score_candidates(&base.fitted.spec, obs, exclude, threads, &|_| {});
        supported(all, base, obs)
            .into_iter()
            .filter(|c| plausible(&c.fitted.frees[..c.fitted.own]))
            .collect()
    };
    // At the noise nothing is added (`dominates`), and only a mode is put in question (the
    // effect whose damped second-order response can stand for the dynamics that part the two
    // laws; a simpler one must win a near tie against it): each candidate fitted beside a play
    // inside its servo costs seconds.
    let at_noise = !beyond_noise(reference);
    // On top: an effect that removes most of what is left, tried where the loop kept the play
    // on the command (where it moved the play inside the servo, it re-added what the path
    // named after the play and searched on top of that law while the data were unexplained).
    if on_command && !at_noise {
        for c in children(&law, found) {
            if dominates(reference, &c) {
                options.push((None, c, false));
            }
        }
    }
    // In place of each other effect.
    let others: Vec<&String> = found
        .iter()
        .filter(|e| !matches!(e.as_str(), "backlash" | "acceleration_saturation"))
        .filter(|e| !at_noise || e.as_str() == "structural_mode")
        .collect();
    for removed in others {
        let mut spec = law.fitted.spec.clone();
        for &k in model_kinds(removed) {
            spec.remove(k);
        }
        let Some(mut base) = engine::control(&spec, obs) else {
            continue;
        };
        // A servo drives one link: a mode inside it kept the play on the command. Without the
        // mode the play goes inside, and may take the mode's place by itself.
        if !on_command && !plays_on_command(&spec).is_empty() {
            if let Some(f) = engine::refit_all_from(
                &play_in_servo_starts(&spec),
                &[EffectKind::Backlash, EffectKind::AccelerationSaturation],
                obs,
            ) {
                let inside = cross_validate("backlash", f, obs);
                if replaces(&inside, removed, reference.chi2) {
                    options.push((Some(removed.clone()), inside.clone(), true));
                }
                if inside.chi2 < base.chi2 {
                    base = inside;
                }
            }
        }
        for c in children(&base, found) {
            if replaces(&c, removed, reference.chi2) {
                options.push((Some(removed.clone()), c, false));
            }
        }
    }
    // The best by held-out chi-square, but the play alone in another effect's place (one
    // effect fewer) wins a near tie, as a simpler effect does in the search ([`CHI2_MIN`], a
    // twentieth far from the noise).
    let Some(least) = options.iter().map(|o| o.1.chi2).min_by(f64::total_cmp) else {
        return Ok(None);
    };
    let slack = CHI2_MIN.max(0.05 * least);
    let pick = options
        .iter()
        .position(|o| o.2 && o.1.chi2 <= least + slack)
        .or_else(|| options.iter().position(|o| o.1.chi2 == least));
    let Some((removed, best, alone)) = pick.map(|k| options.swap_remove(k)) else {
        return Ok(None);
    };
    let mut names: Vec<String> = found.to_vec();
    let label = match &removed {
        Some(r) => {
            progress(&format!(
                "{} replaces {r} beside the play inside its servo (held-out chi-square {:.0} \
                 against {:.0})",
                best.effect, best.chi2, reference.chi2
            ));
            if alone {
                // The play (named already) alone in the mode's place.
                names.retain(|e| e != r);
            } else if let Some(slot) = names.iter_mut().find(|e| *e == r) {
                *slot = best.effect.clone();
            }
            format!("{}-for-{r}", best.effect)
        }
        None => {
            progress(&format!(
                "adding {} beside the play inside its servo (held-out chi-square {:.0} against \
                 {:.0})",
                best.effect, best.chi2, reference.chi2
            ));
            names.push(best.effect.clone());
            format!("+{}", best.effect)
        }
    };
    let aug = version_from_diagnosis(obs, current, &best.fitted, &label, opts)?;
    Ok(Some((names, best.effect, aug)))
}
