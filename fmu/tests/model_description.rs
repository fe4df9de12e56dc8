//! The `modelDescription.xml` of every FMU, byte for byte against files recorded before the
//! variable table became a constant table (issue 54): a change of how the table is built must
//! not move a name, a unit, a start value or a bound.
//!
//! Recorded: the five FMUs `cargo xtask fmu --fmi3 --passthrough` builds from the paper's model
//! (FMI 2.0 plant, controller and pass-through; FMI 3.0 plant and controller), read from their
//! archives, and the FMI 2.0 plant of `golden/all-effects.toml` (every effect of the registry,
//! so every effect parameter's variable) with its documentation page, written in process.
//!
//! A deliberate change of a description (a new variable, a better text) re-records them with
//! `ZMP_UPDATE_GOLDEN=1 cargo test --release -p zmp-fmu --test model_description`; the commit
//! says why.

mod common;

use common::*;
use std::io::Read;
use std::path::{Path, PathBuf};
use zmp_fmu_core::{xml2, FmiVersion, Kind, VarTable};
use zmp_models::ModelSpec;

fn golden_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/golden")
}

/// Compares `got` with the golden file `name`, or writes it with `ZMP_UPDATE_GOLDEN=1`.
fn golden(name: &str, got: &str) {
    let path = golden_dir().join(name);
    if std::env::var("ZMP_UPDATE_GOLDEN").is_ok_and(|v| v == "1") {
        std::fs::write(&path, got).unwrap();
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (record it with ZMP_UPDATE_GOLDEN=1)",
            path.display()
        )
    });
    if want != got {
        let line = want
            .lines()
            .zip(got.lines())
            .position(|(a, b)| a != b)
            .unwrap_or(want.lines().count().min(got.lines().count()));
        panic!(
            "{name} differs from the recorded description from line {}: recorded {:?}, now {:?}",
            line + 1,
            want.lines().nth(line),
            got.lines().nth(line)
        );
    }
}

fn model_description_of(fmu: &Path) -> String {
    let mut z = zip::ZipArchive::new(std::fs::File::open(fmu).unwrap()).unwrap();
    let mut f = z.by_name("modelDescription.xml").unwrap();
    let mut s = String::new();
    f.read_to_string(&mut s).unwrap();
    s
}

#[test]
fn every_fmus_model_description_is_the_recorded_one() {
    let fmus = fmus_all();
    for (kind, fmi) in [
        (Kind::Plant, FmiVersion::V2),
        (Kind::Controller, FmiVersion::V2),
        (Kind::Passthrough, FmiVersion::V2),
        (Kind::Plant, FmiVersion::V3),
        (Kind::Controller, FmiVersion::V3),
    ] {
        let xml = model_description_of(&fmus.path(kind, fmi));
        golden(&format!("{}.xml", kind.model_identifier(fmi)), &xml);
    }
}

#[test]
fn the_plant_with_every_effect_describes_the_recorded_variables() {
    let text = std::fs::read_to_string(golden_dir().join("all-effects.toml")).unwrap();
    let spec = ModelSpec::parse(&text, "all-effects.toml").expect("fixture parses");
    for info in zmp_models::REGISTRY.iter() {
        assert!(spec.has(info.kind), "the fixture lacks {}", info.kind);
    }
    let table = VarTable::new(Kind::Plant, &spec).expect("table builds");
    let name = spec.name.clone().expect("the fixture is named");
    let guid = Kind::Plant.guid(FmiVersion::V2, &text);
    golden(
        "all-effects.xml",
        &xml2::model_description(&table, &guid, &name),
    );
    golden("all-effects.html", &xml2::documentation(&table, &name));
}
