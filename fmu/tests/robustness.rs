//! Robustness of the hand-written FMI 2.0 interface: every `fmi2*` entry point with NULL or
//! invalid arguments, unknown value references, calls out of order, non-finite inputs, zero or
//! negative steps, caught panics, and 10,000 instantiate/free cycles without memory growth
//! (RSS, and valgrind's leak checker on a child run).
//!
//! The functions are called in-process through the `zmp_fmu` rlib: the same code as the shared
//! library. The logger is a Rust function with the five fixed arguments, cast to the C-variadic
//! `fmi2CallbackLogger` type; the FMU calls it with exactly those five (no variadic arguments),
//! which the x86-64 System V ABI passes identically.

mod common;

use std::ffi::{c_char, c_int, c_void, CStr, CString};
use std::path::PathBuf;
use std::ptr::{null, null_mut};
use std::sync::Mutex;
use zmp_fmu::*;
use zmp_fmu_core::{FmiVersion, Kind, VarTable};

/// Messages received by the logger: (status, category, message).
type Log = Mutex<Vec<(c_int, String, String)>>;

unsafe extern "C" fn record(
    env: fmi2ComponentEnvironment,
    _name: fmi2String,
    status: fmi2Status,
    category: fmi2String,
    message: fmi2String,
) {
    // SAFETY: env is the `Log` the test passed as componentEnvironment; strings are valid C
    // strings for the duration of the call (FMU contract).
    unsafe {
        let log = &*(env as *const Log);
        let cat = CStr::from_ptr(category).to_string_lossy().into_owned();
        let msg = CStr::from_ptr(message).to_string_lossy().into_owned();
        log.lock().unwrap().push((status, cat, msg));
    }
}

fn logger() -> fmi2CallbackLogger {
    type Fixed = unsafe extern "C" fn(
        fmi2ComponentEnvironment,
        fmi2String,
        fmi2Status,
        fmi2String,
        fmi2String,
    );
    // SAFETY: see the module docs: the FMU passes exactly the five fixed arguments.
    unsafe { std::mem::transmute::<Fixed, fmi2CallbackLogger>(record as Fixed) }
}

/// An FMU resources directory with the paper model.
fn resources() -> PathBuf {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let dir = common::target_dir().join("fmu-tests/robustness-resources");
        std::fs::create_dir_all(&dir).unwrap();
        // Atomically: the valgrind child reads it while this process may be writing.
        let tmp = dir.join(format!("model.toml.{}", std::process::id()));
        std::fs::write(&tmp, common::model_text()).unwrap();
        std::fs::rename(&tmp, dir.join("model.toml")).unwrap();
        dir
    })
    .clone()
}

struct Fixture {
    log: Box<Log>,
    functions: Box<fmi2CallbackFunctions>,
    guid: CString,
    location: CString,
}

impl Fixture {
    fn new(kind: Kind) -> Fixture {
        let log: Box<Log> = Box::default();
        let functions = Box::new(fmi2CallbackFunctions {
            logger: Some(logger()),
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: &*log as *const Log as *mut c_void,
        });
        Fixture {
            log,
            functions,
            guid: CString::new(kind.guid(FmiVersion::V2, &common::model_text())).unwrap(),
            location: CString::new(format!("file://{}", resources().display())).unwrap(),
        }
    }

    fn instantiate(&self, name: &str) -> fmi2Component {
        let name = CString::new(name).unwrap();
        // SAFETY: valid strings and callbacks that outlive the instance.
        unsafe {
            fmi2Instantiate(
                name.as_ptr(),
                fmi2CoSimulation,
                self.guid.as_ptr(),
                self.location.as_ptr(),
                &*self.functions,
                fmi2False,
                fmi2False,
            )
        }
    }

    /// Instantiated and initialised at t = 0.
    fn running(&self) -> fmi2Component {
        let c = self.instantiate("robust");
        assert!(!c.is_null(), "{:?}", self.messages());
        // SAFETY: a live instance.
        unsafe {
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), fmi2OK);
            assert_eq!(fmi2EnterInitializationMode(c), fmi2OK);
            assert_eq!(fmi2ExitInitializationMode(c), fmi2OK);
        }
        c
    }

    fn messages(&self) -> Vec<(c_int, String, String)> {
        self.log.lock().unwrap().clone()
    }

    fn clear(&self) {
        self.log.lock().unwrap().clear();
    }

    /// Asserts that `status` is Error or Discard and that an error/discard message mentioning
    /// `needle` was logged since the last check.
    fn rejected(&self, status: fmi2Status, needle: &str) {
        assert!(
            status == fmi2Error || status == fmi2Discard,
            "status {status} (expected fmi2Error or fmi2Discard) for {needle:?}"
        );
        let msgs = self.messages();
        assert!(
            msgs.iter()
                .any(|(s, _, m)| (*s == fmi2Error || *s == fmi2Discard) && m.contains(needle)),
            "no logged message containing {needle:?}; got {msgs:?}"
        );
        self.clear();
    }
}

fn vr(kind: Kind, name: &str) -> u32 {
    VarTable::new(kind, &common::spec())
        .unwrap()
        .by_name(name)
        .unwrap()
        .vr
}

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

#[test]
fn instantiate_rejects_bad_arguments_with_a_message() {
    let f = Fixture::new(Kind::Plant);
    let name = CString::new("x").unwrap();
    let bad_guid = CString::new("{00000000-0000-0000-0000-000000000000}").unwrap();
    let bad_uri = CString::new("http://example.org/resources").unwrap();
    let missing = CString::new("file:///nonexistent/zmp/resources").unwrap();
    let call = |name: *const c_char, ty, guid: *const c_char, loc: *const c_char| {
        // SAFETY: each pointer is NULL or a valid C string; callbacks are valid.
        unsafe { fmi2Instantiate(name, ty, guid, loc, &*f.functions, 0, 0) }
    };
    type Case<'a> = (
        *const c_char,
        fmi2Type,
        *const c_char,
        *const c_char,
        &'a str,
    );
    let cases: [Case; 7] = [
        (
            null(),
            fmi2CoSimulation,
            f.guid.as_ptr(),
            f.location.as_ptr(),
            "instanceName",
        ),
        (
            name.as_ptr(),
            fmi2ModelExchange,
            f.guid.as_ptr(),
            f.location.as_ptr(),
            "co-simulation only",
        ),
        (
            name.as_ptr(),
            7,
            f.guid.as_ptr(),
            f.location.as_ptr(),
            "co-simulation only",
        ),
        (
            name.as_ptr(),
            fmi2CoSimulation,
            null(),
            f.location.as_ptr(),
            "fmuGUID is NULL",
        ),
        (
            name.as_ptr(),
            fmi2CoSimulation,
            bad_guid.as_ptr(),
            f.location.as_ptr(),
            "does not match",
        ),
        (
            name.as_ptr(),
            fmi2CoSimulation,
            f.guid.as_ptr(),
            bad_uri.as_ptr(),
            "not a file: URI",
        ),
        (
            name.as_ptr(),
            fmi2CoSimulation,
            f.guid.as_ptr(),
            missing.as_ptr(),
            "cannot read the model file",
        ),
    ];
    for (n, ty, g, l, needle) in cases {
        let c = call(n, ty, g, l);
        assert!(c.is_null(), "instantiated despite {needle:?}");
        f.rejected(fmi2Error, needle);
    }
    assert!(call(name.as_ptr(), fmi2CoSimulation, f.guid.as_ptr(), null()).is_null());
    f.rejected(fmi2Error, "fmuResourceLocation is NULL");
    // No callbacks, or no logger: NULL, and nothing to report to.
    // SAFETY: NULL callbacks pointer / a struct without logger.
    unsafe {
        let none = fmi2Instantiate(
            name.as_ptr(),
            1,
            f.guid.as_ptr(),
            f.location.as_ptr(),
            null(),
            0,
            0,
        );
        assert!(none.is_null());
        let no_logger = fmi2CallbackFunctions {
            logger: None,
            allocateMemory: None,
            freeMemory: None,
            stepFinished: None,
            componentEnvironment: null_mut(),
        };
        let c = fmi2Instantiate(
            name.as_ptr(),
            1,
            f.guid.as_ptr(),
            f.location.as_ptr(),
            &no_logger,
            0,
            0,
        );
        assert!(c.is_null());
    }
    // A corrupt model file whose hash matches: the parse error is reported.
    let dir = common::target_dir().join("fmu-tests/robustness-corrupt");
    std::fs::create_dir_all(&dir).unwrap();
    let corrupt = "format = \"zmp-model/1\"\n[pendulum]\na11 = \"x\"\n";
    std::fs::write(dir.join("model.toml"), corrupt).unwrap();
    let guid = CString::new(Kind::Plant.guid(FmiVersion::V2, corrupt)).unwrap();
    let loc = CString::new(format!("file://{}", dir.display())).unwrap();
    assert!(call(name.as_ptr(), 1, guid.as_ptr(), loc.as_ptr()).is_null());
    f.rejected(fmi2Error, "pendulum.a11");
}

#[test]
fn invalid_arguments_and_out_of_order_calls_are_rejected() {
    let f = Fixture::new(Kind::Plant);
    let c = f.instantiate("order");
    assert!(!c.is_null());
    let x_cr = vr(Kind::Plant, "x_cr");
    let zmp_x = vr(Kind::Plant, "zmp_x");
    let h = vr(Kind::Plant, "h");
    let seed = vr(Kind::Plant, "uncertainty.G11.delta_seed");
    let mut out = [0.0f64; 2];
    let mut st: fmi2FMUstate = null_mut();
    // SAFETY: a live instance and valid (or deliberately NULL) arrays of the stated lengths.
    unsafe {
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

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS")
}

/// `n` instantiate / initialise / step / free cycles of each of `kinds`.
fn cycles(kinds: &[Kind], n: usize) {
    let fixtures: Vec<Fixture> = kinds.iter().map(|&k| Fixture::new(k)).collect();
    for _ in 0..n {
        for f in &fixtures {
            let c = f.running();
            // SAFETY: a live instance, freed right after.
            unsafe {
                assert_eq!(fmi2DoStep(c, 0.0, 0.01, 1), fmi2OK);
                fmi2FreeInstance(c);
            }
        }
    }
    for f in &fixtures {
        assert!(f.messages().is_empty(), "{:?}", f.messages());
    }
}

#[test]
fn ten_thousand_instantiate_free_cycles_do_not_grow_memory() {
    cycles(&Kind::ALL, 1_000);
    let before = rss_kib();
    cycles(&Kind::ALL, 10_000);
    let after = rss_kib();
    assert!(
        after < before + 1024,
        "RSS grew from {before} kB to {after} kB over 10,000 cycles"
    );
}

/// Runs in the valgrind child of [`valgrind_finds_no_leak`] only.
#[test]
fn leak_cycles_child() {
    if std::env::var_os("ZMP_FMU_LEAK_CHILD").is_some() {
        // 10,000 plant cycles (the largest instance) and 1,000 of the others, to keep the
        // valgrind run to about a minute.
        cycles(&[Kind::Plant], 10_000);
        cycles(&[Kind::Controller, Kind::Passthrough], 1_000);
    }
}

#[test]
fn valgrind_finds_no_leak() {
    let valgrind = std::process::Command::new("valgrind")
        .arg("--version")
        .output();
    assert!(
        valgrind.map(|o| o.status.success()).unwrap_or(false),
        "valgrind is missing: run `cargo xtask setup`"
    );
    // Make sure the resources directory exists before the child starts.
    resources();
    let exe = std::env::current_exe().unwrap();
    let out = std::process::Command::new("valgrind")
        .args([
            "--leak-check=full",
            "--errors-for-leak-kinds=definite,indirect",
            "--show-leak-kinds=definite,indirect",
            "--error-exitcode=99",
            "--quiet",
        ])
        .arg(&exe)
        .args([
            "--exact",
            "leak_cycles_child",
            "--test-threads=1",
            "--nocapture",
        ])
        .env("ZMP_FMU_LEAK_CHILD", "1")
        .output()
        .expect("running valgrind");
    assert!(
        out.status.success(),
        "valgrind reports errors or leaks ({}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 passed"));
}
