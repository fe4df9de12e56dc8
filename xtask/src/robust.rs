//! `cargo xtask robust --model M.toml`: the closed loop against the model's identified
//! multiplicative uncertainty (`zmp_models::robust`): `||W T||_inf` per channel, the structured
//! margin and the perturbation that breaks the tightest channel.

use crate::simulate::load_model;
use anyhow::{bail, Context, Result};
use std::path::Path;
use zmp_files::check_output_file;
use zmp_models::robust::{analyse_model, CascadeLoop, Grid, RobustAnalysis};
use zmp_report::robust::{summary, write_plot};

/// What `cargo xtask robust` was asked.
pub struct RobustArgs<'a> {
    pub model: &'a Path,
    /// `K1, K2` (default the seed's 0.014, 0.2).
    pub gains: Option<(f64, f64)>,
    /// CoM per radian of trunk, m/rad (default the seed's convention, 0.17 * 0.65).
    pub trunk_gain: Option<f64>,
    /// Controller sample period, s (default 0.01).
    pub period: Option<f64>,
    pub plot: Option<&'a Path>,
    pub force: bool,
    pub json: bool,
}

/// Parses `K1,K2`.
pub fn parse_gains(s: &str) -> Result<(f64, f64)> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != 2 {
        bail!("--gains expects K1,K2 (e.g. 0.014,0.2), got {s:?}");
    }
    let k1: f64 = parts[0]
        .parse()
        .with_context(|| format!("--gains: K1 {:?}", parts[0]))?;
    let k2: f64 = parts[1]
        .parse()
        .with_context(|| format!("--gains: K2 {:?}", parts[1]))?;
    if !(k1 > 0.0 && k2 > 0.0 && k1.is_finite() && k2.is_finite()) {
        bail!("--gains: K1 and K2 must be positive, got {k1}, {k2}");
    }
    Ok((k1, k2))
}

/// The controller asked for.
pub fn controller(a: &RobustArgs) -> Result<CascadeLoop> {
    let mut c = CascadeLoop::seed();
    if let Some((k1, k2)) = a.gains {
        c.params.k1 = k1;
        c.params.k2 = k2;
    }
    if let Some(g) = a.trunk_gain {
        if !(g > 0.0 && g.is_finite()) {
            bail!("--trunk-gain must be a positive number of m/rad, got {g}");
        }
        // Only the product (m_t/m_r) l_t enters the loop.
        c.params.mass_ratio = 1.0;
        c.params.trunk_length = g;
    }
    if let Some(t) = a.period {
        if !(0.0..=1.0).contains(&t) {
            bail!("--period must be in [0, 1] s (0: continuous), got {t}");
        }
        c.period = t;
    }
    Ok(c)
}

/// `cargo xtask robust`.
pub fn robust(a: &RobustArgs) -> Result<RobustAnalysis> {
    if let Some(p) = a.plot {
        check_output_file(p, a.force)?;
    }
    let spec = load_model(a.model)?;
    let ctrl = controller(a)?;
    let r = analyse_model(&spec, &ctrl, &Grid::default())
        .with_context(|| format!("building the plant of {}", a.model.display()))?;
    if let Some(p) = a.plot {
        write_plot(p, &r, a.force)?;
    }
    let s = summary(&r);
    if a.json {
        let mut v = serde_json::to_value(&s)?;
        v["model"] = serde_json::json!(a.model);
        if let Some(c) = r.tightest_channel() {
            if let Some(p) = r.critical_perturbation(c.channel) {
                v["critical_perturbation"] = serde_json::json!({
                    "channel": c.channel.to_string(), "delta": p.delta,
                    "allpass_rad_s": p.allpass, "omega": p.omega});
            }
        }
        if let Some(p) = a.plot {
            v["plot"] = serde_json::json!(p);
        }
        println!("{}", serde_json::to_string_pretty(&v)?);
        return Ok(r);
    }
    println!("model: {}", a.model.display());
    println!("controller: {}", r.controller);
    match r.unstable_poles {
        Some(0) => println!("nominal closed loop: stable"),
        Some(n) => println!("nominal closed loop: UNSTABLE ({n} poles in the right half-plane)"),
        None => println!("nominal closed loop: a pole on the imaginary axis"),
    }
    if !r.nominally_stable() {
        // Margins of a loop that is unstable without any perturbation mean nothing.
        println!("verdict: {}", s.line);
        return Ok(r);
    }
    if !r.channels.is_empty() {
        println!(
            "{:<6} {:<18} {:>26} {:>10} {:>12}",
            "", "loop", "weight W", "||W T||", "at (rad/s)"
        );
    }
    for c in &r.channels {
        println!(
            "{:<6} {:<18} {:>26} {:>10.4} {:>12.4}",
            c.channel.to_string(),
            zmp_report::robust::channel_words(c.channel),
            format!(
                "{:.3} (s + {:.3})/(s + {:.3})",
                c.weight.k, c.weight.z, c.weight.p
            ),
            c.peak,
            c.omega
        );
    }
    if let Some(st) = r.structured {
        println!(
            "all channels at once: mu upper bound {:.4} at {:.4} rad/s, margin {:.3}x the weights",
            st.peak,
            st.omega,
            1.0 / st.peak
        );
    }
    if let Some(c) = r.tightest_channel() {
        if let Some(p) = r.critical_perturbation(c.channel) {
            let shape = p
                .allpass
                .map_or(String::new(), |q| format!(" * ({q:.4} - s)/({q:.4} + s)"));
            println!(
                "smallest perturbation of {} that puts a pole on the axis: Delta(s) = {:.4}{shape} \
                 (|Delta| = {:.3} {} 1, at {:.4} rad/s)",
                c.channel,
                p.delta,
                p.delta.abs(),
                if p.delta.abs() <= 1.0 { "<=" } else { ">" },
                p.omega
            );
        }
    }
    println!("verdict: {}", s.line);
    if let Some(p) = a.plot {
        println!("plot -> {}", p.display());
    }
    Ok(r)
}

/// The line `identify` and `loop` print: the seed's controller on the model.
pub fn seed_controller_check(spec: &zmp_models::ModelSpec) -> Result<RobustAnalysis> {
    Ok(analyse_model(spec, &CascadeLoop::seed(), &Grid::default())?)
}
