//! Panics caught at the boundary (the error state, then reset), and debug logging's
//! traces.

use crate::{vr, Fixture};
use std::ffi::CString;
use std::ptr::null;
use zmp_fmu::*;
use zmp_fmu_core::Kind;

#[test]
fn panics_are_caught_at_the_boundary() {
    let f = Fixture::new(Kind::Plant);
    let c = f.instantiate(INJECT_PANIC_NAME);
    assert!(!c.is_null());
    let zmp_x = vr(Kind::Plant, "zmp_x");
    let mut out = [0.0];
    // SAFETY: a live instance.
    unsafe {
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        f.rejected(fmi2DoStep(c, 0.0, 1e-3, 1), "panic: fault injected");
        // Error state: only gets, reset and free.
        f.rejected(fmi2DoStep(c, 0.0, 1e-3, 1), "error state");
        f.rejected(
            fmi2SetReal(c, [0].as_ptr(), 1, [0.1].as_ptr()),
            "error state",
        );
        assert_eq!(
            fmi2GetReal(c, [zmp_x].as_ptr(), 1, out.as_mut_ptr()),
            fmi2OK
        );
        assert_eq!(fmi2Reset(c), fmi2OK);
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        fmi2FreeInstance(c);
    }
}

#[test]
fn debug_logging_traces_calls_when_enabled() {
    let f = Fixture::new(Kind::Passthrough);
    let c = f.running();
    let all = CString::new("logAll").unwrap();
    // SAFETY: a live instance.
    unsafe {
        assert_eq!(
            fmi2SetDebugLogging(c, 1, 1, [all.as_ptr()].as_ptr()),
            fmi2OK
        );
        assert_eq!(fmi2Terminate(c), fmi2OK);
        assert!(f
            .messages()
            .iter()
            .any(|(s, cat, m)| *s == fmi2OK && cat == "logAll" && m == "fmi2Terminate"));
        f.clear();
        assert_eq!(fmi2SetDebugLogging(c, 0, 0, null()), fmi2OK);
        assert_eq!(fmi2Reset(c), fmi2OK);
        assert!(f.messages().is_empty());
        fmi2FreeInstance(c);
    }
}
