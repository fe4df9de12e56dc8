//! A record's header is read in time linear in its width (issue 53, defect 6: 100 000 columns
//! took 23.5 s, a million did not end in a minute). Criterion times the parse of records with
//! headers of 10 000, 100 000 and 1 000 000 columns (two data rows each): linear means the
//! million-column parse takes about ten times the hundred-thousand one, and the target is
//! under a second on two cores. After criterion, the million-column parse is timed five more
//! times and its median printed; with `ZMP_UPDATE_DOCS=1` it is written into
//! `docs/src/files-and-safety.md` (section `header-bench`).

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use zmp_campaign::{parse_record, RecordMeta};
use zmp_models::Axis;

fn meta() -> RecordMeta {
    RecordMeta {
        file: PathBuf::from("wide.csv"),
        excited: Axis::X,
        omega: 1.0,
        amplitude: 0.005,
        operating_point: [0.0, 0.0],
    }
}

/// A record whose header has the five required columns and `width - 5` extra ones (distinct
/// names), and two rows of numbers.
fn wide(width: usize) -> Vec<u8> {
    let mut b = b"t,x_cr,y_cr,zmp_x,zmp_y".to_vec();
    for k in 5..width {
        b.extend_from_slice(format!(",c{k}").as_bytes());
    }
    for t in ["0", "0.01"] {
        b.push(b'\n');
        b.extend_from_slice(t.as_bytes());
        for _ in 1..width {
            b.extend_from_slice(b",1.5");
        }
    }
    b.push(b'\n');
    b
}

fn parse(bytes: &[u8]) -> usize {
    let r = parse_record(bytes, Path::new("wide.csv"), 0, meta(), None).expect("parses");
    r.extra.len()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("campaign_header");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    for width in [10_000, 100_000, 1_000_000] {
        let bytes = wide(width);
        assert_eq!(parse(&bytes), width - 5);
        g.bench_function(format!("columns_{width}"), |b| {
            b.iter(|| black_box(parse(black_box(&bytes))))
        });
    }
    g.finish();
    let bytes = wide(1_000_000);
    let mut s: Vec<f64> = (0..5)
        .map(|_| {
            let t = Instant::now();
            black_box(parse(&bytes));
            t.elapsed().as_secs_f64()
        })
        .collect();
    s.sort_by(f64::total_cmp);
    let median = s[2];
    let line = format!(
        "A record with a header of 1 000 000 columns (and two rows) parses in {median:.2} s \
         (median of five, after criterion's samples; target: under 1 s).\n"
    );
    eprint!("campaign_header: {line}");
    if std::env::var(zmp_files::sections::UPDATE_VAR).is_ok_and(|v| v == "1") {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/src/files-and-safety.md");
        zmp_files::sections::replace_sections(&path, &[("header-bench", line)])
            .expect("docs page written");
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
