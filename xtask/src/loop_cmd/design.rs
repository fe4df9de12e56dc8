//! The loop's last step when it ends `ambiguous`: the experiment that decides between the
//! set's structures (`zmp_diagnose::design`, what `cargo xtask design-next` runs), designed on
//! the models the loop wrote for them, written as `design-next.toml` into the loop's folder.

use super::{LoopArgs, OwnFiles};
use crate::design_next::{json, print_text};
use crate::simulate::progress_bar;
use anyhow::Result;
use std::path::{Path, PathBuf};
use zmp_campaign::Campaign;
use zmp_diagnose::design::{design_next_observed, to_toml, DesignOptions, Rival};
use zmp_diagnose::iterate::LoopResult;

/// The design file's name in the loop's folder.
pub const DESIGN_FILE: &str = "design-next.toml";

/// Most structures a design separates (`design_next` takes two or three rivals; the set holds
/// at most three).
const MAX_RIVALS: usize = 3;

/// Designs the experiment that decides between `models` (the set's structures as the loop
/// fitted and wrote them, best first: at most three, what `design_next` separates) on the
/// loop's campaign, writes it into `out` (listed in the folder's marker; never over a file
/// without `force`), and says what it predicts. Returns the `design_next` object of the
/// loop's `--json` (`design-next --json`'s, its `error` when no design could be made: the
/// loop's verdict stands either way).
pub(super) fn design_for_set(
    camp: &Campaign,
    a: &LoopArgs,
    r: &LoopResult,
    models: &[PathBuf],
    out: &Path,
    own: &mut OwnFiles,
    quiet: bool,
) -> Result<serde_json::Value> {
    let campaign = a.campaign;
    let rivals: Vec<Rival> = r
        .ambiguous_models()
        .into_iter()
        .zip(models)
        .take(MAX_RIVALS)
        .map(|(spec, path)| Rival {
            label: path.display().to_string(),
            spec: spec.clone(),
        })
        .collect();
    let opts = DesignOptions {
        campaign_path: campaign.display().to_string(),
        threads: zmp_campaign::par::budget(),
        decision: r.decision(),
        ..DesignOptions::default()
    };
    let pb = progress_bar(1, "designing", quiet);
    let started = std::time::Instant::now();
    // The loop's versions and reports are written: a design that fails (or a bug that panics
    // in it) is said, and the loop's verdict stands.
    let d = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        design_next_observed(camp, &r.observations, &rivals, &opts, &|m| {
            pb.set_message(m.to_string())
        })
    }));
    pb.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    let no_design = |e: String| {
        if !quiet {
            println!("   design-next: {e}");
        }
        Ok(serde_json::json!({ "design": null, "error": e }))
    };
    let d = match d {
        Ok(Ok(d)) => d,
        Ok(Err(e)) => return no_design(e.to_string()),
        Err(p) => {
            return no_design(format!(
                "it stopped on an internal error: {}",
                panic_text(p.as_ref())
            ))
        }
    };
    let file = out.join(DESIGN_FILE);
    let written = (!d.records.is_empty()).then_some(file.as_path());
    if let Some(file) = written {
        own.write_design(file, &to_toml(&d), a.force)?;
    }
    if !quiet {
        println!("the experiment that decides (design-next on the set's models):");
        print_text(&d, written, seconds);
    }
    let mut v = json(&d, campaign, written, seconds);
    v["predicted_sigma"] = serde_json::json!(d.min_sigma());
    Ok(v)
}

/// The report's line on the designed experiment: the records, their recording time and the
/// predicted separation, or why none was written.
pub(super) fn report_line(v: &serde_json::Value) -> String {
    let records = v["records"].as_array().map_or(0, |r| r.len());
    match (v["design"].as_str(), v["error"].as_str()) {
        (Some(file), _) => format!(
            "The experiment that decides: {records} record(s), {:.0} s of recording, written to \
             <code>{}</code>; predicted separation of the least separated pair {:.1} noise \
             standard deviations (target {}); measure them, append them to the campaign and run \
             the loop again.",
            v["total_time_s"].as_f64().unwrap_or(0.0),
            esc(file),
            v["predicted_sigma"].as_f64().unwrap_or(0.0),
            v["target_sigma"].as_f64().unwrap_or(0.0),
        ),
        (None, Some(e)) => format!("No experiment designed: {}.", esc(e)),
        (None, None) if v["decided"].as_bool() == Some(true) => {
            "No experiment designed: the campaign separates the set's structures already.".into()
        }
        (None, None) => {
            "No experiment designed: no record within the limits separates them.".into()
        }
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Adds `line` as a paragraph to the report page `html`, under its verdict (the paragraph of
/// class `v`; at the end of the page if it has none).
pub(super) fn add_to_report(html: &Path, line: &str) -> Result<()> {
    let page = zmp_files::read_limited_text(html, 64 << 20, "a report page")?;
    let at = page
        .find("<p class=\"v\">")
        .and_then(|v| page[v..].find("</p>").map(|e| v + e + "</p>".len()))
        .or_else(|| page.rfind("</body>"))
        .unwrap_or(page.len());
    let page = format!(
        "{}\n<p class=\"design-next\">{line}</p>{}",
        &page[..at],
        &page[at..]
    );
    zmp_files::write_file(html, zmp_files::Kind::Html, page.as_bytes(), true)?;
    Ok(())
}

/// The message of a caught panic.
fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    p.downcast_ref::<String>()
        .cloned()
        .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
        .unwrap_or_else(|| "(no message)".into())
}
