//! The diagnosis as the `zmp-diagnosis/1` JSON document and in words.

use super::{Diagnosis, DIAGNOSIS_FORMAT};
use crate::cells::Cell;
use crate::criterion::ALPHA;
use crate::profiles::catalogue_names;
use crate::structure::Verdict;
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
            "explained": self.explained,
            "selected": self.selected.iter().map(|(c, x)| json!({"effect": c.name(), "structure": c.label(), "error_after": x})).collect::<Vec<_>>(),
            "set": self.alternatives,
            "parted": self.parted,
            "residual": self.residual,
            "criterion": {
                "statistic": "z = min(D / (2 sqrt(c) |r_B - r_A|), sign(D) sqrt(|D| / c)), D = held-out chi2(B) - chi2(A): Cox's test of two structures on their held-out predictions and the likelihood ratio of one added parameter, both at the level, c the best structure's mismatch factor",
                "alpha": ALPHA,
                "structures_compared": self.compared,
                "z_threshold": self.z_crit,
                "mismatch": self.mismatch,
            },
            "tried": self.tried,
            "where_it_fails": self.cells.iter().filter(|c| c.significant).take(12).collect::<Vec<_>>(),
            "time_limit_reached": self.time_limit_reached,
            "catalogue": catalogue_names(),
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
            "  error {:.4} ({:.1}x the noise floor {:.4}); with its own parameters refitted: \
             {:.4} (held-out)\n",
            self.baseline_error,
            self.baseline_error / f,
            f,
            self.refit_error
        ));
        s.push_str(&format!(
            "  {} structures compared; significant at z > {:.2} ({} % shared over them)\n",
            self.compared,
            self.z_crit,
            ALPHA * 100.0
        ));
        let verdict = match &self.verdict {
            Verdict::None => "none: the model explains the data to the noise floor".to_string(),
            Verdict::Unexplained => {
                "unexplained: a significant error remains that no structure of the catalogue \
                 removes"
                    .to_string()
            }
            Verdict::Refit => {
                "parameter_refit: the structure is right, the parameters are off".to_string()
            }
            Verdict::Ambiguous(set) => format!(
                "ambiguous: the records do not decide between {}",
                set.iter().map(|x| x.label()).collect::<Vec<_>>().join(", ")
            ),
            Verdict::Effect(c) => format!("{c} is missing from the model"),
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
                "{}. {} [{}]: error {:.4} -> {:.4}{}\n     {}\n",
                k + 1,
                fd.effect,
                fd.channels.join(", "),
                fd.error_before,
                fd.error_after,
                if fd.held_out { " (held-out)" } else { "" },
                fd.evidence
            ));
        }
        if self.alternatives.len() > 1 {
            s.push_str("What the data cannot decide between (best first):\n");
            for a in &self.alternatives {
                let params: Vec<String> = a
                    .parameters
                    .iter()
                    .map(|(n, v)| format!("{n} = {}", crate::words::sig(*v)))
                    .collect();
                s.push_str(&format!(
                    "  - {}: held-out error {:.1}x the floor, z from the best {:.1}; {}\n",
                    a.structure,
                    a.held_out_error / f,
                    a.z_from_best,
                    params.join(", ")
                ));
                if let Some(d) = &a.distinguished {
                    s.push_str(&format!("    {}\n", d.words));
                }
            }
        }
        if !self.parted.is_empty() {
            s.push_str("What the records part yet fit no better (neither is the whole truth):\n");
            for p in &self.parted {
                s.push_str(&format!("  - {}\n", p.words));
            }
        }
        if !self.residual.is_empty() {
            s.push_str("What the final model leaves:\n");
            for r in &self.residual {
                s.push_str(&format!("  - {}\n", r.words));
            }
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
