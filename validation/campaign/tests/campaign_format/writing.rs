//! Round trip and writing (bit-exact, atomic, refusing to overwrite what is not a campaign).

use crate::fixtures::{assert_bit_equal, check, leftovers, sample_campaign};
use std::fs;
use std::path::PathBuf;
use tempfile::TempDir;
use zmp_campaign::{read_campaign, write_campaign, CampaignError, FORMAT};

#[test]
fn round_trip_is_bit_exact() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("nested/deeper/out");
    let c = sample_campaign();
    write_campaign(&dir, &c, false).unwrap();
    let text = fs::read_to_string(dir.join("campaign.toml")).unwrap();
    assert!(
        text.starts_with(&format!("format = \"{FORMAT}\"\n")),
        "{text}"
    );
    let csv = fs::read_to_string(dir.join("records/r001.csv")).unwrap();
    assert!(
        csv.starts_with("t,x_cr,y_cr,zmp_x,zmp_y,x_c,f_z\n"),
        "{csv}"
    );
    let back = read_campaign(&dir).unwrap();
    assert_bit_equal(&c, &back);
    // And once more through the written files.
    let dir2 = tmp.path().join("again");
    write_campaign(&dir2, &back, false).unwrap();
    assert_bit_equal(&c, &read_campaign(&dir2).unwrap());
    assert_eq!(
        fs::read(dir.join("records/r001.csv")).unwrap(),
        fs::read(dir2.join("records/r001.csv")).unwrap()
    );
    assert!(leftovers(tmp.path()).is_empty());
}

#[test]
fn write_refuses_non_empty_folder_without_overwrite() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("out");
    let c = sample_campaign();
    write_campaign(&dir, &c, false).unwrap();
    let before = fs::read(dir.join("campaign.toml")).unwrap();

    let mut other = c.clone();
    other.name = Some("other".to_owned());
    let e = write_campaign(&dir, &other, false).unwrap_err();
    assert!(matches!(e, CampaignError::AlreadyExists { .. }), "{e}");
    assert_eq!(e.file(), dir);
    assert!(
        e.to_string().contains("exists, pass --force to overwrite"),
        "{e}"
    );
    assert_eq!(fs::read(dir.join("campaign.toml")).unwrap(), before);
    assert!(leftovers(tmp.path()).is_empty());
}

#[test]
fn write_overwrite_replaces_folder() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("out");
    let c = sample_campaign();
    write_campaign(&dir, &c, false).unwrap();
    fs::write(dir.join("stray.txt"), "old").unwrap();

    let mut other = c.clone();
    other.name = Some("other".to_owned());
    other.records.truncate(2);
    write_campaign(&dir, &other, true).unwrap();
    let back = read_campaign(&dir).unwrap();
    assert_bit_equal(&other, &back);
    assert!(!dir.join("stray.txt").exists());
    assert!(!dir.join("records/r002.csv").exists());
    assert!(
        leftovers(tmp.path()).is_empty(),
        "{:?}",
        leftovers(tmp.path())
    );
}

#[test]
fn write_into_existing_empty_folder() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("out");
    fs::create_dir(&dir).unwrap();
    write_campaign(&dir, &sample_campaign(), false).unwrap();
    assert_bit_equal(&sample_campaign(), &read_campaign(&dir).unwrap());
}

#[test]
fn write_refuses_to_replace_a_folder_that_is_not_a_campaign() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("home");
    fs::create_dir(&dir).unwrap();
    fs::write(dir.join("thesis.tex"), "precious").unwrap();
    let e = write_campaign(&dir, &sample_campaign(), true).unwrap_err();
    assert_eq!(e.file(), dir);
    assert!(
        e.to_string().contains("does not look like a campaign"),
        "{e}"
    );
    assert_eq!(
        fs::read_to_string(dir.join("thesis.tex")).unwrap(),
        "precious"
    );
    let file = tmp.path().join("file");
    fs::write(&file, "x").unwrap();
    assert!(write_campaign(&file, &sample_campaign(), true).is_err());
    assert_eq!(fs::read_to_string(&file).unwrap(), "x");
}

#[test]
fn failed_write_leaves_nothing_behind() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("out");

    // An invalid record path: caught before anything is created.
    let mut bad = sample_campaign();
    bad.records[2].meta.file = PathBuf::from("../escape.csv");
    let e = write_campaign(&dir, &bad, false).unwrap_err();
    check(
        &e,
        &dir.join("campaign.toml"),
        None,
        Some(2),
        Some("file"),
        "leaves it",
    );
    assert!(!dir.exists());
    assert!(!tmp.path().join("escape.csv").exists());

    // Bad data in the last record: caught while the temporary folder is half written.
    let mut bad = sample_campaign();
    bad.records[2].zmp_x[7] = f64::NAN;
    let e = write_campaign(&dir, &bad, false).unwrap_err();
    check(
        &e,
        &dir.join("records/r002.csv"),
        Some(9),
        Some(2),
        Some("zmp_x"),
        "NaN",
    );
    assert!(!dir.exists());
    assert!(
        leftovers(tmp.path()).is_empty(),
        "{:?}",
        leftovers(tmp.path())
    );

    // A failed overwrite keeps the old campaign intact.
    let good = sample_campaign();
    write_campaign(&dir, &good, false).unwrap();
    let mut bad = sample_campaign();
    bad.records[1].t[40] = bad.records[1].t[39];
    let e = write_campaign(&dir, &bad, true).unwrap_err();
    check(
        &e,
        &dir.join("records/r001.csv"),
        Some(42),
        Some(1),
        Some("t"),
        "strictly increasing",
    );
    assert_bit_equal(&good, &read_campaign(&dir).unwrap());
    assert!(
        leftovers(tmp.path()).is_empty(),
        "{:?}",
        leftovers(tmp.path())
    );
}

#[test]
fn write_validates_metadata_and_shapes() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("out");
    let manifest = dir.join("campaign.toml");

    let mut c = sample_campaign();
    c.records[1].meta.amplitude = 0.0;
    let e = write_campaign(&dir, &c, false).unwrap_err();
    check(&e, &manifest, None, Some(1), Some("amplitude"), "positive");

    let mut c = sample_campaign();
    c.records[2].meta.file = c.records[0].meta.file.clone();
    let e = write_campaign(&dir, &c, false).unwrap_err();
    check(&e, &manifest, None, Some(2), Some("file"), "records[0]");

    let mut c = sample_campaign();
    c.records[0].y_cr.pop();
    let e = write_campaign(&dir, &c, false).unwrap_err();
    check(
        &e,
        &dir.join("records/r000.csv"),
        None,
        Some(0),
        Some("y_cr"),
        "49 values",
    );

    let mut c = sample_campaign();
    c.records[1].extra[0].0 = "t".to_owned();
    let e = write_campaign(&dir, &c, false).unwrap_err();
    check(
        &e,
        &dir.join("records/r001.csv"),
        Some(1),
        Some(1),
        Some("t"),
        "duplicate",
    );

    let mut c = sample_campaign();
    c.sample_rate_hz = Some(100.0);
    let e = write_campaign(&dir, &c, false).unwrap_err();
    check(
        &e,
        &dir.join("records/r000.csv"),
        None,
        Some(0),
        Some("t"),
        "sample_rate_hz",
    );

    assert!(!dir.exists());
    assert!(leftovers(tmp.path()).is_empty());
}

#[test]
fn first_error_in_record_order_is_reported() {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("many");
    let mut c = sample_campaign();
    let base = c.records[0].clone();
    c.records = (0..24)
        .map(|i| {
            let mut r = base.clone();
            r.meta.file = PathBuf::from(format!("records/r{i:03}.csv"));
            r
        })
        .collect();
    write_campaign(&dir, &c, false).unwrap();
    fs::write(dir.join("records/r005.csv"), "t,x_cr\n").unwrap();
    fs::write(dir.join("records/r017.csv"), "garbage").unwrap();
    fs::remove_file(dir.join("records/r020.csv")).unwrap();
    for _ in 0..20 {
        let e = read_campaign(&dir).unwrap_err();
        assert_eq!(e.record(), Some(5), "{e}");
        assert_eq!(e.field(), Some("y_cr"), "{e}");
    }
}
