//! Cascade ZMP direct-feedback controller (first seed, section 6.6, eqs. 28–29):
//! `C1(s) = K1/s` on the ZMP error, then `C2(s) = K2/(s + K2)`, whose output is the trunk angle
//! reference; the trunk moves the CoM by `(m_t/m_r) l_t theta` (eq. 26).
//!
//! Units (the seed does not state them; chosen so that K1 = 0.014, K2 = 0.2 reproduce its
//! experiment, see `CascadeParams::silo2`): the ZMP error enters in `error_scale` units per
//! metre, the controller output is the trunk angle in radians.
//!
//! Discrete time with the error moving linearly between steps (trapezoidal integration, which
//! is exact for that), exact discretisation of the lag. Anti-windup: the integrator state is
//! clamped to the angle limits; the lag has unit DC gain, so the output stays within them too.

/// Parameters of one axis of the cascade.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeParams {
    /// Integral gain K1 (output unit per error unit per second).
    pub k1: f64,
    /// Lag corner K2, rad/s.
    pub k2: f64,
    /// Error units per metre of ZMP error (100: centimetres).
    pub error_scale: f64,
    /// Trunk mass over robot mass `m_t/m_r` (eq. 26).
    pub mass_ratio: f64,
    /// Trunk length `l_t`, m (eq. 26).
    pub trunk_length: f64,
    /// Trunk angle limits, rad.
    pub theta_min: f64,
    pub theta_max: f64,
}

impl CascadeParams {
    /// The seed's controller: K1 = 0.014, K2 = 0.2, m_t/m_r = 0.17 (48 kg robot).
    ///
    /// Unit convention: ZMP error in centimetres, trunk angle in radians, trunk length 0.65 m.
    /// Only the product `error_scale * mass_ratio * trunk_length` (11.05 m/m here) shapes the
    /// loop; with it the ZMP first reaches the new set point 20.4 s after the step, as the seed
    /// reports ("about 20 seconds"). Metres in and radians out (product 0.11) would take
    /// minutes; the README lists the figures for other conventions.
    pub fn silo2() -> CascadeParams {
        CascadeParams {
            k1: 0.014,
            k2: 0.2,
            error_scale: 100.0,
            mass_ratio: 0.17,
            trunk_length: 0.65,
            theta_min: -0.8,
            theta_max: 0.8,
        }
    }

    /// CoM displacement per radian of trunk angle, m/rad.
    pub fn trunk_gain(&self) -> f64 {
        self.mass_ratio * self.trunk_length
    }

    /// The loop's dominant closed-loop poles on a plant seen at its static gain, `lever` m of
    /// ZMP per radian of trunk (`a11 (m_t/m_r) l_t`). The controller gives the trunk angle
    /// `theta = e_s K1 K2 / (s (s + K2)) (zmp_ref - zmp)` and the plant `zmp = lever theta`, so
    ///
    /// ```text
    /// s^2 + K2 s + K2 kappa = 0,   kappa = e_s K1 lever   (1/s),
    /// s = -K2/2 +- j sqrt(K2 kappa - K2^2/4)
    /// ```
    ///
    /// The real part `-K2/2` does not depend on the lever: the envelope, and so the 2 % settling
    /// time (about `4 / (K2/2)` = 40 s for the seed's K2), is the same for any robot; the lever
    /// sets the damped frequency and the damping `zeta = sqrt(K2 / (4 kappa))`. Valid while the
    /// loop is much slower than the servo (30 rad/s) and the pendulum's `b w^2` is small beside
    /// `a` (1e-3 at 0.1 rad/s). Returns `(real part, imaginary part)`, 1/s (imaginary part 0 for
    /// an over-damped loop, whose slower real pole is then returned).
    pub fn dominant_poles(&self, lever: f64) -> (f64, f64) {
        let kappa = self.error_scale * self.k1 * lever;
        let half = self.k2 / 2.0;
        let d = self.k2 * kappa - half * half;
        if d > 0.0 {
            (-half, d.sqrt())
        } else {
            (-half + (-d).sqrt(), 0.0)
        }
    }

    /// When the step response of that second-order loop first reaches the set point, s:
    /// `(pi - acos zeta) / omega_d` (no zero in the closed loop `K2 kappa / (s^2 + K2 s + K2
    /// kappa)`); infinite for a critically or over-damped loop, which never reaches it.
    pub fn first_reach_time(&self, lever: f64) -> f64 {
        let (re, im) = self.dominant_poles(lever);
        if im <= 0.0 {
            return f64::INFINITY;
        }
        let zeta = -re / re.hypot(im);
        (std::f64::consts::PI - zeta.acos()) / im
    }
}

/// One axis of the cascade controller.
#[derive(Debug, Clone)]
pub struct CascadeAxis {
    p: CascadeParams,
    h: f64,
    /// `e^{-K2 h}` and the first-order-hold input weights of the lag.
    lag_a: f64,
    lag_b0: f64,
    lag_b1: f64,
    integ: f64,
    lag: f64,
    e_prev: f64,
}

impl CascadeAxis {
    pub fn new(p: CascadeParams, h: f64) -> CascadeAxis {
        let a = (-p.k2 * h).exp();
        // Lag y' = K2 (u - y) with u ramping from u0 to u1 over h:
        // y1 = a y0 + (1 - a) u0 + (1 - (1 - a)/(K2 h)) (u1 - u0).
        let ramp = if p.k2 * h > 1e-12 {
            1.0 - (1.0 - a) / (p.k2 * h)
        } else {
            0.0
        };
        CascadeAxis {
            p,
            h,
            lag_a: a,
            lag_b0: 1.0 - a,
            lag_b1: ramp,
            integ: 0.0,
            lag: 0.0,
            e_prev: 0.0,
        }
    }

    pub fn params(&self) -> &CascadeParams {
        &self.p
    }

    /// At rest with trunk angle `theta` and zero error.
    pub fn reset(&mut self, theta: f64) {
        let th = theta.clamp(self.p.theta_min, self.p.theta_max);
        self.integ = th;
        self.lag = th;
        self.e_prev = 0.0;
    }

    /// One step: ZMP reference and measurement (m) in, trunk angle (rad) out.
    #[inline]
    pub fn step(&mut self, zmp_ref: f64, zmp: f64) -> f64 {
        let e = self.p.error_scale * (zmp_ref - zmp);
        let e = if e.is_finite() { e } else { self.e_prev };
        let i0 = self.integ;
        let i1 = (i0 + 0.5 * self.p.k1 * self.h * (self.e_prev + e))
            .clamp(self.p.theta_min, self.p.theta_max);
        self.lag = self.lag_a * self.lag + self.lag_b0 * i0 + self.lag_b1 * (i1 - i0);
        self.integ = i1;
        self.e_prev = e;
        self.lag
    }

    pub fn theta(&self) -> f64 {
        self.lag
    }
}

/// Both axes: ZMP references and measurements in, CoM references out.
#[derive(Debug, Clone)]
pub struct CascadeController {
    pub axes: [CascadeAxis; 2],
    /// CoM reference at zero trunk angle, m.
    pub com_offset: [f64; 2],
}

impl CascadeController {
    pub fn new(p: CascadeParams, h: f64) -> CascadeController {
        CascadeController {
            axes: [CascadeAxis::new(p, h), CascadeAxis::new(p, h)],
            com_offset: [0.0; 2],
        }
    }

    /// At rest producing the CoM reference `com_ref`.
    pub fn reset_to_com(&mut self, com_ref: [f64; 2]) {
        for (j, ax) in self.axes.iter_mut().enumerate() {
            let g = ax.p.trunk_gain();
            ax.reset((com_ref[j] - self.com_offset[j]) / g);
        }
    }

    #[inline]
    pub fn step(&mut self, zmp_ref: [f64; 2], zmp: [f64; 2]) -> [f64; 2] {
        let mut out = [0.0; 2];
        for j in 0..2 {
            let th = self.axes[j].step(zmp_ref[j], zmp[j]);
            out[j] = self.com_offset[j] + self.axes[j].p.trunk_gain() * th;
        }
        out
    }

    pub fn theta(&self) -> [f64; 2] {
        [self.axes[0].theta(), self.axes[1].theta()]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dominant-pole reach time against the project's digital controller closing the loop
    /// on a static plant `zmp = lever theta` at 1 ms (a second-order loop, simulated): within
    /// 0.5 % (the trapezoidal integrator and the sampling at 1 ms against a 20-40 s response).
    #[test]
    fn first_reach_time_is_the_simulated_static_loops() {
        let p = CascadeParams {
            theta_min: -10.0,
            theta_max: 10.0,
            ..CascadeParams::silo2()
        };
        for lever in [0.0916, 0.0524, 0.0439] {
            let h = 1e-3;
            let mut ctrl = CascadeAxis::new(p, h);
            ctrl.reset(0.0);
            let mut zmp = 0.0;
            let mut t_reach = f64::NAN;
            for k in 0..200_000 {
                if zmp >= 0.01 {
                    t_reach = k as f64 * h;
                    break;
                }
                zmp = lever * ctrl.step(0.01, zmp);
            }
            let predicted = p.first_reach_time(lever);
            assert!(
                (t_reach / predicted - 1.0).abs() < 5e-3,
                "{lever}: {t_reach} vs {predicted}"
            );
            // The envelope does not depend on the lever.
            assert!((p.dominant_poles(lever).0 + 0.1).abs() < 1e-12);
        }
        // Critically damped or slower: never reaches.
        assert!(p
            .first_reach_time(0.2 / (4.0 * 100.0 * 0.014))
            .is_infinite());
    }
}
