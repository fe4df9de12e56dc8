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
