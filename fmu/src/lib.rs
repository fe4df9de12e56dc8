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
//! `unsafe` is confined to this boundary; each block states why it is sound.

#![allow(non_camel_case_types, non_snake_case, non_upper_case_globals)]
#![deny(unsafe_op_in_unsafe_fn)]

use std::ffi::{c_char, c_int, c_uint, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use zmp_fmu_core::{FmiVersion, Kind, Slave};

pub type fmi2Component = *mut c_void;
pub type fmi2ComponentEnvironment = *mut c_void;
pub type fmi2FMUstate = *mut c_void;
pub type fmi2ValueReference = c_uint;
pub type fmi2Real = f64;
pub type fmi2Integer = c_int;
pub type fmi2Boolean = c_int;
pub type fmi2Char = c_char;
pub type fmi2String = *const fmi2Char;
pub type fmi2Byte = c_char;
pub type fmi2Status = c_int;
pub type fmi2Type = c_int;
pub type fmi2StatusKind = c_int;

pub const fmi2OK: fmi2Status = 0;
pub const fmi2Warning: fmi2Status = 1;
pub const fmi2Discard: fmi2Status = 2;
pub const fmi2Error: fmi2Status = 3;
pub const fmi2Fatal: fmi2Status = 4;
pub const fmi2Pending: fmi2Status = 5;

pub const fmi2ModelExchange: fmi2Type = 0;
pub const fmi2CoSimulation: fmi2Type = 1;

pub const fmi2DoStepStatus: fmi2StatusKind = 0;
pub const fmi2PendingStatus: fmi2StatusKind = 1;
pub const fmi2LastSuccessfulTime: fmi2StatusKind = 2;
pub const fmi2Terminated: fmi2StatusKind = 3;

pub const fmi2True: fmi2Boolean = 1;
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
    pub logger: Option<fmi2CallbackLogger>,
    pub allocateMemory: Option<unsafe extern "C" fn(usize, usize) -> *mut c_void>,
    pub freeMemory: Option<unsafe extern "C" fn(*mut c_void)>,
    pub stepFinished: Option<unsafe extern "C" fn(fmi2ComponentEnvironment, fmi2Status)>,
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

// ---------------------------------------------------------------------------------------------
// Inquire version numbers, debug logging
// ---------------------------------------------------------------------------------------------

#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[no_mangle]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`; `categories` holds `nCategories` strings.
#[no_mangle]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: fmi2Component,
    loggingOn: fmi2Boolean,
    nCategories: usize,
    categories: *const fmi2String,
) -> fmi2Status {
    let body = |inst: &mut Instance| {
        let on = loggingOn != fmi2False;
        // SAFETY: forwarded FMI contract on `categories`.
        let cats = match unsafe { slice_in(inst, "fmi2SetDebugLogging", categories, nCategories) } {
            Ok(s) => s,
            Err(st) => return st,
        };
        let mut flags = inst.categories;
        if cats.is_empty() {
            flags = [on; 3];
        }
        for &cat in cats {
            // SAFETY: each entry is a NUL-terminated string or NULL (checked).
            let Some(name) = (unsafe { c_str(cat) }) else {
                return inst.error("fmi2SetDebugLogging: NULL or non-UTF-8 category");
            };
            match CATEGORIES
                .iter()
                .position(|c| c.to_str() == Ok(name.as_str()))
            {
                Some(k) => flags[k] = on,
                None => {
                    return inst.error(&format!(
                        "fmi2SetDebugLogging: unknown log category {name:?} (known: \
                         logStatusError, logStatusWarning, logAll)"
                    ))
                }
            }
        }
        inst.logging_on = on;
        inst.categories = flags;
        fmi2OK
    };
    // SAFETY: forwarded FMI contract on `c`.
    unsafe { with_instance(c, "fmi2SetDebugLogging", ANY, body) }
}

// ---------------------------------------------------------------------------------------------
// Creation and destruction
// ---------------------------------------------------------------------------------------------

fn instantiate(
    name: &str,
    fmu_type: fmi2Type,
    guid: Option<String>,
    location: Option<String>,
    logging_on: bool,
    log: &dyn Fn(&str),
) -> Option<Slave> {
    if fmu_type != fmi2CoSimulation {
        log(&format!(
            "fmi2Instantiate: fmuType = {fmu_type}: this FMU supports co-simulation only \
             (fmi2CoSimulation = 1)"
        ));
        return None;
    }
    let Some(guid) = guid else {
        log("fmi2Instantiate: fmuGUID is NULL");
        return None;
    };
    let Some(location) = location else {
        log("fmi2Instantiate: fmuResourceLocation is NULL");
        return None;
    };
    let dir = match zmp_fmu_core::resource::resource_dir(&location) {
        Ok(d) => d,
        Err(e) => {
            log(&format!("fmi2Instantiate: {e}"));
            return None;
        }
    };
    let file = dir.join("model.toml");
    let text = match std::fs::read_to_string(&file) {
        Ok(t) => t,
        Err(e) => {
            log(&format!(
                "fmi2Instantiate: cannot read the model file {}: {e}",
                file.display()
            ));
            return None;
        }
    };
    let Some(kind) = Kind::ALL
        .into_iter()
        .find(|k| k.guid(FmiVersion::V2, &text) == guid)
    else {
        log(&format!(
            "fmi2Instantiate: GUID {guid} does not match this binary (zmp-fmu {}) and {}: the \
             modelDescription.xml, the binary and resources/model.toml come from different \
             builds; rebuild the FMU with `cargo xtask fmu`",
            zmp_fmu_core::guid::binary_version(),
            file.display()
        ));
        return None;
    };
    let _ = (name, logging_on);
    match Slave::new(kind, &text, &file.display().to_string()) {
        Ok(s) => Some(s),
        Err(e) => {
            log(&format!("fmi2Instantiate: {e}"));
            None
        }
    }
}

/// # Safety
/// FMI 2.0 contract: strings NUL-terminated or NULL; `functions` points at a callback struct.
#[no_mangle]
pub unsafe extern "C" fn fmi2Instantiate(
    instanceName: fmi2String,
    fmuType: fmi2Type,
    fmuGUID: fmi2String,
    fmuResourceLocation: fmi2String,
    functions: *const fmi2CallbackFunctions,
    visible: fmi2Boolean,
    loggingOn: fmi2Boolean,
) -> fmi2Component {
    let _ = visible;
    if functions.is_null() || !functions.is_aligned() {
        return std::ptr::null_mut();
    }
    // SAFETY: non-NULL, aligned, a `fmi2CallbackFunctions` by the FMI contract; copied.
    let (logger, env) = unsafe { ((*functions).logger, (*functions).componentEnvironment) };
    // Without a logger errors could not be reported (FMI 2.0 requires one).
    let Some(logger) = logger else {
        return std::ptr::null_mut();
    };
    // SAFETY: NUL-terminated or NULL by the FMI contract.
    let name = unsafe { c_str(instanceName) };
    let name_c = CString::new(name.clone().unwrap_or_else(|| "?".into())).unwrap_or_default();
    let log = |msg: &str| call_logger(logger, env, &name_c, fmi2Error, CATEGORIES[CAT_ERROR], msg);
    let Some(name) = name else {
        log("fmi2Instantiate: instanceName is NULL or not UTF-8");
        return std::ptr::null_mut();
    };
    // SAFETY: NUL-terminated or NULL by the FMI contract.
    let (guid, location) = unsafe { (c_str(fmuGUID), c_str(fmuResourceLocation)) };
    let on = loggingOn != fmi2False;
    let slave = catch_unwind(AssertUnwindSafe(|| {
        instantiate(&name, fmuType, guid, location, on, &log)
    }));
    let slave = match slave {
        Ok(Some(s)) => s,
        Ok(None) => return std::ptr::null_mut(),
        Err(p) => {
            let _ = catch_unwind(AssertUnwindSafe(|| {
                log(&format!(
                    "fmi2Instantiate: internal error (panic: {})",
                    panic_message(&*p)
                ))
            }));
            return std::ptr::null_mut();
        }
    };
    let inst = Box::new(Instance {
        magic: MAGIC,
        inject_panic: name == INJECT_PANIC_NAME,
        name: name_c,
        logger,
        env,
        logging_on: on,
        categories: [on; 3],
        state: Instantiated,
        slave,
    });
    inst.trace(|| {
        format!(
            "fmi2Instantiate: {} ({} variables)",
            inst.slave.kind().model_identifier(FmiVersion::V2),
            inst.slave.table().vars.len()
        )
    });
    Box::into_raw(inst) as fmi2Component
}

/// # Safety
/// FMI 2.0 contract: `c` from `fmi2Instantiate`, not used after this call.
#[no_mangle]
pub unsafe extern "C" fn fmi2FreeInstance(c: fmi2Component) {
    // SAFETY: forwarded FMI contract.
    let Some(inst) = (unsafe { instance(c) }) else {
        return;
    };
    inst.trace(|| "fmi2FreeInstance".into());
    inst.magic = FREED;
    // SAFETY: `c` came from `Box::into_raw` in fmi2Instantiate and is live (magic checked); the
    // magic is cleared first so that a second free is rejected while the memory is readable.
    let boxed = unsafe { Box::from_raw(c as *mut Instance) };
    let _ = catch_unwind(AssertUnwindSafe(move || drop(boxed)));
}

// ---------------------------------------------------------------------------------------------
// Initialisation, termination, reset
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Getting and setting variable values
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// FMU state, directional derivatives: not supported (canGetAndSetFMUstate = false, ...)
// ---------------------------------------------------------------------------------------------

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

// ---------------------------------------------------------------------------------------------
// Co-simulation
// ---------------------------------------------------------------------------------------------

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
