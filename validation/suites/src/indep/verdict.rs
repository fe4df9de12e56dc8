//! What the suite reads from a loop's result: the effects it added, whether it ended
//! explained, and, once the diagnosis gives them, an `ambiguous` set and the words describing
//! an unexplained residual ([`LoopVerdict`]); and what a drawn effect outside the catalogue
//! should be described as ([`expected_words`]).

use zmp_diagnose::iterate::{LoopResult, Outcome};
use zmp_indep_sim::Effect;

/// The most structures an `ambiguous` verdict may name and still count: a set larger than this
/// says little about the robot.
pub const MAX_SET: usize = 3;

/// How a loop ended, as the suite scores it: the effects it added, whether it explains the
/// records, the set it could not decide between, and the words for what is left.
pub trait LoopVerdict {
    /// The effects the loop added to the identified model (those of its best structure), by
    /// catalogue name, in order.
    fn found(&self) -> Vec<String>;
    /// Whether the last model explains the records.
    fn explained(&self) -> bool;
    /// When the records do not decide between structures: each structure of the set (its
    /// effects' catalogue names), best first. `None` otherwise.
    fn ambiguous_set(&self) -> Option<Vec<Vec<String>>> {
        None
    }
    /// When the loop ends unexplained and describes what is left: the residual's features,
    /// strongest first. `None` when it does not describe it.
    fn residual_features(&self) -> Option<Vec<ResidualFeature>> {
        None
    }
}

impl LoopVerdict for LoopResult {
    fn found(&self) -> Vec<String> {
        self.found.clone()
    }
    fn explained(&self) -> bool {
        self.explained
    }
    fn ambiguous_set(&self) -> Option<Vec<Vec<String>>> {
        (self.outcome == Outcome::Ambiguous).then(|| self.set.clone())
    }
    fn residual_features(&self) -> Option<Vec<ResidualFeature>> {
        if self.explained {
            return None;
        }
        let last = self.diagnoses.last()?;
        let features: Vec<ResidualFeature> = last
            .residual
            .iter()
            .filter_map(|f| ResidualFeature::parse(f.feature))
            .collect();
        (!features.is_empty()).then_some(features)
    }
}

/// A feature of an unexplained residual, as the words describing it name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum ResidualFeature {
    /// The large sines answer otherwise than the small ones (stiffening, softening, clipping).
    AmplitudeDependence,
    /// A peak of the misfit near one frequency.
    Resonance,
    /// A misfit that grows with frequency.
    GrowingWithFrequency,
    /// A trend in the records, common or record by record.
    Trend,
    /// Odd harmonics that grow with the amplitude.
    OddHarmonics,
    /// A gain that moves with the operating point.
    OperatingPoint,
}

impl ResidualFeature {
    /// Every feature.
    pub const ALL: [ResidualFeature; 6] = [
        ResidualFeature::AmplitudeDependence,
        ResidualFeature::Resonance,
        ResidualFeature::GrowingWithFrequency,
        ResidualFeature::Trend,
        ResidualFeature::OddHarmonics,
        ResidualFeature::OperatingPoint,
    ];

    /// Its key in the diagnosis's words (`amplitude_dependence`, ...).
    pub const fn key(self) -> &'static str {
        match self {
            ResidualFeature::AmplitudeDependence => "amplitude_dependence",
            ResidualFeature::Resonance => "resonance",
            ResidualFeature::GrowingWithFrequency => "growing_with_frequency",
            ResidualFeature::Trend => "trend",
            ResidualFeature::OddHarmonics => "odd_harmonics",
            ResidualFeature::OperatingPoint => "operating_point",
        }
    }

    /// The feature of a key.
    pub fn parse(key: &str) -> Option<ResidualFeature> {
        ResidualFeature::ALL.into_iter().find(|f| f.key() == key)
    }
}

/// The features the residual of a drawn effect outside the catalogue shows, once the closest
/// catalogue model has taken what it can: the words that describe it right.
///
/// - `second_structural_mode`: a second mode at 1.5-2.5 times the first (15-62 rad/s): a
///   resonance where it lies inside the sweep, a misfit growing with frequency toward it
///   where it lies above.
/// - `stribeck_friction`: a static level 1.5-3 times the kinetic one, which no Coulomb level
///   fits at both amplitudes: the small sines stick more than the large ones, and the
///   stick-slip's odd harmonics grow with the amplitude.
/// - `rate_limited_servo`: the velocity limit cuts the large, fast records and leaves the
///   others: a gain that falls with amplitude, and the clipped velocity's odd harmonics.
/// - `cubic_stiffness`: a transmission that stiffens with its deflection: the large sines see
///   a stiffer, faster trunk, and the spring's cubic term makes odd harmonics.
///
/// Catalogue effects and their forms have none (they are named, not described).
pub fn expected_words(effect: Effect) -> &'static [ResidualFeature] {
    use ResidualFeature::*;
    match effect {
        Effect::SecondStructuralMode => &[Resonance, GrowingWithFrequency],
        Effect::StribeckFriction => &[AmplitudeDependence, OddHarmonics],
        Effect::RateLimitedServo => &[AmplitudeDependence, OddHarmonics],
        Effect::CubicStiffness => &[AmplitudeDependence, OddHarmonics],
        _ => &[],
    }
}
