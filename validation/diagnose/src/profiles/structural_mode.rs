//! A lightly damped structural mode, plane by plane: on the ZMP path (`structural_mode`, a
//! share of the path resonates) or inside the servo's loop (`flexible_trunk` with
//! `in_servo = 1`: part of the trunk's mass on a flexible link the servo drives; where the
//! force limit clamps, the limited force excites the link).

use super::{add_effect, axis, DataRange, Profile, Start};
use crate::fit::Free;
use crate::structure::{Candidate, Law};
use crate::words::{median_by_frequency, Evidence};
use zmp_models::{Binding, EffectKind, ModelSpec};

pub struct Mode;

const PATH: EffectKind = EffectKind::StructuralMode;
const LINK: EffectKind = EffectKind::FlexibleTrunk;

/// Upper bound of a mode's damping ratio: a resonance (peak gain `1/(2 zeta sqrt(1 - zeta^2))`
/// = 1.36 at 0.4; none above 0.71). A fit that ends there is the data asking for a well-damped
/// second-order filter, the servo low-pass's shape, not a ringing mode ([`Mode::physical`]).
const ZETA_MAX: f64 = 0.4;
/// A typical link: damping ratio, share of the plane's mass on the link, drive's share of the
/// inertia (where every start begins, at its frequency).
const LINK_ZETA: f64 = 0.08;
const LINK_SHARE: f64 = 0.4;
const PATH_SHARE: f64 = 0.8;
const DRIVE: f64 = 0.3;

/// The frequencies a mode starts at: the top of the sweep (typical); the upper three of five
/// log-spaced from a sixth of it to two and a half times it (a mode above the band still bends
/// its phase and magnitude there; one far below it would be a drift); each sweep frequency
/// from a sixth of the top up and the geometric middle of each two (a lightly damped mode
/// inside the sweep has a narrow basin). Frequencies within 5 % of one kept are left out.
fn omegas(r: &DataRange) -> Vec<f64> {
    let lo = (r.omega_max / 6.0).max(r.omega_min);
    let hi = 2.5 * r.omega_max;
    let log = |k: usize| lo * (hi / lo).powf((k as f64 + 0.5) / 5.0);
    let mut v = vec![r.omega_max, log(2), log(3), log(4)];
    let band: Vec<f64> = r.sweep().iter().copied().filter(|w| *w >= lo).collect();
    for (k, w) in band.iter().enumerate() {
        v.push(*w);
        if let Some(next) = band.get(k + 1) {
            v.push((w * next).sqrt());
        }
    }
    let mut out: Vec<f64> = Vec::new();
    for w in v {
        if !out.iter().any(|u| (w / u - 1.0).abs() < 0.05) {
            out.push(w);
        }
    }
    out
}

fn omega_range(r: &DataRange) -> (f64, f64) {
    (0.5 * r.omega_min, 3.0 * r.omega_max)
}

/// The free parameters of the mode of kind `kind` at `b` from `[omega_n, zeta, share, drive]`.
fn mode_frees(kind: EffectKind, b: Binding, v: [f64; 4], r: &DataRange) -> Vec<Free> {
    let (wlo, whi) = omega_range(r);
    let mut out = vec![
        Free::new(kind, vec![b], "omega_n", v[0], wlo, whi),
        Free::new(kind, vec![b], "zeta", v[1], 0.005, ZETA_MAX),
    ];
    if kind == LINK {
        out.push(Free::new(kind, vec![b], "share", v[2], 0.05, 0.95));
        out.push(Free::new(kind, vec![b], "drive", v[3], 0.0, 0.8));
    } else {
        out.push(Free::new(kind, vec![b], "share", v[2], 0.05, 1.0));
    }
    out
}

impl Profile for Mode {
    fn kind(&self) -> EffectKind {
        PATH
    }

    fn model_kinds(&self) -> &'static [EffectKind] {
        &[PATH, LINK]
    }

    fn laws(&self) -> &'static [Law] {
        &[Law::InServo, Law::OnZmpPath]
    }

    fn per_plane(&self) -> bool {
        true
    }

    /// Not on a plane that has a mode; inside the servo not where a play is inside it (a servo
    /// drives one link).
    fn addable(&self, spec: &ModelSpec, c: &Candidate, _r: &DataRange) -> bool {
        let Some(p) = c.plane else { return false };
        let b = axis(p);
        spec.get(PATH, b).is_none()
            && spec.get(LINK, b).is_none()
            && (c.law == Law::OnZmpPath
                || spec.value(EffectKind::Backlash, b, "in_servo") != Some(1.0))
    }

    fn starts(&self, spec: &ModelSpec, c: &Candidate, r: &DataRange) -> Vec<Start> {
        let Some(p) = c.plane else {
            return Vec::new();
        };
        let b = axis(p);
        omegas(r)
            .into_iter()
            .map(|w| {
                let mut s = spec.clone();
                let (kind, v) = if c.law == Law::InServo {
                    (LINK, [w, LINK_ZETA, LINK_SHARE, DRIVE])
                } else {
                    (PATH, [w, LINK_ZETA, PATH_SHARE, 0.0])
                };
                if kind == LINK {
                    add_effect(&mut s, kind, &[b], &[v[0], v[1], v[2], v[3], 1.0]);
                } else {
                    add_effect(&mut s, kind, &[b], &v[..3]);
                }
                (s, mode_frees(kind, b, v, r))
            })
            .collect()
    }

    fn frees(&self, spec: &ModelSpec, r: &DataRange) -> Vec<Free> {
        let mut out = Vec::new();
        for e in spec
            .effects
            .iter()
            .filter(|e| e.info.kind == PATH || e.info.kind == LINK)
        {
            let v = ["omega_n", "zeta", "share", "drive"].map(|p| e.value(p).unwrap_or(0.0));
            out.extend(mode_frees(e.info.kind, e.binding, v, r));
        }
        out
    }

    /// A mode whose damping ratio ended at its cap is a well-damped filter bending the
    /// response to absorb a misfit the catalogue does not name; one whose share of the mass
    /// ended at its floor carries next to nothing; a link carrying nearly all the mass (its
    /// share at its cap) spends it on a phase a mode does not make (typically a delay's). A
    /// mode on the ZMP path may take the whole path, and the drive's share may end anywhere.
    fn physical(&self, spec: &ModelSpec) -> bool {
        spec.effects
            .iter()
            .filter(|e| e.info.kind == PATH || e.info.kind == LINK)
            .all(|e| {
                let zeta = e.value("zeta").unwrap_or(0.0);
                let share = e.value("share").unwrap_or(1.0);
                zeta < 0.98 * ZETA_MAX
                    && share > 1.05 * 0.05
                    && !(e.info.kind == LINK && share >= 0.98 * 0.95)
            })
    }

    fn costly(&self, c: &Candidate) -> bool {
        c.law == Law::InServo
    }

    fn signature(&self, c: &Candidate) -> &'static str {
        match c.law {
            Law::InServo => {
                "a resonance of the trunk inside the servo's loop (a gain peak and a phase drop \
                 near its frequency, reshaped where the force limit clamps)"
            }
            _ => "a resonance on the ZMP path (a gain peak and a phase drop near its frequency)",
        }
    }

    fn evidence(&self, _c: &Candidate, e: &Evidence) -> String {
        let (w, _, mag) = e.ratio_parts();
        // Per frequency, the median over its records.
        let prof = median_by_frequency(&w, &mag);
        let by = |a: &&(f64, f64), b: &&(f64, f64)| a.1.total_cmp(&b.1);
        let peak = prof.iter().max_by(by).copied().unwrap_or((f64::NAN, 0.0));
        let dip = prof.iter().min_by(by).copied().unwrap_or((f64::NAN, 1.0));
        let db = |m: f64| 20.0 * m.max(1e-12).log10();
        if db(peak.1) >= 1.0 && peak.0 != dip.0 {
            format!(
                "measured/model magnitude peaks at {:+.1} dB near {:.2} rad/s and dips to \
                 {:+.1} dB near {:.2} rad/s (medians per frequency): a lightly damped \
                 structural mode ({})",
                db(peak.1),
                peak.0,
                db(dip.1),
                dip.0,
                e.params_text()
            )
        } else {
            format!(
                "measured/model magnitude shows no clear resonance in the band (medians per \
                 frequency within {:+.1} to {:+.1} dB); the fitted mode ({}) bends the response \
                 where the other parameters cannot",
                db(dip.1),
                db(peak.1),
                e.params_text()
            )
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::profiles::{paper_with_limits, test_range};
    use zmp_models::Axis;

    /// A link at its damping cap or at its share's floor or cap is not a mode; one inside them
    /// is, whatever its drive share; a mode on the ZMP path may take the whole path.
    #[test]
    fn a_mode_at_the_caps_of_its_ranges_is_not_a_mode() {
        let with = |kind: EffectKind, v: &[f64]| {
            let mut s = paper_with_limits(1.0, 1.2);
            add_effect(&mut s, kind, &[axis(Axis::Y)], v);
            Mode.physical(&s)
        };
        assert!(with(LINK, &[12.0, 0.06, 0.3, 0.3, 1.0]));
        assert!(with(LINK, &[12.0, 0.06, 0.06, 0.0, 1.0]));
        assert!(with(LINK, &[12.0, 0.06, 0.9, 0.8, 1.0]));
        assert!(!with(LINK, &[12.0, 0.06, 0.0504, 0.3, 1.0]));
        assert!(!with(LINK, &[12.0, ZETA_MAX, 0.3, 0.3, 1.0]));
        assert!(!with(LINK, &[12.0, 0.06, 0.95, 0.3, 1.0]));
        assert!(with(PATH, &[12.0, 0.06, 1.0]));
        assert!(!with(PATH, &[12.0, 0.06, 0.05]));
    }

    /// The starts: the top of the sweep first, then the upper log-spaced frequencies and the
    /// sweep's own from a sixth of its top, none within 5 % of another; each on its plane only.
    #[test]
    fn a_mode_starts_across_and_above_the_sweep_on_its_plane() {
        let r = test_range();
        let w = omegas(&r);
        assert_eq!(w[0], 15.0);
        assert!(w.iter().all(|x| *x >= 2.5 && *x <= 37.5), "{w:?}");
        assert!(w.iter().any(|x| *x > 25.0) && w.iter().any(|x| *x < 3.0));
        for (k, a) in w.iter().enumerate() {
            assert!(w[..k].iter().all(|b| (a / b - 1.0).abs() >= 0.05));
        }
        let spec = paper_with_limits(1.0, 1.2);
        let c = Candidate::on(PATH, Law::InServo, Axis::Y);
        for (s, own) in Mode.starts(&spec, &c, &r) {
            assert!(s.get(LINK, axis(Axis::X)).is_none());
            assert_eq!(s.value(LINK, axis(Axis::Y), "in_servo"), Some(1.0));
            assert_eq!(own.len(), 4);
        }
    }
}
