//! `cargo xtask robust`: the JSON a script reads, the plot written once (again only with
//! `--force`), and bad input named.

use std::path::Path;
use std::process::{Command, Output};

fn xtask(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(args)
        .current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."))
        .output()
        .expect("xtask runs")
}

#[test]
fn robust_reports_the_margin_and_refuses_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let plot = tmp.path().join("t.svg");
    let plot_s = plot.to_str().unwrap();
    let model = "models/params/silo2-paper.toml";
    let out = xtask(&["robust", "--model", model, "--json", "--plot", plot_s]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The seed's controller on the seed's model: robustly stable, G22 the tight channel.
    assert_eq!(v["robustly_stable"], true, "{v}");
    assert_eq!(v["tightest_channel"], "G22", "{v}");
    let mu = v["mu_peak"].as_f64().unwrap();
    assert!(mu > 0.5 && mu < 1.0, "{v}");
    assert_eq!(v["channels"].as_array().unwrap().len(), 4);
    let svg = std::fs::read_to_string(&plot).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("1/|W|"));
    // Again without --force: refused before any work, the file kept.
    let again = xtask(&["robust", "--model", model, "--plot", plot_s]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("--force"));
    assert!(
        xtask(&["robust", "--model", model, "--plot", plot_s, "--force"])
            .status
            .success()
    );
    // Faster gains fail the check; the text says so.
    let fast = xtask(&["robust", "--model", model, "--gains", "0.05,0.2"]);
    let text = String::from_utf8_lossy(&fast.stdout);
    assert!(
        fast.status.success() && text.contains("NOT robustly stable"),
        "{text}"
    );
    // Bad input: the option or file is named.
    for (args, needle) in [
        (vec!["--gains", "0.1"], "--gains"),
        (vec!["--gains", "0.1,-2"], "--gains"),
        (vec!["--trunk-gain", "-1"], "--trunk-gain"),
        (vec!["--period", "7"], "--period"),
    ] {
        let mut a = vec!["robust", "--model", model];
        a.extend(args);
        let o = xtask(&a);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success() && err.contains(needle), "{a:?}: {err}");
    }
    let o = xtask(&["robust", "--model", "no/such/model.toml"]);
    assert!(String::from_utf8_lossy(&o.stderr).contains("no/such/model.toml"));
}
