//! Robustness of the hand-written FMI 2.0 interface: every `fmi2*` entry point with NULL or
//! invalid arguments, unknown value references, calls out of order, non-finite inputs, zero or
//! negative steps, caught panics, and 10,000 instantiate/free cycles without memory growth
//! (RSS, and valgrind's leak checker on a child run).
//!
//! The functions are called in-process through the `zmp_fmu` rlib: the same code as the shared
//! library. The logger is a Rust function with the five fixed arguments, cast to the C-variadic
//! `fmi2CallbackLogger` type; the FMU calls it with exactly those five (no variadic arguments),
//! which the x86-64 System V ABI passes identically.

#[path = "../common/mod.rs"]
mod common;

mod arguments;
mod instantiate;
mod memory;
mod panics_and_logging;
mod pointers;

use std::ffi::{c_int, c_void, CStr, CString};
use std::path::PathBuf;
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
