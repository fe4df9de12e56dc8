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
