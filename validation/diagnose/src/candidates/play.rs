//! The play's second law: a backlash found on the CoM command (the catalogue's candidate law)
//! moved inside its axis's servo, between the drive and the trunk (`backlash.in_servo = 1`).

use zmp_models::EffectKind;
use zmp_models::{Binding, ModelSpec};

/// Drive shares (the part of the axis's inertia on the servo's encoder side) the law is
/// fitted from: a fit from one share runs it to a bound where the other is nearer.
const DRIVE_STARTS: [f64; 2] = [0.3, 0.5];

/// Factors on the force limit of a play's axis the law is fitted from: inside the servo the
/// limited force accelerates the drive alone while the play is open, so the command law's
/// limit (fitted for a rigid trunk) is low for the law inside (development seed 20: from the
/// command law's limit the fit ran the drive shares to their bounds, chi-square 6810 against
/// 3111 for the command law; from twice that limit 831).
const LIMIT_FACTORS: [f64; 2] = [1.0, 2.0];

/// Starts of the model `spec` with every play on the command (of positive width) moved inside
/// its axis's servo: each drive share of [`DRIVE_STARTS`] with each factor of
/// [`LIMIT_FACTORS`] on those axes' force limits; the transmission (mode, damping, drag)
/// at its defaults. Empty when `spec` has no such play. An axis whose servo already drives a
/// link (a flexible trunk inside it) keeps its play on the command: a servo drives one link.
pub fn play_in_servo_starts(spec: &ModelSpec) -> Vec<ModelSpec> {
    let plays = plays_on_command(spec);
    if plays.is_empty() {
        return Vec::new();
    }
    let mut out = Vec::new();
    for drive in DRIVE_STARTS {
        for factor in LIMIT_FACTORS {
            let mut s = spec.clone();
            for &b in &plays {
                let Some(mut e) = s.get(EffectKind::Backlash, b).cloned() else {
                    continue;
                };
                // Values may leave out trailing optional parameters: written out in full.
                let n = e.info.params.len();
                for k in e.values.len()..n {
                    e.values.push(e.info.params[k].default.unwrap_or(0.0));
                }
                s.insert(e);
                s.set_value(EffectKind::Backlash, b, "in_servo", 1.0);
                s.set_value(EffectKind::Backlash, b, "drive", drive);
                if let Some(limit) = s.value(EffectKind::AccelerationSaturation, b, "limit") {
                    s.set_value(
                        EffectKind::AccelerationSaturation,
                        b,
                        "limit",
                        limit * factor,
                    );
                }
            }
            out.push(s);
        }
    }
    out
}

/// The axes of `spec` whose play (of positive width) is on the command and could move inside
/// the servo (see [`play_in_servo_starts`]).
pub fn plays_on_command(spec: &ModelSpec) -> Vec<Binding> {
    spec.effects
        .iter()
        .filter(|e| e.info.kind == EffectKind::Backlash)
        .filter(|e| e.value("in_servo") != Some(1.0) && e.value("width").unwrap_or(0.0) > 0.0)
        .filter(|e| spec.value(EffectKind::FlexibleTrunk, e.binding, "in_servo") != Some(1.0))
        .map(|e| e.binding)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::tests::paper_with_limits;
    use super::super::{add_effect, AXES};
    use super::*;

    /// Four starts, each with the play inside the servo at the same width, the drive shares
    /// and limit factors crossed, the other axis untouched; none without a play on the
    /// command.
    #[test]
    fn every_play_on_the_command_moves_inside_its_servo_from_four_starts() {
        let base = paper_with_limits(1.0, 1.2);
        assert!(play_in_servo_starts(&base).is_empty());
        let mut s = base.clone();
        add_effect(&mut s, EffectKind::Backlash, &[AXES[0]], &[0.0005]);
        let starts = play_in_servo_starts(&s);
        assert_eq!(starts.len(), 4);
        let mut seen = Vec::new();
        for st in &starts {
            let v = |p| st.value(EffectKind::Backlash, AXES[0], p).unwrap();
            assert_eq!((v("width"), v("in_servo")), (0.0005, 1.0));
            let limit = |b| {
                st.value(EffectKind::AccelerationSaturation, b, "limit")
                    .unwrap()
            };
            seen.push((v("drive"), limit(AXES[0])));
            assert_eq!(limit(AXES[1]), 1.2, "the other axis's limit");
            assert!(st.validate("start").is_ok(), "a valid model");
        }
        assert_eq!(seen, vec![(0.3, 1.0), (0.3, 2.0), (0.5, 1.0), (0.5, 2.0)]);
        assert!(
            play_in_servo_starts(&starts[0]).is_empty() && plays_on_command(&starts[0]).is_empty(),
            "already inside"
        );
        assert_eq!(plays_on_command(&s), vec![AXES[0]]);
    }
}
