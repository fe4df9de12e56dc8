//! Build script of both FMI 3.0 FMUs (`plant`, `controller`). Compiles the model file in: `ZMP_FMU_MODEL` (default: the paper's SILO2 model) is copied to
//! `$OUT_DIR/model.toml` and its instantiation token (the hash of `zmp_fmu_core::guid`) is
//! passed as `ZMP_FMI3_TOKEN`.

#[path = "../core/src/guid.rs"]
#[allow(dead_code)]
mod guid;

use std::path::PathBuf;

fn main() {
    println!("cargo:rerun-if-env-changed=ZMP_FMU_MODEL");
    println!("cargo:rerun-if-changed=../../core/src/guid.rs");
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("CARGO_MANIFEST_DIR"));
    let model = std::env::var_os("ZMP_FMU_MODEL")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest.join("../../../models/params/silo2-paper.toml"));
    println!("cargo:rerun-if-changed={}", model.display());
    let text = std::fs::read_to_string(&model)
        .unwrap_or_else(|e| panic!("ZMP_FMU_MODEL = {}: {e}", model.display()));
    // `zmp-fmi3-plant` -> `plant`.
    let package = std::env::var("CARGO_PKG_NAME").expect("CARGO_PKG_NAME");
    let kind = package.rsplit('-').next().expect("package name");
    let out = PathBuf::from(std::env::var("OUT_DIR").expect("OUT_DIR"));
    std::fs::write(out.join("model.toml"), &text).expect("writing model.toml");
    println!(
        "cargo:rustc-env=ZMP_FMI3_TOKEN={}",
        guid::guid(&format!("fmi3-{kind}"), &text)
    );
}
