//! Getting and setting variable values: `fmi2GetReal`, `fmi2SetReal` and the Integer, Boolean
//! and String getters and setters (the FMUs have Real variables only).

use crate::{
    fmi2Boolean, fmi2Component, fmi2Integer, fmi2OK, fmi2Real, fmi2Status, fmi2String,
    fmi2ValueReference,
};
use crate::{slice_in, slice_out, with_instance, Instance, State, ANY, SET_STATES};

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; `vr` and `value` hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Real,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        // SAFETY: forwarded FMI contract on the arrays.
        let vrs = match unsafe { slice_in(inst, "fmi2GetReal", vr, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: as above.
        let out = match unsafe { slice_out(inst, "fmi2GetReal", value, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        match inst.slave.get_real(vrs, out) {
            Ok(()) => fmi2OK,
            Err(e) => inst.error(&format!("fmi2GetReal: {e}")),
        }
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2GetReal", ANY, body) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; `vr` and `value` hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetReal(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Real,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        // SAFETY: forwarded FMI contract on the arrays.
        let vrs = match unsafe { slice_in(inst, "fmi2SetReal", vr, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        // SAFETY: as above.
        let vals = match unsafe { slice_in(inst, "fmi2SetReal", value, nvr) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        match inst.slave.set_real(vrs, vals) {
            Ok(()) => fmi2OK,
            Err(e) => inst.error(&format!("fmi2SetReal: {e}")),
        }
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2SetReal", SET_STATES, body) }
}

/// The FMUs have Real variables only: any value reference of another type is unknown.
///
/// # Safety
/// FMI 2.0 contract on `c` and `vr` (`nvr` elements).
unsafe fn no_variables_of_type(
    c: fmi2Component,
    function: &str,
    allowed: &[State],
    vr: *const fmi2ValueReference,
    nvr: usize,
    value_is_null: bool,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe {
        with_instance(c, function, allowed, |inst| {
            // SAFETY: forwarded FMI contract on the array.
            let vrs = match slice_in(inst, function, vr, nvr) {
                Ok(s) => s,
                Err(st) => return st,
            };
            if nvr > 0 && value_is_null {
                return inst.error(&format!("{function}: NULL value array with {nvr} elements"));
            }
            match vrs.first() {
                None => fmi2OK,
                Some(v) => inst.error(&format!(
                    "{function}: unknown value reference {v} (this FMU has Real variables only)"
                )),
            }
        })
    }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; arrays hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Integer,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe { no_variables_of_type(c, "fmi2GetInteger", ANY, vr, nvr, value.is_null()) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; arrays hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2Boolean,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe { no_variables_of_type(c, "fmi2GetBoolean", ANY, vr, nvr, value.is_null()) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; arrays hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *mut fmi2String,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe { no_variables_of_type(c, "fmi2GetString", ANY, vr, nvr, value.is_null()) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; arrays hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetInteger(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Integer,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe { no_variables_of_type(c, "fmi2SetInteger", SET_STATES, vr, nvr, value.is_null()) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; arrays hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2Boolean,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe { no_variables_of_type(c, "fmi2SetBoolean", SET_STATES, vr, nvr, value.is_null()) }
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; arrays hold `nvr` elements.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetString(
    c: fmi2Component,
    vr: *const fmi2ValueReference,
    nvr: usize,
    value: *const fmi2String,
) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe { no_variables_of_type(c, "fmi2SetString", SET_STATES, vr, nvr, value.is_null()) }
}
