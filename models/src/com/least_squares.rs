//! N >= 2 postures of a rigid body by weighted least squares, with the estimate's covariance.
//!
//! With noise the postures' lines are skew: no point lies on all of them. Each posture gives the
//! residual `r = tau - c x F` (3 rows; the seed's two lines are its x and y rows, the z row is the
//! moment about the vertical); the estimate minimises `sum r^T S^-1 r`, where `S` is the
//! residual's covariance propagated from the sensors' noise and the tilt-angle error at the
//! current estimate (errors in variables, linearised; two reweighting passes). Its covariance is
//! `(sum A^T S^-1 A)^-1` with `A = dr/dc = skew(F)`. For exact data and N = 2 it is the seed's
//! intersection (eq. 5).

use super::wrench::{ComError, PostureWrench};
use super::{skew, Mat3, Vec3, G};
use nalgebra::{SMatrix, SVector};

/// The measurement noise the covariance is propagated from (standard deviations).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseModel {
    /// Each force axis of each sensor (N).
    pub force_std_n: f64,
    /// Each moment axis of each sensor (N m).
    pub moment_std_nm: f64,
    /// The tilt of the calibration frame against the sensors, about each horizontal axis (rad):
    /// the encoder or inclinometer error of each posture, independent between postures.
    pub tilt_std_rad: f64,
}

impl NoiseModel {
    /// Whether the model has no noise at all (an exact fit; no weighting possible).
    pub fn is_zero(&self) -> bool {
        self.force_std_n == 0.0 && self.moment_std_nm == 0.0 && self.tilt_std_rad == 0.0
    }

    /// Covariance (6x6, order F, tau) of a posture's total wrench in the calibration frame.
    pub fn wrench_covariance(&self, p: &PostureWrench) -> SMatrix<f64, 6, 6> {
        let mut d = SMatrix::<f64, 6, 6>::zeros();
        for k in 0..3 {
            d[(k, k)] = self.force_std_n.powi(2);
            d[(k + 3, k + 3)] = self.moment_std_nm.powi(2);
        }
        let jl = p.left.jacobian();
        let jr = p.right.jacobian();
        let mut s = jl * d * jl.transpose() + jr * d * jr.transpose();
        // A small rotation dphi of the frame: dF = dphi x F, dtau = dphi x tau (about x and y).
        let w = p.total();
        let mut t = SMatrix::<f64, 6, 2>::zeros();
        let sf = -skew(&w.force);
        let st = -skew(&w.moment);
        for col in 0..2 {
            for row in 0..3 {
                t[(row, col)] = sf[(row, col)];
                t[(row + 3, col)] = st[(row, col)];
            }
        }
        s += t * t.transpose() * self.tilt_std_rad.powi(2);
        s
    }
}

/// The CoM of a rigid body from N postures.
#[derive(Debug, Clone, PartialEq)]
pub struct RigidEstimate {
    /// CoM in the calibration frame (m).
    pub com: Vec3,
    /// Its covariance (m^2), from the noise model (zero-noise models give the unweighted
    /// least-squares covariance scaled by the residual variance).
    pub covariance: Mat3,
    /// The body's mass, mean |F| / g over the postures (kg).
    pub mass_kg: f64,
    /// Condition number of the whitened stacked system.
    pub condition_number: f64,
    /// Sum of squared whitened residuals (chi-square with 3N - 3 degrees of freedom when the
    /// noise model is right).
    pub chi2: f64,
}

/// Weighted least squares over `postures` (at least 2, each checked: finite, both feet loaded
/// with `min_foot_load_n`). `min_tilt_rad` is the least angle between the gravity directions of
/// some pair of postures: below it Z cannot be separated and the call fails.
pub fn rigid_com(
    postures: &[PostureWrench],
    noise: &NoiseModel,
    min_foot_load_n: f64,
    min_tilt_rad: f64,
) -> Result<RigidEstimate, ComError> {
    if postures.len() < 2 {
        return Err(ComError::TooFewPostures {
            need: 2,
            got: postures.len(),
        });
    }
    for p in postures {
        p.check(min_foot_load_n)?;
    }
    let totals: Vec<_> = postures.iter().map(|p| p.total()).collect();
    // The widest pair of force directions.
    let mut widest = (0.0, 0, 1);
    for a in 0..totals.len() {
        for b in a + 1..totals.len() {
            let ang = totals[a].force.angle(&totals[b].force);
            if ang > widest.0 {
                widest = (ang, a, b);
            }
        }
    }
    if widest.0 < min_tilt_rad {
        return Err(ComError::PosturesTooClose {
            a: widest.1,
            b: widest.2,
            gap: widest.0.tan(),
            min: min_tilt_rad.tan(),
        });
    }
    let solve = |weights: &[Mat3]| -> Result<(Vec3, Mat3, f64), ComError> {
        let mut n = Mat3::zeros();
        let mut rhs = Vec3::zeros();
        for (w, wt) in totals.iter().zip(weights) {
            let a = skew(&w.force);
            n += a.transpose() * wt * a;
            rhs -= a.transpose() * wt * w.moment;
        }
        let eig = n.symmetric_eigen();
        let (lo, hi) = eig
            .eigenvalues
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(l, h), &v| (l.min(v), h.max(v)));
        let cond = (hi / lo.max(f64::MIN_POSITIVE)).sqrt();
        if lo.is_nan() || lo <= 0.0 || cond.is_nan() || cond > 1e10 {
            return Err(ComError::Singular {
                what: "the centre of mass".into(),
                condition: cond,
            });
        }
        let inv = n.try_inverse().ok_or(ComError::Singular {
            what: "the centre of mass".into(),
            condition: cond,
        })?;
        Ok((inv * rhs, inv, cond))
    };
    let identity = vec![Mat3::identity(); totals.len()];
    let (mut c, mut cov, mut cond) = solve(&identity)?;
    let mut weights = identity;
    if !noise.is_zero() {
        for _ in 0..2 {
            weights = postures
                .iter()
                .map(|p| {
                    let s6 = noise.wrench_covariance(p);
                    let mut l = SMatrix::<f64, 3, 6>::zeros();
                    l.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-skew(&c)));
                    l.fixed_view_mut::<3, 3>(0, 3).copy_from(&Mat3::identity());
                    let s = l * s6 * l.transpose();
                    s.try_inverse().unwrap_or_else(Mat3::identity)
                })
                .collect();
            (c, cov, cond) = solve(&weights)?;
        }
    }
    let mut chi2 = 0.0;
    for (w, wt) in totals.iter().zip(&weights) {
        let r: SVector<f64, 3> = w.moment - c.cross(&w.force);
        chi2 += (r.transpose() * wt * r)[(0, 0)];
    }
    if noise.is_zero() {
        let dof = (3 * totals.len()).saturating_sub(3).max(1) as f64;
        cov *= chi2 / dof;
    }
    let mass_kg = totals.iter().map(|w| w.force.norm()).sum::<f64>() / (G * totals.len() as f64);
    Ok(RigidEstimate {
        com: c,
        covariance: cov,
        mass_kg,
        condition_number: cond,
        chi2,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::com::two_posture::{intersect, PostureLines};
    use crate::com::wrench::{SensorReading, Wrench};
    use crate::com::{rot_x, rot_y};
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr_free::normal;

    /// Box-Muller, so the models crate needs no distribution crate.
    mod rand_distr_free {
        use rand::Rng;
        pub fn normal(rng: &mut impl Rng) -> f64 {
            let u1: f64 = rng.gen_range(f64::EPSILON..1.0);
            let u2: f64 = rng.gen();
            (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        }
    }

    const M: f64 = 37.0;

    fn truth() -> Vec3 {
        Vec3::new(0.031, -0.012, 0.587)
    }

    /// Exact readings of the rigid body at tilt `rot`, then noise: each sensor axis gets
    /// N(0, sigma), and the readings are rotated by a tilt error of N(0, sigma_tilt) about x, y
    /// (the frame the calibration believes in is off by that rotation).
    fn posture(rot: Mat3, noise: &NoiseModel, rng: &mut ChaCha8Rng) -> PostureWrench {
        let mut p = crate::com::two_posture::tests::synthetic(M, truth(), rot, 0.5);
        let err = rot_x(noise.tilt_std_rad * normal(rng)) * rot_y(noise.tilt_std_rad * normal(rng));
        for s in [&mut p.left, &mut p.right] {
            let f = s.wrench.force.map(|v| v + noise.force_std_n * normal(rng));
            let m = s
                .wrench
                .moment
                .map(|v| v + noise.moment_std_nm * normal(rng));
            // The sensor frame as the calibration believes it: rotated by the tilt error.
            *s = SensorReading {
                position: err * s.position,
                rotation: err * s.rotation,
                wrench: Wrench::new(f, m),
            };
        }
        p
    }

    /// Tilts spread over +/- 5 degrees in pitch and roll.
    fn design(n: usize) -> Vec<Mat3> {
        (0..n)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / n as f64;
                let r = if k == 0 { 0.0 } else { 5f64.to_radians() };
                rot_y(r * a.cos()) * rot_x(r * a.sin())
            })
            .collect()
    }

    #[test]
    fn n2_least_squares_equals_the_two_posture_formula() {
        let zero = NoiseModel {
            force_std_n: 0.0,
            moment_std_nm: 0.0,
            tilt_std_rad: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let ps = [
            posture(Mat3::identity(), &zero, &mut rng),
            posture(rot_y(1f64.to_radians()), &zero, &mut rng),
        ];
        let la = PostureLines::from_posture(&ps[0], 1.0).unwrap();
        let lb = PostureLines::from_posture(&ps[1], 1.0).unwrap();
        let closed = intersect(&la, &lb, 1e-3).unwrap();
        let ls = rigid_com(&ps, &zero, 1.0, 1e-3).unwrap();
        assert!((closed - truth()).norm() < 1e-9);
        assert!((ls.com - closed).norm() < 1e-9, "{} vs {}", ls.com, closed);
        assert!((ls.mass_kg - M).abs() < 1e-9);
    }

    #[test]
    fn error_falls_with_more_postures_and_matches_the_reported_covariance() {
        let noise = NoiseModel {
            force_std_n: 0.5,
            moment_std_nm: 0.05,
            tilt_std_rad: 0.05f64.to_radians(),
        };
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let draws = 400;
        let mut rms = Vec::new();
        let mut within = 0usize;
        let mut total = 0usize;
        for n in [2usize, 4, 8, 16] {
            let mut sq = 0.0;
            let mut mean_reported = 0.0;
            for _ in 0..draws {
                let ps: Vec<_> = design(n)
                    .into_iter()
                    .map(|r| posture(r, &noise, &mut rng))
                    .collect();
                let est = rigid_com(&ps, &noise, 1.0, 1e-3).unwrap();
                let e = est.com - truth();
                sq += e.norm_squared();
                mean_reported += est.covariance.trace();
                for k in 0..3 {
                    let z = e[k] / est.covariance[(k, k)].sqrt();
                    within += usize::from(z.abs() <= 2.0);
                    total += 1;
                }
            }
            let observed = (sq / draws as f64).sqrt();
            let reported = (mean_reported / draws as f64).sqrt();
            // The reported covariance is the observed scatter (within 20 %).
            assert!(
                (observed / reported - 1.0).abs() < 0.2,
                "N = {n}: observed {observed:.3e} m, reported {reported:.3e} m"
            );
            rms.push(observed);
        }
        for w in rms.windows(2) {
            assert!(w[1] < w[0], "error does not fall with N: {rms:?}");
        }
        let frac = within as f64 / total as f64;
        assert!((0.93..=0.97).contains(&frac), "|z| <= 2 in {frac:.3}");
    }

    #[test]
    fn one_posture_or_parallel_postures_are_refused() {
        let zero = NoiseModel {
            force_std_n: 0.0,
            moment_std_nm: 0.0,
            tilt_std_rad: 0.0,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let p = posture(Mat3::identity(), &zero, &mut rng);
        assert!(matches!(
            rigid_com(&[p], &zero, 1.0, 1e-3),
            Err(ComError::TooFewPostures { .. })
        ));
        let q = posture(rot_y(1e-5), &zero, &mut rng);
        let e = rigid_com(&[p, q], &zero, 1.0, 1e-3).unwrap_err();
        assert!(e.to_string().contains("too close to separate Z"), "{e}");
    }
}
