//! Record CSV files: parsing (from bytes, no per-cell allocation) and rendering.

use super::error::{CampaignError, Part};
use super::{Record, RecordMeta};
use std::fmt::Write as _;
use std::path::Path;

/// The required columns, in the order they are written.
pub const REQUIRED_COLUMNS: [&str; 5] = ["t", "x_cr", "y_cr", "zmp_x", "zmp_y"];

/// Relative deviation of one time step from the median step (and of the CSV rate from
/// `sample_rate_hz`) above which a record is rejected.
pub const STEP_TOLERANCE: f64 = 0.01;

#[derive(Clone, Copy)]
enum Slot {
    Required(usize),
    Extra(usize),
    Ignored,
}

struct Extra {
    name: String,
    values: Vec<f64>,
    /// False once a cell of this column failed to parse: the column is then dropped.
    numeric: bool,
}

/// Maps a data-row index to its 1-based line, allowing for skipped blank lines and quoted
/// multi-line cells without storing one number per row.
struct LineMap {
    anchors: Vec<(usize, usize)>,
    next_expected: usize,
}

impl LineMap {
    fn new(first_line: usize) -> LineMap {
        LineMap {
            anchors: vec![(0, first_line)],
            next_expected: first_line,
        }
    }

    fn push(&mut self, row: usize, line: usize) {
        if line != self.next_expected {
            self.anchors.push((row, line));
        }
        self.next_expected = line + 1;
    }

    fn line(&self, row: usize) -> usize {
        let k = self.anchors.partition_point(|a| a.0 <= row);
        let (r0, l0) = self.anchors[k.saturating_sub(1)];
        l0 + (row - r0)
    }
}

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
    let mut parser = Parser::new(file, index, count_byte(bytes, b'\n') + 1);
    if is_simple(bytes) {
        drive_simple(bytes, &mut parser)?;
    } else {
        drive_csv(bytes, &mut parser)?;
    }
    parser.finish(meta, sample_rate_hz)
}

/// Counts `needle` in `bytes` (vectorises: 64-byte blocks summed in a `u8`).
fn count_byte(bytes: &[u8], needle: u8) -> usize {
    let mut chunks = bytes.chunks_exact(64);
    let mut n = 0usize;
    for chunk in &mut chunks {
        n += chunk.iter().map(|&b| (b == needle) as u8).sum::<u8>() as usize;
    }
    n + chunks.remainder().iter().filter(|&&b| b == needle).count()
}

/// True when the file has no quotes and no `\r` other than in `\r\n`: then lines and cells can
/// be split on `\n` and `,` directly, much faster than the general CSV state machine.
fn is_simple(bytes: &[u8]) -> bool {
    if count_byte(bytes, b'"') != 0 {
        return false;
    }
    let cr = count_byte(bytes, b'\r');
    cr == 0 || cr == bytes.windows(2).filter(|w| *w == b"\r\n").count()
}

/// The cells of one CSV row.
trait Cells {
    fn count(&self) -> usize;
    fn cell(&self, j: usize) -> &[u8];
}

impl Cells for csv::ByteRecord {
    fn count(&self) -> usize {
        self.len()
    }
    fn cell(&self, j: usize) -> &[u8] {
        self.get(j).unwrap_or(b"")
    }
}

/// One line of a simple (quote-free) file: cell `j` ends at `ends[j]` (absolute offsets).
struct Line<'a> {
    bytes: &'a [u8],
    start: usize,
    ends: &'a [usize],
}

impl Cells for Line<'_> {
    fn count(&self) -> usize {
        self.ends.len()
    }
    #[inline]
    fn cell(&self, j: usize) -> &[u8] {
        let from = if j == 0 {
            self.start
        } else {
            self.ends[j - 1] + 1
        };
        &self.bytes[from..self.ends[j]]
    }
}

/// Splits a simple file into lines and cells. Once the header is known, each data row is first
/// tried by [`Parser::fast_row`], which parses the cells straight from the bytes; a row it does
/// not take (anything but plain decimals where numbers are expected, a wrong cell count, ...)
/// is split on `,` and goes through the general [`Parser::feed`], which also reports errors.
fn drive_simple(bytes: &[u8], parser: &mut Parser) -> Result<(), CampaignError> {
    let mut ends: Vec<usize> = Vec::with_capacity(32);
    let mut start = 0;
    let mut line = 1;
    while start < bytes.len() {
        if parser.header_line.is_some() {
            if let Some(order) = parser.plain_layout() {
                (start, line) = parser.plain_rows(bytes, start, line, order);
                if start >= bytes.len() {
                    break;
                }
            }
            if let Some(next) = parser.fast_row(bytes, start, line) {
                start = next;
                line += 1;
                continue;
            }
        }
        let newline = bytes[start..].iter().position(|&b| b == b'\n');
        let (end, next) = match newline {
            Some(k) => {
                let i = start + k;
                let end = if i > start && bytes[i - 1] == b'\r' {
                    i - 1
                } else {
                    i
                };
                (end, i + 1)
            }
            None => (bytes.len(), bytes.len()),
        };
        if end > start {
            ends.clear();
            ends.extend(
                bytes[start..end]
                    .iter()
                    .enumerate()
                    .filter(|(_, &b)| b == b',')
                    .map(|(k, _)| start + k),
            );
            ends.push(end);
            parser.feed(
                line,
                &Line {
                    bytes,
                    start,
                    ends: &ends,
                },
            )?;
        } // else a blank line
        line += 1;
        start = next;
    }
    Ok(())
}

/// Reads any RFC 4180 file with the `csv` crate.
fn drive_csv(bytes: &[u8], parser: &mut Parser) -> Result<(), CampaignError> {
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .from_reader(bytes);
    let mut row = csv::ByteRecord::new();
    // The csv crate's line numbers (and record start offsets) include the blank lines it skips
    // before a record. So take the reader's offset after the record, count the newlines up to
    // there (incrementally: linear overall), and step back over the terminator and over the
    // line breaks inside quoted cells.
    let (mut offset, mut newlines) = (0usize, 0usize);
    loop {
        let more = reader.read_byte_record(&mut row);
        let end = (reader.position().byte() as usize).clamp(offset, bytes.len());
        newlines += count_byte(&bytes[offset..end], b'\n');
        offset = end;
        let terminated = end > 0 && bytes[end - 1] == b'\n';
        let end_line = newlines + 1 - terminated as usize;
        match more {
            Ok(true) => {
                let inside: usize = row.iter().map(|c| count_byte(c, b'\n')).sum();
                parser.feed(end_line.saturating_sub(inside).max(1), &row)?;
            }
            Ok(false) => return Ok(()),
            Err(e) => {
                return Err(parser.err(Some(end_line), None, format!("unreadable CSV: {e}")));
            }
        }
    }
}

/// Length of the cell at the start of `rest` in a simple file: up to the next `,` or line end
/// (`\n`, or the `\r` of a `\r\n`).
#[inline]
fn cell_len(rest: &[u8]) -> usize {
    rest.iter()
        .position(|&b| b == b',' || b == b'\n' || b == b'\r')
        .unwrap_or(rest.len())
}

/// Turns rows into columns, whichever way the rows were split.
struct Parser<'a> {
    file: &'a Path,
    index: usize,
    capacity: usize,
    /// `None` until the header has been read.
    header_line: Option<usize>,
    slots: Vec<Slot>,
    names: Vec<String>,
    cols: [Vec<f64>; 5],
    extras: Vec<Extra>,
    lines: LineMap,
    last_line: usize,
    n: usize,
}

impl<'a> Parser<'a> {
    fn new(file: &'a Path, index: usize, capacity: usize) -> Parser<'a> {
        Parser {
            file,
            index,
            capacity,
            header_line: None,
            slots: Vec::new(),
            names: Vec::new(),
            cols: Default::default(),
            extras: Vec::new(),
            lines: LineMap::new(1),
            last_line: 0,
            n: 0,
        }
    }

    fn err(&self, line: Option<usize>, column: Option<&str>, message: String) -> CampaignError {
        CampaignError::invalid(
            Part::Data,
            self.file,
            line,
            Some(self.index),
            column,
            message,
        )
    }

    #[inline]
    fn feed(&mut self, line: usize, cells: &impl Cells) -> Result<(), CampaignError> {
        if self.header_line.is_some() {
            self.row(line, cells)
        } else {
            self.header(line, cells)
        }
    }

    fn header(&mut self, line: usize, cells: &impl Cells) -> Result<(), CampaignError> {
        let line = line.max(1);
        self.header_line = Some(line);
        self.last_line = line;
        self.lines = LineMap::new(line + 1);
        let mut required = [false; 5];
        for j in 0..cells.count() {
            let raw = cells.cell(j);
            let name = std::str::from_utf8(raw.trim_ascii()).map_err(|_| {
                self.err(
                    Some(line),
                    None,
                    format!(
                        "header cell {} is not valid UTF-8: {:?}",
                        j + 1,
                        String::from_utf8_lossy(raw)
                    ),
                )
            })?;
            if name.is_empty() {
                self.slots.push(Slot::Ignored);
                self.names.push(String::new());
                continue;
            }
            if let Some(k) = self.names.iter().position(|n| n == name) {
                return Err(self.err(
                    Some(line),
                    Some(name),
                    format!(
                        "duplicate column name: header cells {} and {} are both {name:?}",
                        k + 1,
                        j + 1
                    ),
                ));
            }
            self.names.push(name.to_owned());
            match REQUIRED_COLUMNS.iter().position(|c| *c == name) {
                Some(k) => {
                    required[k] = true;
                    self.slots.push(Slot::Required(k));
                }
                None => {
                    self.slots.push(Slot::Extra(self.extras.len()));
                    self.extras.push(Extra {
                        name: name.to_owned(),
                        values: Vec::new(),
                        numeric: true,
                    });
                }
            }
        }
        if let Some(k) = required.iter().position(|found| !found) {
            return Err(self.err(
                Some(line),
                Some(REQUIRED_COLUMNS[k]),
                format!(
                    "missing required column (the header must name {})",
                    REQUIRED_COLUMNS.join(", ")
                ),
            ));
        }
        for col in &mut self.cols {
            col.reserve_exact(self.capacity);
        }
        for extra in &mut self.extras {
            extra.values.reserve_exact(self.capacity);
        }
        Ok(())
    }

    #[inline]
    fn row(&mut self, line: usize, cells: &impl Cells) -> Result<(), CampaignError> {
        self.last_line = line;
        let ncols = self.slots.len();
        if cells.count() != ncols {
            let count = cells.count();
            let (column, what) = if count < ncols {
                let missing = self.names[count].as_str();
                ((!missing.is_empty()).then_some(missing), "too few cells")
            } else {
                (None, "too many cells")
            };
            return Err(self.err(
                Some(line),
                column,
                format!("{what}: the row has {count} cells, the header has {ncols}"),
            ));
        }
        for (j, slot) in self.slots.iter().enumerate() {
            match *slot {
                Slot::Required(k) => match parse_cell(cells.cell(j)) {
                    Ok(v) => self.cols[k].push(v),
                    Err(m) => return Err(self.err(Some(line), Some(REQUIRED_COLUMNS[k]), m)),
                },
                Slot::Extra(e) => {
                    let extra = &mut self.extras[e];
                    if extra.numeric {
                        match parse_cell(cells.cell(j)) {
                            Ok(v) => extra.values.push(v),
                            Err(_) => {
                                extra.numeric = false;
                                extra.values = Vec::new();
                            }
                        }
                    }
                }
                Slot::Ignored => {}
            }
        }
        self.lines.push(self.n, line);
        self.n += 1;
        Ok(())
    }

    /// The column of each cell when the header names exactly the five required columns (in
    /// any order) and nothing else: the common layout, which [`Parser::plain_rows`] reads.
    fn plain_layout(&self) -> Option<[usize; 5]> {
        if self.slots.len() != 5 {
            return None;
        }
        let mut order = [0; 5];
        for (o, slot) in order.iter_mut().zip(&self.slots) {
            match *slot {
                Slot::Required(k) => *o = k,
                _ => return None,
            }
        }
        Some(order)
    }

    /// [`Parser::fast_row`] for the plain layout, row after row without per-cell dispatch:
    /// parses rows from `bytes[start]` (line `line`) while each is five decimals that
    /// [`fast_f64`] takes, separated by commas and ended by a line end or the end of the file;
    /// returns where the first row it did not take starts and its line (the general path
    /// then reads that row, blank lines and errors included).
    fn plain_rows(
        &mut self,
        bytes: &[u8],
        mut start: usize,
        mut line: usize,
        order: [usize; 5],
    ) -> (usize, usize) {
        let first_row = self.n;
        let first_line = line;
        'rows: while start < bytes.len() {
            let mut p = start;
            let mut row = [0.0f64; 5];
            for (j, v) in row.iter_mut().enumerate() {
                let Some((x, len)) = fast_f64_prefix(&bytes[p..]) else {
                    break 'rows;
                };
                *v = x;
                p += len;
                if j < 4 {
                    if bytes.get(p) != Some(&b',') {
                        break 'rows;
                    }
                    p += 1;
                }
            }
            p += match bytes.get(p) {
                None => 0,
                Some(b'\n') => 1,
                Some(b'\r') if bytes.get(p + 1) == Some(&b'\n') => 2,
                _ => break 'rows,
            };
            for (&k, &v) in order.iter().zip(&row) {
                self.cols[k].push(v);
            }
            start = p;
            line += 1;
        }
        let taken = line - first_line;
        if taken > 0 {
            self.lines.push(first_row, first_line);
            // Consecutive lines: one anchor covers them all (see `LineMap::push`).
            self.lines.next_expected = line;
            self.last_line = line - 1;
            self.n += taken;
        }
        (start, line)
    }

    /// Parses the data row that starts at `bytes[start]` if every cell to keep is a plain
    /// decimal that [`fast_f64`] takes, the row has exactly the header's cell count and it ends
    /// with `\n`, `\r\n` or the end of the file; returns where the next line starts. Otherwise
    /// leaves the parser as it was and returns `None` (the general path then handles the row,
    /// errors included). Cells of ignored and non-numeric extra columns are skipped unread.
    #[inline]
    fn fast_row(&mut self, bytes: &[u8], start: usize, line: usize) -> Option<usize> {
        let last = self.slots.len() - 1;
        let mut p = start;
        for (j, slot) in self.slots.iter().enumerate() {
            let target = match *slot {
                Slot::Required(k) => Some(&mut self.cols[k]),
                Slot::Extra(e) if self.extras[e].numeric => Some(&mut self.extras[e].values),
                _ => None,
            };
            match target {
                Some(col) => match fast_f64_prefix(&bytes[p..]) {
                    Some((v, len)) => {
                        col.push(v);
                        p += len;
                    }
                    None => return self.undo_row(),
                },
                None => p += cell_len(&bytes[p..]),
            }
            // The cell must end here: with a comma before the last cell, with the line after it.
            if j < last {
                if bytes.get(p) != Some(&b',') {
                    return self.undo_row();
                }
                p += 1;
            }
        }
        let next = match bytes.get(p) {
            None => p,
            Some(b'\n') => p + 1,
            Some(b'\r') if bytes.get(p + 1) == Some(&b'\n') => p + 2,
            _ => return self.undo_row(),
        };
        self.last_line = line;
        self.lines.push(self.n, line);
        self.n += 1;
        Some(next)
    }

    /// Drops the values a failed [`Parser::fast_row`] pushed.
    #[cold]
    fn undo_row(&mut self) -> Option<usize> {
        for col in &mut self.cols {
            col.truncate(self.n);
        }
        for extra in self.extras.iter_mut().filter(|e| e.numeric) {
            extra.values.truncate(self.n);
        }
        None
    }

    fn finish(
        self,
        meta: RecordMeta,
        sample_rate_hz: Option<f64>,
    ) -> Result<Record, CampaignError> {
        if self.header_line.is_none() {
            return Err(self.err(
                Some(1),
                None,
                format!(
                    "empty file: expected a header line naming the columns {}",
                    REQUIRED_COLUMNS.join(", ")
                ),
            ));
        }
        let n = self.n;
        if n < 2 {
            return Err(self.err(
                Some(self.last_line + 1),
                None,
                format!("expected at least 2 data rows after the header, found {n}"),
            ));
        }
        if let Err((row, m)) = check_time(&self.cols[0], sample_rate_hz) {
            return Err(self.err(row.map(|r| self.lines.line(r)), Some("t"), m));
        }
        let [t, x_cr, y_cr, zmp_x, zmp_y] = self.cols;
        Ok(Record {
            meta,
            t,
            x_cr,
            y_cr,
            zmp_x,
            zmp_y,
            extra: self
                .extras
                .into_iter()
                .filter(|e| e.numeric)
                .map(|e| (e.name, e.values))
                .collect(),
        })
    }
}

/// Parses one cell as a finite decimal number (surrounding ASCII whitespace allowed).
fn parse_cell(cell: &[u8]) -> Result<f64, String> {
    if let Some(v) = fast_f64(cell) {
        return Ok(v);
    }
    let s = cell.trim_ascii();
    if s.is_empty() {
        return Err("empty cell: expected a number".to_owned());
    }
    let v = std::str::from_utf8(s)
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .ok_or_else(|| format!("not a number: {:?}", shorten(&String::from_utf8_lossy(s))))?;
    if v.is_nan() {
        Err(format!(
            "{:?} is not allowed: expected a finite number",
            String::from_utf8_lossy(s)
        ))
    } else if v.is_infinite() {
        Err(format!(
            "infinite value {:?}: expected a finite number",
            shorten(&String::from_utf8_lossy(s))
        ))
    } else {
        Ok(v)
    }
}

/// The exact fast path (Eisel-Lemire, Clinger for short decimals) for a cell that is a finite
/// decimal and nothing else: the correctly rounded value, so exactly what `str::parse` returns.
/// `None` for anything else (`inf`, `nan`, whitespace, junk); the caller then goes through
/// `str::parse`, which also words the errors.
#[inline]
fn fast_f64(s: &[u8]) -> Option<f64> {
    match fast_f64_prefix(s) {
        Some((v, len)) if len == s.len() => Some(v),
        _ => None,
    }
}

/// [`fast_f64`] on the longest prefix of `s` that is a decimal number; returns the value and
/// the prefix length, `None` when there is none or it is not finite.
#[inline(always)]
fn fast_f64_prefix(s: &[u8]) -> Option<(f64, usize)> {
    if let Some(hit) = short_decimal_prefix(s) {
        return Some(hit);
    }
    match fast_float2::parse_partial::<f64, _>(s) {
        Ok((v, len)) if v.is_finite() => Some((v, len)),
        _ => None,
    }
}

/// Exact powers of ten up to `1e22` (the largest a double holds exactly).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// The cells of a typical record, `-?digits(.digits)?` with at most 19 digits, a significand
/// of at most 2^53 and at most 22 decimals, parsed without the general machinery: the digits
/// as an integer `m`, the value `m / 10^d`, both exact doubles, so one correctly rounded
/// division gives the correctly rounded value (Clinger's fast path), the bits `str::parse`
/// gives. Anything else (an exponent, a leading `+` or `.`, a trailing `.`, more digits) is
/// `None` and goes to `fast-float2`, which takes every decimal.
#[inline(always)]
fn short_decimal_prefix(s: &[u8]) -> Option<(f64, usize)> {
    let neg = s.first() == Some(&b'-');
    let mut i = neg as usize;
    let mut m: u64 = 0;
    let int_start = i;
    i = push_digits(s, i, &mut m);
    let int_digits = i - int_start;
    let mut decimals = 0;
    if s.get(i) == Some(&b'.') {
        i += 1;
        let frac_start = i;
        i = push_digits(s, i, &mut m);
        decimals = i - frac_start;
        if decimals == 0 {
            return None;
        }
    }
    if int_digits == 0
        || int_digits + decimals > 19
        || decimals > 22
        || m > 1 << 53
        || matches!(s.get(i), Some(b'e' | b'E'))
    {
        return None;
    }
    let v = m as f64 / POW10[decimals];
    Some((if neg { -v } else { v }, i))
}

/// Appends the ASCII digits from `s[i]` on to `m` (wrapping: the caller bounds the count);
/// returns where they end.
#[inline(always)]
fn push_digits(s: &[u8], mut i: usize, m: &mut u64) -> usize {
    while let Some(&b) = s.get(i) {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            break;
        }
        *m = m.wrapping_mul(10).wrapping_add(d as u64);
        i += 1;
    }
    i
}

fn shorten(s: &str) -> String {
    if s.chars().count() > 40 {
        let cut: String = s.chars().take(37).collect();
        format!("{cut}...")
    } else {
        s.to_owned()
    }
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

/// Appends `v` in a shortest form that parses back to the same bits.
pub(crate) fn push_f64(buf: &mut String, v: f64) {
    let a = v.abs();
    if a == 0.0 || (1e-5..1e16).contains(&a) {
        let _ = write!(buf, "{v}");
    } else {
        let _ = write!(buf, "{v:e}");
    }
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
        if columns.iter().any(|(c, _)| c == name) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_map() {
        let mut m = LineMap::new(2);
        m.push(0, 2);
        m.push(1, 3);
        m.push(2, 5);
        m.push(3, 6);
        assert_eq!(
            (0..4).map(|r| m.line(r)).collect::<Vec<_>>(),
            vec![2, 3, 5, 6]
        );
    }

    #[test]
    fn fast_path_agrees_with_std() {
        for s in [
            "0",
            "-0",
            "+0",
            "0.0",
            "-0.0",
            "1",
            "1.",
            ".5",
            "-.5",
            "+1.25",
            "0.003112",
            "12345678",
            "9007199254740992",
            "9007199254740993",
            "1e22",
            "1e23",
            "1e-22",
            "4e-3",
            "4E+3",
            "1e",
            "1e+",
            "-",
            ".",
            "",
            "e5",
            "1.2.3",
            "1,5",
            "inf",
            "NaN",
            " 1",
            "1 ",
            "0.1",
            "0.2",
            "0.30000000000000004",
            "123456789012345678901",
            "1e-0005",
            "00000000000000000001",
            "5.0200000000000005",
            "-0.000064421",
            "1e400",
            "1e-400",
            "infinity",
            "0x10",
        ] {
            // Taken exactly when std reads a finite number, and then the same bits.
            let std = s.parse::<f64>().ok().filter(|v| v.is_finite());
            let fast = fast_f64(s.as_bytes());
            assert_eq!(fast.map(f64::to_bits), std.map(f64::to_bits), "{s:?}");
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(4096))]

        #[test]
        fn fast_path_agrees_with_std_on_random_decimals(s in "[-+]?[0-9]{0,20}(\\.[0-9]{0,20})?([eE][-+]?[0-9]{0,4})?") {
            let std = s.parse::<f64>().ok().filter(|v| v.is_finite());
            let fast = fast_f64(s.as_bytes());
            proptest::prop_assert_eq!(fast.map(f64::to_bits), std.map(f64::to_bits), "{:?}", s);
        }

        #[test]
        fn fast_path_agrees_with_std_on_written_values(bits in proptest::prelude::any::<u64>()) {
            let v = f64::from_bits(bits);
            if v.is_finite() {
                let mut s = String::new();
                push_f64(&mut s, v);
                let got = parse_cell(s.as_bytes()).unwrap();
                proptest::prop_assert_eq!(got.to_bits(), v.to_bits(), "{}", s);
            }
        }
    }

    fn both_drivers(bytes: &[u8]) -> [Result<Record, CampaignError>; 2] {
        let run = |simple: bool| {
            let mut p = Parser::new(Path::new("f.csv"), 0, 4);
            let driven = if simple {
                drive_simple(bytes, &mut p)
            } else {
                drive_csv(bytes, &mut p)
            };
            let meta = RecordMeta {
                file: "f.csv".into(),
                excited: zmp_models::Axis::X,
                omega: 1.0,
                amplitude: 1.0,
                operating_point: [0.0, 0.0],
            };
            driven.and_then(|()| p.finish(meta, None))
        };
        [run(true), run(false)]
    }

    /// Asserts both drivers give the same result; returns whether it was `Ok`.
    fn assert_same(bytes: &[u8]) -> bool {
        match both_drivers(bytes) {
            [Ok(a), Ok(b)] => {
                let bits = |r: &Record| -> Vec<Vec<u64>> {
                    let mut v: Vec<&[f64]> = vec![&r.t, &r.x_cr, &r.y_cr, &r.zmp_x, &r.zmp_y];
                    v.extend(r.extra.iter().map(|(_, c)| c.as_slice()));
                    v.iter()
                        .map(|c| c.iter().map(|x| x.to_bits()).collect())
                        .collect()
                };
                assert_eq!(bits(&a), bits(&b), "{:?}", String::from_utf8_lossy(bytes));
                let names = |r: &Record| r.extra.iter().map(|(n, _)| n.clone()).collect::<Vec<_>>();
                assert_eq!(names(&a), names(&b));
                true
            }
            [Err(a), Err(b)] => {
                assert_eq!(
                    a.to_string(),
                    b.to_string(),
                    "{:?}",
                    String::from_utf8_lossy(bytes)
                );
                false
            }
            [a, b] => panic!(
                "drivers disagree on {:?}: simple {:?}, csv {:?}",
                String::from_utf8_lossy(bytes),
                a.map(|_| ()),
                b.map(|_| ())
            ),
        }
    }

    #[test]
    fn simple_driver_matches_csv_crate_on_examples() {
        for text in [
            "",
            "\n\n",
            "t,x_cr,y_cr,zmp_x,zmp_y\n",
            "t,x_cr,y_cr,zmp_x,zmp_y\n0,1,2,3,4\n0.01,1,2,3,4",
            "t,x_cr,y_cr,zmp_x,zmp_y\r\n0,1,2,3,4\r\n\r\n0.01,1,2,3,4\r\n",
            "\n\nt,x_cr,y_cr,zmp_x,zmp_y,x_c\n\n0,1,2,3,4,a\n0.01,1,2,3,4,5\n\n\n0.02,1,2,3,x,5\n",
            "t,x_cr,y_cr,zmp_x,zmp_y\n0,1,2,3\n",
            "t,x_cr,y_cr,zmp_x,zmp_y\n0,1,2,3,4,5\n",
            " \n",
            ",\n",
            "t,x_cr,y_cr,zmp_x,zmp_y\n0,1,2,3,4\n \n",
        ] {
            let _ = assert_same(text.as_bytes());
        }
    }

    fn cell(k: usize, j: usize) -> impl proptest::strategy::Strategy<Value = String> {
        use proptest::prelude::*;
        let number = if j == 0 {
            Just(format!("{}", k as f64 * 0.01)).boxed()
        } else {
            (-1000i32..1000)
                .prop_map(|v| format!("{}", v as f64 / 64.0))
                .boxed()
        };
        prop_oneof![
            60 => number,
            1 => "[0-9.eE+ a-z-]{0,6}",
            1 => Just(String::new()),
        ]
    }

    fn simple_csv() -> impl proptest::strategy::Strategy<Value = Vec<u8>> {
        use proptest::prelude::*;
        let header = prop_oneof![
            Just("t,x_cr,y_cr,zmp_x,zmp_y".to_owned()),
            Just("t,x_cr,y_cr,zmp_x,zmp_y,x_c".to_owned()),
            Just("t, zmp_y ,x_cr,y_cr,zmp_x,,note".to_owned()),
            Just("t,x_cr,y_cr,zmp_x,zmp_y,t".to_owned()),
            "[a-z_, ]{0,30}",
        ];
        let file = (header, 0usize..14).prop_flat_map(|(header, n)| {
            let width = header.split(',').count();
            let rows = (0..n)
                .map(|k| {
                    prop_oneof![20 => Just(width), 1 => 0usize..9]
                        .prop_flat_map(move |w| (0..w).map(|j| cell(k, j)).collect::<Vec<_>>())
                })
                .collect::<Vec<_>>();
            (Just(header), rows)
        });
        (
            file,
            prop_oneof![Just("\n"), Just("\r\n")],
            0usize..3,
            any::<bool>(),
        )
            .prop_map(|((header, rows), eol, blank_every, trailing)| {
                let mut s = header;
                for (k, row) in rows.iter().enumerate() {
                    s.push_str(eol);
                    if blank_every > 0 && k % (blank_every + 2) == 1 {
                        s.push_str(eol);
                    }
                    s.push_str(&row.join(","));
                }
                if trailing {
                    s.push_str(eol);
                }
                s.into_bytes()
            })
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2048))]

        #[test]
        fn simple_driver_matches_csv_crate(bytes in simple_csv()) {
            proptest::prop_assume!(is_simple(&bytes));
            let _ = assert_same(&bytes);
        }
    }

    #[test]
    fn simple_driver_matches_csv_crate_with_valid_files() {
        use proptest::strategy::{Strategy, ValueTree};
        let mut runner = proptest::test_runner::TestRunner::deterministic();
        let mut ok = 0;
        for _ in 0..512 {
            let bytes = simple_csv().new_tree(&mut runner).unwrap().current();
            ok += assert_same(&bytes) as usize;
        }
        assert!(ok >= 50, "only {ok} of 512 generated files were valid");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2048))]

        #[test]
        fn simple_driver_matches_csv_crate_on_noise(bytes in "[t,x_crympz0-9. \n-]{0,80}") {
            let _ = assert_same(bytes.as_bytes());
        }
    }

    #[test]
    fn counting_and_simplicity() {
        let text = "a\nb\r\n".repeat(100);
        assert_eq!(count_byte(text.as_bytes(), b'\n'), 200);
        assert!(is_simple(text.as_bytes()));
        assert!(!is_simple(b"a\rb\n"));
        assert!(!is_simple(b"\"a\"\n"));
    }

    #[test]
    fn floats_round_trip() {
        for v in [
            0.0,
            -0.0,
            1.0,
            0.1,
            1e-5,
            9.99e-6,
            1e16,
            1e300,
            -5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            123456.789,
        ] {
            let mut s = String::new();
            push_f64(&mut s, v);
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), v.to_bits(), "{s}");
        }
    }
}
