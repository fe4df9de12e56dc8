//! What a diagnosis reports: its findings (each effect of the best structure, in the order of
//! its chain, with evidence; the refit; what is left unexplained), the structures the data
//! cannot decide between, and every single candidate tried.

use super::{evidence_of, parameters_of, without};
use crate::cells::{cells, channel_summary, Cell};
use crate::criterion::compare;
use crate::fit::Fit;
use crate::measure::{predict, Prediction};
use crate::observe::Observation;
use crate::profiles::profile;
use crate::search::{Node, Search};
use crate::structure::{Candidate, Structure, Verdict};
use crate::words::{ResidualFeature, Separation};
use serde::Serialize;
use std::collections::BTreeMap;
use zmp_models::{Binding, Channel, ModelSpec, Site};

/// What a finding is about.
#[derive(Debug, Clone, PartialEq)]
pub enum Subject {
    /// An effect of the catalogue the data show.
    Effect(Candidate),
    /// The model's own structure with its parameters refitted.
    Refit,
    /// What no structure of the catalogue removes.
    Unexplained,
}

impl Subject {
    /// Its name in `zmp-diagnosis/1` (`time_delay`, `parameter_refit`, `unexplained`).
    pub fn name(&self) -> &'static str {
        match self {
            Subject::Effect(c) => c.name(),
            Subject::Refit => "parameter_refit",
            Subject::Unexplained => "unexplained",
        }
    }
}

impl std::fmt::Display for Subject {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Subject::Effect(c) => write!(f, "{c}"),
            other => f.write_str(other.name()),
        }
    }
}

impl Serialize for Subject {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// One finding.
#[derive(Debug, Clone, Serialize)]
pub struct Finding {
    /// What the finding is about: an effect, the refit, or what remains unexplained.
    pub effect: Subject,
    /// The effect's law (`on_command`, `in_servo`, ...) and plane, when it has them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub law: Option<&'static str>,
    /// The plane (`x`, `y`) an effect with a plane acts in.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plane: Option<&'static str>,
    /// Output channels the effect changed (for the refit and the rest: every channel).
    pub channels: Vec<String>,
    /// Fitted parameters of the effect by dotted name.
    pub parameters: BTreeMap<String, f64>,
    /// Standard error of each of `parameters`, same names.
    pub std_errors: BTreeMap<String, f64>,
    /// Error of the structure without the effect (the starting model's for the refit).
    pub error_before: f64,
    /// Error of the structure with it.
    pub error_after: f64,
    /// Whether both errors are held-out (false for what remains: its errors are in-sample).
    pub held_out: bool,
    /// Whether it passed the criterion at the diagnosis's level (every reported finding does).
    pub significant: bool,
    /// The evidence in words: what the records show and the criterion's numbers.
    pub evidence: String,
    /// The criterion's statistic against the structure without it (`criterion::compare`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub z: Option<f64>,
    /// Where the error remains after this finding (significant cells, worst first).
    #[serde(rename = "where")]
    pub remaining: Vec<Cell>,
}

/// One structure of the set the data cannot decide between.
#[derive(Debug, Clone, Serialize)]
pub struct Alternative {
    /// The effects' catalogue names, in the structure's order.
    pub effects: Vec<&'static str>,
    /// The effects with their laws and planes in words.
    pub structure: String,
    /// Fitted parameters of its effects by dotted name.
    pub parameters: BTreeMap<String, f64>,
    /// Standard error of each of `parameters`, same names.
    pub std_errors: BTreeMap<String, f64>,
    /// Its held-out error (the diagnosis measure).
    pub held_out_error: f64,
    /// Its held-out chi-square, the score the criterion compares.
    pub held_out_chi2: f64,
    /// The criterion's statistic of the best against it (0 for the best).
    pub z_from_best: f64,
    /// What separates it from the best (the best: from the second).
    pub distinguished: Option<Separation>,
    /// The structure itself, for the report and the loop.
    #[serde(skip)]
    pub typed: Structure,
    /// Fitted on every record.
    #[serde(skip)]
    pub fit: Fit,
}

impl Alternative {
    pub(super) fn of(st: &Structure, fit: &Fit, s: &Search, words: Option<Separation>) -> Self {
        let params: Vec<(String, f64, f64)> = st
            .effects()
            .iter()
            .flat_map(|c| parameters_of(fit, c))
            .collect();
        let node = s.node(st);
        Alternative {
            effects: st.effects().iter().map(|c| c.name()).collect(),
            structure: st.label(),
            parameters: params.iter().map(|p| (p.0.clone(), p.1)).collect(),
            std_errors: params.iter().map(|p| (p.0.clone(), p.2)).collect(),
            held_out_error: node.held.error,
            held_out_chi2: node.held.chi2,
            z_from_best: s.compare(&s.best, st).z,
            distinguished: words,
            typed: st.clone(),
            fit: fit.clone(),
        }
    }
}

/// A structure the records part from a member of the set yet fit about as well: Cox's test
/// centred on each rejects both (`criterion::Comparison::neither`), so it is no alternative
/// the data cannot decide between, and neither is the whole truth.
#[derive(Debug, Clone, Serialize)]
pub struct Parted {
    /// The parted structure's effects, by catalogue name.
    pub effects: Vec<&'static str>,
    /// The parted structure in words (laws and planes).
    pub structure: String,
    /// The member of the set it was compared with, in words.
    pub against: String,
    /// How far apart their held-out predictions are, in noise standard deviations in all.
    pub distance_sigma: f64,
    /// Its held-out chi-square less the member's.
    pub chi2_difference: f64,
    /// The difference either would give were the other the whole truth (`distance^2`).
    pub expected_difference: f64,
    /// Cox's statistic against the member as the whole truth (rejected above the threshold).
    pub z_against_member: f64,
    /// Cox's statistic against the parted structure as the whole truth.
    pub z_against_it: f64,
    /// The same in words.
    pub words: String,
}

impl Parted {
    pub(super) fn of(member: &Structure, st: &Structure, s: &Search) -> Self {
        let cmp = s.compare(member, st);
        let (t_a, t_b) = cmp.centred();
        let expected = cmp.distance * cmp.distance;
        let words = format!(
            "{} predicts the held-out records about as well as {} (held-out chi-square {:+.0}), \
             yet the records part the two by {:.1} noise standard deviations: were either the \
             whole truth, the other would do worse by about {:.0} (give or take {:.0}). Cox's \
             test rejects each (z = {:.1} and {:.1} against {:.2}): neither is the whole \
             truth, both miss something along what parts them, and no new record is needed to \
             tell them apart",
            st.label(),
            member.label(),
            cmp.difference,
            cmp.distance,
            expected,
            cmp.spread,
            -t_a,
            t_b,
            s.z_crit
        );
        Parted {
            effects: st.effects().iter().map(|c| c.name()).collect(),
            structure: st.label(),
            against: member.label(),
            distance_sigma: cmp.distance,
            chi2_difference: cmp.difference,
            expected_difference: expected,
            z_against_member: -t_a,
            z_against_it: t_b,
            words,
        }
    }
}

/// A single candidate as the search scored it.
#[derive(Debug, Clone, Serialize)]
pub struct Tried {
    /// The candidate effect's catalogue name.
    pub effect: &'static str,
    /// The candidate with its law and plane in words.
    pub structure: String,
    /// Held-out error of the model with this candidate alone.
    pub held_out_error: f64,
    /// Its held-out chi-square.
    pub held_out_chi2: f64,
    /// The criterion's statistic against the model's own structure refitted.
    pub z: f64,
}

impl Tried {
    pub(super) fn of(n: &Node, root: &Node, s: &Search) -> Tried {
        Tried {
            effect: n.structure.effects()[0].name(),
            structure: n.structure.label(),
            held_out_error: n.held.error,
            held_out_chi2: n.held.chi2,
            z: compare(&n.held, &root.held, s.mismatch).z,
        }
    }
}

/// What the findings are computed from.
pub(super) struct Context<'a> {
    pub obs: &'a [&'a Observation],
    pub search: &'a Search,
    pub floor: f64,
    pub baseline: f64,
    pub channels: &'a [(String, f64, f64)],
}

impl Context<'_> {
    /// The findings: every effect along the best structure's chain, the refit when it is the
    /// verdict, and what is left when the final model does not explain the data.
    pub fn findings(
        &self,
        chain: &[(Structure, Fit)],
        verdict: &Verdict,
        explained: bool,
        final_error: f64,
        residual: &[ResidualFeature],
    ) -> Vec<Finding> {
        let mut out: Vec<Finding> = chain
            .windows(2)
            .filter_map(|w| self.effect(&w[0].0, &w[1].0, &w[1].1))
            .collect();
        let f = self.floor;
        let root = &self.search.node(&Structure::root()).held;
        if *verdict == Verdict::Refit {
            out.insert(
                0,
                self.plain(
                    Subject::Refit,
                    root.error,
                    format!(
                        "the model's own structure with its parameters refitted explains the \
                         data ({:.1}x -> {:.1}x the noise floor on held-out records): identify \
                         the campaign again rather than add an effect",
                        self.baseline / f,
                        root.error / f
                    ),
                ),
            );
        }
        if !explained && *verdict != Verdict::Refit && *verdict != Verdict::None {
            let named: Vec<String> = out.iter().map(|x| x.effect.to_string()).collect();
            let mut text = if named.is_empty() {
                format!(
                    "an error of {:.1}x the noise floor remains ({:.1}x with the model's own \
                     parameters refitted) that no structure of the catalogue removes \
                     significantly",
                    self.baseline / f,
                    root.error / f
                )
            } else {
                format!(
                    "with {} added, an error of {:.1}x the noise floor remains that no further \
                     catalogue effect removes significantly",
                    named.join(" and "),
                    final_error / f
                )
            };
            if !residual.is_empty() {
                let words: Vec<&str> = residual.iter().map(|r| r.words.as_str()).collect();
                text.push_str(&format!("; what is left: {}", words.join("; ")));
            }
            let at = out.len();
            let mut u = self.plain(Subject::Unexplained, final_error, text);
            u.error_before = final_error;
            u.held_out = false;
            out.insert(at, u);
        }
        out
    }

    fn plain(&self, subject: Subject, after: f64, evidence: String) -> Finding {
        Finding {
            effect: subject,
            law: None,
            plane: None,
            channels: self.channels.iter().map(|c| c.0.clone()).collect(),
            parameters: BTreeMap::new(),
            std_errors: BTreeMap::new(),
            error_before: self.baseline,
            error_after: after,
            held_out: true,
            significant: true,
            evidence,
            z: None,
            remaining: Vec::new(),
        }
    }

    /// The finding of the effect `child` adds to `parent` (as fitted on every record).
    fn effect(&self, parent: &Structure, child: &Structure, fit: &Fit) -> Option<Finding> {
        let c = *child.effects().iter().find(|c| !parent.contains(c))?;
        let (p, n) = (self.search.node(parent), self.search.node(child));
        let cmp = self.search.compare(child, parent);
        let f = self.floor;
        let mut evidence = evidence_of(self.obs, fit, &c, self.search.z_crit);
        evidence.push_str(&format!(
            "; with it the held-out error falls from {:.1}x to {:.1}x the noise floor (held-out \
             chi-square {:.0} -> {:.0}, z = {:.1} against {:.2})",
            p.held.error / f,
            n.held.error / f,
            p.held.chi2,
            n.held.chi2,
            cmp.z,
            self.search.z_crit
        ));
        let before = predict(&without(fit, &c), self.obs).ok()?;
        let after = predict(&fit.spec, self.obs).ok()?;
        let params = parameters_of(fit, &c);
        let laws = profile(c.kind).laws().len() > 1;
        Some(Finding {
            effect: Subject::Effect(c),
            law: laws.then(|| c.law.name()),
            plane: c.plane.map(|a| a.name()),
            channels: channels_changed(self.obs, &before, &after, &c, &fit.spec),
            parameters: params.iter().map(|p| (p.0.clone(), p.1)).collect(),
            std_errors: params.iter().map(|p| (p.0.clone(), p.2)).collect(),
            error_before: p.held.error,
            error_after: n.held.error,
            held_out: true,
            significant: true,
            evidence,
            z: Some(cmp.z),
            remaining: cells(self.obs, &after)
                .into_iter()
                .filter(|c| c.significant)
                .take(8)
                .collect(),
        })
    }
}

/// Channels an effect changed: those whose error fell by at least half of their excess over
/// the floor; else where the effect sits.
fn channels_changed(
    obs: &[&Observation],
    before: &[Prediction],
    after: &[Prediction],
    c: &Candidate,
    spec: &ModelSpec,
) -> Vec<String> {
    let b = channel_summary(obs, before);
    let a = channel_summary(obs, after);
    let mut out: Vec<String> = b
        .iter()
        .zip(&a)
        .filter(|(x, y)| {
            let excess = x.1 * x.1 - x.2 * x.2;
            excess > 0.0 && x.1 * x.1 - y.1 * y.1 > 0.5 * excess
        })
        .map(|(x, _)| x.0.clone())
        .collect();
    if out.is_empty() {
        let kinds = profile(c.kind).model_kinds();
        for e in spec.effects.iter().filter(|e| kinds.contains(&e.info.kind)) {
            if let Binding::Axis(ax) = e.binding {
                for ch in Channel::ALL {
                    let hit = match e.info.site {
                        Site::Sensor => ch.output == ax,
                        _ => ch.input == ax,
                    };
                    if hit && !out.iter().any(|x| x == ch.name()) {
                        out.push(ch.name().to_string());
                    }
                }
            }
        }
        out.sort();
    }
    out
}
