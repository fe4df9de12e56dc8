//! Initialisation, termination, reset: `fmi2SetupExperiment`, `fmi2EnterInitializationMode`,
//! `fmi2ExitInitializationMode`, `fmi2Terminate`, `fmi2Reset`.

use crate::{fmi2Boolean, fmi2Component, fmi2False, fmi2OK, fmi2Real, fmi2Status};
use crate::{
    with_instance, Instance,
    State::{InitializationMode, Instantiated, StepComplete, Terminated},
    ANY,
};

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: fmi2Component,
    toleranceDefined: fmi2Boolean,
    tolerance: fmi2Real,
    startTime: fmi2Real,
    stopTimeDefined: fmi2Boolean,
    stopTime: fmi2Real,
) -> fmi2Status {
    let _ = (toleranceDefined, tolerance);
    let body = |inst: &mut Instance| {
        inst.trace(|| format!("fmi2SetupExperiment(startTime = {startTime})"));
        if stopTimeDefined != fmi2False && !(stopTime.is_finite() && stopTime >= startTime) {
            return inst.error(&format!(
                "fmi2SetupExperiment: stopTime = {stopTime} must be finite and not before \
                 startTime = {startTime}"
            ));
        }
        match inst.slave.set_start_time(startTime) {
            Ok(()) => fmi2OK,
            Err(e) => inst.error(&format!("fmi2SetupExperiment: {e}")),
        }
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2SetupExperiment", &[Instantiated], body) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: fmi2Component) -> fmi2Status {
    let body = |inst: &mut Instance| {
        inst.trace(|| "fmi2EnterInitializationMode".into());
        inst.state = InitializationMode;
        fmi2OK
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2EnterInitializationMode", &[Instantiated], body) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: fmi2Component) -> fmi2Status {
    let body = |inst: &mut Instance| {
        inst.trace(|| "fmi2ExitInitializationMode".into());
        match inst.slave.initialize() {
            Ok(()) => {
                inst.state = StepComplete;
                fmi2OK
            }
            Err(e) => inst.error(&format!("fmi2ExitInitializationMode: {e}")),
        }
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2ExitInitializationMode", &[InitializationMode], body) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2Terminate(c: fmi2Component) -> fmi2Status {
    let body = |inst: &mut Instance| {
        inst.trace(|| "fmi2Terminate".into());
        inst.state = Terminated;
        fmi2OK
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2Terminate", &[StepComplete], body) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2Reset(c: fmi2Component) -> fmi2Status {
    let body = |inst: &mut Instance| {
        inst.trace(|| "fmi2Reset".into());
        inst.slave.reset();
        inst.state = Instantiated;
        fmi2OK
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2Reset", ANY, body) }
}
