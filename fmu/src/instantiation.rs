//! Inquire version numbers, debug logging, and the creation and destruction of instances:
//! `fmi2GetTypesPlatform`, `fmi2GetVersion`, `fmi2SetDebugLogging`, `fmi2Instantiate`,
//! `fmi2FreeInstance`.

use crate::{
    c_str, call_logger, instance, panic_message, slice_in, with_instance, Instance,
    State::Instantiated, ANY, CATEGORIES, CAT_ERROR, FREED, INJECT_PANIC_NAME, MAGIC,
};
use crate::{
    fmi2Boolean, fmi2CallbackFunctions, fmi2CoSimulation, fmi2Component, fmi2Error, fmi2False,
    fmi2OK, fmi2Status, fmi2String, fmi2Type,
};
use std::ffi::{c_char, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use zmp_fmu_core::{FmiVersion, Kind, Slave};

// ---------------------------------------------------------------------------------------------
// Inquire version numbers, debug logging
// ---------------------------------------------------------------------------------------------

/// The platform types this FMU was compiled with: `"default"` (the standard's headers).
#[no_mangle]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

/// The FMI version of the interface: `"2.0"`.
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
