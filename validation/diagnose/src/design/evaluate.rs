//! The separations a given list of records gives: a design proposed by hand, or a designed one
//! judged under other hypotheses (a model of the robot that drew a simulated campaign).

use super::limits::{Candidate, RecordTiming};
use super::separation::{
    as_truth, candidate_observation, predict_all, record_set, refit, start, NESTED_CHI2,
};
use super::{check, model_error, noise_model, DesignError, DesignOptions, DesignedRecord};
use super::{Rival, Separation};
use crate::observe::Observation;
use crate::run::observe_campaign;
use zmp_campaign::Campaign;

/// Every ordered pair's separation on `campaign` with `records` added (each rival refitted to
/// the other's predictions with every parameter, as [`super::design_next`] does); `nested`
/// here: the rival reproduces the truth on these records.
pub fn evaluate(
    campaign: &Campaign,
    rivals: &[Rival],
    records: &[DesignedRecord],
    opts: &DesignOptions,
) -> Result<Vec<Separation>, DesignError> {
    if !(2..=3).contains(&rivals.len()) {
        return Err(DesignError::ModelCount(rivals.len()));
    }
    let (observations, _) = observe_campaign(campaign, opts.threads);
    zmp_campaign::par::with_threads(opts.threads, || {
        let obs: Vec<&Observation> = observations.iter().collect();
        check(&obs, rivals, opts)?;
        let noise = noise_model(&obs, opts)?;
        let timing = RecordTiming::of(campaign, &obs);
        let blank: Vec<Observation> = records
            .iter()
            .enumerate()
            .map(|(k, r)| {
                let c = Candidate {
                    excited: r.excited,
                    omega: r.omega,
                    amplitude: r.amplitude,
                    operating_point: r.operating_point,
                };
                candidate_observation(&c, &timing, &noise, usize::MAX - k)
            })
            .collect();
        let truths = |r: &Rival, on: &[Observation]| {
            let p = predict_all(&r.spec, on).map_err(|e| model_error(r, e))?;
            Ok::<_, DesignError>(
                on.iter()
                    .zip(&p)
                    .map(|(o, p)| as_truth(o, p))
                    .collect::<Vec<_>>(),
            )
        };
        let mut out = Vec::new();
        for (i, truth) in rivals.iter().enumerate() {
            let on_campaign = truths(truth, &observations)?;
            let on_records = truths(truth, &blank)?;
            for (j, rival) in rivals.iter().enumerate().filter(|(j, _)| *j != i) {
                let failed = || DesignError::Fit {
                    model: rival.label.clone(),
                    truth: truth.label.clone(),
                };
                let pair =
                    start(i, j, &rival.spec, &truth.spec, &on_campaign).ok_or_else(failed)?;
                let set = record_set(&on_campaign, &on_records);
                let full =
                    refit(&pair, &set, on_campaign.len(), Some(&rival.spec)).ok_or_else(failed)?;
                out.push(Separation {
                    truth: i,
                    rival: j,
                    campaign_sigma: pair.campaign.max(0.0).sqrt(),
                    total_sigma: full.total.max(0.0).sqrt(),
                    added_sigma: full.added.max(0.0).sqrt(),
                    nested: full.total < NESTED_CHI2,
                });
            }
        }
        Ok(out)
    })
}
