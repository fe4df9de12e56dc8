//! Malformed `campaign.toml`: each error names the file, line, record and key.

use crate::fixtures::{check, csv_cells, join, manifest_text, record_table, Fixture, HEADER};
use std::fs;
use zmp_campaign::CampaignError;

#[test]
fn manifest_missing_format() {
    let f = Fixture::new();
    f.set_manifest(&manifest_text("name = \"x\"\n", &record_table(3)));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("format"),
        "missing required key",
    );
}

#[test]
fn manifest_wrong_format() {
    let f = Fixture::new();
    f.set_manifest(&manifest_text(
        "format = \"zmp-campaign/2\"\n",
        &record_table(3),
    ));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("format"),
        "zmp-campaign/2",
    );
    f.set_manifest(&manifest_text("format = 1\n", &record_table(3)));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("format"),
        "got 1",
    );
}

#[test]
fn manifest_records_missing() {
    let f = Fixture::new();
    f.set_manifest(HEADER);
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("records"),
        "missing",
    );
    f.set_manifest(&format!("{HEADER}records = []\n"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("records"),
        "at least one",
    );
    f.set_manifest(&format!("{HEADER}records = 3\n"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("records"),
        "array of tables",
    );
}

#[test]
fn manifest_record_not_a_table() {
    let f = Fixture::new();
    f.set_manifest(&format!(
        "{HEADER}records = [{{ file = \"records/r000.csv\", excited = \"x\", omega = 1.0, \
         amplitude = 0.004, operating_point = {{ x = 0.0, y = 0.0 }} }}, 7]\n"
    ));
    let e = f.read_err();
    check(&e, &f.manifest(), None, Some(1), None, "must be a table");
}

fn rec3_without(key: &str) -> String {
    record_table(3)
        .lines()
        .filter(|l| !l.starts_with(&format!("{key} =")))
        .map(|l| format!("{l}\n"))
        .collect()
}

fn rec3_with(key: &str, value: &str) -> String {
    format!("{}{key} = {value}\n", rec3_without(key))
}

#[test]
fn record_missing_required_keys() {
    for key in ["file", "excited", "omega", "amplitude", "operating_point"] {
        let f = Fixture::new();
        f.set_rec3(&rec3_without(key));
        check(
            &f.read_err(),
            &f.manifest(),
            None,
            Some(3),
            Some(key),
            "missing required key",
        );
    }
}

#[test]
fn record_excited_z() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("excited", "\"z\""));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("excited"),
        "must be \"x\" or \"y\", got \"z\"",
    );
}

#[test]
fn record_omega_negative() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("omega", "-1"));
    let e = f.read_err();
    check(
        &e,
        &f.manifest(),
        None,
        Some(3),
        Some("omega"),
        "must be a positive number, got -1",
    );
    assert!(
        e.to_string()
            .ends_with("campaign.toml: records[3].omega: must be a positive number, got -1"),
        "{e}"
    );
}

#[test]
fn record_omega_not_finite_or_not_a_number() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("omega", "inf"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("omega"),
        "positive",
    );
    f.set_rec3(&rec3_with("omega", "\"fast\""));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("omega"),
        "\"fast\"",
    );
}

#[test]
fn record_amplitude_zero() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("amplitude", "0.0"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("amplitude"),
        "must be a positive number, got 0.0",
    );
}

#[test]
fn record_operating_point_missing_y() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("operating_point", "{ x = 0.0 }"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("operating_point.y"),
        "missing required key",
    );
}

#[test]
fn record_operating_point_x_string() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("operating_point", "{ x = \"left\", y = 0.0 }"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("operating_point.x"),
        "must be a number, got \"left\"",
    );
    f.set_rec3(&rec3_with("operating_point", "[0.0, 0.0]"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("operating_point"),
        "inline table",
    );
}

#[test]
fn record_absolute_path() {
    let f = Fixture::new();
    let abs = f.csv(0);
    f.set_rec3(&rec3_with("file", &format!("{:?}", abs.to_str().unwrap())));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("file"),
        "absolute path",
    );
}

#[test]
fn record_dotdot_path() {
    let f = Fixture::new();
    fs::write(
        f.dir.parent().unwrap().join("outside.csv"),
        join(&csv_cells(10)),
    )
    .unwrap();
    f.set_rec3(&rec3_with("file", "\"records/../../outside.csv\""));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("file"),
        "leaves it through \"..\"",
    );
}

#[test]
fn record_file_not_a_string() {
    let f = Fixture::new();
    f.set_rec3(&rec3_with("file", "3"));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        Some(3),
        Some("file"),
        "must be a string",
    );
}

#[test]
fn manifest_header_fields_wrong_types() {
    let f = Fixture::new();
    f.set_manifest(&manifest_text(
        "format = \"zmp-campaign/1\"\nsample_rate_hz = -200.0\n",
        &record_table(3),
    ));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("sample_rate_hz"),
        "positive",
    );
    f.set_manifest(&manifest_text(
        "format = \"zmp-campaign/1\"\nrobot = 2\n",
        &record_table(3),
    ));
    check(
        &f.read_err(),
        &f.manifest(),
        None,
        None,
        Some("robot"),
        "must be a string",
    );
}

#[test]
fn manifest_invalid_utf8() {
    let f = Fixture::new();
    let mut bytes = b"format = \"zmp-campaign/1\"\nname = \"".to_vec();
    bytes.extend_from_slice(&[0xff, 0xfe]);
    bytes.extend_from_slice(b"\"\n");
    fs::write(f.manifest(), bytes).unwrap();
    check(
        &f.read_err(),
        &f.manifest(),
        Some(2),
        None,
        None,
        "not valid UTF-8",
    );
}

#[test]
fn manifest_toml_syntax_error_names_line() {
    let f = Fixture::new();
    f.set_manifest("format = \"zmp-campaign/1\"\n\n[[records]]\nomega = = 3\n");
    check(
        &f.read_err(),
        &f.manifest(),
        Some(4),
        None,
        None,
        "TOML syntax error",
    );
}

#[test]
fn manifest_missing_file() {
    let f = Fixture::new();
    fs::remove_file(f.manifest()).unwrap();
    let e = f.read_err();
    assert!(matches!(e, CampaignError::Io { .. }));
    assert_eq!(e.file(), f.manifest());
    assert!(e
        .to_string()
        .starts_with(&f.manifest().display().to_string()));
}
