//! The blind suite: campaigns drawn from seeds with hidden effects (every catalogued effect,
//! pairs, and none), a model identified from each, and the diagnosis must name what is hidden.
//! Prints the confusion matrix (markdown) and writes it to the test's temporary folder.

use std::collections::BTreeMap;
use zmp_campaign::par::parallel_map;
use zmp_suites::blind::{run, suite, Outcome, EFFECTS};

const PER_EFFECT: usize = 4;
const PAIRS: usize = 6;
const CLEAN: usize = 8;

fn matrix(outcomes: &[Outcome]) -> String {
    let mut cols: Vec<String> = EFFECTS.iter().map(|e| e.to_string()).collect();
    cols.extend(["none".into(), "unexplained".into(), "other".into()]);
    let mut rows: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for o in outcomes.iter().filter(|o| o.draw.effects.len() <= 1) {
        let truth = o.draw.effects.first().cloned().unwrap_or("none".into());
        let said = if cols.contains(&o.verdict) {
            o.verdict.clone()
        } else {
            "other".into()
        };
        *rows.entry(truth).or_default().entry(said).or_default() += 1;
    }
    let short = |s: &str| -> String {
        s.split('_')
            .map(|w| w.chars().take(4).collect::<String>())
            .collect::<Vec<_>>()
            .join("_")
    };
    let mut t = String::from("| hidden \\ verdict |");
    for c in &cols {
        t.push_str(&format!(" {} |", short(c)));
    }
    t.push('\n');
    t.push_str(&"|---".repeat(cols.len() + 1));
    t.push_str("|\n");
    let mut order: Vec<String> = EFFECTS.iter().map(|e| e.to_string()).collect();
    order.push("none".into());
    for r in order {
        let Some(row) = rows.get(&r) else { continue };
        t.push_str(&format!("| {r} |"));
        for c in &cols {
            match row.get(c) {
                Some(n) => t.push_str(&format!(" {n} |")),
                None => t.push_str(" · |"),
            }
        }
        t.push('\n');
    }
    t
}

#[test]
#[ignore = "long: 58 loops, over 20 minutes on 2 cores since the one search; `cargo xtask ci --long` runs it"]
fn blind_suite_names_the_hidden_effects() {
    let draws = suite(1000, PER_EFFECT, PAIRS, CLEAN);
    assert!(draws.len() >= 40);
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    // Draws in parallel, each on one thread.
    let outcomes: Vec<Outcome> = parallel_map(draws.len(), threads, |k| {
        let d = draws[k].clone();
        let desc = d.description.clone();
        let effects = d.effects.clone();
        run(d, 1).unwrap_or_else(|e| panic!("draw {effects:?} ({desc}): {e:#}"))
    });
    for o in &outcomes {
        println!(
            "{:<45} -> {:<28} selected {:?}; error {:.4} floor {:.4}{}  [{}]",
            format!("{:?}", o.draw.effects),
            o.verdict,
            o.selected,
            o.baseline_error,
            o.noise_floor,
            o.error_after_adding.map_or(String::new(), |e| format!(
                ", after adding {:.2}x floor",
                e / o.noise_floor
            )),
            o.draw.description
        );
    }
    let singles: Vec<&Outcome> = outcomes
        .iter()
        .filter(|o| o.draw.effects.len() == 1)
        .collect();
    let named = singles
        .iter()
        .filter(|o| o.verdict == o.draw.effects[0])
        .count();
    let clean: Vec<&Outcome> = outcomes
        .iter()
        .filter(|o| o.draw.effects.is_empty())
        .collect();
    let alarms = clean.iter().filter(|o| o.verdict != "none").count();
    let pairs: Vec<&Outcome> = outcomes
        .iter()
        .filter(|o| o.draw.effects.len() == 2)
        .collect();
    let both = pairs
        .iter()
        .filter(|o| o.draw.effects.iter().all(|e| o.selected.contains(e)))
        .count();
    let first_of_pair = pairs
        .iter()
        .filter(|o| o.draw.effects.contains(&o.verdict))
        .count();
    let after: Vec<f64> = singles
        .iter()
        .filter_map(|o| o.error_after_adding.map(|e| e / o.noise_floor))
        .collect();
    let within = after.iter().filter(|r| **r <= 2.0).count();
    let table = matrix(&outcomes);
    let summary = format!(
        "{table}\nSingle effects named first: {named}/{} ({:.0} %). Clean campaigns with a false \
         alarm: {alarms}/{} ({:.0} %). Pairs: both effects found in {both}/{}, one of the two \
         named first in {first_of_pair}/{}. After adding the named effect: error within 2x the \
         noise floor in {within}/{} (worst {:.2}x).\n",
        singles.len(),
        100.0 * named as f64 / singles.len() as f64,
        clean.len(),
        100.0 * alarms as f64 / clean.len() as f64,
        pairs.len(),
        pairs.len(),
        after.len(),
        after.iter().copied().fold(0.0, f64::max),
    );
    println!("{summary}");
    zmp_files::sections::check_page("docs/src/suites.md", "blind-insample", &summary);
    assert!(
        named as f64 >= 0.9 * singles.len() as f64,
        "single effects named first: {named}/{}",
        singles.len()
    );
    assert!(
        alarms as f64 <= 0.05 * clean.len() as f64,
        "false alarms on clean data: {alarms}/{}",
        clean.len()
    );
    assert_eq!(
        within,
        after.len(),
        "error after adding the effect: {after:?}"
    );
    assert!(
        first_of_pair == pairs.len(),
        "pairs: {first_of_pair}/{}",
        pairs.len()
    );
    assert!(
        2 * both >= pairs.len(),
        "pairs with both effects found: {both}/{}",
        pairs.len()
    );
}
