//! The co-simulation functions: input and output derivatives, `fmi2DoStep`, `fmi2CancelStep`
//! and the status inquiries.

use crate::{
    fmi2Boolean, fmi2Component, fmi2False, fmi2Integer, fmi2LastSuccessfulTime, fmi2OK, fmi2Real,
    fmi2Status, fmi2StatusKind, fmi2String, fmi2Terminated, fmi2ValueReference, fmi2Warning,
};
use crate::{
    slice_in, unsupported, with_instance, Instance, State::StepComplete, CAT_WARNING,
    INJECT_PANIC_NAME, SET_STATES, STATUS_STATES,
};

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    order: *const fmi2Integer,
    value: *const fmi2Real,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        const F: &str = "fmi2SetRealInputDerivatives";
        // SAFETY: forwarded FMI contract on the arrays.
        let vrs = match unsafe { slice_in(inst, F, vr, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: as above.
        let orders = match unsafe { slice_in(inst, F, order, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: as above.
        let vals = match unsafe { slice_in(inst, F, value, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        match inst.slave.set_input_derivatives(vrs, orders, vals) {
            Ok(w) if w.is_empty() => fmi2OK,
            Ok(w) => {
                inst.log(fmi2Warning, CAT_WARNING, &format!("{F}: {}", w.join("; ")));
                fmi2Warning
            }
            Err(e) => inst.error(&format!("{F}: {e}")),
        }
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2SetRealInputDerivatives", SET_STATES, body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    order: *const fmi2Integer,
    value: *mut fmi2Real,
) -> fmi2Status {
    let _ = (vr, nvr, order, value);
    // SAFETY: forwarded FMI contract.
    unsafe {
        unsupported(
            c,
            "fmi2GetRealOutputDerivatives",
            "not supported (maxOutputDerivativeOrder = 0)",
        )
    }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
#[no_mangle]
pub unsafe extern "C" fn fmi2DoStep(
    c: fmi2Component,
    currentCommunicationPoint: fmi2Real,
    communicationStepSize: fmi2Real,
    noSetFMUStatePriorToCurrentPoint: fmi2Boolean,
) -> fmi2Status {
    let _ = noSetFMUStatePriorToCurrentPoint;
    let body = |inst: &mut Instance| {
        if inst.inject_panic {
            panic!("fault injected by the instance name {INJECT_PANIC_NAME:?}");
        }
        match inst
            .slave
            .do_step(currentCommunicationPoint, communicationStepSize)
        {
            Ok(()) => fmi2OK,
            Err(e) => inst.error(&format!("fmi2DoStep: {e}")),
        }
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2DoStep", &[StepComplete], body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2CancelStep(c: fmi2Component) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe {
        unsupported(
            c,
            "fmi2CancelStep",
            "not supported (fmi2DoStep never returns fmi2Pending)",
        )
    }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Status,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        if value.is_null() {
            return inst.error("fmi2GetStatus: value is NULL");
        }
        inst.discard(&format!(
            "fmi2GetStatus({s}): no asynchronous step to report on"
        ))
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2GetStatus", STATUS_STATES, body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Real,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        if value.is_null() || !value.is_aligned() {
            return inst.error("fmi2GetRealStatus: value is NULL or misaligned");
        }
        if s != fmi2LastSuccessfulTime {
            return inst.discard(&format!(
                "fmi2GetRealStatus({s}): only fmi2LastSuccessfulTime is available"
            ));
        }
        // SAFETY: non-NULL, aligned, writable by the FMI contract.
        unsafe { *value = inst.slave.communication_time() };
        fmi2OK
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2GetRealStatus", STATUS_STATES, body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Integer,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        if value.is_null() {
            return inst.error("fmi2GetIntegerStatus: value is NULL");
        }
        inst.discard(&format!("fmi2GetIntegerStatus({s}): no integer status"))
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2GetIntegerStatus", STATUS_STATES, body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        if value.is_null() || !value.is_aligned() {
            return inst.error("fmi2GetBooleanStatus: value is NULL or misaligned");
        }
        if s != fmi2Terminated {
            return inst.discard(&format!(
                "fmi2GetBooleanStatus({s}): only fmi2Terminated is available"
            ));
        }
        // SAFETY: non-NULL, aligned, writable by the FMI contract.
        unsafe { *value = fmi2False };
        fmi2OK
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2GetBooleanStatus", STATUS_STATES, body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: fmi2Component,
    s: fmi2StatusKind,
    value: *mut fmi2String,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        if value.is_null() {
            return inst.error("fmi2GetStringStatus: value is NULL");
        }
        inst.discard(&format!(
            "fmi2GetStringStatus({s}): no asynchronous step to report on"
        ))
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2GetStringStatus", STATUS_STATES, body) }
}
