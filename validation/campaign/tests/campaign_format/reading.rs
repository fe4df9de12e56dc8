//! Reading valid campaigns.

use crate::fixtures::{check, csv_cells, join, manifest_text, record_table, Fixture, HEADER};
use std::fs;
use std::path::Path;
use zmp_campaign::{read_campaign, read_manifest};
use zmp_models::Axis;

#[test]
fn fixture_reads() {
    let f = Fixture::new();
    let c = read_campaign(&f.dir).unwrap();
    assert_eq!(c.name.as_deref(), Some("fixture"));
    assert_eq!(c.robot.as_deref(), Some("SILO2"));
    assert_eq!(c.sample_rate_hz, Some(100.0));
    assert_eq!(c.records.len(), 4);
    let r = &c.records[3];
    assert_eq!(r.meta.file, Path::new("records/r003.csv"));
    assert_eq!(r.meta.excited, Axis::Y);
    assert_eq!(r.meta.omega, 4.0);
    assert_eq!(r.meta.operating_point, [0.0, 0.01]);
    assert_eq!(r.len(), 10);
    assert!(!r.is_empty());
    assert!((r.dt() - 0.01).abs() < 1e-12);
    assert_eq!(r.input(Axis::X), r.x_cr.as_slice());
    assert_eq!(r.output(Axis::Y), r.zmp_y.as_slice());
    assert_eq!(r.excitation(), r.y_cr.as_slice());
    assert_eq!(r.column("x_c").unwrap().len(), 10);
    assert!(r.column("nope").is_none());
    assert_eq!(r.extra.len(), 1);
}

#[test]
fn read_manifest_opens_no_csv() {
    let f = Fixture::new();
    fs::remove_dir_all(f.dir.join("records")).unwrap();
    let m = read_manifest(&f.dir).unwrap();
    assert_eq!(m.records.len(), 4);
    assert_eq!(m.records[2].excited, Axis::X);
    assert_eq!(m.records[2].omega, 3.0);
}

#[test]
fn unknown_keys_are_ignored() {
    let f = Fixture::new();
    let header = format!(
        "{HEADER}kind = \"future\"\nversion_note = [1, 2, 3]\n[operator]\nname = \"someone\"\n"
    );
    let rec3 = format!(
        "{}kind = \"multisine\"\nnotes = {{ a = 1 }}\nweights = [1.0, 2.0]\n",
        record_table(3)
    );
    f.set_manifest(&manifest_text(&header, &rec3));
    let c = read_campaign(&f.dir).unwrap();
    assert_eq!(c.records.len(), 4);
    assert_eq!(c.records[3].meta.omega, 4.0);
}

#[test]
fn integers_accepted_as_floats() {
    let f = Fixture::new();
    f.set_manifest(&manifest_text(
        "format = \"zmp-campaign/1\"\nsample_rate_hz = 100\n",
        "file = \"records/r003.csv\"\nexcited = \"x\"\nomega = 2\namplitude = 1\noperating_point = { y = -1, x = 3 }\n",
    ));
    let m = read_manifest(&f.dir).unwrap();
    assert_eq!(m.sample_rate_hz, Some(100.0));
    assert_eq!(m.records[3].omega, 2.0);
    assert_eq!(m.records[3].operating_point, [3.0, -1.0]);
}

#[test]
fn columns_in_any_order_with_whitespace_crlf_and_non_numeric_extras() {
    let f = Fixture::new();
    let mut s = String::from("\u{feff} zmp_y ,note,t,zmp_x,y_cr,x_cr,f_z\r\n");
    for k in 0..5 {
        let t = 1.0 + k as f64 * 0.01;
        s.push_str(&format!("{k}.5,ok {k},{t}, {k} ,2,3,{}\r\n", k * 10));
    }
    f.set_csv(3, &s);
    let c = read_campaign(&f.dir).unwrap();
    let r = &c.records[3];
    assert_eq!(r.zmp_y, vec![0.5, 1.5, 2.5, 3.5, 4.5]);
    assert_eq!(r.zmp_x, vec![0.0, 1.0, 2.0, 3.0, 4.0]);
    assert_eq!(r.y_cr, vec![2.0; 5]);
    assert_eq!(r.x_cr, vec![3.0; 5]);
    assert_eq!(r.extra.len(), 1, "the text column `note` is ignored");
    assert_eq!(r.column("f_z").unwrap(), &[0.0, 10.0, 20.0, 30.0, 40.0]);
}

#[test]
fn blank_lines_keep_line_numbers_right() {
    let f = Fixture::new();
    let cells = csv_cells(10);
    // Header on line 1, rows 0..3 on lines 2..4, a blank line 5, rows from line 6 on.
    let mut s = join(&cells[..4]);
    s.push('\n');
    let mut rest = cells[4..].to_vec();
    rest[2][3] = "abc".to_owned(); // on line 6 + 2 = 8
    s.push_str(&join(&rest));
    f.set_csv(3, &s);
    let e = f.read_err();
    check(
        &e,
        &f.csv(3),
        Some(8),
        Some(3),
        Some("zmp_x"),
        "not a number: \"abc\"",
    );
}
