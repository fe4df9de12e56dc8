//! Postures that change the body's shape, and the sensors' offsets, through the static regressor.
//!
//! When the knees bend or the weight shifts, the CoM is no fixed point of any one link: it is
//! `c(q) = (M_cad(q) + m_e P(q) + R(q) h_e) / (m_cad + m_e)`, where `M_cad(q)` is the CAD model's
//! first moment of the body above the sensors (kg m, from the kinematics), and the unknown error
//! mass `m_e` (cables, electronics) with first moment `h_e = m_e s_e` about the origin of the link
//! that carries it (the trunk: pose `P, R`). The balance of the body is linear in `(m_e, h_e)`
//! and in the sensors' offsets `o_L, o_R` (6 each, in the sensor frames: reading = true + o):
//!
//! ```text
//!   -sum_i J_i o_i + [g; P x g] m_e + [0; -skew(g) R h_e] = -(sum_i J_i w_i + [m_cad g; M_cad x g])
//! ```
//!
//! (`J_i`: sensor frame -> calibration frame about its origin, `w_i` the raw reading). A foot in
//! the air reads its sole's weight (from the CAD model) plus its offset, six more rows that pin
//! that sensor's offset; without such postures the offsets only enter as one constant wrench that
//! small tilts cannot tell from a CoM shift, and the call reports the system singular.
//!
//! The tilt-angle error is an error of the body's orientation about the stance ankles (the ankle
//! encoders): it rotates the body's first moment about the pivot, and enters the moment rows'
//! covariance as `skew(g) skew(M - m p_pivot) sigma^2 (.)^T` about the two horizontal axes.

use super::least_squares::NoiseModel;
use super::wrench::{ComError, SensorReading, Wrench};
use super::{skew, Mat3, Vec3};
use nalgebra::{DMatrix, DVector};

/// Number of unknowns with offsets: error mass, its first moment, 6 offsets per sensor.
pub const UNKNOWNS: usize = 16;

/// The unknowns' names, in order.
pub const UNKNOWN_NAMES: [&str; UNKNOWNS] = [
    "error_mass_kg",
    "error_first_moment_x_kg_m",
    "error_first_moment_y_kg_m",
    "error_first_moment_z_kg_m",
    "left_offset_fx_n",
    "left_offset_fy_n",
    "left_offset_fz_n",
    "left_offset_mx_nm",
    "left_offset_my_nm",
    "left_offset_mz_nm",
    "right_offset_fx_n",
    "right_offset_fy_n",
    "right_offset_fz_n",
    "right_offset_mx_nm",
    "right_offset_my_nm",
    "right_offset_mz_nm",
];

/// The CAD model's sole below a sensor (the seed's foot).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoleCad {
    /// (kg)
    pub mass_kg: f64,
    /// The sole's CoM in the sensor frame (m).
    pub com_in_sensor: Vec3,
}

impl SoleCad {
    /// What the sensor reads when its foot hangs in the air, in the sensor frame: the sole's
    /// weight held by the body (`rotation`: sensor -> calibration frame, `gravity` in the
    /// calibration frame).
    pub fn hanging_reading(&self, rotation: &Mat3, gravity: &Vec3) -> Wrench {
        let g_s = rotation.transpose() * gravity;
        let f = g_s * self.mass_kg;
        Wrench::new(f, self.com_in_sensor.cross(&f))
    }
}

/// One static posture for the regressor, everything in the calibration frame (the floor's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationPosture {
    /// Left, right sensor: pose from the kinematics, raw reading (offsets included).
    pub sensors: [SensorReading; 2],
    /// Whether each foot stands on the floor (else it hangs and reads its sole).
    pub loaded: [bool; 2],
    /// CAD mass of the body above the sensors (kg).
    pub cad_mass_kg: f64,
    /// CAD first moment of the body above the sensors at this posture (kg m).
    pub cad_first_moment: Vec3,
    /// Origin of the link that carries the error mass (m).
    pub carrier_position: Vec3,
    /// Orientation of that link (link -> calibration frame).
    pub carrier_rotation: Mat3,
    /// Point the tilt error rotates the body about (the stance ankles) (m).
    pub tilt_pivot: Vec3,
    /// Gravity (m/s^2).
    pub gravity: Vec3,
}

/// The estimator's fixed inputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RegressorModel {
    /// The two soles' geometry from the CAD model (0 left, 1 right).
    pub soles: [SoleCad; 2],
    /// The measurement noise the postures are weighted by.
    pub noise: NoiseModel,
    /// Estimate the 12 offsets jointly (else they are taken as zero).
    pub estimate_offsets: bool,
    /// Least load on a foot that counts as standing (N).
    pub min_foot_load_n: f64,
}

/// The estimate, its covariance and the fit's diagnostics.
#[derive(Debug, Clone, PartialEq)]
pub struct RegressorEstimate {
    /// The unknowns in [`UNKNOWN_NAMES`] order (the first 4 only without offsets).
    pub theta: DVector<f64>,
    /// Covariance of `theta` (units of the unknowns squared).
    pub covariance: DMatrix<f64>,
    /// Of the whitened system with unit-norm columns.
    pub condition_number: f64,
    /// Sum of squared whitened residuals and its degrees of freedom.
    pub chi2: f64,
    /// Degrees of freedom of `chi2`: equations minus unknowns.
    pub dof: usize,
}

impl RegressorEstimate {
    /// The estimated mass error (kg): true mass minus the CAD model's.
    pub fn error_mass_kg(&self) -> f64 {
        self.theta[0]
    }

    /// The estimated error of the first moment of mass (kg m): the CoM error times the mass.
    pub fn error_first_moment(&self) -> Vec3 {
        Vec3::new(self.theta[1], self.theta[2], self.theta[3])
    }

    /// A sensor's offsets (0 left, 1 right) if they were estimated.
    pub fn offset(&self, foot: usize) -> Option<Wrench> {
        (self.theta.len() == UNKNOWNS).then(|| {
            let b = 4 + 6 * foot;
            Wrench::from_array(std::array::from_fn(|k| self.theta[b + k]))
        })
    }

    /// The body's mass (kg), CoM (m) and the CoM's covariance (m^2) at a posture given by its
    /// CAD mass and first moment and the carrier's pose.
    pub fn body_com(
        &self,
        cad_mass_kg: f64,
        cad_first_moment: &Vec3,
        carrier_position: &Vec3,
        carrier_rotation: &Mat3,
    ) -> (f64, Vec3, Mat3) {
        let me = self.error_mass_kg();
        let m = cad_mass_kg + me;
        let first =
            cad_first_moment + carrier_position * me + carrier_rotation * self.error_first_moment();
        let c = first / m;
        // d c / d (m_e, h_e)
        let mut j = nalgebra::SMatrix::<f64, 3, 4>::zeros();
        j.set_column(0, &((carrier_position - c) / m));
        j.fixed_view_mut::<3, 3>(0, 1)
            .copy_from(&(carrier_rotation / m));
        let cov4: nalgebra::SMatrix<f64, 4, 4> = self.covariance.fixed_view::<4, 4>(0, 0).into();
        (m, c, j * cov4 * j.transpose())
    }
}

struct Block {
    a: DMatrix<f64>,
    b: DVector<f64>,
    /// Maps the posture's raw readings' noise (12) to the rows' right-hand side.
    l: DMatrix<f64>,
}

fn block(p: &CalibrationPosture, model: &RegressorModel, np: usize) -> Block {
    let unloaded: Vec<usize> = if model.estimate_offsets {
        (0..2).filter(|&i| !p.loaded[i]).collect()
    } else {
        Vec::new()
    };
    let rows = 6 + 6 * unloaded.len();
    let mut a = DMatrix::zeros(rows, np);
    let mut b = DVector::zeros(rows);
    let mut l = DMatrix::zeros(rows, 12);
    let g = p.gravity;
    let mut sum = Wrench::zero();
    for (i, s) in p.sensors.iter().enumerate() {
        sum = sum + s.in_frame();
        let j = s.jacobian();
        // The right-hand side holds -J_i w_i: its noise is -J_i n_i.
        l.view_mut((0, 6 * i), (6, 6)).copy_from(&(-j));
        if model.estimate_offsets {
            a.view_mut((0, 4 + 6 * i), (6, 6)).copy_from(&(-j));
        }
    }
    // Error mass and its first moment.
    a.view_mut((0, 0), (3, 1)).copy_from(&g);
    a.view_mut((3, 0), (3, 1))
        .copy_from(&p.carrier_position.cross(&g));
    a.view_mut((3, 1), (3, 3))
        .copy_from(&(-skew(&g) * p.carrier_rotation));
    let rhs_f = -(sum.force + g * p.cad_mass_kg);
    let rhs_m = -(sum.moment + p.cad_first_moment.cross(&g));
    b.rows_mut(0, 3).copy_from(&rhs_f);
    b.rows_mut(3, 3).copy_from(&rhs_m);
    for (k, &i) in unloaded.iter().enumerate() {
        let r0 = 6 + 6 * k;
        a.view_mut((r0, 4 + 6 * i), (6, 6))
            .copy_from(&DMatrix::identity(6, 6));
        let truth = model.soles[i].hanging_reading(&p.sensors[i].rotation, &g);
        let raw = p.sensors[i].wrench;
        b.rows_mut(r0, 6)
            .copy_from(&DVector::from_row_slice(&(raw - truth).as_array()));
        l.view_mut((r0, 6 * i), (6, 6))
            .copy_from(&DMatrix::identity(6, 6));
    }
    Block { a, b, l }
}

/// The whitening matrix `W` (`W^T W = S^-1`) of a posture's rows, `S` from the sensors' noise
/// and the tilt error at the current estimate `theta`.
fn whitening(
    p: &CalibrationPosture,
    bl: &Block,
    noise: &NoiseModel,
    theta: &DVector<f64>,
) -> Result<DMatrix<f64>, ComError> {
    let n = bl.b.len();
    if noise.is_zero() {
        return Ok(DMatrix::identity(n, n));
    }
    let mut d = DMatrix::zeros(12, 12);
    for k in 0..12 {
        let s = if k % 6 < 3 {
            noise.force_std_n
        } else {
            noise.moment_std_nm
        };
        d[(k, k)] = s * s;
    }
    let mut s = &bl.l * d * bl.l.transpose();
    // Tilt of the body about the pivot (x and y axes).
    let m = p.cad_mass_kg + theta[0];
    let first = p.cad_first_moment
        + p.carrier_position * theta[0]
        + p.carrier_rotation * Vec3::new(theta[1], theta[2], theta[3]);
    let t: Mat3 = skew(&p.gravity) * skew(&(first - p.tilt_pivot * m));
    let mut tt = DMatrix::zeros(n, 2);
    for c in 0..2 {
        for r in 0..3 {
            tt[(3 + r, c)] = t[(r, c)];
        }
    }
    s += &tt * tt.transpose() * noise.tilt_std_rad.powi(2);
    // A tiny floor keeps rows with no modelled noise from dominating.
    for k in 0..n {
        s[(k, k)] += 1e-12;
    }
    let singular = || ComError::Singular {
        what: "the residual covariance".into(),
        condition: f64::INFINITY,
    };
    let chol = s.cholesky().ok_or_else(singular)?;
    chol.l().try_inverse().ok_or_else(singular)
}

/// A posture's Fisher information `A^T S^-1 A` about the unknowns (16 with offsets, else 4), at
/// a guess of the error mass and first moment (the tilt term depends on them). Needs only the
/// kinematics, not the readings: the design tool evaluates candidate postures with it.
pub fn information(
    p: &CalibrationPosture,
    model: &RegressorModel,
    guess: &[f64; 4],
) -> Result<DMatrix<f64>, ComError> {
    let np = if model.estimate_offsets { UNKNOWNS } else { 4 };
    let bl = block(p, model, np);
    let mut theta = DVector::zeros(np);
    for k in 0..4 {
        theta[k] = guess[k];
    }
    let w = whitening(p, &bl, &model.noise, &theta)?;
    let wa = w * &bl.a;
    Ok(wa.transpose() * wa)
}

/// Estimates the error mass, its first moment and (optionally) the sensors' offsets from N
/// postures by generalised least squares (two reweighting passes for the tilt term).
pub fn estimate(
    postures: &[CalibrationPosture],
    model: &RegressorModel,
) -> Result<RegressorEstimate, ComError> {
    let np = if model.estimate_offsets { UNKNOWNS } else { 4 };
    if postures.len() < 2 {
        return Err(ComError::TooFewPostures {
            need: 2,
            got: postures.len(),
        });
    }
    for (k, p) in postures.iter().enumerate() {
        for (i, s) in p.sensors.iter().enumerate() {
            let foot = ["left", "right"][i];
            let finite = s.wrench.is_finite()
                && s.position
                    .iter()
                    .chain(s.rotation.iter())
                    .all(|v| v.is_finite());
            if !finite {
                return Err(ComError::NonFinite {
                    what: format!("posture {k}: the {foot} sensor's wrench or pose"),
                });
            }
            if p.loaded[i]
                && (s.wrench.force.z.is_nan() || s.wrench.force.z < model.min_foot_load_n)
            {
                return Err(ComError::UnloadedFoot {
                    foot: if i == 0 { "left" } else { "right" },
                    normal_force_n: s.wrench.force.z,
                    min_n: model.min_foot_load_n,
                });
            }
        }
        let rest = [p.cad_mass_kg]
            .into_iter()
            .chain(p.cad_first_moment.iter().copied())
            .chain(p.carrier_position.iter().copied())
            .chain(p.carrier_rotation.iter().copied())
            .chain(p.gravity.iter().copied());
        if !rest.into_iter().all(|v| v.is_finite()) {
            return Err(ComError::NonFinite {
                what: format!("posture {k}: the kinematics (CAD first moment, carrier pose)"),
            });
        }
    }
    let blocks: Vec<Block> = postures.iter().map(|p| block(p, model, np)).collect();
    let noise = &model.noise;
    let mut theta = DVector::zeros(np);
    let mut result = None;
    let passes = if noise.is_zero() { 1 } else { 3 };
    for _pass in 0..passes {
        let mut rows_a = Vec::new();
        let mut rows_b = Vec::new();
        for (p, bl) in postures.iter().zip(&blocks) {
            let w = whitening(p, bl, noise, &theta)?;
            rows_a.push(&w * &bl.a);
            rows_b.push(&w * &bl.b);
        }
        let total: usize = rows_b.iter().map(|b| b.len()).sum();
        let mut a = DMatrix::zeros(total, np);
        let mut b = DVector::zeros(total);
        let mut r0 = 0;
        for (ra, rb) in rows_a.iter().zip(&rows_b) {
            a.view_mut((r0, 0), (rb.len(), np)).copy_from(ra);
            b.rows_mut(r0, rb.len()).copy_from(rb);
            r0 += rb.len();
        }
        // Condition number with unit-norm columns.
        let scale: Vec<f64> = (0..np).map(|c| a.column(c).norm().max(1e-300)).collect();
        let mut an = a.clone();
        for c in 0..np {
            an.column_mut(c).scale_mut(1.0 / scale[c]);
        }
        let svd = an.clone().svd(true, true);
        let smax = svd.singular_values.max();
        let smin = svd.singular_values.min();
        let cond = smax / smin.max(f64::MIN_POSITIVE);
        if total < np || cond.is_nan() || cond >= 1e9 {
            return Err(ComError::Singular {
                what: if model.estimate_offsets {
                    "the error mass and the sensors' offsets".into()
                } else {
                    "the error mass".into()
                },
                condition: cond,
            });
        }
        let y = svd.solve(&b, 0.0).map_err(|_| ComError::Singular {
            what: "the error mass".into(),
            condition: cond,
        })?;
        theta = DVector::from_iterator(np, (0..np).map(|c| y[c] / scale[c]));
        let res = &a * &theta - &b;
        let chi2 = res.norm_squared();
        let dof = total - np;
        // (A^T A)^-1 with the column scaling undone.
        let ata = an.transpose() * &an;
        let inv = ata.try_inverse().ok_or(ComError::Singular {
            what: "the error mass".into(),
            condition: cond,
        })?;
        let mut cov = DMatrix::from_fn(np, np, |r, c| inv[(r, c)] / (scale[r] * scale[c]));
        if noise.is_zero() {
            cov *= chi2 / dof.max(1) as f64;
        }
        result = Some(RegressorEstimate {
            theta: theta.clone(),
            covariance: cov,
            condition_number: cond,
            chi2,
            dof,
        });
    }
    Ok(result.expect("at least one pass"))
}

#[cfg(test)]
mod tests;
