//! Malformed record CSV: each error names the file, line, record and column.

use crate::fixtures::{check, csv_cells, join, manifest_text, record_table, Fixture};
use std::fs;
use zmp_campaign::{read_campaign, CampaignError};

#[test]
fn csv_missing_file() {
    let f = Fixture::new();
    fs::remove_file(f.csv(3)).unwrap();
    let e = f.read_err();
    assert!(matches!(e, CampaignError::Io { .. }), "{e}");
    check(
        &e,
        &f.csv(3),
        None,
        Some(3),
        Some("file"),
        "records[3].file: cannot read",
    );
}

#[test]
fn csv_missing_column_zmp_y() {
    let f = Fixture::new();
    let cells: Vec<Vec<String>> = csv_cells(10)
        .into_iter()
        .map(|mut r| {
            r.remove(4);
            r
        })
        .collect();
    f.set_csv(3, &join(&cells));
    check(
        &f.read_err(),
        &f.csv(3),
        Some(1),
        Some(3),
        Some("zmp_y"),
        "missing required column",
    );
}

#[test]
fn csv_duplicate_column() {
    let f = Fixture::new();
    f.set_cell3(1, 5, "zmp_x");
    check(
        &f.read_err(),
        &f.csv(3),
        Some(1),
        Some(3),
        Some("zmp_x"),
        "duplicate column name",
    );
}

#[test]
fn csv_nan_cell() {
    let f = Fixture::new();
    f.set_cell3(17 - 10, 3, "NaN");
    check(
        &f.read_err(),
        &f.csv(3),
        Some(7),
        Some(3),
        Some("zmp_x"),
        "\"NaN\" is not allowed",
    );
}

#[test]
fn csv_infinite_cell() {
    let f = Fixture::new();
    f.set_cell3(5, 2, "-inf");
    check(
        &f.read_err(),
        &f.csv(3),
        Some(5),
        Some(3),
        Some("y_cr"),
        "infinite",
    );
}

#[test]
fn csv_empty_cell() {
    let f = Fixture::new();
    f.set_cell3(4, 1, "");
    check(
        &f.read_err(),
        &f.csv(3),
        Some(4),
        Some(3),
        Some("x_cr"),
        "empty cell",
    );
}

#[test]
fn csv_unparsable_cell() {
    let f = Fixture::new();
    f.set_cell3(11, 3, "abc");
    let e = f.read_err();
    check(
        &e,
        &f.csv(3),
        Some(11),
        Some(3),
        Some("zmp_x"),
        "not a number: \"abc\"",
    );
    assert!(
        e.to_string()
            .ends_with("records/r003.csv:11: column zmp_x: not a number: \"abc\""),
        "{e}"
    );
}

#[test]
fn csv_wrong_cell_count() {
    let f = Fixture::new();
    let mut cells = csv_cells(10);
    cells[6].truncate(4);
    f.set_csv(3, &join(&cells));
    check(
        &f.read_err(),
        &f.csv(3),
        Some(7),
        Some(3),
        Some("zmp_y"),
        "the row has 4 cells, the header has 6",
    );

    let mut cells = csv_cells(10);
    cells[8].push("1.0".to_owned());
    f.set_csv(3, &join(&cells));
    check(
        &f.read_err(),
        &f.csv(3),
        Some(9),
        Some(3),
        None,
        "the row has 7 cells, the header has 6",
    );
}

#[test]
fn csv_t_decreasing() {
    let f = Fixture::new();
    f.set_cell3(6, 0, "0.0");
    check(
        &f.read_err(),
        &f.csv(3),
        Some(6),
        Some(3),
        Some("t"),
        "strictly increasing",
    );
}

#[test]
fn csv_t_non_uniform() {
    let f = Fixture::new();
    // One dropped sample: the step from line 8 to line 9 is doubled; the error names line 9.
    let mut cells = csv_cells(11);
    cells.remove(8);
    f.set_csv(3, &join(&cells));
    check(
        &f.read_err(),
        &f.csv(3),
        Some(9),
        Some(3),
        Some("t"),
        "non-uniform time step",
    );
}

#[test]
fn csv_t_jitter_tolerated() {
    let f = Fixture::new();
    f.set_cell3(5, 0, &(0.03 + 0.01 * 2e-3).to_string());
    read_campaign(&f.dir).unwrap();
}

#[test]
fn csv_sample_rate_mismatch() {
    let f = Fixture::new();
    f.set_manifest(&manifest_text(
        "format = \"zmp-campaign/1\"\nsample_rate_hz = 200.0\n",
        &record_table(3),
    ));
    let e = f.read_err();
    check(
        &e,
        &f.csv(0),
        None,
        Some(0),
        Some("t"),
        "sample_rate_hz = 200",
    );
    // Within 1 %: fine.
    f.set_manifest(&manifest_text(
        "format = \"zmp-campaign/1\"\nsample_rate_hz = 100.5\n",
        &record_table(3),
    ));
    read_campaign(&f.dir).unwrap();
}

#[test]
fn csv_only_header() {
    let f = Fixture::new();
    f.set_csv(3, "t,x_cr,y_cr,zmp_x,zmp_y\n");
    check(
        &f.read_err(),
        &f.csv(3),
        Some(2),
        Some(3),
        None,
        "at least 2 data rows",
    );
    f.set_csv(3, "t,x_cr,y_cr,zmp_x,zmp_y\n0,0,0,0,0\n");
    check(&f.read_err(), &f.csv(3), Some(3), Some(3), None, "found 1");
}

#[test]
fn csv_empty_file() {
    let f = Fixture::new();
    f.set_csv(3, "");
    check(&f.read_err(), &f.csv(3), Some(1), Some(3), None, "header");
}

#[test]
fn csv_invalid_utf8_cell() {
    let f = Fixture::new();
    let mut cells = csv_cells(3);
    cells[3][4] = "#".to_owned();
    let mut bytes = join(&cells).into_bytes();
    let pos = bytes.iter().position(|&b| b == b'#').unwrap();
    bytes[pos] = 0xff;
    fs::write(f.csv(3), &bytes).unwrap();
    check(
        &f.read_err(),
        &f.csv(3),
        Some(4),
        Some(3),
        Some("zmp_y"),
        "not a number",
    );
}

#[test]
fn csv_quoted_cells_and_multiline_keep_line_numbers_right() {
    let f = Fixture::new();
    let head = "t,x_cr,y_cr,zmp_x,zmp_y,note\n";
    f.set_csv(
        3,
        &format!("{head}0,\"1\",2,3,4,\"multi\nline\"\n0.01,1,2,3,4,x\n\n0.02,1,2,abc,4,y\n"),
    );
    check(
        &f.read_err(),
        &f.csv(3),
        Some(6),
        Some(3),
        Some("zmp_x"),
        "not a number: \"abc\"",
    );
    f.set_csv(
        3,
        &format!("{head}0,\"1\",2,3,4,\"multi\r\nline\"\r\n0.01,1,2,3,\" 4.5\",x\r\n"),
    );
    let c = read_campaign(&f.dir).unwrap();
    assert_eq!(c.records[3].x_cr, vec![1.0, 1.0]);
    assert_eq!(c.records[3].zmp_y, vec![4.0, 4.5]);
    assert!(c.records[3].extra.is_empty());
}
