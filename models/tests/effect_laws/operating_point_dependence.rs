//! `operating_point_dependence`: `a` and `b` scaled at the CoM position as documented.

use crate::assert_close;
use crate::support::{plant, spec, H};
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

/// Slopes `[da_dx, da_dy, db_dx, db_dy]` per channel `[i][j]`.
type Slopes = [[[f64; 4]; 2]; 2];

/// The model text of per-channel slopes: a sub-table per channel with a non-zero slope.
fn per_channel(s: &Slopes) -> String {
    let mut t = String::new();
    for i in 0..2 {
        for j in 0..2 {
            let d = s[i][j];
            if d != [0.0; 4] {
                t += &format!(
                    "[operating_point_dependence.G{}{}]\nda_dx = {}\nda_dy = {}\ndb_dx = {}\n\
                     db_dy = {}\n",
                    i + 1,
                    j + 1,
                    d[0],
                    d[1],
                    d[2],
                    d[3]
                );
            }
        }
    }
    t
}

/// The law with one slope per channel, computed here from the model page's equation:
/// `zmp_i = sum_j a_ij (1 + da_ij . x_c) x_cj - b_ij (1 + db_ij . x_c) x_cj''`. Its static map
/// at `op` and that map's slope (the small-signal `a`), the scaled `b`.
fn law(a: [[f64; 2]; 2], b: [[f64; 2]; 2], s: &Slopes, op: [f64; 2]) -> [[[f64; 3]; 2]; 2] {
    let mut out = [[[0.0; 3]; 2]; 2];
    for i in 0..2 {
        for k in 0..2 {
            let scale = |j: usize, o: usize| 1.0 + s[i][j][o] * op[0] + s[i][j][o + 1] * op[1];
            // d/dx_k sum_j a_ij scale_ij(x) x_j.
            let slope: f64 = (0..2).map(|j| a[i][j] * op[j] * s[i][j][k]).sum();
            out[i][k] = [
                a[i][k] * scale(k, 0),
                a[i][k] * scale(k, 0) + slope,
                b[i][k] * scale(k, 2),
            ];
        }
    }
    out
}

/// Each channel with its own slopes, here only `G12` and `G21` move: the rest output, the
/// small-signal gain at DC and at frequency, a small step in time, and the slope of the rest
/// output over operating points are those of the law computed in the test; the channels
/// without slopes keep the model's coefficients (their small-signal gain still sees the other
/// channel's slope where the row's static map moves, as the law says).
#[test]
fn operating_point_dependence_per_channel_follows_its_law() {
    let mut s: Slopes = [[[0.0; 4]; 2]; 2];
    s[0][1] = [2.5, -1.2, 0.0, 3.0];
    s[1][0] = [-0.7, 1.9, -2.0, 0.0];
    let mut p = plant(&per_channel(&s));
    let base = plant("");
    let (a, b) = (base.pendulum().a, base.pendulum().b);
    for op in [[0.05, -0.03], [-0.02, 0.06]] {
        p.set_operating_point(op);
        let want = law(a, b, &s, op);
        let (a_static, b_op) = p.pendulum_at_operating_point();
        let (a_lin, _) = p.pendulum_gain_at_operating_point();
        for i in 0..2 {
            for k in 0..2 {
                let [ws, wl, wb] = want[i][k];
                assert!((a_static[i][k] - ws).abs() <= 1e-15, "{op:?} a{i}{k}");
                assert!((a_lin[i][k] - wl).abs() <= 1e-14, "{op:?} slope a{i}{k}");
                assert!((b_op[i][k] - wb).abs() <= 1e-15, "{op:?} b{i}{k}");
            }
        }
        // G11 and G22 have no slopes of their own: their coefficients are the model's.
        assert_eq!(a_static[0][0], a[0][0]);
        assert_eq!(b_op[1][1], b[1][1]);
        // Frequency response: (a_lin + b(op) w^2) H(jw).
        for w in [0.0, 2.0, 12.0] {
            let s_ = Complex64::new(0.0, w);
            let hw = 900.0 / (s_ * s_ + 60.0 * s_ + 900.0);
            let g = p.frequency_response(w);
            for i in 0..2 {
                for j in 0..2 {
                    let wnt = (want[i][j][1] + want[i][j][2] * w * w) * hw;
                    assert!(
                        (g[i][j] - wnt).norm() <= 1e-12 * wnt.norm(),
                        "{op:?} G{i}{j}"
                    );
                }
            }
        }
        // Rest output: the static map.
        let rest = p.reset(op);
        for i in 0..2 {
            let wnt = want[i][0][0] * op[0] + want[i][1][0] * op[1];
            assert!((rest.zmp[i] - wnt).abs() <= 1e-14, "{op:?} rest {i}");
        }
        // A small step settles at the small-signal gain.
        let d = [0.002, -0.001];
        let o = p.advance([op[0] + d[0], op[1] + d[1]], 10_000);
        for i in 0..2 {
            let wnt = want[i][0][1] * d[0] + want[i][1][1] * d[1];
            assert!(
                (o.zmp[i] - rest.zmp[i] - wnt).abs() <= 1e-12,
                "{op:?} step {i}"
            );
        }
        // That gain is the slope of the rest output over operating points.
        let eps = 1e-4;
        for k in 0..2 {
            let mut at = |e: f64| {
                let mut o = op;
                o[k] += e;
                p.set_operating_point(o);
                p.reset(o).zmp
            };
            let (hi, lo) = (at(eps), at(-eps));
            for i in 0..2 {
                let slope = (hi[i] - lo[i]) / (2.0 * eps);
                assert!((slope - want[i][k][1]).abs() <= 1e-9, "{op:?} dz{i}/dop{k}");
            }
        }
        p.set_operating_point(op);
        // And a simulated sine's first harmonic is the frequency response.
        let sim = p.simulated_response(Axis::X, 8.0, 0.005);
        let g = p.frequency_response(8.0);
        assert_close(sim[0], g[0][0], 0.005, 0.5, "G11 at op");
        assert_close(sim[1], g[1][0], 0.005, 0.5, "G21 at op");
    }
}

/// The flat table (one law for every channel, the only form before the slopes could differ)
/// and four sub-tables with the same slopes are the same plant: frequency responses and a
/// time simulation agree to 1e-12 at several operating points. The flat table reads back as
/// itself (one instance, written flat) and the sub-tables as four.
#[test]
fn equal_slopes_per_channel_are_the_flat_law() {
    let d = [1.5, -0.8, -2.0, 0.5];
    let flat = format!(
        "[operating_point_dependence]\nda_dx = {}\nda_dy = {}\ndb_dx = {}\ndb_dy = {}\n",
        d[0], d[1], d[2], d[3]
    );
    let four = per_channel(&[[d; 2]; 2]);
    let (sf, s4) = (spec(&flat), spec(&four));
    let count = |m: &zmp_models::ModelSpec| {
        m.effects
            .iter()
            .filter(|e| e.info.kind == zmp_models::EffectKind::OperatingPointDependence)
            .count()
    };
    assert_eq!((count(&sf), count(&s4)), (1, 4));
    assert!(sf.to_toml().contains("[operating_point_dependence]\n"));
    assert!(s4.to_toml().contains("[operating_point_dependence.G21]\n"));
    let (mut pf, mut p4) = (
        zmp_models::Plant::new(&sf, H).unwrap(),
        zmp_models::Plant::new(&s4, H).unwrap(),
    );
    for op in [[0.0, 0.0], [0.06, -0.04], [-0.03, 0.08]] {
        pf.set_operating_point(op);
        p4.set_operating_point(op);
        for w in [0.0, 0.5, 3.0, 15.0, 40.0] {
            let (gf, g4) = (pf.frequency_response(w), p4.frequency_response(w));
            for i in 0..2 {
                for j in 0..2 {
                    assert!(
                        (gf[i][j] - g4[i][j]).norm() <= 1e-12 * gf[i][j].norm(),
                        "{op:?} {w} rad/s G{i}{j}: {} vs {}",
                        gf[i][j],
                        g4[i][j]
                    );
                }
            }
        }
        let (rf, r4) = (pf.reset(op), p4.reset(op));
        assert!((rf.zmp[0] - r4.zmp[0]).abs() <= 1e-12 && (rf.zmp[1] - r4.zmp[1]).abs() <= 1e-12);
        for k in 1..=5000 {
            let t = k as f64 * H;
            let r = [
                op[0] + 0.008 * (3.0 * t).sin(),
                op[1] + 0.005 * (7.0 * t).cos(),
            ];
            let (of, o4) = (pf.step(r), p4.step(r));
            for i in 0..2 {
                assert!(
                    (of.zmp[i] - o4.zmp[i]).abs() <= 1e-12,
                    "{op:?} t = {t}: {} vs {}",
                    of.zmp[i],
                    o4.zmp[i]
                );
            }
        }
    }
}
