//! The small campaign whose identification and diagnosis `cargo xtask bench` counts in
//! instructions (`src/bin/pipeline_count.rs`), one thread, so that the count is exact and
//! repeatable: the demo's hidden robot (the paper's SILO2 model with a 40 ms servo latency on
//! both axes and a ZMP sensor drifting at 0.03 mm/s), measured with 1 operating point × 2
//! amplitudes × 4 frequencies × 2 excited channels = 16 records (about 35k rows).

use std::path::{Path, PathBuf};
use zmp_campaign::{read_manifest, write_campaign, Campaign};
use zmp_diagnose::{diagnose, DiagnoseOptions, Diagnosis};
use zmp_identify::{analyse_folder, identify_analysed, Identification, IdentifyOptions};
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, EffectInstance, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

/// Name of the campaign folder that [`write()`] creates.
pub const CAMPAIGN: &str = "small-campaign";
/// Name of the identified model file that [`write()`] creates beside it.
pub const MODEL: &str = "small-campaign-identified.toml";

/// The demo's hidden robot: the paper's model, 40 ms servo latency, drifting ZMP sensor (y).
pub fn hidden_robot() -> ModelSpec {
    let mut spec = ModelSpec::parse(
        include_str!("../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .expect("paper model");
    let x = Binding::Axis(Axis::X);
    let y = Binding::Axis(Axis::Y);
    for (kind, binding, values) in [
        (EffectKind::TimeDelay, x, vec![0.04]),
        (EffectKind::TimeDelay, y, vec![0.04]),
        (EffectKind::SensorDrift, y, vec![0.0, 3e-5]),
    ] {
        spec.insert(EffectInstance {
            info: kind.info(),
            binding,
            values,
        });
    }
    spec
}

/// The reference design cut down to 16 records: operating point (0, 0), amplitudes 3 and 8 mm,
/// 4 frequencies from 0.5 to 15 rad/s, both channels excited.
pub fn design() -> ExperimentDesign {
    ExperimentDesign {
        name: CAMPAIGN.into(),
        operating_points: vec![[0.0, 0.0]],
        omegas: logspace(0.5, 15.0, 4),
        ..ExperimentDesign::reference()
    }
}

/// Identification options of the counts: one thread.
pub fn identify_options() -> IdentifyOptions {
    IdentifyOptions {
        threads: Some(1),
        ..IdentifyOptions::default()
    }
}

/// Diagnosis options of the counts: one thread.
pub fn diagnose_options() -> DiagnoseOptions {
    DiagnoseOptions {
        threads: 1,
        ..DiagnoseOptions::default()
    }
}

/// Simulates the small campaign, writes it to `parent/small-campaign` and the model identified
/// from it to `parent/small-campaign-identified.toml`; returns both paths.
pub fn write(parent: &Path) -> anyhow::Result<(PathBuf, PathBuf)> {
    let camp = simulate_campaign(&hidden_robot(), &design())?;
    let dir = parent.join(CAMPAIGN);
    write_campaign(&dir, &camp, true)?;
    let id = identify_read(&dir)?;
    let model = parent.join(MODEL);
    zmp_files::write_file(
        &model,
        zmp_files::Kind::Model,
        id.model.to_toml().as_bytes(),
        true,
    )?;
    Ok((dir, model))
}

/// What the identification count measures: read the campaign from disk and identify it, as
/// `cargo xtask identify` does (each record analysed as it is read).
pub fn identify_read(dir: &Path) -> anyhow::Result<Identification> {
    let opts = identify_options();
    let manifest = read_manifest(dir)?;
    let fits = analyse_folder(dir, &manifest, &opts, &|_| {})?;
    Ok(identify_analysed(fits, manifest.name.clone(), &opts)?)
}

/// What the diagnosis count measures: diagnose a campaign (already read) against a model.
pub fn diagnose_campaign(camp: &Campaign, model: &ModelSpec) -> anyhow::Result<Diagnosis> {
    Ok(diagnose(camp, model, &diagnose_options(), &|_| {})?)
}
