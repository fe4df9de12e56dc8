//! What the diagnosis searches over, as types: an effect of the catalogue under one of its
//! laws ([`Candidate`]), a model structure (the identified model plus a set of candidates,
//! [`Structure`]) and what a diagnosis concludes ([`Verdict`]). Names on disk (`zmp-diagnosis/1`
//! JSON, model files) come from [`EffectKind::name`] and the profiles; nothing inside the crate
//! matches on strings.

use crate::profiles::profile;
use serde::Serialize;
use std::fmt;
use zmp_models::{Axis, EffectKind};

/// How an effect acts, where a kind has more than one way to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Law {
    /// The one law the kind has (each excited axis with its own parameters).
    Only,
    /// Before the servo, on the CoM command (a play the command must cross).
    OnCommand,
    /// Inside the servo's loop: a play between drive and trunk, or a flexible trunk link the
    /// servo drives (where the force limit clamps, the limited force moves the drive first).
    InServo,
    /// A mode filtering the ZMP path, outside the servo's loop.
    OnZmpPath,
    /// The pendulum's coupling terms a model leaves at zero (`cross_coupling`).
    Coupling,
    /// Each channel `G_ij` with slopes of its own (an operating-point dependence): the
    /// common law is the case of equal slopes.
    PerChannel,
    /// Each record with a value of its own (a ZMP sensor re-zeroed at every record, drifting
    /// at a rate that changes from record to record): the one rate is the case of equal rates.
    PerRecord,
}

impl Law {
    /// The law's name in words and JSON (`on_command`, `in_servo`, ...).
    pub const fn name(self) -> &'static str {
        match self {
            Law::Only => "only",
            Law::OnCommand => "on_command",
            Law::InServo => "in_servo",
            Law::OnZmpPath => "on_zmp_path",
            Law::Coupling => "coupling",
            Law::PerChannel => "per_channel",
            Law::PerRecord => "per_record",
        }
    }

    /// Whether this law holds `other` of the same kind as a special case (per-channel slopes
    /// hold the common ones: every channel the same slope; per-record rates the one rate).
    pub const fn generalizes(self, other: Law) -> bool {
        matches!(
            (self, other),
            (Law::PerChannel, Law::Only) | (Law::PerRecord, Law::Only)
        )
    }
}

/// One effect the search can add: a catalogue kind under one of its laws, on one plane for
/// kinds whose absence is no parameter value (a structural mode: a trunk plane rings or not;
/// every other kind sits on every excited axis with its own parameters, absent at zero).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Candidate {
    /// The catalogue kind of the effect.
    pub kind: EffectKind,
    /// The law it follows (where in the loop it acts).
    pub law: Law,
    /// The plane of a structural mode; `None` for kinds on every excited axis.
    pub plane: Option<Axis>,
}

impl Candidate {
    /// A candidate on every excited axis.
    pub const fn new(kind: EffectKind, law: Law) -> Candidate {
        Candidate {
            kind,
            law,
            plane: None,
        }
    }

    /// A candidate on one plane (a structural mode).
    pub const fn on(kind: EffectKind, law: Law, plane: Axis) -> Candidate {
        Candidate {
            kind,
            law,
            plane: Some(plane),
        }
    }

    /// The catalogue name (`zmp-diagnosis/1`): the kind's, or its profile's own
    /// (`cross_coupling`).
    pub fn name(&self) -> &'static str {
        profile(self.kind).name()
    }

    /// Name, law and plane: `structural_mode (in_servo, x)`.
    pub fn label(&self) -> String {
        let mut parts: Vec<&str> = Vec::new();
        if profile(self.kind).laws().len() > 1 {
            parts.push(self.law.name());
        }
        if let Some(p) = self.plane {
            parts.push(p.name());
        }
        if parts.is_empty() {
            self.name().to_string()
        } else {
            format!("{} ({})", self.name(), parts.join(", "))
        }
    }
}

impl fmt::Display for Candidate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.label())
    }
}

/// A model structure: the identified model's own (the root, no candidate) plus candidates,
/// kept sorted so that one set of effects is one structure whatever the order it was reached
/// in.
#[derive(Debug, Clone, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Structure(Vec<Candidate>);

impl Structure {
    /// The identified model's own structure: no candidate added.
    pub fn root() -> Structure {
        Structure(Vec::new())
    }

    /// Its candidates, sorted.
    pub fn effects(&self) -> &[Candidate] {
        &self.0
    }

    /// How many candidates it adds to the root.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether it is the root.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// This structure with `c` added (sorted).
    pub fn with(&self, c: Candidate) -> Structure {
        let mut v = self.0.clone();
        v.push(c);
        v.sort();
        Structure(v)
    }

    /// This structure without `c`.
    pub fn without(&self, c: &Candidate) -> Structure {
        Structure(self.0.iter().filter(|x| *x != c).copied().collect())
    }

    /// Whether `t` is a smaller structure inside this one: another structure whose every
    /// effect is one of this one's, or one of this one's laws holds it as a special case (the
    /// same kind and plane). What parsimony compares a structure with.
    pub fn holds(&self, t: &Structure) -> bool {
        t != self
            && t.len() <= self.len()
            && t.effects().iter().all(|c| {
                self.0.iter().any(|s| {
                    s == c || (s.kind == c.kind && s.plane == c.plane && s.law.generalizes(c.law))
                })
            })
    }

    /// Whether `c` is one of its candidates.
    pub fn contains(&self, c: &Candidate) -> bool {
        self.0.contains(c)
    }

    /// Whether `c` can join this structure: not there yet, one law per kind (a play is on the
    /// command or inside the servo, the trunk's modes follow one law), one mode per plane.
    pub fn admits(&self, c: &Candidate) -> bool {
        !self
            .0
            .iter()
            .any(|x| x.kind == c.kind && (x.law != c.law || x.plane == c.plane))
    }

    /// The catalogue kinds it names, sorted, each once: what an explanation is made of (two
    /// laws of one kind are one explanation of the data).
    pub fn kinds(&self) -> Vec<&'static str> {
        let mut v: Vec<&'static str> = self.0.iter().map(|c| c.name()).collect();
        v.sort();
        v.dedup();
        v
    }

    /// `identified`, or the labels joined with ` + `.
    pub fn label(&self) -> String {
        if self.0.is_empty() {
            return "identified".into();
        }
        self.0
            .iter()
            .map(|c| c.label())
            .collect::<Vec<_>>()
            .join(" + ")
    }
}

impl fmt::Display for Structure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.label())
    }
}

/// What a diagnosis concludes.
#[derive(Debug, Clone, PartialEq)]
pub enum Verdict {
    /// The model as given explains the data.
    None,
    /// The model's own structure, its parameters refitted, explains the data.
    Refit,
    /// A significant error remains that no structure of the catalogue removes.
    Unexplained,
    /// Several structures explain the data and the records do not separate them (best first).
    Ambiguous(Vec<Structure>),
    /// One structure explains the data best and significantly: its first effect.
    Effect(Candidate),
}

impl Verdict {
    /// The verdict's name in `zmp-diagnosis/1`: `none`, `parameter_refit`, `unexplained`,
    /// `ambiguous` or the effect's catalogue name.
    pub fn name(&self) -> &'static str {
        match self {
            Verdict::None => "none",
            Verdict::Refit => "parameter_refit",
            Verdict::Unexplained => "unexplained",
            Verdict::Ambiguous(_) => "ambiguous",
            Verdict::Effect(c) => c.name(),
        }
    }
}

impl Serialize for Verdict {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Per-channel slopes hold the common ones (and what the common ones are added to); the
    /// common ones hold neither, and no structure holds itself.
    #[test]
    fn a_per_channel_law_holds_the_common_law() {
        let op = EffectKind::OperatingPointDependence;
        let common = Structure::root().with(Candidate::new(op, Law::Only));
        let channel = Structure::root().with(Candidate::new(op, Law::PerChannel));
        let delay = Candidate::new(EffectKind::TimeDelay, Law::Only);
        assert!(channel.holds(&common));
        assert!(channel.with(delay).holds(&common));
        assert!(channel.with(delay).holds(&common.with(delay)));
        assert!(channel.holds(&Structure::root()));
        assert!(!common.holds(&channel));
        assert!(!channel.holds(&channel));
        assert!(!channel.holds(&common.with(delay)));
    }

    #[test]
    fn a_structure_is_its_set_of_effects_whatever_the_order() {
        let delay = Candidate::new(EffectKind::TimeDelay, Law::Only);
        let play = Candidate::new(EffectKind::Backlash, Law::OnCommand);
        let a = Structure::root().with(delay).with(play);
        let b = Structure::root().with(play).with(delay);
        assert_eq!(a, b);
        assert_eq!(a.without(&play), Structure::root().with(delay));
        assert_eq!(a.kinds(), vec!["backlash", "time_delay"]);
        // One law per kind; one mode per plane, on both planes under one law.
        assert!(!a.admits(&Candidate::new(EffectKind::Backlash, Law::InServo)));
        assert!(!a.admits(&delay));
        let mx = Candidate::on(EffectKind::StructuralMode, Law::InServo, Axis::X);
        let my = Candidate::on(EffectKind::StructuralMode, Law::InServo, Axis::Y);
        let my_path = Candidate::on(EffectKind::StructuralMode, Law::OnZmpPath, Axis::Y);
        let m = a.with(mx);
        assert!(m.admits(&my) && !m.admits(&mx) && !m.admits(&my_path));
        assert_eq!(m.with(my).kinds().len(), 3);
        assert_eq!(
            mx.label(),
            "structural_mode (in_servo, x)",
            "the law and plane in words"
        );
        assert_eq!(delay.label(), "time_delay");
    }

    #[test]
    fn verdicts_keep_their_json_names() {
        let v = [
            (Verdict::None, "none"),
            (Verdict::Refit, "parameter_refit"),
            (Verdict::Unexplained, "unexplained"),
            (Verdict::Ambiguous(Vec::new()), "ambiguous"),
            (
                Verdict::Effect(Candidate::new(EffectKind::Pendulum, Law::Coupling)),
                "cross_coupling",
            ),
        ];
        for (verdict, name) in v {
            assert_eq!(serde_json::to_value(&verdict).unwrap(), name);
        }
    }
}
