//! Where the project's prerequisites live, and how child processes find them.
//!
//! Everything that `cargo xtask setup` installs outside the system package
//! manager goes under one directory, `$ZMP_DEPS_DIR` or, by default,
//! `$HOME/.cache/zmp-toolkit`. It lives outside the clone so that repeated CI
//! runs on one machine (each in a fresh clone) reuse it; a fresh machine just
//! downloads it again.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

/// MuJoCo version whose shared library we extract from the PyPI wheel.
pub const MUJOCO_VERSION: &str = "3.17.0";

/// Paths of the prerequisites installed by `cargo xtask setup`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Prereqs {
    /// Root of everything setup downloads (`$ZMP_DEPS_DIR` or `$HOME/.cache/zmp-toolkit`).
    pub deps_dir: PathBuf,
    /// Directory holding `libmujoco.so` (and `libmujoco.so.3.17.0`).
    pub mujoco_lib_dir: PathBuf,
    /// Python virtual environment with FMPy, numpy and matplotlib.
    pub venv_dir: PathBuf,
    /// The venv's interpreter, `venv_dir/bin/python`.
    pub python: PathBuf,
}

impl Prereqs {
    /// `venv_dir/bin`: the interpreter and console scripts such as `fmpy`.
    pub fn venv_bin(&self) -> PathBuf {
        self.venv_dir.join("bin")
    }

    /// The versioned MuJoCo shared library file itself.
    pub fn mujoco_lib(&self) -> PathBuf {
        self.mujoco_lib_dir
            .join(format!("libmujoco.so.{MUJOCO_VERSION}"))
    }
}

/// `$ZMP_DEPS_DIR` if set and non-empty, else `$HOME/.cache/zmp-toolkit`
/// (or `<tmp>/zmp-toolkit` if there is no `$HOME`).
pub fn deps_dir() -> PathBuf {
    if let Some(dir) = std::env::var_os("ZMP_DEPS_DIR").filter(|d| !d.is_empty()) {
        return absolute(PathBuf::from(dir));
    }
    match std::env::var_os("HOME").filter(|h| !h.is_empty()) {
        Some(home) => PathBuf::from(home).join(".cache").join("zmp-toolkit"),
        None => std::env::temp_dir().join("zmp-toolkit"),
    }
}

/// The prerequisite paths for this machine (nothing is checked or created).
pub fn prereqs() -> Prereqs {
    let deps_dir = deps_dir();
    let mujoco_lib_dir = deps_dir
        .join(format!("mujoco-{MUJOCO_VERSION}"))
        .join("lib");
    let venv_dir = deps_dir.join("venv");
    let python = venv_dir.join("bin").join("python");
    Prereqs {
        deps_dir,
        mujoco_lib_dir,
        venv_dir,
        python,
    }
}

/// Make `cmd` see the prerequisites:
/// `MUJOCO_DYNAMIC_LINK_DIR` = the MuJoCo lib dir, which is also prepended to
/// `LD_LIBRARY_PATH`; `ZMP_PYTHON` = the venv's interpreter (tests that need
/// FMPy use it); and `venv/bin` prepended to `PATH`.
pub fn apply_env(cmd: &mut Command, p: &Prereqs) {
    cmd.env("MUJOCO_DYNAMIC_LINK_DIR", &p.mujoco_lib_dir);
    cmd.env(
        "LD_LIBRARY_PATH",
        prepend_path(&p.mujoco_lib_dir, current_var(cmd, "LD_LIBRARY_PATH")),
    );
    cmd.env("ZMP_PYTHON", &p.python);
    cmd.env(
        "PATH",
        prepend_path(&p.venv_bin(), current_var(cmd, "PATH")),
    );
}

/// Root of the repository (the workspace directory containing `xtask/`): the one `cargo
/// xtask` runs in (see [`zmp_fmu_core::package::workspace_root`]).
pub fn repo_root() -> PathBuf {
    zmp_fmu_core::package::workspace_root()
}

/// The value `cmd` would see for `key`: an explicit override on `cmd` wins
/// over the inherited environment.
fn current_var(cmd: &Command, key: &str) -> Option<OsString> {
    for (k, v) in cmd.get_envs() {
        if k == key {
            return v.map(|v| v.to_os_string());
        }
    }
    std::env::var_os(key)
}

/// `dir` followed by the entries of `existing`, without duplicating `dir`
/// and without empty entries (an empty entry would mean "current directory").
fn prepend_path(dir: &Path, existing: Option<OsString>) -> OsString {
    let mut parts = vec![dir.to_path_buf()];
    if let Some(existing) = existing {
        parts.extend(
            std::env::split_paths(&existing).filter(|e| !e.as_os_str().is_empty() && e != dir),
        );
    }
    std::env::join_paths(&parts).unwrap_or_else(|_| {
        // Only fails if `dir` itself contains ':'; nothing sensible to do but
        // pass it through and let the consumer complain.
        dir.as_os_str().to_os_string()
    })
}

fn absolute(p: PathBuf) -> PathBuf {
    if p.is_absolute() {
        p
    } else {
        std::env::current_dir().map(|d| d.join(&p)).unwrap_or(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prepend_dedups_and_drops_empty() {
        let got = prepend_path(Path::new("/a"), Some("/b::/a:/c".into()));
        assert_eq!(got, OsString::from("/a:/b:/c"));
        assert_eq!(prepend_path(Path::new("/a"), None), OsString::from("/a"));
    }

    #[test]
    fn apply_env_sets_vars() {
        let p = Prereqs {
            deps_dir: "/d".into(),
            mujoco_lib_dir: "/d/mj/lib".into(),
            venv_dir: "/d/venv".into(),
            python: "/d/venv/bin/python".into(),
        };
        let mut cmd = Command::new("true");
        cmd.env("PATH", "/usr/bin");
        cmd.env("LD_LIBRARY_PATH", "");
        apply_env(&mut cmd, &p);
        let get = |k: &str| {
            cmd.get_envs()
                .find(|(key, _)| *key == k)
                .and_then(|(_, v)| v.map(|v| v.to_os_string()))
        };
        assert_eq!(get("PATH"), Some("/d/venv/bin:/usr/bin".into()));
        assert_eq!(get("LD_LIBRARY_PATH"), Some("/d/mj/lib".into()));
        assert_eq!(get("MUJOCO_DYNAMIC_LINK_DIR"), Some("/d/mj/lib".into()));
        assert_eq!(get("ZMP_PYTHON"), Some("/d/venv/bin/python".into()));
    }
}
