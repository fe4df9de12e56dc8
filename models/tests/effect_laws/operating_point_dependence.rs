//! `operating_point_dependence`: `a` and `b` scaled at the CoM position as documented.

use crate::assert_close;
use crate::support::plant;
use num_complex::Complex64;
use zmp_models::Axis;

/// `a_ij(x_c) = a_ij (1 + da_dx x + da_dy y)`, `b_ij(x_c)` likewise, at the CoM position: the
/// rest output is `a(op) op`; a small motion about `op` sees the slope of that static map,
/// `a_ij(op) + da_j (a op)_i` (the DC gain, the response at frequency, a small step in time);
/// and that slope is the one of the rest outputs at neighbouring operating points.
#[test]
fn operating_point_dependence_scales_a_and_b_as_documented() {
    let (da_dx, da_dy, db_dx, db_dy) = (1.5, -0.8, -2.0, 0.5);
    let mut p = plant(&format!(
        "[operating_point_dependence]\nda_dx = {da_dx}\nda_dy = {da_dy}\ndb_dx = {db_dx}\n\
         db_dy = {db_dy}\n"
    ));
    let base = plant("");
    let a = base.pendulum().a;
    let b = base.pendulum().b;
    // At the origin the model's own coefficients.
    for w in [0.0, 3.0, 30.0] {
        assert_eq!(p.frequency_response(w), base.frequency_response(w));
    }
    for op in [[0.06, -0.04], [-0.03, 0.08]] {
        let sa = 1.0 + da_dx * op[0] + da_dy * op[1];
        let sb = 1.0 + db_dx * op[0] + db_dy * op[1];
        p.set_operating_point(op);
        assert_eq!(p.operating_point(), op);
        let da = [da_dx, da_dy];
        let lin = |i: usize, j: usize| a[i][j] * sa + da[j] * (a[i][0] * op[0] + a[i][1] * op[1]);
        // DC gain: G(0) = a_ij(op) + da_j (a op)_i.
        let g0 = p.frequency_response(0.0);
        for i in 0..2 {
            for j in 0..2 {
                let want = lin(i, j);
                assert!(
                    (g0[i][j].re - want).abs() <= 1e-12 * want.abs(),
                    "{op:?} {i}{j}"
                );
                assert!(g0[i][j].im.abs() <= 1e-15);
            }
        }
        // At frequency: (a_lin(op) + b(op) w^2) H(jw).
        for w in [1.0, 10.0, 40.0] {
            let s = Complex64::new(0.0, w);
            let hw = 900.0 / (s * s + 60.0 * s + 900.0);
            let g = p.frequency_response(w);
            for i in 0..2 {
                for j in 0..2 {
                    let want = (lin(i, j) + b[i][j] * sb * w * w) * hw;
                    assert!((g[i][j] - want).norm() <= 1e-12 * want.norm());
                }
            }
        }
        // Rest output and DC gain in the time domain.
        let rest = p.reset(op);
        for i in 0..2 {
            let want = sa * (a[i][0] * op[0] + a[i][1] * op[1]);
            assert!(
                (rest.zmp[i] - want).abs() <= 1e-15,
                "{} vs {want}",
                rest.zmp[i]
            );
        }
        let d = [0.002, -0.001];
        let o = p.advance([op[0] + d[0], op[1] + d[1]], 10_000);
        for i in 0..2 {
            let gain = (o.zmp[i] - rest.zmp[i]) / 1.0;
            let want = lin(i, 0) * d[0] + lin(i, 1) * d[1];
            assert!(
                (gain - want).abs() <= 1e-12,
                "{op:?} output {i}: {gain} vs {want}"
            );
        }
        // The small-signal gain is the slope of the rest ZMP over operating points (central
        // differences; the static map is quadratic, so they are exact up to rounding).
        let eps = 1e-4;
        for j in 0..2 {
            let mut at = |s: f64| {
                let mut o = op;
                o[j] += s;
                p.set_operating_point(o);
                p.reset(o).zmp
            };
            let (hi, lo) = (at(eps), at(-eps));
            for i in 0..2 {
                let slope = (hi[i] - lo[i]) / (2.0 * eps);
                assert!(
                    (slope - g0[i][j].re).abs() <= 1e-9,
                    "{op:?} d zmp_{i}/d op_{j}: {slope} vs G(0) {}",
                    g0[i][j].re
                );
            }
        }
        p.set_operating_point(op);
        p.reset(op);
        // And the time response at frequency matches the scaled frequency response.
        let sim = p.simulated_response(Axis::Y, 10.0, 0.005);
        let g = p.frequency_response(10.0);
        assert_close(sim[0], g[0][1], 0.005, 0.5, "G12 at op");
        assert_close(sim[1], g[1][1], 0.005, 0.5, "G22 at op");
    }
}
