//! The `zmp-campaign/1` reader and writer: round trip, malformed inputs, atomic writing.

use std::fs;
use std::path::{Path, PathBuf};
use tempfile::TempDir;
use zmp_models::Axis;
use zmp_validation::campaign::{
    read_campaign, read_manifest, write_campaign, Campaign, CampaignError, Part, Record,
    RecordMeta, FORMAT,
};

// ---------------------------------------------------------------------------------------------
// Fixtures

/// A valid campaign folder with 4 records (so `records[3]` is not the first or the only one),
/// 10 rows each at 100 Hz, and an extra column `x_c`.
struct Fixture {
    _tmp: TempDir,
    dir: PathBuf,
}

const HEADER: &str =
    "format = \"zmp-campaign/1\"\nname = \"fixture\"\nrobot = \"SILO2\"\nsample_rate_hz = 100.0\n";

fn record_table(i: usize) -> String {
    format!(
        "file = \"records/r{i:03}.csv\"\nexcited = \"{}\"\nomega = {}\namplitude = 0.004\noperating_point = {{ x = 0.0, y = 0.01 }}\n",
        ["x", "y"][i % 2],
        1.0 + i as f64,
    )
}

/// `campaign.toml` with `header` and 4 records, the last one's body replaced by `rec3`.
fn manifest_text(header: &str, rec3: &str) -> String {
    let mut s = header.to_owned();
    for i in 0..3 {
        s.push_str("\n[[records]]\n");
        s.push_str(&record_table(i));
    }
    s.push_str("\n[[records]]\n");
    s.push_str(rec3);
    s
}

/// CSV rows as cells, header first; data row k is on line k + 2.
fn csv_cells(rows: usize) -> Vec<Vec<String>> {
    let mut out = vec!["t,x_cr,y_cr,zmp_x,zmp_y,x_c"
        .split(',')
        .map(str::to_owned)
        .collect::<Vec<_>>()];
    for k in 0..rows {
        let t = k as f64 * 0.01;
        out.push(
            [
                t,
                0.004 * (1.5 * t).sin(),
                0.01,
                0.003 * (1.5 * t).sin(),
                0.01,
                0.0039 * (1.5 * t).sin(),
            ]
            .iter()
            .map(|v| v.to_string())
            .collect(),
        );
    }
    out
}

fn join(cells: &[Vec<String>]) -> String {
    let mut s = String::new();
    for row in cells {
        s.push_str(&row.join(","));
        s.push('\n');
    }
    s
}

impl Fixture {
    fn new() -> Fixture {
        let tmp = TempDir::new().unwrap();
        let dir = tmp.path().join("campaign");
        fs::create_dir_all(dir.join("records")).unwrap();
        let f = Fixture { _tmp: tmp, dir };
        f.set_manifest(&manifest_text(HEADER, &record_table(3)));
        for i in 0..4 {
            f.set_csv(i, &join(&csv_cells(10)));
        }
        f
    }

    fn set_manifest(&self, text: &str) {
        fs::write(self.dir.join("campaign.toml"), text).unwrap();
    }

    fn set_rec3(&self, rec3: &str) {
        self.set_manifest(&manifest_text(HEADER, rec3));
    }

    fn set_csv(&self, i: usize, text: &str) {
        fs::write(self.csv(i), text).unwrap();
    }

    /// Record 3's CSV with cell (`row` = line - 1, `col`) replaced.
    fn set_cell3(&self, line: usize, col: usize, value: &str) {
        let mut cells = csv_cells(10);
        cells[line - 1][col] = value.to_owned();
        self.set_csv(3, &join(&cells));
    }

    fn csv(&self, i: usize) -> PathBuf {
        self.dir.join(format!("records/r{i:03}.csv"))
    }

    fn manifest(&self) -> PathBuf {
        self.dir.join("campaign.toml")
    }

    fn read_err(&self) -> CampaignError {
        match read_campaign(&self.dir) {
            Ok(_) => panic!("expected an error"),
            Err(e) => e,
        }
    }
}

/// Asserts the structured location of `e` and that its Display shows it.
#[track_caller]
fn check(
    e: &CampaignError,
    file: &Path,
    line: Option<usize>,
    record: Option<usize>,
    field: Option<&str>,
    message_contains: &str,
) {
    let shown = e.to_string();
    eprintln!("{shown}");
    assert_eq!(e.file(), file, "file of {shown}");
    assert_eq!(e.line(), line, "line of {shown}");
    assert_eq!(e.record(), record, "record of {shown}");
    assert_eq!(e.field(), field, "field of {shown}");
    let mut prefix = file.display().to_string();
    if let Some(line) = line {
        prefix.push_str(&format!(":{line}"));
    }
    assert!(
        shown.starts_with(&prefix),
        "{shown:?} should start with {prefix:?}"
    );
    if let Some(field) = field {
        let located = match (e.part(), record) {
            (Some(Part::Data), _) => format!("column {field}"),
            (_, Some(i)) => format!("records[{i}].{field}"),
            (_, None) => field.to_owned(),
        };
        assert!(
            shown.contains(&located),
            "{shown:?} should name {located:?}"
        );
    } else if let (Some(Part::Manifest), Some(i)) = (e.part(), record) {
        assert!(shown.contains(&format!("records[{i}]")), "{shown:?}");
    }
    assert!(
        shown.contains(message_contains),
        "{shown:?} should contain {message_contains:?}"
    );
}

fn sample_campaign() -> Campaign {
    let mut seed = 0x9E37_79B9_7F4A_7C15_u64;
    let mut noise = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let mut records = Vec::new();
    for (i, (excited, omega, n)) in [(Axis::X, 0.7, 50), (Axis::Y, 1.3, 80), (Axis::X, 12.5, 33)]
        .into_iter()
        .enumerate()
    {
        let dt = 0.005;
        let t: Vec<f64> = (0..n).map(|k| 0.1 + k as f64 * dt).collect();
        let x_cr: Vec<f64> = t.iter().map(|t| 0.02 + 0.004 * (omega * t).sin()).collect();
        let y_cr: Vec<f64> = t.iter().map(|_| -0.0).collect();
        let zmp_x: Vec<f64> = x_cr.iter().map(|x| x * 0.9 + 1e-4 * noise()).collect();
        let zmp_y: Vec<f64> = t.iter().map(|_| 1e-7 * noise()).collect();
        let mut extra = Vec::new();
        if i == 1 {
            extra.push((
                "x_c".to_owned(),
                x_cr.iter().map(|x| x + 1e-20 * noise()).collect(),
            ));
            extra.push((
                "f_z".to_owned(),
                t.iter().map(|_| 1e300 * noise()).collect(),
            ));
        }
        records.push(Record {
            meta: RecordMeta {
                file: PathBuf::from(format!("records/r{i:03}.csv")),
                excited,
                omega,
                amplitude: 0.004,
                operating_point: [0.02, 0.1 + 0.2],
            },
            t,
            x_cr,
            y_cr,
            zmp_x,
            zmp_y,
            extra,
        });
    }
    Campaign {
        name: Some("round \"trip\" \\ test\nwith é".to_owned()),
        robot: Some("SILO2".to_owned()),
        sample_rate_hz: Some(200.0),
        records,
    }
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn assert_bit_equal(a: &Campaign, b: &Campaign) {
    assert_eq!(a.name, b.name);
    assert_eq!(a.robot, b.robot);
    assert_eq!(
        a.sample_rate_hz.map(f64::to_bits),
        b.sample_rate_hz.map(f64::to_bits)
    );
    assert_eq!(a.records.len(), b.records.len());
    for (ra, rb) in a.records.iter().zip(&b.records) {
        assert_eq!(ra.meta.file, rb.meta.file);
        assert_eq!(ra.meta.excited, rb.meta.excited);
        assert_eq!(ra.meta.omega.to_bits(), rb.meta.omega.to_bits());
        assert_eq!(ra.meta.amplitude.to_bits(), rb.meta.amplitude.to_bits());
        assert_eq!(
            bits(&ra.meta.operating_point),
            bits(&rb.meta.operating_point)
        );
        for name in ["t", "x_cr", "y_cr", "zmp_x", "zmp_y"] {
            assert_eq!(
                bits(ra.column(name).unwrap()),
                bits(rb.column(name).unwrap()),
                "{name}"
            );
        }
        assert_eq!(ra.extra.len(), rb.extra.len());
        for ((na, va), (nb, vb)) in ra.extra.iter().zip(&rb.extra) {
            assert_eq!(na, nb);
            assert_eq!(bits(va), bits(vb), "{na}");
        }
    }
    assert_eq!(a, b);
}

/// Names in `parent` that look like leftovers of an interrupted write.
fn leftovers(parent: &Path) -> Vec<String> {
    fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".campaign-"))
        .collect()
}

// ---------------------------------------------------------------------------------------------
// Reading valid campaigns

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

// ---------------------------------------------------------------------------------------------
// Round trip and writing

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

// ---------------------------------------------------------------------------------------------
// Malformed campaign.toml

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

// ---------------------------------------------------------------------------------------------
// Malformed record CSV

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
