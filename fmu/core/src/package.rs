//! Building the FMU archives: `cargo build` of the shared libraries, then the FMU folder layout
//! (`modelDescription.xml`, `binaries/<platform>/<modelIdentifier>.so`, `resources/model.toml`,
//! `documentation/index.html`) zipped in memory and written through the one output path
//! (`zmp_files`: atomically, never over anything but an FMU, an existing one only with
//! `force`). The packager writes its files itself rather than hand bytes to each caller: the
//! CLI, the FMU tests and the benches all call [`build_fmus`], and `zmp-files` is a leaf
//! crate that adds nothing to the FMU's shared library (this module is not part of it).
//!
//! The FMI 2.0 binary (`zmp-fmu`) is generic: it reads `resources/model.toml` at instantiation.
//! The FMI 3.0 binaries (`zmp-fmi3-plant`, `zmp-fmi3-controller`) embed the model: fmi-export
//! fixes the instantiation token and the variable list at compile time, so they are compiled
//! with `ZMP_FMU_MODEL` pointing at the model file, and their model description comes from the
//! same binary (its `--model-description` executable).

use crate::vars::{FmiVersion, Kind, VarTable};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use zmp_models::ModelSpec;

/// What to build.
#[derive(Debug, Clone)]
pub struct BuildOptions {
    /// `cargo build --release` (else the dev profile).
    pub release: bool,
    /// Also the FMI 3.0 FMUs (needs libclang).
    pub fmi3: bool,
    /// Also the trivial pass-through FMU (benchmark baseline).
    pub passthrough: bool,
    /// Overwrite existing `.fmu` files.
    pub force: bool,
    /// `CARGO_TARGET_DIR` for the builds (`None`: inherit).
    pub target_dir: Option<PathBuf>,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            release: true,
            fmi3: true,
            passthrough: false,
            force: false,
            target_dir: None,
        }
    }
}

/// The workspace root: the nearest directory at or above the package `cargo run` / `cargo
/// test` runs (`CARGO_MANIFEST_DIR` at run time) whose `Cargo.toml` declares `[workspace]`;
/// else where this crate was compiled from. Two checkouts sharing one `CARGO_TARGET_DIR`
/// share the uplifted `target/release/xtask`, so the compiled-in path can be the other
/// checkout's (a `cargo xtask bench` in one wrote its tables into the other).
pub fn workspace_root() -> PathBuf {
    if let Some(dir) = std::env::var_os("CARGO_MANIFEST_DIR") {
        if let Some(root) = enclosing_workspace(Path::new(&dir)) {
            return root;
        }
    }
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .unwrap_or_else(|_| PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../..")))
}

/// The nearest directory at or above `start` whose `Cargo.toml` has a `[workspace]` table.
fn enclosing_workspace(start: &Path) -> Option<PathBuf> {
    start.ancestors().find_map(|d| {
        let text = std::fs::read_to_string(d.join("Cargo.toml")).ok()?;
        text.lines()
            .any(|l| l.trim() == "[workspace]")
            .then(|| d.canonicalize().unwrap_or_else(|_| d.to_path_buf()))
    })
}

/// Artifacts of one `cargo build`.
#[derive(Debug, Default)]
struct Artifacts {
    dylibs: Vec<PathBuf>,
    executables: Vec<PathBuf>,
}

fn cargo_build(
    package: &str,
    opts: &BuildOptions,
    env: &[(&str, &Path)],
) -> Result<Artifacts, String> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.arg("build")
        .arg("--manifest-path")
        .arg(workspace_root().join("Cargo.toml"))
        .args(["-p", package, "--message-format=json-render-diagnostics"]);
    if opts.release {
        cmd.arg("--release");
    }
    if let Some(t) = &opts.target_dir {
        cmd.env("CARGO_TARGET_DIR", t);
    }
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.stderr(std::process::Stdio::inherit());
    let out = cmd
        .output()
        .map_err(|e| format!("cannot run cargo build -p {package}: {e}"))?;
    if !out.status.success() {
        return Err(format!("cargo build -p {package} failed ({})", out.status));
    }
    let mut a = Artifacts::default();
    let crate_name = package.replace('-', "_");
    for line in String::from_utf8_lossy(&out.stdout).lines() {
        let Ok(msg) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        if msg["reason"] != "compiler-artifact"
            || msg["target"]["name"] != crate_name.as_str() && msg["target"]["name"] != package
        {
            continue;
        }
        if let Some(files) = msg["filenames"].as_array() {
            for f in files.iter().filter_map(|f| f.as_str()) {
                if f.ends_with(std::env::consts::DLL_SUFFIX) {
                    a.dylibs.push(PathBuf::from(f));
                }
            }
        }
        if let Some(exe) = msg["executable"].as_str() {
            a.executables.push(PathBuf::from(exe));
        }
    }
    Ok(a)
}

/// The zip archive of `entries` (folders added for every path), in memory: the FMU's bytes,
/// which [`build_fmus`] writes through the one output path (`zmp_files`).
pub fn zip_bytes(entries: &[(String, Vec<u8>)]) -> Result<Vec<u8>, String> {
    let mut zw = zip::ZipWriter::new(std::io::Cursor::new(Vec::new()));
    let opts = zip::write::SimpleFileOptions::default()
        .compression_method(zip::CompressionMethod::Deflated)
        .unix_permissions(0o644);
    let mut dirs: Vec<String> = Vec::new();
    for (name, _) in entries {
        let mut acc = String::new();
        let parts: Vec<&str> = name.split('/').collect();
        for p in &parts[..parts.len() - 1] {
            acc.push_str(p);
            acc.push('/');
            if !dirs.contains(&acc) {
                dirs.push(acc.clone());
            }
        }
    }
    for d in &dirs {
        zw.add_directory(d.as_str(), opts)
            .map_err(|e| e.to_string())?;
    }
    for (name, data) in entries {
        zw.start_file(name.as_str(), opts)
            .map_err(|e| e.to_string())?;
        zw.write_all(data).map_err(|e| e.to_string())?;
    }
    Ok(zw.finish().map_err(|e| e.to_string())?.into_inner())
}

/// Display name of the model: its `name`, else the file stem.
pub fn model_name(spec: &ModelSpec, path: &Path) -> String {
    spec.name.clone().unwrap_or_else(|| {
        path.file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "model".into())
    })
}

/// The archive entries of the FMI 2.0 FMU of `kind`.
pub fn fmi2_entries(
    kind: Kind,
    model_toml: &str,
    model_name: &str,
    dylib: &[u8],
) -> Result<Vec<(String, Vec<u8>)>, String> {
    let spec = ModelSpec::parse(model_toml, model_name).map_err(|e| e.to_string())?;
    let table = VarTable::new(kind, &spec)?;
    let guid = kind.guid(FmiVersion::V2, model_toml);
    let id = kind.model_identifier(FmiVersion::V2);
    Ok(vec![
        (
            "modelDescription.xml".into(),
            crate::xml2::model_description(&table, &guid, model_name).into_bytes(),
        ),
        (format!("binaries/linux64/{id}.so"), dylib.to_vec()),
        (
            "resources/model.toml".into(),
            model_toml.as_bytes().to_vec(),
        ),
        (
            "documentation/index.html".into(),
            crate::xml2::documentation(&table, model_name).into_bytes(),
        ),
    ])
}

/// The archive entries of an FMI 3.0 FMU whose model description is `xml`.
pub fn fmi3_entries(
    kind: Kind,
    model_toml: &str,
    xml: String,
    dylib: &[u8],
) -> Vec<(String, Vec<u8>)> {
    let id = kind.model_identifier(FmiVersion::V3);
    vec![
        ("modelDescription.xml".into(), xml.into_bytes()),
        (format!("binaries/x86_64-linux/{id}.so"), dylib.to_vec()),
        (
            "resources/model.toml".into(),
            model_toml.as_bytes().to_vec(),
        ),
    ]
}

/// The `.fmu` files `build_fmus` writes for `opts`, in order.
pub fn fmu_paths(out: &Path, opts: &BuildOptions) -> Vec<(Kind, FmiVersion, PathBuf)> {
    let mut v = vec![
        (Kind::Plant, FmiVersion::V2),
        (Kind::Controller, FmiVersion::V2),
    ];
    if opts.passthrough {
        v.push((Kind::Passthrough, FmiVersion::V2));
    }
    if opts.fmi3 {
        v.push((Kind::Plant, FmiVersion::V3));
        v.push((Kind::Controller, FmiVersion::V3));
    }
    v.into_iter()
        .map(|(k, f)| (k, f, out.join(format!("{}.fmu", k.model_identifier(f)))))
        .collect()
}

fn read(path: &Path) -> Result<Vec<u8>, String> {
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

/// Builds the FMUs of the model file `model` into `out` (see the module docs).
pub fn build_fmus(model: &Path, out: &Path, opts: &BuildOptions) -> Result<Vec<PathBuf>, String> {
    let model = model
        .canonicalize()
        .map_err(|e| format!("{}: {e}", model.display()))?;
    let model_toml =
        zmp_files::read_limited_text(&model, zmp_files::limits::MODEL_BYTES, "a model file")
            .map_err(|e| e.to_string())?;
    let spec =
        ModelSpec::parse(&model_toml, &model.display().to_string()).map_err(|e| e.to_string())?;
    let name = model_name(&spec, &model);
    let targets = fmu_paths(out, opts);
    // Every destination is checked before the builds (and again when written): an existing
    // file needs --force, and only an FMU is ever replaced.
    let mut existing = Vec::new();
    for (_, _, p) in &targets {
        match zmp_files::check_file(p, zmp_files::Kind::Fmu, opts.force) {
            Ok(()) => {}
            Err(e) if e.is_exists() => existing.push(p.display().to_string()),
            Err(e) => return Err(e.to_string()),
        }
    }
    if !existing.is_empty() {
        return Err(format!(
            "refusing to overwrite {} (use --force)",
            existing.join(", ")
        ));
    }
    let fmi2 = cargo_build("zmp-fmu", opts, &[])?;
    let fmi2_lib = fmi2
        .dylibs
        .first()
        .ok_or("cargo build -p zmp-fmu produced no shared library")?;
    let fmi2_bytes = read(fmi2_lib)?;
    let mut written = Vec::new();
    for (kind, fmi, path) in &targets {
        let entries = match fmi {
            FmiVersion::V2 => fmi2_entries(*kind, &model_toml, &name, &fmi2_bytes)?,
            FmiVersion::V3 => {
                let package = match kind {
                    Kind::Plant => "zmp-fmi3-plant",
                    Kind::Controller => "zmp-fmi3-controller",
                    Kind::Passthrough => unreachable!("no FMI 3.0 pass-through"),
                };
                let a = cargo_build(package, opts, &[("ZMP_FMU_MODEL", &model)])?;
                let lib = a.dylibs.first().ok_or_else(|| {
                    format!("cargo build -p {package} produced no shared library")
                })?;
                let exe = a
                    .executables
                    .first()
                    .ok_or_else(|| format!("cargo build -p {package} produced no executable"))?;
                let xml = Command::new(exe)
                    .arg("--model-description")
                    .output()
                    .map_err(|e| format!("{}: {e}", exe.display()))?;
                if !xml.status.success() {
                    return Err(format!(
                        "{} --model-description failed: {}",
                        exe.display(),
                        String::from_utf8_lossy(&xml.stderr)
                    ));
                }
                let xml = String::from_utf8(xml.stdout).map_err(|e| e.to_string())?;
                fmi3_entries(*kind, &model_toml, xml, &read(lib)?)
            }
        };
        zmp_files::write_file(
            path,
            zmp_files::Kind::Fmu,
            &zip_bytes(&entries)?,
            opts.force,
        )
        .map_err(|e| e.to_string())?;
        written.push(path.clone());
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_workspace_is_the_nearest_directory_declaring_one() {
        let base = std::env::temp_dir().join(format!("zmp-ws-test-{}", std::process::id()));
        let pkg = base.join("ws/tools/xtask");
        std::fs::create_dir_all(&pkg).unwrap();
        std::fs::write(
            base.join("ws/Cargo.toml"),
            "[workspace]\nmembers = [\"tools/xtask\"]\n",
        )
        .unwrap();
        std::fs::write(pkg.join("Cargo.toml"), "[package]\nname = \"xtask\"\n").unwrap();
        let found = enclosing_workspace(&pkg).unwrap();
        assert_eq!(found, base.join("ws").canonicalize().unwrap());
        // A package outside any workspace: none (the compiled-in root is used).
        let lone = base.join("lone");
        std::fs::create_dir_all(&lone).unwrap();
        std::fs::write(lone.join("Cargo.toml"), "[package]\nname = \"lone\"\n").unwrap();
        assert!(enclosing_workspace(&lone).is_none_or(|r| !r.starts_with(&base)));
        // This crate's own tests run in this workspace.
        assert!(workspace_root().join("fmu/core/Cargo.toml").exists());
        std::fs::remove_dir_all(&base).unwrap();
    }
}
