//! The one table of FMU variables: value references, names, causalities, units, descriptions,
//! start values and bounds. The FMI 2.0 and 3.0 shells dispatch value references through it and
//! the model descriptions are written from it, so the two cannot disagree.
//!
//! Value references: the fixed variables of a kind are numbered from 0 in table order; the
//! model-file parameters of the plant are `PARAM_VR_BASE + i`, `i` their index in
//! [`ModelSpec::parameters`] (canonical effect order, then parameter order), so they are
//! deterministic for a given model file.

use zmp_models::closed_loop::{com_for_zmp, StepExperiment};
use zmp_models::{ModelSpec, Plant, DEFAULT_STEP};

mod build;

/// First value reference of the model-file parameters of the plant.
pub const PARAM_VR_BASE: u32 = 100;

/// Which FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// The ZMP plant of the model file.
    Plant,
    /// The cascade ZMP controller.
    Controller,
    /// A trivial FMU with the plant's interface shape (2 inputs, 4 outputs) and no physics: the
    /// baseline of the FMPy overhead benchmark.
    Passthrough,
}

/// FMI version of a shell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum FmiVersion {
    /// FMI 2.0.
    V2,
    /// FMI 3.0.
    V3,
}

impl Kind {
    /// Every kind, in the order the FMUs are built.
    pub const ALL: [Kind; 3] = [Kind::Plant, Kind::Controller, Kind::Passthrough];

    /// The kind's short name (`plant`, `controller`, `passthrough`).
    pub fn name(self) -> &'static str {
        match self {
            Kind::Plant => "plant",
            Kind::Controller => "controller",
            Kind::Passthrough => "passthrough",
        }
    }

    /// The FMI model identifier: the shared library's and the `.fmu` file's base name.
    pub const fn model_identifier(self, fmi: FmiVersion) -> &'static str {
        match (self, fmi) {
            (Kind::Plant, FmiVersion::V2) => "zmp_plant",
            (Kind::Controller, FmiVersion::V2) => "zmp_controller",
            (Kind::Passthrough, FmiVersion::V2) => "zmp_passthrough",
            (Kind::Plant, FmiVersion::V3) => "zmp_plant_fmi3",
            (Kind::Controller, FmiVersion::V3) => "zmp_controller_fmi3",
            (Kind::Passthrough, FmiVersion::V3) => "zmp_passthrough_fmi3",
        }
    }

    /// The flavour string hashed into the GUID.
    pub fn flavour(self, fmi: FmiVersion) -> String {
        let v = match fmi {
            FmiVersion::V2 => "fmi2",
            FmiVersion::V3 => "fmi3",
        };
        format!("{v}-{}", self.name())
    }

    /// The GUID (FMI 2.0) or instantiation token (FMI 3.0) for the model file text `model_toml`.
    pub fn guid(self, fmi: FmiVersion, model_toml: &str) -> String {
        crate::guid::guid(&self.flavour(fmi), model_toml)
    }

    /// The model description's `description` of the kind's FMU.
    pub fn description(self) -> &'static str {
        match self {
            Kind::Plant => {
                "2x2 ZMP plant of a biped (zmp-model/1 file): CoM references in, ZMP and CoM out. \
                 Fixed internal step h; the inputs set at a communication point are held over \
                 the step (zero-order hold), or follow their first derivatives when set \
                 (first-order hold)."
            }
            Kind::Controller => {
                "Cascade ZMP direct-feedback controller C1 = K1/s, C2 = K2/(s+K2) per axis, \
                 sampled every h: ZMP reference and measured ZMP in, CoM references out."
            }
            Kind::Passthrough => {
                "Trivial pass-through FMU (y1 = y3 = u1, y2 = y4 = u2): baseline for the FMU \
                 overhead benchmarks."
            }
        }
    }

    /// `(stop time, communication step)` of the DefaultExperiment, s.
    pub fn default_experiment(self) -> (f64, f64) {
        match self {
            Kind::Plant => (10.0, 1e-3),
            Kind::Controller => (160.0, 1e-2),
            Kind::Passthrough => (1.0, 1e-3),
        }
    }
}

/// The FMI causality of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Causality {
    /// Set by the importer before or between steps; the FMU never changes it.
    Parameter,
    /// Set by the importer at communication points; drives the step.
    Input,
    /// Computed by the FMU; read by the importer.
    Output,
}

impl Causality {
    /// The causality as written in modelDescription.xml.
    pub fn as_str(self) -> &'static str {
        match self {
            Causality::Parameter => "parameter",
            Causality::Input => "input",
            Causality::Output => "output",
        }
    }
}

/// The FMI variability of a variable.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Variability {
    /// Set only before initialisation ends.
    Fixed,
    /// Changes only at communication points (sampled signals).
    Discrete,
    /// Changes continuously over a step.
    Continuous,
}

impl Variability {
    /// The variability as written in modelDescription.xml.
    pub fn as_str(self) -> &'static str {
        match self {
            Variability::Fixed => "fixed",
            Variability::Discrete => "discrete",
            Variability::Continuous => "continuous",
        }
    }
}

/// Parameters of the controller FMU.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CtrlParam {
    /// Integral gain of C1 = K1/s, rad/s (trunk angle rate per error unit).
    K1,
    /// Corner frequency of the lag C2 = K2/(s + K2), rad/s.
    K2,
    /// Error units per metre of ZMP error, 1/m (100: centimetres).
    ErrorScale,
    /// Trunk mass over robot mass m_t/m_r, dimensionless.
    MassRatio,
    /// Trunk length l_t, m.
    TrunkLength,
    /// Lower trunk angle limit (anti-windup clamp), rad.
    ThetaMin,
    /// Upper trunk angle limit (anti-windup clamp), rad.
    ThetaMax,
    /// Lateral (x) CoM reference at zero trunk angle, m.
    OffsetX,
    /// Sagittal (y) CoM reference at zero trunk angle, m.
    OffsetY,
}

/// What a variable is, for dispatch.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Input number `i` of the kind.
    Input(usize),
    /// Output number `i` of the kind.
    Output(usize),
    /// The fixed internal step (plant) or sample period (controller), s.
    Step,
    /// Model-file parameter number `i` of [`ModelSpec::parameters`].
    ModelParam(usize),
    /// A parameter of the controller FMU.
    Controller(CtrlParam),
}

/// One variable of an FMU.
#[derive(Debug, Clone, PartialEq)]
pub struct Var {
    /// The variable's name in modelDescription.xml.
    pub name: String,
    /// Value reference: the handle the importer gets and sets it by.
    pub vr: u32,
    /// Who sets it: the importer (parameter, input) or the FMU (output).
    pub causality: Causality,
    /// When it may change.
    pub variability: Variability,
    /// Its unit, as written in the model description ("1": dimensionless).
    pub unit: &'static str,
    /// What it is, for the importer's user.
    pub description: String,
    /// Start value: written to the model description for parameters and inputs; for outputs
    /// the value at rest before initialisation.
    pub start: f64,
    /// Inclusive lower bound accepted by the setter (infinite: none).
    pub min: f64,
    /// Inclusive upper bound accepted by the setter (infinite: none).
    pub max: f64,
    /// The value must be a whole number (random seeds).
    pub whole: bool,
    /// What the variable is for the shells, for dispatch.
    pub role: Role,
}

impl Var {
    /// Checks a value the importer wants to set.
    pub fn check(&self, v: f64) -> Result<(), String> {
        if !v.is_finite() {
            return Err(format!("{} = {v}: not a finite number", self.name));
        }
        if v < self.min || v > self.max {
            return Err(format!(
                "{} = {v} is out of bounds [{}, {}] {} ({})",
                self.name, self.min, self.max, self.unit, self.description
            ));
        }
        if self.whole && v.fract() != 0.0 {
            return Err(format!("{} = {v} must be a whole number", self.name));
        }
        Ok(())
    }

    /// Whether the variable has a finite lower bound (written as `min`).
    pub fn has_min(&self) -> bool {
        self.min.is_finite()
    }

    /// Whether the variable has a finite upper bound (written as `max`).
    pub fn has_max(&self) -> bool {
        self.max.is_finite()
    }
}

/// The variables of one FMU kind for one model.
#[derive(Debug, Clone)]
pub struct VarTable {
    /// The FMU the table belongs to.
    pub kind: Kind,
    /// The variables: the kind's fixed ones, then the model-file parameters.
    pub vars: Vec<Var>,
    /// Variables `0..n_fixed` have value reference = index.
    n_fixed: usize,
    /// Number of inputs of the kind.
    pub n_inputs: usize,
    /// Number of outputs of the kind.
    pub n_outputs: usize,
}

/// The operating point the FMUs start at by default: the seed experiment's initial ZMP
/// reference (section 6.6), with the plant at rest there and the controller's trunk upright.
pub fn initial_zmp() -> [f64; 2] {
    StepExperiment::silo2().zmp_ref_before
}

/// CoM reference holding the plant of `spec` at rest with its ZMP at [`initial_zmp`], and the
/// plant's outputs there.
///
/// The operating point of `operating_point_dependence` is the CoM reference itself (the
/// plant FMU takes it from its inputs when initialisation ends), so the rest point solves
/// `a(c) c = zmp`: found by fixed-point iteration from the origin's `a`.
pub fn initial_operating_point(
    spec: &ModelSpec,
) -> Result<([f64; 2], zmp_models::PlantOutput), String> {
    let mut plant = Plant::new(spec, DEFAULT_STEP).map_err(|e| e.to_string())?;
    let mut com0 = com_for_zmp(&plant, initial_zmp());
    for _ in 0..100 {
        plant.set_operating_point(com0);
        let next = com_for_zmp(&plant, initial_zmp());
        let moved = (next[0] - com0[0]).abs() + (next[1] - com0[1]).abs();
        com0 = next;
        if moved <= 1e-15 {
            break;
        }
    }
    if !(com0[0].is_finite() && com0[1].is_finite()) {
        return Err(format!(
            "no CoM reference holds the ZMP at {:?} m with this model's pendulum and \
             operating_point_dependence",
            initial_zmp()
        ));
    }
    plant.set_operating_point(com0);
    let out = plant.reset(com0);
    Ok((com0, out))
}

impl VarTable {
    /// Index in [`VarTable::vars`] of value reference `vr`.
    #[inline]
    pub fn index_of(&self, vr: u32) -> Option<usize> {
        let v = vr as usize;
        if v < self.n_fixed {
            Some(v)
        } else if vr >= PARAM_VR_BASE {
            let i = self.n_fixed + (vr - PARAM_VR_BASE) as usize;
            (i < self.vars.len()).then_some(i)
        } else {
            None
        }
    }

    /// The variable called `name`, if any.
    pub fn by_name(&self, name: &str) -> Option<&Var> {
        self.vars.iter().find(|v| v.name == name)
    }

    /// Every unit used, sorted, once.
    pub fn units(&self) -> Vec<&'static str> {
        let mut u: Vec<&'static str> = self.vars.iter().map(|v| v.unit).collect();
        u.sort_unstable();
        u.dedup();
        u
    }

    /// Whether the FMU uses input derivatives (FMI 2.0 `canInterpolateInputs`): the plant
    /// follows first derivatives over a communication step (first-order hold).
    pub fn interpolates_inputs(&self) -> bool {
        self.kind == Kind::Plant
    }

    /// Whether the outputs depend directly on the inputs at the same communication point.
    pub fn direct_feedthrough(&self) -> bool {
        matches!(self.kind, Kind::Controller | Kind::Passthrough)
    }
}
