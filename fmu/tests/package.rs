//! What `cargo xtask fmu` writes: the archive layout, the model's values as parameter start
//! values, a GUID that follows the model's content, and no silent overwrite.

mod common;

use common::*;
use fmi::fmi2::schema::{Fmi2ModelDescription, ScalarVariableElement};
use std::io::Read;
use std::path::Path;
use std::str::FromStr;
use zmp_fmu_core::package::{build_fmus, BuildOptions};
use zmp_fmu_core::{FmiVersion, Kind};

fn entry(fmu: &Path, name: &str) -> Vec<u8> {
    let mut z = zip::ZipArchive::new(std::fs::File::open(fmu).unwrap()).unwrap();
    let mut f = z
        .by_name(name)
        .unwrap_or_else(|_| panic!("{} has no {name}", fmu.display()));
    let mut v = Vec::new();
    f.read_to_end(&mut v).unwrap();
    v
}

fn description(fmu: &Path) -> Fmi2ModelDescription {
    let xml = String::from_utf8(entry(fmu, "modelDescription.xml")).unwrap();
    Fmi2ModelDescription::from_str(&xml).expect("modelDescription.xml parses (fmi-schema)")
}

fn start(md: &Fmi2ModelDescription, name: &str) -> Option<f64> {
    md.model_variables
        .variables
        .iter()
        .find(|v| v.name == name)
        .and_then(|v| match &v.elem {
            ScalarVariableElement::Real(r) => r.start,
            _ => None,
        })
}

#[test]
fn fmi2_archives_have_the_layout_and_the_models_values() {
    let fmus = fmus();
    let text = model_text();
    let spec = spec();
    for (kind, path) in [
        (Kind::Plant, fmus.plant()),
        (Kind::Controller, fmus.controller()),
    ] {
        let id = kind.model_identifier(FmiVersion::V2);
        assert!(!entry(&path, &format!("binaries/linux64/{id}.so")).is_empty());
        assert_eq!(entry(&path, "resources/model.toml"), text.as_bytes());
        assert!(!entry(&path, "documentation/index.html").is_empty());
        let md = description(&path);
        assert_eq!(md.fmi_version, "2.0");
        assert_eq!(md.guid, kind.guid(FmiVersion::V2, &text));
    }
    let md = description(&fmus.plant());
    let params = spec.parameters();
    assert!(params.len() >= 30);
    for p in &params {
        assert_eq!(
            start(&md, &p.key),
            Some(p.value),
            "start value of {}",
            p.key
        );
    }
    assert_eq!(start(&md, "h"), Some(1e-3));
    for name in ["x_cr", "y_cr"] {
        assert!(
            start(&md, name).is_some(),
            "input {name} needs a start value"
        );
    }
    let md = description(&fmus.controller());
    assert_eq!(start(&md, "K1"), Some(0.014));
    assert_eq!(start(&md, "K2"), Some(0.2));
    assert_eq!(start(&md, "h"), Some(0.01));
}

#[test]
fn guid_follows_the_model_content_and_overwrite_needs_force() {
    let text = model_text();
    let changed = text.replace("a11 = 0.8293", "a11 = 0.8300");
    assert_ne!(text, changed);
    let dir = target_dir().join("fmu-tests/package-guid");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let model = dir.join("changed.toml");
    std::fs::write(&model, &changed).unwrap();
    let opts = BuildOptions {
        release: true,
        fmi3: false,
        passthrough: false,
        force: false,
        target_dir: Some(target_dir()),
    };
    let out = dir.join("out");
    let files = build_fmus(&model, &out, &opts).expect("build");
    assert_eq!(files.len(), 2);
    let md = description(&out.join("zmp_plant.fmu"));
    let paper = description(&fmus().plant());
    assert_ne!(md.guid, paper.guid, "the GUID must change with the model");
    assert_eq!(start(&md, "pendulum.a11"), Some(0.83));
    assert_eq!(start(&paper, "pendulum.a11"), Some(0.8293));
    // A binary-compatible but different model file in resources/ is refused at instantiation
    // (tests/robustness/instantiate.rs checks the message); here: the GUIDs of all flavours
    // differ.
    let mut all: Vec<String> = Vec::new();
    for k in Kind::ALL {
        for f in [FmiVersion::V2, FmiVersion::V3] {
            all.push(k.guid(f, &text));
            all.push(k.guid(f, &changed));
        }
    }
    let n = all.len();
    all.sort();
    all.dedup();
    assert_eq!(all.len(), n, "GUID collision between flavours or models");
    // Refuses to overwrite without force, leaves the files alone, overwrites with it.
    let before = std::fs::read(&files[0]).unwrap();
    let err = build_fmus(&model, &out, &opts).unwrap_err();
    assert!(err.contains("refusing to overwrite"), "{err}");
    assert_eq!(std::fs::read(&files[0]).unwrap(), before);
    let forced = BuildOptions {
        force: true,
        ..opts
    };
    build_fmus(&model, &out, &forced).expect("forced rebuild");
    // No temporary files left behind.
    let names: Vec<String> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(names.iter().all(|n| n.ends_with(".fmu")), "{names:?}");
}

#[test]
fn fmi3_token_is_the_models_hash() {
    let fmus = fmus_all();
    let text = model_text();
    for (kind, path) in [
        (Kind::Plant, fmus.plant3()),
        (Kind::Controller, fmus.controller3()),
    ] {
        let xml = String::from_utf8(entry(&path, "modelDescription.xml")).unwrap();
        let token = kind.guid(FmiVersion::V3, &text);
        assert!(
            xml.contains(&format!("instantiationToken=\"{token}\"")),
            "{kind:?}"
        );
        let id = kind.model_identifier(FmiVersion::V3);
        assert!(!entry(&path, &format!("binaries/x86_64-linux/{id}.so")).is_empty());
        assert_eq!(entry(&path, "resources/model.toml"), text.as_bytes());
    }
}
