//! `fmi2Instantiate` with bad arguments (type, GUID, resource location, callbacks, model
//! file): NULL and a logged message.

use crate::common;
use crate::Fixture;
use std::ffi::{c_char, CString};
use std::ptr::{null, null_mut};
use zmp_fmu::*;
use zmp_fmu_core::{FmiVersion, Kind};

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
