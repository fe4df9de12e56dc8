//! What the benchmarks measure, shared by the criterion benches (`benches/`) and the
//! instruction-count binaries (`src/bin/*_count.rs`) that `cargo xtask bench` runs under
//! callgrind (see `README.md`): the real-time models and inputs, the reference identification
//! campaign, and the small campaign of the identification and diagnosis counts.

pub mod realtime {
    use std::f64::consts::PI;
    use zmp_models::controller::{CascadeController, CascadeParams};
    use zmp_models::{Binding, Channel, ModelSpec, Plant, REGISTRY};

    /// The paper's SILO2 model (`models/params/silo2-paper.toml`).
    pub const PAPER: &str = include_str!("../../models/params/silo2-paper.toml");

    /// Every effect of the registry besides the paper's, at realistic SILO2-like values.
    pub const EXTRA_EFFECTS: &str = r#"
[acceleration_saturation]
limit = 3.0          # m/s2

[coulomb_friction]
level = 0.05         # m/s2

[time_delay]
delay = 0.012        # s

[backlash]
width = 0.002        # m

[operating_point_dependence]
da_dx = 0.5
db_dy = -0.3

[structural_mode]
omega_n = 60.0       # rad/s
zeta = 0.05

[flexible_trunk]
omega_n = 40.0       # rad/s
zeta = 0.05
share = 0.3

[sensor_lowpass]
cutoff = 100.0       # rad/s

[sensor_drift]
offset = 0.001       # m
rate = 1e-5          # m/s
"#;

    /// Internal step of the plant, s.
    pub const PLANT_STEP: f64 = 1e-3;
    /// Sample period of the controller, s.
    pub const CONTROLLER_PERIOD: f64 = 0.01;
    /// Length of the input tables: a power of two holding whole periods.
    pub const TABLE: usize = 4096;

    pub fn paper_spec() -> ModelSpec {
        ModelSpec::parse(PAPER, "silo2-paper.toml").expect("the paper's model parses")
    }

    /// The paper's model with every effect of the registry on; the uncertainty is a random
    /// stable `Delta` of gain 0.5 on every channel (its own seed per channel).
    pub fn all_effects_spec() -> ModelSpec {
        let text = format!("{PAPER}\n{EXTRA_EFFECTS}");
        let mut spec = ModelSpec::parse(&text, "all-effects").expect("all-effects model parses");
        for (n, ch) in Channel::ALL.iter().enumerate() {
            let b = Binding::Channel(*ch);
            assert!(spec.set_value(zmp_models::EffectKind::Uncertainty, b, "delta", 0.5));
            assert!(spec.set_value(
                zmp_models::EffectKind::Uncertainty,
                b,
                "delta_seed",
                7.0 + n as f64
            ));
        }
        for info in REGISTRY.iter() {
            assert!(spec.has(info.kind), "bench model lacks {}", info.kind);
        }
        spec
    }

    /// CoM reference: sines of 1 cm and 0.8 cm (4 and 3 whole periods over the table, about
    /// 6 and 4.6 rad/s at 1 ms) around a small operating point.
    pub fn com_ref_table() -> Vec<[f64; 2]> {
        (0..TABLE)
            .map(|k| {
                let t = k as f64 / TABLE as f64;
                [
                    0.02 + 0.010 * (2.0 * PI * 4.0 * t).sin(),
                    -0.01 + 0.008 * (2.0 * PI * 3.0 * t).sin(),
                ]
            })
            .collect()
    }

    /// Measured ZMP fed to the controller while it tracks 0.17 m.
    pub fn zmp_table() -> Vec<[f64; 2]> {
        (0..TABLE)
            .map(|k| {
                let t = k as f64 / TABLE as f64;
                [
                    0.15 + 0.01 * (2.0 * PI * t).sin(),
                    0.002 * (4.0 * PI * t).cos(),
                ]
            })
            .collect()
    }

    /// The plant of `spec` at the table's operating point, past its start-up transient.
    pub fn settled_plant(spec: &ModelSpec) -> Plant {
        let mut plant = Plant::new(spec, PLANT_STEP).expect("plant builds");
        let input = com_ref_table();
        plant.set_operating_point(input[0]);
        plant.reset(input[0]);
        for r in input.iter().cycle().take(4 * TABLE) {
            plant.step(*r);
        }
        plant
    }

    pub fn controller() -> CascadeController {
        let mut ctrl = CascadeController::new(CascadeParams::silo2(), CONTROLLER_PERIOD);
        ctrl.reset_to_com([0.14, 0.0]);
        ctrl
    }
}

#[cfg(feature = "pipeline")]
pub mod pipeline;

/// Appends one peer comparison of a bench (a JSON line: `name`, `ours_s`, `peer_s`, `ratio` =
/// peer / ours, `unit`, `note`) to the file `$ZMP_BENCH_RESULTS`, which `cargo xtask bench`
/// collects into its history and table; does nothing when that variable is not set.
pub fn report_peer(name: &str, ours_s: f64, peer_s: f64, unit: &str, note: &str) {
    let Some(path) = std::env::var_os("ZMP_BENCH_RESULTS") else {
        return;
    };
    let line = serde_json::json!({
        "name": name, "ours_s": ours_s, "peer_s": peer_s, "ratio": peer_s / ours_s,
        "unit": unit, "note": note,
    });
    use std::io::Write;
    let written = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(&path)
        .and_then(|mut f| f.write_all(format!("{line}\n").as_bytes()));
    if let Err(e) = written {
        panic!(
            "appending to ZMP_BENCH_RESULTS={}: {e}",
            path.to_string_lossy()
        );
    }
}

/// The identification benchmark's campaign and pipeline, shared by the criterion bench
/// `benches/identify.rs` and the instruction-count binary `src/bin/identify_count.rs`.
#[cfg(feature = "pipeline")]
pub mod identify {
    use std::path::{Path, PathBuf};
    use zmp_campaign::{read_manifest, write_campaign};
    use zmp_identify::{analyse_folder, identify_analysed, IdentifyOptions};
    use zmp_models::{Axis, Binding, EffectInstance, ModelSpec};
    use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

    /// Simulates the reference virtual SILO2 campaign (paper model with an acceleration limit
    /// of 1.2 m/s2) and writes it to `parent/virtual-silo2`; returns that folder.
    pub fn write_reference_campaign(parent: &Path) -> PathBuf {
        let mut spec = ModelSpec::parse(
            include_str!("../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .expect("paper model");
        for axis in Axis::BOTH {
            spec.insert(EffectInstance {
                info: zmp_models::EffectKind::AccelerationSaturation.info(),
                binding: Binding::Axis(axis),
                values: vec![1.2],
            });
        }
        let camp = simulate_campaign(&spec, &ExperimentDesign::reference()).expect("simulate");
        let dir = parent.join("virtual-silo2");
        write_campaign(&dir, &camp, true).expect("write campaign");
        dir
    }

    /// The measured pipeline, as `cargo xtask identify` runs it: read the campaign from disk,
    /// analysing each record as it is read, and identify it; returns `a11`.
    pub fn pipeline(dir: &Path) -> f64 {
        let opts = IdentifyOptions::default();
        let manifest = read_manifest(dir).expect("manifest");
        let fits = analyse_folder(dir, &manifest, &opts, &|_| {}).expect("read");
        let id = identify_analysed(fits, manifest.name.clone(), &opts).expect("identify");
        id.a[0][0].value
    }
}
