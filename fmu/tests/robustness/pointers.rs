//! Instance pointers: a NULL component is rejected by every entry point, and foreign memory
//! is not taken for an instance (nor written to).

use std::ffi::CStr;
use std::ptr::{null, null_mut};
use zmp_fmu::*;

#[test]
fn null_component_is_rejected_by_every_entry_point() {
    let c: fmi2Component = null_mut();
    let vrs = [0u32];
    let mut r = [0.0f64];
    let mut i = [0 as fmi2Integer];
    let mut s: [fmi2String; 1] = [null()];
    let mut st: fmi2FMUstate = null_mut();
    let mut size = 0usize;
    let mut status = fmi2OK;
    // SAFETY: NULL component: the functions must not dereference anything.
    unsafe {
        let results = [
            fmi2SetDebugLogging(c, 1, 0, null()),
            fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
            fmi2EnterInitializationMode(c),
            fmi2ExitInitializationMode(c),
            fmi2Terminate(c),
            fmi2Reset(c),
            fmi2GetReal(c, vrs.as_ptr(), 1, r.as_mut_ptr()),
            fmi2SetReal(c, vrs.as_ptr(), 1, r.as_ptr()),
            fmi2GetInteger(c, vrs.as_ptr(), 1, i.as_mut_ptr()),
            fmi2SetInteger(c, vrs.as_ptr(), 1, i.as_ptr()),
            fmi2GetBoolean(c, vrs.as_ptr(), 1, i.as_mut_ptr()),
            fmi2SetBoolean(c, vrs.as_ptr(), 1, i.as_ptr()),
            fmi2GetString(c, vrs.as_ptr(), 1, s.as_mut_ptr()),
            fmi2SetString(c, vrs.as_ptr(), 1, s.as_ptr()),
            fmi2GetFMUstate(c, &mut st),
            fmi2SetFMUstate(c, st),
            fmi2FreeFMUstate(c, &mut st),
            fmi2SerializedFMUstateSize(c, st, &mut size),
            fmi2SerializeFMUstate(c, st, null_mut(), 0),
            fmi2DeSerializeFMUstate(c, null(), 0, &mut st),
            fmi2GetDirectionalDerivative(c, null(), 0, null(), 0, null(), null_mut()),
            fmi2SetRealInputDerivatives(c, null(), 0, null(), null()),
            fmi2GetRealOutputDerivatives(c, null(), 0, null(), null_mut()),
            fmi2DoStep(c, 0.0, 1e-3, 1),
            fmi2CancelStep(c),
            fmi2GetStatus(c, fmi2DoStepStatus, &mut status),
            fmi2GetRealStatus(c, fmi2LastSuccessfulTime, r.as_mut_ptr()),
            fmi2GetIntegerStatus(c, fmi2DoStepStatus, i.as_mut_ptr()),
            fmi2GetBooleanStatus(c, fmi2Terminated, i.as_mut_ptr()),
            fmi2GetStringStatus(c, fmi2PendingStatus, s.as_mut_ptr()),
        ];
        assert!(results.iter().all(|&x| x == fmi2Error), "{results:?}");
        fmi2FreeInstance(c);
        assert_eq!(CStr::from_ptr(fmi2GetVersion()).to_str(), Ok("2.0"));
        assert_eq!(
            CStr::from_ptr(fmi2GetTypesPlatform()).to_str(),
            Ok("default")
        );
    }
}

#[test]
fn foreign_pointer_is_not_taken_for_an_instance() {
    let mut junk = vec![0u64; 64];
    let c = junk.as_mut_ptr() as fmi2Component;
    let mut r = [0.0];
    // SAFETY: readable memory that is not an instance: rejected by the magic number.
    unsafe {
        assert_eq!(fmi2DoStep(c, 0.0, 1e-3, 1), fmi2Error);
        assert_eq!(
            fmi2GetReal(c, [0u32].as_ptr(), 1, r.as_mut_ptr()),
            fmi2Error
        );
        fmi2FreeInstance(c);
    }
    assert!(
        junk.iter().all(|&w| w == 0),
        "the FMU wrote into foreign memory"
    );
}
