//! A bad model file gets an error that names the file and the dotted key; `to_toml` writes a
//! file that reads back to the same model.

use zmp_models::EffectKind;
use zmp_models::{ModelError, ModelSpec, Plant};

const FILE: &str = "bad.toml";
const PAPER: &str = include_str!("../params/silo2-paper.toml");

const PENDULUM: &str = "[pendulum]\na11 = 0.8293\na12 = 0.07455\na21 = 0.1895\na22 = 1.245\n\
                        b11 = 0.2767\nb12 = 0.005428\nb21 = 0.09979\nb22 = 0.1012\n";
const LOWPASS: &str = "[tracking_lowpass]\nomega_n = 30.0\nzeta = 1.0\n";

/// A valid model with `extra` appended.
fn with(extra: &str) -> String {
    format!("format = \"zmp-model/1\"\n{PENDULUM}{LOWPASS}{extra}")
}

/// A valid model with top-level `keys` (before any table header, where TOML puts them).
fn with_top(keys: &str) -> String {
    format!("format = \"zmp-model/1\"\n{keys}{PENDULUM}{LOWPASS}")
}

/// Parses `text`, expects an error at `key` whose message contains every one of `words`.
fn expect_error(text: &str, key: &str, words: &[&str]) -> ModelError {
    let e = match ModelSpec::parse(text, FILE) {
        Ok(spec) => panic!("expected an error at {key}, parsed {spec:?}\n{text}"),
        Err(e) => e,
    };
    assert_eq!(e.file, FILE, "{e}");
    assert_eq!(e.key, key, "{e}");
    for w in words {
        assert!(
            e.message.to_lowercase().contains(&w.to_lowercase()),
            "message of {key} lacks {w:?}: {e}"
        );
    }
    let shown = e.to_string();
    assert!(shown.starts_with(FILE) && shown.contains(key), "{shown}");
    e
}

#[test]
fn the_valid_base_parses() {
    let spec = ModelSpec::parse(&with(""), FILE).unwrap();
    Plant::new(&spec, 1e-3).unwrap();
}

#[test]
fn unknown_effect() {
    let e = expect_error(
        &with("[gearbox_wobble]\namplitude = 1.0\n"),
        "gearbox_wobble",
        &["unknown effect"],
    );
    // The message lists what is known.
    assert!(e.message.contains("backlash") && e.message.contains("structural_mode"));
}

#[test]
fn effect_that_is_not_a_table() {
    expect_error(&with_top("backlash = 0.002\n"), "backlash", &["table"]);
}

#[test]
fn unknown_parameter() {
    let e = expect_error(
        &with("[backlash]\nwidth = 0.002\nwdith = 0.003\n"),
        "backlash.wdith",
        &["unknown parameter"],
    );
    assert!(
        e.message.contains("width"),
        "lists the known parameters: {e}"
    );
    expect_error(
        &format!(
            "format = \"zmp-model/1\"\n{PENDULUM}[tracking_lowpass]\nomega_n = 30.0\nzeta = 1.0\n\
             wn = 3.0\n"
        ),
        "tracking_lowpass.wn",
        &["unknown parameter"],
    );
    expect_error(
        &with("[uncertainty.G11]\nk = 4.0\nz = 1.0\np = 10.0\ngain = 2.0\n"),
        "uncertainty.G11.gain",
        &["unknown parameter"],
    );
}

#[test]
fn missing_parameter() {
    expect_error(
        &format!("format = \"zmp-model/1\"\n{PENDULUM}[tracking_lowpass]\nomega_n = 30.0\n"),
        "tracking_lowpass.zeta",
        &["missing"],
    );
    expect_error(
        &with("[uncertainty.G12]\nk = 4.0\np = 20.0\n"),
        "uncertainty.G12.z",
        &["missing"],
    );
    expect_error(
        &format!("format = \"zmp-model/1\"\n{LOWPASS}[pendulum]\na11 = 1.0\n"),
        "pendulum.a12",
        &["missing"],
    );
}

#[test]
fn out_of_bounds_parameter() {
    expect_error(
        &with("[backlash]\nwidth = 0.5\n"),
        "backlash.x.width",
        &["out of bounds", "0.5", "m"],
    );
    expect_error(
        &with("[time_delay.y]\ndelay = -0.01\n"),
        "time_delay.y.delay",
        &["out of bounds"],
    );
    expect_error(
        &with("[structural_mode]\nomega_n = 50.0\nzeta = 0.0\n"),
        "structural_mode.x.zeta",
        &["out of bounds"],
    );
    expect_error(
        &with("[uncertainty]\nk = 1.0\nz = 1.0\np = 1.0\ndelta = 1.5\n"),
        "uncertainty.G11.delta",
        &["out of bounds"],
    );
}

#[test]
fn unstable_tracking_lowpass() {
    let lowpass = |wn: f64, zeta: f64| {
        format!(
            "format = \"zmp-model/1\"\n{PENDULUM}[tracking_lowpass.x]\nomega_n = 30.0\n\
             zeta = 1.0\n[tracking_lowpass.y]\nomega_n = {wn:?}\nzeta = {zeta:?}\n"
        )
    };
    expect_error(
        &lowpass(30.0, 0.0),
        "tracking_lowpass.y.zeta",
        &["unstable"],
    );
    expect_error(
        &lowpass(30.0, -0.4),
        "tracking_lowpass.y.zeta",
        &["unstable"],
    );
    expect_error(
        &lowpass(0.0, 1.0),
        "tracking_lowpass.y.omega_n",
        &["unstable"],
    );
    expect_error(
        &lowpass(-30.0, 1.0),
        "tracking_lowpass.y.omega_n",
        &["unstable"],
    );
}

#[test]
fn missing_core_effects() {
    expect_error(
        &format!("format = \"zmp-model/1\"\n{LOWPASS}"),
        "pendulum",
        &["missing"],
    );
    expect_error(
        &format!("format = \"zmp-model/1\"\n{PENDULUM}"),
        "tracking_lowpass.x",
        &["missing"],
    );
    // Only one axis given.
    expect_error(
        &format!("format = \"zmp-model/1\"\n{PENDULUM}[tracking_lowpass.x]\nomega_n = 30.0\nzeta = 1.0\n"),
        "tracking_lowpass.y",
        &["missing"],
    );
}

#[test]
fn string_where_a_number_goes() {
    let text = with("").replace("a11 = 0.8293", "a11 = \"0.8293\"");
    expect_error(&text, "pendulum.a11", &["expected a number", "string"]);
    expect_error(
        &with("[sensor_lowpass]\ncutoff = true\n"),
        "sensor_lowpass.cutoff",
        &["expected a number"],
    );
}

#[test]
fn wrong_or_missing_format() {
    let body = format!("{PENDULUM}{LOWPASS}");
    expect_error(
        &format!("format = \"zmp-model/2\"\n{body}"),
        "format",
        &["zmp-model/1", "zmp-model/2"],
    );
    expect_error(&body, "format", &["missing", "zmp-model/1"]);
    expect_error(&format!("format = 1\n{body}"), "format", &["zmp-model/1"]);
}

#[test]
fn toml_syntax_error_names_the_line() {
    let text = with("[backlash]\nwidth = = 0.002\n");
    let line = text
        .lines()
        .position(|l| l.starts_with("width = ="))
        .unwrap()
        + 1;
    expect_error(&text, &format!("line {line}"), &["TOML syntax"]);
    // A key given twice is a syntax error too.
    let text = with("[backlash]\nwidth = 0.002\nwidth = 0.003\n");
    let e = ModelSpec::parse(&text, FILE).unwrap_err();
    assert!(
        e.key.starts_with("line ") && e.message.contains("TOML syntax"),
        "{e}"
    );
}

#[test]
fn uncertainty_channel_that_does_not_exist() {
    let e = expect_error(
        &with("[uncertainty.G33]\nk = 1.0\nz = 1.0\np = 10.0\n"),
        "uncertainty.G33",
        &["unknown"],
    );
    assert!(
        e.message.contains("G11") && e.message.contains("G22"),
        "{e}"
    );
    // An axis effect has no channels, a channel effect no axes.
    expect_error(
        &with("[backlash.G11]\nwidth = 0.001\n"),
        "backlash.G11",
        &["unknown"],
    );
    expect_error(
        &with("[uncertainty.x]\nk = 1.0\nz = 1.0\np = 10.0\n"),
        "uncertainty.x",
        &["unknown"],
    );
}

#[test]
fn delta_seed_must_be_whole() {
    expect_error(
        &with("[uncertainty]\nk = 1.0\nz = 1.0\np = 10.0\ndelta = 0.5\ndelta_seed = 1.5\n"),
        "uncertainty.G11.delta_seed",
        &["whole number", "1.5"],
    );
    expect_error(
        &with("[uncertainty.G21]\nk = 1.0\nz = 1.0\np = 10.0\ndelta_seed = 2.25\n"),
        "uncertainty.G21.delta_seed",
        &["whole number"],
    );
}

#[test]
fn bad_metadata() {
    expect_error(&with_top("name = 3\n"), "name", &["string"]);
    expect_error(&with_top("description = [1]\n"), "description", &["string"]);
    expect_error(&with_top("provenance = 2\n"), "provenance", &["table"]);
}

#[test]
fn plant_rejects_a_bad_step() {
    let spec = ModelSpec::parse(&with(""), FILE).unwrap();
    for h in [0.0, -1e-3, 0.5, f64::NAN] {
        let e = Plant::new(&spec, h).unwrap_err();
        assert_eq!(e.key, "step", "{e}");
    }
}

// ---------------------------------------------------------------------------------------------
// to_toml round trip

fn assert_same(a: &ModelSpec, b: &ModelSpec) {
    assert_eq!(a.name, b.name);
    assert_eq!(a.description, b.description);
    assert_eq!(a.provenance, b.provenance);
    assert_eq!(a.stderr, b.stderr);
    assert_eq!(
        a.effects.len(),
        b.effects.len(),
        "{:?}\n{:?}",
        a.effects,
        b.effects
    );
    for (x, y) in a.effects.iter().zip(&b.effects) {
        assert_eq!(x.key(), y.key());
        // Bit for bit.
        let xb: Vec<u64> = x.values.iter().map(|v| v.to_bits()).collect();
        let yb: Vec<u64> = y.values.iter().map(|v| v.to_bits()).collect();
        assert_eq!(xb, yb, "{}: {:?} vs {:?}", x.key(), x.values, y.values);
    }
}

fn round_trip(spec: &ModelSpec) {
    let text = spec.to_toml();
    let back = ModelSpec::parse(&text, "written.toml").unwrap_or_else(|e| panic!("{e}\n{text}"));
    assert_same(spec, &back);
    assert_eq!(back.to_toml(), text, "to_toml is a fixed point");
}

#[test]
fn paper_model_round_trips() {
    let spec = ModelSpec::parse(PAPER, "silo2-paper.toml").unwrap();
    round_trip(&spec);
}

#[test]
fn per_axis_model_round_trips() {
    let text = r#"
format = "zmp-model/1"
name = "per-axis \"test\" model"
description = """two
lines"""

[pendulum]
a11 = 0.8293
a12 = -0.07455
a21 = 0.30000000000000004
a22 = 1.245
b11 = 0.2767
b12 = 1e-7
b21 = -0.09979
b22 = 0.1012

[tracking_lowpass.x]
omega_n = 28.5
zeta = 0.9

[tracking_lowpass.y]
omega_n = 33
zeta = 1.2

[backlash.x]
width = 0.0015

[time_delay.y]
delay = 0.0123

[coulomb_friction.x]
level = 0.2

[acceleration_saturation.y]
limit = 2.5

[uncertainty]
z = 1.0
p = 10.0

[uncertainty.G12]
k = 4.0
z = 5.0
p = 20.0
delta = -0.3
delta_seed = 42

[uncertainty.G21]
k = 7.0
delta = 1.0

[operating_point_dependence]
da_dx = 0.5
db_dy = -1.25

[structural_mode.y]
omega_n = 55.0
zeta = 0.04

[sensor_lowpass.x]
cutoff = 120.0

[sensor_drift.y]
offset = -0.002
rate = 1e-5

[provenance]
source = "unit test"
campaign = "none"

[stderr.pendulum]
a11 = 0.01
"#;
    let spec = ModelSpec::parse(text, "per-axis.toml").unwrap();
    // The instances are the ones named, with the shared values overlaid.
    let keys: Vec<String> = spec.effects.iter().map(|e| e.key()).collect();
    for k in [
        "backlash.x",
        "time_delay.y",
        "coulomb_friction.x",
        "acceleration_saturation.y",
        "uncertainty.G12",
        "uncertainty.G21",
        "structural_mode.y",
        "sensor_lowpass.x",
        "sensor_drift.y",
    ] {
        assert!(keys.iter().any(|x| x == k), "{k} missing from {keys:?}");
    }
    for k in ["backlash.y", "uncertainty.G11", "sensor_lowpass.y"] {
        assert!(
            !keys.iter().any(|x| x == k),
            "{k} should not exist: {keys:?}"
        );
    }
    let g21 = spec.get(
        EffectKind::Uncertainty,
        zmp_models::Binding::Channel(zmp_models::Channel::ALL[2]),
    );
    assert_eq!(g21.unwrap().values, vec![7.0, 1.0, 10.0, 1.0, 0.0]);
    round_trip(&spec);
    Plant::new(&spec, 1e-3).unwrap();
}

#[test]
fn an_effect_taken_out_takes_its_standard_errors_with_it() {
    let text = with(
        "[backlash]\nwidth = 0.001\n\n[stderr.pendulum]\na11 = 0.01\n\n\
         [stderr.backlash]\nwidth = 0.00002\n",
    );
    let mut spec = ModelSpec::parse(&text, FILE).unwrap();
    assert!(spec.has(EffectKind::Backlash) && spec.stderr.contains_key("backlash"));
    spec.remove(EffectKind::Backlash);
    assert!(!spec.has(EffectKind::Backlash));
    let written = spec.to_toml();
    assert!(!written.contains("backlash"), "{written}");
    // The standard errors of what stays are kept, and the file reads back.
    assert!(written.contains("[stderr.pendulum]"), "{written}");
    let back = ModelSpec::parse(&written, FILE).unwrap();
    assert!(back.stderr.contains_key("pendulum") && !back.stderr.contains_key("backlash"));
}
