//! Step 8: the identified model file (with `[stderr]` and `[provenance]`), its writing, the
//! date it carries, and the JSON summary.

use super::{Identification, IdentifyError, IdentifyOptions, POOR_FIT};
use zmp_campaign::ledger::utc_now;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, Channel, EffectInstance, ModelSpec};

fn fl(v: f64) -> toml::Value {
    toml::Value::Float(v)
}

/// Step 8: the model file.
pub(super) fn build_model(
    ident: &Identification,
    opts: &IdentifyOptions,
) -> Result<ModelSpec, IdentifyError> {
    let mut spec = match &opts.start_model {
        Some(m) => m.clone(),
        None => ModelSpec::parse(
            include_str!("../../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .map_err(|e| IdentifyError::FitFailed(e.to_string()))?,
    };
    let name = ident.campaign_name.as_deref().unwrap_or("campaign");
    spec.name = Some(format!("identified from {name}"));
    spec.description = Some(format!(
        "Identified by zmp-toolkit {} (first seed, section 5) from {} of {} records; \
         uncertainty delta = 0 (nominal).",
        env!("CARGO_PKG_VERSION"),
        ident.used().count(),
        ident.records.len()
    ));
    let fail = |what: &str| IdentifyError::FitFailed(format!("cannot set {what} in the model"));
    let mut se_pend = toml::Table::new();
    let mut pendulum = spec.pendulum().ok_or_else(|| fail("the pendulum"))?;
    for (m, letter) in [(&ident.a, 'a'), (&ident.b, 'b')] {
        for (i, row) in m.iter().enumerate() {
            for (j, prm) in row.iter().enumerate() {
                // A structure without a coupling channel (both terms zero in the model given)
                // keeps it out.
                let absent = i != j
                    && opts
                        .start_model
                        .as_ref()
                        .and_then(ModelSpec::pendulum)
                        .is_some_and(|p| p.a[i][j] == 0.0 && p.b[i][j] == 0.0);
                if absent {
                    continue;
                }
                let slot = if letter == 'a' {
                    &mut pendulum.a[i][j]
                } else {
                    &mut pendulum.b[i][j]
                };
                *slot = prm.value;
                se_pend.insert(format!("{letter}{}{}", i + 1, j + 1), fl(prm.stderr));
            }
        }
    }
    spec.set_pendulum(&pendulum);
    let lp = zmp_models::EffectKind::TrackingLowpass.info();
    for axis in Axis::BOTH {
        spec.insert(EffectInstance {
            info: lp,
            binding: Binding::Axis(axis),
            values: vec![ident.bandwidth.omega_n, ident.bandwidth.zeta],
        });
    }
    let unc = zmp_models::EffectKind::Uncertainty.info();
    let mut se_unc = toml::Table::new();
    for (ch, cu) in Channel::ALL.iter().zip(&ident.uncertainty) {
        let (k, z, p) = cu.weight;
        spec.insert(EffectInstance {
            info: unc,
            binding: Binding::Channel(*ch),
            values: vec![k, z, p, 0.0, 0.0],
        });
        let _ = &mut se_unc;
    }
    let mut stderr = toml::Table::new();
    stderr.insert(EffectKind::Pendulum.into(), toml::Value::Table(se_pend));
    if ident.bandwidth.estimated {
        let mut t = toml::Table::new();
        t.insert("omega_n".into(), fl(ident.bandwidth.omega_n_stderr));
        t.insert("zeta".into(), fl(ident.bandwidth.zeta_stderr));
        stderr.insert(EffectKind::TrackingLowpass.into(), toml::Value::Table(t));
    }
    let wants_limit = opts.include_saturation
        || opts
            .start_model
            .as_ref()
            .is_some_and(|m| m.has(EffectKind::AccelerationSaturation));
    if let (Some(l), true) = (ident.saturation.limit, wants_limit) {
        let sat = zmp_models::EffectKind::AccelerationSaturation.info();
        for axis in Axis::BOTH {
            // The limit is identified; a start model's other saturation parameters (its
            // passive damping) are kept, as its other effects are.
            let mut values = vec![l.clamp(1e-3, 1e3)];
            if let Some(start) = opts.start_model.as_ref().and_then(|m| {
                m.effects.iter().find(|e| {
                    e.info.kind == EffectKind::AccelerationSaturation
                        && e.binding == Binding::Axis(axis)
                })
            }) {
                values.extend(start.values.iter().skip(1));
            }
            spec.insert(EffectInstance {
                info: sat,
                binding: Binding::Axis(axis),
                values,
            });
        }
        if let Some(se) = ident.saturation.limit_stderr {
            let mut t = toml::Table::new();
            t.insert("limit".into(), fl(se));
            stderr.insert(
                EffectKind::AccelerationSaturation.into(),
                toml::Value::Table(t),
            );
        }
    }
    spec.stderr = stderr;
    let mut prov = toml::Table::new();
    prov.insert("campaign".into(), toml::Value::String(name.to_owned()));
    if let Some(p) = &opts.campaign_path {
        prov.insert(
            "campaign_path".into(),
            toml::Value::String(p.display().to_string()),
        );
    }
    let used = ident.used().count();
    prov.insert(
        "records".into(),
        toml::Value::Integer(ident.records.len() as i64),
    );
    prov.insert("records_used".into(), toml::Value::Integer(used as i64));
    prov.insert(
        "records_excluded".into(),
        toml::Value::Integer((ident.records.len() - used) as i64),
    );
    prov.insert("date".into(), toml::Value::String(utc_now()));
    prov.insert(
        "tool".into(),
        toml::Value::String(format!(
            "zmp-toolkit {} identify",
            env!("CARGO_PKG_VERSION")
        )),
    );
    prov.insert(
        "harmonics".into(),
        toml::Value::Integer(opts.harmonics as i64),
    );
    prov.insert("reduced_chi2".into(), fl(ident.reduced_chi2));
    prov.insert(
        "bandwidth".into(),
        toml::Value::String(if ident.bandwidth.estimated {
            "estimated".into()
        } else {
            "given".into()
        }),
    );
    spec.provenance = prov;
    spec.validate("identified model")
        .map_err(|e| IdentifyError::FitFailed(format!("the identified model is invalid: {e}")))?;
    Ok(spec)
}

/// Writes the model file atomically; an existing file needs `force`.
pub fn write_model(
    ident: &Identification,
    path: &std::path::Path,
    force: bool,
) -> anyhow::Result<()> {
    zmp_files::atomic_write(path, ident.model.to_toml().as_bytes(), force)
}

/// A JSON summary: parameters with standard errors, excluded records, warnings.
pub fn summary_json(ident: &Identification) -> serde_json::Value {
    let excluded: Vec<serde_json::Value> = ident
        .records
        .iter()
        .filter_map(|r| {
            r.excluded
                .as_ref()
                .map(|w| serde_json::json!({"record": r.index, "reason": w}))
        })
        .collect();
    serde_json::json!({
        "campaign": ident.campaign_name,
        "records": ident.records.len(),
        "records_used": ident.used().count(),
        "parameters": ident.parameters(),
        "bandwidth": ident.bandwidth,
        "saturation": ident.saturation,
        EffectKind::Uncertainty: ident.uncertainty,
        "reduced_chi2": ident.reduced_chi2,
        "poor_fit": ident.reduced_chi2 > POOR_FIT,
        "delay_alternative": ident.delay_alternative,
        "excluded": excluded,
        "warnings": ident.warnings,
    })
}
