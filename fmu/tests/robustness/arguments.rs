//! Invalid arguments and out-of-order calls of a live instance, and the controller's
//! inconsistent limits: rejected with a logged message, the instance unchanged.

use crate::{vr, Fixture};
use std::ffi::CString;
use std::ptr::{null, null_mut};
use zmp_fmu::*;
use zmp_fmu_core::Kind;

#[test]
fn invalid_arguments_and_out_of_order_calls_are_rejected() {
    let f = Fixture::new(Kind::Plant);
    let c = f.instantiate("order");
    assert!(!c.is_null());
    let x_cr = vr(Kind::Plant, "x_cr");
    let zmp_x = vr(Kind::Plant, "zmp_x");
    let mut out = [0.0f64; 2];
    // SAFETY: a live instance and valid (or deliberately NULL) arrays of the stated lengths;
    // the steps run in order on the one instance, which must stay usable after each.
    unsafe {
        rejects_calls_before_initialisation(&f, c);
        rejects_bad_arrays(&f, c);
        rejects_unknown_references_and_other_types(&f, c);
        let before = rejects_bad_values_and_sets_none_of_a_batch(&f, c);
        rejects_bad_logging_and_unsupported_features(&f, c);
        checks_input_derivatives_like_values(&f, c);
        reports_a_bad_parameter_combination_at_initialisation(&f, c);
        rejects_bad_calls_after_initialisation(&f, c);
        answers_status_inquiries(&f, c);
        // Still usable after all the errors.
        assert_eq!(fmi2SetReal(c, [x_cr].as_ptr(), 1, [0.2].as_ptr()), fmi2OK);
        assert_eq!(fmi2DoStep(c, 0.1, 0.1, 1), fmi2OK);
        assert_eq!(
            fmi2GetReal(c, [zmp_x].as_ptr(), 1, out.as_mut_ptr()),
            fmi2OK
        );
        assert!(out[0].is_finite());
        assert_eq!(fmi2Terminate(c), fmi2OK);
        f.rejected(
            fmi2DoStep(c, 0.2, 0.1, 1),
            "not allowed in state Terminated",
        );
        assert_eq!(
            fmi2GetReal(c, [zmp_x].as_ptr(), 1, out.as_mut_ptr()),
            fmi2OK
        );
        // Reset: back to instantiated with the start values.
        assert_eq!(fmi2Reset(c), fmi2OK);
        let mut x = [0.0];
        assert_eq!(fmi2GetReal(c, [x_cr].as_ptr(), 1, x.as_mut_ptr()), fmi2OK);
        assert_eq!(x[0], before[0]);
        fmi2FreeInstance(c);
    }
}

/// Steps, initialisation's end and termination before initialisation.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn rejects_calls_before_initialisation(f: &Fixture, c: fmi2Component) {
    // Out of order before initialisation.
    f.rejected(
        fmi2DoStep(c, 0.0, 1e-3, 1),
        "not allowed in state Instantiated",
    );
    f.rejected(
        fmi2ExitInitializationMode(c),
        "not allowed in state Instantiated",
    );
    f.rejected(fmi2Terminate(c), "not allowed");
}

/// NULL, oversized and misaligned arrays; an empty NULL array is fine.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn rejects_bad_arrays(f: &Fixture, c: fmi2Component) {
    let x_cr = vr(Kind::Plant, "x_cr");
    let zmp_x = vr(Kind::Plant, "zmp_x");
    let mut out = [0.0f64; 2];
    // Arrays.
    f.rejected(fmi2GetReal(c, null(), 1, out.as_mut_ptr()), "NULL array");
    f.rejected(
        fmi2GetReal(c, [zmp_x].as_ptr(), 1, null_mut()),
        "NULL array",
    );
    f.rejected(fmi2SetReal(c, [x_cr].as_ptr(), 1, null()), "NULL array");
    f.rejected(
        fmi2GetReal(c, [x_cr].as_ptr(), usize::MAX, out.as_mut_ptr()),
        "invalid array",
    );
    let mis = (out.as_mut_ptr() as *mut u8).add(1) as *mut f64;
    f.rejected(fmi2GetReal(c, [x_cr].as_ptr(), 1, mis), "invalid array");
    assert_eq!(fmi2GetReal(c, null(), 0, null_mut()), fmi2OK);
}

/// Unknown value references, setting an output, and the non-Real variable types.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn rejects_unknown_references_and_other_types(f: &Fixture, c: fmi2Component) {
    let zmp_x = vr(Kind::Plant, "zmp_x");
    let mut out = [0.0f64; 2];
    // Unknown value references and wrong causality.
    f.rejected(
        fmi2GetReal(c, [99_999].as_ptr(), 1, out.as_mut_ptr()),
        "unknown value reference 99999",
    );
    f.rejected(
        fmi2GetReal(c, [50].as_ptr(), 1, out.as_mut_ptr()),
        "unknown value reference 50",
    );
    f.rejected(
        fmi2SetReal(c, [zmp_x].as_ptr(), 1, [0.1].as_ptr()),
        "is an output",
    );
    let mut iv = [0 as fmi2Integer];
    f.rejected(
        fmi2GetInteger(c, [0].as_ptr(), 1, iv.as_mut_ptr()),
        "Real variables only",
    );
    f.rejected(
        fmi2SetBoolean(c, [0].as_ptr(), 1, iv.as_ptr()),
        "Real variables only",
    );
    let mut sv: [fmi2String; 1] = [null()];
    f.rejected(
        fmi2GetString(c, [0].as_ptr(), 1, sv.as_mut_ptr()),
        "Real variables only",
    );
    f.rejected(
        fmi2SetString(c, [0].as_ptr(), 1, null()),
        "NULL value array",
    );
    assert_eq!(fmi2GetInteger(c, null(), 0, null_mut()), fmi2OK);
}

/// Non-finite, out-of-bounds and fractional values; nothing of a rejected batch is set.
/// Returns `x_cr` as it was before.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn rejects_bad_values_and_sets_none_of_a_batch(f: &Fixture, c: fmi2Component) -> [f64; 1] {
    let x_cr = vr(Kind::Plant, "x_cr");
    let h = vr(Kind::Plant, "h");
    let seed = vr(Kind::Plant, "uncertainty.G11.delta_seed");
    // Values: non-finite, out of bounds, not whole; nothing of a rejected batch is set.
    f.rejected(
        fmi2SetReal(c, [x_cr].as_ptr(), 1, [f64::NAN].as_ptr()),
        "not a finite number",
    );
    f.rejected(
        fmi2SetReal(c, [x_cr].as_ptr(), 1, [f64::INFINITY].as_ptr()),
        "not a finite number",
    );
    f.rejected(
        fmi2SetReal(c, [h].as_ptr(), 1, [-1e-3].as_ptr()),
        "out of bounds",
    );
    f.rejected(
        fmi2SetReal(c, [h].as_ptr(), 1, [0.0].as_ptr()),
        "out of bounds",
    );
    f.rejected(
        fmi2SetReal(c, [seed].as_ptr(), 1, [2.5].as_ptr()),
        "whole number",
    );
    let mut before = [0.0];
    assert_eq!(
        fmi2GetReal(c, [x_cr].as_ptr(), 1, before.as_mut_ptr()),
        fmi2OK
    );
    f.rejected(
        fmi2SetReal(c, [x_cr, h].as_ptr(), 2, [0.3, f64::NAN].as_ptr()),
        "not a finite number",
    );
    let mut after = [0.0];
    assert_eq!(
        fmi2GetReal(c, [x_cr].as_ptr(), 1, after.as_mut_ptr()),
        fmi2OK
    );
    assert_eq!(before, after, "a rejected batch set some values");
    before
}

/// Unknown or NULL log categories, and the FMU-state and directional-derivative functions the FMU does not offer.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn rejects_bad_logging_and_unsupported_features(f: &Fixture, c: fmi2Component) {
    let mut st: fmi2FMUstate = null_mut();
    // Debug logging.
    let bogus = CString::new("logNothing").unwrap();
    f.rejected(
        fmi2SetDebugLogging(c, 1, 1, [bogus.as_ptr()].as_ptr()),
        "unknown log category",
    );
    f.rejected(fmi2SetDebugLogging(c, 1, 1, null()), "NULL array");
    f.rejected(
        fmi2SetDebugLogging(c, 1, 1, [null()].as_ptr()),
        "NULL or non-UTF-8",
    );
    // Unsupported features.
    f.rejected(fmi2GetFMUstate(c, &mut st), "canGetAndSetFMUstate");
    f.rejected(fmi2SetFMUstate(c, st), "canGetAndSetFMUstate");
    assert_eq!(
        fmi2FreeFMUstate(c, &mut st),
        fmi2OK,
        "freeing no state is a no-op"
    );
    f.rejected(
        fmi2SerializedFMUstateSize(c, st, null_mut()),
        "canGetAndSetFMUstate",
    );
    f.rejected(
        fmi2SerializeFMUstate(c, st, null_mut(), 0),
        "canGetAndSetFMUstate",
    );
    f.rejected(
        fmi2DeSerializeFMUstate(c, null(), 0, &mut st),
        "canGetAndSetFMUstate",
    );
    f.rejected(
        fmi2GetDirectionalDerivative(c, null(), 0, null(), 0, null(), null_mut()),
        "providesDirectionalDerivative",
    );
}

/// Input derivatives (the plant interpolates inputs): checked like values; output derivatives and step cancelling are not offered.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn checks_input_derivatives_like_values(f: &Fixture, c: fmi2Component) {
    let x_cr = vr(Kind::Plant, "x_cr");
    // Input derivatives (the plant interpolates inputs): checked like values.
    let zmp_x = vr(Kind::Plant, "zmp_x");
    f.rejected(
        fmi2SetRealInputDerivatives(c, [x_cr].as_ptr(), 1, [1].as_ptr(), [f64::NAN].as_ptr()),
        "not a finite number",
    );
    f.rejected(
        fmi2SetRealInputDerivatives(c, [zmp_x].as_ptr(), 1, [1].as_ptr(), [0.1].as_ptr()),
        "not an input",
    );
    f.rejected(
        fmi2SetRealInputDerivatives(c, [x_cr].as_ptr(), 1, [0].as_ptr(), [0.1].as_ptr()),
        "orders start at 1",
    );
    f.rejected(
        fmi2SetRealInputDerivatives(c, [x_cr].as_ptr(), 1, null(), [0.1].as_ptr()),
        "NULL array",
    );
    assert_eq!(
        fmi2SetRealInputDerivatives(c, [x_cr].as_ptr(), 1, [2].as_ptr(), [0.1].as_ptr()),
        fmi2Warning,
        "a second derivative is accepted and ignored, with a warning"
    );
    assert_eq!(
        fmi2SetRealInputDerivatives(c, [x_cr].as_ptr(), 1, [1].as_ptr(), [0.0].as_ptr()),
        fmi2OK
    );
    f.clear();
    f.rejected(
        fmi2GetRealOutputDerivatives(c, null(), 0, null(), null_mut()),
        "maxOutputDerivativeOrder",
    );
    f.rejected(fmi2CancelStep(c), "never returns fmi2Pending");
}

/// The experiment setup's checks, and a parameter combination that fails at the end of initialisation, which is retried after fixing it.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn reports_a_bad_parameter_combination_at_initialisation(f: &Fixture, c: fmi2Component) {
    let h = vr(Kind::Plant, "h");
    // Experiment setup.
    f.rejected(
        fmi2SetupExperiment(c, 0, 0.0, f64::NAN, 0, 0.0),
        "not finite",
    );
    f.rejected(fmi2SetupExperiment(c, 0, 0.0, 1.0, 1, 0.5), "stopTime");
    assert_eq!(fmi2SetupExperiment(c, 1, 1e-6, 0.0, 1, 10.0), fmi2OK);
    // Invalid parameter combination: reported at the end of initialisation, which can be
    // retried after fixing it.
    let tl = vr(Kind::Plant, "tracking_lowpass.x.omega_n");
    assert_eq!(fmi2SetReal(c, [h].as_ptr(), 1, [0.1].as_ptr()), fmi2OK);
    assert_eq!(fmi2SetReal(c, [tl].as_ptr(), 1, [5000.0].as_ptr()), fmi2OK);
    assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
    f.rejected(
        fmi2EnterInitializationMode(c),
        "not allowed in state InitializationMode",
    );
    let st_exit = fmi2ExitInitializationMode(c);
    if st_exit != fmi2OK {
        f.rejected(st_exit, "fmi2ExitInitializationMode");
        assert_eq!(fmi2SetReal(c, [tl].as_ptr(), 1, [30.0].as_ptr()), fmi2OK);
        assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
    }
    f.clear();
}

/// Setup and fixed parameters after initialisation; steps of zero, negative or non-finite size, or not starting where the last one ended.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn rejects_bad_calls_after_initialisation(f: &Fixture, c: fmi2Component) {
    let h = vr(Kind::Plant, "h");
    // Out of order after initialisation.
    f.rejected(
        fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0),
        "not allowed in state StepComplete",
    );
    f.rejected(
        fmi2SetReal(c, [h].as_ptr(), 1, [1e-3].as_ptr()),
        "fixed parameter",
    );
    // Steps: zero, negative, non-finite, not starting where the last one ended.
    f.rejected(fmi2DoStep(c, 0.0, 0.0, 1), "must be positive");
    f.rejected(fmi2DoStep(c, 0.0, -0.1, 1), "must be positive");
    f.rejected(fmi2DoStep(c, 0.0, f64::NAN, 1), "not finite");
    f.rejected(fmi2DoStep(c, f64::INFINITY, 0.1, 1), "not finite");
    f.rejected(
        fmi2DoStep(c, 0.5, 0.1, 1),
        "not where the previous step ended",
    );
    f.rejected(fmi2DoStep(c, 0.0, 1e300, 1), "beyond the internal grid");
    assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), fmi2OK);
}

/// The status inquiries after a step: the last successful time, not terminated, no asynchronous step.
///
/// # Safety
/// `c` is a live instance of `f`.
unsafe fn answers_status_inquiries(f: &Fixture, c: fmi2Component) {
    // Status inquiries.
    let mut t = [0.0];
    assert_eq!(
        fmi2GetRealStatus(c, fmi2LastSuccessfulTime, t.as_mut_ptr()),
        fmi2OK
    );
    assert!((t[0] - 0.1).abs() < 1e-15);
    let mut b = [7 as fmi2Boolean];
    assert_eq!(
        fmi2GetBooleanStatus(c, fmi2Terminated, b.as_mut_ptr()),
        fmi2OK
    );
    assert_eq!(b[0], fmi2False);
    let mut s = fmi2OK;
    f.rejected(
        fmi2GetStatus(c, fmi2DoStepStatus, &mut s),
        "no asynchronous step",
    );
    f.rejected(
        fmi2GetRealStatus(c, fmi2DoStepStatus, t.as_mut_ptr()),
        "only fmi2LastSuccessfulTime",
    );
    f.rejected(
        fmi2GetRealStatus(c, fmi2LastSuccessfulTime, null_mut()),
        "NULL",
    );
    f.rejected(
        fmi2GetIntegerStatus(c, fmi2DoStepStatus, b.as_mut_ptr()),
        "no integer status",
    );
    f.rejected(
        fmi2GetBooleanStatus(c, fmi2DoStepStatus, b.as_mut_ptr()),
        "only fmi2Terminated",
    );
    let mut sv: fmi2String = null();
    f.rejected(
        fmi2GetStringStatus(c, fmi2PendingStatus, &mut sv),
        "no asynchronous step",
    );
}

#[test]
fn controller_rejects_inconsistent_limits() {
    let f = Fixture::new(Kind::Controller);
    let c = f.instantiate("ctrl");
    assert!(!c.is_null(), "{:?}", f.messages());
    let (lo, hi) = (
        vr(Kind::Controller, "theta_min"),
        vr(Kind::Controller, "theta_max"),
    );
    // SAFETY: a live instance.
    unsafe {
        assert_eq!(
            fmi2SetReal(c, [lo, hi].as_ptr(), 2, [0.5, -0.5].as_ptr()),
            fmi2OK
        );
        assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
        f.rejected(fmi2ExitInitializationMode(c), "must not exceed theta_max");
        // The controller samples its inputs: it declares canInterpolateInputs = false.
        f.rejected(
            fmi2SetRealInputDerivatives(c, [0].as_ptr(), 1, [1].as_ptr(), [0.1].as_ptr()),
            "canInterpolateInputs = false",
        );
        fmi2FreeInstance(c);
    }
}
