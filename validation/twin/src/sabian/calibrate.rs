//! The CoM calibration on the twin: static postures held by the servos, the two ankle sensors'
//! readings (with the offsets and noise stated in [`SensorNoise`]), the seed's two-posture design
//! and our D-optimal design, compared with MuJoCo's true CoM.

pub use super::postures::{candidates, home_pelvis_x, seed_design, Kinematics, PostureSpec};
use super::robot::{PointMass, Sabian, Variant, MOTORS};
use crate::mj::TwinError;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use zmp_models::com::{
    self, d_optimal_subset, intersect, joint_moments, rigid_com, rot_x, rot_y, CadCom,
    CalibrationPosture, JointAxis, MotorCurrent, NoiseModel, PostureLines, PostureWrench,
    RegressorModel, SensorReading, SoleCad, Vec3, Wrench, G,
};

/// The "real robot": the CAD model plus 3 kg of cables and electronics on the trunk's back,
/// a little to the left (trunk frame, m). The calibration does not know it.
pub const TRUE_ERROR_MASS: PointMass = PointMass {
    mass_kg: 3.0,
    position: Vec3::new(-0.15, 0.05, 0.25),
};

/// Pelvis height of the home posture (knees slightly bent) (m).
pub const PELVIS_HEIGHT: f64 = 0.62;
/// Lateral distance of the feet's centres (m).
pub const FOOT_SPACING: f64 = 0.16;
/// Where the soles' centres are relative to the ankles, along x (m).
pub const SOLE_CENTRE_X: f64 = 0.02;
/// Height of the ankle axes above the floor (m): the pivot of the tilts.
pub const ANKLE_HEIGHT: f64 = 0.08;

/// The sensors' imperfections on the twin (standard deviations of the averaged readings, and the
/// offsets' size).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct SensorNoise {
    /// Each force axis (N).
    pub force_std_n: f64,
    /// Each moment axis (N m).
    pub moment_std_nm: f64,
    /// The body's tilt as the ankle encoders give it, about x and y (deg).
    pub tilt_std_deg: f64,
    /// Each force offset is +/- this (random sign) (N).
    pub force_offset_n: f64,
    /// Each moment offset is +/- this (N m).
    pub moment_offset_nm: f64,
}

impl SensorNoise {
    /// The noise the issue asks for (at least 0.05 N m, 0.05 deg, 10 N offsets).
    pub fn stated() -> SensorNoise {
        SensorNoise {
            force_std_n: 0.5,
            moment_std_nm: 0.05,
            tilt_std_deg: 0.05,
            force_offset_n: 10.0,
            moment_offset_nm: 1.0,
        }
    }

    pub fn model(&self) -> NoiseModel {
        NoiseModel {
            force_std_n: self.force_std_n,
            moment_std_nm: self.moment_std_nm,
            tilt_std_rad: self.tilt_std_deg.to_radians(),
        }
    }
}

/// A posture held on the real twin: the readings (true, averaged over 0.5 s after 1.5 s of
/// settling) and the true encoders' kinematics.
#[derive(Debug, Clone, Copy)]
pub struct HeldPosture {
    pub spec: PostureSpec,
    pub readings: [Wrench; 2],
    pub kinematics: Kinematics,
    /// The real twin's body above the sensors (kg, m) and whole robot's CoM (m).
    pub true_body: (f64, Vec3),
    pub true_com: Vec3,
    /// Each servo's torque (N m, averaged like the readings) and its joint's axis: the motor
    /// currents of the seed's eq. 7.
    pub motor_torques: [f64; MOTORS],
    pub motor_axes: [JointAxis; MOTORS],
}

/// The seed's eq. 7 on the twin: `M = K I` per motor, the current `I` simulated from the
/// servo's torque, `I = tau / K` plus the current sensing noise. The seed gives no K; the
/// twin's (torque constant times gear ratio) are 4.8 N m/A for pitch joints, 3.6 for roll and
/// 2.4 for yaw. Since `K I` gives back the torque, K only scales the noise.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct MotorModel {
    pub k_pitch_nm_per_a: f64,
    pub k_roll_nm_per_a: f64,
    pub k_yaw_nm_per_a: f64,
    /// White noise of each averaged current reading (A).
    pub current_std_a: f64,
}

impl MotorModel {
    pub fn twin() -> MotorModel {
        MotorModel {
            k_pitch_nm_per_a: 4.8,
            k_roll_nm_per_a: 3.6,
            k_yaw_nm_per_a: 2.4,
            current_std_a: 0.01,
        }
    }

    fn k(&self, axis: JointAxis) -> f64 {
        match axis {
            JointAxis::Pitch => self.k_pitch_nm_per_a,
            JointAxis::Roll => self.k_roll_nm_per_a,
            JointAxis::Yaw => self.k_yaw_nm_per_a,
        }
    }

    /// The seed's `M_2 = (sum of roll, sum of pitch, sum of yaw joint moments)` (eq. 7) from
    /// simulated currents of a held posture (N m).
    pub fn m2(&self, h: &HeldPosture, rng: &mut ChaCha8Rng) -> Result<Vec3, com::ComError> {
        let currents: Vec<MotorCurrent> = (0..MOTORS)
            .map(|k| {
                let kk = self.k(h.motor_axes[k]);
                MotorCurrent {
                    axis: h.motor_axes[k],
                    torque_constant_nm_per_a: kk,
                    current_a: h.motor_torques[k] / kk + self.current_std_a * normal(rng),
                }
            })
            .collect();
        joint_moments(&currents)
    }
}

/// Holds each posture on the real twin (`real`: the CAD model plus extra masses) and on the CAD
/// model (for the kinematics), in parallel.
pub fn hold_postures(
    specs: &[PostureSpec],
    real: &Variant,
    home_x: f64,
) -> Result<Vec<HeldPosture>, TwinError> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    zmp_campaign::par::try_parallel_map(specs.len(), threads, |k| {
        let spec = specs[k];
        let mut cad = Sabian::load(&Variant::default(), "CAD")?;
        spec.pose(&mut cad, home_x)?;
        let mut robot = Sabian::load(real, "real")?;
        let q: Vec<f64> = cad.data.qpos().to_vec();
        robot.data.qpos_mut().copy_from_slice(&q);
        robot.hold_current_posture();
        for _ in 0..1500 {
            robot.data.step();
        }
        let mut acc = [[0.0; 6]; 2];
        let mut torques = [0.0; MOTORS];
        let n = 500;
        for _ in 0..n {
            robot.data.step();
            for (s, a) in acc.iter_mut().enumerate() {
                let w = robot.ft_reading(s).as_array();
                for i in 0..6 {
                    a[i] += w[i] / n as f64;
                }
            }
            for (t, m) in torques.iter_mut().zip(robot.motor_torques()) {
                *t += m / n as f64;
            }
        }
        // The encoders read the real joint angles and the base pose follows from the feet on
        // the floor: the CAD model at the real qpos.
        let q: Vec<f64> = robot.data.qpos().to_vec();
        cad.data.qpos_mut().copy_from_slice(&q);
        let kinematics = Kinematics::of(&mut cad);
        robot.kinematics();
        let (m, first) = robot.body_first_moment();
        if robot.com().z < 0.4 {
            return Err(TwinError::Model {
                path: "sabian".into(),
                message: format!("the twin fell in posture '{}'", spec.label()),
            });
        }
        Ok(HeldPosture {
            spec,
            readings: [Wrench::from_array(acc[0]), Wrench::from_array(acc[1])],
            kinematics,
            true_body: (m, first / m),
            true_com: robot.com(),
            motor_torques: torques,
            motor_axes: std::array::from_fn(|k| robot.idx.servo_axis[k]),
        })
    })
}

/// The sensors' fixed offsets for one calibration (drawn once).
pub fn draw_offsets(noise: &SensorNoise, rng: &mut ChaCha8Rng) -> [Wrench; 2] {
    std::array::from_fn(|_| {
        Wrench::from_array(std::array::from_fn(|k| {
            let size = if k < 3 {
                noise.force_offset_n
            } else {
                noise.moment_offset_nm
            };
            if rng.gen::<bool>() {
                size
            } else {
                -size
            }
        }))
    })
}

fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The encoders' tilt error of each posture (rotation about x and y, N(0, tilt_std) each): a
/// property of the encoders' zero offsets and the posture, so repeating the same postures repeats
/// them.
pub fn draw_tilts(n: usize, noise: &SensorNoise, rng: &mut ChaCha8Rng) -> Vec<com::Mat3> {
    let sd = noise.tilt_std_deg.to_radians();
    (0..n)
        .map(|_| rot_x(sd * normal(rng)) * rot_y(sd * normal(rng)))
        .collect()
}

/// One measurement of a held posture: readings with offsets and white noise (standard
/// deviations divided by `sqrt(averaging)` when the posture is held `averaging` times longer),
/// kinematics with the posture's tilt error.
pub fn measure(
    h: &HeldPosture,
    offsets: &[Wrench; 2],
    noise: &SensorNoise,
    tilt: &com::Mat3,
    averaging: f64,
    rng: &mut ChaCha8Rng,
) -> ([Wrench; 2], Kinematics) {
    let shrink = 1.0 / averaging.sqrt();
    let readings = std::array::from_fn(|s| {
        let t = h.readings[s].as_array();
        let o = offsets[s].as_array();
        Wrench::from_array(std::array::from_fn(|k| {
            let sd = if k < 3 {
                noise.force_std_n
            } else {
                noise.moment_std_nm
            };
            t[k] + o[k] + sd * shrink * normal(rng)
        }))
    });
    let pivot = pivot_of(h);
    (readings, h.kinematics.tilted(tilt, &pivot, h.spec.lifted))
}

fn pivot_of(h: &HeldPosture) -> Vec3 {
    let st: Vec<Vec3> = (0..2)
        .filter(|s| h.spec.lifted != Some(*s))
        .map(|s| h.kinematics.sensors[s].0)
        .collect();
    st.iter().sum::<Vec3>() / st.len() as f64
}

/// The regressor's posture from a measurement.
pub fn regressor_posture(
    h: &HeldPosture,
    readings: &[Wrench; 2],
    k: &Kinematics,
) -> CalibrationPosture {
    CalibrationPosture {
        sensors: std::array::from_fn(|s| SensorReading {
            position: k.sensors[s].0,
            rotation: k.sensors[s].1,
            wrench: readings[s],
        }),
        loaded: std::array::from_fn(|s| h.spec.lifted != Some(s)),
        cad_mass_kg: k.cad_mass,
        cad_first_moment: k.cad_first_moment,
        carrier_position: k.trunk.0,
        carrier_rotation: k.trunk.1,
        tilt_pivot: pivot_of(h),
        gravity: Vec3::new(0.0, 0.0, -G),
    }
}

/// The seed's posture wrench in the pelvis frame (the body is rigid between its postures).
pub fn pelvis_frame_posture(readings: &[Wrench; 2], k: &Kinematics) -> PostureWrench {
    let (pp, pr) = k.pelvis;
    let s = |i: usize| SensorReading {
        position: pr.transpose() * (k.sensors[i].0 - pp),
        rotation: pr.transpose() * k.sensors[i].1,
        wrench: readings[i],
    };
    PostureWrench::new(s(0), s(1))
}

/// The soles from the CAD model.
pub fn soles(cad: &Sabian) -> [SoleCad; 2] {
    std::array::from_fn(|s| {
        let (m, c) = cad.sole_cad(s);
        SoleCad {
            mass_kg: m,
            com_in_sensor: c,
        }
    })
}

/// The CAD model's whole-robot and without-feet (body) mass centres at the upright posture, for
/// the seed's eq. 6.
pub fn cad_with_and_without_feet(h0: &HeldPosture, soles: &[SoleCad; 2]) -> (CadCom, CadCom) {
    let k = &h0.kinematics;
    let feet_mass = soles[0].mass_kg + soles[1].mass_kg;
    (
        CadCom {
            mass_kg: k.cad_mass + feet_mass,
            com: k.cad_com,
        },
        CadCom {
            mass_kg: k.cad_mass,
            com: k.cad_first_moment / k.cad_mass,
        },
    )
}

/// One calibration's result for one design.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct ComResult {
    /// Estimated whole-robot CoM at the upright posture (m, world).
    pub com: [f64; 3],
    /// Its error against MuJoCo's (m).
    pub error: [f64; 3],
    /// The estimate's standard deviations, from the covariance (m).
    pub std: [f64; 3],
    /// The estimate's covariance (m^2).
    pub covariance: [[f64; 3]; 3],
    /// Estimated whole-robot mass (kg).
    pub mass_kg: f64,
}

fn result(total: &CadCom, truth: &Vec3, cov: &com::Mat3) -> ComResult {
    let e = total.com - truth;
    ComResult {
        com: total.com.into(),
        error: e.into(),
        std: std::array::from_fn(|k| cov[(k, k)].sqrt()),
        covariance: std::array::from_fn(|r| std::array::from_fn(|c| cov[(r, c)])),
        mass_kg: total.mass_kg,
    }
}

/// The seed's two-posture calibration of one draw: with the sensors as stated and perfectly
/// zeroed (both with `M_2 = 0`, ours), and the seed's eq. 7 variant with zeroed sensors,
/// `M_2 = + sum K I` and `- sum K I` (the seed does not fix the joint moments' sign).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeedCalibration {
    pub with_offsets: ComResult,
    pub zeroed: ComResult,
    pub eq7_plus: ComResult,
    pub eq7_minus: ComResult,
}

/// The seed's two-posture formula (eqs. 3, 5, 6) on two held postures, readings in the pelvis
/// frame. The eq. 7 variants draw their current noise from `current_rng` (so the other results
/// do not depend on it).
pub fn seed_calibration(
    held: &[HeldPosture; 2],
    soles: [SoleCad; 2],
    offsets: &[Wrench; 2],
    noise: &SensorNoise,
    rng: &mut ChaCha8Rng,
    motors: &MotorModel,
    current_rng: &mut ChaCha8Rng,
) -> Result<SeedCalibration, com::ComError> {
    let zero = [Wrench::zero(), Wrench::zero()];
    let tilts = draw_tilts(2, noise, rng);
    let mut out = Vec::new();
    let mut eq7 = Vec::new();
    for offs in [offsets, &zero] {
        let m: Vec<_> = held
            .iter()
            .zip(&tilts)
            .map(|(h, t)| measure(h, offs, noise, t, 1.0, rng))
            .collect();
        let pw: Vec<PostureWrench> = m.iter().map(|(r, k)| pelvis_frame_posture(r, k)).collect();
        out.push(seed_estimate(held, &pw, soles, noise)?);
        if offs == &zero {
            let m2: Vec<Vec3> = held
                .iter()
                .map(|h| motors.m2(h, current_rng))
                .collect::<Result<_, _>>()?;
            for sign in [1.0, -1.0] {
                let mut p = pw.clone();
                for (p, m) in p.iter_mut().zip(&m2) {
                    p.extra_moment = m * sign;
                }
                eq7.push(seed_estimate(held, &p, soles, noise)?);
            }
        }
    }
    Ok(SeedCalibration {
        with_offsets: out[0],
        zeroed: out[1],
        eq7_plus: eq7[0],
        eq7_minus: eq7[1],
    })
}

/// Eqs. 3, 5 and 6 on two postures' pelvis-frame wrenches, back in the world at the upright
/// posture, with the covariance of the least-squares form.
fn seed_estimate(
    held: &[HeldPosture; 2],
    pw: &[PostureWrench],
    soles: [SoleCad; 2],
    noise: &SensorNoise,
) -> Result<ComResult, com::ComError> {
    let la = PostureLines::from_posture(&pw[0], 20.0)?;
    let lb = PostureLines::from_posture(&pw[1], 20.0)?;
    let c_pel = intersect(&la, &lb, 1e-3)?;
    let ls = rigid_com(pw, &noise.model(), 20.0, 1e-3)?;
    // Back to the world at the upright posture (the true upright kinematics).
    let k0 = &held[0].kinematics;
    let c2 = k0.pelvis.0 + k0.pelvis.1 * c_pel;
    let cov2 = k0.pelvis.1 * ls.covariance * k0.pelvis.1.transpose();
    let (with, without) = cad_with_and_without_feet(&held[0], &soles);
    let total = com::total_com_with_feet(la.mass_kg, &c2, &with, &without)?;
    let f = la.mass_kg / total.mass_kg;
    Ok(result(&total, &held[0].true_com, &(cov2 * f * f)))
}

/// Our calibration: the static regressor with the offsets as nuisance parameters on the held
/// postures (the first is the upright reference).
pub fn regressor_calibration(
    held: &[HeldPosture],
    offsets: &[Wrench; 2],
    tilts: &[com::Mat3],
    averaging: f64,
    noise: &SensorNoise,
    soles: [SoleCad; 2],
    rng: &mut ChaCha8Rng,
) -> Result<(ComResult, com::RegressorEstimate), com::ComError> {
    let mut model_noise = noise.model();
    model_noise.force_std_n /= averaging.sqrt();
    model_noise.moment_std_nm /= averaging.sqrt();
    let ps: Vec<CalibrationPosture> = held
        .iter()
        .zip(tilts)
        .map(|(h, t)| {
            let (r, k) = measure(h, offsets, noise, t, averaging, rng);
            regressor_posture(h, &r, &k)
        })
        .collect();
    let model = RegressorModel {
        soles,
        noise: model_noise,
        estimate_offsets: true,
        min_foot_load_n: 20.0,
    };
    let est = com::estimate(&ps, &model)?;
    let k0 = &held[0].kinematics;
    let (m2, c2, cov2) = est.body_com(k0.cad_mass, &k0.cad_first_moment, &k0.trunk.0, &k0.trunk.1);
    let (with, without) = cad_with_and_without_feet(&held[0], &soles);
    let total = com::total_com_with_feet(m2, &c2, &with, &without)?;
    let f = m2 / total.mass_kg;
    Ok((result(&total, &held[0].true_com, &(cov2 * f * f)), est))
}

/// Chooses `n` postures of [`candidates`] by D-optimality on the CAD kinematics, keeping those
/// whose CAD CoM stays 2 cm inside the support polygon; the upright posture is always in.
pub fn design(
    n: usize,
    noise: &SensorNoise,
    home_x: f64,
) -> Result<(Vec<PostureSpec>, f64), TwinError> {
    let mut cad = Sabian::load(&Variant::default(), "CAD")?;
    let soles = soles(&cad);
    let model = RegressorModel {
        soles,
        noise: noise.model(),
        estimate_offsets: true,
        min_foot_load_n: 20.0,
    };
    let mut specs = Vec::new();
    let mut infos = Vec::new();
    for spec in candidates() {
        spec.pose(&mut cad, home_x)?;
        let k = Kinematics::of(&mut cad);
        if !k.supported(spec.lifted, 0.02) {
            continue;
        }
        let fake = HeldPosture {
            spec,
            readings: [Wrench::zero(); 2],
            kinematics: k,
            true_body: (0.0, Vec3::zeros()),
            true_com: Vec3::zeros(),
            motor_torques: [0.0; MOTORS],
            motor_axes: [JointAxis::Pitch; MOTORS],
        };
        let p = regressor_posture(&fake, &[Wrench::zero(); 2], &k);
        let guess = [3.0, 0.0, 0.0, 0.0];
        let info = com::information(&p, &model, &guess).map_err(|e| TwinError::Model {
            path: "design".into(),
            message: e.to_string(),
        })?;
        specs.push(spec);
        infos.push(info);
    }
    let choice = d_optimal_subset(&infos, n, &[0]).map_err(|e| TwinError::Model {
        path: "design".into(),
        message: e.to_string(),
    })?;
    Ok((
        choice.chosen.iter().map(|&k| specs[k]).collect(),
        choice.condition_number,
    ))
}

/// A fresh generator for a named purpose (reproducible runs).
pub fn rng(seed: u64) -> ChaCha8Rng {
    ChaCha8Rng::seed_from_u64(seed)
}
