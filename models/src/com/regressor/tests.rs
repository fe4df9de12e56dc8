use super::*;
use crate::com::{rot_x, rot_y, rot_z};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn normal(rng: &mut impl Rng) -> f64 {
    let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
    let u2: f64 = rng.gen();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

const CAD_MASS: f64 = 35.0;
const ERROR_MASS: f64 = 3.0;

fn error_at() -> Vec3 {
    Vec3::new(-0.10, 0.03, 0.25)
}

fn soles() -> [SoleCad; 2] {
    [
        SoleCad {
            mass_kg: 0.9,
            com_in_sensor: Vec3::new(0.02, 0.0, -0.04),
        },
        SoleCad {
            mass_kg: 0.9,
            com_in_sensor: Vec3::new(0.02, 0.0, -0.04),
        },
    ]
}

fn offsets() -> [Wrench; 2] {
    [
        Wrench::from_array([10.0, -8.0, 10.0, 0.8, -1.0, 0.3]),
        Wrench::from_array([-7.0, 10.0, -6.0, -0.5, 0.9, -0.4]),
    ]
}

/// A posture: the body tilted by `tilt` about the ankles, the trunk shifted by `shift`, feet
/// loaded as given; readings exact, then offsets and noise.
fn posture(
    tilt: Mat3,
    shift: Vec3,
    loaded: [bool; 2],
    noise: &NoiseModel,
    rng: &mut ChaCha8Rng,
) -> CalibrationPosture {
    let g = Vec3::new(0.0, 0.0, -9.81);
    let carrier_position = tilt * (Vec3::new(0.0, 0.0, 0.7) + shift);
    let carrier_rotation = tilt * rot_z(0.02);
    // The CAD body: legs (fixed) and a trunk that moves with the carrier.
    let cad_first_moment = Vec3::new(0.0, 0.0, 0.3) * 15.0
        + (carrier_position + carrier_rotation * Vec3::new(0.01, 0.0, 0.2)) * 20.0;
    let first = cad_first_moment + (carrier_position + carrier_rotation * error_at()) * ERROR_MASS;
    let m = CAD_MASS + ERROR_MASS;
    // Required total on the body from the sensors, about the origin.
    let need = Wrench::new(-g * m, -first.cross(&g));
    let pose = |y: f64| SensorReading {
        position: Vec3::new(0.0, y, 0.05),
        rotation: Mat3::identity(),
        wrench: Wrench::zero(),
    };
    let mut s = [pose(0.1), pose(-0.1)];
    let sol = soles();
    let inv = |sr: &SensorReading, w: Wrench| -> Wrench {
        // in_frame inverse: rotate back, moment about the sensor.
        let f = sr.rotation.transpose() * w.force;
        let mm = sr.rotation.transpose() * (w.moment - sr.position.cross(&w.force));
        Wrench::new(f, mm)
    };
    match loaded {
        [true, true] => {
            let wl = Wrench::new(need.force * 0.4, Vec3::new(0.2, -0.3, 0.01));
            s[0].wrench = wl;
            let rest = need - s[0].in_frame();
            s[1].wrench = inv(&s[1], rest);
        }
        [true, false] | [false, true] => {
            let (up, down) = if loaded[0] { (0, 1) } else { (1, 0) };
            s[down].wrench = sol[down].hanging_reading(&s[down].rotation, &g);
            let rest = need - s[down].in_frame();
            s[up].wrench = inv(&s[up], rest);
        }
        _ => unreachable!(),
    }
    let off = offsets();
    // (The tilt error is exercised by the rigid estimator's test and on the twin.)
    for (i, sr) in s.iter_mut().enumerate() {
        let mut a = sr.wrench.as_array();
        let o = off[i].as_array();
        for k in 0..6 {
            let sd = if k < 3 {
                noise.force_std_n
            } else {
                noise.moment_std_nm
            };
            a[k] += o[k] + sd * normal(rng);
        }
        sr.wrench = Wrench::from_array(a);
    }
    CalibrationPosture {
        sensors: s,
        loaded,
        cad_mass_kg: CAD_MASS,
        cad_first_moment,
        carrier_position,
        carrier_rotation,
        tilt_pivot: Vec3::new(0.0, 0.0, 0.05),
        gravity: g,
    }
}

fn design(noise: &NoiseModel, rng: &mut ChaCha8Rng, n_tilts: usize) -> Vec<CalibrationPosture> {
    let mut v = Vec::new();
    for k in 0..n_tilts {
        let a = std::f64::consts::TAU * k as f64 / n_tilts as f64;
        let r = 5f64.to_radians();
        v.push(posture(
            rot_y(r * a.cos()) * rot_x(r * a.sin()),
            Vec3::new(0.0, 0.02 * a.sin(), -0.05 * (k % 2) as f64),
            [true, true],
            noise,
            rng,
        ));
    }
    v.push(posture(
        Mat3::identity(),
        Vec3::new(0.0, 0.1, 0.0),
        [true, false],
        noise,
        rng,
    ));
    v.push(posture(
        Mat3::identity(),
        Vec3::new(0.0, -0.1, 0.0),
        [false, true],
        noise,
        rng,
    ));
    v
}

fn model(noise: NoiseModel) -> RegressorModel {
    RegressorModel {
        soles: soles(),
        noise,
        estimate_offsets: true,
        min_foot_load_n: 20.0,
    }
}

const ZERO: NoiseModel = NoiseModel {
    force_std_n: 0.0,
    moment_std_nm: 0.0,
    tilt_std_rad: 0.0,
};

#[test]
fn exact_readings_give_the_error_mass_and_all_twelve_offsets() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let ps = design(&ZERO, &mut rng, 6);
    let est = estimate(&ps, &model(ZERO)).unwrap();
    assert!((est.error_mass_kg() - ERROR_MASS).abs() < 1e-9);
    assert!((est.error_first_moment() - error_at() * ERROR_MASS).norm() < 1e-9);
    for i in 0..2 {
        let o = est.offset(i).unwrap();
        let d = (o - offsets()[i]).as_array();
        assert!(d.iter().all(|v| v.abs() < 1e-8), "{d:?}");
    }
    // And the body's CoM at the upright posture.
    let p0 = &ps[0];
    let (m, c, _) = est.body_com(
        p0.cad_mass_kg,
        &p0.cad_first_moment,
        &p0.carrier_position,
        &p0.carrier_rotation,
    );
    let truth = (p0.cad_first_moment
        + (p0.carrier_position + p0.carrier_rotation * error_at()) * ERROR_MASS)
        / (CAD_MASS + ERROR_MASS);
    assert!((m - CAD_MASS - ERROR_MASS).abs() < 1e-9);
    assert!((c - truth).norm() < 1e-10);
}

#[test]
fn without_a_lifted_foot_the_offsets_are_not_determined() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let ps: Vec<_> = design(&ZERO, &mut rng, 6).into_iter().take(6).collect();
    let e = estimate(&ps, &model(ZERO)).unwrap_err();
    assert!(matches!(e, ComError::Singular { .. }), "{e}");
    assert!(e.to_string().contains("offsets"), "{e}");
    // Without offsets in the model the same postures determine the error mass (biased by the
    // offsets, which is why they are estimated).
    let mut m = model(ZERO);
    m.estimate_offsets = false;
    let est = estimate(&ps, &m).unwrap();
    assert!((est.error_mass_kg() - ERROR_MASS).abs() > 0.01);
}

#[test]
fn noisy_estimates_scatter_as_the_reported_covariance_says() {
    let noise = NoiseModel {
        force_std_n: 0.5,
        moment_std_nm: 0.05,
        tilt_std_rad: 0.0,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut within = 0;
    let mut total = 0;
    for _ in 0..300 {
        let ps = design(&noise, &mut rng, 8);
        let est = estimate(&ps, &model(noise)).unwrap();
        let truth = [ERROR_MASS, 3.0 * -0.10, 3.0 * 0.03, 3.0 * 0.25];
        for k in 0..4 {
            let z = (est.theta[k] - truth[k]) / est.covariance[(k, k)].sqrt();
            within += usize::from(z.abs() <= 2.0);
            total += 1;
        }
    }
    let frac = within as f64 / total as f64;
    assert!((0.92..=0.975).contains(&frac), "|z| <= 2 in {frac:.3}");
}

#[test]
fn nan_readings_and_unloaded_standing_feet_are_named() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut ps = design(&ZERO, &mut rng, 4);
    ps[2].sensors[1].wrench.force.x = f64::NAN;
    let e = estimate(&ps, &model(ZERO)).unwrap_err();
    assert!(e.to_string().contains("posture 2: the right sensor"), "{e}");
    let mut ps = design(&ZERO, &mut rng, 4);
    ps[4].loaded = [true, true];
    let e = estimate(&ps, &model(ZERO)).unwrap_err();
    assert!(e.to_string().contains("right foot carries"), "{e}");
}
