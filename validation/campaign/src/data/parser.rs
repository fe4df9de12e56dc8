//! The parser that turns a record's rows into columns: the header, each row (general and
//! fast paths), and the final checks that make a [`Record`].

use super::number::{fast_f64_prefix, parse_cell};
use super::rows::Cells;
use super::{check_time, MAX_COLUMNS, REQUIRED_COLUMNS};
use crate::{CampaignError, Part, Record, RecordMeta};
use std::collections::HashMap;
use std::path::Path;

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

/// Length of the cell at the start of `rest` in a simple file: up to the next `,` or line end
/// (`\n`, or the `\r` of a `\r\n`).
#[inline]
fn cell_len(rest: &[u8]) -> usize {
    rest.iter()
        .position(|&b| b == b',' || b == b'\n' || b == b'\r')
        .unwrap_or(rest.len())
}

/// Turns rows into columns, whichever way the rows were split.
pub(super) struct Parser<'a> {
    file: &'a Path,
    index: usize,
    /// Lines in the file: no more rows than that.
    capacity: usize,
    /// Bytes in the file: a row of `n` cells takes at least `n` of them.
    bytes: usize,
    /// `None` until the header has been read.
    pub(super) header_line: Option<usize>,
    slots: Vec<Slot>,
    names: Vec<String>,
    cols: [Vec<f64>; 5],
    extras: Vec<Extra>,
    lines: LineMap,
    last_line: usize,
    n: usize,
}

impl<'a> Parser<'a> {
    pub(super) fn new(file: &'a Path, index: usize, capacity: usize, bytes: usize) -> Parser<'a> {
        Parser {
            file,
            index,
            capacity,
            bytes,
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

    pub(super) fn err(
        &self,
        line: Option<usize>,
        column: Option<&str>,
        message: String,
    ) -> CampaignError {
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
    pub(super) fn feed(&mut self, line: usize, cells: &impl Cells) -> Result<(), CampaignError> {
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
        let width = cells.count();
        if width > MAX_COLUMNS {
            return Err(self.err(
                Some(line),
                None,
                format!(
                    "the header has {width} cells, more than the limit of {MAX_COLUMNS} columns \
                     a record may have"
                ),
            ));
        }
        let mut required = [false; 5];
        // Each name's first cell: duplicates are found in time linear in the width.
        let mut first: HashMap<&str, usize> = HashMap::with_capacity(width);
        for j in 0..width {
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
            if let Some(&k) = first.get(name) {
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
            first.insert(name, j);
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
        // Room for every row the file can hold, reserved once (pushes never reallocate) and
        // fallibly (a crafted file under a memory limit is an error, not an abort): no more
        // rows than lines, and no more than the file's bytes over the header's width (a row
        // of n cells has n - 1 commas and a line end). The whole is at most one value per
        // byte of the file.
        let rows = self.capacity.min(self.bytes / width.max(1) + 1);
        let cols = self
            .cols
            .iter_mut()
            .chain(self.extras.iter_mut().map(|e| &mut e.values));
        for col in cols {
            if let Err(e) = col.try_reserve_exact(rows) {
                return Err(CampaignError::invalid(
                    Part::Data,
                    self.file,
                    Some(line),
                    Some(self.index),
                    None,
                    format!("cannot reserve memory for {rows} rows of {width} columns: {e}"),
                ));
            }
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
    pub(super) fn plain_layout(&self) -> Option<[usize; 5]> {
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
    /// [`fast_f64`](super::number::fast_f64) takes, separated by commas and ended by a line
    /// end or the end of the file; returns where the first row it did not take starts and its
    /// line (the general path then reads that row, blank lines and errors included).
    pub(super) fn plain_rows(
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
    /// decimal that [`fast_f64`](super::number::fast_f64) takes, the row has exactly the
    /// header's cell count and it ends with `\n`, `\r\n` or the end of the file; returns where
    /// the next line starts. Otherwise leaves the parser as it was and returns `None` (the
    /// general path then handles the row, errors included). Cells of ignored and non-numeric
    /// extra columns are skipped unread.
    #[inline]
    pub(super) fn fast_row(&mut self, bytes: &[u8], start: usize, line: usize) -> Option<usize> {
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
                    None => return self.undo_row(j),
                },
                None => p += cell_len(&bytes[p..]),
            }
            // The cell must end here: with a comma before the last cell, with the line after it.
            if j < last {
                if bytes.get(p) != Some(&b',') {
                    return self.undo_row(j + 1);
                }
                p += 1;
            }
        }
        let next = match bytes.get(p) {
            None => p,
            Some(b'\n') => p + 1,
            Some(b'\r') if bytes.get(p + 1) == Some(&b'\n') => p + 2,
            _ => return self.undo_row(self.slots.len()),
        };
        self.last_line = line;
        self.lines.push(self.n, line);
        self.n += 1;
        Some(next)
    }

    /// Drops the values a failed [`Parser::fast_row`] pushed into the first `slots` cells'
    /// columns (only those: a row given up at its first cell costs nothing however wide the
    /// header, so blank lines under a wide header are read in linear time).
    #[cold]
    fn undo_row(&mut self, slots: usize) -> Option<usize> {
        for slot in &self.slots[..slots] {
            match *slot {
                Slot::Required(k) => self.cols[k].truncate(self.n),
                Slot::Extra(e) => self.extras[e].values.truncate(self.n),
                Slot::Ignored => {}
            }
        }
        None
    }

    pub(super) fn finish(
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
}
