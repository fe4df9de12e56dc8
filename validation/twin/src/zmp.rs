//! The ZMP of a twin, three ways: from corner load cells (what the robot measures), from
//! MuJoCo's own contact forces (the engine's centre of pressure), and from the robot's momentum
//! (Newton-Euler of the whole body, and its cart-table simplification `x - z/g x''`).
//!
//! Shared by the twins: any model whose feet carry `touch` sensors on corner sites can use
//! [`LoadCells`] and [`ZmpSensor`].
//!
//! Frames: world frame, floor at `z = 0`; the ZMP is a point of the floor, `[x, y]` in m.

use crate::mj::TwinError;
use mujoco_rs::prelude::*;
use mujoco_rs::wrappers::mj_model::traits::ModelType;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Standard gravity used by the momentum ZMP, m/s² (MuJoCo's default `gravity`).
pub const GRAVITY: f64 = 9.81;

/// Total normal load below which there is no ZMP (the robot is in the air), N.
pub const MIN_LOAD_N: f64 = 1.0;

/// Touch sensors on sole-corner sites: the twin of a foot's load cells.
#[derive(Debug, Clone)]
pub struct LoadCells {
    /// `(sensordata address, site id)` per cell.
    cells: Vec<(usize, usize)>,
    /// Names of the cells, in sensor order.
    pub names: Vec<String>,
}

/// One reading of every cell.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CellReading<const N: usize> {
    /// Normal force of each cell, N.
    pub force: [f64; N],
    /// Floor-plane position of each cell, m.
    pub position: [[f64; 2]; N],
}

impl LoadCells {
    /// The `touch` sensors named `names`; each must be a touch sensor attached to a site.
    pub fn find(model: &MjModel, names: &[&str], file: &str) -> Result<LoadCells, TwinError> {
        let err = |message: String| TwinError::Model {
            path: file.into(),
            message,
        };
        let mut cells = Vec::with_capacity(names.len());
        for name in names {
            let id = model
                .name_to_id(MjtObjBase::mjOBJ_SENSOR, name)
                .ok_or_else(|| err(format!("no sensor named '{name}' (a touch sensor)")))?;
            if model.sensor_type()[id] != MjtSensor::mjSENS_TOUCH {
                return Err(err(format!("sensor '{name}' is not a touch sensor")));
            }
            if model.sensor_objtype()[id] != MjtObjBase::mjOBJ_SITE {
                return Err(err(format!("sensor '{name}' is not attached to a site")));
            }
            let adr = usize::try_from(model.sensor_adr()[id])
                .map_err(|_| err(format!("sensor '{name}' has no data address")))?;
            let site = usize::try_from(model.sensor_objid()[id])
                .map_err(|_| err(format!("sensor '{name}' has no site")))?;
            cells.push((adr, site));
        }
        Ok(LoadCells {
            cells,
            names: names.iter().map(|s| s.to_string()).collect(),
        })
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether there are no cells.
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Forces and positions of the cells (`N` must be their number; checked).
    pub fn read<const N: usize, M: ModelType>(&self, data: &MjData<M>) -> CellReading<N> {
        assert_eq!(N, self.cells.len(), "LoadCells::read: N is the cell count");
        let sd = data.sensordata();
        let sp = data.site_xpos();
        let mut r = CellReading {
            force: [0.0; N],
            position: [[0.0; 2]; N],
        };
        for (k, &(adr, site)) in self.cells.iter().enumerate() {
            r.force[k] = sd[adr];
            r.position[k] = [sp[site][0], sp[site][1]];
        }
        r
    }
}

impl<const N: usize> Default for CellReading<N> {
    fn default() -> Self {
        CellReading {
            force: [0.0; N],
            position: [[0.0; 2]; N],
        }
    }
}

impl<const N: usize> CellReading<N> {
    /// Force-weighted mean of the cell positions; `None` below [`MIN_LOAD_N`].
    pub fn zmp(&self) -> Option<[f64; 2]> {
        let total: f64 = self.force.iter().sum();
        if total < MIN_LOAD_N || !total.is_finite() {
            return None;
        }
        let mut p = [0.0; 2];
        for k in 0..N {
            p[0] += self.force[k] * self.position[k][0];
            p[1] += self.force[k] * self.position[k][1];
        }
        Some([p[0] / total, p[1] / total])
    }

    /// The cells' total normal force, N.
    pub fn total(&self) -> f64 {
        self.force.iter().sum()
    }
}

/// What the ZMP measurement adds to the truth: white force noise on every cell, a resolution
/// of the ZMP output, and a pure delay.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ZmpSensorSpec {
    /// Standard deviation of each cell's white force noise, N.
    pub force_noise_std: f64,
    /// Resolution of the ZMP output, m (0: none).
    pub quantisation: f64,
    /// Delay of the ZMP output, s (rounded to whole physics steps).
    pub delay: f64,
    /// Noise seed.
    pub seed: u64,
}

impl ZmpSensorSpec {
    /// The campaign's sensor: 0.5 N per cell (about 1 % of a cell's 59 N share of SILO2's
    /// weight), 0.1 mm resolution, no delay.
    pub fn silo2() -> ZmpSensorSpec {
        ZmpSensorSpec {
            force_noise_std: 0.5,
            quantisation: 1e-4,
            delay: 0.0,
            seed: 1,
        }
    }

    /// One line for reports and `campaign.toml`.
    pub fn describe(&self) -> String {
        format!(
            "ZMP from the 8 sole-corner load cells: force noise {} N per cell, resolution {} mm, \
             delay {} ms",
            self.force_noise_std,
            self.quantisation * 1e3,
            self.delay * 1e3
        )
    }
}

/// The measured ZMP: cell readings through the sensor spec. Call [`ZmpSensor::push`] after every
/// physics step and [`ZmpSensor::sample`] when a sample is taken.
#[derive(Debug, Clone)]
pub struct ZmpSensor<const N: usize> {
    spec: ZmpSensorSpec,
    /// Ring of the last `delay_steps + 1` readings.
    ring: Vec<CellReading<N>>,
    head: usize,
    filled: usize,
    rng: ChaCha8Rng,
    noise: Option<Normal<f64>>,
}

impl<const N: usize> ZmpSensor<N> {
    /// `step` is the physics step, s; `stream` separates the noise of independent runs that
    /// share a seed (e.g. the record index).
    pub fn new(spec: ZmpSensorSpec, step: f64, stream: u64) -> Result<ZmpSensor<N>, String> {
        if !(spec.force_noise_std >= 0.0 && spec.force_noise_std.is_finite()) {
            return Err(format!(
                "force_noise_std must be >= 0, got {}",
                spec.force_noise_std
            ));
        }
        if !(spec.quantisation >= 0.0 && spec.quantisation.is_finite()) {
            return Err(format!(
                "quantisation must be >= 0, got {}",
                spec.quantisation
            ));
        }
        if !(spec.delay >= 0.0 && spec.delay <= 1.0) {
            return Err(format!("delay must be in [0, 1] s, got {}", spec.delay));
        }
        let delay_steps = (spec.delay / step).round() as usize;
        let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
        rng.set_stream(stream);
        Ok(ZmpSensor {
            spec,
            ring: vec![CellReading::default(); delay_steps + 1],
            head: 0,
            filled: 0,
            rng,
            noise: (spec.force_noise_std > 0.0)
                .then(|| Normal::new(0.0, spec.force_noise_std).expect("checked")),
        })
    }

    /// Stores the current readings.
    #[inline]
    pub fn push(&mut self, r: CellReading<N>) {
        self.head = (self.head + 1) % self.ring.len();
        self.ring[self.head] = r;
        self.filled = (self.filled + 1).min(self.ring.len());
    }

    /// The delayed, noisy, quantised ZMP (the oldest reading held until the delay line fills).
    pub fn sample(&mut self) -> Option<[f64; 2]> {
        if self.filled == 0 {
            return None;
        }
        let oldest = if self.filled < self.ring.len() {
            (self.head + self.ring.len() + 1 - self.filled) % self.ring.len()
        } else {
            (self.head + 1) % self.ring.len()
        };
        let mut r = self.ring[oldest];
        if let Some(n) = self.noise {
            for f in &mut r.force {
                *f += n.sample(&mut self.rng);
            }
        }
        let z = r.zmp()?;
        Some(z.map(|v| quantise(v, self.spec.quantisation)))
    }

    /// The sensor's specification.
    pub fn spec(&self) -> &ZmpSensorSpec {
        &self.spec
    }
}

/// `v` rounded to a multiple of `q` (unchanged for `q = 0`).
pub fn quantise(v: f64, q: f64) -> f64 {
    if q > 0.0 {
        (v / q).round() * q
    } else {
        v
    }
}

/// MuJoCo's centre of pressure: the normal forces of the active contacts between `floor_geom`
/// and anything else, weighted by the contact positions (`mj_contactForce`). `None` without
/// load.
pub fn contact_cop<M: ModelType>(data: &MjData<M>, floor_geom: usize) -> Option<[f64; 2]> {
    let ncon = usize::try_from(data.ncon()).unwrap_or(0);
    let contacts = data.contact();
    let mut total = 0.0;
    let mut p = [0.0; 2];
    for (i, c) in contacts.iter().enumerate().take(ncon) {
        let g1 = usize::try_from(c.geom[0]).ok();
        let g2 = usize::try_from(c.geom[1]).ok();
        if g1 != Some(floor_geom) && g2 != Some(floor_geom) {
            continue;
        }
        // Contacts beyond the margin are in the list but carry no force.
        let Ok(f) = data.try_contact_force(i) else {
            continue;
        };
        // f[0] is the normal force in the contact frame (the floor's normal is +z).
        let fz = f[0];
        total += fz;
        p[0] += fz * c.pos[0];
        p[1] += fz * c.pos[1];
    }
    (total >= MIN_LOAD_N).then(|| [p[0] / total, p[1] / total])
}

/// Momentum of the whole robot at one instant (MuJoCo's subtree quantities of its root body).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Momentum {
    /// Centre of mass, m.
    pub com: [f64; 3],
    /// CoM velocity, m/s.
    pub com_vel: [f64; 3],
    /// Angular momentum about the CoM, kg m²/s.
    pub angmom: [f64; 3],
}

/// Reads [`Momentum`] of the subtree of `root_body` (calls `mj_subtreeVel`).
pub fn momentum<M: ModelType>(data: &mut MjData<M>, root_body: usize) -> Momentum {
    data.subtree_vel();
    Momentum {
        com: data.subtree_com()[root_body],
        com_vel: data.subtree_linvel()[root_body],
        angmom: data.subtree_angmom()[root_body],
    }
}

/// The exact ZMP of a body of mass `mass` from its CoM `c`, CoM acceleration `a` and the rate of
/// its angular momentum about the CoM `ldot` (Newton-Euler on the whole robot, floor at z = 0):
/// `p_x = x - (z a_x + Ldot_y/m)/(g + a_z)`, `p_y = y - (z a_y - Ldot_x/m)/(g + a_z)`.
pub fn momentum_zmp(mass: f64, c: [f64; 3], a: [f64; 3], ldot: [f64; 3]) -> [f64; 2] {
    let gz = GRAVITY + a[2];
    [
        c[0] - (c[2] * a[0] + ldot[1] / mass) / gz,
        c[1] - (c[2] * a[1] - ldot[0] / mass) / gz,
    ]
}

/// The seed's cart-table ZMP (eqs. 6-7 with `z''` = 0): `x - z/g x''`.
pub fn cart_table_zmp(c: [f64; 3], a: [f64; 3]) -> [f64; 2] {
    [c[0] - c[2] / GRAVITY * a[0], c[1] - c[2] / GRAVITY * a[1]]
}

/// Central differences of a uniformly sampled 3-vector series (one-sided at the ends).
pub fn derivative3(v: &[[f64; 3]], dt: f64) -> Vec<[f64; 3]> {
    let n = v.len();
    (0..n)
        .map(|k| {
            let (lo, hi) = (k.saturating_sub(1), (k + 1).min(n - 1));
            let span = (hi - lo) as f64 * dt;
            if span == 0.0 {
                return [0.0; 3];
            }
            [0, 1, 2].map(|i| (v[hi][i] - v[lo][i]) / span)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zmp_is_the_force_weighted_mean() {
        let r = CellReading::<4> {
            force: [10.0, 30.0, 0.0, 0.0],
            position: [[0.0, 0.0], [0.1, 0.2], [5.0, 5.0], [-5.0, 5.0]],
        };
        let z = r.zmp().unwrap();
        assert!((z[0] - 0.075).abs() < 1e-15 && (z[1] - 0.15).abs() < 1e-15);
        let none = CellReading::<4>::default();
        assert!(none.zmp().is_none());
    }

    #[test]
    fn the_sensor_delays_by_whole_steps_and_quantises() {
        let spec = ZmpSensorSpec {
            force_noise_std: 0.0,
            quantisation: 1e-3,
            delay: 0.003,
            seed: 0,
        };
        let mut s = ZmpSensor::<1>::new(spec, 0.001, 0).unwrap();
        let mut out = Vec::new();
        for k in 0..6 {
            s.push(CellReading {
                force: [10.0],
                position: [[0.0101 * k as f64, 0.0]],
            });
            out.push(s.sample().unwrap()[0]);
        }
        // Until the line is full the oldest reading (k = 0) is held; then k - 3, rounded to mm.
        assert_eq!(out, vec![0.0, 0.0, 0.0, 0.0, 0.010, 0.020]);
        assert!(ZmpSensor::<1>::new(
            ZmpSensorSpec {
                delay: -1.0,
                ..spec
            },
            0.001,
            0
        )
        .is_err());
    }

    #[test]
    fn momentum_zmp_reduces_to_the_cart_table_without_rotation() {
        let c = [0.01, -0.02, 0.8];
        let a = [0.3, -0.1, 0.0];
        let p = momentum_zmp(48.0, c, a, [0.0; 3]);
        let q = cart_table_zmp(c, a);
        assert!((p[0] - q[0]).abs() < 1e-15 && (p[1] - q[1]).abs() < 1e-15);
        // A positive rate of angular momentum about +y (tipping towards +x) pulls the ZMP to -x.
        let r = momentum_zmp(48.0, c, [0.0; 3], [0.0, 4.8, 0.0]);
        assert!((r[0] - (0.01 - 0.1 / GRAVITY)).abs() < 1e-12);
    }
}
