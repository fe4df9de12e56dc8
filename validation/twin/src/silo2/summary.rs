//! What `validate silo2` found, as written to `summary.json`: the `a`, `b` table against the
//! predictions, the campaign, the closed loop and the diagnosis in short.

use super::closed_loop::LoopComparison;
use super::crosscheck::{BudgetRow, DynamicCheck, StaticCheck};
use super::props::{MassProperties, OperatingPoint};
use serde::Serialize;
use std::path::PathBuf;
use zmp_diagnose::Diagnosis;
use zmp_identify::Identification;
use zmp_models::closed_loop::StepExperiment;
use zmp_models::Axis;
use zmp_models::EffectKind;

/// One row of the `a`, `b` table.
#[derive(Debug, Clone, Serialize)]
pub struct ParameterRow {
    pub name: String,
    /// Seed eqs. 6-15 (point mass), rigid multibody, multibody through the servos (means over
    /// the campaign's operating points).
    pub seed: f64,
    pub multibody: f64,
    pub servo: f64,
    pub identified: f64,
    pub identified_stderr: f64,
    /// After the diagnosis loop added its effects (`None` if it added none).
    pub after_loop: Option<f64>,
}

/// The diagnosis, in short.
#[derive(Debug, Clone, Serialize)]
pub struct DiagnosisSummary {
    pub verdict: String,
    pub noise_floor: f64,
    pub baseline_error: f64,
    pub final_error: f64,
    /// Effects added, with the held-out error after each.
    pub selected: Vec<(String, f64)>,
    /// Every finding: effect, significant, evidence sentence.
    pub findings: Vec<(String, bool, String)>,
    /// Fitted parameters of the final model's added effects.
    pub parameters: Vec<(String, f64)>,
    pub final_model: Option<PathBuf>,
}

#[derive(Debug, Clone, Serialize)]
pub struct CampaignSummary {
    pub records: usize,
    pub rows: usize,
    pub simulated_s: f64,
    pub wall_s: f64,
    pub sensor: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct ClosedLoopSummary {
    pub experiment: Experiment,
    pub comparison: LoopComparison,
    pub wall_s: f64,
}

/// `StepExperiment`, serialisable.
#[derive(Debug, Clone, Serialize)]
pub struct Experiment {
    pub zmp_ref_before: [f64; 2],
    pub zmp_ref_after: [f64; 2],
    pub load_time: f64,
    pub load_mass: f64,
    pub load_position: [f64; 2],
    pub duration: f64,
    pub controller_period: f64,
}

impl From<&StepExperiment> for Experiment {
    fn from(e: &StepExperiment) -> Experiment {
        Experiment {
            zmp_ref_before: e.zmp_ref_before,
            zmp_ref_after: e.zmp_ref_after,
            load_time: e.load_time,
            load_mass: e.load_mass,
            load_position: e.load_position,
            duration: e.duration,
            controller_period: e.controller_period,
        }
    }
}

/// Everything the run found (`summary.json`).
#[derive(Debug, Clone, Serialize)]
pub struct Summary {
    pub format: &'static str,
    pub model_file: String,
    pub short: bool,
    /// The campaign was extended to 50 rad/s.
    pub extended: bool,
    pub output: PathBuf,
    pub mass: MassProperties,
    pub predictions: Vec<OperatingPoint>,
    pub eq10: Vec<StaticCheck>,
    pub dynamic: Vec<DynamicCheck>,
    pub budget: Vec<BudgetRow>,
    pub campaign: CampaignSummary,
    pub parameters: Vec<ParameterRow>,
    pub reduced_chi2: f64,
    pub excluded_records: Vec<(usize, String)>,
    pub identify_warnings: Vec<String>,
    pub closed_loop: ClosedLoopSummary,
    pub diagnosis: DiagnosisSummary,
    /// The stance resonance swept on the model file against the mode the diagnosis named.
    pub stance: Vec<super::stance::AxisStance>,
    /// Frame files (relative to the output folder), or why there are none.
    pub frames: Vec<PathBuf>,
    pub frames_note: Option<String>,
    pub wall_s: f64,
}

pub fn summarise_diagnosis(d: &Diagnosis, final_model: Option<PathBuf>) -> DiagnosisSummary {
    let selected: Vec<String> = d.selected.iter().map(|(e, _)| e.clone()).collect();
    let parameters = d
        .findings
        .iter()
        .filter(|f| selected.contains(&f.effect))
        .flat_map(|f| f.parameters.iter().map(|(k, v)| (k.clone(), *v)))
        .collect();
    DiagnosisSummary {
        verdict: d.verdict.clone(),
        noise_floor: d.noise_floor,
        baseline_error: d.baseline_error,
        final_error: d.final_error,
        selected: d.selected.clone(),
        findings: d
            .findings
            .iter()
            .map(|f| (f.effect.clone(), f.significant, f.evidence.clone()))
            .collect(),
        parameters,
        final_model,
    }
}

pub fn parameter_rows(
    preds: &[OperatingPoint],
    ident: &Identification,
    d: &Diagnosis,
) -> Vec<ParameterRow> {
    let mean = |f: &dyn Fn(&OperatingPoint) -> f64| {
        preds.iter().map(f).sum::<f64>() / preds.len().max(1) as f64
    };
    let after = |key: &str| -> Option<f64> {
        if d.selected.is_empty() {
            return None;
        }
        let (effect, binding, name) = match key {
            "omega_n" | "zeta" => (
                EffectKind::TrackingLowpass,
                zmp_models::Binding::Axis(Axis::X),
                key,
            ),
            k => (EffectKind::Pendulum, zmp_models::Binding::Global, k),
        };
        d.final_model.value(effect, binding, name)
    };
    let mut rows = Vec::new();
    for (letter, idm) in [("a", &ident.a), ("b", &ident.b)] {
        for i in 0..2 {
            for j in 0..2 {
                let name = format!("{letter}{}{}", i + 1, j + 1);
                let pick = |p: &super::props::Pendulum| {
                    if letter == "a" {
                        p.a[i][j]
                    } else {
                        p.b[i][j]
                    }
                };
                rows.push(ParameterRow {
                    after_loop: after(&name),
                    name,
                    seed: mean(&|o| pick(&o.seed)),
                    multibody: mean(&|o| pick(&o.multibody)),
                    servo: mean(&|o| pick(&o.servo)),
                    identified: idm[i][j].value,
                    identified_stderr: idm[i][j].stderr,
                });
            }
        }
    }
    let bw = &ident.bandwidth;
    rows.push(ParameterRow {
        name: "omega_n".into(),
        seed: 30.0,
        multibody: 30.0,
        servo: mean(&|o| 0.5 * (o.omega_n[0] + o.omega_n[1])),
        identified: bw.omega_n,
        identified_stderr: bw.omega_n_stderr,
        after_loop: after("omega_n"),
    });
    rows.push(ParameterRow {
        name: "zeta".into(),
        seed: 1.0,
        multibody: 1.0,
        servo: mean(&|o| 0.5 * (o.zeta[0] + o.zeta[1])),
        identified: bw.zeta,
        identified_stderr: bw.zeta_stderr,
        after_loop: after("zeta"),
    });
    rows
}
