//! The held-out record: one row per held-out range of the out-of-sample suite, each range run
//! once (`validation/suites/held-out-ranges.csv`), and the book's table generated from it
//! (`docs/src/held-out-history.md`), with a Wilson 95 % interval on every rate: a range of 12
//! pairs cannot tell 70 % from 90 %, and the table says so.

use std::path::{Path, PathBuf};

/// The record file, from the repository root.
pub const RECORD: &str = "validation/suites/held-out-ranges.csv";

/// The columns of the record, in order.
pub const COLUMNS: [&str; 16] = [
    "range",
    "date",
    "code",
    "singles",
    "carried",
    "pairs",
    "triples",
    "clean",
    "outside",
    "closed",
    "false",
    "ambiguous",
    "words",
    "after_design",
    "minutes",
    "note",
];

/// A count `right / total`.
pub type Count = Option<(usize, usize)>;

/// One held-out range as recorded: what its run gave.
#[derive(Debug, Clone, PartialEq)]
pub struct RangeRow {
    /// First seed of the range.
    pub range: u64,
    /// The day it was recorded (YYYY-MM-DD).
    pub date: String,
    /// The commit whose code ran it (empty when not recorded).
    pub code: String,
    /// Draws with a lone catalogue effect hidden: named first.
    pub singles: Count,
    /// Effects the seed's structure carries (saturation, pendulum-form coupling).
    pub carried: Count,
    /// Draws with two catalogue effects hidden: both added.
    pub pairs: Count,
    /// Draws with three catalogue effects hidden: all three added.
    pub triples: Count,
    /// Draws without a hidden effect: no false effect added.
    pub clean: Count,
    /// Draws with an effect outside the catalogue: ended `unexplained`.
    pub outside: Count,
    /// In-catalogue draws explained within 2x their noise floor after the loop.
    pub closed: Count,
    /// In-catalogue draws with a false effect (a count of failures, not of successes).
    pub false_effects: Count,
    /// In-catalogue draws ending `ambiguous` (a count of such ends; blank before the
    /// diagnosis could end so).
    pub ambiguous: Count,
    /// Outside draws whose residual was described: described right (blank before the
    /// diagnosis described it).
    pub words: Count,
    /// Draws that ended `ambiguous`: the truth named alone after one designed experiment
    /// (blank before the suite ran the designed experiment).
    pub after_design: Count,
    /// Wall time of the run, minutes.
    pub minutes: Option<f64>,
    /// Free text: why a range was spent without a table, what changed (commas as `;`).
    pub note: String,
}

/// The record's path from this crate.
pub fn record_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("held-out-ranges.csv")
}

fn count(field: &str, line: usize, name: &str) -> Result<Count, String> {
    if field.is_empty() {
        return Ok(None);
    }
    let bad = || format!("{RECORD}:{line}: column `{name}`: expected right/total, got {field:?}");
    let (a, b) = field.split_once('/').ok_or_else(bad)?;
    let (a, b): (usize, usize) = (a.parse().map_err(|_| bad())?, b.parse().map_err(|_| bad())?);
    if a > b {
        return Err(bad());
    }
    Ok(Some((a, b)))
}

fn fmt_count(c: Count) -> String {
    c.map(|(a, b)| format!("{a}/{b}")).unwrap_or_default()
}

/// Parses the record (lines starting with `#` are comments; the first other line is the
/// header, which must be [`COLUMNS`]). Errors name the line and the column.
pub fn parse(text: &str) -> Result<Vec<RangeRow>, String> {
    let mut rows = Vec::new();
    let mut header = false;
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        if raw.starts_with('#') || raw.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = raw.splitn(COLUMNS.len(), ',').collect();
        if !header {
            if f != COLUMNS {
                return Err(format!(
                    "{RECORD}:{line}: header must be {}",
                    COLUMNS.join(",")
                ));
            }
            header = true;
            continue;
        }
        if f.len() != COLUMNS.len() {
            return Err(format!(
                "{RECORD}:{line}: {} columns, expected {}",
                f.len(),
                COLUMNS.len()
            ));
        }
        let c = |i: usize| count(f[i], line, COLUMNS[i]);
        rows.push(RangeRow {
            range: f[0]
                .parse()
                .map_err(|_| format!("{RECORD}:{line}: column `range`: {:?}", f[0]))?,
            date: f[1].to_string(),
            code: f[2].to_string(),
            singles: c(3)?,
            carried: c(4)?,
            pairs: c(5)?,
            triples: c(6)?,
            clean: c(7)?,
            outside: c(8)?,
            closed: c(9)?,
            false_effects: c(10)?,
            ambiguous: c(11)?,
            words: c(12)?,
            after_design: c(13)?,
            minutes: if f[14].is_empty() {
                None
            } else {
                Some(
                    f[14]
                        .parse()
                        .map_err(|_| format!("{RECORD}:{line}: column `minutes`: {:?}", f[14]))?,
                )
            },
            note: f[15].to_string(),
        });
    }
    Ok(rows)
}

/// The record line of `row` (commas in the note become semicolons).
pub fn line(row: &RangeRow) -> String {
    [
        row.range.to_string(),
        row.date.clone(),
        row.code.clone(),
        fmt_count(row.singles),
        fmt_count(row.carried),
        fmt_count(row.pairs),
        fmt_count(row.triples),
        fmt_count(row.clean),
        fmt_count(row.outside),
        fmt_count(row.closed),
        fmt_count(row.false_effects),
        fmt_count(row.ambiguous),
        fmt_count(row.words),
        fmt_count(row.after_design),
        row.minutes.map(|m| format!("{m:.1}")).unwrap_or_default(),
        row.note.replace(',', ";"),
    ]
    .join(",")
}

/// The Wilson score interval of `k` successes in `n` trials at 95 % (z = 1.96): the interval
/// that keeps its coverage for small `n` and rates near 0 or 1, where `p ± z sqrt(p(1-p)/n)`
/// does not. `(0, 1)` for `n = 0`.
pub fn wilson(k: usize, n: usize) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z = 1.959_963_984_540_054_f64;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    ((centre - half).max(0.0), (centre + half).min(1.0))
}

/// `k/n (lo-hi %)` with the Wilson interval.
pub fn rate(c: Count) -> String {
    match c {
        None => "".into(),
        Some((k, n)) => {
            let (lo, hi) = wilson(k, n);
            format!("{k}/{n} ({:.0}-{:.0} %)", 100.0 * lo, 100.0 * hi)
        }
    }
}

/// The book's table: a row per range, newest first, each rate with its Wilson interval.
pub fn render(rows: &[RangeRow]) -> String {
    let mut rows: Vec<&RangeRow> = rows.iter().collect();
    rows.sort_by_key(|r| std::cmp::Reverse(r.range));
    let mut t = String::from(
        "| range | date | code | singles named | carried | pairs found | triples | clean | \
         outside unexplained | closed within 2x | false effect | ambiguous | words right | \
         alone after design | minutes | note |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        t.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.range,
            r.date,
            if r.code.is_empty() {
                "·".into()
            } else {
                format!("`{}`", r.code)
            },
            rate(r.singles),
            fmt_count(r.carried),
            rate(r.pairs),
            fmt_count(r.triples),
            fmt_count(r.clean),
            rate(r.outside),
            fmt_count(r.closed),
            fmt_count(r.false_effects),
            fmt_count(r.ambiguous),
            rate(r.words),
            rate(r.after_design),
            r.minutes.map(|m| format!("{m:.1}")).unwrap_or_default(),
            r.note,
        ));
    }
    t
}

/// Appends `row` to the record (rewritten atomically); a range already recorded is an error:
/// a held-out range is run once.
pub fn append(row: &RangeRow) -> Result<(), String> {
    let path = record_path();
    let text = zmp_files::read_limited_text(&path, zmp_files::limits::MODEL_BYTES, "a record")
        .map_err(|e| format!("{RECORD}: {e}"))?;
    if parse(&text)?.iter().any(|r| r.range == row.range) {
        return Err(format!("{RECORD}: range {} is recorded already", row.range));
    }
    let mut text = text;
    if !text.ends_with('\n') {
        text.push('\n');
    }
    text.push_str(&line(row));
    text.push('\n');
    zmp_files::write_file(&path, zmp_files::Kind::HeldOutRanges, text.as_bytes(), true)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wilson_matches_hand_values() {
        // 8/12: p = 0.6667, z^2 = 3.8415; centre = (0.6667 + 0.16006)/1.32012 = 0.62626,
        // half = 1.95996/1.32012 * sqrt(0.018519 + 0.0066691) = 0.23568.
        let (lo, hi) = wilson(8, 12);
        assert!(
            (lo - 0.3906).abs() < 5e-4 && (hi - 0.8619).abs() < 5e-4,
            "{lo} {hi}"
        );
        // All right on 21: the lower bound is n/(n + z^2) = 0.8454.
        let (lo, hi) = wilson(21, 21);
        assert!(
            (lo - 21.0 / (21.0 + 3.8415)).abs() < 1e-4 && hi == 1.0,
            "{lo} {hi}"
        );
        assert_eq!(wilson(0, 0), (0.0, 1.0));
    }

    #[test]
    fn a_line_reads_back_and_bad_counts_name_line_and_column() {
        let header = COLUMNS.join(",");
        let text = format!("# c\n{header}\n1250000,2026-11-29,8ea5e78,21/21,6/6,8/12,2/3,10/10,5/8,52/52,5/52,,,3/4,23.0,\n");
        let rows = parse(&text).unwrap();
        assert_eq!(rows.len(), 1);
        assert_eq!(rows[0].pairs, Some((8, 12)));
        assert_eq!(rows[0].after_design, Some((3, 4)));
        assert_eq!(line(&rows[0]), text.lines().nth(2).unwrap());
        let bad = format!("{header}\n1,d,c,9/8,,,,,,,,,,,,\n");
        let e = parse(&bad).unwrap_err();
        assert!(e.contains(":2:") && e.contains("`singles`"), "{e}");
    }
}
