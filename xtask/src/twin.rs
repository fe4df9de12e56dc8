//! `cargo xtask validate <robot>`: the MuJoCo twins. The twin crate (`validation/twin`, binary
//! `zmp-twin`) is the only one that links MuJoCo; xtask runs it through
//! `cargo run --release -p zmp-twin` with the prerequisites' environment
//! (`MUJOCO_DYNAMIC_LINK_DIR`, absolute), so xtask itself never links MuJoCo and a plain
//! `cargo build` needs no MuJoCo.
//!
//! Frames of the robot need the twin's `renderer` feature (EGL): it is enabled when the EGL
//! library is on this machine (`cargo xtask setup` installs Mesa's); otherwise the report is
//! written without frames and says why.

use crate::env::{apply_env, repo_root, Prereqs};
use anyhow::{bail, Context, Result};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// Where the EGL loader is looked for.
const EGL_DIRS: &[&str] = &[
    "/usr/lib/x86_64-linux-gnu",
    "/usr/lib/aarch64-linux-gnu",
    "/usr/lib64",
    "/usr/lib",
    "/lib/x86_64-linux-gnu",
];

/// `Ok` if `libEGL.so.1` is found, else why not.
pub fn egl_available() -> std::result::Result<PathBuf, String> {
    EGL_DIRS
        .iter()
        .map(|d| Path::new(d).join("libEGL.so.1"))
        .find(|p| p.exists())
        .ok_or_else(|| {
            format!(
                "libEGL.so.1 was not found in {} (`cargo xtask setup` installs libegl1 and \
                 Mesa's EGL driver)",
                EGL_DIRS.join(", ")
            )
        })
}

/// The `cargo run` of the twin binary with `args`, the prerequisites' environment and, if
/// `renderer`, the `renderer` feature.
pub fn twin_command(p: &Prereqs, renderer: bool, args: &[OsString]) -> Result<Command> {
    if !p.mujoco_lib_dir.is_absolute() {
        bail!(
            "the MuJoCo library folder {} is not an absolute path",
            p.mujoco_lib_dir.display()
        );
    }
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args([
        "run",
        "--release",
        "-q",
        "-p",
        "zmp-twin",
        "--bin",
        "zmp-twin",
    ]);
    if renderer {
        cmd.args(["--features", "renderer"]);
    }
    cmd.arg("--").args(args).current_dir(repo_root());
    crate::ci::strip_cargo_run_env(&mut cmd);
    apply_env(&mut cmd, p);
    Ok(cmd)
}

/// What `cargo xtask validate silo2` was asked.
pub struct Silo2Args<'a> {
    pub out: Option<&'a Path>,
    pub short: bool,
    pub extended: bool,
    pub force: bool,
    pub json: bool,
    pub readme: Option<&'a Path>,
}

fn silo2_args(a: &Silo2Args, egl: &std::result::Result<PathBuf, String>) -> Vec<OsString> {
    let mut args: Vec<OsString> = vec!["silo2".into(), "validate".into()];
    // The binary runs in the repository root: relative paths (and the default) are the user's.
    let o = a.out.unwrap_or(Path::new("out/twin-silo2"));
    let o = std::env::current_dir()
        .map(|d| d.join(o))
        .unwrap_or_else(|_| o.to_path_buf());
    args.push("--out".into());
    args.push(o.into());
    for (on, flag) in [
        (a.short, "--short"),
        (a.extended, "--extended"),
        (a.force, "--force"),
        (a.json, "--json"),
    ] {
        if on {
            args.push(flag.into());
        }
    }
    if let Err(why) = egl {
        args.push("--frames-unavailable".into());
        args.push(why.into());
    }
    if let Some(r) = a.readme {
        args.push("--readme".into());
        args.push(
            std::env::current_dir()
                .map(|d| d.join(r))
                .unwrap_or_else(|_| r.to_path_buf())
                .into(),
        );
    }
    args
}

/// `cargo xtask validate silo2`.
pub fn validate_silo2(a: &Silo2Args) -> Result<()> {
    let p = crate::setup::setup(true)?;
    let egl = egl_available();
    let mut cmd = twin_command(&p, egl.is_ok(), &silo2_args(a, &egl))?;
    let status = cmd
        .stdin(Stdio::null())
        .status()
        .context("starting cargo run -p zmp-twin")?;
    if !status.success() {
        bail!("validate silo2 failed ({status})");
    }
    Ok(())
}

/// The demo's step: the short SILO2 validation into `out/twin-silo2`; prints what it found.
pub fn demo_step(out: &Path, quiet: bool) -> Result<()> {
    let say = |s: &str| {
        if !quiet {
            println!("{s}");
        }
    };
    say("6. MuJoCo twin of SILO2 (short validation): campaign, identification, closed loop, diagnosis");
    let p = crate::setup::setup(true)?;
    let egl = egl_available();
    let dir = out.join("twin-silo2");
    let args = silo2_args(
        &Silo2Args {
            out: Some(&dir),
            short: true,
            extended: false,
            force: false,
            json: true,
            readme: None,
        },
        &egl,
    );
    let o = twin_command(&p, egl.is_ok(), &args)?
        .stdin(Stdio::null())
        .stderr(Stdio::inherit())
        .output()
        .context("starting cargo run -p zmp-twin")?;
    if !o.status.success() {
        bail!("the twin's validation failed ({})", o.status);
    }
    let s: serde_json::Value =
        serde_json::from_slice(&o.stdout).context("reading the twin's summary")?;
    let row = |n: &str| {
        s["parameters"]
            .as_array()
            .and_then(|a| a.iter().find(|r| r["name"] == n))
            .cloned()
            .unwrap_or_default()
    };
    let f = |v: &serde_json::Value| v.as_f64().unwrap_or(f64::NAN);
    for n in ["a11", "b11", "b22"] {
        let r = row(n);
        say(&format!(
            "   {n}: identified {:.4}, predicted from the twin's mass properties {:.4} (seed eqs. 6-15, point mass: {:.4})",
            f(&r["identified"]),
            f(&r["servo"]),
            f(&r["seed"])
        ));
    }
    let c = &s["closed_loop"]["comparison"];
    say(&format!(
        "   closed loop: reaches the reference at {:.1} s, 4 kg load peak error {:.1} mm, final error {:.2} mm; \
         identified model's prediction NRMSE {:.4}",
        f(&c["twin"]["reach_time_s"]),
        1e3 * f(&c["twin"]["load_peak_error_m"]),
        1e3 * f(&c["twin"]["final_error_m"]),
        f(&c["nrmse_x"])
    ));
    say(&format!(
        "   diagnosis: {}; report {}",
        s["diagnosis"]["verdict"].as_str().unwrap_or("?"),
        dir.join("report.html").display()
    ));
    for a in s["stance"].as_array().into_iter().flatten() {
        say(&format!(
            "   stance {}: {} ({})",
            a["axis"].as_str().unwrap_or("?"),
            a["verdict"].as_str().unwrap_or("?"),
            a["why"].as_str().unwrap_or("")
        ));
    }
    Ok(())
}

/// `cargo run --release -q -p zmp-twin --bin zmp-twin -- <args>` from the repository root with
/// the prerequisites' environment (no renderer feature); fails when the binary does.
pub fn run_twin(args: &[String], prereqs: &Prereqs) -> Result<()> {
    let args: Vec<OsString> = args.iter().map(OsString::from).collect();
    let mut cmd = twin_command(prereqs, false, &args)?;
    let status = cmd
        .status()
        .context("starting cargo run -p zmp-twin (the MuJoCo twin binary)")?;
    if !status.success() {
        bail!(
            "zmp-twin {} failed ({status})",
            args.iter()
                .map(|a| a.to_string_lossy().into_owned())
                .collect::<Vec<_>>()
                .join(" ")
        );
    }
    Ok(())
}
