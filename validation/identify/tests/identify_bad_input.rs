//! Bad input gives a clear error or a warning that names the records, never a silent fit; the
//! model file parses back and is not overwritten without force.
#![allow(clippy::needless_range_loop)]

use zmp_campaign::{Campaign, Record, RecordMeta};
use zmp_identify::{
    analyse_records, identify, reason, write_model, IdentifyError, IdentifyOptions, NoiseSource,
};
use zmp_models::logspace;
use zmp_models::EffectKind;
use zmp_models::{Axis, Binding, ModelSpec};
use zmp_virtual_robot::{simulate_campaign, ExperimentDesign};

fn paper() -> ModelSpec {
    ModelSpec::parse(
        include_str!("../../../models/params/silo2-paper.toml"),
        "silo2-paper.toml",
    )
    .unwrap()
}

fn small(omegas: Vec<f64>) -> Campaign {
    let d = ExperimentDesign {
        operating_points: vec![[0.0, 0.0]],
        amplitudes: vec![0.005],
        omegas,
        ..ExperimentDesign::reference()
    };
    simulate_campaign(&paper(), &d).unwrap()
}

#[test]
fn narrow_frequency_span_is_an_error() {
    let camp = small(vec![2.0, 2.2, 2.4]);
    let e = identify(&camp, &IdentifyOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, IdentifyError::FrequencySpan(_)), "{msg}");
    assert!(msg.contains("cannot be separated"), "{msg}");
    assert!(msg.contains("records 0, 1, 2"), "{msg}");
    let camp = small(vec![3.0]);
    assert!(identify(&camp, &IdentifyOptions::default()).is_err());
}

#[test]
fn short_zero_and_constant_records_are_named() {
    let mut camp = small(logspace(0.5, 15.0, 8));
    // Record 2: cut below two periods.
    let r = &mut camp.records[2];
    let keep = ((2.0 * std::f64::consts::PI / r.meta.omega) * 1.5 / r.dt()) as usize;
    for c in [
        &mut r.t,
        &mut r.x_cr,
        &mut r.y_cr,
        &mut r.zmp_x,
        &mut r.zmp_y,
    ] {
        c.truncate(keep);
    }
    // Record 5: zero amplitude, constant input.
    let r = &mut camp.records[5];
    r.meta.amplitude = 0.0;
    let v = r.x_cr[0];
    r.x_cr.iter_mut().for_each(|x| *x = v);
    // Records 9 and 11: constant output.
    for k in [9, 11] {
        let r = &mut camp.records[k];
        r.zmp_y.iter_mut().for_each(|x| *x = 0.0);
    }
    let id = identify(&camp, &IdentifyOptions::default()).unwrap();
    let ex = |k: usize| id.records[k].excluded.clone();
    assert_eq!(ex(2).as_deref(), Some(reason::TOO_SHORT));
    assert_eq!(ex(5).as_deref(), Some(reason::ZERO_AMPLITUDE));
    assert_eq!(ex(9).as_deref(), Some(reason::CONSTANT_OUTPUT));
    assert_eq!(ex(11).as_deref(), Some(reason::CONSTANT_OUTPUT));
    let all = id.warnings.join("\n");
    eprintln!("{all}");
    assert!(
        all.contains("record 2: excluded: shorter than two periods"),
        "{all}"
    );
    assert!(all.contains("record 5: excluded: zero amplitude"), "{all}");
    assert!(
        all.contains("records 9, 11: excluded: constant output"),
        "{all}"
    );
    assert_eq!(id.used().count(), camp.records.len() - 4);
}

/// The noise of a record from its periods (`noise`): a record with fewer than two whole
/// periods of steady state is excluded and neither measures a noise nor receives one; one of
/// exactly two periods measures nothing of its own (a line through two periods' phasors
/// leaves no variation) and receives the campaign's pooled noise at its frequency.
#[test]
fn a_record_of_two_periods_gets_the_pooled_noise_and_one_of_fewer_none() {
    let mut camp = small(logspace(0.5, 15.0, 8));
    let opts = IdentifyOptions::default();
    let whole = analyse_records(&camp, &opts, &|_| {});
    let cut = |r: &mut Record, keep: usize| {
        for c in [
            &mut r.t,
            &mut r.x_cr,
            &mut r.y_cr,
            &mut r.zmp_x,
            &mut r.zmp_y,
        ] {
            c.truncate(keep);
        }
    };
    // Record 3: its steady state cut to 2.4 periods; record 4: to 1.6.
    for (k, periods) in [(3usize, 2.4), (4, 1.6)] {
        let r = &mut camp.records[k];
        let start = whole[k].steady_start_s;
        let keep =
            ((start + periods * 2.0 * std::f64::consts::PI / r.meta.omega) / r.dt()) as usize;
        cut(r, keep);
    }
    let fits = analyse_records(&camp, &opts, &|_| {});
    let two = &fits[3];
    assert_eq!(two.excluded, None);
    assert_eq!(two.periods, 2);
    let c = two.components.as_ref().unwrap();
    for i in 0..2 {
        let own = c.noise[i].periods_first;
        assert_eq!(own.source, NoiseSource::Unmeasured, "{own:?}");
        let first = c.noise[i].first;
        assert_eq!(first.source, NoiseSource::Pooled, "{first:?}");
        assert!(first.dof > 20.0, "{first:?}");
        assert!(c.y1_var(i).is_finite() && c.y1_var(i) > 0.0);
        assert!(two.sigma[i].is_finite() && two.sigma[i] > 0.0);
    }
    let short = &fits[4];
    assert!(
        [Some(reason::NO_STEADY), Some(reason::TOO_SHORT)].contains(&short.excluded.as_deref()),
        "{:?}",
        short.excluded
    );
    assert!(short.components.is_none());
}

#[test]
fn in_memory_zero_amplitude_campaign_is_an_error() {
    let n = 2000;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 0.005).collect();
    let rec = |i: usize, axis: Axis| Record {
        meta: RecordMeta {
            file: format!("records/r{i:03}.csv").into(),
            excited: axis,
            omega: 3.0 + i as f64,
            amplitude: 0.0,
            operating_point: [0.0, 0.0],
        },
        t: t.clone(),
        x_cr: vec![0.0; n],
        y_cr: vec![0.0; n],
        zmp_x: t.iter().map(|x| (x * 7.0).sin() * 1e-3).collect(),
        zmp_y: t.iter().map(|x| (x * 5.0).sin() * 1e-3).collect(),
        extra: vec![],
    };
    let camp = Campaign {
        name: Some("zeros".into()),
        robot: None,
        sample_rate_hz: Some(200.0),
        records: vec![rec(0, Axis::X), rec(1, Axis::Y)],
    };
    let e = identify(&camp, &IdentifyOptions::default()).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("records 0, 1: excluded: zero amplitude"),
        "{msg}"
    );
}

#[test]
fn model_file_parses_back_and_is_not_overwritten_without_force() {
    let camp = small(logspace(0.5, 15.0, 8));
    let id = identify(&camp, &IdentifyOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.toml");
    write_model(&id, &path, false).unwrap();
    let back = ModelSpec::parse(&std::fs::read_to_string(&path).unwrap(), "m.toml").unwrap();
    for (m, l) in [(&id.a, 'a'), (&id.b, 'b')] {
        for i in 0..2 {
            for j in 0..2 {
                let key = format!("{l}{}{}", i + 1, j + 1);
                assert_eq!(
                    back.value(EffectKind::Pendulum, Binding::Global, &key),
                    Some(m[i][j].value),
                    "{key}"
                );
                let se = back.stderr["pendulum"][&key].as_float().unwrap();
                assert_eq!(se, m[i][j].stderr);
            }
        }
    }
    assert_eq!(
        back.provenance["records"].as_integer(),
        Some(camp.records.len() as i64)
    );
    let before = std::fs::read(&path).unwrap();
    let e = write_model(&id, &path, false).unwrap_err();
    assert!(e.to_string().contains("--force"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), before);
    write_model(&id, &path, true).unwrap();
    // The report writes its figures and HTML.
    let rep = zmp_report::identify::write_report(&id, &dir.path().join("rep"), false).unwrap();
    let html = std::fs::read_to_string(&rep.html).unwrap();
    assert!(html.contains("<svg") && html.contains("pendulum.a11"));
}

/// `cargo xtask identify` analyses each record as it reads it (`analyse_folder`): the analyses
/// and the model equal those of reading the whole campaign first, on one thread and on two;
/// a bad record gives the same error (file, line, column) as `read_campaign`, the first in
/// record order.
#[test]
fn analysing_while_reading_equals_reading_first() {
    use zmp_campaign::{read_campaign, read_manifest, write_campaign};
    use zmp_identify::{analyse_folder, analyse_records, identify_analysed};
    let mut camp = small(logspace(0.5, 15.0, 8));
    camp.name = Some("streamed".into());
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("c");
    write_campaign(&folder, &camp, false).unwrap();
    let read = read_campaign(&folder).unwrap();
    let manifest = read_manifest(&folder).unwrap();
    for threads in [1, 2] {
        let opts = IdentifyOptions {
            threads: Some(threads),
            ..IdentifyOptions::default()
        };
        let first = analyse_records(&read, &opts, &|_| {});
        let done = std::sync::atomic::AtomicUsize::new(0);
        let streamed = analyse_folder(&folder, &manifest, &opts, &|d| {
            done.fetch_max(d, std::sync::atomic::Ordering::Relaxed);
        })
        .unwrap();
        assert_eq!(
            done.into_inner(),
            camp.records.len(),
            "progress reaches the end"
        );
        assert_eq!(streamed, first, "{threads} threads");
        let a = identify(&read, &opts).unwrap();
        let b = identify_analysed(streamed, manifest.name.clone(), &opts).unwrap();
        assert_eq!(a.model.to_toml(), b.model.to_toml(), "{threads} threads");
        assert_eq!(b.campaign_name.as_deref(), Some("streamed"));
    }
    // Two bad records: both paths name the first one, at the same line and column.
    let files: Vec<_> = manifest
        .records
        .iter()
        .map(|r| folder.join(&r.file))
        .collect();
    for (k, line) in [(5, 40), (2, 7)] {
        let text = std::fs::read_to_string(&files[k]).unwrap();
        let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
        let cells: Vec<&str> = lines[line - 1].split(',').collect();
        let mut bad: Vec<String> = cells.iter().map(|c| c.to_string()).collect();
        bad[3] = "0.1x".into();
        lines[line - 1] = bad.join(",");
        std::fs::write(&files[k], lines.join("\n") + "\n").unwrap();
    }
    let whole = read_campaign(&folder).unwrap_err().to_string();
    let opts = IdentifyOptions {
        threads: Some(2),
        ..IdentifyOptions::default()
    };
    let streamed = analyse_folder(&folder, &manifest, &opts, &|_| {})
        .unwrap_err()
        .to_string();
    assert_eq!(streamed, whole);
    assert!(
        whole.contains("r002.csv:7:") && whole.contains("zmp_x"),
        "{whole}"
    );
}
