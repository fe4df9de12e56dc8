//! The table of each FMU kind as data: a constant table of its fixed variables (inputs,
//! outputs, step, controller parameters) with their units, descriptions, start sources and
//! bounds, as Reference-FMUs keep theirs in `config.h`; the builder walks it, then appends the
//! plant's model-file parameters.

use super::{
    initial_operating_point, initial_zmp, Causality, CtrlParam, Kind, Role, Var, VarTable,
    Variability, PARAM_VR_BASE,
};
use zmp_models::closed_loop::StepExperiment;
use zmp_models::controller::CascadeParams;
use zmp_models::{ModelSpec, PlantOutput, DEFAULT_STEP};
// The tables name variants bare, one column per field.
use CtrlParam::*;
use Role::{Controller as Ctrl, Input, Output, Step};
use Start::*;
use Variability::{Continuous, Discrete, Fixed};

/// Where a fixed variable's start value comes from.
#[derive(Debug, Clone, Copy)]
enum Start {
    /// A constant, in the variable's unit.
    Value(f64),
    /// The plant's default internal step [`DEFAULT_STEP`], s.
    PlantStep,
    /// The seed experiment's controller sample period, s.
    ControllerPeriod,
    /// Axis `i` (0: x, 1: y) of the initial ZMP reference ([`initial_zmp`]), m.
    ZmpRef(usize),
    /// Axis `i` of the CoM reference holding the plant at rest with its ZMP at the initial
    /// ZMP reference ([`initial_operating_point`]), m.
    RestComRef(usize),
    /// Axis `i` of the plant's measured ZMP at that rest point, m.
    RestZmp(usize),
    /// Axis `i` of the plant's CoM at that rest point, m.
    RestCom(usize),
    /// A parameter of the seed's cascade controller ([`CascadeParams::silo2`]).
    Seed(fn(&CascadeParams) -> f64),
}

/// One row of a kind's constant table: a variable whose value reference is its row number.
struct Row {
    name: &'static str,
    /// What the variable is for the shells; its causality follows from it.
    role: Role,
    variability: Variability,
    unit: &'static str,
    start: Start,
    /// Inclusive bounds accepted by the setter.
    bounds: (f64, f64),
    description: &'static str,
}

/// A row of the table (keeps the tables one column per field).
const fn row(
    name: &'static str,
    role: Role,
    variability: Variability,
    unit: &'static str,
    start: Start,
    bounds: (f64, f64),
    description: &'static str,
) -> Row {
    Row {
        name,
        role,
        variability,
        unit,
        start,
        bounds,
        description,
    }
}

/// No bounds.
const FREE: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

/// The plant: CoM references in, measured ZMP and CoM out, the fixed internal step.
#[rustfmt::skip]
const PLANT: &[Row] = &[
    //   name     role       variability unit start          bounds
    row("x_cr",  Input(0),  Continuous, "m", RestComRef(0), FREE,
        "CoM reference, lateral (x); held over each communication step unless its \
         derivative is set; its value when initialisation ends is the operating \
         point x of operating_point_dependence"),
    row("y_cr",  Input(1),  Continuous, "m", RestComRef(1), FREE,
        "CoM reference, sagittal (y); held over each communication step unless its \
         derivative is set; its value when initialisation ends is the operating \
         point y of operating_point_dependence"),
    row("zmp_x", Output(0), Continuous, "m", RestZmp(0),    FREE, "measured ZMP, lateral (x)"),
    row("zmp_y", Output(1), Continuous, "m", RestZmp(1),    FREE, "measured ZMP, sagittal (y)"),
    row("x_c",   Output(2), Continuous, "m", RestCom(0),    FREE, "CoM position, lateral (x)"),
    row("y_c",   Output(3), Continuous, "m", RestCom(1),    FREE, "CoM position, sagittal (y)"),
    row("h",     Step,      Fixed,      "s", PlantStep,     (1e-6, 0.1),
        "fixed internal step of the plant; the internal time grid is start + n h"),
];

/// The cascade controller: ZMP reference and measured ZMP in, CoM and trunk angle references
/// out, the sample period and the controller's parameters (the seed's by default).
#[rustfmt::skip]
const CONTROLLER: &[Row] = &[
    //   name            role               variability unit     start
    //   bounds          description
    row("zmp_ref_x",    Input(0),          Continuous, "m",     ZmpRef(0),
        FREE,           "ZMP reference, lateral (x)"),
    row("zmp_ref_y",    Input(1),          Continuous, "m",     ZmpRef(1),
        FREE,           "ZMP reference, sagittal (y)"),
    row("zmp_x",        Input(2),          Continuous, "m",     RestZmp(0),
        FREE,           "measured ZMP, lateral (x)"),
    row("zmp_y",        Input(3),          Continuous, "m",     RestZmp(1),
        FREE,           "measured ZMP, sagittal (y)"),
    row("x_cr",         Output(0),         Discrete,   "m",     RestComRef(0),
        FREE,           "CoM reference, lateral (x): com_offset_x + (m_t/m_r) l_t theta_x"),
    row("y_cr",         Output(1),         Discrete,   "m",     RestComRef(1),
        FREE,           "CoM reference, sagittal (y): com_offset_y + (m_t/m_r) l_t theta_y"),
    row("theta_x",      Output(2),         Discrete,   "rad",   Value(0.0),
        FREE,           "trunk angle reference, lateral (x)"),
    row("theta_y",      Output(3),         Discrete,   "rad",   Value(0.0),
        FREE,           "trunk angle reference, sagittal (y)"),
    row("h",            Step,              Fixed,      "s",     ControllerPeriod,
        (1e-6, 10.0),   "sample period; samples at start + n h"),
    row("K1",           Ctrl(K1),          Fixed,      "rad/s", Seed(|p| p.k1),
        (0.0, 1e3),     "integral gain of C1 = K1/s (trunk angle rate per error unit)"),
    row("K2",           Ctrl(K2),          Fixed,      "rad/s", Seed(|p| p.k2),
        (0.0, 1e4),     "corner of the lag C2 = K2/(s + K2)"),
    row("error_scale",  Ctrl(ErrorScale),  Fixed,      "1/m",   Seed(|p| p.error_scale),
        (1e-6, 1e6),    "error units per metre of ZMP error (100: centimetres)"),
    row("mass_ratio",   Ctrl(MassRatio),   Fixed,      "1",     Seed(|p| p.mass_ratio),
        (1e-6, 1.0),    "trunk mass over robot mass m_t/m_r"),
    row("trunk_length", Ctrl(TrunkLength), Fixed,      "m",     Seed(|p| p.trunk_length),
        (1e-6, 100.0),  "trunk length l_t"),
    row("theta_min",    Ctrl(ThetaMin),    Fixed,      "rad",   Seed(|p| p.theta_min),
        (-3.2, 3.2),    "lower trunk angle limit (anti-windup clamp)"),
    row("theta_max",    Ctrl(ThetaMax),    Fixed,      "rad",   Seed(|p| p.theta_max),
        (-3.2, 3.2),    "upper trunk angle limit (anti-windup clamp)"),
    row("com_offset_x", Ctrl(OffsetX),     Fixed,      "m",     RestComRef(0),
        (-10.0, 10.0),  "CoM reference at zero trunk angle, lateral (x); the controller starts there"),
    row("com_offset_y", Ctrl(OffsetY),     Fixed,      "m",     RestComRef(1),
        (-10.0, 10.0),  "CoM reference at zero trunk angle, sagittal (y); the controller starts there"),
];

/// The pass-through: the plant's interface shape (2 inputs, 4 outputs), no physics.
#[rustfmt::skip]
const PASSTHROUGH: &[Row] = &[
    //   name  role       variability unit start       bounds description
    row("u1", Input(0),  Continuous, "1", Value(0.0), FREE,  "input 1"),
    row("u2", Input(1),  Continuous, "1", Value(0.0), FREE,  "input 2"),
    row("y1", Output(0), Continuous, "1", Value(0.0), FREE,  "u1"),
    row("y2", Output(1), Continuous, "1", Value(0.0), FREE,  "u2"),
    row("y3", Output(2), Continuous, "1", Value(0.0), FREE,  "u1"),
    row("y4", Output(3), Continuous, "1", Value(0.0), FREE,  "u2"),
];

/// The constant table of `kind`.
fn fixed_table(kind: Kind) -> &'static [Row] {
    match kind {
        Kind::Plant => PLANT,
        Kind::Controller => CONTROLLER,
        Kind::Passthrough => PASSTHROUGH,
    }
}

impl Role {
    /// The FMI causality of a fixed variable in this role.
    fn causality(self) -> Causality {
        match self {
            Role::Input(_) => Causality::Input,
            Role::Output(_) => Causality::Output,
            Role::Step | Role::ModelParam(_) | Role::Controller(_) => Causality::Parameter,
        }
    }
}

/// The CoM reference that holds the plant at rest at the initial ZMP reference, and the
/// plant's outputs there.
type Rest = ([f64; 2], PlantOutput);

/// What start values are computed from: the model, and its rest point once a start needs it
/// (the pass-through never builds a plant).
struct Origin<'a> {
    spec: &'a ModelSpec,
    rest: Option<Rest>,
}

impl Origin<'_> {
    fn rest(&mut self) -> Result<Rest, String> {
        let rest = match self.rest.take() {
            Some(r) => r,
            None => initial_operating_point(self.spec)?,
        };
        Ok(*self.rest.insert(rest))
    }

    /// The start value `start` stands for.
    fn start(&mut self, start: Start) -> Result<f64, String> {
        Ok(match start {
            Value(v) => v,
            PlantStep => DEFAULT_STEP,
            ControllerPeriod => StepExperiment::silo2().controller_period,
            ZmpRef(i) => initial_zmp()[i],
            RestComRef(i) => self.rest()?.0[i],
            RestZmp(i) => self.rest()?.1.zmp[i],
            RestCom(i) => self.rest()?.1.com[i],
            Seed(get) => get(&CascadeParams::silo2()),
        })
    }
}

/// The plant's model-file parameters as variables, numbered from [`PARAM_VR_BASE`].
fn model_parameters(spec: &ModelSpec) -> impl Iterator<Item = Var> + '_ {
    spec.parameters().into_iter().enumerate().map(|(i, p)| {
        let title = spec.effects[p.effect].info.title;
        Var {
            name: p.key.clone(),
            vr: PARAM_VR_BASE + i as u32,
            causality: Causality::Parameter,
            variability: Variability::Fixed,
            unit: p.spec.unit,
            description: format!("{title}: {}", p.spec.doc),
            start: p.value,
            min: p.spec.min,
            max: p.spec.max,
            whole: p.spec.whole,
            role: Role::ModelParam(i),
        }
    })
}

impl VarTable {
    /// The table of `kind` for the model `spec`: the kind's constant table, its start values
    /// resolved for `spec`, then (plant) the model file's parameters.
    pub fn new(kind: Kind, spec: &ModelSpec) -> Result<VarTable, String> {
        let table = fixed_table(kind);
        assert!((table.len() as u32) < PARAM_VR_BASE);
        let mut origin = Origin { spec, rest: None };
        let mut vars = Vec::with_capacity(table.len());
        for (vr, row) in (0u32..).zip(table) {
            vars.push(Var {
                name: row.name.to_string(),
                vr,
                causality: row.role.causality(),
                variability: row.variability,
                unit: row.unit,
                description: row.description.to_string(),
                start: origin.start(row.start)?,
                min: row.bounds.0,
                max: row.bounds.1,
                whole: false,
                role: row.role,
            });
        }
        if kind == Kind::Plant {
            vars.extend(model_parameters(spec));
        }
        let count = |is: fn(Role) -> bool| table.iter().filter(|row| is(row.role)).count();
        Ok(VarTable {
            kind,
            vars,
            n_fixed: table.len(),
            n_inputs: count(|r| matches!(r, Role::Input(_))),
            n_outputs: count(|r| matches!(r, Role::Output(_))),
        })
    }
}
