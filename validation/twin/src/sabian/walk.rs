//! The second seed's walking comparison on the twin: a pattern planned from a virtual model
//! (n, r, s, v: where the error mass is put) by ZMP preview control and whole-body IK, then
//! executed by the servos of the twin with the true masses, the ZMP measured by the two ankle
//! force/torque sensors.

use super::calibrate::{FOOT_SPACING, SOLE_CENTRE_X};
use super::ik::{solve, IkTarget};
use super::robot::{mat3, vec3, PointMass, Sabian, Variant};
use crate::mj::TwinError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use zmp_models::com::{Mat3, Vec3, Wrench};
use zmp_models::walking::{Gait, PreviewController, PreviewParams};

/// Pelvis height while walking (m).
pub const WALK_PELVIS_HEIGHT: f64 = 0.60;
/// The planner's sample time (s).
pub const PLAN_STEP: f64 = 0.01;

/// A virtual model: the CAD model with the error mass put somewhere on the trunk.
#[derive(Debug, Clone, PartialEq)]
pub struct VirtualModel {
    /// The seed's letter (n, r, s, v) or ours (e).
    pub name: String,
    pub description: String,
    /// The error mass on the trunk (none for n).
    pub error_mass: Option<PointMass>,
}

/// A planned walk: joint targets and the ideal ZMP at [`PLAN_STEP`].
#[derive(Debug, Clone)]
pub struct Plan {
    pub model: String,
    /// Full qpos per sample (free joint included).
    pub qpos: Vec<Vec<f64>>,
    /// The planner's (cart-table) ZMP, (m).
    pub zmp: Vec<[f64; 2]>,
    /// The reference ZMP (m).
    pub zmp_ref: Vec<[f64; 2]>,
    /// The planned CoM (m).
    pub com: Vec<[f64; 2]>,
    pub com_height_m: f64,
}

/// Plans the seed's gait with a virtual model.
pub fn plan(model: &VirtualModel, gait: &Gait) -> Result<Plan, TwinError> {
    let variant = Variant {
        trunk_masses: model.error_mass.into_iter().collect(),
        ..Default::default()
    };
    let mut robot = Sabian::load(&variant, &format!("model {}", model.name))?;
    let n = (gait.duration_s() / PLAN_STEP).round() as usize + 1;
    let samples: Vec<_> = (0..n).map(|k| gait.sample(k as f64 * PLAN_STEP)).collect();
    let zmp_ref: Vec<[f64; 2]> = samples
        .iter()
        .map(|s| [s.zmp_ref[0] + SOLE_CENTRE_X, s.zmp_ref[1]])
        .collect();
    let target = |k: usize, com_xy: [f64; 2]| IkTarget {
        feet: samples[k].feet.map(|f| Vec3::new(f.x, f.y, f.z)),
        pelvis_position: Vec3::new(0.0, 0.0, WALK_PELVIS_HEIGHT),
        pelvis_rotation: Mat3::identity(),
        com_xy: Some(com_xy),
        waist: [0.0, 0.0],
    };
    // The CoM height of the model's standing posture sets the cart-table's height.
    solve(&mut robot, &target(0, zmp_ref[0]))?;
    let com_height_m = robot.com().z;
    let ctrl = PreviewController::new(PreviewParams {
        step_s: PLAN_STEP,
        ..PreviewParams::kajita(com_height_m)
    });
    // Kajita's two-stage planning: the cart-table plan, then the multibody ZMP of the planned
    // motion, and a second preview pass on the difference that moves the CoM to cancel it.
    let ref_x: Vec<f64> = zmp_ref.iter().map(|p| p[0]).collect();
    let ref_y: Vec<f64> = zmp_ref.iter().map(|p| p[1]).collect();
    let xs = ctrl.run(&ref_x, ref_x[0]);
    let ys = ctrl.run(&ref_y, ref_y[0]);
    let mut com: Vec<[f64; 2]> = xs.iter().zip(&ys).map(|(x, y)| [x[0], y[0]]).collect();
    let mut qpos = Vec::with_capacity(n);
    let mut zmp = Vec::new();
    for pass in 0..3 {
        qpos.clear();
        let mut positions = Vec::with_capacity(n);
        for k in 0..n {
            solve(&mut robot, &target(k, com[k]))?;
            qpos.push(robot.data.qpos().to_vec());
            positions.push(body_positions(&robot));
        }
        let masses: Vec<f64> = robot.model().body_mass().to_vec();
        zmp = multibody_zmp(&positions, &masses, PLAN_STEP);
        if pass == 2 {
            break;
        }
        let dx: Vec<f64> = (0..n).map(|k| ref_x[k] - zmp[k][0]).collect();
        let dy: Vec<f64> = (0..n).map(|k| ref_y[k] - zmp[k][1]).collect();
        let cx = ctrl.run(&dx, 0.0);
        let cy = ctrl.run(&dy, 0.0);
        for k in 0..n {
            com[k][0] += cx[k][0];
            com[k][1] += cy[k][0];
        }
    }
    Ok(Plan {
        model: model.name.clone(),
        qpos,
        zmp,
        zmp_ref,
        com,
        com_height_m,
    })
}

fn body_positions(robot: &Sabian) -> Vec<Vec3> {
    robot.data.xipos().iter().map(vec3).collect()
}

/// The multibody ZMP of a motion sampled every `dt` (point masses at the bodies' centres; the
/// bodies' rotational inertia is left out, as in a multi-mass pattern generator): accelerations
/// by central differences, the ends held.
pub fn multibody_zmp(positions: &[Vec<Vec3>], masses: &[f64], dt: f64) -> Vec<[f64; 2]> {
    let n = positions.len();
    let g = 9.81;
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            let (mut num_x, mut num_y, mut den) = (0.0, 0.0, 0.0);
            for (i, &m) in masses.iter().enumerate() {
                if m == 0.0 {
                    continue;
                }
                let p = positions[k][i];
                let acc = if a < k && b > k {
                    (positions[b][i] - p * 2.0 + positions[a][i]) / (dt * dt)
                } else {
                    Vec3::zeros()
                };
                let fz = m * (acc.z + g);
                num_x += fz * p.x - m * p.z * acc.x;
                num_y += fz * p.y - m * p.z * acc.y;
                den += fz;
            }
            [num_x / den, num_y / den]
        })
        .collect()
}

/// The small differences between runs.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Perturbation {
    pub friction_scale: f64,
    pub servo_gain_scale: f64,
    /// Initial pelvis offset (m).
    pub initial_offset: [f64; 2],
    /// White noise of the sensors per sample (N, N m).
    pub force_noise_n: f64,
    pub moment_noise_nm: f64,
    pub seed: u64,
}

impl Perturbation {
    /// Run `k`'s perturbation: friction +/-20 %, servo gains +/-5 %, 1 mm initial offset.
    pub fn draw(seed: u64) -> Perturbation {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        Perturbation {
            friction_scale: rng.gen_range(0.8..1.2),
            servo_gain_scale: rng.gen_range(0.95..1.05),
            initial_offset: [rng.gen_range(-1e-3..1e-3), rng.gen_range(-1e-3..1e-3)],
            force_noise_n: 0.5,
            moment_noise_nm: 0.05,
            seed,
        }
    }
}

/// What one run recorded, per phase (the seed's 0.03 s samples; measured values are the
/// phase's means).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Run {
    pub model: String,
    pub fell: bool,
    /// Time of the fall (s), if any.
    pub fall_time_s: Option<f64>,
    /// Measured ZMP (m) from the ankle sensors.
    pub zmp: Vec<[f64; 2]>,
    /// The plan's ZMP at the same phases (m).
    pub zmp_plan: Vec<[f64; 2]>,
    /// Roll joints (rad), measured and planned: left ankle, left hip, right ankle, right hip.
    pub roll: Vec<[f64; 4]>,
    pub roll_plan: Vec<[f64; 4]>,
    /// Largest sole height reached (m).
    pub max_clearance_m: f64,
    /// Where the pelvis ended (m).
    pub final_pelvis: [f64; 2],
    /// Wall time of the simulation (s) and simulated time (s).
    pub wall_s: f64,
    pub sim_s: f64,
}

/// The ZMP measured by the two ankle sensors (the seed's way): each sensor's wrench, corrected
/// for its sole's weight, summed about the world origin; feet with less than 10 N ignored.
pub fn measured_zmp(robot: &Sabian, noise: &mut impl FnMut() -> Wrench) -> Option<[f64; 2]> {
    let mut f = Vec3::zeros();
    let mut m = Vec3::zeros();
    let g = Vec3::new(0.0, 0.0, -9.81);
    for s in 0..2 {
        let (p, r) = robot.sensor_pose(s);
        let (ms, cs) = robot.sole_cad(s);
        let w = robot.ft_reading(s) + noise();
        // The ground's wrench on the sole: the sole's balance (static), sensor frame.
        let gs = r.transpose() * g * ms;
        let fg = w.force - gs;
        let mg = w.moment - cs.cross(&gs);
        let fw = r * fg;
        if fw.z < 10.0 {
            continue;
        }
        f += fw;
        m += r * mg + p.cross(&fw);
    }
    (f.z > 10.0).then(|| [-m.y / f.z, m.x / f.z])
}

/// Executes a plan on the real twin (`real`: the CAD model with the true masses).
pub fn execute(
    plan: &Plan,
    real: &Variant,
    gait: &Gait,
    pert: &Perturbation,
) -> Result<Run, TwinError> {
    let variant = Variant {
        friction_scale: Some(pert.friction_scale),
        servo_gain_scale: Some(pert.servo_gain_scale),
        ..real.clone()
    };
    let mut robot = Sabian::load(&variant, "real")?;
    let mut q0 = plan.qpos[0].clone();
    q0[0] += pert.initial_offset[0];
    q0[1] += pert.initial_offset[1];
    robot.data.qpos_mut().copy_from_slice(&q0);
    robot.hold_current_posture();
    let dt = robot.model().opt().timestep;
    let per_plan = (PLAN_STEP / dt).round() as usize;
    let per_phase = (gait.phase_s / dt).round() as usize;
    let phases = (gait.duration_s() / gait.phase_s).round() as usize;
    let servo = robot.idx.servo.clone();
    let roll_q = [
        robot.idx.leg_qpos[0][6],
        robot.idx.leg_qpos[0][1],
        robot.idx.leg_qpos[1][6],
        robot.idx.leg_qpos[1][1],
    ];
    let soles = robot.idx.sole_bottom_site;
    let mut rng = ChaCha8Rng::seed_from_u64(pert.seed ^ 0x5ab1a);
    let mut normal = move || {
        let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
        let u2: f64 = rng.gen();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let mut noise = || {
        Wrench::from_array(std::array::from_fn(|k| {
            if k < 3 {
                pert.force_noise_n * normal()
            } else {
                pert.moment_noise_nm * normal()
            }
        }))
    };
    let mut run = Run {
        model: plan.model.clone(),
        fell: false,
        fall_time_s: None,
        zmp: Vec::with_capacity(phases),
        zmp_plan: Vec::with_capacity(phases),
        roll: Vec::with_capacity(phases),
        roll_plan: Vec::with_capacity(phases),
        max_clearance_m: 0.0,
        final_pelvis: [0.0; 2],
        wall_s: 0.0,
        sim_s: 0.0,
    };
    let started = std::time::Instant::now();
    let total_steps = phases * per_phase;
    let mut acc = [0.0; 2];
    let mut acc_n = 0usize;
    for step in 0..total_steps {
        // Servo targets: linear between the plan's samples.
        let k = step / per_plan;
        let a = (step % per_plan) as f64 / per_plan as f64;
        let q_a = &plan.qpos[k.min(plan.qpos.len() - 1)];
        let q_b = &plan.qpos[(k + 1).min(plan.qpos.len() - 1)];
        {
            let ctrl = robot.data.ctrl_mut();
            for &(act, adr) in &servo {
                ctrl[act] = q_a[adr] + (q_b[adr] - q_a[adr]) * a;
            }
        }
        robot.data.step();
        if let Some(z) = measured_zmp(&robot, &mut noise) {
            acc[0] += z[0];
            acc[1] += z[1];
            acc_n += 1;
        }
        for &s in &soles {
            let z = robot.data.site_xpos()[s][2];
            run.max_clearance_m = run.max_clearance_m.max(z);
        }
        if (step + 1) % per_phase == 0 {
            let t = (step + 1) as f64 * dt;
            let qpos = robot.data.qpos();
            if qpos[2] < 0.45 {
                run.fell = true;
                run.fall_time_s = Some(t);
                break;
            }
            let n = acc_n.max(1) as f64;
            run.zmp.push([acc[0] / n, acc[1] / n]);
            acc = [0.0; 2];
            acc_n = 0;
            // The plan at the phase's middle, to match the phase mean.
            let tm = t - gait.phase_s / 2.0;
            let kp = tm / PLAN_STEP;
            let i = (kp.floor() as usize).min(plan.zmp.len() - 2);
            let w = kp - i as f64;
            run.zmp_plan.push(std::array::from_fn(|c| {
                plan.zmp[i][c] * (1.0 - w) + plan.zmp[i + 1][c] * w
            }));
            run.roll.push(roll_q.map(|adr| qpos[adr]));
            let kq = ((t / PLAN_STEP).round() as usize).min(plan.qpos.len() - 1);
            run.roll_plan.push(roll_q.map(|adr| plan.qpos[kq][adr]));
        }
    }
    run.wall_s = started.elapsed().as_secs_f64();
    run.final_pelvis = [robot.data.qpos()[0], robot.data.qpos()[1]];
    run.sim_s = robot.data.time();
    Ok(run)
}

/// The pose of the trunk in the CAD model's standing posture (for placing error masses).
pub fn trunk_at_home() -> Result<(Vec3, Mat3), TwinError> {
    let mut cad = Sabian::load(&Variant::default(), "CAD")?;
    let y = FOOT_SPACING / 2.0;
    solve(
        &mut cad,
        &IkTarget {
            feet: [Vec3::new(0.0, y, 0.0), Vec3::new(0.0, -y, 0.0)],
            pelvis_position: Vec3::new(0.0, 0.0, WALK_PELVIS_HEIGHT),
            pelvis_rotation: Mat3::identity(),
            com_xy: Some([SOLE_CENTRE_X, 0.0]),
            waist: [0.0, 0.0],
        },
    )?;
    cad.kinematics();
    let b = cad.idx.trunk;
    Ok((vec3(&cad.data.xpos()[b]), mat3(&cad.data.xmat()[b])))
}
