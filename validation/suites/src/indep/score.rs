//! The suite's scores and its table, every rate with its Wilson 95 % interval
//! ([`crate::history::wilson`]).

use super::{Class, Outcome, DRAW_TIME_LIMIT, IN_STRUCTURE, SINGLES};
use crate::history::rate;

/// The suite's scores, each `(right, draws)`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scores {
    /// Single catalogue effects (the diagnosis must add them): named first / draws.
    pub singles: (usize, usize),
    /// Single effects the seed's structure carries: right / draws.
    pub in_structure: (usize, usize),
    /// Pairs and triples (the pairs built ambiguous among them): every hidden effect found,
    /// or the truth inside an ambiguous set / draws.
    pub multiples: (usize, usize),
    /// Pairs alone (not those built ambiguous).
    pub pairs: (usize, usize),
    /// Pairs built to be ambiguous on the standard design.
    pub ambiguous_pairs: (usize, usize),
    /// Pairs and triples right only through the truth inside an ambiguous set / draws.
    pub in_set: (usize, usize),
    /// Clean robots with no false effect / clean draws.
    pub clean: (usize, usize),
    /// Outside effects that end unexplained / draws.
    pub outside: (usize, usize),
    /// Outside effects ending unexplained whose residual is described: the strongest word
    /// right / described draws.
    pub words: (usize, usize),
    /// In-catalogue draws explained within 2x the floor after the loop / draws.
    pub closed: (usize, usize),
    /// The largest final error over the floor among the in-catalogue draws that ended explained.
    pub worst_closed_ratio: f64,
    /// In-catalogue draws with a false effect.
    pub false_alarms: (usize, usize),
    /// In-catalogue draws ending ambiguous.
    pub ambiguous: (usize, usize),
    /// Draws that ended ambiguous: the truth named alone after one designed experiment
    /// ([`Outcome::named_alone_after_design`]) / such draws.
    pub after_design: (usize, usize),
}

fn add(x: &mut (usize, usize), ok: bool) {
    x.1 += 1;
    if ok {
        x.0 += 1;
    }
}

/// The scores of `outcomes` by the rules of [`super`].
pub fn scores(outcomes: &[Outcome]) -> Scores {
    let mut s = Scores::default();
    for o in outcomes {
        let multiple = |s: &mut Scores| {
            add(&mut s.multiples, o.right());
            let all_found = o.must_find().iter().all(|m| o.found.iter().any(|f| f == m));
            add(&mut s.in_set, o.right() && !all_found);
        };
        match &o.case.class {
            Class::Single(_) if !o.must_find().is_empty() => add(&mut s.singles, o.right()),
            Class::Single(_) => add(&mut s.in_structure, o.right()),
            Class::Pair => {
                multiple(&mut s);
                add(&mut s.pairs, o.right());
            }
            Class::AmbiguousPair => {
                multiple(&mut s);
                add(&mut s.ambiguous_pairs, o.right());
            }
            Class::Triple => multiple(&mut s),
            Class::Clean => add(&mut s.clean, o.right()),
            Class::Outside(_) => add(&mut s.outside, o.right()),
        }
        if let Some(ok) = o.words_right() {
            add(&mut s.words, ok);
        }
        if let Some(ok) = o.named_alone_after_design() {
            add(&mut s.after_design, ok);
        }
        if o.in_catalogue {
            add(&mut s.closed, o.closed());
            add(&mut s.false_alarms, !o.false_effects().is_empty());
            add(&mut s.ambiguous, o.ambiguous());
            if o.explained {
                s.worst_closed_ratio = s.worst_closed_ratio.max(o.final_ratio);
            }
        }
    }
    s
}

/// A count with its Wilson interval, `-` for none.
fn pct(x: (usize, usize)) -> String {
    if x.1 == 0 {
        return "-".into();
    }
    rate(Some(x))
}

/// The table's row of an outcome: the hidden effect of a single (by scenario name), else the
/// class.
fn row_of(o: &Outcome) -> String {
    match &o.case.class {
        Class::Single(e) => e.clone(),
        Class::Clean => "clean (saturation only)".into(),
        Class::Pair => "pair".into(),
        Class::AmbiguousPair => format!("built ambiguous: {}", o.case.scenario),
        Class::Triple => "triple".into(),
        Class::Outside(e) => format!("outside: {e}"),
    }
}

/// The table's column of an outcome: the first effect the loop added, or its end when it
/// added none.
fn col_of(o: &Outcome) -> String {
    if o.error.is_some() {
        return "error".into();
    }
    match o.first_named() {
        Some(f) => f.to_string(),
        None if o.ambiguous() => "ambiguous".into(),
        None if o.explained => "none".into(),
        None => "unexplained".into(),
    }
}

/// The confusion table (rows: what was hidden; columns: the first effect the loop added, or
/// its outcome when it added none; `ambig` counts the row's draws that ended ambiguous,
/// `alone after design` those of them whose truth the loop named alone once the designed
/// experiment's records were appended, and `right` the row's right draws with their Wilson
/// interval) and the scores, as markdown.
pub fn markdown(title: &str, outcomes: &[Outcome]) -> String {
    use std::collections::BTreeMap;
    let short = |s: &str| -> String {
        s.split('_')
            .map(|w| w.chars().take(4).collect::<String>())
            .collect::<Vec<_>>()
            .join("_")
    };
    // The columns are the catalogue's names (a form is named by its effect's name).
    let mut cols: Vec<String> = SINGLES
        .iter()
        .filter(|e| !IN_STRUCTURE.contains(e))
        .filter(|e| zmp_indep_sim::Effect::from_name(e).is_some_and(|x| x.catalogue_name() == **e))
        .map(|e| e.to_string())
        .collect();
    cols.extend(["none", "unexplained", "ambiguous", "error"].map(String::from));
    let mut rows: BTreeMap<(usize, String), Vec<&Outcome>> = BTreeMap::new();
    for o in outcomes {
        let order = match &o.case.class {
            Class::Single(e) => SINGLES.iter().position(|s| s == e).unwrap_or(0),
            Class::Clean => 20,
            Class::Pair => 30,
            Class::AmbiguousPair => 31,
            Class::Triple => 32,
            Class::Outside(_) => 40,
        };
        rows.entry((order, row_of(o))).or_default().push(o);
    }
    let mut t = format!("**{title}**\n\n| hidden \\ first added | ");
    t.push_str(
        &cols
            .iter()
            .map(|c| short(c))
            .collect::<Vec<_>>()
            .join(" | "),
    );
    t.push_str(" | ambig | alone after design | right |\n|---");
    t.push_str(&"|---".repeat(cols.len() + 3));
    t.push_str("|\n");
    for ((_, r), row) in &rows {
        t.push_str(&format!("| {r} |"));
        for c in &cols {
            match row.iter().filter(|o| &col_of(o) == c).count() {
                0 => t.push_str(" · |"),
                n => t.push_str(&format!(" {n} |")),
            }
        }
        let ambiguous = row.iter().filter(|o| o.ambiguous()).count();
        let alone = row
            .iter()
            .filter(|o| o.named_alone_after_design() == Some(true))
            .count();
        let alone = if ambiguous == 0 {
            "·".to_string()
        } else {
            format!("{alone}/{ambiguous}")
        };
        let right = row.iter().filter(|o| o.right()).count();
        t.push_str(&format!(
            " {ambiguous} | {alone} | {} |\n",
            pct((right, row.len()))
        ));
    }
    let s = scores(outcomes);
    t.push_str(&format!(
        "\nRates with their Wilson 95 % intervals. Single effects named first: {}. Effects the \
         seed's structure carries (saturation, pendulum-form coupling): {}. Pairs and triples \
         with every effect found or the truth inside an ambiguous set of at most three: {} \
         (pairs {}, pairs built ambiguous {}; through the set {}). Clean robots without a false \
         effect: {}. Outside the catalogue ending unexplained: {}; its residual described \
         right: {}. In-catalogue draws explained within 2x the noise floor after the loop: {} \
         (worst {:.2}x); with a false effect: {}; ending ambiguous: {}. Of the draws that \
         ended ambiguous, the truth named alone after one designed experiment: {}.\n",
        pct(s.singles),
        pct(s.in_structure),
        pct(s.multiples),
        pct(s.pairs),
        pct(s.ambiguous_pairs),
        pct(s.in_set),
        pct(s.clean),
        pct(s.outside),
        pct(s.words),
        pct(s.closed),
        s.worst_closed_ratio,
        pct(s.false_alarms),
        pct(s.ambiguous),
        pct(s.after_design),
    ));
    let limited: Vec<String> = outcomes
        .iter()
        .filter(|o| o.time_limit_reached)
        .map(|o| o.case.seed.to_string())
        .collect();
    if !limited.is_empty() {
        t.push_str(&format!(
            "Draws whose loop reached the {} s time limit (scored on the model reached): {} \
             ({}).\n",
            DRAW_TIME_LIMIT.as_secs(),
            limited.len(),
            limited.join(", ")
        ));
    }
    t
}
