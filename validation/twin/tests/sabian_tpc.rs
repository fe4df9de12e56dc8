//! The Torso Position Control's actuation on the twin: the legs' linear map of a torso shift
//! (`TorsoMap`) against MuJoCo's forward kinematics.

use zmp_models::walking::Gait;
use zmp_twin::sabian::calibrate::FOOT_SPACING;
use zmp_twin::sabian::walk::{plan, VirtualModel};
use zmp_twin::sabian::{Sabian, Variant};

#[test]
fn a_torso_shift_through_the_leg_map_keeps_the_soles_and_moves_the_com_by_mu() {
    let gait = Gait::seed(FOOT_SPACING);
    let model = VirtualModel {
        name: "n".into(),
        description: "CAD".into(),
        error_mass: None,
    };
    let p = plan(&model, &gait).unwrap();
    let mut r = Sabian::load(&Variant::default(), "CAD").unwrap();
    let map = &p.torso;
    assert_eq!(map.per_sample.len(), p.qpos.len());
    // Standing, double support at a step's start, single support mid-step, and the end.
    let n = p.qpos.len();
    for k in [0, 384 + 3 * 96, 384 + 3 * 96 + 50, n - 1] {
        let feet = |r: &mut Sabian, q: &[f64]| {
            r.data.qpos_mut().copy_from_slice(q);
            r.kinematics();
            let sites = r.idx.sole_bottom_site;
            (
                sites.map(|s| r.data.site_xpos()[s]),
                sites.map(|s| r.data.site_xmat()[s][8]),
                r.com(),
            )
        };
        let q0 = p.qpos[k].clone();
        let (p0, _, c0) = feet(&mut r, &q0);
        let shifted = |d: [f64; 2]| {
            let mut q = q0.clone();
            let mut dq = vec![0.0; map.qpos.len()];
            map.apply(k, 0.0, d, &mut dq);
            for (adr, v) in map.qpos.iter().zip(&dq) {
                q[*adr] += v;
            }
            q[0] += d[0];
            q[1] += d[1];
            q
        };
        // At the 5 cm limit: the map is linear, its error second order. Both soles rise
        // together relative to the pelvis by about d^2 / (2 L) (L ~ 0.5 m, the legs' length: the
        // pelvis drops as over a leaning rigid leg, 2.5 mm at 5 cm), which on the floor only
        // lowers the pelvis; what would matter, the soles' horizontal places and their height
        // difference, stays within 1 mm, and they stay level within 0.1 degree.
        for d in [[0.05, 0.0], [0.0, 0.05], [-0.035, 0.035]] {
            let (p1, level, _) = feet(&mut r, &shifted(d));
            let e: Vec<[f64; 3]> = (0..2)
                .map(|s| std::array::from_fn(|i| p1[s][i] - p0[s][i]))
                .collect();
            let drop = (d[0] * d[0] + d[1] * d[1]) / (2.0 * 0.5);
            for s in 0..2 {
                assert!(
                    e[s][0].hypot(e[s][1]) < 1e-3,
                    "sample {k}, shift {d:?}: sole {s} moved {:?} m horizontally",
                    e[s]
                );
                assert!(
                    e[s][2] > 0.0 && e[s][2] < 1.5 * drop,
                    "sample {k}, shift {d:?}: sole {s} rose {} m (d^2/2L = {drop})",
                    e[s][2]
                );
                assert!(
                    level[s] > 0.1f64.to_radians().cos(),
                    "sample {k}: sole {s} tilts"
                );
            }
            assert!(
                (e[0][2] - e[1][2]).abs() < 1e-3,
                "sample {k}, shift {d:?}: soles' heights part by {} m",
                e[0][2] - e[1][2]
            );
        }
        if k == 0 {
            // The CoM moves by mu d for a small shift (finite difference against the map's mu,
            // 1 %: second-order terms over 1 mm).
            for c in 0..2 {
                let mut d = [0.0; 2];
                d[c] = 1e-3;
                let (_, _, c1) = feet(&mut r, &shifted(d));
                let mu = (c1[c] - c0[c]) / 1e-3;
                assert!(
                    (mu - map.com_per_shift[c]).abs() < 0.01 * mu,
                    "axis {c}: finite difference {mu}, map {}",
                    map.com_per_shift[c]
                );
            }
        }
    }
}
