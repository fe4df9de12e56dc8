//! The FMI 3.0 glue: [`Fmi3Fmu`] implements `fmi-export`'s `Model`, `UserModel`, `ModelGetSet`
//! and `ModelGetSetStates` over the same [`Slave`] and variable table as the FMI 2.0 shell;
//! `fmi_export::export_fmu!` in the `zmp-fmi3-*` crates generates the `fmi3*` C interface
//! (instance life cycle, state machine, value-reference dispatch, logging).
//!
//! Why not `#[derive(FmuModel)]`: the derive takes the variables, their start values and the
//! instantiation token (a UUID of the struct's name) from a static Rust struct, has no `unit`
//! attribute, and the variable list of the plant depends on the model file. So the model file is
//! compiled in instead (`ZMP_FMU_MODEL` at build time, see the crates' `build.rs`): the token is
//! the same hash as the FMI 2.0 GUID (kind, binary version, model text), the metadata is built
//! from the variable table, units go through `TypeDefinitions`, and the traits are implemented
//! by hand here.
//!
//! Value references: FMI 3.0 reserves 0 for `time`; every variable has the FMI 2.0 value
//! reference + 1 (fmi-export subtracts the 1 before calling the model).

use crate::units::base_unit;
use crate::vars::{Causality, FmiVersion, Kind, VarTable, Variability};
use crate::Slave;
use fmi::fmi3::{Fmi3Error, Fmi3Res};
use fmi::schema::fmi3 as schema;
use fmi_export::fmi3::{
    CSDoStepResult, Context, DefaultLoggingCategory, Model, ModelGetSet, ModelGetSetStates,
    UserModel,
};
use std::marker::PhantomData;

/// What a `zmp-fmi3-*` crate compiles in.
pub trait Baked: 'static {
    /// Which FMU the crate is: the plant or the controller.
    const KIND: Kind;
    /// The model file's text.
    const MODEL_TOML: &'static str;
    /// `KIND.guid(FmiVersion::V3, MODEL_TOML)`, computed by the build script.
    const TOKEN: &'static str;
}

/// An FMI 3.0 co-simulation model of kind `B::KIND` for the compiled-in model.
pub struct Fmi3Fmu<B: Baked> {
    slave: Result<Slave, String>,
    _baked: PhantomData<B>,
}

impl<B: Baked> Default for Fmi3Fmu<B> {
    fn default() -> Self {
        Fmi3Fmu {
            slave: Slave::new(B::KIND, B::MODEL_TOML, "model.toml (compiled in)"),
            _baked: PhantomData,
        }
    }
}

fn log<B: Baked>(ctx: &dyn Context<Fmi3Fmu<B>>, msg: &str) -> Fmi3Error {
    ctx.log(
        Fmi3Error::Error.into(),
        DefaultLoggingCategory::LogAll,
        format_args!("{msg}"),
    );
    Fmi3Error::Error
}

impl<B: Baked> Fmi3Fmu<B> {
    fn slave(&mut self, ctx: &dyn Context<Self>) -> Result<&mut Slave, Fmi3Error> {
        match &mut self.slave {
            Ok(s) => Ok(s),
            Err(e) => Err(log(ctx, e)),
        }
    }

    /// The variable table of the compiled-in model.
    pub fn table() -> Result<VarTable, String> {
        let spec =
            zmp_models::ModelSpec::parse(B::MODEL_TOML, "model.toml").map_err(|e| e.to_string())?;
        VarTable::new(B::KIND, &spec)
    }
}

fn unit_type_name(unit: &str) -> String {
    format!("Unit_{}", unit.replace('/', "_per_"))
}

fn causality(c: Causality) -> schema::Causality {
    match c {
        Causality::Parameter => schema::Causality::Parameter,
        Causality::Input => schema::Causality::Input,
        Causality::Output => schema::Causality::Output,
    }
}

fn variability(v: Variability) -> schema::Variability {
    match v {
        Variability::Fixed => schema::Variability::Fixed,
        Variability::Discrete => schema::Variability::Discrete,
        Variability::Continuous => schema::Variability::Continuous,
    }
}

impl<B: Baked> Model for Fmi3Fmu<B> {
    const MODEL_NAME: &'static str = B::KIND.model_identifier(FmiVersion::V3);
    const INSTANTIATION_TOKEN: &'static str = B::TOKEN;
    const MAX_EVENT_INDICATORS: usize = 0;
    const SUPPORTS_MODEL_EXCHANGE: bool = false;
    const SUPPORTS_CO_SIMULATION: bool = true;
    const SUPPORTS_SCHEDULED_EXECUTION: bool = false;

    fn build_metadata(
        variables: &mut schema::ModelVariables,
        model_structure: &mut schema::ModelStructure,
        vr_offset: u32,
        prefix: Option<&str>,
    ) -> u32 {
        use schema::AppendToModelVariables;
        let Ok(table) = Self::table() else {
            return 0;
        };
        let prefix = prefix.unwrap_or("");
        let inputs: Vec<u32> = table
            .vars
            .iter()
            .filter(|v| v.causality == Causality::Input)
            .map(|v| v.vr + vr_offset)
            .collect();
        for v in &table.vars {
            let mut f = schema::FmiFloat64::new(
                format!("{prefix}{}", v.name),
                v.vr + vr_offset,
                Some(v.description.clone()),
                causality(v.causality),
                variability(v.variability),
                (v.causality != Causality::Output).then(|| vec![v.start]),
                None,
            );
            f.declared_type = Some(unit_type_name(v.unit));
            f.min = v.has_min().then_some(v.min);
            f.max = v.has_max().then_some(v.max);
            f.append_to_variables(variables);
        }
        for v in table
            .vars
            .iter()
            .filter(|v| v.causality == Causality::Output)
        {
            let deps = if table.direct_feedthrough() {
                inputs.clone()
            } else {
                Vec::new()
            };
            model_structure
                .unknowns
                .push(schema::VariableDependency::Output(schema::Fmi3Unknown {
                    value_reference: v.vr + vr_offset,
                    dependencies: Some(fmi::schema::utils::AttrList(deps)),
                    ..Default::default()
                }));
            model_structure
                .unknowns
                .push(schema::VariableDependency::InitialUnknown(
                    schema::Fmi3Unknown {
                        value_reference: v.vr + vr_offset,
                        ..Default::default()
                    },
                ));
        }
        table.vars.len() as u32
    }

    fn set_start_values(&mut self) {
        if let Ok(s) = &mut self.slave {
            s.reset();
        }
    }
}

impl<B: Baked> UserModel for Fmi3Fmu<B> {
    type LoggingCategory = DefaultLoggingCategory;

    fn configurate(&mut self, ctx: &dyn Context<Self>) -> Result<(), Fmi3Error> {
        let t0 = ctx.time();
        let s = self.slave(ctx)?;
        s.set_start_time(t0)
            .and_then(|()| s.initialize())
            .map_err(|e| log(ctx, &format!("fmi3ExitInitializationMode: {e}")))
    }

    fn calculate_values(&mut self, ctx: &dyn Context<Self>) -> Result<Fmi3Res, Fmi3Error> {
        let s = self.slave(ctx)?;
        s.refresh().map(|()| Fmi3Res::OK).map_err(|e| log(ctx, &e))
    }

    fn do_step(
        &mut self,
        ctx: &mut dyn Context<Self>,
        current_communication_point: f64,
        communication_step_size: f64,
        _no_set_fmu_state_prior_to_current_point: bool,
    ) -> Result<CSDoStepResult, Fmi3Error> {
        let s = self.slave(ctx)?;
        if let Err(e) = s.do_step(current_communication_point, communication_step_size) {
            return Err(log(ctx, &format!("fmi3DoStep: {e}")));
        }
        let t = s.communication_time();
        ctx.set_time(t);
        Ok(CSDoStepResult::completed(t))
    }
}

impl<B: Baked> ModelGetSet<Self> for Fmi3Fmu<B> {
    const FIELD_COUNT: usize = 0;

    fn get_float64(
        &self,
        vr: u32,
        values: &mut [f64],
        ctx: &dyn Context<Self>,
    ) -> Result<usize, Fmi3Error> {
        let s = self.slave.as_ref().map_err(|e| log(ctx, e))?;
        let v = s.value_of(vr).ok_or_else(|| {
            log(
                ctx,
                &format!("fmi3GetFloat64: unknown value reference {}", vr + 1),
            )
        })?;
        let slot = values
            .first_mut()
            .ok_or_else(|| log(ctx, "fmi3GetFloat64: values array too short"))?;
        *slot = v;
        Ok(1)
    }

    fn set_float64(
        &mut self,
        vr: u32,
        values: &[f64],
        ctx: &dyn Context<Self>,
    ) -> Result<usize, Fmi3Error> {
        let v = *values
            .first()
            .ok_or_else(|| log(ctx, "fmi3SetFloat64: values array too short"))?;
        let s = self.slave(ctx)?;
        s.set_real(&[vr], &[v]).map_err(|e| {
            log(
                ctx,
                &format!(
                    "fmi3SetFloat64: {}",
                    e.replace(&format!("reference {vr}"), &format!("reference {}", vr + 1))
                ),
            )
        })?;
        Ok(1)
    }
}

impl<B: Baked> ModelGetSetStates for Fmi3Fmu<B> {
    const NUM_STATES: usize = 0;

    fn get_continuous_states(&self, _states: &mut [f64]) -> Result<(), Fmi3Error> {
        Ok(())
    }

    fn set_continuous_states(&mut self, _states: &[f64]) -> Result<(), Fmi3Error> {
        Ok(())
    }

    fn get_continuous_state_derivatives(
        &mut self,
        _derivatives: &mut [f64],
    ) -> Result<(), Fmi3Error> {
        Ok(())
    }
}

/// The `modelDescription.xml` of the FMI 3.0 FMU `B`: fmi-export's metadata (the variables from
/// [`Model::build_metadata`] plus `time`) with the co-simulation capabilities, units, default
/// experiment and log categories, serialized by fmi-schema.
pub fn model_description<B: Baked>(model_name: &str) -> Result<String, String> {
    let table = Fmi3Fmu::<B>::table()?;
    let meta = <Fmi3Fmu<B> as Model>::build_toplevel_metadata();
    let kind = B::KIND;
    let units = table
        .units()
        .into_iter()
        .map(|u| schema::Fmi3Unit {
            name: u.to_string(),
            base_unit: base_unit(u).map(|b| schema::BaseUnit {
                kg: (b.kg != 0).then_some(b.kg),
                m: (b.m != 0).then_some(b.m),
                s: (b.s != 0).then_some(b.s),
                rad: (b.rad != 0).then_some(b.rad),
                ..Default::default()
            }),
            ..Default::default()
        })
        .collect();
    let types = table
        .units()
        .into_iter()
        .map(|u| {
            schema::TypeDefinition::Float64(schema::Float64Type {
                name: unit_type_name(u),
                unit: Some(u.to_string()),
                ..Default::default()
            })
        })
        .collect();
    let (stop, step) = kind.default_experiment();
    let md = schema::Fmi3ModelDescription {
        fmi_version: "3.0".into(),
        model_name: format!("{} ({model_name})", kind.model_identifier(FmiVersion::V3)),
        instantiation_token: B::TOKEN.to_string(),
        description: Some(kind.description().to_string()),
        author: Some("zmp-toolkit".into()),
        version: Some(env!("CARGO_PKG_VERSION").into()),
        generation_tool: Some(format!(
            "zmp-fmu {} with fmi-export 0.3",
            crate::guid::binary_version()
        )),
        variable_naming_convention: Some("structured".into()),
        co_simulation: Some(schema::Fmi3CoSimulation {
            model_identifier: kind.model_identifier(FmiVersion::V3).into(),
            needs_execution_tool: Some(false),
            can_be_instantiated_only_once_per_process: Some(false),
            can_get_and_set_fmu_state: Some(false),
            can_serialize_fmu_state: Some(false),
            provides_directional_derivatives: Some(false),
            provides_adjoint_derivatives: Some(false),
            can_handle_variable_communication_step_size: Some(true),
            max_output_derivative_order: Some(0),
            provides_intermediate_update: Some(false),
            might_return_early_from_do_step: Some(false),
            has_event_mode: Some(false),
            ..Default::default()
        }),
        unit_definitions: Some(schema::UnitDefinitions { units }),
        type_definitions: Some(schema::TypeDefinitions {
            type_definitions: types,
        }),
        log_categories: Some(schema::LogCategories {
            categories: [("logAll", "all messages"), ("trace", "FMI API calls")]
                .into_iter()
                .map(|(n, d)| schema::Category {
                    name: n.into(),
                    description: Some(d.into()),
                    ..Default::default()
                })
                .collect(),
        }),
        default_experiment: Some(schema::DefaultExperiment {
            start_time: Some(0.0),
            stop_time: Some(stop),
            step_size: Some(step),
            ..Default::default()
        }),
        model_variables: meta.model_variables,
        model_structure: meta.model_structure,
        ..Default::default()
    };
    fmi::schema::serialize(&md, false).map_err(|e| e.to_string())
}

/// The main of a `zmp-fmi3-*` crate's executable: `--model-description` prints the model
/// description, `--token` the instantiation token.
pub fn main<B: Baked>() -> std::process::ExitCode {
    let arg = std::env::args().nth(1).unwrap_or_default();
    let name = zmp_models::ModelSpec::parse(B::MODEL_TOML, "model.toml")
        .ok()
        .and_then(|s| s.name)
        .unwrap_or_else(|| "model".into());
    match arg.as_str() {
        "--model-description" => match model_description::<B>(&name) {
            Ok(xml) => {
                print!("{xml}");
                std::process::ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("error: {e}");
                std::process::ExitCode::FAILURE
            }
        },
        "--token" => {
            println!("{}", B::TOKEN);
            std::process::ExitCode::SUCCESS
        }
        _ => {
            eprintln!(
                "usage: {} --model-description | --token",
                B::KIND.model_identifier(FmiVersion::V3)
            );
            std::process::ExitCode::FAILURE
        }
    }
}
