//! The out-of-sample suite without running a loop: the composition of a 300-draw range (counts
//! per class, seeds stable), the expected cost of a draw, and the scoring of verdicts on
//! synthetic outcomes, the `ambiguous` set and the words describing a residual included.

use std::collections::BTreeMap;
use zmp_indep_sim::{Effect, Scenario};
use zmp_suites::indep::{
    expected_words, markdown, scores, suite, AfterDesign, Case, Class, Composition, LoopVerdict,
    Outcome, ResidualFeature, AMBIGUOUS_PAIRS, OUTSIDE, PAIRS, SINGLES, TRIPLES,
};

/// The held-out range that follows the last one spent (see `tests/blind_independent.rs`).
const HELD_OUT_FIRST_SEED: u64 = 1_260_000;

#[test]
fn a_range_holds_300_draws_in_the_stated_proportions_with_stable_seeds() {
    let c = Composition::RANGE;
    assert_eq!(c.draws(), 300);
    for first in [1, HELD_OUT_FIRST_SEED] {
        let cases = suite(first, &c);
        assert_eq!(cases.len(), 300);
        for (k, case) in cases.iter().enumerate() {
            assert_eq!(case.seed, first + k as u64, "one seed per draw, in order");
            // Every scenario is one the independent simulator draws.
            let s: Scenario = case.scenario.parse().unwrap_or_else(|e| panic!("{e}"));
            s.validate().unwrap();
        }
        let mut by: BTreeMap<String, usize> = BTreeMap::new();
        for case in &cases {
            let key = match &case.class {
                Class::Single(e) => format!("single:{e}"),
                Class::Outside(e) => format!("outside:{e}"),
                Class::Pair => format!("pair {}", case.scenario),
                Class::AmbiguousPair => format!("ambiguous {}", case.scenario),
                Class::Triple => format!("triple {}", case.scenario),
                Class::Clean => "clean".into(),
            };
            *by.entry(key).or_default() += 1;
        }
        for e in SINGLES {
            assert_eq!(by[&format!("single:{e}")], 8, "{e}");
        }
        for (a, b) in PAIRS {
            assert_eq!(by[&format!("pair pair:{a},{b}")], 5, "{a},{b}");
        }
        for (a, b) in AMBIGUOUS_PAIRS {
            assert_eq!(by[&format!("ambiguous pair:{a},{b}")], 12, "{a},{b}");
        }
        for (a, b, d) in TRIPLES {
            assert_eq!(by[&format!("triple triple:{a},{b},{d}")], 6, "{a},{b},{d}");
        }
        assert_eq!(by["clean"], 40);
        for e in OUTSIDE {
            assert_eq!(by[&format!("outside:{e}")], 13, "{e}");
        }
        // Seeds stable: where each class starts.
        let at = |seed: u64| &cases[(seed - first) as usize].scenario;
        assert_eq!(at(first), "single:time_delay");
        assert_eq!(at(first + 9), "single:op_per_channel");
        assert_eq!(at(first + 10), "single:sensor_rezero");
        assert_eq!(at(first + 88), "pair:time_delay,sensor_drift");
        assert_eq!(at(first + 148), "pair:time_delay,backlash");
        assert_eq!(at(first + 149), "pair:coulomb_friction,sensor_lowpass");
        assert_eq!(at(first + 172), "triple:time_delay,backlash,sensor_drift");
        assert_eq!(at(first + 208), "clean");
        assert_eq!(at(first + 248), "outside:second_structural_mode");
        assert_eq!(at(first + 299), "outside:cubic_stiffness");
    }
    // The held-out range is unspent and stays below the next range's seeds.
    let text = std::fs::read_to_string(zmp_suites::history::record_path()).unwrap();
    let spent = zmp_suites::history::parse(&text).unwrap();
    let last = spent.iter().map(|r| r.range).max().unwrap();
    assert!(spent.iter().all(|r| r.range != HELD_OUT_FIRST_SEED));
    assert_eq!(HELD_OUT_FIRST_SEED, last + 10_000, "the next unspent range");
    assert!(
        (c.draws() as u64) <= 10_000,
        "a range fits before the next one"
    );
}

/// Each class's expected cost is the mean wall time of its draws in the development range as
/// measured (`development-unit-times.csv`, written from the complete job of build 77a39f7:
/// every draw of the range, one build), within 5 %; the scenario of every line is the
/// range's own for that seed.
#[test]
fn expected_costs_are_the_development_means() {
    let text = include_str!("../development-unit-times.csv");
    let cases: BTreeMap<String, Case> = suite(1, &Composition::RANGE)
        .into_iter()
        .map(|c| (format!("draw-{}", c.seed), c))
        .collect();
    // Per expected cost (one per class; the singles: those the seed's structure carries, the
    // rest): the measured wall times' sum and count.
    let mut classes: BTreeMap<String, (f64, f64, usize)> = BTreeMap::new();
    let mut lines = 0;
    for line in text.lines().skip(1) {
        // unit,"scenario",wall_s,time_limit_reached (the scenario quoted: it holds commas)
        let (unit, rest) = line.split_once(",\"").unwrap();
        let (scenario, rest) = rest.split_once("\",").unwrap();
        let wall: f64 = rest.split(',').next().unwrap().parse().unwrap();
        let case = &cases[unit];
        assert_eq!(scenario, case.scenario, "{line}");
        let cost = case.expected_cost();
        let e = classes.entry(format!("{cost}")).or_insert((cost, 0.0, 0));
        e.1 += wall;
        e.2 += 1;
        lines += 1;
    }
    assert_eq!(lines, Composition::RANGE.draws());
    assert_eq!(classes.len(), 7, "{classes:?}");
    for (expected, sum, n) in classes.values() {
        let mean = sum / *n as f64;
        assert!(
            (expected / mean - 1.0).abs() < 0.05,
            "expected {expected} s against the mean {mean:.1} s of {n} draws"
        );
    }
    // Every draw of a range has a cost, and the order of the classes is the measured one.
    for c in suite(1, &Composition::RANGE) {
        assert!(c.expected_cost() > 0.0, "{c:?}");
    }
    let cost = |c: Class| c.expected_cost();
    assert!(cost(Class::Clean) < cost(Class::Single("acceleration_saturation".into())));
    assert!(cost(Class::Single("cross_coupling".into())) < cost(Class::Single("backlash".into())));
    assert!(cost(Class::Single("backlash".into())) < cost(Class::Pair));
    assert!(cost(Class::Pair) < cost(Class::Triple));
}

/// A synthetic outcome of `scenario` (class as the suite gives it), hiding `hidden`.
fn outcome(scenario: &str, class: Class, hidden: &[&str], in_catalogue: bool) -> Outcome {
    Outcome {
        case: Case {
            seed: 1,
            scenario: scenario.into(),
            class,
        },
        hidden: hidden.iter().map(|s| s.to_string()).collect(),
        in_catalogue,
        found: Vec::new(),
        explained: true,
        ambiguous_set: None,
        residual: None,
        identified_ratio: 5.0,
        final_ratio: 0.9,
        truth: String::new(),
        seconds: 1.0,
        error: None,
        time_limit_reached: false,
        after_design: None,
    }
}

fn names(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

#[test]
fn an_ambiguous_set_holding_the_truth_counts_for_pairs_and_is_counted_apart() {
    let pair = |found: &[&str], set: Option<Vec<Vec<&str>>>| {
        let mut o = outcome(
            "pair:time_delay,backlash",
            Class::AmbiguousPair,
            &["time_delay", "backlash"],
            true,
        );
        o.found = names(found);
        o.ambiguous_set = set.map(|s| s.iter().map(|x| names(x)).collect());
        o
    };
    // Both found: right, not through a set.
    let both = pair(&["backlash", "time_delay"], None);
    assert!(both.right() && both.false_effects().is_empty() && !both.ambiguous());
    // The play alone, no set: wrong.
    let alone = pair(&["backlash"], None);
    assert!(!alone.right());
    // The play alone, with the truth inside a set of two: right, counted through the set;
    // the set's other structure adds nothing false.
    let set = pair(
        &["backlash"],
        Some(vec![vec!["backlash"], vec!["backlash", "time_delay"]]),
    );
    assert!(set.right() && set.ambiguous() && set.false_effects().is_empty());
    assert_eq!(set.truth_in_set().unwrap(), ["backlash", "time_delay"]);
    // A set of four: too many to count, even with the truth inside.
    let four = pair(
        &["backlash"],
        Some(vec![
            vec!["backlash"],
            vec!["coulomb_friction"],
            vec!["structural_mode"],
            vec!["backlash", "time_delay"],
        ]),
    );
    assert!(!four.right());
    // A set without the truth: wrong, and its first structure's false effect is counted.
    let without = pair(
        &["backlash", "sensor_lowpass"],
        Some(vec![vec!["backlash", "sensor_lowpass"], vec!["backlash"]]),
    );
    assert!(!without.right() && without.false_effects() == ["sensor_lowpass"]);
    // A single is named first or not: a set does not rescue it.
    let mut single = outcome(
        "single:op_per_channel",
        Class::Single("op_per_channel".into()),
        &["operating_point_dependence"],
        true,
    );
    single.found = names(&["sensor_drift"]);
    single.ambiguous_set = Some(vec![
        names(&["sensor_drift"]),
        names(&["operating_point_dependence"]),
    ]);
    assert!(!single.right());
    single.found = names(&["operating_point_dependence"]);
    single.ambiguous_set = None;
    assert!(
        single.right(),
        "the per-channel form is named by its effect's name"
    );
    // The scores: pairs built ambiguous 2 of 5 (both, set), through the set 1, ambiguous 3 of
    // the 6 in-catalogue draws, false effects 1.
    let all = [both, alone, set, four, without, single];
    let s = scores(&all);
    assert_eq!(s.ambiguous_pairs, (2, 5));
    assert_eq!(s.multiples, (2, 5));
    assert_eq!(s.in_set, (1, 5));
    assert_eq!(s.ambiguous, (3, 6));
    assert_eq!(s.false_alarms, (1, 6));
    assert_eq!(s.singles, (1, 1));
    let table = markdown("synthetic", &all);
    // Every rate with its Wilson interval: 2 of 5 is 12-77 %, 1 of 1 21-100 %.
    assert!(table.contains("2/5 (12-77 %)"), "{table}");
    assert!(table.contains("1/1 (21-100 %)"), "{table}");
    assert!(
        table.contains("built ambiguous: pair:time_delay,backlash"),
        "{table}"
    );
}

#[test]
fn the_truth_named_alone_after_the_designed_experiment_is_scored_among_ambiguous_draws() {
    let after = |found: &[&str], set: Option<Vec<Vec<&str>>>, error: Option<&str>| AfterDesign {
        records: 2,
        recording_s: 30.0,
        predicted_sigma: 5.5,
        found: names(found),
        explained: true,
        ambiguous_set: set.map(|s| s.iter().map(|x| names(x)).collect()),
        error: error.map(String::from),
        time_limit_reached: false,
    };
    let draw = |a: Option<AfterDesign>| {
        let mut o = outcome(
            "pair:time_delay,backlash",
            Class::AmbiguousPair,
            &["time_delay", "backlash"],
            true,
        );
        o.found = names(&["backlash"]);
        o.ambiguous_set = Some(vec![
            names(&["backlash"]),
            names(&["backlash", "time_delay"]),
        ]);
        o.after_design = a;
        o
    };
    // The truth named alone (saturation never counts as false).
    let decided = draw(Some(after(
        &["acceleration_saturation", "time_delay", "backlash"],
        None,
        None,
    )));
    assert_eq!(decided.named_alone_after_design(), Some(true));
    assert!(decided.named_alone());
    // Still ambiguous, the play alone, a false effect beside the truth, an error, no design:
    // not named alone.
    let again = draw(Some(after(
        &["backlash"],
        Some(vec![vec!["backlash"], vec!["backlash", "time_delay"]]),
        None,
    )));
    let play = draw(Some(after(&["backlash"], None, None)));
    let extra = draw(Some(after(
        &["backlash", "time_delay", "sensor_drift"],
        None,
        None,
    )));
    let failed = draw(Some(after(&[], None, Some("design-next: no candidate"))));
    let none = draw(None);
    for o in [&again, &play, &extra, &failed, &none] {
        assert_eq!(
            o.named_alone_after_design(),
            Some(false),
            "{:?}",
            o.after_design
        );
        assert!(!o.named_alone());
        // Still right as a pair: the truth inside the first loop's set.
        assert!(o.right());
    }
    // A draw that did not end ambiguous is not scored after a design; it is named alone
    // when the loop named the truth alone.
    let mut direct = draw(None);
    direct.ambiguous_set = None;
    direct.found = names(&["time_delay", "backlash"]);
    assert_eq!(direct.named_alone_after_design(), None);
    assert!(direct.named_alone());
    let s = scores(&[decided, again, play, extra, failed, none, direct]);
    assert_eq!(s.after_design, (1, 6));
    let table = markdown(
        "synthetic",
        &[
            draw(Some(after(&["time_delay", "backlash"], None, None))),
            draw(None),
        ],
    );
    // The row's column: 1 of its 2 ambiguous draws named alone; the rate with its Wilson
    // interval (1 of 2: 9-91 %).
    assert!(table.contains("| 2 | 1/2 |"), "{table}");
    assert!(
        table.contains("named alone after one designed experiment: 1/2 (9-91 %)"),
        "{table}"
    );
}

#[test]
fn outside_draws_are_scored_on_the_verdict_and_then_on_the_words() {
    let outside = |effect: &str, explained: bool, words: Option<Vec<ResidualFeature>>| {
        let mut o = outcome(
            &format!("outside:{effect}"),
            Class::Outside(effect.into()),
            &[effect],
            false,
        );
        o.explained = explained;
        o.residual = words;
        o
    };
    use ResidualFeature::*;
    let described = outside(
        "second_structural_mode",
        false,
        Some(vec![Resonance, Trend]),
    );
    assert!(described.right() && described.words_right() == Some(true));
    let above = outside(
        "second_structural_mode",
        false,
        Some(vec![GrowingWithFrequency]),
    );
    assert_eq!(above.words_right(), Some(true));
    let wrong_words = outside(
        "cubic_stiffness",
        false,
        Some(vec![Trend, AmplitudeDependence]),
    );
    assert!(wrong_words.right() && wrong_words.words_right() == Some(false));
    let silent = outside("stribeck_friction", false, Some(Vec::new()));
    assert_eq!(
        silent.words_right(),
        Some(false),
        "no word is not the right word"
    );
    // Today's loop gives no words: the verdict alone is scored.
    let today = outside("rate_limited_servo", false, None);
    assert!(today.right() && today.words_right().is_none());
    // Explained, or ambiguous, is wrong for an effect outside the catalogue, words unscored.
    let explained = outside("cubic_stiffness", true, Some(vec![AmplitudeDependence]));
    assert!(!explained.right() && explained.words_right().is_none());
    let mut ambiguous = outside("cubic_stiffness", false, None);
    ambiguous.ambiguous_set = Some(vec![names(&["structural_mode"])]);
    assert!(!ambiguous.right());
    let s = scores(&[
        described,
        above,
        wrong_words,
        silent,
        today,
        explained,
        ambiguous,
    ]);
    assert_eq!(s.outside, (5, 7));
    assert_eq!(s.words, (2, 4));
    // The words expected of each outside effect, and none for catalogue effects.
    for e in Effect::OUTSIDE {
        assert!(!expected_words(e).is_empty(), "{e}");
    }
    for e in Effect::CATALOGUE {
        assert!(expected_words(e).is_empty(), "{e}");
    }
    for f in ResidualFeature::ALL {
        assert_eq!(ResidualFeature::parse(f.key()), Some(f));
    }
}

/// Today's loop result gives the effects and the verdict; the set and the words default to
/// none (what a result that cannot end ambiguous says).
#[test]
fn a_verdict_without_set_or_words_defaults_to_none() {
    struct Today;
    impl LoopVerdict for Today {
        fn found(&self) -> Vec<String> {
            vec!["time_delay".into()]
        }
        fn explained(&self) -> bool {
            true
        }
    }
    assert_eq!(Today.found(), ["time_delay"]);
    assert!(Today.explained());
    assert!(Today.ambiguous_set().is_none() && Today.residual_features().is_none());
}
