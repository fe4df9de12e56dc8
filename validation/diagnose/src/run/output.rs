//! The diagnosis as the `zmp-diagnosis/1` JSON document and in words.

use super::{Diagnosis, DIAGNOSIS_FORMAT};
use crate::candidates::CATALOGUE;
use crate::cells::Cell;
use serde_json::{json, Value};

impl Diagnosis {
    /// The `zmp-diagnosis/1` JSON document.
    pub fn to_json(&self) -> Value {
        json!({
            "format": DIAGNOSIS_FORMAT,
            "campaign": self.campaign,
            "model": self.model,
            "noise_floor": self.noise_floor,
            "baseline_error": self.baseline_error,
            "verdict": self.verdict,
            "findings": self.findings,
            "error_measure": "rms over records of the steady-state NRMSE (first harmonic and trend of both ZMP outputs, over the measured first harmonic's RMS)",
            "records": self.records,
            "skipped": self.skipped.iter().map(|(k, r)| json!({"record": k, "reason": r})).collect::<Vec<_>>(),
            "refit_error": self.refit_error,
            "final_error": self.final_error,
            "selected": self.selected.iter().map(|(e, x)| json!({"effect": e, "error_after": x})).collect::<Vec<_>>(),
            "tried": self.tried.iter().map(|(e, x)| json!({"effect": e, "held_out_error": x})).collect::<Vec<_>>(),
            "where_it_fails": self.cells.iter().filter(|c| c.significant).take(12).collect::<Vec<_>>(),
            "time_limit_reached": self.time_limit_reached,
            "catalogue": CATALOGUE.iter().map(|c| c.effect).collect::<Vec<_>>(),
        })
    }

    /// The same in words.
    pub fn to_text(&self) -> String {
        let mut s = String::new();
        let f = self.noise_floor;
        s.push_str(&format!(
            "Diagnosis of {} against {} ({} records{})\n",
            self.campaign,
            self.model,
            self.records,
            if self.skipped.is_empty() {
                String::new()
            } else {
                format!(", {} left out", self.skipped.len())
            }
        ));
        s.push_str(&format!(
            "  error {:.4} ({:.1}x the noise floor {:.4})",
            self.baseline_error,
            self.baseline_error / f,
            f,
        ));
        // No refit when the model already explains the data.
        if self.refit_error.is_finite() {
            s.push_str(&format!(
                "; with the pendulum and bandwidth refitted: {:.4} (held-out)",
                self.refit_error
            ));
        }
        s.push('\n');
        let verdict = match self.verdict.as_str() {
            "none" => "none: the model explains the data to the noise floor".to_string(),
            "unexplained" => {
                "unexplained: a significant error remains that no catalogued effect removes"
                    .to_string()
            }
            "parameter_refit" => {
                "parameter_refit: the structure is right, the parameters are off".to_string()
            }
            e => format!("{e} is missing from the model"),
        };
        s.push_str(&format!("Verdict: {verdict}\n"));
        if self.time_limit_reached {
            s.push_str(
                "  (the time limit passed before the search ended: what follows is what it \
                 reached in time)\n",
            );
        }
        for (k, fd) in self.findings.iter().enumerate() {
            s.push_str(&format!(
                "{}. {}{} [{}]: error {:.4} -> {:.4}{}\n     {}\n",
                k + 1,
                fd.effect,
                if fd.significant {
                    ""
                } else {
                    " (not significant)"
                },
                fd.channels.join(", "),
                fd.error_before,
                fd.error_after,
                if fd.held_out { " (held-out)" } else { "" },
                fd.evidence
            ));
        }
        let bad: Vec<&Cell> = self
            .cells
            .iter()
            .filter(|c| c.significant)
            .take(6)
            .collect();
        if !bad.is_empty() {
            s.push_str("Where the starting model fails (error / noise floor):\n");
            for c in bad {
                s.push_str(&format!("  {}\n", c.line()));
            }
        }
        s
    }
}
