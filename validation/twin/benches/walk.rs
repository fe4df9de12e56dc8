//! Real-time factor of the walking twin: one execution of the seed's gait (15.36 s simulated,
//! planned beforehand) on the SABIAN twin, one thread, open loop and with the Torso Position
//! Control (its update and the legs' correction every 1 ms step). Peer in the same run: MuJoCo
//! stepping the same model for the same time with fixed servo targets (no interpolation, sensors
//! or recording): the floor of what a run can cost.

use criterion::{criterion_group, criterion_main, Criterion};
use std::time::Duration;
use zmp_models::walking::Gait;
use zmp_twin::sabian::calibrate::{FOOT_SPACING, TRUE_ERROR_MASS};
use zmp_twin::sabian::walk::{execute, plan, Perturbation, VirtualModel};
use zmp_twin::sabian::{Sabian, Variant};

fn bench(c: &mut Criterion) {
    let gait = Gait::seed(FOOT_SPACING);
    let model = VirtualModel {
        name: "n".into(),
        description: "CAD".into(),
        error_mass: None,
    };
    let p = plan(&model, &gait).unwrap();
    let real = Variant {
        trunk_masses: vec![TRUE_ERROR_MASS],
        ..Default::default()
    };
    let pert = Perturbation::draw(1);
    let simulated = gait.duration_s();
    let mut g = c.benchmark_group("walking_twin");
    g.sample_size(10)
        .warm_up_time(Duration::from_secs(2))
        .measurement_time(Duration::from_secs(25));
    for (name, tpc) in [("seed_gait_15.36s", false), ("seed_gait_15.36s_tpc", true)] {
        g.bench_function(name, |b| {
            b.iter(|| {
                let r = execute(&p, &real, &gait, &pert, tpc).unwrap();
                assert!(!r.fell);
                r
            })
        });
    }
    g.bench_function("peer_mujoco_steps_only_15.36s", |b| {
        b.iter(|| {
            let mut robot = Sabian::load(&real, "real").unwrap();
            robot.data.qpos_mut().copy_from_slice(&p.qpos[0]);
            robot.hold_current_posture();
            let steps = (simulated / robot.model().opt().timestep).round() as usize;
            for _ in 0..steps {
                robot.data.step();
            }
            robot.data.time()
        })
    });
    g.finish();
    eprintln!(
        "simulated time per iteration: {simulated} s (real-time factor = {simulated} s / median)"
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
