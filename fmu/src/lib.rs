#![warn(missing_docs)]
//! The FMI 2.0 co-simulation interface of the ZMP FMUs, written by hand: all 34 common and
//! co-simulation `fmi2*` functions, exported with C linkage from one generic shared library.
//!
//! The same binary serves the plant, the controller and the pass-through FMU (it is copied to
//! `binaries/linux64/<modelIdentifier>.so` of each). At `fmi2Instantiate` it reads
//! `resources/model.toml` from the resource location and recognises its kind by the GUID, which
//! is a hash of the kind, the binary version and the model file (`zmp_fmu_core::guid`): a GUID
//! that matches no kind is an error. All model logic is `zmp_fmu_core::Slave` over `zmp_models`.
//!
//! Robustness: every entry point catches panics (`catch_unwind`), checks NULL pointers, the
//! instance's magic number, the call order and the values, and answers `fmi2Error` with a
//! logger message instead of crashing. After a caught panic the instance is in the error state:
//! only get functions, `fmi2Reset` and `fmi2FreeInstance` are accepted. Instances share no
//! state. Fault injection for the tests: an instance named `zmp-fmu:inject-panic` panics inside
//! `fmi2DoStep`.
//!
//! The exports are grouped by FMI function family in private modules and re-exported here:
//! `instantiation` (version, debug logging, creation and destruction), `initialization`,
//! `variables`, `fmu_state` (not supported) and `co_simulation`. The instance, its state
//! machine and the argument checks they share stay in this file.
//!
//! `unsafe` is confined to this boundary; each block states why it is sound.

#![allow(non_camel_case_types, non_snake_case, non_upper_case_globals)]
#![deny(unsafe_op_in_unsafe_fn)]

use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use zmp_fmu_core::Slave;

mod co_simulation;
mod fmu_state;
mod initialization;
mod instantiation;
mod variables;

pub use co_simulation::{
    fmi2CancelStep, fmi2DoStep, fmi2GetBooleanStatus, fmi2GetIntegerStatus,
    fmi2GetRealOutputDerivatives, fmi2GetRealStatus, fmi2GetStatus, fmi2GetStringStatus,
    fmi2SetRealInputDerivatives,
};
pub use fmu_state::{
    fmi2DeSerializeFMUstate, fmi2FreeFMUstate, fmi2GetDirectionalDerivative, fmi2GetFMUstate,
    fmi2SerializeFMUstate, fmi2SerializedFMUstateSize, fmi2SetFMUstate,
};
pub use initialization::{
    fmi2EnterInitializationMode, fmi2ExitInitializationMode, fmi2Reset, fmi2SetupExperiment,
    fmi2Terminate,
};
pub use instantiation::{
    fmi2FreeInstance, fmi2GetTypesPlatform, fmi2GetVersion, fmi2Instantiate, fmi2SetDebugLogging,
};
pub use variables::{
    fmi2GetBoolean, fmi2GetInteger, fmi2GetReal, fmi2GetString, fmi2SetBoolean, fmi2SetInteger,
    fmi2SetReal, fmi2SetString,
};

/// An FMU instance, as the importer holds it (`fmi2TypesPlatform.h`).
pub type fmi2Component = *mut c_void;
/// The importer's own pointer, passed back to its logger unchanged.
pub type fmi2ComponentEnvironment = *mut c_void;
/// A saved FMU state (`fmi2GetFMUstate`; this FMU cannot save its state).
pub type fmi2FMUstate = *mut c_void;
/// The handle of a variable: its `valueReference` in modelDescription.xml.
pub type fmi2ValueReference = c_uint;
/// A real value of FMI 2.0.
pub type fmi2Real = f64;
/// An integer value of FMI 2.0.
pub type fmi2Integer = c_int;
/// A boolean of FMI 2.0: [`fmi2True`] or [`fmi2False`].
pub type fmi2Boolean = c_int;
/// A character of an FMI 2.0 string.
pub type fmi2Char = c_char;
/// A NUL-terminated string of FMI 2.0.
pub type fmi2String = *const fmi2Char;
/// A byte of FMI 2.0 (serialised states).
pub type fmi2Byte = c_char;
/// The status every FMI 2.0 function returns: [`fmi2OK`] .. [`fmi2Pending`].
pub type fmi2Status = c_int;
/// The interface type asked for at instantiation: [`fmi2ModelExchange`] or [`fmi2CoSimulation`].
pub type fmi2Type = c_int;
/// Which status `fmi2Get*Status` reports: [`fmi2DoStepStatus`] .. [`fmi2Terminated`].
pub type fmi2StatusKind = c_int;

/// The call succeeded.
pub const fmi2OK: fmi2Status = 0;
/// The call succeeded, with something the importer should be told of.
pub const fmi2Warning: fmi2Status = 1;
/// The call did not complete (a step not taken); the instance can go on.
pub const fmi2Discard: fmi2Status = 2;
/// The call failed; the instance must be reset or freed.
pub const fmi2Error: fmi2Status = 3;
/// The call failed and every instance of the FMU is unusable.
pub const fmi2Fatal: fmi2Status = 4;
/// An asynchronous step is still running (never returned: steps are synchronous).
pub const fmi2Pending: fmi2Status = 5;

/// Model exchange (not supported by these FMUs).
pub const fmi2ModelExchange: fmi2Type = 0;
/// Co-simulation, the interface these FMUs implement.
pub const fmi2CoSimulation: fmi2Type = 1;

/// The status of the last `fmi2DoStep`.
pub const fmi2DoStepStatus: fmi2StatusKind = 0;
/// The description of a pending asynchronous step.
pub const fmi2PendingStatus: fmi2StatusKind = 1;
/// The end time (s) of the last step taken.
pub const fmi2LastSuccessfulTime: fmi2StatusKind = 2;
/// Whether the slave asks to terminate the simulation.
pub const fmi2Terminated: fmi2StatusKind = 3;

/// Boolean true.
pub const fmi2True: fmi2Boolean = 1;
/// Boolean false.
pub const fmi2False: fmi2Boolean = 0;

/// The importer's logger (C variadic: the message is a printf format).
pub type fmi2CallbackLogger = unsafe extern "C" fn(
    fmi2ComponentEnvironment,
    fmi2String,
    fmi2Status,
    fmi2String,
    fmi2String,
    ...
);

/// `fmi2CallbackFunctions` of `fmi2FunctionTypes.h`.
#[repr(C)]
pub struct fmi2CallbackFunctions {
    /// Where the FMU sends its log messages.
    pub logger: Option<fmi2CallbackLogger>,
    /// The importer's `calloc` (unused: the FMU allocates with Rust's allocator).
    pub allocateMemory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    /// The importer's `free` (unused, as `allocateMemory`).
    pub freeMemory: Option<unsafe extern "C" fn(*mut c_void)>,
    /// Called when an asynchronous step ends (unused: steps are synchronous).
    pub stepFinished: Option<unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2Status)>,
    /// Passed back unchanged as the logger's first argument.
    pub componentEnvironment: fmi2ComponentEnvironment,
}

const MAGIC: u64 = 0x5a4d_505f_464d_5532; // "ZMP_FMU2"
const FREED: u64 = 0xdead_dead_dead_dead;
/// Instance name that makes `fmi2DoStep` panic (tests of the panic boundary).
pub const INJECT_PANIC_NAME: &str = "zmp-fmu:inject-panic";
/// Larger arrays are rejected as corrupt arguments.
const MAX_NVR: usize = 1 << 24;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    Instantiated,
    InitializationMode,
    StepComplete,
    Terminated,
    /// After a caught panic: only get functions, reset and free.
    Error,
}

use State::*;

const ANY: &[State] = &[
    Instantiated,
    InitializationMode,
    StepComplete,
    Terminated,
    Error,
];
const SET_STATES: &[State] = &[Instantiated, InitializationMode, StepComplete];
const STATUS_STATES: &[State] = &[StepComplete, Terminated, Error];

const CAT_ERROR: usize = 0;
const CAT_WARNING: usize = 1;
const CAT_ALL: usize = 2;
const CATEGORIES: [&CStr; 3] = [c"logStatusError", c"logStatusWarning", c"logAll"];

/// One FMU instance. `repr(C)` so that `magic` is the first word.
#[repr(C)]
struct Instance {
    magic: u64,
    name: CString,
    logger: fmi2CallbackLogger,
    env: fmi2ComponentEnvironment,
    logging_on: bool,
    categories: [bool; 3],
    state: State,
    inject_panic: bool,
    slave: Slave,
}

/// Sends `msg` to `logger` (escaped, so that it is printed verbatim by printf-style loggers).
fn call_logger(
    logger: fmi2CallbackLogger,
    env: fmi2ComponentEnvironment,
    name: &CStr,
    status: fmi2Status,
    category: &CStr,
    msg: &str,
) {
    let text = CString::new(msg.replace('%', "%%").replace('\0', " ")).unwrap_or_default();
    // SAFETY: `logger` is the non-NULL function the importer passed to fmi2Instantiate, called
    // with the documented argument types; all strings are NUL-terminated and outlive the call.
    unsafe { logger(env, name.as_ptr(), status, category.as_ptr(), text.as_ptr()) };
}

impl Instance {
    fn log(&self, status: fmi2Status, category: usize, msg: &str) {
        call_logger(
            self.logger,
            self.env,
            &self.name,
            status,
            CATEGORIES[category],
            msg,
        );
    }

    /// Logs an error (always, whatever the debug-logging settings) and returns `fmi2Error`.
    fn error(&self, msg: &str) -> fmi2Status {
        self.log(fmi2Error, CAT_ERROR, msg);
        fmi2Error
    }

    /// Logs a discard (always) and returns `fmi2Discard`.
    fn discard(&self, msg: &str) -> fmi2Status {
        self.log(fmi2Discard, CAT_WARNING, msg);
        fmi2Discard
    }

    fn trace(&self, msg: impl FnOnce() -> String) {
        if self.logging_on && self.categories[CAT_ALL] {
            self.log(fmi2OK, CAT_ALL, &msg());
        }
    }
}

/// The instance behind `c`, if `c` is a live instance of this library.
///
/// # Safety
/// `c` must be NULL or a pointer returned by `fmi2Instantiate` (the FMI contract). A pointer to
/// freed or foreign memory is caught by the magic number when that memory is still readable, but
/// this cannot be guaranteed.
unsafe fn instance<'a>(c: fmi2Component) -> Option<&'a mut Instance> {
    let p = c as *mut Instance;
    if p.is_null() || !p.is_aligned() {
        return None;
    }
    // SAFETY: per the contract above `p` points at an `Instance` (repr(C), magic first); the
    // magic number is read before anything else to reject freed or foreign pointers.
    let magic = unsafe { std::ptr::read_volatile(std::ptr::addr_of!((*p).magic)) };
    if magic != MAGIC {
        return None;
    }
    // SAFETY: a live instance, exclusively used by this call (FMI: one call at a time per
    // instance).
    Some(unsafe { &mut *p })
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

/// Runs `f` on the instance behind `c` if the call is allowed in its state, catching panics.
///
/// # Safety
/// See [`instance`].
// `#[inline]`: the exports calling it live in the family modules, and a generic function's
// instances are compiled in the codegen unit of the module that defines it; without the hint
// they were no longer inlined into the exports (fmu_do_step/plant_fmi2: +2.4 % instructions).
#[inline]
unsafe fn with_instance(
    c: fmi2Component,
    function: &str,
    allowed: &[State],
    f: impl FnOnce(&mut Instance) -> fmi2Status,
) -> fmi2Status {
    // SAFETY: forwarded contract.
    let Some(inst) = (unsafe { instance(c) }) else {
        return fmi2Error;
    };
    if !allowed.contains(&inst.state) {
        let msg = if inst.state == Error {
            format!(
                "{function}: the instance is in the error state after an internal failure; call \
                 fmi2Reset or fmi2FreeInstance"
            )
        } else {
            format!("{function}: not allowed in state {:?}", inst.state)
        };
        return inst.error(&msg);
    }
    let result = catch_unwind(AssertUnwindSafe(|| f(&mut *inst)));
    match result {
        Ok(status) => status,
        Err(p) => {
            inst.state = Error;
            let msg = format!("{function}: internal error (panic: {})", panic_message(&*p));
            // The logger itself must not unwind into the importer either.
            let _ = catch_unwind(AssertUnwindSafe(|| inst.log(fmi2Error, CAT_ERROR, &msg)));
            fmi2Error
        }
    }
}

/// Borrows `n` elements at `p` for reading, after NULL and alignment checks.
///
/// # Safety
/// When non-NULL, `p` must point at `n` readable elements (the FMI contract).
unsafe fn slice_in<'a, T>(
    inst: &Instance,
    what: &str,
    p: *const T,
    n: usize,
) -> Result<&'a [T], fmi2Status> {
    if n == 0 {
        return Ok(&[]);
    }
    if p.is_null() {
        return Err(inst.error(&format!("{what}: NULL array with {n} elements")));
    }
    if !p.is_aligned() || n > MAX_NVR {
        return Err(inst.error(&format!("{what}: invalid array ({n} elements at {p:p})")));
    }
    // SAFETY: non-NULL, aligned, and by the FMI contract `n` elements long.
    Ok(unsafe { std::slice::from_raw_parts(p, n) })
}

/// Borrows `n` elements at `p` for writing, after NULL and alignment checks.
///
/// # Safety
/// When non-NULL, `p` must point at `n` writable elements (the FMI contract).
// `#[inline]`: as for `with_instance` (`fmi2GetReal` inlined it before the split).
#[inline]
unsafe fn slice_out<'a, T>(
    inst: &Instance,
    what: &str,
    p: *mut T,
    n: usize,
) -> Result<&'a mut [T], fmi2Status> {
    if n == 0 {
        return Ok(&mut []);
    }
    if p.is_null() {
        return Err(inst.error(&format!("{what}: NULL array with {n} elements")));
    }
    if !p.is_aligned() || n > MAX_NVR {
        return Err(inst.error(&format!("{what}: invalid array ({n} elements at {p:p})")));
    }
    // SAFETY: non-NULL, aligned, and by the FMI contract `n` writable elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, n) })
}

/// Copies a C string argument; `None` for NULL or invalid UTF-8.
///
/// # Safety
/// When non-NULL, `s` must be a NUL-terminated string.
unsafe fn c_str(s: fmi2String) -> Option<String> {
    if s.is_null() {
        return None;
    }
    // SAFETY: non-NULL and NUL-terminated by the FMI contract.
    unsafe { CStr::from_ptr(s) }
        .to_str()
        .ok()
        .map(str::to_string)
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`.
unsafe fn unsupported(c: fmi2Component, function: &str, why: &str) -> fmi2Status {
    // SAFETY: forwarded FMI contract.
    unsafe {
        with_instance(c, function, ANY, |inst| {
            inst.error(&format!("{function}: {why}"))
        })
    }
}
