//! Fixtures: a valid campaign folder to break one piece at a time, a campaign to write, and
//! the assertions on errors and on bit-exact equality.

use std::fs;
use std::path::{Path, PathBuf};
use tempfile::TempDir;
use zmp_campaign::{read_campaign, Campaign, CampaignError, Part, Record, RecordMeta};
use zmp_models::Axis;

/// A valid campaign folder with 4 records (so `records[3]` is not the first or the only one),
/// 10 rows each at 100 Hz, and an extra column `x_c`.
pub(crate) struct Fixture {
    _tmp: TempDir,
    pub(crate) dir: PathBuf,
}

pub(crate) const HEADER: &str =
    "format = \"zmp-campaign/1\"\nname = \"fixture\"\nrobot = \"SILO2\"\nsample_rate_hz = 100.0\n";

pub(crate) fn record_table(i: usize) -> String {
    format!(
        "file = \"records/r{i:03}.csv\"\nexcited = \"{}\"\nomega = {}\namplitude = 0.004\noperating_point = {{ x = 0.0, y = 0.01 }}\n",
        ["x", "y"][i % 2],
        1.0 + i as f64,
    )
}

/// `campaign.toml` with `header` and 4 records, the last one's body replaced by `rec3`.
pub(crate) fn manifest_text(header: &str, rec3: &str) -> String {
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
pub(crate) fn csv_cells(rows: usize) -> Vec<Vec<String>> {
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

pub(crate) fn join(cells: &[Vec<String>]) -> String {
    let mut s = String::new();
    for row in cells {
        s.push_str(&row.join(","));
        s.push('\n');
    }
    s
}

impl Fixture {
    pub(crate) fn new() -> Fixture {
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

    pub(crate) fn set_manifest(&self, text: &str) {
        fs::write(self.dir.join("campaign.toml"), text).unwrap();
    }

    pub(crate) fn set_rec3(&self, rec3: &str) {
        self.set_manifest(&manifest_text(HEADER, rec3));
    }

    pub(crate) fn set_csv(&self, i: usize, text: &str) {
        fs::write(self.csv(i), text).unwrap();
    }

    /// Record 3's CSV with cell (`row` = line - 1, `col`) replaced.
    pub(crate) fn set_cell3(&self, line: usize, col: usize, value: &str) {
        let mut cells = csv_cells(10);
        cells[line - 1][col] = value.to_owned();
        self.set_csv(3, &join(&cells));
    }

    pub(crate) fn csv(&self, i: usize) -> PathBuf {
        self.dir.join(format!("records/r{i:03}.csv"))
    }

    pub(crate) fn manifest(&self) -> PathBuf {
        self.dir.join("campaign.toml")
    }

    pub(crate) fn read_err(&self) -> CampaignError {
        match read_campaign(&self.dir) {
            Ok(_) => panic!("expected an error"),
            Err(e) => e,
        }
    }
}

/// Asserts the structured location of `e` and that its Display shows it.
#[track_caller]
pub(crate) fn check(
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

pub(crate) fn sample_campaign() -> Campaign {
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

pub(crate) fn assert_bit_equal(a: &Campaign, b: &Campaign) {
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
pub(crate) fn leftovers(parent: &Path) -> Vec<String> {
    fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        // Temporary entries: `.NAME.zmp-tmp-PID-N` (and the older `.campaign-*`).
        .filter(|n| n.starts_with(".campaign-") || n.contains(".zmp-tmp-"))
        .collect()
}
