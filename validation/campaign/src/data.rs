//! Record CSV files: parsing (from bytes, no per-cell allocation) and rendering.
//!
//! The bytes are split into rows and cells in `rows`, turned into columns in `parser`, and
//! each cell's number is read (and written) in `number`.

mod number;
mod parser;
mod rows;

use super::error::{CampaignError, Part};
use super::{Record, RecordMeta};
use number::push_f64;
use parser::Parser;
use rows::{count_byte, drive_csv, drive_simple, is_simple};
use std::path::Path;

/// The required columns, in the order they are written.
pub const REQUIRED_COLUMNS: [&str; 5] = ["t", "x_cr", "y_cr", "zmp_x", "zmp_y"];

/// Most cells a record's header may have (a little over a million; the five required columns
/// and any extra ones): the header is read in time linear in its width, and each column costs
/// memory, so a wider header is an error naming the file and the limit.
pub const MAX_COLUMNS: usize = 1 << 20;

/// Relative deviation of one time step from the median step (and of the CSV rate from
/// `sample_rate_hz`) above which a record is rejected.
pub const STEP_TOLERANCE: f64 = 0.01;

/// Parses the bytes of one record CSV.
///
/// `file` names the file in errors, `index` is the record's index in `campaign.toml`,
/// `sample_rate_hz` the optional rate the time step must agree with (within 1 %).
///
/// Columns are found by name (surrounding ASCII whitespace and a UTF-8 byte-order mark are
/// ignored). Extra columns whose cells all parse as finite numbers are kept in
/// [`Record::extra`]; other extra columns and columns with an empty header are ignored.
/// Blank lines are skipped; `\n` and `\r\n` line ends are accepted, and quoted cells (RFC 4180)
/// are understood.
pub fn parse_record(
    bytes: &[u8],
    file: &Path,
    index: usize,
    meta: RecordMeta,
    sample_rate_hz: Option<f64>,
) -> Result<Record, CampaignError> {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut parser = Parser::new(file, index, count_byte(bytes, b'\n') + 1, bytes.len());
    if is_simple(bytes) {
        drive_simple(bytes, &mut parser)?;
    } else {
        drive_csv(bytes, &mut parser)?;
    }
    parser.finish(meta, sample_rate_hz)
}

/// Checks that `t` (at least 2 samples, all finite) is strictly increasing with a uniform step
/// (each step within 1 % of the median step) and, if given, agrees with `sample_rate_hz` within 1 %.
/// On error returns the row index the problem shows at (if any) and a message.
pub(crate) fn check_time(
    t: &[f64],
    sample_rate_hz: Option<f64>,
) -> Result<(), (Option<usize>, String)> {
    let n = t.len();
    debug_assert!(n >= 2);
    for i in 1..n {
        if t[i] <= t[i - 1] {
            return Err((
                Some(i),
                format!(
                    "time must be strictly increasing, but {} follows {} on the previous row",
                    t[i],
                    t[i - 1]
                ),
            ));
        }
    }
    let mean = (t[n - 1] - t[0]) / (n - 1) as f64;
    if !(mean.is_finite() && mean > 0.0) {
        return Err((None, format!("unusable mean time step {mean}")));
    }
    // Every step must be within 1 % of the typical (median) step. Fast path without the median:
    // if max <= (1 + tol) min, every step is within tol of any value between min and max.
    let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
    for w in t.windows(2) {
        let step = w[1] - w[0];
        lo = lo.min(step);
        hi = hi.max(step);
    }
    if hi > (1.0 + STEP_TOLERANCE) * lo {
        let mut steps: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
        let mid = steps.len() / 2;
        let median = *steps.select_nth_unstable_by(mid, f64::total_cmp).1;
        let tol = STEP_TOLERANCE * median;
        for i in 1..n {
            let step = t[i] - t[i - 1];
            if (step - median).abs() > tol {
                return Err((
                    Some(i),
                    format!(
                        "non-uniform time step: {step} s from the previous row, the typical \
                         (median) step is {median} s (more than {} % off)",
                        STEP_TOLERANCE * 100.0
                    ),
                ));
            }
        }
    }
    if let Some(rate) = sample_rate_hz {
        let csv_rate = 1.0 / mean;
        if (csv_rate - rate).abs() > STEP_TOLERANCE * rate {
            return Err((
                None,
                format!(
                    "the time step {mean} s ({csv_rate} Hz) disagrees with sample_rate_hz = {rate} \
                     in campaign.toml by more than {} %",
                    STEP_TOLERANCE * 100.0
                ),
            ));
        }
    }
    Ok(())
}

/// Checks `record`'s data and renders its CSV. `file` (the destination path) and `index` only
/// name things in errors; lines in errors are the lines the rows would have had.
pub(crate) fn render_record(
    record: &Record,
    file: &Path,
    index: usize,
    sample_rate_hz: Option<f64>,
) -> Result<String, CampaignError> {
    let err = |line: Option<usize>, column: Option<&str>, message: String| {
        CampaignError::invalid(Part::Data, file, line, Some(index), column, message)
    };
    let n = record.t.len();
    let mut columns: Vec<(&str, &[f64])> = vec![
        ("t", &record.t),
        ("x_cr", &record.x_cr),
        ("y_cr", &record.y_cr),
        ("zmp_x", &record.zmp_x),
        ("zmp_y", &record.zmp_y),
    ];
    let mut seen: std::collections::HashSet<&str> = REQUIRED_COLUMNS.into_iter().collect();
    for (j, (name, values)) in record.extra.iter().enumerate() {
        let bad = name.is_empty()
            || name.trim_ascii() != name
            || name.contains([',', '"', '\r', '\n'])
            || name.starts_with('\u{feff}');
        if bad {
            return Err(err(
                Some(1),
                Some(name),
                format!(
                    "extra column {j} has an invalid name {name:?}: it must be non-empty, without \
                     commas, quotes, line breaks or surrounding whitespace"
                ),
            ));
        }
        if !seen.insert(name.as_str()) {
            return Err(err(Some(1), Some(name), "duplicate column name".to_owned()));
        }
        columns.push((name, values));
    }
    for (name, values) in &columns {
        if values.len() != n {
            return Err(err(
                None,
                Some(name),
                format!("has {} values but t has {n}", values.len()),
            ));
        }
    }
    if n < 2 {
        return Err(err(
            Some(n + 2),
            None,
            format!("expected at least 2 data rows, found {n}"),
        ));
    }

    let mut buf = String::with_capacity(64 + n * columns.len() * 22);
    for (j, (name, _)) in columns.iter().enumerate() {
        if j > 0 {
            buf.push(',');
        }
        buf.push_str(name);
    }
    buf.push('\n');
    for i in 0..n {
        for (j, (name, values)) in columns.iter().enumerate() {
            let v = values[i];
            if !v.is_finite() {
                return Err(err(
                    Some(i + 2),
                    Some(name),
                    format!("{v} is not allowed: expected a finite number"),
                ));
            }
            if j > 0 {
                buf.push(',');
            }
            push_f64(&mut buf, v);
        }
        buf.push('\n');
    }
    check_time(&record.t, sample_rate_hz)
        .map_err(|(row, m)| err(row.map(|r| r + 2), Some("t"), m))?;
    Ok(buf)
}
