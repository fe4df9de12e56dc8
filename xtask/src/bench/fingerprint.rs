//! What the instruction counts depend on besides our own code: the toolchain, the C library,
//! valgrind, and the third-party crates compiled into the count binaries and the FMU.
//!
//! The crates are read from `cargo metadata`'s resolved graph, following normal and build
//! dependencies only: a test-only dependency (a dev-dependency) is not in the binaries, and a
//! workspace member is our own code, which is what the gate measures, so neither changes the
//! fingerprint.

use anyhow::{anyhow, bail, Context, Result};
use serde_json::Value;
use sha2::{Digest, Sha256};
use std::collections::{BTreeSet, HashMap};
use std::process::{Command, Stdio};

use super::gate::Fingerprint;
use crate::env::repo_root;

/// The packages whose binaries are counted.
const ROOTS: [&str; 2] = ["zmp-bench", "zmp-fmu"];

fn first_line(program: &str, args: &[&str]) -> Result<String> {
    let out = Command::new(program)
        .args(args)
        .current_dir(repo_root())
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("running {program} {}", args.join(" ")))?;
    if !out.status.success() {
        bail!("{program} {} failed ({})", args.join(" "), out.status);
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .next()
        .unwrap_or("")
        .trim()
        .to_string())
}

/// The fingerprint of this machine and checkout.
pub fn fingerprint() -> Result<Fingerprint> {
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let out = Command::new(&cargo)
        .args(["metadata", "--format-version", "1", "--locked"])
        .current_dir(repo_root())
        .stdin(Stdio::null())
        .stderr(Stdio::inherit())
        .output()
        .context("running cargo metadata")?;
    if !out.status.success() {
        bail!("cargo metadata failed ({})", out.status);
    }
    let metadata: Value =
        serde_json::from_slice(&out.stdout).context("parsing the output of cargo metadata")?;
    Ok(Fingerprint {
        rustc: first_line(&rustc, &["-V"])?,
        cargo_lock: closure_hash(&metadata, &ROOTS).context("hashing the dependency closure")?,
        glibc: first_line("getconf", &["GNU_LIBC_VERSION"])?,
        valgrind: first_line("valgrind", &["--version"])
            .context("valgrind is needed for the instruction counts: run `cargo xtask setup`")?,
    })
}

/// SHA-256 over the sorted `name version source` lines of the third-party packages that the
/// workspace members `roots` reach through normal and build dependencies, transitively.
pub fn closure_hash(metadata: &Value, roots: &[&str]) -> Result<String> {
    let packages = metadata["packages"]
        .as_array()
        .ok_or_else(|| anyhow!("cargo metadata: no `packages`"))?;
    let by_id: HashMap<&str, &Value> = packages
        .iter()
        .filter_map(|p| Some((p["id"].as_str()?, p)))
        .collect();
    let nodes: HashMap<&str, &Value> = metadata["resolve"]["nodes"]
        .as_array()
        .ok_or_else(|| anyhow!("cargo metadata: no `resolve.nodes`"))?
        .iter()
        .filter_map(|n| Some((n["id"].as_str()?, n)))
        .collect();
    let mut stack = Vec::new();
    for root in roots {
        let id = packages
            .iter()
            .find(|p| p["name"] == *root && p["source"].is_null())
            .and_then(|p| p["id"].as_str())
            .ok_or_else(|| anyhow!("cargo metadata: no workspace package {root:?}"))?;
        stack.push(id);
    }
    let mut visited: BTreeSet<&str> = BTreeSet::new();
    let mut lines: BTreeSet<String> = BTreeSet::new();
    while let Some(id) = stack.pop() {
        if !visited.insert(id) {
            continue;
        }
        let p = by_id
            .get(id)
            .ok_or_else(|| anyhow!("cargo metadata: no package {id:?}"))?;
        if let Some(source) = p["source"].as_str() {
            let field = |k: &str| p[k].as_str().unwrap_or("?").to_string();
            lines.insert(format!("{} {} {source}", field("name"), field("version")));
        }
        let deps = nodes.get(id).and_then(|n| n["deps"].as_array());
        for d in deps.into_iter().flatten() {
            let shipped = d["dep_kinds"]
                .as_array()
                .is_some_and(|k| k.iter().any(|k| k["kind"] != "dev"));
            if shipped {
                if let Some(dep) = d["pkg"].as_str() {
                    stack.push(dep);
                }
            }
        }
    }
    let mut h = Sha256::new();
    for line in &lines {
        h.update(line.as_bytes());
        h.update(b"\n");
    }
    let hex: String = h.finalize().iter().map(|b| format!("{b:02x}")).collect();
    Ok(format!("sha256:{hex} ({} packages)", lines.len()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn pkg(id: &str, name: &str, source: Option<&str>) -> Value {
        json!({"id": id, "name": name, "version": "1.0.0", "source": source})
    }

    fn dep(pkg: &str, kind: Option<&str>) -> Value {
        json!({"pkg": pkg, "dep_kinds": [{"kind": kind}]})
    }

    fn metadata(test_dep: &str, lib_source: &str) -> Value {
        json!({
            "packages": [
                pkg("a", "a", None),
                pkg("member", "member", None),
                pkg("lib", "lib", Some(lib_source)),
                pkg("build", "build", Some("registry")),
                pkg("test", test_dep, Some("registry")),
                pkg("other", "other", Some("registry")),
            ],
            "resolve": {"nodes": [
                {"id": "a", "deps": [dep("member", None), dep("test", Some("dev"))]},
                {"id": "member", "deps": [dep("lib", None), dep("build", Some("build"))]},
                {"id": "lib", "deps": []},
                {"id": "build", "deps": []},
                {"id": "test", "deps": []},
                {"id": "other", "deps": []},
            ]}
        })
    }

    #[test]
    fn the_hash_covers_shipped_third_party_code_only() {
        let h = closure_hash(&metadata("scraper", "registry"), &["a"]).unwrap();
        // lib and build: the members a and member are ours, test is dev-only, other unrelated.
        assert!(h.ends_with("(2 packages)"), "{h}");
        // A dev-dependency may change freely.
        assert_eq!(
            closure_hash(&metadata("roxmltree", "registry"), &["a"]).unwrap(),
            h
        );
        // A shipped dependency from another source may not.
        assert_ne!(
            closure_hash(&metadata("scraper", "git"), &["a"]).unwrap(),
            h
        );
        assert!(closure_hash(&metadata("x", "registry"), &["missing"]).is_err());
    }
}
