//! Diagnostics (not checks, every test `#[ignore]`): why `design-next`'s predicted separation
//! over-states the gain the designed records give on the independent simulator, measured one
//! cause at a time (the conclusions in `docs/src/design-next.md`, the tables in the commit that
//! added them). Run with `cargo test --release -p zmp-suites --test design_overpredict --
//! --ignored --nocapture`; `OP_INBAND=1` keeps the design within the campaign's band,
//! `OP_TARGET` sets its target, `OP_KEEP=DIR` keeps the runs, `OP_SEED` the decomposed draw,
//! `OP_SEEDS=1,2,..` the draws of `sweep`, `OP_TWO=1` runs `sweep` in two stages, `OP_CAP`
//! caps `two_stage`'s frequencies.

mod indep_pair;

use indep_pair::{
    campaign_of, run_on_robot, undecided_campaign, Undecided, LR_1PCT_2DOF, SEED, TOP,
};
use zmp_campaign::{append_campaign, Campaign};
use zmp_diagnose::criterion::{compare, split, HeldOut};
use zmp_diagnose::design::separation::{as_truth, predict_all, record_set, refit, start};
use zmp_diagnose::design::{design_next, evaluate};
use zmp_diagnose::design::{to_toml, DesignOptions, Designed, Rival, Separation, MAX_RECORDS};
use zmp_diagnose::fit::Fit as Fitted;
use zmp_diagnose::measure::components;
use zmp_diagnose::observe::mark_third_band;
use zmp_diagnose::observe::Observation;
use zmp_diagnose::profiles::DataRange;
use zmp_diagnose::run::observe_campaign;
use zmp_diagnose::search::fit_root;
use zmp_indep_sim::Design;
use zmp_indep_sim::Noise;
use zmp_models::{Axis, Binding, EffectKind, ModelSpec};
use zmp_suites::design_table::records_table;

fn fitr(m: &ModelSpec, obs: &[&Observation]) -> Fitted {
    fit_root(m, obs, &DataRange::of(obs)).unwrap()
}

/// The data of `obs` replaced by `truth`'s predictions (the weights kept).
fn truth_data(truth: &ModelSpec, obs: &[Observation]) -> Vec<Observation> {
    let p = predict_all(truth, obs).unwrap();
    obs.iter().zip(&p).map(|(o, p)| as_truth(o, p)).collect()
}

/// T: `play` refitted to `truth`'s noise-free predictions on `camp` + `added`, as the
/// design does (start on the campaign, refit on the set); and with the real fit.
fn t_design(
    truth: &ModelSpec,
    play: &ModelSpec,
    camp: &[Observation],
    added: &[Observation],
) -> (f64, f64) {
    let on_c = truth_data(truth, camp);
    let on_r = truth_data(truth, added);
    let pair = start(1, 0, play, truth, &on_c).unwrap();
    let set = record_set(&on_c, &on_r);
    let full = refit(&pair, &set, on_c.len(), Some(play)).unwrap();
    let refs: Vec<&Observation> = set.iter().collect();
    let real = fitr(play, &refs).cost;
    (full.total, real)
}

/// Held-out criterion of play vs both: (chi2(play) - chi2(both), distance, z, c).
fn cv(play: &ModelSpec, both: &ModelSpec, obs: &[&Observation]) -> (f64, f64, f64, f64) {
    let fold = |m: &ModelSpec| {
        let f0 = fitr(m, &split(obs, 0).0).spec;
        let f1 = fitr(m, &split(obs, 1).0).spec;
        HeldOut::of([&f0, &f1], obs).unwrap()
    };
    let (hp, hb) = (fold(play), fold(both));
    let c = hp.mismatch().min(hb.mismatch());
    let cmp = compare(&hb, &hp, c);
    (cmp.difference, cmp.distance, cmp.z, c)
}

/// The pair as the design's rivals: the play, and the play with the delay.
fn rivals(play: &ModelSpec, both: &ModelSpec) -> Vec<Rival> {
    vec![
        Rival {
            label: "play.toml".into(),
            spec: play.clone(),
        },
        Rival {
            label: "play+delay.toml".into(),
            spec: both.clone(),
        },
    ]
}

/// The predicted chi-square difference with play+delay true.
fn predicted(separations: &[Separation]) -> f64 {
    let s = separations.iter().find(|s| s.truth == 1).unwrap();
    s.total_sigma.powi(2)
}

/// `d` noise-free: white noise of 1e-9 m, no quantisation.
fn noise_free(d: Design) -> Design {
    Design {
        noise: Some(Noise {
            white_std: 1e-9,
            coloured_std: 0.0,
            coloured_tau: 1.0,
        }),
        quantisation: 0.0,
        ..d
    }
}

/// The delay of `s` on x, ms (0 without one).
fn delay_ms(s: &ModelSpec) -> f64 {
    s.value(EffectKind::TimeDelay, Binding::Axis(Axis::X), "delay")
        .unwrap_or(0.0)
        * 1e3
}

#[test]
#[ignore = "diagnostic: prints the over-prediction's decomposition"]
fn overprediction_decomposed() {
    let tmpdir = tempfile::tempdir().unwrap();
    let base: std::path::PathBuf = match std::env::var("OP_KEEP") {
        Ok(d) => {
            let _ = std::fs::remove_dir_all(&d);
            std::fs::create_dir_all(&d).unwrap();
            d.into()
        }
        Err(_) => tmpdir.path().to_path_buf(),
    };
    let tmp = base.as_path();
    let seed: u64 = std::env::var("OP_SEED").map_or(SEED, |s| s.parse().unwrap());
    let u = if seed == SEED {
        undecided_campaign(tmp)
    } else {
        campaign_of(tmp, seed)
    };
    let rivals = rivals(&u.play, &u.both);
    let opts = DesignOptions {
        threads: 2,
        campaign_path: u.camp_dir.display().to_string(),
        target_sigma: std::env::var("OP_TARGET").ok().map(|s| s.parse().unwrap()),
        omega_cap: std::env::var("OP_INBAND").ok().map(|_| TOP),
        ..DesignOptions::default()
    };
    let d = design_next(&u.camp, &rivals, &opts, &|_| {}).unwrap();
    eprintln!(
        "target {:.2} decision {:?} path {:?}",
        d.target_sigma, d.decision, d.path
    );
    eprintln!("{}", records_table(&d.records));
    eprintln!("timing {:?}", d.timing);
    let file = tmp.join("design-next.toml");
    std::fs::write(&file, to_toml(&d)).unwrap();
    let next = Design::from_toml_file(&file).unwrap();
    let noisy_design = Design {
        seed: seed + 1,
        zmp_noise_std: None,
        ..next
    };
    let clean_design = noise_free(noisy_design.clone());
    eprintln!("robot sensor noise {:?}", u.robot.sensor.noise);
    eprintln!(
        "robot axes {:#?} hidden {:?}",
        u.robot.axes,
        u.robot.hidden.iter().map(|h| &h.name).collect::<Vec<_>>()
    );
    eprintln!("limits {:?}", d.limits);
    let noisy = run_on_robot(&u.robot, &noisy_design, &tmp.join("noisy"));
    let clean = run_on_robot(&u.robot, &clean_design, &tmp.join("clean"));
    // Campaign noise-free too.
    let camp_clean_design = noise_free(Design {
        omegas: (0..9)
            .map(|k| 0.5 * (TOP / 0.5f64).powf(k as f64 / 8.0))
            .collect(),
        seed,
        ..Design::default()
    });
    let camp_clean = run_on_robot(&u.robot, &camp_clean_design, &tmp.join("cc"));
    let (mut c_obs, _) = observe_campaign(&u.camp, 2);
    let (cc_obs, _) = observe_campaign(&camp_clean, 2);
    let (n_obs, sk) = observe_campaign(&noisy, 2);
    assert!(sk.is_empty(), "{sk:?}");
    let (k_obs, sk) = observe_campaign(&clean, 2);
    assert!(sk.is_empty(), "{sk:?}");
    // Noise-free data with the noisy records' weights.
    let with_data = |w: &Observation, x: &Observation| Observation {
        y1: x.y1,
        y3: x.y3,
        slope: x.slope,
        u1: x.u1,
        ..w.clone()
    };
    let c_clean: Vec<Observation> = c_obs
        .iter()
        .map(|o| with_data(o, cc_obs.iter().find(|x| x.index == o.index).unwrap()))
        .collect();
    let r_clean: Vec<Observation> = n_obs
        .iter()
        .zip(&k_obs)
        .map(|(w, x)| with_data(w, x))
        .collect();
    // Blank candidate observations as the design saw them: the design's own weights.
    for o in c_obs.iter_mut() {
        o.third_band = false;
    }
    for o in c_obs.iter().filter(|o| o.omega > 3.0 || o.omega < 0.6) {
        eprintln!(
            "camp rec {} w {:.2} t0 {:.2} t1 {:.2}",
            o.index, o.omega, o.t0, o.t1
        );
    }
    for o in n_obs.iter().take(6) {
        eprintln!(
            "new rec {} w {:.2} t0 {:.2} t1 {:.2}",
            o.index, o.omega, o.t0, o.t1
        );
    }
    noise_calibration(&c_obs, &cc_obs, &n_obs, &k_obs);
    decomposition_table(&u, &d, &opts, &c_obs, &c_clean, &r_clean, &n_obs);
    variance_ratios(&d, &c_obs, &cc_obs, &n_obs, &k_obs);
}

/// Noise calibration: each noisy record against its noise-free twin, over the noisy
/// record's own variances (chi-square per component, 1 if the estimate is right).
fn noise_calibration(
    c_obs: &[Observation],
    cc_obs: &[Observation],
    n_obs: &[Observation],
    k_obs: &[Observation],
) {
    let calib = |noisy: &Observation, clean: &Observation| {
        let a = clean.u1.norm();
        let ph = clean.u1 / a;
        let pred = zmp_diagnose::measure::Prediction {
            g: [clean.y1[0] / clean.u1, clean.y1[1] / clean.u1],
            g3: [
                clean.y3[0] / (a * ph * ph * ph),
                clean.y3[1] / (a * ph * ph * ph),
            ],
            slope: clean.slope,
        };
        let mut r = Vec::new();
        zmp_diagnose::measure::whitened(noisy, &pred, &mut r);
        let first: f64 = [0, 1, 3, 4].iter().map(|&k| r[k] * r[k]).sum();
        let trend: f64 = [2, 5].iter().map(|&k| r[k] * r[k]).sum();
        let third: f64 = r[6..].iter().map(|x| x * x).sum();
        [(first, 4), (trend, 2), (third, r.len() - 6)]
    };
    let mut groups: Vec<(String, [(f64, usize); 3])> = Vec::new();
    let mut add = |key: String, v: [(f64, usize); 3]| match groups.iter_mut().find(|g| g.0 == key) {
        Some(g) => {
            for (acc, x) in g.1.iter_mut().zip(v) {
                acc.0 += x.0;
                acc.1 += x.1;
            }
        }
        None => groups.push((key, v)),
    };
    for o in c_obs {
        let cc = cc_obs.iter().find(|x| x.index == o.index).unwrap();
        let mut o3 = o.clone();
        o3.third_band = 3.0 * o.omega <= TOP * (1.0 + 1e-9);
        add("campaign".into(), calib(&o3, cc));
    }
    for (o, c) in n_obs.iter().zip(k_obs) {
        let mut o3 = o.clone();
        o3.third_band = false;
        add(
            format!(
                "new w {:.2} a {:.4} {:?}",
                o.omega, o.nominal_amplitude, o.excited
            ),
            calib(&o3, c),
        );
    }
    for g in &groups {
        let f = |k: usize| g.1[k].0 / g.1[k].1.max(1) as f64;
        eprintln!(
            "noise calibration {}: chi2/comp first {:.3} ({}) trend {:.3} ({}) third {:.3} ({})",
            g.0,
            f(0),
            g.1[0].1,
            f(1),
            g.1[1].1,
            f(2),
            g.1[2].1
        );
    }
}

/// The decomposition's table over the first k designed records (`c_clean`, `r_clean`:
/// the campaign's and the records' noise-free data with the noisy records' weights).
fn decomposition_table(
    u: &Undecided,
    d: &Designed,
    opts: &DesignOptions,
    c_obs: &[Observation],
    c_clean: &[Observation],
    r_clean: &[Observation],
    n_obs: &[Observation],
) {
    let rivals = rivals(&u.play, &u.both);
    eprintln!("k | P(design) | P(real w) | T real-fit | P(theta*) | D0 clean | D noisy | c | D/c | CV D | CV dist^2 | CV z | c_cv");
    for k in [1usize, 2, 4, 8, 12, 16, 24] {
        if k > d.records.len() {
            break;
        }
        let sep = evaluate(&u.camp, &rivals, &d.records[..k], opts).unwrap();
        let p_design = predicted(&sep);
        let added_n: Vec<Observation> = n_obs[..k].to_vec();
        let (p_w, t_real) = t_design(&u.both, &u.play, c_obs, &added_n);
        // Noise-free measured.
        let mut set0: Vec<Observation> = c_clean.iter().chain(&r_clean[..k]).cloned().collect();
        mark_third_band(&mut set0);
        let refs0: Vec<&Observation> = set0.iter().collect();
        let (p0, b0) = (fitr(&u.play, &refs0), fitr(&u.both, &refs0));
        let (p_theta, _) = t_design(&b0.spec, &u.play, c_obs, &added_n);
        // Noisy measured.
        let mut set1: Vec<Observation> = c_obs.iter().chain(&n_obs[..k]).cloned().collect();
        mark_third_band(&mut set1);
        let refs1: Vec<&Observation> = set1.iter().collect();
        let (p1, b1) = (fitr(&u.play, &refs1), fitr(&u.both, &refs1));
        let n1 = components(&refs1) as f64;
        let c1 = (b1.cost / n1).max(1.0);
        let (cvd, cvdist, cvz, ccv) = cv(&u.play, &u.both, &refs1);
        eprintln!(
            "{k} | {p_design:.1} | {p_w:.1} | {t_real:.1} | {p_theta:.1} | {:.1} | {:.1} | {c1:.2} | {:.1} | {cvd:.1} | {:.1} | {cvz:.2} | {ccv:.2}",
            p0.cost - b0.cost,
            p1.cost - b1.cost,
            (p1.cost - b1.cost) / c1,
            cvdist * cvdist
        );
        eprintln!(
            "   clean: play {:.1} both {:.1} (n {}) delay {:?}; noisy: play {:.1} both {:.1} (n {n1}) delay {:?}",
            p0.cost, b0.cost, components(&refs0),
            Axis::BOTH.iter().map(|a| b0.spec.value(EffectKind::TimeDelay, Binding::Axis(*a), "delay")).collect::<Vec<_>>(),
            p1.cost, b1.cost,
            Axis::BOTH.iter().map(|a| b1.spec.value(EffectKind::TimeDelay, Binding::Axis(*a), "delay")).collect::<Vec<_>>(),
        );
    }
}

/// Per record: the design's predicted variance against the record's own estimate.
fn variance_ratios(
    d: &Designed,
    c_obs: &[Observation],
    cc_obs: &[Observation],
    n_obs: &[Observation],
    k_obs: &[Observation],
) {
    let cands =
        zmp_diagnose::design::noise::NoiseModel::of(&c_obs.iter().collect::<Vec<_>>()).unwrap();
    for o in c_obs.iter().filter(|o| o.omega > 3.0) {
        let w = o.duration();
        let (v1x, _, _) = cands.variances(0, o.omega, w);
        let (v1y, _, _) = cands.variances(1, o.omega, w);
        let cc = cc_obs.iter().find(|x| x.index == o.index).unwrap();
        eprintln!(
            "camp w {:.2} amp {:.4} {:?} op {:?}: y1_var obs/pred x {:.2} y {:.2}; noise-free x {:.3} y {:.3}",
            o.omega, o.nominal_amplitude, o.excited, o.operating_point, o.y1_var[0] / v1x, o.y1_var[1] / v1y,
            cc.y1_var[0] / v1x, cc.y1_var[1] / v1y
        );
    }
    for (r, o) in d.records.iter().zip(n_obs) {
        let w = o.duration();
        let (v1x, v3x, _) = cands.variances(0, r.omega, w);
        let (v1y, _, _) = cands.variances(1, r.omega, w);
        eprintln!(
            "rec w {:.2} amp {:.4} {:?}: y1_var obs/pred x {:.2} y {:.2}; y3 x {:.2}; window {:.1}; noise-free run x {:.3} y {:.3}; t0 {:.2} t1 {:.2}",
            r.omega, r.amplitude, r.excited, o.y1_var[0] / v1x, o.y1_var[1] / v1y, o.y3_var[0] / v3x, w,
            k_obs[o.index - n_obs[0].index].y1_var[0] / v1x,
            k_obs[o.index - n_obs[0].index].y1_var[1] / v1y, o.t0, o.t1
        );
    }
}

/// Runs `d`'s records on the robot (noise seed `seed`), appended to `base`.
fn extend(
    u: &Undecided,
    base: &Campaign,
    d: &Designed,
    seed: u64,
    dir: &std::path::Path,
) -> Campaign {
    std::fs::create_dir_all(dir).unwrap();
    let file = dir.join("design.toml");
    std::fs::write(&file, to_toml(d)).unwrap();
    let next = Design::from_toml_file(&file).unwrap();
    let next = Design {
        seed,
        zmp_noise_std: None,
        ..next
    };
    let added = run_on_robot(&u.robot, &next, &dir.join("records"));
    append_campaign(base, &u.camp_dir, &added, &dir.join("records")).unwrap()
}

/// `both` refitted on `refs` from the fitted play's values where they share a parameter
/// (the delay where `both` has it): the nested start.
fn both_from_play(both: &ModelSpec, play: &Fitted, refs: &[&Observation]) -> Fitted {
    let mut s = both.clone();
    for f in &play.frees {
        for b in &f.bindings {
            if let Some(v) = play.spec.value(f.kind, *b, f.param) {
                s.set_value(f.kind, *b, f.param, v);
            }
        }
    }
    fitr(&s, refs)
}

/// Both structures refitted on `camp`: (play, both, gain D, c).
fn measure(u: &Undecided, camp: &Campaign) -> (ModelSpec, ModelSpec, f64, f64) {
    let (obs, _) = observe_campaign(camp, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let (p, b) = (fitr(&u.play, &refs), fitr(&u.both, &refs));
    let c = (b.cost / components(&refs) as f64).max(1.0);
    (p.spec, b.spec, p.cost - b.cost, c)
}

#[test]
#[ignore = "diagnostic: a pilot pair, then the design again on the extended campaign"]
fn two_stage() {
    let tmp = tempfile::tempdir().unwrap();
    let u = undecided_campaign(tmp.path());
    let pilot_n: usize = std::env::var("OP_PILOT").map_or(2, |s| s.parse().unwrap());
    let opts = |camp_dir: &std::path::Path, max: usize| DesignOptions {
        threads: 2,
        campaign_path: camp_dir.display().to_string(),
        max_records: max,
        omega_cap: std::env::var("OP_CAP").ok().map(|s| s.parse().unwrap()),
        ..DesignOptions::default()
    };
    let d1 = design_next(
        &u.camp,
        &rivals(&u.play, &u.both),
        &opts(&u.camp_dir, pilot_n),
        &|_| {},
    )
    .unwrap();
    let p1 = predicted(&d1.separations);
    let e1 = extend(&u, &u.camp, &d1, SEED + 1, &tmp.path().join("stage1"));
    let (play1, both1, g1, c1) = measure(&u, &e1);
    eprintln!("stage 1: {} records {}\n predicted {p1:.1}, measured D {g1:.1}, c {c1:.2}, D/c {:.1}; delay {:?}",
        d1.records.len(), records_table(&d1.records), g1 / c1,
        both1.value(EffectKind::TimeDelay, Binding::Axis(Axis::X), "delay"));
    let d2 = design_next(
        &e1,
        &rivals(&play1, &both1),
        &opts(&u.camp_dir, MAX_RECORDS - d1.records.len()),
        &|_| {},
    )
    .unwrap();
    let s2 = d2.separations.iter().find(|s| s.truth == 1).unwrap();
    eprintln!(
        "stage 2: omega_max {} target {:.2} ({:?}), {} records\n{}\npath {:?}",
        d2.limits.omega_max,
        d2.target_sigma,
        d2.decision,
        d2.records.len(),
        records_table(&d2.records),
        d2.path
    );
    let e2 = extend(&u, &e1, &d2, SEED + 2, &tmp.path().join("stage2"));
    let (_, both2, g2, c2) = measure(&u, &e2);
    let p2 = s2.total_sigma.powi(2);
    eprintln!(
        "stage 2: predicted {:.1} (campaign+pilot {:.1}), measured D {g2:.1}, c {c2:.2}, D/c {:.1}, ratio {:.2}; gain over stage 1 predicted {:.1} measured {:.1}; delay {:?}",
        p2, s2.campaign_sigma.powi(2), g2 / c2, (g2 / c2) / p2, p2 - s2.campaign_sigma.powi(2), g2 - g1,
        both2.value(EffectKind::TimeDelay, Binding::Axis(Axis::X), "delay")
    );
}

#[test]
#[ignore = "diagnostic: beyond the band and within it, over draws"]
fn sweep() {
    let seeds: Vec<u64> = std::env::var("OP_SEEDS")
        .unwrap_or_else(|_| "1,2,3,4,5,6,7,8".into())
        .split(',')
        .map(|s| s.parse().unwrap())
        .collect();
    eprintln!("seed | band | robot delay ms | campaign delay | gain before | target | records | top w | P | D/c | D/c / P | c | delay after | CV z");
    for seed in seeds {
        let tmp = tempfile::tempdir().unwrap();
        let u = campaign_of(tmp.path(), seed);
        if u.gain_before >= LR_1PCT_2DOF {
            eprintln!(
                "{seed} | decided by the campaign (gain {:.1}, c {:.2}) | {:.1} | {:.1}",
                u.gain_before,
                u.mismatch,
                u.robot.axes[0].command_delay * 1e3,
                delay_ms(&u.both)
            );
        } else if std::env::var("OP_TWO").is_ok() {
            sweep_two_stage(&u, seed, tmp.path());
        } else {
            for beyond in [true, false] {
                sweep_one_stage(&u, seed, beyond, tmp.path());
            }
        }
    }
}

/// One of `sweep`'s draws in two stages, the frequencies capped at twice the campaign's top.
fn sweep_two_stage(u: &Undecided, seed: u64, dir: &std::path::Path) {
    let robot_delay = u.robot.axes[0].command_delay * 1e3;
    let opts = |max: usize| DesignOptions {
        threads: 2,
        campaign_path: u.camp_dir.display().to_string(),
        max_records: max,
        omega_cap: Some(2.0 * TOP),
        ..DesignOptions::default()
    };
    let Ok(d1) = design_next(&u.camp, &rivals(&u.play, &u.both), &opts(2), &|_| {}) else {
        eprintln!("{seed} | two-stage | no pilot");
        return;
    };
    if d1.records.is_empty() {
        eprintln!("{seed} | two-stage | empty pilot");
        return;
    }
    let e1 = extend(u, &u.camp, &d1, seed + 1, &dir.join("s1"));
    let (play1, both1, _, _) = measure(u, &e1);
    let d2 = design_next(
        &e1,
        &rivals(&play1, &both1),
        &opts(MAX_RECORDS - d1.records.len()),
        &|_| {},
    )
    .unwrap();
    let p2 = predicted(&d2.separations);
    let e2 = if d2.records.is_empty() {
        e1.clone()
    } else {
        extend(u, &e1, &d2, seed + 2, &dir.join("s2"))
    };
    let (obs, _) = observe_campaign(&e2, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let (pf, bf) = (fitr(&u.play, &refs), fitr(&u.both, &refs));
    let bf2 = both_from_play(&u.both, &pf, &refs);
    eprintln!(
        "   play {:.1} both {:.1} both from play {:.1} (delay {:.1} ms)",
        pf.cost,
        bf.cost,
        bf2.cost,
        delay_ms(&bf2.spec)
    );
    let c = (bf.cost / components(&refs) as f64).max(1.0);
    let g = (pf.cost - bf.cost) / c;
    let (_, _, z, _) = cv(&u.play, &u.both, &refs);
    let top = d1
        .records
        .iter()
        .chain(&d2.records)
        .map(|r| r.omega)
        .fold(0.0, f64::max);
    eprintln!(
        "{seed} | two-stage | {robot_delay:.1} | {:.1} | {:.1} | {:.1} | {}+{} | {top:.1} | {p2:.1} | {g:.1} | {:.2} | {c:.2} | {:.1} | {z:.2}",
        delay_ms(&u.both), u.gain_before, d2.target_sigma, d1.records.len(), d2.records.len(), g / p2, delay_ms(&bf.spec)
    );
}

/// One of `sweep`'s draws in one stage: beyond the band (to twice its top) or within it.
fn sweep_one_stage(u: &Undecided, seed: u64, beyond: bool, dir: &std::path::Path) {
    let robot_delay = u.robot.axes[0].command_delay * 1e3;
    let opts = DesignOptions {
        threads: 2,
        campaign_path: u.camp_dir.display().to_string(),
        omega_cap: (!beyond).then_some(TOP),
        ..DesignOptions::default()
    };
    let d = match design_next(&u.camp, &rivals(&u.play, &u.both), &opts, &|_| {}) {
        Ok(d) if !d.records.is_empty() => d,
        other => {
            eprintln!("{seed} | {beyond} | no design: {:?}", other.map(|d| d.path));
            return;
        }
    };
    let p = predicted(&d.separations);
    let e = extend(u, &u.camp, &d, seed + 1, &dir.join(format!("b{beyond}")));
    let (obs, _) = observe_campaign(&e, 2);
    let refs: Vec<&Observation> = obs.iter().collect();
    let (pf, bf) = (fitr(&u.play, &refs), fitr(&u.both, &refs));
    let c = (bf.cost / components(&refs) as f64).max(1.0);
    let g = (pf.cost - bf.cost) / c;
    let (_, _, z, _) = cv(&u.play, &u.both, &refs);
    let top = d.records.iter().map(|r| r.omega).fold(0.0, f64::max);
    eprintln!(
        "{seed} | {} | {robot_delay:.1} | {:.1} | {:.1} | {:.1} | {} | {top:.1} | {p:.1} | {g:.1} | {:.2} | {c:.2} | {:.1} | {z:.2}",
        if beyond { "to 2x" } else { "band" },
        delay_ms(&u.both), u.gain_before, d.target_sigma, d.records.len(), g / p, delay_ms(&bf.spec)
    );
}
