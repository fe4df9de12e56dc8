//! Robust stability of the ZMP loop against the identified multiplicative uncertainty: the
//! check the first seed's conclusion names as the next step ("robust controllers for ZMP
//! direct feedback"), for the cascade controller of section 6.6 or any controller given by its
//! frequency response.
//!
//! **Uncertainty structure.** The seed (section 6.5) and this project's plant perturb each
//! channel on its own, `G_ij -> G_ij (1 + W_ij(s) Delta_ij(s))` with `||Delta_ij||_inf <= 1`:
//! four independent complex scalars ([`crate::effects::uncertainty`]). This is neither input
//! nor output multiplicative uncertainty (`G (I + W_I Delta_I)`, `(I + W_O Delta_O) G`, one
//! weight per input or output): the identification gives no such weights, and the three
//! coincide only for a diagonal plant. The analysis keeps the structure as identified.
//!
//! **The loop.** Negative feedback `u = K(s) (r - y)`, `y` the ZMP (m), `u` the CoM reference
//! (m), `K` the controller from ZMP error to CoM reference ([`LoopController`]). Each
//! perturbation is pulled out of the loop: `z_k = W_k G_k u_(j_k)` leaves channel
//! `k = (i_k, j_k)`, `w_k = Delta_k z_k` enters output `i_k`. The loop is broken at the
//! perturbations' outputs `w` and closed back at their inputs `z`; what they see is
//!
//! ```text
//! M(jw) = -R K S L,   S = (I + G K)^-1,   M_kl = -W_k G_k [K S]_(j_k, i_l)
//! ```
//!
//! and the perturbed loop is `det(I - M Delta) = 0`. One channel alone (`Delta_k` only): the
//! scalar `M_kk = -W_k T_k` with the channel's complementary sensitivity
//!
//! ```text
//! T_k(jw) = G_k(jw) [K (I + G K)^-1]_(j_k, i_k)      (= G K / (1 + G K) for a single loop)
//! ```
//!
//! and, the nominal loop being stable, the small-gain theorem is necessary and sufficient for a
//! complex scalar: the loop is stable for every `||Delta_k|| <= 1` iff `||W_k T_k||_inf < 1`.
//! All four at once: stable for every such `Delta` iff `mu(M(jw)) < 1` at every frequency; the
//! bound used is the D-scaled largest singular value ([`mu::upper_bound`]), exact for up to
//! three channels and never optimistic. `1 / peak` is the margin: the factor by which every
//! weight could grow before some perturbation inside them destabilises the loop.
//!
//! **Nominal stability** is checked first ([`nyquist`]): a loop unstable without perturbation
//! has no robustness margin, whatever `||W T||` says.
//!
//! **Grid.** Logarithmic, [`Grid::default`]: 100 points per decade from 1e-4 to 1e4 rad/s (the
//! seed's loop crosses over near 0.1 rad/s, its servo low-pass is at 30 rad/s, a weight's
//! corners lie within the campaign's band). Points 2.3 % apart resolve a resonance of damping
//! down to about 0.01 (half-power width `2 zeta`); each curve's largest grid value is refined
//! by a golden-section search between its grid neighbours, so a peak's value and frequency do
//! not depend on the grid's phase. The nominal-stability count refines its own grid further.
//!
//! **What is left out.** The plant is its small-signal frequency response
//! ([`Plant::frequency_response`]: nonlinear effects such as saturation or backlash are not in
//! it; an operating point's linearisation is), with every `Delta = 0`. The digital controller's
//! sampling enters as the zero-order hold's `(1 - e^(-sT)) / (sT)` on its output (about a delay
//! of `T/2`), accurate well below the Nyquist frequency where any sensible loop crosses over.

pub mod mu;
pub mod nyquist;
pub mod perturbed;

pub use perturbed::Perturbation;

use crate::axis::Channel;
use crate::controller::CascadeParams;
use crate::effect::Binding;
use crate::model_file::{ModelError, ModelSpec};
use crate::plant::{Plant, DEFAULT_STEP};
use nalgebra::{DMatrix, Matrix2};
use num_complex::Complex64;

/// A 2×2 frequency response, `[output][input]` as `[[G11, G12], [G21, G22]]`.
pub type Response2 = Matrix2<Complex64>;

/// Index of a channel in [`Channel::ALL`] order (G11, G12, G21, G22).
pub fn channel_index(ch: Channel) -> usize {
    2 * ch.output.index() + ch.input.index()
}

/// A channel's multiplicative uncertainty weight `W(s) = k (s + z) / (s + p)` (seed section 6.4).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Weight {
    /// High-frequency gain, 1.
    pub k: f64,
    /// Zero, rad/s.
    pub z: f64,
    /// Pole, rad/s.
    pub p: f64,
}

impl Weight {
    pub fn at(&self, s: Complex64) -> Complex64 {
        self.k * (s + self.z) / (s + self.p)
    }

    pub fn response(&self, omega: f64) -> Complex64 {
        self.at(Complex64::new(0.0, omega))
    }
}

/// The weights of the four channels, in [`Channel::ALL`] order; `None` where a channel has no
/// uncertainty.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Weights(pub [Option<Weight>; 4]);

impl Weights {
    /// The `uncertainty` tables of a model file (a zero gain `k` counts as no weight).
    pub fn from_model(spec: &ModelSpec) -> Weights {
        let mut w = [None; 4];
        for ch in Channel::ALL {
            let b = Binding::Channel(ch);
            let v = |p: &str| spec.value(crate::EffectKind::Uncertainty, b, p);
            if let (Some(k), Some(z), Some(p)) = (v("k"), v("z"), v("p")) {
                if k > 0.0 {
                    w[channel_index(ch)] = Some(Weight { k, z, p });
                }
            }
        }
        Weights(w)
    }

    pub fn get(&self, ch: Channel) -> Option<Weight> {
        self.0[channel_index(ch)]
    }

    /// The channels that carry a weight, in [`Channel::ALL`] order.
    pub fn channels(&self) -> Vec<(Channel, Weight)> {
        Channel::ALL
            .into_iter()
            .filter_map(|ch| self.get(ch).map(|w| (ch, w)))
            .collect()
    }
}

/// A controller as the loop sees it: `K(s)` from the ZMP error (m) to the CoM reference (m), at
/// any `s` of the closed right half-plane (the nominal-stability count evaluates it off the
/// imaginary axis, around its poles at the origin).
pub trait LoopController {
    fn at(&self, s: Complex64) -> Response2;
    /// One line for reports: what the controller is.
    fn describe(&self) -> String;
}

/// The zero-order hold's `(1 - e^(-x)) / x`, `x = sT`.
fn hold(x: Complex64) -> Complex64 {
    if x.norm() < 1e-6 {
        1.0 - x / 2.0
    } else {
        (1.0 - (-x).exp()) / x
    }
}

/// The cascade controller of [`crate::controller`] (seed eqs. 28-29), both axes:
///
/// ```text
/// K(s) = diag(k(s), k(s)),   k(s) = e_s (m_t/m_r) l_t  K1/s  K2/(s + K2)  (1 - e^(-sT))/(sT)
/// ```
///
/// with `e_s` the error scale (units per metre) and `(m_t/m_r) l_t` the CoM per radian of trunk
/// (eq. 26). The angle limits are not in it (small signal).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CascadeLoop {
    pub params: CascadeParams,
    /// Controller sample period `T`, s (0: continuous).
    pub period: f64,
}

impl CascadeLoop {
    /// The seed's controller as the project runs it: [`CascadeParams::silo2`] at 100 Hz.
    pub fn seed() -> CascadeLoop {
        CascadeLoop {
            params: CascadeParams::silo2(),
            period: 0.01,
        }
    }

    /// The seed's controller with other gains.
    pub fn with_gains(k1: f64, k2: f64) -> CascadeLoop {
        let mut c = CascadeLoop::seed();
        c.params.k1 = k1;
        c.params.k2 = k2;
        c
    }

    /// Loop gain per integrator: ZMP error to CoM reference, `e_s (m_t/m_r) l_t K1`, 1/s.
    pub fn integral_gain(&self) -> f64 {
        self.params.error_scale * self.params.trunk_gain() * self.params.k1
    }
}

impl LoopController for CascadeLoop {
    fn at(&self, s: Complex64) -> Response2 {
        let p = &self.params;
        let k = self.integral_gain() * p.k2 / (s * (s + p.k2)) * hold(s * self.period);
        let zero = Complex64::new(0.0, 0.0);
        Matrix2::new(k, zero, zero, k)
    }

    fn describe(&self) -> String {
        format!(
            "cascade K1 = {}, K2 = {}, {:.4} m of CoM per unit of ZMP error, {} ms",
            self.params.k1,
            self.params.k2,
            self.params.error_scale * self.params.trunk_gain(),
            self.period * 1e3
        )
    }
}

/// Where the loop is evaluated (see the module docs for the choice).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    /// Lowest and highest frequency, rad/s.
    pub lo: f64,
    pub hi: f64,
    pub per_decade: usize,
}

impl Default for Grid {
    fn default() -> Grid {
        Grid {
            lo: 1e-4,
            hi: 1e4,
            per_decade: 100,
        }
    }
}

impl Grid {
    pub fn omegas(&self) -> Vec<f64> {
        let decades = (self.hi / self.lo).log10();
        let n = (decades * self.per_decade as f64).round().max(1.0) as usize;
        (0..=n)
            .map(|k| self.lo * 10f64.powf(decades * k as f64 / n as f64))
            .collect()
    }
}

/// `||W_k T_k||_inf` of one channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ChannelMargin {
    pub channel: Channel,
    pub weight: Weight,
    /// `max_w |W_k T_k|`; below 1: robustly stable against this channel's uncertainty.
    pub peak: f64,
    /// Where, rad/s.
    pub omega: f64,
    /// `W_k T_k` there.
    pub wt_at_peak: Complex64,
}

/// The structured margin: the peak over frequency of the `mu` upper bound.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StructuredMargin {
    pub peak: f64,
    /// Where it is tightest, rad/s.
    pub omega: f64,
}

/// The curves behind the margins, on the grid.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Curves {
    pub omega: Vec<f64>,
    /// `T_k(jw)` of every channel, [`Channel::ALL`] order.
    pub t: Vec<[Complex64; 4]>,
    /// The `mu` upper bound (NaN without weights).
    pub mu: Vec<f64>,
}

/// What the check found.
#[derive(Debug, Clone, PartialEq)]
pub struct RobustAnalysis {
    pub controller: String,
    /// Closed-loop poles in the right half-plane without perturbation; `None`: a pole on the
    /// imaginary axis.
    pub unstable_poles: Option<usize>,
    pub weights: Weights,
    /// One per weighted channel.
    pub channels: Vec<ChannelMargin>,
    /// `None` without any weight.
    pub structured: Option<StructuredMargin>,
    pub curves: Curves,
}

/// `T_k` of the four channels and `M` of the weighted ones at one frequency (`None` if
/// `I + G K` is singular there).
fn loop_at(
    g: &Response2,
    k: &Response2,
    weighted: &[(Channel, Weight)],
    omega: f64,
) -> Option<([Complex64; 4], DMatrix<Complex64>)> {
    let ks = k * (Matrix2::identity() + g * k).try_inverse()?;
    let mut t = [Complex64::new(0.0, 0.0); 4];
    for ch in Channel::ALL {
        let (i, j) = (ch.output.index(), ch.input.index());
        t[channel_index(ch)] = g[(i, j)] * ks[(j, i)];
    }
    let n = weighted.len();
    let m = DMatrix::from_fn(n, n, |a, b| {
        let (ca, wa) = weighted[a];
        let (ia, ja) = (ca.output.index(), ca.input.index());
        let ib = weighted[b].0.output.index();
        -wa.response(omega) * g[(ia, ja)] * ks[(ja, ib)]
    });
    Some((t, m))
}

/// Golden-section search for the maximum of `f` over `[lo, hi]` in `log w`; returns the best of
/// the search and `start` (a grid point inside).
fn refine_max(f: &mut dyn FnMut(f64) -> f64, lo: f64, hi: f64, start: (f64, f64)) -> (f64, f64) {
    let r = (5f64.sqrt() - 1.0) / 2.0;
    let (mut a, mut b) = (lo.ln(), hi.ln());
    let mut c = b - r * (b - a);
    let mut d = a + r * (b - a);
    let (mut fc, mut fd) = (f(c.exp()), f(d.exp()));
    let mut best = start;
    for _ in 0..60 {
        if (b - a).abs() < 1e-9 {
            break;
        }
        if fc > fd {
            b = d;
            d = c;
            fd = fc;
            c = b - r * (b - a);
            fc = f(c.exp());
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + r * (b - a);
            fd = f(d.exp());
        }
    }
    for (w, v) in [(c.exp(), fc), (d.exp(), fd)] {
        if v > best.1 {
            best = (w, v);
        }
    }
    best
}

/// The grid neighbours of index `k` (the search interval around a grid maximum).
fn bracket(omega: &[f64], k: usize) -> (f64, f64) {
    (
        omega[k.saturating_sub(1)],
        omega[(k + 1).min(omega.len() - 1)],
    )
}

fn argmax(v: impl Iterator<Item = f64>) -> Option<(usize, f64)> {
    v.enumerate()
        .filter(|(_, x)| x.is_finite())
        .fold(None, |best, (k, x)| match best {
            Some((_, b)) if b >= x => best,
            _ => Some((k, x)),
        })
}

/// The check: nominal stability, `||W_k T_k||_inf` per weighted channel and the structured
/// margin, for the plant `plant(w) = G(jw)` (stable) and the controller `ctrl`.
pub fn analyse(
    plant: &dyn Fn(f64) -> Response2,
    ctrl: &dyn LoopController,
    weights: &Weights,
    grid: &Grid,
) -> RobustAnalysis {
    let weighted = weights.channels();
    let at = |w: f64| {
        let g = plant(w);
        let k = ctrl.at(Complex64::new(0.0, w));
        loop_at(&g, &k, &weighted, w)
    };
    let omega = grid.omegas();
    let nan = Complex64::new(f64::NAN, f64::NAN);
    let mut curves = Curves {
        omega: omega.clone(),
        ..Curves::default()
    };
    let mut scaling: Option<Vec<f64>> = None;
    for &w in &omega {
        match at(w) {
            Some((t, m)) => {
                curves.t.push(t);
                if weighted.is_empty() {
                    curves.mu.push(f64::NAN);
                } else {
                    let b = mu::upper_bound(&m, scaling.as_deref());
                    scaling = Some(b.log_scaling);
                    curves.mu.push(b.value);
                }
            }
            None => {
                curves.t.push([nan; 4]);
                curves.mu.push(f64::NAN);
            }
        }
    }
    let mut channels = Vec::new();
    for &(ch, wt) in &weighted {
        let c = channel_index(ch);
        let mut f = |w: f64| match at(w) {
            Some((t, _)) => (wt.response(w) * t[c]).norm(),
            None => f64::NAN,
        };
        let values = (0..omega.len()).map(|k| (wt.response(omega[k]) * curves.t[k][c]).norm());
        if let Some((k, v)) = argmax(values) {
            let (lo, hi) = bracket(&omega, k);
            let (w, peak) = refine_max(&mut f, lo, hi, (omega[k], v));
            let wt_at_peak = at(w).map_or(nan, |(t, _)| wt.response(w) * t[c]);
            channels.push(ChannelMargin {
                channel: ch,
                weight: wt,
                peak,
                omega: w,
                wt_at_peak,
            });
        }
    }
    let structured = argmax(curves.mu.iter().copied()).map(|(k, v)| {
        let (lo, hi) = bracket(&omega, k);
        let mut scale: Option<Vec<f64>> = None;
        let mut f = |w: f64| match at(w) {
            Some((_, m)) => {
                let b = mu::upper_bound(&m, scale.as_deref());
                scale = Some(b.log_scaling);
                b.value
            }
            None => f64::NAN,
        };
        let (w, peak) = refine_max(&mut f, lo, hi, (omega[k], v));
        StructuredMargin { peak, omega: w }
    });
    RobustAnalysis {
        controller: ctrl.describe(),
        unstable_poles: nyquist::unstable_poles(plant, ctrl, grid),
        weights: *weights,
        channels,
        structured,
        curves,
    }
}

/// The check for a model file: its nominal plant (every `uncertainty` effect at `delta = 0`)
/// and its weights.
pub fn analyse_model(
    spec: &ModelSpec,
    ctrl: &dyn LoopController,
    grid: &Grid,
) -> Result<RobustAnalysis, ModelError> {
    let plant = Plant::new(&perturbed::nominal_spec(spec), DEFAULT_STEP)?;
    let response = |w: f64| {
        let g = plant.frequency_response(w);
        Matrix2::new(g[0][0], g[0][1], g[1][0], g[1][1])
    };
    Ok(analyse(&response, ctrl, &Weights::from_model(spec), grid))
}

impl RobustAnalysis {
    pub fn nominally_stable(&self) -> bool {
        self.unstable_poles == Some(0)
    }

    /// Stable for every perturbation inside the weights, all channels at once (by the bound).
    pub fn robustly_stable(&self) -> bool {
        self.nominally_stable() && self.structured.is_some_and(|s| s.peak < 1.0)
    }

    /// The channel with the largest `||W T||_inf`.
    pub fn tightest_channel(&self) -> Option<&ChannelMargin> {
        self.channels
            .iter()
            .max_by(|a, b| a.peak.total_cmp(&b.peak))
    }

    /// The smallest perturbation of one channel that puts a closed-loop pole on the imaginary
    /// axis, at that channel's tightest frequency `w*`: `1 + W T Delta = 0` there, so
    /// `Delta(jw*) = -1 / (W T)(jw*)`, `|Delta| = 1 / ||W T||_inf` (inside the weight exactly
    /// when the check fails). Realised as a stable all-pass of that gain (see [`Perturbation`]).
    pub fn critical_perturbation(&self, channel: Channel) -> Option<Perturbation> {
        let c = self.channels.iter().find(|c| c.channel == channel)?;
        Some(Perturbation::matching(
            channel,
            -1.0 / c.wt_at_peak,
            c.omega,
        ))
    }

    /// The verdict in one line (for `identify`, `loop` and `robust`).
    pub fn summary(&self) -> String {
        match self.unstable_poles {
            None => {
                return "the nominal closed loop has a pole on the imaginary axis: no margin".into()
            }
            Some(n) if n > 0 => {
                return format!(
                    "the nominal closed loop is unstable ({n} poles in the right half-plane): \
                     no margin"
                )
            }
            _ => {}
        }
        let (Some(s), Some(c)) = (self.structured, self.tightest_channel()) else {
            return "nominally stable; the model has no uncertainty weights".into();
        };
        format!(
            "mu <= {:.3} at {:.3} rad/s (margin {:.2}x the weights); tightest channel {}: \
             ||W T|| = {:.3} at {:.3} rad/s: {}",
            s.peak,
            s.omega,
            1.0 / s.peak,
            c.channel,
            c.peak,
            c.omega,
            if self.robustly_stable() {
                "robustly stable"
            } else {
                "NOT robustly stable"
            }
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cascade_loop_is_the_controllers_transfer_function() {
        let c = CascadeLoop {
            params: CascadeParams::silo2(),
            period: 0.0,
        };
        let s = Complex64::new(0.0, 0.3);
        let k = c.at(s)[(0, 0)];
        // e_s (m_t/m_r) l_t = 100 * 0.17 * 0.65 = 11.05; K1 K2 / (s (s + K2)).
        let expected = 11.05 * 0.014 * 0.2 / (s * (s + 0.2));
        assert!((k - expected).norm() < 1e-12 * expected.norm());
        assert_eq!(c.at(s)[(0, 1)], Complex64::new(0.0, 0.0));
        // The hold: |.| = sinc(wT/2), phase -wT/2.
        let h = hold(Complex64::new(0.0, 10.0 * 0.01));
        assert!((h.arg() + 0.05).abs() < 1e-12);
        assert!((h.norm() - (0.05f64).sin() / 0.05).abs() < 1e-12);
    }
}
