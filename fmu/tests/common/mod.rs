//! Shared helpers of the FMU tests: building the `.fmu` files once per test binary, finding the
//! Python interpreter of the venv, running the helper scripts, and the in-process references.
#![allow(dead_code)]

pub mod importer;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use zmp_fmu_core::package::{build_fmus, BuildOptions};
use zmp_fmu_core::{FmiVersion, Kind};
use zmp_models::ModelSpec;

/// The model every test uses: the paper's SILO2 model.
pub fn model_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/params/silo2-paper.toml")
}

pub fn model_text() -> String {
    std::fs::read_to_string(model_path()).expect("model file")
}

pub fn spec() -> ModelSpec {
    ModelSpec::parse(&model_text(), "silo2-paper.toml").expect("model parses")
}

/// The cargo target directory this test binary was built in.
pub fn target_dir() -> PathBuf {
    if let Some(t) = std::env::var_os("CARGO_TARGET_DIR") {
        return PathBuf::from(t);
    }
    let exe = std::env::current_exe().expect("current exe");
    // <target>/<profile>/deps/<test binary>
    exe.ancestors().nth(3).expect("target dir").to_path_buf()
}

/// The FMUs of the paper model, built (release) once per test binary into a directory of its own.
pub struct Fmus {
    pub dir: PathBuf,
    pub fmi3: bool,
}

impl Fmus {
    pub fn path(&self, kind: Kind, fmi: FmiVersion) -> PathBuf {
        self.dir.join(format!("{}.fmu", kind.model_identifier(fmi)))
    }
    pub fn plant(&self) -> PathBuf {
        self.path(Kind::Plant, FmiVersion::V2)
    }
    pub fn controller(&self) -> PathBuf {
        self.path(Kind::Controller, FmiVersion::V2)
    }
    pub fn passthrough(&self) -> PathBuf {
        self.path(Kind::Passthrough, FmiVersion::V2)
    }
    pub fn plant3(&self) -> PathBuf {
        self.path(Kind::Plant, FmiVersion::V3)
    }
    pub fn controller3(&self) -> PathBuf {
        self.path(Kind::Controller, FmiVersion::V3)
    }
    /// Every FMU built.
    pub fn all(&self) -> Vec<PathBuf> {
        let mut v = vec![self.plant(), self.controller(), self.passthrough()];
        if self.fmi3 {
            v.push(self.plant3());
            v.push(self.controller3());
        }
        v
    }
}

fn build(fmi3: bool) -> Fmus {
    let bin = std::env::current_exe().expect("current exe");
    // `<test name>-<hash>`: one directory per test file, whatever the hash.
    let stem = bin
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "tests".into());
    let stem = stem
        .rsplit_once('-')
        .map(|(a, _)| a.to_string())
        .unwrap_or(stem);
    let dir = target_dir()
        .join("fmu-tests")
        .join(format!("{stem}-{}", if fmi3 { "all" } else { "fmi2" }));
    let opts = BuildOptions {
        release: true,
        fmi3,
        passthrough: true,
        force: true,
        target_dir: Some(target_dir()),
    };
    build_fmus(&model_path(), &dir, &opts).unwrap_or_else(|e| panic!("building the FMUs: {e}"));
    Fmus { dir, fmi3 }
}

/// The FMI 2.0 FMUs (plant, controller, pass-through).
pub fn fmus() -> &'static Fmus {
    static F: OnceLock<Fmus> = OnceLock::new();
    F.get_or_init(|| build(false))
}

/// The FMI 2.0 and FMI 3.0 FMUs.
pub fn fmus_all() -> &'static Fmus {
    static F: OnceLock<Fmus> = OnceLock::new();
    F.get_or_init(|| build(true))
}

/// The venv's Python: `ZMP_PYTHON`, else `$HOME/.cache/zmp-toolkit/venv/bin/python`. Fails the
/// test (never skips) when it is missing.
pub fn python() -> PathBuf {
    let p = std::env::var_os("ZMP_PYTHON")
        .map(PathBuf::from)
        .or_else(|| {
            std::env::var_os("HOME")
                .map(|h| PathBuf::from(h).join(".cache/zmp-toolkit/venv/bin/python"))
        })
        .expect("neither ZMP_PYTHON nor HOME is set");
    assert!(
        p.exists(),
        "Python with FMPy not found at {}: run `cargo xtask setup` (or set ZMP_PYTHON)",
        p.display()
    );
    p
}

/// Runs `tests/python/<script>` with `args`; returns its stdout. Panics with its output if it
/// fails.
pub fn run_python(script: &str, args: &[&str]) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/python")
        .join(script);
    let out = Command::new(python())
        .arg(&path)
        .args(args)
        .output()
        .expect("running python");
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{script} failed ({}):\n--- stdout\n{stdout}\n--- stderr\n{}\nIf fmpy is missing, run `cargo xtask setup`.",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// Index of the last grid point at or before `t` (the FMUs' rule, written independently).
pub fn grid_floor(t: f64, h: f64) -> u64 {
    (t / h + 1e-6).floor() as u64
}

/// Largest absolute difference, with its position.
pub fn max_abs_diff(a: &[f64], b: &[f64]) -> (f64, usize) {
    assert_eq!(a.len(), b.len(), "series lengths differ");
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .enumerate()
        .fold(
            (0.0, 0),
            |(m, k), (i, d)| if d > m || d.is_nan() { (d, i) } else { (m, k) },
        )
}
