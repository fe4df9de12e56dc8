//! FMU state and directional derivatives: not supported (canGetAndSetFMUstate = false,
//! providesDirectionalDerivative = false); each function answers with an error message.

use crate::{
    fmi2Byte, fmi2Component, fmi2FMUstate, fmi2OK, fmi2Real, fmi2Status, fmi2ValueReference,
};
use crate::{unsupported, with_instance, Instance, ANY};

const NO_STATE: &str = "not supported (canGetAndSetFMUstate = false)";

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetFMUstate(
    c: fmi2Component,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    let _ = FMUstate;
    // SAFETY: forwarded FMI contract.
    unsafe { unsupported(c, "fmi2GetFMUstate", NO_STATE) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetFMUstate(c: fmi2Component, FMUstate: fmi2FMUstate) -> fmi2Status {
    let _ = FMUstate;
    // SAFETY: forwarded FMI contract.
    unsafe { unsupported(c, "fmi2SetFMUstate", NO_STATE) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeFMUstate(
    c: fmi2Component,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        // Freeing "no state" is a no-op; this FMU never hands out states.
        if !FMUstate.is_null() && FMUstate.is_aligned() {
            // SAFETY: non-NULL, aligned pointer to a state handle by the FMI contract.
            if unsafe { (*FMUstate).is_null() } {
                return fmi2OK;
            }
        }
        inst.error(&format!("fmi2FreeFMUstate: {NO_STATE}"))
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2FreeFMUstate", ANY, body) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    size: *mut usize,
) -> fmi2Status {
    let _ = (FMUstate, size);
    // SAFETY: forwarded FMI contract.
    unsafe { unsupported(c, "fmi2SerializedFMUstateSize", NO_STATE) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: fmi2Component,
    FMUstate: fmi2FMUstate,
    serializedState: *mut fmi2Byte,
    size: usize,
) -> fmi2Status {
    let _ = (FMUstate, serializedState, size);
    // SAFETY: forwarded FMI contract.
    unsafe { unsupported(c, "fmi2SerializeFMUstate", NO_STATE) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: fmi2Component,
    serializedState: *const fmi2Byte,
    size: usize,
    FMUstate: *mut fmi2FMUstate,
) -> fmi2Status {
    let _ = (serializedState, size, FMUstate);
    // SAFETY: forwarded FMI contract.
    unsafe { unsupported(c, "fmi2DeSerializeFMUstate", NO_STATE) }
}

/// # Safety
/// FMI 2.0 contract.
#[no_mangle]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: fmi2Component,
    vUnknown_ref: *const fmi2ValueReference,
    nUnknown: usize,
    vKnown_ref: *const fmi2ValueReference,
    nKnown: usize,
    dvKnown: *const fmi2Real,
    dvUnknown: *mut fmi2Real,
) -> fmi2Status {
    let _ = (
        vUnknown_ref,
        nUnknown,
        vKnown_ref,
        nKnown,
        dvKnown,
        dvUnknown,
    );
    // SAFETY: forwarded FMI contract.
    unsafe {
        unsupported(
            c,
            "fmi2GetDirectionalDerivative",
            "not supported (providesDirectionalDerivative = false)",
        )
    }
}
