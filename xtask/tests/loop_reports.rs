//! The pages `cargo xtask loop` writes pass the report checks of
//! `validation/report/tests/support/html.rs`: the diagnosis report (no markup shown
//! as text, every reference beside it, every figure an SVG that parses, no heading without
//! content, no empty table) and the waterfall `history.svg`.
//!
//! The campaign: the seed's SILO2 model with a 40 ms servo delay, one operating point, two
//! amplitudes, five frequencies, seed 7 (20 records; the loop's one search finds the delay, a
//! few seconds).

#[path = "../../validation/report/tests/support/html.rs"]
mod html;
mod support;

use std::path::Path;
use support::{ok, xtask};

#[test]
fn the_loops_pages_are_fit_to_be_read() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    std::fs::write(
        dir.join("design.toml"),
        "operating_points = [[0.0, 0.0]]\namplitudes = [0.003, 0.008]\n\
         omegas = [0.5, 1.5, 4.0, 9.0, 14.0]\nexcited = [\"x\", \"y\"]\n\
         sample_rate_hz = 200.0\ntransient_s = 3.0\nperiods = 4\nmin_steady_s = 8.0\n\
         zmp_noise_std = 0.0005\nquantisation = 0.0001\nseed = 7\n",
    )
    .unwrap();
    let paper = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/params/silo2-paper.toml");
    let truth = std::fs::read_to_string(paper).unwrap() + "\n[time_delay]\ndelay = 0.04\n";
    std::fs::write(dir.join("truth.toml"), truth).unwrap();
    let sim = [
        "simulate",
        "--model",
        "truth.toml",
        "--design",
        "design.toml",
        "--out",
        "camp",
    ];
    ok(xtask(&sim, dir), "simulate");
    let out = ok(
        xtask(&["loop", "camp", "--out", "lp", "--json"], dir),
        "loop",
    );
    let summary: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(summary["found"], serde_json::json!(["time_delay"]));
    let reports: Vec<&str> = summary["reports"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r.as_str().unwrap())
        .collect();
    // One search, one diagnosis: its report names the delay.
    assert_eq!(reports.len(), 1, "{reports:?}");
    for r in &reports {
        html::check_page(&dir.join(r));
    }
    // The diagnosis found the delay: its parameters one per line, its "Before and after" the
    // two models over the measured points.
    let first = html::check_page(&dir.join(reports[0]));
    let params = first.select("td.nw");
    assert_eq!(html::within(&params[..1], "br").len(), 1);
    let ba = first.section("Before and after");
    let legend = html::text(&html::within(&ba, "svg")[0]);
    assert!(
        legend.contains("model as given") && legend.contains("with the effects found"),
        "{legend}"
    );
    let history = dir.join(summary["history"].as_str().unwrap());
    html::check_figure(&history).unwrap();
    let svg = std::fs::read_to_string(history).unwrap();
    for bar in ["identified", "+time_delay", "noise floor"] {
        assert!(svg.contains(bar), "history.svg has no {bar:?}");
    }
}
