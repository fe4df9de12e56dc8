//! The virtual robot: runs a stepped-sine campaign on a model (the same `zmp_models::Plant` every
//! other tool uses) and returns it in the `zmp-campaign/1` form, with ZMP sensor noise and
//! quantisation. Deterministic for a seed: record `k` draws its noise from `(seed, k)` alone, so
//! records can be simulated in parallel and the result does not depend on the thread count.
//! The plant runs record `k` as record `k` ([`Plant::set_record`]): a ZMP sensor re-zeroed at
//! every record drifts at that record's rate, drawn from the model's `sensor_drift.rate_seed`
//! and `k` (a normal law of mean `rate` and standard deviation `rate_spread`; see
//! `zmp_models::effects::sensor_drift`).
#![warn(missing_docs)]

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use zmp_campaign::{Campaign, Record, RecordMeta};
use zmp_models::{ModelSpec, Plant};

mod design;

pub use design::{
    ExperimentDesign, ListedRecord, MAX_CAMPAIGN_ROWS, MAX_DURATION_S, MAX_INTERNAL_STEPS,
    MAX_LIST, MAX_PERIODS, MAX_RECORDS, MAX_RECORD_ROWS, MAX_SAMPLE_RATE_HZ,
};

/// Rounds to the sensor resolution `q`, keeping decimal-friendly values (k / (1/q)).
fn quantise(v: f64, q: f64) -> f64 {
    if q <= 0.0 {
        return v;
    }
    let inv = (1.0 / q).round();
    if (inv * q - 1.0).abs() < 1e-12 {
        (v * inv).round() / inv
    } else {
        (v / q).round() * q
    }
}

/// Commanded references are written to the nanometre: far below any sensor, short in CSV.
fn to_nm(v: f64) -> f64 {
    (v * 1e9).round() / 1e9
}

/// Simulates one record.
pub fn simulate_record(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    index: usize,
    meta: RecordMeta,
) -> Result<Record, zmp_models::ModelError> {
    let mut plant = Plant::new(spec, design.internal_step)?;
    plant.set_record(index as u64);
    let h = design.internal_step;
    let dt = 1.0 / design.sample_rate_hz;
    let sub = (dt / h).round() as usize;
    let period = 2.0 * std::f64::consts::PI / meta.omega;
    let steady = (design.periods as f64 * period).max(design.min_steady_s);
    let steady = (steady / period).ceil() * period;
    let n = ((design.transient_s + steady) / dt).round() as usize + 1;
    let mut rng =
        ChaCha8Rng::seed_from_u64(design.seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ index as u64);
    let noise = Normal::new(0.0, design.zmp_noise_std.max(0.0)).expect("std >= 0");
    let op = meta.operating_point;
    plant.set_operating_point(op);
    plant.reset(op);
    let (ax, amp, omega) = (meta.excited.index(), meta.amplitude, meta.omega);
    let reference = move |t: f64| -> [f64; 2] {
        let mut r = op;
        r[ax] += amp * (omega * t).sin();
        r
    };
    let mut rec = Record {
        meta,
        t: Vec::with_capacity(n),
        x_cr: Vec::with_capacity(n),
        y_cr: Vec::with_capacity(n),
        zmp_x: Vec::with_capacity(n),
        zmp_y: Vec::with_capacity(n),
        extra: Vec::new(),
    };
    let (mut xc, mut yc) = (Vec::new(), Vec::new());
    let mut out = plant.last_output();
    let mut step = 0usize;
    for k in 0..n {
        let t = k as f64 * dt;
        while step < k * sub {
            step += 1;
            out = plant.step(reference(step as f64 * h));
        }
        let r = reference(t);
        rec.t.push(t);
        rec.x_cr.push(to_nm(r[0]));
        rec.y_cr.push(to_nm(r[1]));
        let zx = out.zmp[0]
            + if design.zmp_noise_std > 0.0 {
                noise.sample(&mut rng)
            } else {
                0.0
            };
        let zy = out.zmp[1]
            + if design.zmp_noise_std > 0.0 {
                noise.sample(&mut rng)
            } else {
                0.0
            };
        rec.zmp_x.push(quantise(zx, design.quantisation));
        rec.zmp_y.push(quantise(zy, design.quantisation));
        if design.record_com {
            xc.push(to_nm(out.com[0]));
            yc.push(to_nm(out.com[1]));
        }
    }
    if design.record_com {
        rec.extra = vec![("x_c".into(), xc), ("y_c".into(), yc)];
    }
    Ok(rec)
}

/// Runs the whole design on `spec`, records in parallel on the available cores.
pub fn simulate_campaign(spec: &ModelSpec, design: &ExperimentDesign) -> anyhow::Result<Campaign> {
    simulate_campaign_with_progress(spec, design, &|_| {})
}

/// As [`simulate_campaign`], calling `progress(done)` after each record.
pub fn simulate_campaign_with_progress(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    progress: &(dyn Fn(usize) + Sync),
) -> anyhow::Result<Campaign> {
    simulate_records_after(spec, design, 0, progress)
}

/// As [`simulate_campaign_with_progress`], the design's records numbered from `first` for
/// their noise: record `k` draws from `(seed, first + k)`. Records to append to a campaign of
/// `first` records simulated with the same seed (`cargo xtask simulate --append`) carry noise
/// of their own, as if the campaign had been longer.
pub fn simulate_records_after(
    spec: &ModelSpec,
    design: &ExperimentDesign,
    first: usize,
    progress: &(dyn Fn(usize) + Sync),
) -> anyhow::Result<Campaign> {
    design
        .check()
        .map_err(|e| anyhow::anyhow!("experiment design: {e}"))?;
    Plant::new(spec, design.internal_step)?;
    let metas = design.records();
    let workers = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(metas.len().max(1));
    let next = std::sync::atomic::AtomicUsize::new(0);
    let done = std::sync::atomic::AtomicUsize::new(0);
    let mut slots: Vec<Option<Record>> = vec![None; metas.len()];
    let results: Vec<Vec<(usize, Record)>> = std::thread::scope(|s| {
        let handles: Vec<_> = (0..workers)
            .map(|_| {
                s.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        if k >= metas.len() {
                            break;
                        }
                        let rec = simulate_record(spec, design, first + k, metas[k].clone())
                            .expect("model checked above");
                        mine.push((k, rec));
                        let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
                        progress(d);
                    }
                    mine
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().expect("simulation thread"))
            .collect()
    });
    for (k, r) in results.into_iter().flatten() {
        slots[k] = Some(r);
    }
    Ok(Campaign {
        name: Some(design.name.clone()),
        robot: Some(format!(
            "virtual: {}",
            spec.name.clone().unwrap_or_else(|| "model".into())
        )),
        sample_rate_hz: Some(design.sample_rate_hz),
        records: slots
            .into_iter()
            .map(|r| r.expect("every record simulated"))
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use zmp_models::harmonic::first_harmonic;
    use zmp_models::Axis;

    fn paper() -> ModelSpec {
        ModelSpec::parse(
            include_str!("../../../models/params/silo2-paper.toml"),
            "silo2-paper.toml",
        )
        .unwrap()
    }

    fn small_design() -> ExperimentDesign {
        ExperimentDesign {
            operating_points: vec![[0.0, 0.0]],
            amplitudes: vec![0.005],
            omegas: vec![1.0, 8.0],
            excited: vec![Axis::X, Axis::Y],
            ..ExperimentDesign::reference()
        }
    }

    #[test]
    fn deterministic_for_a_seed_and_seed_sensitive() {
        let spec = paper();
        let d = small_design();
        let a = simulate_campaign(&spec, &d).unwrap();
        let b = simulate_campaign(&spec, &d).unwrap();
        assert_eq!(a, b);
        let c = simulate_campaign(&spec, &ExperimentDesign { seed: 2, ..d }).unwrap();
        assert_ne!(a.records[0].zmp_x, c.records[0].zmp_x);
    }

    #[test]
    fn noiseless_record_steady_state_matches_frequency_response() {
        let spec = paper();
        let d = ExperimentDesign {
            zmp_noise_std: 0.0,
            quantisation: 0.0,
            ..small_design()
        };
        let camp = simulate_campaign(&spec, &d).unwrap();
        let plant = Plant::new(&spec, d.internal_step).unwrap();
        for rec in &camp.records {
            let w = rec.meta.omega;
            let dt = rec.dt();
            let period = 2.0 * std::f64::consts::PI / w;
            let start = (d.transient_s / dt).ceil() as usize;
            let n_per = (period / dt).round() as usize;
            let keep = ((rec.len() - start) / n_per) * n_per;
            let j = rec.meta.excited.index();
            let g = plant.frequency_response(w);
            let u = first_harmonic(
                &rec.input(rec.meta.excited)[start..start + keep],
                w,
                dt,
                rec.t[start],
            );
            for (i, out) in [&rec.zmp_x, &rec.zmp_y].iter().enumerate() {
                let y = first_harmonic(&out[start..start + keep], w, dt, rec.t[start]);
                let rel = ((y / u) - g[i][j]).norm() / g[i][j].norm();
                assert!(rel < 2e-3, "omega {w} G{}{}: rel err {rel}", i + 1, j + 1);
            }
        }
    }

    #[test]
    fn quantisation_and_noise_level() {
        let spec = paper();
        let d = small_design();
        let camp = simulate_campaign(&spec, &d).unwrap();
        for v in &camp.records[0].zmp_x {
            let k = v / d.quantisation;
            assert!((k - k.round()).abs() < 1e-6, "{v} not on the 0.1 mm grid");
        }
        let clean = simulate_campaign(
            &spec,
            &ExperimentDesign {
                zmp_noise_std: 0.0,
                quantisation: 0.0,
                ..d.clone()
            },
        )
        .unwrap();
        let r = &camp.records[1];
        let diff: Vec<f64> = r
            .zmp_y
            .iter()
            .zip(&clean.records[1].zmp_y)
            .map(|(a, b)| a - b)
            .collect();
        let std = (diff.iter().map(|e| e * e).sum::<f64>() / diff.len() as f64).sqrt();
        // Noise 0.5 mm plus uniform quantisation error 0.1 mm / sqrt(12).
        let expect = (0.0005f64.powi(2) + 0.0001f64.powi(2) / 12.0).sqrt();
        assert!(
            (std / expect - 1.0).abs() < 0.05,
            "noise std {std} vs {expect}"
        );
    }

    #[test]
    fn design_errors_name_the_field() {
        let d = ExperimentDesign {
            omegas: vec![1.0, 1000.0],
            ..small_design()
        };
        assert!(d.check().unwrap_err().contains("Nyquist"));
        let d = ExperimentDesign {
            sample_rate_hz: 300.0,
            ..small_design()
        };
        assert!(d.check().unwrap_err().contains("internal steps"));
        let d = ExperimentDesign {
            amplitudes: vec![0.0],
            ..small_design()
        };
        assert!(d.check().unwrap_err().contains("amplitudes"));
    }

    /// The list form runs its records in its order, each as the grid form runs the same
    /// record (same noise stream: same samples); numbered from `first`, a record draws the
    /// noise of that place in a longer campaign.
    #[test]
    fn a_listed_design_runs_its_records_as_the_grid_does() {
        let spec = paper();
        let grid = small_design();
        let metas = grid.records();
        let listed = ExperimentDesign {
            operating_points: Vec::new(),
            amplitudes: Vec::new(),
            omegas: Vec::new(),
            excited: Vec::new(),
            records: metas
                .iter()
                .map(|m| ListedRecord {
                    excited: m.excited,
                    omega: m.omega,
                    amplitude: m.amplitude,
                    operating_point: m.operating_point,
                })
                .collect(),
            ..grid.clone()
        };
        assert_eq!(listed.records(), metas);
        let a = simulate_campaign(&spec, &grid).unwrap();
        let b = simulate_campaign(&spec, &listed).unwrap();
        assert!(a == b);
        let n = metas.len();
        let later = simulate_records_after(&spec, &listed, n, &|_| {}).unwrap();
        assert!(later.records[0].zmp_x != a.records[0].zmp_x);
        let longer = ExperimentDesign {
            records: [listed.records.clone(), listed.records.clone()].concat(),
            ..listed.clone()
        };
        let both = simulate_campaign(&spec, &longer).unwrap();
        assert!(later.records[0].zmp_x == both.records[n].zmp_x);
    }

    #[test]
    fn a_listed_design_is_read_and_its_errors_name_the_field() {
        let head = "sample_rate_hz = 200.0\ntransient_s = 3.0\nperiods = 4\n\
                    min_steady_s = 8.0\nzmp_noise_std = 0.0005\nquantisation = 0.0001\nseed = 1\n";
        let rec = |omega: &str| {
            format!(
                "[[records]]\nexcited = \"y\"\nomega = {omega}\namplitude = 0.002\n\
                 operating_point = [0.0, 0.02]\n"
            )
        };
        let d =
            ExperimentDesign::from_toml(&format!("{head}{}{}", rec("20.0"), rec("3.0")), "d.toml")
                .unwrap();
        let metas = d.records();
        assert_eq!(metas.len(), 2);
        assert_eq!(metas[1].omega, 3.0);
        assert_eq!(metas[0].excited, Axis::Y);
        assert_eq!(metas[0].operating_point, [0.0, 0.02]);
        let e =
            ExperimentDesign::from_toml(&format!("{head}{}{}", rec("20.0"), rec("1e5")), "d.toml")
                .unwrap_err();
        assert!(e.starts_with("d.toml: records[1].omega = 100000"), "{e}");
        let e =
            ExperimentDesign::from_toml(&format!("{head}omegas = [1.0]\n{}", rec("2.0")), "d.toml")
                .unwrap_err();
        assert!(e.contains("not both"), "{e}");
        let e = ExperimentDesign::from_toml(
            &format!("{head}{}", rec("2.0").replace("amplitude", "amplitud")),
            "d.toml",
        )
        .unwrap_err();
        assert!(e.starts_with("d.toml") && e.contains("amplitud"), "{e}");
        let e = ExperimentDesign::from_toml(head, "d.toml").unwrap_err();
        assert!(e.contains("operating_points is empty"), "{e}");
    }

    #[test]
    fn reference_design_size() {
        let d = ExperimentDesign::reference();
        assert_eq!(d.records().len(), 168);
    }
}
