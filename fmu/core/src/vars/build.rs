//! Building the table of each FMU kind: its fixed variables (inputs, outputs, step,
//! controller parameters) with their units, descriptions, start values and bounds, then the
//! plant's model-file parameters.

use super::{
    initial_operating_point, initial_zmp, Causality, CtrlParam, Kind, Role, Var, VarTable,
    Variability, PARAM_VR_BASE,
};
use zmp_models::closed_loop::StepExperiment;
use zmp_models::controller::CascadeParams;
use zmp_models::{ModelSpec, DEFAULT_STEP};

struct Builder {
    vars: Vec<Var>,
}

impl Builder {
    #[allow(clippy::too_many_arguments)]
    fn push(
        &mut self,
        name: &str,
        causality: Causality,
        variability: Variability,
        unit: &'static str,
        description: &str,
        start: f64,
        bounds: (f64, f64),
        role: Role,
    ) {
        let vr = self.vars.len() as u32;
        self.vars.push(Var {
            name: name.to_string(),
            vr,
            causality,
            variability,
            unit,
            description: description.to_string(),
            start,
            min: bounds.0,
            max: bounds.1,
            whole: false,
            role,
        });
    }
}

const FREE: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

impl VarTable {
    /// The table of `kind` for the model `spec`.
    pub fn new(kind: Kind, spec: &ModelSpec) -> Result<VarTable, String> {
        use Causality::*;
        use Variability::*;
        let mut b = Builder { vars: Vec::new() };
        let (n_inputs, n_outputs);
        match kind {
            Kind::Plant => {
                let (com0, out) = initial_operating_point(spec)?;
                b.push(
                    "x_cr",
                    Input,
                    Continuous,
                    "m",
                    "CoM reference, lateral (x); held over each communication step unless its \
                     derivative is set; its value when initialisation ends is the operating \
                     point x of operating_point_dependence",
                    com0[0],
                    FREE,
                    Role::Input(0),
                );
                b.push(
                    "y_cr",
                    Input,
                    Continuous,
                    "m",
                    "CoM reference, sagittal (y); held over each communication step unless its \
                     derivative is set; its value when initialisation ends is the operating \
                     point y of operating_point_dependence",
                    com0[1],
                    FREE,
                    Role::Input(1),
                );
                b.push(
                    "zmp_x",
                    Output,
                    Continuous,
                    "m",
                    "measured ZMP, lateral (x)",
                    out.zmp[0],
                    FREE,
                    Role::Output(0),
                );
                b.push(
                    "zmp_y",
                    Output,
                    Continuous,
                    "m",
                    "measured ZMP, sagittal (y)",
                    out.zmp[1],
                    FREE,
                    Role::Output(1),
                );
                b.push(
                    "x_c",
                    Output,
                    Continuous,
                    "m",
                    "CoM position, lateral (x)",
                    out.com[0],
                    FREE,
                    Role::Output(2),
                );
                b.push(
                    "y_c",
                    Output,
                    Continuous,
                    "m",
                    "CoM position, sagittal (y)",
                    out.com[1],
                    FREE,
                    Role::Output(3),
                );
                b.push(
                    "h",
                    Parameter,
                    Fixed,
                    "s",
                    "fixed internal step of the plant; the internal time grid is start + n h",
                    DEFAULT_STEP,
                    (1e-6, 0.1),
                    Role::Step,
                );
                n_inputs = 2;
                n_outputs = 4;
            }
            Kind::Controller => {
                let (com0, out) = initial_operating_point(spec)?;
                let p = CascadeParams::silo2();
                let z0 = initial_zmp();
                let dt = StepExperiment::silo2().controller_period;
                b.push(
                    "zmp_ref_x",
                    Input,
                    Continuous,
                    "m",
                    "ZMP reference, lateral (x)",
                    z0[0],
                    FREE,
                    Role::Input(0),
                );
                b.push(
                    "zmp_ref_y",
                    Input,
                    Continuous,
                    "m",
                    "ZMP reference, sagittal (y)",
                    z0[1],
                    FREE,
                    Role::Input(1),
                );
                b.push(
                    "zmp_x",
                    Input,
                    Continuous,
                    "m",
                    "measured ZMP, lateral (x)",
                    out.zmp[0],
                    FREE,
                    Role::Input(2),
                );
                b.push(
                    "zmp_y",
                    Input,
                    Continuous,
                    "m",
                    "measured ZMP, sagittal (y)",
                    out.zmp[1],
                    FREE,
                    Role::Input(3),
                );
                b.push(
                    "x_cr",
                    Output,
                    Discrete,
                    "m",
                    "CoM reference, lateral (x): com_offset_x + (m_t/m_r) l_t theta_x",
                    com0[0],
                    FREE,
                    Role::Output(0),
                );
                b.push(
                    "y_cr",
                    Output,
                    Discrete,
                    "m",
                    "CoM reference, sagittal (y): com_offset_y + (m_t/m_r) l_t theta_y",
                    com0[1],
                    FREE,
                    Role::Output(1),
                );
                b.push(
                    "theta_x",
                    Output,
                    Discrete,
                    "rad",
                    "trunk angle reference, lateral (x)",
                    0.0,
                    FREE,
                    Role::Output(2),
                );
                b.push(
                    "theta_y",
                    Output,
                    Discrete,
                    "rad",
                    "trunk angle reference, sagittal (y)",
                    0.0,
                    FREE,
                    Role::Output(3),
                );
                b.push(
                    "h",
                    Parameter,
                    Fixed,
                    "s",
                    "sample period; samples at start + n h",
                    dt,
                    (1e-6, 10.0),
                    Role::Step,
                );
                b.push(
                    "K1",
                    Parameter,
                    Fixed,
                    "rad/s",
                    "integral gain of C1 = K1/s (trunk angle rate per error unit)",
                    p.k1,
                    (0.0, 1e3),
                    Role::Controller(CtrlParam::K1),
                );
                b.push(
                    "K2",
                    Parameter,
                    Fixed,
                    "rad/s",
                    "corner of the lag C2 = K2/(s + K2)",
                    p.k2,
                    (0.0, 1e4),
                    Role::Controller(CtrlParam::K2),
                );
                b.push(
                    "error_scale",
                    Parameter,
                    Fixed,
                    "1/m",
                    "error units per metre of ZMP error (100: centimetres)",
                    p.error_scale,
                    (1e-6, 1e6),
                    Role::Controller(CtrlParam::ErrorScale),
                );
                b.push(
                    "mass_ratio",
                    Parameter,
                    Fixed,
                    "1",
                    "trunk mass over robot mass m_t/m_r",
                    p.mass_ratio,
                    (1e-6, 1.0),
                    Role::Controller(CtrlParam::MassRatio),
                );
                b.push(
                    "trunk_length",
                    Parameter,
                    Fixed,
                    "m",
                    "trunk length l_t",
                    p.trunk_length,
                    (1e-6, 100.0),
                    Role::Controller(CtrlParam::TrunkLength),
                );
                b.push(
                    "theta_min",
                    Parameter,
                    Fixed,
                    "rad",
                    "lower trunk angle limit (anti-windup clamp)",
                    p.theta_min,
                    (-3.2, 3.2),
                    Role::Controller(CtrlParam::ThetaMin),
                );
                b.push(
                    "theta_max",
                    Parameter,
                    Fixed,
                    "rad",
                    "upper trunk angle limit (anti-windup clamp)",
                    p.theta_max,
                    (-3.2, 3.2),
                    Role::Controller(CtrlParam::ThetaMax),
                );
                b.push(
                    "com_offset_x",
                    Parameter,
                    Fixed,
                    "m",
                    "CoM reference at zero trunk angle, lateral (x); the controller starts there",
                    com0[0],
                    (-10.0, 10.0),
                    Role::Controller(CtrlParam::OffsetX),
                );
                b.push(
                    "com_offset_y",
                    Parameter,
                    Fixed,
                    "m",
                    "CoM reference at zero trunk angle, sagittal (y); the controller starts there",
                    com0[1],
                    (-10.0, 10.0),
                    Role::Controller(CtrlParam::OffsetY),
                );
                n_inputs = 4;
                n_outputs = 4;
            }
            Kind::Passthrough => {
                b.push(
                    "u1",
                    Input,
                    Continuous,
                    "1",
                    "input 1",
                    0.0,
                    FREE,
                    Role::Input(0),
                );
                b.push(
                    "u2",
                    Input,
                    Continuous,
                    "1",
                    "input 2",
                    0.0,
                    FREE,
                    Role::Input(1),
                );
                b.push(
                    "y1",
                    Output,
                    Continuous,
                    "1",
                    "u1",
                    0.0,
                    FREE,
                    Role::Output(0),
                );
                b.push(
                    "y2",
                    Output,
                    Continuous,
                    "1",
                    "u2",
                    0.0,
                    FREE,
                    Role::Output(1),
                );
                b.push(
                    "y3",
                    Output,
                    Continuous,
                    "1",
                    "u1",
                    0.0,
                    FREE,
                    Role::Output(2),
                );
                b.push(
                    "y4",
                    Output,
                    Continuous,
                    "1",
                    "u2",
                    0.0,
                    FREE,
                    Role::Output(3),
                );
                n_inputs = 2;
                n_outputs = 4;
            }
        }
        let n_fixed = b.vars.len();
        assert!((n_fixed as u32) < PARAM_VR_BASE);
        if kind == Kind::Plant {
            for (i, p) in spec.parameters().into_iter().enumerate() {
                let title = spec.effects[p.effect].info.title;
                b.vars.push(Var {
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
                });
            }
        }
        Ok(VarTable {
            kind,
            vars: b.vars,
            n_fixed,
            n_inputs,
            n_outputs,
        })
    }
}
