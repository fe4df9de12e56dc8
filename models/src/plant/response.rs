//! The plant in the frequency domain: the linear part's response, the describing functions
//! of the nonlinear effects (first and third harmonic) along each channel, and the simulated
//! first harmonic of the whole plant.

use super::*;

impl Plant {
    /// Frequency response of the linear part at `omega` (rad/s): `G[i][j]` for output `i`,
    /// input `j`. Nonlinear effects are left out (see [`Plant::describing_response`]).
    pub fn frequency_response(&self, omega: f64) -> [[Complex64; 2]; 2] {
        let mut g = [[Complex64::new(0.0, 0.0); 2]; 2];
        for ch in Channel::ALL {
            g[ch.output.index()][ch.input.index()] =
                self.channel_response(ch, omega, None, false).0;
        }
        g
    }

    /// First-harmonic response of one channel with nonlinear effects replaced by their
    /// describing functions, for a reference sine of `amplitude` (m) on the channel's input.
    /// The amplitude is carried along the command chain; the servo effects' describing
    /// functions multiply.
    pub fn describing_response(&self, ch: Channel, omega: f64, amplitude: f64) -> Complex64 {
        self.channel_response(ch, omega, Some(amplitude), false).0
    }

    /// [`Plant::describing_response`] and the channel's third harmonic over the reference's
    /// amplitude, for a reference `amplitude sin(omega t)` (sin-referenced phasors; for an
    /// input of phase `phi` the third harmonic turns by `3 phi`). Each nonlinear effect's own
    /// third harmonic ([`Effect::third_harmonic`], at the amplitude and phase of the first
    /// harmonic reaching it) is carried through the linear elements after it at `3 omega`,
    /// and third harmonics of several effects add (first order in the distortion). The
    /// servo passes a third harmonic from the command chain as its linear response.
    pub fn describing_harmonics(
        &self,
        ch: Channel,
        omega: f64,
        amplitude: f64,
    ) -> (Complex64, Complex64) {
        self.channel_response(ch, omega, Some(amplitude), true)
    }

    /// The first-harmonic response of a channel and, with an amplitude and `third`, its third
    /// harmonic (zero otherwise: the chain at 3 omega is evaluated only when asked for).
    fn channel_response(
        &self,
        ch: Channel,
        omega: f64,
        amplitude: Option<f64>,
        third: bool,
    ) -> (Complex64, Complex64) {
        let (i, j) = (ch.output.index(), ch.input.index());
        let zero = Complex64::new(0.0, 0.0);
        let third = third && amplitude.is_some_and(|a| a > 0.0);
        let mut g = Complex64::new(1.0, 0.0);
        let mut g3 = zero;
        let w3 = 3.0 * omega;
        let a0 = amplitude.unwrap_or(0.0);
        let mut amp = a0;
        // An effect's own third harmonic `h3` (for its input `amp sin(omega t)`), for its input
        // `amp sin(omega t + arg g)`, over the reference's amplitude.
        let own = |h3: Complex64, g: Complex64, amp: f64| {
            if g.norm() == 0.0 {
                return zero;
            }
            let p = g / g.norm();
            h3 * (amp / a0) * p * p * p
        };
        // The amplitude each nonlinear effect sees is the reference's after the command
        // effects before it.
        for e in &self.command[j] {
            if third {
                let (n, h3) = e.harmonics(omega, amp);
                g3 = g3 * e.frequency_response(w3, amp) + own(h3, g, amp);
                g *= n;
                amp *= n.norm();
            } else if e.info().linear || amplitude.is_some() {
                let n = e.frequency_response(omega, amp);
                g *= n;
                amp *= n.norm();
            }
        }
        let mut servo3 = zero;
        // The reference the servo follows (after the command effects).
        let reference = g;
        let joint = match amplitude {
            Some(_) => joint_servo(&self.servo_limits[j], omega, amp),
            None => None,
        };
        if let Some((n, h3)) = joint {
            if third {
                servo3 += own(h3, reference, amp);
            }
            g *= n;
        } else if amplitude.is_some() {
            for e in &self.servo_limits[j] {
                if third {
                    let (n, h3) = e.harmonics(omega, amp);
                    servo3 += own(h3, reference, amp);
                    g *= n;
                } else {
                    g *= e.frequency_response(omega, amp);
                }
            }
        }
        // The linked loop's linear response is the flexible trunk's filter times `H`; the
        // servo effects' describing functions above are relative to it, their third harmonics
        // are the servo's own (the CoM's with a linked trunk).
        // A play inside the loop (a backlash `in_servo`) is the loop's describing function at
        // the reference's amplitude, its third harmonic the CoM's own; a command's third
        // harmonic passes its engaged, small-signal filter.
        for e in &self.in_loop[j] {
            if e.info().linear {
                g *= e.frequency_response(omega, amp);
                if third {
                    g3 *= e.frequency_response(w3, amp);
                }
            } else if third {
                let (n, h3) = e.harmonics(omega, amp);
                servo3 += own(h3, reference, amp);
                g *= n;
                g3 *= e.frequency_response(w3, 0.0);
            } else {
                g *= e.frequency_response(omega, if amplitude.is_some() { amp } else { 0.0 });
            }
        }
        g *= self.lowpass[j].freq(omega);
        let pendulum = |w: f64| Complex64::new(self.a_lin[i][j] + self.b[i][j] * w * w, 0.0);
        g *= pendulum(omega);
        if third {
            g3 = (g3 * self.lowpass[j].freq(w3) + servo3) * pendulum(w3);
        }
        for e in self.channel[i][j].iter().chain(&self.sensor[i]) {
            g *= e.frequency_response(omega, amp);
            if third {
                g3 *= e.frequency_response(w3, amp);
            }
        }
        (g, g3)
    }

    /// The simulated first harmonic of both outputs, divided by the input's, for a sine of
    /// `amplitude` (m) at `omega` on `excited` around the current operating point: the
    /// numerically exact describing response of the whole plant, nonlinearities included.
    /// The fit waits for the periodic steady state (see [`steady_first_harmonics`]).
    pub fn simulated_response(
        &mut self,
        excited: Axis,
        omega: f64,
        amplitude: f64,
    ) -> [Complex64; 2] {
        let op = self.operating_point;
        self.reset(op);
        let period = 2.0 * std::f64::consts::PI / omega;
        let per = (period / self.h).round().max(8.0) as usize;
        let slowest = self.slowest_time_constant();
        let n_settle = (((10.0 * slowest).max(3.0 * period)) / self.h).ceil() as usize;
        let n_max = n_settle + (per * MAX_SETTLE_PERIODS).min(MAX_SETTLE_STEPS);
        let h = self.h;
        let z = steady_first_harmonics(omega, h, n_settle, n_max, |k| {
            let t = k as f64 * h;
            let mut r = op;
            r[excited.index()] += amplitude * (omega * t).sin();
            self.step(r).zmp
        });
        [z[0] / amplitude, z[1] / amplitude]
    }

    /// A bound on the slowest time constant of the linear dynamics, s (for settling times).
    pub fn slowest_time_constant(&self) -> f64 {
        let mut tau: f64 = 0.0;
        for lp in &self.lowpass {
            tau = tau.max(lp.slowest_time_constant());
        }
        let chains = self
            .command
            .iter()
            .chain(self.in_loop.iter())
            .chain(self.sensor.iter())
            .chain(self.channel.iter().flatten());
        for chain in chains {
            for e in chain {
                if let Some(tf) = e.transfer_function() {
                    tau = tau.max(crate::lti::slowest_time_constant(&tf.den));
                }
            }
        }
        tau
    }
}

/// The describing function and third harmonic of an axis's servo effects simulated together,
/// when two of them act at `omega` and `amplitude` (a friction in a servo whose force limit
/// clips: see [`crate::effects::servo::joint_servo_harmonics`]); `None` when at most one
/// acts, whose own describing function is then exact (the others' is 1). A saturation is
/// counted as acting unless the linear servo's force plus twice what the others may add stays
/// below its limit (the margin covers the friction's distortion of the demanded force).
fn joint_servo(
    limits: &[Box<dyn Effect>],
    omega: f64,
    amplitude: f64,
) -> Option<(Complex64, Complex64)> {
    if limits.len() < 2 {
        return None;
    }
    let extra: f64 = limits.iter().map(|e| e.servo_force_bound()).sum();
    let acting: Vec<&Box<dyn Effect>> = limits
        .iter()
        .filter(|e| !e.servo_idle(omega, amplitude, 2.0 * (extra - e.servo_force_bound())))
        .collect();
    if acting.len() < 2 {
        return None;
    }
    let parts = acting
        .iter()
        .map(|e| e.servo_part())
        .collect::<Option<Vec<_>>>()?;
    crate::effects::servo::joint_servo_harmonics(parts, omega, amplitude)
}
