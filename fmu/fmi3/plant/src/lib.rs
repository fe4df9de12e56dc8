#![warn(missing_docs)]
//! FMI 3.0 co-simulation FMU of the ZMP plant: `fmi_export::export_fmu!` over
//! `zmp_fmu_core::fmi3::Fmi3Fmu` (see there for why the model file is compiled in).

use zmp_fmu_core::fmi3::{Baked, Fmi3Fmu};
use zmp_fmu_core::Kind;

/// The compiled-in model file and its instantiation token.
pub struct Model;

impl Baked for Model {
    const KIND: Kind = Kind::Plant;
    const MODEL_TOML: &'static str = include_str!(concat!(env!("OUT_DIR"), "/model.toml"));
    const TOKEN: &'static str = env!("ZMP_FMI3_TOKEN");
}

/// The FMU's model type.
pub type ZmpPlantFmi3 = Fmi3Fmu<Model>;

/// The FMI 3.0 C entry points the macro generates (`fmi3InstantiateCoSimulation`, ...):
/// exported by symbol name, so they need no public Rust path and no documentation of their own.
mod exports {
    #![allow(missing_docs)]
    use super::ZmpPlantFmi3;
    fmi_export::export_fmu!(ZmpPlantFmi3);
}
