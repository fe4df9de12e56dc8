//! The SABIAN twin stands on its two sensors, and they carry its weight.

use zmp_models::com::{Mat3, Vec3, Wrench};
use zmp_twin::sabian::ik::{solve, IkTarget};
use zmp_twin::sabian::walk::measured_zmp;
use zmp_twin::sabian::{Sabian, Variant};

#[test]
fn the_cad_twin_stands_and_its_sensors_carry_the_body() {
    let mut r = Sabian::load(&Variant::default(), "cad").unwrap();
    assert!((r.mass() - 37.75).abs() < 1e-9, "CAD mass {}", r.mass());
    let t = IkTarget {
        feet: [Vec3::new(0.0, 0.08, 0.0), Vec3::new(0.0, -0.08, 0.0)],
        pelvis_position: Vec3::new(0.0, 0.0, 0.62),
        pelvis_rotation: Mat3::identity(),
        com_xy: Some([0.0, 0.0]),
        waist: [0.0, 0.0],
    };
    let it = solve(&mut r, &t).unwrap();
    assert!(it < 50);
    assert!(r.com().xy().norm() < 1e-9);
    r.hold_current_posture();
    for _ in 0..2000 {
        r.data.step();
    }
    let (body_mass, _) = r.body_first_moment();
    let fz: f64 = (0..2).map(|s| r.ft_reading(s).force.z).sum();
    assert!(
        (fz - body_mass * 9.81).abs() < 0.5,
        "sensors {fz} N, body weight {} N",
        body_mass * 9.81
    );
    assert!(r.com().z > 0.55, "fell: CoM at {}", r.com());
    // At rest the ZMP the two ankle sensors give (sole weights removed) is the ground
    // projection of the whole robot's CoM.
    let zmp = measured_zmp(&r, &mut Wrench::zero).unwrap();
    let c = r.com();
    assert!(
        (zmp[0] - c.x).hypot(zmp[1] - c.y) < 1e-3,
        "sensor ZMP {zmp:?} vs CoM {c}"
    );
}

#[test]
fn the_stand_keyframe_is_the_home_posture_with_the_soles_on_the_floor() {
    use zmp_twin::sabian::calibrate::{home_pelvis_x, PostureSpec, SOLE_CENTRE_X};
    // The keyframe as MuJoCo loads it from the file.
    let mut r = Sabian::load(&Variant::default(), "cad").unwrap();
    let key = r
        .model()
        .name_to_id(mujoco_rs::prelude::MjtObjBase::mjOBJ_KEY, "stand")
        .expect("sabian.xml has a keyframe 'stand'");
    r.data.reset_keyframe(key).unwrap();
    r.kinematics();
    let key_q: Vec<f64> = r.data.qpos().to_vec();
    // Soles level and on the floor: 7 decimals of a joint angle are 0.05 urad, under 0.1 um at
    // the soles.
    for s in 0..2 {
        let site = r.idx.sole_bottom_site[s];
        let z = r.data.site_xpos()[site][2];
        let m = r.data.site_xmat()[site];
        assert!(z.abs() < 1e-6, "sole {s} at z = {z} m");
        assert!((m[8] - 1.0).abs() < 1e-10, "sole {s} not level: {m:?}");
    }
    // The CAD CoM over the soles' centres.
    let c = r.com();
    assert!(
        (c.x - SOLE_CENTRE_X).abs() < 1e-6 && c.y.abs() < 1e-6,
        "CoM {c}"
    );
    // The servos hold it: each target is its joint's angle.
    for &(a, q) in &r.idx.servo {
        assert_eq!(r.data.ctrl()[a], key_q[q], "actuator {a}");
    }
    // It is the calibration's upright posture solved by the twin's inverse kinematics.
    let mut cad = Sabian::load(&Variant::default(), "cad").unwrap();
    let hx = home_pelvis_x(&mut cad).unwrap();
    PostureSpec::upright().pose(&mut cad, hx).unwrap();
    for (k, (a, b)) in key_q.iter().zip(cad.data.qpos()).enumerate() {
        assert!((a - b).abs() < 1e-7, "qpos[{k}]: keyframe {a}, IK {b}");
    }
}
