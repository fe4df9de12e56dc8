//! The FMUs through the Rust `fmi` crate (a second importer): the plant against the in-process
//! simulation, two instances in one process, and the closed loop of plant and controller against
//! `zmp_models::closed_loop::run` (FMI 2.0 and FMI 3.0).

mod common;

use common::importer::{vrs, CoSim, Imported};
use common::*;
use zmp_fmu_core::{FmiVersion, Kind};
use zmp_models::closed_loop::{run, StepExperiment};
use zmp_models::controller::{CascadeController, CascadeParams};
use zmp_models::Plant;

fn input(t: f64, base: [f64; 2], phase: f64) -> [f64; 2] {
    [
        base[0] + 0.02 * (2.0 * std::f64::consts::PI * 0.9 * t + phase).sin(),
        base[1] + 0.01 * (1.0 - (2.0 * std::f64::consts::PI * 1.7 * t).cos()),
    ]
}

/// One communication step `[k dt, (k+1) dt]` of `slave` and of the in-process `plant` with the
/// same input; returns the largest difference of the four outputs.
fn step_both(
    slave: &mut dyn CoSim,
    plant: &mut Plant,
    k: usize,
    dt: f64,
    phase: f64,
    base: [f64; 2],
) -> f64 {
    let h = plant.step_size();
    let vin = vrs(Kind::Plant, &["x_cr", "y_cr"]);
    let vout = vrs(Kind::Plant, &["zmp_x", "zmp_y", "x_c", "y_c"]);
    let t = k as f64 * dt;
    let u = input(t, base, phase);
    slave.set(&vin, &u);
    slave.step(t, dt);
    let steps = grid_floor((k + 1) as f64 * dt, h) - grid_floor(t, h);
    let o = if steps > 0 {
        plant.advance(u, steps as usize)
    } else {
        plant.last_output()
    };
    let mut out = [0.0; 4];
    slave.get(&vout, &mut out);
    out.iter()
        .zip([o.zmp[0], o.zmp[1], o.com[0], o.com[1]])
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max)
}

fn plant_matches(fmi: FmiVersion, dt: f64) {
    let fmus = fmus_all();
    let imp = Imported::load(&fmus.path(Kind::Plant, fmi), fmi);
    let mut s = imp.instantiate("plant");
    let base = {
        let mut b = [0.0; 2];
        s.get(&vrs(Kind::Plant, &["x_cr", "y_cr"]), &mut b);
        b
    };
    let u0 = input(0.0, base, 0.3);
    s.init(0.0, &mut |s| {
        s.set(&vrs(Kind::Plant, &["x_cr", "y_cr"]), &u0)
    });
    let mut plant = Plant::new(&spec(), 1e-3).unwrap();
    plant.reset(u0);
    let d = (0..(2.0 / dt) as usize)
        .map(|k| step_both(&mut *s, &mut plant, k, dt, 0.3, base))
        .fold(0.0, f64::max);
    assert!(
        d <= 1e-9,
        "{fmi:?}, dt = {dt}: the fmi-crate run differs by {d:e}"
    );
}

#[test]
fn fmi_crate_plant_fmi2_matches_in_process() {
    plant_matches(FmiVersion::V2, 1e-3);
    plant_matches(FmiVersion::V2, 0.0025);
    plant_matches(FmiVersion::V2, 0.02);
}

#[test]
fn fmi_crate_plant_fmi3_matches_in_process() {
    plant_matches(FmiVersion::V3, 1e-3);
    plant_matches(FmiVersion::V3, 0.0025);
}

#[test]
fn two_instances_in_one_process_are_independent() {
    let fmus = fmus();
    let imp = Imported::load(&fmus.plant(), FmiVersion::V2);
    let (mut a, mut b) = (imp.instantiate("a"), imp.instantiate("b"));
    let vin = vrs(Kind::Plant, &["x_cr", "y_cr"]);
    let vdelta = vrs(
        Kind::Plant,
        &["uncertainty.G11.delta", "uncertainty.G11.delta_seed"],
    );
    let mut base = [0.0; 2];
    a.get(&vin, &mut base);
    // b has a different plant (a random Delta) and different inputs.
    b.set(&vdelta, &[0.8, 3.0]);
    a.init(0.0, &mut |s| s.set(&vin, &input(0.0, base, 0.0)));
    b.init(0.0, &mut |s| s.set(&vin, &input(0.0, base, 1.0)));
    let mut spec_b = spec();
    for p in spec_b.parameters() {
        match p.key.as_str() {
            "uncertainty.G11.delta" => spec_b.effects[p.effect].values[p.index] = 0.8,
            "uncertainty.G11.delta_seed" => spec_b.effects[p.effect].values[p.index] = 3.0,
            _ => {}
        }
    }
    let mut pa = Plant::new(&spec(), 1e-3).unwrap();
    let mut pb = Plant::new(&spec_b, 1e-3).unwrap();
    pa.reset(input(0.0, base, 0.0));
    pb.reset(input(0.0, base, 1.0));
    // Interleaved step by step: a's calls never disturb b's state and vice versa.
    let (mut da, mut db) = (0.0f64, 0.0f64);
    for k in 0..300 {
        da = da.max(step_both(&mut *a, &mut pa, k, 0.01, 0.0, base));
        db = db.max(step_both(&mut *b, &mut pb, k, 0.01, 1.0, base));
    }
    assert!(
        da <= 1e-9 && db <= 1e-9,
        "instance a differs by {da:e}, b by {db:e}"
    );
    let vout = vrs(Kind::Plant, &["zmp_x"]);
    let (mut za, mut zb) = ([0.0], [0.0]);
    a.get(&vout, &mut za);
    b.get(&vout, &mut zb);
    assert!(
        (za[0] - zb[0]).abs() > 1e-6,
        "the two instances ended equal"
    );
}

/// Trace of a closed-loop run: time, measured ZMP, CoM reference, CoM, trunk angle.
#[derive(Default, Debug)]
struct Trace {
    t: Vec<f64>,
    zmp: Vec<[f64; 2]>,
    com_ref: Vec<[f64; 2]>,
    com: Vec<[f64; 2]>,
    theta: Vec<[f64; 2]>,
}

/// The seed's experiment with the plant and controller FMUs in closed loop, stepped exactly as
/// `closed_loop::run` steps the in-process models: at each controller sample t_k the master
/// reads the plant's ZMP, adds the load's effect, sets the controller's inputs, reads the CoM
/// reference (direct feedthrough), then steps both over [t_k, t_k+1].
fn fmu_closed_loop(fmi: FmiVersion, exp: &StepExperiment) -> Trace {
    let fmus = fmus_all();
    let pimp = Imported::load(&fmus.path(Kind::Plant, fmi), fmi);
    let cimp = Imported::load(&fmus.path(Kind::Controller, fmi), fmi);
    let (mut plant, mut ctrl) = (pimp.instantiate("plant"), cimp.instantiate("controller"));
    let p_zmp = vrs(Kind::Plant, &["zmp_x", "zmp_y"]);
    let p_com = vrs(Kind::Plant, &["x_c", "y_c"]);
    let p_in = vrs(Kind::Plant, &["x_cr", "y_cr"]);
    let c_in = vrs(
        Kind::Controller,
        &["zmp_ref_x", "zmp_ref_y", "zmp_x", "zmp_y"],
    );
    let c_out = vrs(Kind::Controller, &["x_cr", "y_cr", "theta_x", "theta_y"]);
    // The default start values are the experiment's initial operating point.
    plant.init(0.0, &mut |_| {});
    ctrl.init(0.0, &mut |_| {});
    let tc = exp.controller_period;
    let n = (exp.duration / tc).round() as usize;
    let measure = |z: [f64; 2], t: f64| -> [f64; 2] {
        if t >= exp.load_time {
            let m = exp.robot_mass + exp.load_mass;
            [
                (exp.robot_mass * z[0] + exp.load_mass * exp.load_position[0]) / m,
                (exp.robot_mass * z[1] + exp.load_mass * exp.load_position[1]) / m,
            ]
        } else {
            z
        }
    };
    let mut tr = Trace::default();
    for k in 0..=n {
        let t = k as f64 * tc;
        let zref = if k > 0 {
            exp.zmp_ref_after
        } else {
            exp.zmp_ref_before
        };
        let (mut z, mut c, mut co) = ([0.0; 2], [0.0; 2], [0.0; 4]);
        plant.get(&p_zmp, &mut z);
        plant.get(&p_com, &mut c);
        let zm = measure(z, t);
        ctrl.set(&c_in, &[zref[0], zref[1], zm[0], zm[1]]);
        ctrl.get(&c_out, &mut co);
        tr.t.push(t);
        tr.zmp.push(zm);
        tr.com_ref.push([co[0], co[1]]);
        tr.com.push(c);
        tr.theta.push([co[2], co[3]]);
        if k < n {
            ctrl.step(t, tc);
            plant.set(&p_in, &[co[0], co[1]]);
            plant.step(t, tc);
        }
    }
    tr
}

fn reference(exp: &StepExperiment) -> zmp_models::closed_loop::ClosedLoopTrace {
    let mut plant = Plant::new(&spec(), 1e-3).unwrap();
    let mut ctrl = CascadeController::new(CascadeParams::silo2(), exp.controller_period);
    run(&mut plant, &mut ctrl, exp)
}

fn worst(a: &[[f64; 2]], b: &[[f64; 2]]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter()
        .zip(b)
        .flat_map(|(x, y)| [(x[0] - y[0]).abs(), (x[1] - y[1]).abs()])
        .fold(0.0, f64::max)
}

#[test]
fn fmi_crate_closed_loop_reproduces_in_process_experiment() {
    let exp = StepExperiment::silo2();
    let want = reference(&exp);
    let mut traces = Vec::new();
    for fmi in [FmiVersion::V2, FmiVersion::V3] {
        let got = fmu_closed_loop(fmi, &exp);
        assert_eq!(got.t.len(), want.t.len());
        for (name, d) in [
            ("measured ZMP", worst(&got.zmp, &want.zmp)),
            ("CoM reference", worst(&got.com_ref, &want.com_ref)),
            ("CoM", worst(&got.com, &want.com)),
            ("trunk angle", worst(&got.theta, &want.theta)),
        ] {
            assert!(
                d <= 1e-9,
                "{fmi:?}: {name} differs from closed_loop::run by {d:e}"
            );
        }
        traces.push(got);
    }
    let d =
        worst(&traces[0].zmp, &traces[1].zmp).max(worst(&traces[0].com_ref, &traces[1].com_ref));
    assert!(d <= 1e-9, "FMI 3.0 differs from FMI 2.0 by {d:e}");
    // The experiment happened: the ZMP reached the new set point and felt the load.
    let m = want.metrics(0, &exp);
    assert!(m.reach_time > 10.0 && m.load_peak_error > 1e-3, "{m:?}");
}
