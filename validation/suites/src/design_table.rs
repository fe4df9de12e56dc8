//! The book's table of the records `design-next` proposed, one Markdown row per record, as
//! both design-next suites (virtual robot, independent simulator) write it into
//! `docs/src/design-next.md`.

use zmp_diagnose::design::DesignedRecord;

/// The Markdown table of `records` (axis, frequency in rad/s, amplitude in mm, operating
/// point in m, duration in s), header first, without a trailing newline.
pub fn records_table(records: &[DesignedRecord]) -> String {
    let mut table = String::from(
        "| axis | rad/s | mm | operating point (m) | s |\n| --- | --- | --- | --- | --- |\n",
    );
    let rows: Vec<String> = records
        .iter()
        .map(|r| {
            format!(
                "| {} | {:.2} | {:.2} | ({:.2}, {:.2}) | {:.1} |",
                r.excited,
                r.omega,
                r.amplitude * 1e3,
                r.operating_point[0],
                r.operating_point[1],
                r.duration_s
            )
        })
        .collect();
    table.push_str(&rows.join("\n"));
    table
}

#[cfg(test)]
mod tests {
    use super::*;
    use zmp_models::Axis;

    /// The record of one table row `| axis | rad/s | mm | (x, y) | s |`, as printed.
    fn record_of(row: &str) -> DesignedRecord {
        let cells: Vec<&str> = row.trim_matches('|').split('|').map(str::trim).collect();
        let num = |s: &str| -> f64 { s.parse().unwrap_or_else(|_| panic!("{row}: {s}")) };
        let (x, y) = cells[3]
            .trim_matches(|c| c == '(' || c == ')')
            .split_once(", ")
            .unwrap();
        DesignedRecord {
            excited: Axis::parse(cells[0]).unwrap(),
            omega: num(cells[1]),
            amplitude: num(cells[2]) / 1e3,
            operating_point: [num(x), num(y)],
            duration_s: num(cells[4]),
        }
    }

    /// The design-next sections of the book hold the tables of their records as this helper
    /// writes it, byte for byte: the suites that write those sections are long (`#[ignore]`d),
    /// so this guards the format they share in CI. The rows are read back from the page
    /// (printed values reprint unchanged), so a rerun of the suites keeps it valid.
    #[test]
    fn writes_the_tables_of_the_books_design_next_sections() {
        let page = std::fs::read_to_string(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../docs/src/design-next.md"
        ))
        .unwrap();
        let header = "| axis | rad/s | mm | operating point (m) | s |";
        let mut tables = 0;
        for (at, _) in page.match_indices(header) {
            let block = &page[at..];
            let block = &block[..block.find("\n\n").unwrap()];
            let rows: Vec<DesignedRecord> = block.lines().skip(2).map(record_of).collect();
            assert!(!rows.is_empty(), "{block}");
            assert_eq!(records_table(&rows), block);
            tables += 1;
        }
        assert_eq!(
            tables, 3,
            "the virtual robot's, the independent simulator's pilot and its rest"
        );
    }
}
