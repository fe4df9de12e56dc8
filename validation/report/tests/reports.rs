//! The identification, comparison and diagnosis reports pass the checks of `support/html.rs`
//! (no markup shown as text, every reference beside the report, every figure an SVG that
//! parses, no heading without content, no empty table), and show what they promise: the
//! diagnosis's parameters one per line, its "Before and after" the two models over the
//! measured points.
//!
//! The campaign: the seed's SILO2 model with a 40 ms servo delay (what the diagnosis must
//! find), two operating points, two amplitudes, five frequencies, seed 7: 40 records, a few
//! seconds for the three reports.

#[path = "support/html.rs"]
mod html;

use std::path::Path;
use std::sync::OnceLock;
use zmp_campaign::Campaign;
use zmp_diagnose::observe::Observation;
use zmp_diagnose::{diagnose, DiagnoseOptions};
use zmp_models::{Axis, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

const PAPER: &str = include_str!("../../../models/params/silo2-paper.toml");

fn paper() -> ModelSpec {
    ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap()
}

fn campaign() -> &'static Campaign {
    static C: OnceLock<Campaign> = OnceLock::new();
    C.get_or_init(|| {
        let truth = format!("{PAPER}\n[time_delay]\ndelay = 0.04\n");
        let truth = ModelSpec::parse(&truth, "truth.toml").unwrap();
        let design = ExperimentDesign {
            name: "delayed".into(),
            operating_points: vec![[0.0, 0.0], [0.02, 0.0]],
            amplitudes: vec![0.003, 0.008],
            omegas: vec![0.5, 1.5, 4.0, 9.0, 14.0],
            excited: vec![Axis::X, Axis::Y],
            sample_rate_hz: 200.0,
            transient_s: 3.0,
            periods: 4,
            min_steady_s: 8.0,
            zmp_noise_std: 0.0005,
            quantisation: 0.0001,
            seed: 7,
            ..ExperimentDesign::reference()
        };
        simulate_campaign(&truth, &design).unwrap()
    })
}

/// Every SVG file in `dir` (the figures the report also writes as files) parses.
fn figures_in(dir: &Path) -> usize {
    let mut n = 0;
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "svg") {
            html::check_figure(&p).unwrap_or_else(|e| panic!("{e}"));
            n += 1;
        }
    }
    n
}

#[test]
fn the_identification_report_is_fit_to_be_read() {
    let id = zmp_identify::identify(campaign(), &Default::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let files = zmp_report::identify::write_report(&id, dir.path(), false).unwrap();
    let page = html::check_page(&files.html);
    // The four Bode diagrams (in one figure) and the uncertainty database, inline; the files
    // (each diagram alone too) beside.
    assert_eq!(page.select("svg").len(), 2);
    assert_eq!(figures_in(dir.path()), 6, "4 Bode, all four, uncertainty");
    let params = page.section("Parameters");
    let names: Vec<String> = html::within(&params, "td.l")
        .iter()
        .map(html::text)
        .collect();
    assert!(names.contains(&"pendulum.a11".to_string()), "{names:?}");
    let records = page.section("Records");
    assert_eq!(
        html::within(&records, "tr").len(),
        campaign().records.len() + 1
    );
}

#[test]
fn the_comparison_report_is_fit_to_be_read() {
    let camp = campaign();
    let (obs, _) = zmp_diagnose::run::observe_campaign(camp, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let preds = zmp_diagnose::measure::predict(&paper(), &refs).unwrap();
    let cells = zmp_diagnose::cells::cells(&refs, &preds);
    let dir = tempfile::tempdir().unwrap();
    let html = zmp_report::diagnose::write_compare_report(
        camp,
        "delayed",
        "paper",
        &refs,
        &preds,
        &cells,
        &[3],
        dir.path(),
        false,
    )
    .unwrap();
    let page = html::check_page(&html);
    // The delay is found somewhere: the table of failing cells has rows.
    let fails = page.section("Where it fails");
    assert!(html::within(&fails, "td").len() > 8);
    // The record asked for, its time overlay and residual spectrum.
    let rec = page.section("Record 3");
    assert_eq!(html::within(&rec, "svg").len(), 2);
    assert_eq!(figures_in(dir.path()), 7);
}

#[test]
fn the_diagnosis_report_is_fit_to_be_read() {
    let camp = campaign();
    let opts = DiagnoseOptions {
        campaign_path: "delayed".into(),
        model_path: "paper.toml".into(),
        threads: 2,
        ..DiagnoseOptions::default()
    };
    let d = diagnose(camp, &paper(), &opts, &|_| {}).unwrap();
    assert_eq!(d.verdict, "time_delay", "{}", d.to_text());
    let dir = tempfile::tempdir().unwrap();
    let html = zmp_report::diagnose::write_diagnosis_report(camp, &d, dir.path(), false).unwrap();
    let page = html::check_page(&html);
    // The delay's two parameters (x and y), one per line: two texts, one <br> between them.
    let first = &page.select("td.nw")[0];
    assert_eq!(html::within(&[*first], "br").len(), 1, "{}", first.html());
    let lines: Vec<&str> = first.text().collect();
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert!(
        lines[0].starts_with("time_delay.x.delay = 0.0"),
        "{lines:?}"
    );
    assert!(
        lines[1].starts_with("time_delay.y.delay = 0.0"),
        "{lines:?}"
    );
    // "Before and after": the figure the sentence describes, both models in its legend.
    let ba = page.section("Before and after");
    let figs = html::within(&ba, "svg");
    assert_eq!(figs.len(), 1, "one Bode overlay");
    let legend = html::text(&figs[0]);
    assert!(
        legend.contains("model as given") && legend.contains("with the effects found"),
        "{legend}"
    );
    // The figures after it are of the model with the effects found, and say so.
    assert!(page
        .headings()
        .iter()
        .any(|h| h == "Error against frequency, with the effects found"));
    assert!(figures_in(dir.path()) >= 7);
}
