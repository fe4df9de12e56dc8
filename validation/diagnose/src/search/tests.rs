//! The search's admissibility and ambiguity set on synthetic held-out residuals.

use super::*;
use crate::criterion::{tests::normals, threshold};
use crate::fit::Free;
use crate::structure::Law;
use zmp_models::{Binding, EffectKind};

/// A node whose held-out residuals are `r` (one component per record).
fn node(s: &Structure, r: Vec<f64>) -> Node {
    let spec = ModelSpec::parse(
        include_str!("../../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap();
    // Each effect fitted at 1 +- 0.01: determined.
    let frees: Vec<Free> = s
        .effects()
        .iter()
        .map(|c| Free::new(c.kind, vec![Binding::Global], "value", 1.0, 0.0, 10.0))
        .collect();
    let fit = Fit {
        spec,
        std_err: vec![0.01; frees.len()],
        frees,
        cost: 0.0,
    };
    Node {
        structure: s.clone(),
        folds: [fit.clone(), fit],
        held: HeldOut {
            chi2: r.iter().map(|x| x * x).sum(),
            error: 0.0,
            scores: Vec::new(),
            chi2s: r.iter().map(|x| x * x).collect(),
            residuals: r.into_iter().map(|x| vec![x]).collect(),
            nuisance: 0,
        },
    }
}

fn plus(a: &[f64], b: &[f64], k: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x + k * y).collect()
}

/// Two effects that each remove the same misfit (8 of 108 records off by 6 standard
/// deviations) and part by a third of a standard deviation per record are not separated:
/// the set names both, best first. An effect that removes nothing is not admissible;
/// the pair of the two, which only adds noise to either, is not admissible either. With
/// the two parting by 3 standard deviations on those 8 records, the better one is alone.
#[test]
fn the_set_holds_what_the_records_cannot_separate() {
    let delay = Candidate::new(EffectKind::TimeDelay, Law::Only);
    let lowpass = Candidate::new(EffectKind::SensorLowpass, Law::Only);
    let drift = Candidate::new(EffectKind::SensorDrift, Law::Only);
    let root = Structure::root();
    let (d, l, dr, pair) = (
        root.with(delay),
        root.with(lowpass),
        root.with(drift),
        root.with(delay).with(lowpass),
    );
    let noise = normals(108, 11);
    let miss: Vec<f64> = (0..108)
        .map(|k| if k % 13 == 0 { 6.0 } else { 0.0 })
        .collect();
    let apart = normals(108, 12);
    let set_of = |l_res: Vec<f64>| {
        let mut nodes = BTreeMap::new();
        for (s, r) in [
            (&root, plus(&noise, &miss, 1.0)),
            (&d, noise.clone()),
            (&l, l_res.clone()),
            (&dr, plus(&noise, &miss, 1.0)),
            (&pair, plus(&noise, &apart, 0.5)),
        ] {
            nodes.insert(s.clone(), node(s, r));
        }
        let z = threshold(10);
        let c = mismatch(&nodes);
        let adm = adm_sorted(&nodes, z, c);
        let (set, parted) = ambiguity_set(&nodes, &adm, z, c);
        assert!(parted.is_empty(), "{parted:?}");
        (adm, set)
    };
    let (adm, set) = set_of(plus(&noise, &apart, 0.3));
    assert!(adm.contains(&d) && adm.contains(&l) && adm.contains(&root));
    assert!(!adm.contains(&dr), "an effect that removes nothing");
    assert!(!adm.contains(&pair), "a pair that only adds noise");
    assert_eq!(set.len(), 2, "{set:?}");
    assert!(set.contains(&d) && set.contains(&l));
    // The low-pass misses the 8 records by 3 standard deviations: the delay alone.
    let (_, set) = set_of(plus(&noise, &miss, 0.5));
    assert_eq!(set, vec![d.clone()]);
}

/// Two effects that each remove most of a misfit (8 of 108 records off by 6 standard
/// deviations) but part by 20 standard deviations elsewhere, the records lying halfway
/// between them (each misses by 10 along that direction): they fit about equally, yet were
/// either the truth the other would fit far worse. Not what the records cannot decide
/// between: the set is the better alone, the other parted from it.
#[test]
fn structures_the_records_part_and_fit_equally_are_parted_not_ambiguous() {
    let delay = Candidate::new(EffectKind::TimeDelay, Law::Only);
    let lowpass = Candidate::new(EffectKind::SensorLowpass, Law::Only);
    let root = Structure::root();
    let (d, l) = (root.with(delay), root.with(lowpass));
    let noise = normals(108, 41);
    let miss: Vec<f64> = (0..108)
        .map(|k| if k % 13 == 0 { 6.0 } else { 0.0 })
        .collect();
    let dir = normals(108, 42);
    let norm = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
    let unit: Vec<f64> = dir.iter().map(|x| x / norm).collect();
    let set_of = |half: f64| {
        let mut nodes = BTreeMap::new();
        for (s, r) in [
            (&root, plus(&plus(&noise, &miss, 1.0), &unit, half)),
            (&d, plus(&noise, &unit, half)),
            (&l, plus(&noise, &unit, -half)),
        ] {
            nodes.insert(s.clone(), node(s, r));
        }
        let z = threshold(10);
        let c = mismatch(&nodes);
        let adm = adm_sorted(&nodes, z, c);
        assert!(adm.contains(&d) && adm.contains(&l), "{adm:?}");
        ambiguity_set(&nodes, &adm, z, c)
    };
    let (set, parted) = set_of(10.0);
    assert_eq!(set.len(), 1, "{set:?}");
    assert_eq!(parted.len(), 1, "{parted:?}");
    assert_eq!(parted[0].0, set[0]);
    assert!(parted[0].1 == d || parted[0].1 == l);
    assert_ne!(parted[0].1, set[0]);
    // Parting by 1 standard deviation: the records cannot decide, both in the set.
    let (set, parted) = set_of(0.5);
    assert_eq!(set.len(), 2, "{set:?}");
    assert!(parted.is_empty());
}

/// Two effects that each make the fit worse (8 records missed by 12 standard deviations
/// instead of 6) and together only add noise to the identified model's own: the pair beats
/// each of them, so it is admissible, and the identified model cannot be shown better than
/// it (z about 2.6 against 3.09); but it is not better than the model inside it, so it is
/// no alternative: the set is the identified model alone.
#[test]
fn a_structure_no_better_than_one_inside_it_is_no_alternative() {
    let a = Candidate::new(EffectKind::TimeDelay, Law::Only);
    let b = Candidate::new(EffectKind::SensorDrift, Law::Only);
    let root = Structure::root();
    let (sa, sb, pair) = (root.with(a), root.with(b), root.with(a).with(b));
    let noise = normals(108, 21);
    let miss: Vec<f64> = (0..108)
        .map(|k| if k % 13 == 0 { 6.0 } else { 0.0 })
        .collect();
    let apart = normals(108, 22);
    let mut nodes = BTreeMap::new();
    for (s, r) in [
        (&root, plus(&noise, &miss, 1.0)),
        (&sa, plus(&noise, &miss, 2.0)),
        (&sb, plus(&noise, &miss, 2.0)),
        (&pair, plus(&plus(&noise, &miss, 1.0), &apart, 0.5)),
    ] {
        nodes.insert(s.clone(), node(s, r));
    }
    let z = threshold(10);
    let c = mismatch(&nodes);
    let adm = adm_sorted(&nodes, z, c);
    assert!(adm.contains(&pair), "the pair beats both its parents");
    assert!(!compare(&nodes[&root].held, &nodes[&pair].held, c).better(z));
    assert_eq!(ambiguity_set(&nodes, &adm, z, c), (vec![root], Vec::new()));
}

/// A delay that removes the misfit is admissible while a fold's fit determines it (0.04 +-
/// 0.0004 s: 100 standard errors) and the other's does not (0.001 +- 0.01 s), and not where
/// neither does, however much it gains on held-out records.
#[test]
fn an_effect_the_records_do_not_determine_is_not_admissible() {
    let delay = Candidate::new(EffectKind::TimeDelay, Law::Only);
    let root = Structure::root();
    let d = root.with(delay);
    let noise = normals(108, 31);
    let miss: Vec<f64> = (0..108)
        .map(|k| if k % 13 == 0 { 6.0 } else { 0.0 })
        .collect();
    let mut nodes = BTreeMap::new();
    nodes.insert(root.clone(), node(&root, plus(&noise, &miss, 1.0)));
    nodes.insert(d.clone(), node(&d, noise));
    let z = threshold(10);
    let c = mismatch(&nodes);
    for (f, value, se, expected) in [(1, 0.001, 0.01, true), (0, 0.001, 0.01, false)] {
        let fold = &mut nodes.get_mut(&d).unwrap().folds[f];
        fold.frees[0].bounds.value = value;
        fold.std_err[0] = se;
        assert!(!determined(fold, &delay, z), "{value} +- {se}");
        let folds = &nodes[&d].folds;
        assert_eq!(determined(&folds[1 - f], &delay, z), expected);
        assert_eq!(
            admissible(&nodes, &d, z, c),
            expected,
            "fold {f} undetermined"
        );
    }
}

/// The admissible structures of `nodes`, best first.
fn adm_sorted(nodes: &BTreeMap<Structure, Node>, z: f64, c: f64) -> Vec<Structure> {
    let mut adm: Vec<Structure> = nodes
        .keys()
        .filter(|s| admissible(nodes, s, z, c))
        .cloned()
        .collect();
    adm.sort_by(|a, b| nodes[a].held.chi2.total_cmp(&nodes[b].held.chi2));
    adm
}

/// A play inside the servo is determined by its widths alone: a well-determined drive share
/// (it acts through the transmission even without a play) with a width the records leave at
/// zero is no play; the same width determined is one.
#[test]
fn a_play_is_determined_by_its_width_not_its_drive_share() {
    let play = Candidate::new(EffectKind::Backlash, Law::InServo);
    let spec = ModelSpec::parse(
        include_str!("../../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap();
    let x = vec![Binding::Axis(zmp_models::Axis::X)];
    let fit = |width: f64| Fit {
        spec: spec.clone(),
        frees: vec![
            Free::new(EffectKind::Backlash, x.clone(), "width", width, 0.0, 0.01),
            Free::new(EffectKind::Backlash, x.clone(), "drive", 0.3, 0.01, 0.9),
        ],
        // The share 0.3 +- 0.001 (300 standard errors), the width +- 1e-5 m.
        std_err: vec![1e-5, 0.001],
        cost: 0.0,
    };
    let z = threshold(100);
    assert!(
        !determined(&fit(0.0), &play, z),
        "a zero width with a known share"
    );
    assert!(
        determined(&fit(3e-4), &play, z),
        "a width of 30 standard errors"
    );
}
