//! Identification and diagnosis of the small campaign (`zmp_bench::pipeline`, 16 records, one
//! thread), for instruction counts under callgrind (`cargo xtask bench` runs it):
//!
//! ```text
//! target/release/pipeline_count write DIR       # simulate, write, identify once (not counted)
//! valgrind --tool=callgrind --toggle-collect='*count_loop*' \
//!     target/release/pipeline_count identify DIR
//! valgrind --tool=callgrind --toggle-collect='*count_loop*' \
//!     target/release/pipeline_count diagnose DIR
//! ```
//!
//! `identify` counts reading the campaign from disk and identifying it; `diagnose` reads the
//! campaign and the identified model first (not counted), then counts the diagnosis. Each
//! prints what it found, so a run that silently did nothing cannot pass for a fast one.

use std::hint::black_box;
use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;
use zmp_bench::pipeline::{diagnose_campaign, identify_read, write, CAMPAIGN, MODEL};
use zmp_campaign::{read_campaign, Campaign};
use zmp_models::ModelSpec;

#[inline(never)]
fn count_loop_identify(dir: &Path) -> anyhow::Result<String> {
    let id = identify_read(black_box(dir))?;
    Ok(format!(
        "identified: a11 {:.6}, b11 {:.6}",
        id.a[0][0].value, id.b[0][0].value
    ))
}

#[inline(never)]
fn count_loop_diagnose(camp: &Campaign, model: &ModelSpec) -> anyhow::Result<String> {
    let d = diagnose_campaign(black_box(camp), black_box(model))?;
    let first = d
        .findings
        .first()
        .map_or("none".to_string(), |f| f.effect.to_string());
    Ok(format!("diagnosed: verdict {}, first {first}", d.verdict))
}

fn run(mode: &str, dir: &Path) -> anyhow::Result<String> {
    match mode {
        "write" => {
            let (camp, model) = write(dir)?;
            Ok(format!("wrote {} and {}", camp.display(), model.display()))
        }
        "identify" => count_loop_identify(&dir.join(CAMPAIGN)),
        "diagnose" => {
            let camp = read_campaign(&dir.join(CAMPAIGN))?;
            let path = dir.join(MODEL);
            let text = std::fs::read_to_string(&path)
                .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
            let model = ModelSpec::parse(&text, &path.display().to_string())?;
            count_loop_diagnose(&camp, &model)
        }
        other => anyhow::bail!("unknown mode {other:?}"),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().collect();
    let [_, mode, dir] = args.as_slice() else {
        eprintln!("usage: pipeline_count write|identify|diagnose DIR");
        return ExitCode::from(2);
    };
    let t = Instant::now();
    match run(mode, Path::new(dir)) {
        Ok(what) => {
            println!("{what}");
            eprintln!("{:.3} s (wall clock)", t.elapsed().as_secs_f64());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("pipeline_count {mode}: {e:#}");
            ExitCode::FAILURE
        }
    }
}
