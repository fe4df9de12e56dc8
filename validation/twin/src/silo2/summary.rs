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
    /// The parameter's model-file key (`a11` .. `b22`, `omega_n`, `zeta`).
    pub name: String,
    /// Seed eqs. 6-15 (point mass), rigid multibody, multibody through the servos (means over
    /// the campaign's operating points).
    pub seed: f64,
    /// The rigid multibody prediction.
    pub multibody: f64,
    /// The multibody prediction through the servos.
    pub servo: f64,
    /// The value identified from the twin's campaign.
    pub identified: f64,
    /// Its standard error.
    pub identified_stderr: f64,
    /// After the diagnosis loop added its effects (`None` if it added none).
    pub after_loop: Option<f64>,
}

/// The diagnosis, in short.
#[derive(Debug, Clone, Serialize)]
pub struct DiagnosisSummary {
    /// The diagnosis's verdict sentence.
    pub verdict: String,
    /// The noise floor of the diagnosis's held-out error measure.
    pub noise_floor: f64,
    /// Held-out error of the identified model (the same measure).
    pub baseline_error: f64,
    /// Held-out error of the final model (the same measure).
    pub final_error: f64,
    /// Effects added, with the held-out error after each.
    pub selected: Vec<(String, f64)>,
    /// Every finding: effect, significant, evidence sentence.
    pub findings: Vec<(String, bool, String)>,
    /// Fitted parameters of the final model's added effects.
    pub parameters: Vec<(String, f64)>,
    /// Where the final model file was written, if it was.
    pub final_model: Option<PathBuf>,
}

/// The twin's campaign, in short.
#[derive(Debug, Clone, Serialize)]
pub struct CampaignSummary {
    /// Records measured.
    pub records: usize,
    /// Samples over all records.
    pub rows: usize,
    /// Simulated time, s.
    pub simulated_s: f64,
    /// Wall time of the campaign, s.
    pub wall_s: f64,
    /// The ZMP sensor, described.
    pub sensor: String,
}

/// The closed-loop experiment, in short.
#[derive(Debug, Clone, Serialize)]
pub struct ClosedLoopSummary {
    /// The experiment's design.
    pub experiment: Experiment,
    /// The twin's run against the model's.
    pub comparison: LoopComparison,
    /// Wall time of both runs, s.
    pub wall_s: f64,
}

/// `StepExperiment`, serialisable.
#[derive(Debug, Clone, Serialize)]
pub struct Experiment {
    /// ZMP reference before the step, m.
    pub zmp_ref_before: [f64; 2],
    /// ZMP reference after the step, m.
    pub zmp_ref_after: [f64; 2],
    /// When the load is placed, s.
    pub load_time: f64,
    /// Mass of the load, kg.
    pub load_mass: f64,
    /// Where the load sits, absolute ZMP-plane coordinates, m.
    pub load_position: [f64; 2],
    /// Length of the run, s.
    pub duration: f64,
    /// Controller sample period, s.
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
    /// The summary's format string.
    pub format: &'static str,
    /// The model file checked.
    pub model_file: String,
    /// The short campaign was run.
    pub short: bool,
    /// The campaign was extended to 50 rad/s.
    pub extended: bool,
    /// Output folder.
    pub output: PathBuf,
    /// The twin's mass properties and servo gains.
    pub mass: MassProperties,
    /// The three predictions of `a`, `b` at each operating point.
    pub predictions: Vec<OperatingPoint>,
    /// The static checks of the seed's eq. 10 (ZMP of the load cells against the CoM and the centre of pressure).
    pub eq10: Vec<StaticCheck>,
    /// The dynamic checks during trunk sines (load-cell ZMP against the momentum and cart-table ZMP).
    pub dynamic: Vec<DynamicCheck>,
    /// The contact-softness budget.
    pub budget: Vec<BudgetRow>,
    /// The campaign.
    pub campaign: CampaignSummary,
    /// The `a`, `b` table.
    pub parameters: Vec<ParameterRow>,
    /// Reduced chi-squared of the identification.
    pub reduced_chi2: f64,
    /// Records the identification left out, and why.
    pub excluded_records: Vec<(usize, String)>,
    /// The identification's warnings.
    pub identify_warnings: Vec<String>,
    /// The closed-loop experiment.
    pub closed_loop: ClosedLoopSummary,
    /// The diagnosis.
    pub diagnosis: DiagnosisSummary,
    /// The stance resonance swept on the model file against the mode the diagnosis named.
    pub stance: Vec<super::stance::AxisStance>,
    /// Frame files (relative to the output folder), or why there are none.
    pub frames: Vec<PathBuf>,
    /// Why there are no frames, if there are none.
    pub frames_note: Option<String>,
    /// Wall time of the whole run, s.
    pub wall_s: f64,
}

/// The diagnosis `d`, in short; `final_model` is where its final model was written.
pub fn summarise_diagnosis(d: &Diagnosis, final_model: Option<PathBuf>) -> DiagnosisSummary {
    let selected: Vec<(String, f64)> = d
        .selected
        .iter()
        .map(|(c, e)| (c.name().to_string(), *e))
        .collect();
    let parameters = d
        .findings
        .iter()
        .filter(|f| matches!(f.effect, zmp_diagnose::run::Subject::Effect(_)))
        .flat_map(|f| f.parameters.iter().map(|(k, v)| (k.clone(), *v)))
        .collect();
    DiagnosisSummary {
        verdict: d.verdict.to_string(),
        noise_floor: d.noise_floor,
        baseline_error: d.baseline_error,
        final_error: d.final_error,
        selected,
        findings: d
            .findings
            .iter()
            .map(|f| (f.effect.to_string(), f.significant, f.evidence.clone()))
            .collect(),
        parameters,
        final_model,
    }
}

/// The rows of the `a`, `b` table (and `omega_n`, `zeta`) at the campaign's operating points.
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
