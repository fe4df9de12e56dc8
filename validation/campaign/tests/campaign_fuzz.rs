//! Property tests of the campaign reader: arbitrary or mutated input never panics, and written
//! campaigns read back bit-exactly.

use proptest::prelude::*;
use std::fs;
use std::path::{Path, PathBuf};
use tempfile::TempDir;
use zmp_campaign::{
    parse_manifest, parse_record, read_campaign, write_campaign, Campaign, Record, RecordMeta,
};
use zmp_models::Axis;

const MANIFEST: &str = "format = \"zmp-campaign/1\"\nname = \"fuzz\"\nsample_rate_hz = 100.0\n\n\
[[records]]\nfile = \"records/r000.csv\"\nexcited = \"x\"\nomega = 1.5\namplitude = 0.004\n\
operating_point = { x = 0.0, y = 0.01 }\n";

fn valid_csv() -> String {
    let mut s = String::from("t,x_cr,y_cr,zmp_x,zmp_y,x_c\n");
    for k in 0..12 {
        let t = k as f64 * 0.01;
        let x = 0.004 * (1.5 * t).sin();
        s.push_str(&format!("{t},{x},0.01,{},{},{}\n", 0.9 * x, 0.01, x));
    }
    s
}

/// A campaign folder with one record; the manifest and the CSV are replaced per case.
fn folder() -> (TempDir, PathBuf) {
    let tmp = TempDir::new().unwrap();
    let dir = tmp.path().join("c");
    fs::create_dir_all(dir.join("records")).unwrap();
    fs::write(dir.join("campaign.toml"), MANIFEST).unwrap();
    fs::write(dir.join("records/r000.csv"), valid_csv()).unwrap();
    (tmp, dir)
}

fn meta() -> RecordMeta {
    RecordMeta {
        file: PathBuf::from("records/r000.csv"),
        excited: Axis::X,
        omega: 1.5,
        amplitude: 0.004,
        operating_point: [0.0, 0.01],
    }
}

#[derive(Debug, Clone)]
enum Edit {
    Set(usize, u8),
    Insert(usize, u8),
    Delete(usize),
}

fn edits() -> impl Strategy<Value = Vec<Edit>> {
    // Bytes biased towards the ones that matter to CSV and TOML.
    let byte = prop_oneof![
        any::<u8>(),
        prop::sample::select(b",\n\r\"=[]{}.-+e0123456789 #NaninfxyzT".to_vec()),
    ];
    let edit = prop_oneof![
        (any::<usize>(), byte.clone()).prop_map(|(p, b)| Edit::Set(p, b)),
        (any::<usize>(), byte).prop_map(|(p, b)| Edit::Insert(p, b)),
        any::<usize>().prop_map(Edit::Delete),
    ];
    prop::collection::vec(edit, 1..8)
}

fn apply(text: &str, edits: &[Edit]) -> Vec<u8> {
    let mut b = text.as_bytes().to_vec();
    for e in edits {
        match *e {
            Edit::Set(p, v) if !b.is_empty() => {
                let n = b.len();
                b[p % n] = v;
            }
            Edit::Insert(p, v) => {
                let n = b.len() + 1;
                b.insert(p % n, v);
            }
            Edit::Delete(p) if !b.is_empty() => {
                let n = b.len();
                b.remove(p % n);
            }
            _ => {}
        }
    }
    b
}

/// Reading must return (Ok or Err), and an Err must render and name a file in the folder.
fn read_without_panic(dir: &Path) {
    match read_campaign(dir) {
        Ok(c) => {
            for r in &c.records {
                assert_eq!(r.t.len(), r.zmp_y.len());
                assert!(r.len() >= 2);
            }
        }
        Err(e) => {
            let shown = e.to_string();
            assert!(e.file().starts_with(dir), "{shown}");
            assert!(!e.message().is_empty(), "{shown}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn arbitrary_bytes_as_manifest(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let (_tmp, dir) = folder();
        fs::write(dir.join("campaign.toml"), &bytes).unwrap();
        read_without_panic(&dir);
        if let Ok(text) = std::str::from_utf8(&bytes) {
            let _ = parse_manifest(text, Path::new("campaign.toml"));
        }
    }

    #[test]
    fn arbitrary_bytes_as_record_csv(bytes in prop::collection::vec(any::<u8>(), 0..600)) {
        let (_tmp, dir) = folder();
        fs::write(dir.join("records/r000.csv"), &bytes).unwrap();
        read_without_panic(&dir);
        let _ = parse_record(&bytes, Path::new("r.csv"), 0, meta(), None);
    }

    #[test]
    fn mutated_manifest(edits in edits()) {
        let (_tmp, dir) = folder();
        fs::write(dir.join("campaign.toml"), apply(MANIFEST, &edits)).unwrap();
        read_without_panic(&dir);
    }

    #[test]
    fn mutated_record_csv(edits in edits()) {
        let (_tmp, dir) = folder();
        let bytes = apply(&valid_csv(), &edits);
        fs::write(dir.join("records/r000.csv"), &bytes).unwrap();
        read_without_panic(&dir);
        let _ = parse_record(&bytes, Path::new("r.csv"), 0, meta(), Some(100.0));
    }
}

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<u64>()
            .prop_map(f64::from_bits)
            .prop_filter("finite", |v| v.is_finite()),
        -1.0e3..1.0e3f64,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Any finite values (other than the uniform time axis) round-trip bit-exactly.
    #[test]
    fn write_read_round_trip(
        t0 in -1.0e4..1.0e4f64,
        dt in 1e-4..1.0f64,
        rows in prop::collection::vec(prop::array::uniform5(finite()), 2..40),
        omega in 1e-3..1e3f64,
        amplitude in 1e-9..1.0f64,
        op in prop::array::uniform2(finite()),
        name in proptest::option::of(".*"),
    ) {
        let n = rows.len();
        let column = |k: usize| rows.iter().map(|r| r[k]).collect::<Vec<f64>>();
        let record = Record {
            meta: RecordMeta {
                file: PathBuf::from("data/one.csv"),
                excited: Axis::Y,
                omega,
                amplitude,
                operating_point: op,
            },
            t: (0..n).map(|k| t0 + k as f64 * dt).collect(),
            x_cr: column(0),
            y_cr: column(1),
            zmp_x: column(2),
            zmp_y: column(3),
            extra: vec![("f".to_owned(), column(4))],
        };
        let c = Campaign { name, robot: None, sample_rate_hz: Some(1.0 / dt), records: vec![record] };
        let tmp = TempDir::new().unwrap();
        let dir = tmp.path().join("rt");
        write_campaign(&dir, &c, false).unwrap();
        let back = read_campaign(&dir).unwrap();
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let (a, b) = (&c.records[0], &back.records[0]);
        for name in ["t", "x_cr", "y_cr", "zmp_x", "zmp_y", "f"] {
            prop_assert_eq!(bits(a.column(name).unwrap()), bits(b.column(name).unwrap()));
        }
        prop_assert_eq!(bits(&a.meta.operating_point), bits(&b.meta.operating_point));
        prop_assert_eq!(a.meta.omega.to_bits(), b.meta.omega.to_bits());
        prop_assert_eq!(&c.name, &back.name);
    }
}
