//! `cargo xtask fmu --model MODEL.toml [--out DIR] [--force]`: the FMI co-simulation FMUs of a
//! model file.
//!
//! Writes to `DIR` (default `target/fmu`):
//! - `zmp_plant.fmu`, `zmp_controller.fmu`: FMI 2.0 co-simulation, Linux 64-bit (the generic
//!   `zmp-fmu` shared library, which reads `resources/model.toml` at instantiation);
//! - `zmp_plant_fmi3.fmu`, `zmp_controller_fmi3.fmu`: FMI 3.0 co-simulation through fmi-export
//!   (`zmp-fmi3-plant`, `zmp-fmi3-controller`, compiled with the model file built in).
//!
//! Parameter start values are the model file's; the GUID / instantiation token is a hash of
//! the model file's text and the binary version, so it changes with the model. The shared
//! libraries are built with `cargo build --release` (through `$CARGO`); each archive is written
//! to a temporary file and renamed into place; existing `.fmu` files are kept unless `force`.

use anyhow::{anyhow, Context, Result};
use std::path::{Path, PathBuf};
use zmp_fmu_core::package::BuildOptions;

/// Builds the FMI 2.0 and FMI 3.0 FMUs of `model` into `out`; returns the files written.
pub fn build_fmus(model: &Path, out: &Path, force: bool) -> Result<Vec<PathBuf>> {
    let opts = BuildOptions {
        release: true,
        fmi3: true,
        passthrough: false,
        force,
        target_dir: None,
    };
    build_fmus_with(model, out, &opts)
}

/// [`build_fmus`] with every option (FMI 2.0 only, the pass-through benchmark FMU, profile,
/// target directory).
pub fn build_fmus_with(model: &Path, out: &Path, opts: &BuildOptions) -> Result<Vec<PathBuf>> {
    zmp_fmu_core::package::build_fmus(model, out, opts)
        .map_err(|e| anyhow!(e))
        .with_context(|| format!("building the FMUs of {}", model.display()))
}
