//! Property tests of the inputs people write by hand: design files (`cargo xtask simulate
//! --design`) and model files (`zmp-model/1`). Whatever the values (NaN, infinities, huge or
//! negative numbers, strings, missing or unknown keys), reading never panics or aborts, and
//! every error names the file and the field.

use proptest::prelude::*;
use zmp_models::{ModelSpec, Plant};
use zmp_virtual_robot::ExperimentDesign;

const DESIGN_FILE: &str = "my-design.toml";
const MODEL_FILE: &str = "my-model.toml";
const PAPER: &str = include_str!("../../../models/params/silo2-paper.toml");

/// Design fields with a valid value each (TOML text).
const FIELDS: [(&str, &str); 13] = [
    ("name", "\"fuzz\""),
    ("operating_points", "[[0.0, 0.0], [0.02, 0.0]]"),
    ("amplitudes", "[0.003, 0.008]"),
    ("omegas", "[1.0, 5.0]"),
    ("excited", "[\"x\", \"y\"]"),
    ("sample_rate_hz", "200.0"),
    ("transient_s", "3.0"),
    ("periods", "4"),
    ("min_steady_s", "8.0"),
    ("zmp_noise_std", "0.0005"),
    ("quantisation", "0.0001"),
    ("seed", "1"),
    ("internal_step", "0.001"),
];

/// A value for any field: mostly bad.
fn value() -> impl Strategy<Value = String> {
    let number = prop_oneof![
        Just("nan".to_string()),
        Just("inf".to_string()),
        Just("-inf".to_string()),
        Just("1e300".to_string()),
        Just("-1.0".to_string()),
        Just("0".to_string()),
        Just("0.0".to_string()),
        Just("1e-300".to_string()),
        Just("18446744073709551615".to_string()),
        Just("-9223372036854775808".to_string()),
        (-1e9f64..1e9).prop_map(|v| format!("{v:e}")),
        (0u64..100_000_000).prop_map(|v| v.to_string()),
    ];
    prop_oneof![
        3 => number.clone(),
        1 => prop::collection::vec(number.clone(), 0..4).prop_map(|v| format!("[{}]", v.join(", "))),
        1 => prop::collection::vec(
            (number.clone(), number).prop_map(|(a, b)| format!("[{a}, {b}]")), 0..3)
            .prop_map(|v| format!("[{}]", v.join(", "))),
        1 => Just("\"x\"".to_string()),
        1 => Just("[\"x\", \"x\", \"z\"]".to_string()),
        1 => Just("true".to_string()),
        1 => Just("{ a = 1 }".to_string()),
    ]
}

/// A design file: every field valid, missing, or replaced; maybe an unknown key.
fn design_text() -> impl Strategy<Value = String> {
    (
        prop::collection::vec((0u8..4, value()), FIELDS.len()),
        prop::option::of(value()),
    )
        .prop_map(|(choices, extra)| {
            let mut s = String::new();
            for ((name, good), (c, v)) in FIELDS.iter().zip(choices) {
                match c {
                    0 => {}
                    1 => s.push_str(&format!("{name} = {v}\n")),
                    _ => s.push_str(&format!("{name} = {good}\n")),
                }
            }
            if let Some(v) = extra {
                s.push_str(&format!("transient = {v}\n"));
            }
            s
        })
}

/// Mutates the paper's model file: some parameter values replaced, some lines dropped, maybe
/// an unknown key.
fn model_text() -> impl Strategy<Value = String> {
    let lines: Vec<String> = PAPER.lines().map(str::to_string).collect();
    let n = lines.len();
    (
        prop::collection::vec((0..n, value()), 0..4),
        prop::collection::vec(0..n, 0..2),
        prop::option::of(value()),
    )
        .prop_map(move |(set, drop, extra)| {
            let mut l = lines.clone();
            for (k, v) in set {
                if let Some((key, _)) = l[k].split_once('=') {
                    if !key.trim_start().starts_with('#') {
                        l[k] = format!("{key}= {v}");
                    }
                }
            }
            for k in drop {
                l[k] = String::new();
            }
            if let Some(v) = extra {
                l.push(format!("[tracking_lowpass.x]\nomega_n = {v}"));
            }
            l.join("\n")
        })
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn design_files_never_panic_and_name_file_and_field(text in design_text()) {
        match ExperimentDesign::from_toml(&text, DESIGN_FILE) {
            Ok(d) => {
                // Accepted: bounded, and the campaign is small enough to allocate.
                prop_assert!(d.check().is_ok());
                prop_assert!(d.records().len() <= zmp_virtual_robot::MAX_RECORDS);
            }
            Err(e) => {
                prop_assert!(e.starts_with(DESIGN_FILE), "{e}");
                let named = FIELDS.iter().any(|(f, _)| e.contains(f)) || e.contains("transient");
                prop_assert!(named, "no field named: {e}\n{text}");
            }
        }
    }

    #[test]
    fn model_files_never_panic_and_name_file_and_key(text in model_text()) {
        match ModelSpec::parse(&text, MODEL_FILE) {
            Ok(spec) => {
                // Accepted: the plant builds and steps without panicking.
                let mut p = Plant::new(&spec, 1e-3).map_err(|e| TestCaseError::fail(e.to_string()))?;
                for k in 0..50 {
                    p.step([0.01 * (k as f64 * 0.1).sin(), 0.0]);
                }
            }
            Err(e) => {
                prop_assert_eq!(&e.file, MODEL_FILE);
                prop_assert!(!e.key.is_empty(), "no key named: {e}\n{text}");
                prop_assert!(e.to_string().starts_with(MODEL_FILE), "{e}");
            }
        }
    }
}

#[test]
fn design_errors_name_the_field_for_each_bad_number() {
    let base: String = FIELDS.iter().map(|(n, v)| format!("{n} = {v}\n")).collect();
    ExperimentDesign::from_toml(&base, DESIGN_FILE).unwrap();
    for (field, bad) in [
        ("transient_s", "nan"),
        ("transient_s", "inf"),
        ("min_steady_s", "-inf"),
        ("min_steady_s", "nan"),
        ("zmp_noise_std", "nan"),
        ("zmp_noise_std", "inf"),
        ("quantisation", "nan"),
        ("quantisation", "-1.0"),
        ("transient_s", "1e12"),
        ("min_steady_s", "99999.0"),
        ("sample_rate_hz", "inf"),
        ("internal_step", "nan"),
        ("amplitudes", "[nan]"),
        ("omegas", "[inf]"),
        ("operating_points", "[[nan, 0.0]]"),
        ("periods", "0"),
        ("periods", "4000000000"),
    ] {
        let text = base.replace(
            &format!(
                "{field} = {}",
                FIELDS.iter().find(|f| f.0 == field).unwrap().1
            ),
            &format!("{field} = {bad}"),
        );
        let e = ExperimentDesign::from_toml(&text, DESIGN_FILE)
            .expect_err(&format!("{field} = {bad} accepted"));
        assert!(
            e.starts_with(DESIGN_FILE) && e.contains(field),
            "{field} = {bad}: {e}"
        );
    }
}
