//! The Torso Position Control's effort per model against the model's CoM error, and the seed's
//! claim tested on it: "the better the CoM model, the less the control acts".

use super::experiment::{ModelOutcome, Walks};
use std::fmt::Write as _;

/// The claim's resolution: models whose CoM errors differ by less are not ranked against each
/// other. Four times the designed calibration's horizontal RMS error (0.25 mm).
pub const CLAIM_RESOLUTION_M: f64 = 1e-3;

/// The seed's claim on the twin: "the better the CoM model, the less the control acts".
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Claim {
    pub holds: bool,
    /// Pairs ranked (CoM errors further apart than [`CLAIM_RESOLUTION_M`]).
    pub ranked_pairs: usize,
    /// Pairs where the model with the smaller CoM error needed more control (RMS shift).
    pub violations: Vec<(String, String)>,
    /// Spearman's rank correlation of the horizontal CoM error and the RMS shift.
    pub spearman: f64,
}

fn horizontal(v: [f64; 3]) -> f64 {
    v[0].hypot(v[1])
}

fn ranks(v: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
    let mut r = vec![0.0; v.len()];
    for (rank, &i) in idx.iter().enumerate() {
        r[i] = rank as f64;
    }
    r
}

/// Tests the claim over `(name, horizontal CoM error (m), RMS shift (m))`.
pub fn claim(points: &[(String, f64, f64)]) -> Claim {
    let mut ranked = 0;
    let mut violations = Vec::new();
    for (i, a) in points.iter().enumerate() {
        for b in &points[i + 1..] {
            if (a.1 - b.1).abs() < CLAIM_RESOLUTION_M {
                continue;
            }
            ranked += 1;
            let (better, worse) = if a.1 < b.1 { (a, b) } else { (b, a) };
            if better.2 >= worse.2 {
                violations.push((better.0.clone(), worse.0.clone()));
            }
        }
    }
    let e: Vec<f64> = points.iter().map(|p| p.1).collect();
    let u: Vec<f64> = points.iter().map(|p| p.2).collect();
    let spearman = super::compare::correlation(&ranks(&e), &ranks(&u));
    Claim {
        holds: ranked > 0 && violations.is_empty(),
        ranked_pairs: ranked,
        violations,
        spearman,
    }
}

/// The claim over the walked models.
pub fn claim_of(models: &[ModelOutcome]) -> Option<Claim> {
    let pts: Vec<(String, f64, f64)> = models
        .iter()
        .filter_map(|m| {
            let e = m.with_tpc.effort?;
            Some((m.name.clone(), horizontal(m.com_error_m), e.rms_m[2]))
        })
        .collect();
    (!pts.is_empty()).then(|| claim(&pts))
}

fn rss_pos(w: &Walks) -> f64 {
    w.mean.rms_pos[0].hypot(w.mean.rms_pos[1])
}

/// The control effort per model against the model's CoM error, and what the control does to the
/// ZMP; then the claim.
pub fn effort_table(models: &[ModelOutcome]) -> String {
    let mut s = String::from(
        "| model | CoM error of the model, horizontal (mm) | TPC shift RMS x / y / magnitude (mm) | \
         magnitude RMS, runs min-max (mm) | peak (mm) | ∫\\|d\\|² dt (mm² s) | steps at the 5 cm limit | \
         ZMP bias, open loop → TPC (mm) | ZMP RMS XY sqrt(X²+Y²), open loop → TPC (mm) | \
         TPC walks finished standing |\n|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for m in models {
        let Some(e) = m.with_tpc.effort else { continue };
        let mags: Vec<f64> = m.with_tpc.efforts.iter().map(|e| e.rms_m[2]).collect();
        let (lo, hi) = mags
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(*v), b.max(*v))
            });
        let bias = |w: &Walks| w.mean.bias[0].hypot(w.mean.bias[1]) * 1e3;
        let _ = writeln!(
            s,
            "| {} | {:.2} | {:.2} / {:.2} / {:.2} | {:.2}-{:.2} | {:.2} | {:.1} | {:.1} % | {:.2} → {:.2} | \
             {:.2} → {:.2} | {} of {} |",
            m.name,
            horizontal(m.com_error_m) * 1e3,
            e.rms_m[0] * 1e3,
            e.rms_m[1] * 1e3,
            e.rms_m[2] * 1e3,
            lo * 1e3,
            hi * 1e3,
            e.peak_m * 1e3,
            e.integral_sq_m2s * 1e6,
            100.0 * e.saturated_fraction,
            bias(&m.open_loop),
            bias(&m.with_tpc),
            rss_pos(&m.open_loop) * 1e3,
            rss_pos(&m.with_tpc) * 1e3,
            m.with_tpc.finished_standing,
            m.with_tpc.traces.len()
        );
    }
    if let Some(p) = models.iter().find_map(|m| m.tpc) {
        let mus: Vec<String> = models
            .iter()
            .filter_map(|m| {
                let mu = m.tpc?.com_per_shift;
                Some(format!("{} {:.3}/{:.3}", m.name, mu[0], mu[1]))
            })
            .collect();
        let _ = writeln!(
            s,
            "\nGains (`zmp_models::walking::torso`, every {:.0} ms physics step): closed-loop time \
             constant {:.2} s, ZMP error low-pass {:.3} s (critical damping on the cart-table \
             model), limit {:.0} mm; CoM shift per torso shift, x/y, from each planning model: {}.",
            p.step_s * 1e3,
            p.closed_loop_s,
            p.filter_s,
            p.limit_m * 1e3,
            mus.join(", ")
        );
    }
    if let Some(c) = claim_of(models) {
        let mut order: Vec<&ModelOutcome> = models
            .iter()
            .filter(|m| m.with_tpc.effort.is_some())
            .collect();
        order.sort_by(|a, b| horizontal(a.com_error_m).total_cmp(&horizontal(b.com_error_m)));
        let names: Vec<&str> = order.iter().map(|m| m.name.as_str()).collect();
        let _ = writeln!(
            s,
            "\n**The seed's claim (the better the CoM model, the less the control acts) {} on the \
             twin**: ordered by CoM error the models are {}; of the {} pairs whose CoM errors \
             differ by more than {:.0} mm, {} the model with the smaller error needed less \
             correction{}. Spearman's rank correlation of CoM error and RMS shift: {:.2}.",
            if c.holds { "holds" } else { "does not hold" },
            names.join(" < "),
            c.ranked_pairs,
            CLAIM_RESOLUTION_M * 1e3,
            if c.violations.is_empty() {
                "in every one".to_string()
            } else {
                format!("in {}", c.ranked_pairs - c.violations.len())
            },
            if c.violations.is_empty() {
                String::new()
            } else {
                let v: Vec<String> = c
                    .violations
                    .iter()
                    .map(|(a, b)| format!("{a} against {b}"))
                    .collect();
                format!(" (not: {})", v.join(", "))
            },
            c.spearman
        );
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_claim_ranks_only_models_whose_com_errors_differ() {
        let p = |n: &str, e: f64, u: f64| (n.to_string(), e, u);
        // e < r < s in CoM error and in effort; n and v within the resolution, in any order:
        // 9 of the 10 pairs are ranked.
        let c = claim(&[
            p("n", 0.0135, 0.020),
            p("r", 0.0120, 0.018),
            p("s", 0.0152, 0.022),
            p("v", 0.0132, 0.0205),
            p("e", 0.0005, 0.006),
        ]);
        assert!(c.holds, "{c:?}");
        assert_eq!(c.ranked_pairs, 9);
        // r and n swapped in effort: one violation.
        let d = claim(&[
            p("n", 0.0135, 0.017),
            p("r", 0.0122, 0.018),
            p("e", 0.0, 0.001),
        ]);
        assert!(!d.holds);
        assert_eq!(d.violations, vec![("r".to_string(), "n".to_string())]);
        assert!((d.spearman - 0.5).abs() < 1e-12, "{}", d.spearman);
    }
}
