//! The FMUs through the Rust `fmi` crate (0.8), FMI 2.0 and FMI 3.0 behind one small trait.

use fmi::fmi2::import::Fmi2Import;
use fmi::fmi3::import::Fmi3Import;
use fmi::traits::{FmiImport, FmiInstance};
use std::path::Path;
use zmp_fmu_core::{FmiVersion, Kind, VarTable};

/// A co-simulation slave as the tests drive it; value references are the FMI 2.0 ones.
pub trait CoSim {
    fn set(&mut self, vrs: &[u32], values: &[f64]);
    fn get(&mut self, vrs: &[u32], out: &mut [f64]);
    fn step(&mut self, t: f64, h: f64);
    /// Enters and exits initialisation at `t0`; `before_exit` runs in initialisation mode.
    fn init(&mut self, t0: f64, before_exit: &mut dyn FnMut(&mut dyn CoSim));
}

pub struct Fmi2Slave {
    pub inst: fmi::fmi2::instance::InstanceCS,
}

impl CoSim for Fmi2Slave {
    fn set(&mut self, vrs: &[u32], values: &[f64]) {
        use fmi::fmi2::instance::Common;
        self.inst.set_real(vrs, values).expect("fmi2SetReal");
    }
    fn get(&mut self, vrs: &[u32], out: &mut [f64]) {
        use fmi::fmi2::instance::Common;
        self.inst.get_real(vrs, out).expect("fmi2GetReal");
    }
    fn step(&mut self, t: f64, h: f64) {
        use fmi::fmi2::instance::CoSimulation;
        self.inst.do_step(t, h, true).expect("fmi2DoStep");
    }
    fn init(&mut self, t0: f64, before_exit: &mut dyn FnMut(&mut dyn CoSim)) {
        self.inst
            .enter_initialization_mode(None, t0, None)
            .expect("fmi2SetupExperiment + fmi2EnterInitializationMode");
        before_exit(self);
        self.inst
            .exit_initialization_mode()
            .expect("fmi2ExitInitializationMode");
    }
}

pub struct Fmi3Slave {
    pub inst: fmi::fmi3::instance::InstanceCS,
}

fn plus_one(vrs: &[u32]) -> Vec<u32> {
    vrs.iter().map(|v| v + 1).collect()
}

impl CoSim for Fmi3Slave {
    fn set(&mut self, vrs: &[u32], values: &[f64]) {
        use fmi::fmi3::GetSet;
        self.inst
            .set_float64(&plus_one(vrs), values)
            .expect("fmi3SetFloat64");
    }
    fn get(&mut self, vrs: &[u32], out: &mut [f64]) {
        use fmi::fmi3::GetSet;
        self.inst
            .get_float64(&plus_one(vrs), out)
            .expect("fmi3GetFloat64");
    }
    fn step(&mut self, t: f64, h: f64) {
        use fmi::fmi3::CoSimulation;
        let (mut ev, mut term, mut early, mut last) = (false, false, false, 0.0);
        self.inst
            .do_step(t, h, true, &mut ev, &mut term, &mut early, &mut last)
            .expect("fmi3DoStep");
    }
    fn init(&mut self, t0: f64, before_exit: &mut dyn FnMut(&mut dyn CoSim)) {
        self.inst
            .enter_initialization_mode(None, t0, None)
            .expect("fmi3EnterInitializationMode");
        before_exit(self);
        self.inst
            .exit_initialization_mode()
            .expect("fmi3ExitInitializationMode");
    }
}

/// An imported FMU (the extracted archive stays alive as long as this does).
pub enum Imported {
    V2(Fmi2Import),
    V3(Fmi3Import),
}

impl Imported {
    pub fn load(path: &Path, fmi: FmiVersion) -> Imported {
        match fmi {
            FmiVersion::V2 => Imported::V2(fmi::import::from_path(path).expect("import FMI 2.0")),
            FmiVersion::V3 => Imported::V3(fmi::import::from_path(path).expect("import FMI 3.0")),
        }
    }

    pub fn instantiate(&self, name: &str) -> Box<dyn CoSim> {
        match self {
            Imported::V2(i) => Box::new(Fmi2Slave {
                inst: i
                    .instantiate_cs(name, false, false)
                    .expect("fmi2Instantiate"),
            }),
            Imported::V3(i) => {
                use fmi::fmi3::Fmi3Model;
                Box::new(Fmi3Slave {
                    inst: i
                        .instantiate_cs(name, false, false, false, false, &[])
                        .expect("fmi3InstantiateCoSimulation"),
                })
            }
        }
    }

    pub fn model_identifier(&self) -> String {
        match self {
            Imported::V2(i) => i
                .model_description()
                .co_simulation
                .as_ref()
                .map(|c| c.model_identifier.clone())
                .unwrap_or_default(),
            Imported::V3(i) => i
                .model_description()
                .co_simulation
                .as_ref()
                .map(|c| c.model_identifier.clone())
                .unwrap_or_default(),
        }
    }
}

/// FMI 2.0 value references of `names` in the table of `kind`.
pub fn vrs(kind: Kind, names: &[&str]) -> Vec<u32> {
    let table = VarTable::new(kind, &super::spec()).expect("table");
    names
        .iter()
        .map(|n| {
            table
                .by_name(n)
                .unwrap_or_else(|| panic!("no variable {n}"))
                .vr
        })
        .collect()
}
