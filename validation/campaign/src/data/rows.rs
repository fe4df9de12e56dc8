//! Splitting a record CSV into rows and cells: the quote-free fast driver and the general
//! RFC 4180 driver (the `csv` crate), both feeding the [`Parser`].

use super::parser::Parser;
use crate::CampaignError;

/// Counts `needle` in `bytes` (vectorises: 64-byte blocks summed in a `u8`).
pub(super) fn count_byte(bytes: &[u8], needle: u8) -> usize {
    let mut chunks = bytes.chunks_exact(64);
    let mut n = 0usize;
    for chunk in &mut chunks {
        n += chunk.iter().map(|&b| (b == needle) as u8).sum::<u8>() as usize;
    }
    n + chunks.remainder().iter().filter(|&&b| b == needle).count()
}

/// True when the file has no quotes and no `\r` other than in `\r\n`: then lines and cells can
/// be split on `\n` and `,` directly, much faster than the general CSV state machine.
pub(super) fn is_simple(bytes: &[u8]) -> bool {
    if count_byte(bytes, b'"') != 0 {
        return false;
    }
    let cr = count_byte(bytes, b'\r');
    cr == 0 || cr == bytes.windows(2).filter(|w| *w == b"\r\n").count()
}

/// The cells of one CSV row.
pub(super) trait Cells {
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
pub(super) fn drive_simple(bytes: &[u8], parser: &mut Parser) -> Result<(), CampaignError> {
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
pub(super) fn drive_csv(bytes: &[u8], parser: &mut Parser) -> Result<(), CampaignError> {
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Record, RecordMeta};
    use std::path::Path;

    fn both_drivers(bytes: &[u8]) -> [Result<Record, CampaignError>; 2] {
        let run = |simple: bool| {
            let mut p = Parser::new(Path::new("f.csv"), 0, 4, bytes.len());
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
}
