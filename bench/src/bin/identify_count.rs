//! The identification pipeline once, for instruction counts under callgrind (see
//! `bench/README.md`, "Identification"):
//!
//! ```text
//! target/release/identify_count write /tmp/id          # simulate + write the campaign once
//! valgrind --tool=callgrind --callgrind-out-file=/tmp/cg.out \
//!     target/release/identify_count run /tmp/id/virtual-silo2
//! ```
//!
//! `run` reads the campaign and identifies it (what the criterion bench `identify` times) and
//! prints `a11` and the wall-clock time; `read` only reads it; `phases` prints the wall time of
//! reading, of the per-record analysis and of the whole identification.

use std::path::Path;
use std::time::Instant;
use zmp_bench::identify::{pipeline, write_reference_campaign};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let usage =
        "usage: identify_count write PARENT_DIR | run CAMPAIGN_DIR | read CAMPAIGN_DIR | phases CAMPAIGN_DIR";
    let (mode, dir) = match args.as_slice() {
        [_, mode, dir] => (mode.as_str(), Path::new(dir)),
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    };
    let t = Instant::now();
    match mode {
        "write" => println!("{}", write_reference_campaign(dir).display()),
        "run" => println!("a11 {}", pipeline(dir)),
        "phases" => {
            // Wall time of each phase, for finding where the time goes; three rounds in one
            // process (the first pays for fresh memory, the others reuse it).
            for _ in 0..3 {
                let t0 = Instant::now();
                let camp = zmp_campaign::read_campaign(dir).expect("read");
                let t1 = Instant::now();
                let opts = zmp_identify::IdentifyOptions::default();
                let fits = zmp_identify::analyse_records(&camp, &opts, &|_| {});
                let t2 = Instant::now();
                let id = zmp_identify::identify(&camp, &opts).expect("identify");
                let t3 = Instant::now();
                eprintln!(
                "read {:.1} ms, analyse {:.1} ms, identify (analyse again + rest) {:.1} ms; {} fits, a11 {}, limit {:?} +- {:?}",
                (t1 - t0).as_secs_f64() * 1e3,
                (t2 - t1).as_secs_f64() * 1e3,
                (t3 - t2).as_secs_f64() * 1e3,
                fits.len(),
                id.a[0][0].value,
                id.saturation.limit,
                id.saturation.limit_stderr
            );
            }
        }
        "read" => {
            let camp = zmp_campaign::read_campaign(dir).expect("read");
            println!("records {}", camp.records.len());
        }
        _ => {
            eprintln!("{usage}");
            std::process::exit(2);
        }
    }
    eprintln!("{:.3} s", t.elapsed().as_secs_f64());
}
