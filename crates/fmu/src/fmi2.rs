//! The FMI 2.0 C API (`fmi2Functions.h`, `fmi2FunctionTypes.h`, `fmi2TypesPlatform.h` of FMI
//! 2.0.5): every one of its 44 functions, exported unmangled from the `cdylib`.
//!
//! Types as `fmi2TypesPlatform.h` "default" defines them: `fmi2Component`,
//! `fmi2ComponentEnvironment` and `fmi2FMUstate` are `void*`, `fmi2ValueReference` is
//! `unsigned int`, `fmi2Real` `double`, `fmi2Integer` and `fmi2Boolean` `int`, `fmi2String`
//! `const char*`, `fmi2Byte` `char`; the enums (`fmi2Status`, `fmi2Type`, `fmi2StatusKind`)
//! are passed as `int`. `fmi2CallbackFunctions` is `{logger, allocateMemory, freeMemory,
//! stepFinished, componentEnvironment}` (pack 8, i.e. natural alignment on x86-64).
//!
//! Every function:
//! * checks its pointers (null instance, null arrays with a non-zero length, unknown value
//!   references are `fmi2Error`, reported through the logger when there is one);
//! * runs its body inside `catch_unwind`: a panic never crosses the C boundary, it becomes
//!   `fmi2Error` and puts the instance in the error state;
//! * leaves the work to [`Slave`], which is safe Rust.
//!
//! Logging: messages of failing calls (categories `logStatusWarning`, `…Discard`, `…Error`,
//! `…Fatal`) are sent whether or not `loggingOn` was set — a host must learn why a call failed —
//! unless `fmi2SetDebugLogging` switched them off; information messages (`logEvents`) only with
//! logging on. The message is a `printf` format (§2.1.5), so `%` is sent as `%%`, and `#`,
//! the standard's escape for variable references, as `##`.
//!
//! Model Exchange functions and the optional co-simulation capabilities this FMU does not
//! declare (input/output derivatives, asynchronous steps, serialised states, directional
//! derivatives) exist — hosts such as FMPy resolve every symbol at load time — and return
//! `fmi2Error` with a message.
//!
//! # Safety
//!
//! The exported functions are `unsafe extern "C"`: they trust the host to keep the contract of
//! the FMI 2.0 standard — `c` is null or an instance returned by `fmi2Instantiate` and not yet
//! freed, arrays hold the number of elements passed beside them, strings are NUL-terminated,
//! `fmi2FMUstate` values come from `fmi2GetFMUstate` of this library, and one instance is not
//! called from two threads at once. Magic numbers in instances and states catch some (not all)
//! broken pointers.

#![allow(non_snake_case)]
// The contract of every exported function is the module's `# Safety` section: FMI 2.0's.
#![allow(clippy::missing_safety_doc)]

use std::any::Any;
use std::ffi::{CStr, CString, c_char, c_int, c_uint, c_void};
use std::panic::{AssertUnwindSafe, catch_unwind};

use crate::config::{ExportConfig, Prepared, RESOURCE_FILE};
use crate::description::LOG_CATEGORIES;
use crate::slave::{Failure, Slave, Snapshot, Status};

type Fmi2Component = *mut c_void;
type Fmi2ComponentEnvironment = *mut c_void;
type Fmi2FmuState = *mut c_void;
type Fmi2ValueReference = c_uint;
type Fmi2Real = f64;
type Fmi2Integer = c_int;
type Fmi2Boolean = c_int;
type Fmi2String = *const c_char;
type Fmi2Byte = c_char;
type Fmi2Status = c_int;

type Fmi2CallbackLogger = unsafe extern "C" fn(
    Fmi2ComponentEnvironment,
    Fmi2String,
    Fmi2Status,
    Fmi2String,
    Fmi2String,
    ...
);
type Fmi2CallbackAllocateMemory = unsafe extern "C" fn(usize, usize) -> *mut c_void;
type Fmi2CallbackFreeMemory = unsafe extern "C" fn(*mut c_void);
type Fmi2StepFinished = unsafe extern "C" fn(Fmi2ComponentEnvironment, Fmi2Status);

/// `fmi2CallbackFunctions`. Only the logger and the environment are used: the FMU declares
/// `canNotUseMemoryManagementFunctions` and runs synchronously.
#[repr(C)]
pub struct Fmi2CallbackFunctions {
    logger: Option<Fmi2CallbackLogger>,
    _allocate_memory: Option<Fmi2CallbackAllocateMemory>,
    _free_memory: Option<Fmi2CallbackFreeMemory>,
    _step_finished: Option<Fmi2StepFinished>,
    component_environment: Fmi2ComponentEnvironment,
}

const OK: Fmi2Status = Status::Ok as Fmi2Status;
const ERROR: Fmi2Status = Status::Error as Fmi2Status;

/// `fmi2Type`.
const FMI2_CO_SIMULATION: c_int = 1;
/// `fmi2StatusKind`.
const FMI2_LAST_SUCCESSFUL_TIME: c_int = 2;
const FMI2_TERMINATED: c_int = 3;

const INSTANCE_MAGIC: u64 = 0x6169_7273_7573_2d63; // "airsus-c"
const STATE_MAGIC: u64 = 0x6169_7273_7573_2d73; // "airsus-s"

const NO_MODEL_EXCHANGE: &str = "this FMU implements FMI 2.0 for Co-Simulation only; Model Exchange functions are not available";

/// The logger callback with the instance's name and which categories are on.
struct Logger {
    callback: Option<Fmi2CallbackLogger>,
    environment: Fmi2ComponentEnvironment,
    instance_name: CString,
    events: bool,
    warning: bool,
    discard: bool,
    error: bool,
    fatal: bool,
}

impl Logger {
    fn new(
        callback: Option<Fmi2CallbackLogger>,
        environment: Fmi2ComponentEnvironment,
        instance_name: &str,
        logging_on: bool,
    ) -> Self {
        Self {
            callback,
            environment,
            instance_name: c_string(instance_name),
            events: logging_on,
            warning: true,
            discard: true,
            error: true,
            fatal: true,
        }
    }

    fn log(&self, status: Status, message: &str) {
        let (on, category) = match status {
            Status::Ok => (self.events, "logEvents"),
            Status::Warning => (self.warning, "logStatusWarning"),
            Status::Discard => (self.discard, "logStatusDiscard"),
            Status::Error => (self.error, "logStatusError"),
            Status::Fatal => (self.fatal, "logStatusFatal"),
        };
        let Some(callback) = self.callback else {
            return;
        };
        if !on {
            return;
        }
        let text = c_string(&message.replace('%', "%%").replace('#', "##"));
        let category = c_string(category);
        // SAFETY: the host's logger (FMI 2.0 §2.1.5), called with the environment pointer it
        // gave, NUL-terminated strings that live until it returns, and no variadic arguments:
        // `%` in the message is escaped, so the format string consumes none.
        unsafe {
            callback(
                self.environment,
                self.instance_name.as_ptr(),
                status as Fmi2Status,
                category.as_ptr(),
                text.as_ptr(),
            );
        }
    }

    fn set_all(&mut self, on: bool) {
        self.events = on;
        self.warning = on;
        self.discard = on;
        self.error = on;
        self.fatal = on;
    }

    /// False for an unknown category.
    fn set(&mut self, category: &str, on: bool) -> bool {
        match category {
            "logEvents" => self.events = on,
            "logStatusWarning" => self.warning = on,
            "logStatusDiscard" => self.discard = on,
            "logStatusError" => self.error = on,
            "logStatusFatal" => self.fatal = on,
            "logAll" => self.set_all(on),
            _ => return false,
        }
        true
    }
}

struct Instance {
    magic: u64,
    logger: Logger,
    slave: Slave,
}

/// What an `fmi2FMUstate` points to.
struct StateBox {
    magic: u64,
    snapshot: Snapshot,
}

fn c_string(text: &str) -> CString {
    CString::new(text.replace('\0', " ")).unwrap_or_default()
}

fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_owned()
    }
}

/// The instance behind `c`, if it is one.
///
/// # Safety
/// `c` is null or was returned by `fmi2Instantiate` and not yet freed.
unsafe fn instance<'a>(c: Fmi2Component) -> Option<&'a mut Instance> {
    let ptr = c.cast::<Instance>();
    if ptr.is_null() {
        return None;
    }
    // SAFETY: by the caller's contract `ptr` came from `Box::into_raw` in `fmi2Instantiate`
    // and is still allocated; the host never calls one instance from two threads at once.
    let instance = unsafe { &mut *ptr };
    (instance.magic == INSTANCE_MAGIC).then_some(instance)
}

/// The state box behind an `fmi2FMUstate`, if it is one.
///
/// # Safety
/// `state` is null or was returned by `fmi2GetFMUstate` and not yet freed.
unsafe fn state_box<'a>(state: Fmi2FmuState) -> Option<&'a mut StateBox> {
    let ptr = state.cast::<StateBox>();
    if ptr.is_null() {
        return None;
    }
    // SAFETY: by the caller's contract `ptr` came from `Box::into_raw` in `fmi2GetFMUstate`.
    let state = unsafe { &mut *ptr };
    (state.magic == STATE_MAGIC).then_some(state)
}

/// `n` elements at `ptr` (an empty slice for `n == 0`, whatever `ptr` is).
///
/// # Safety
/// A non-null `ptr` points to `n` initialised elements that outlive the returned slice.
unsafe fn slice<'a, T>(ptr: *const T, n: usize, what: &str) -> Result<&'a [T], Failure> {
    if n == 0 {
        return Ok(&[]);
    }
    if ptr.is_null() {
        return Err(Failure::error(format!(
            "argument `{what}` is a null pointer but its length is {n}"
        )));
    }
    // SAFETY: non-null, and by the caller's contract `n` valid elements.
    Ok(unsafe { std::slice::from_raw_parts(ptr, n) })
}

/// `n` writable elements at `ptr`.
///
/// # Safety
/// A non-null `ptr` points to `n` elements the callee may write and nobody else reads meanwhile.
unsafe fn slice_mut<'a, T>(ptr: *mut T, n: usize, what: &str) -> Result<&'a mut [T], Failure> {
    if n == 0 {
        return Ok(&mut []);
    }
    if ptr.is_null() {
        return Err(Failure::error(format!(
            "argument `{what}` is a null pointer but its length is {n}"
        )));
    }
    // SAFETY: non-null, and by the caller's contract `n` writable elements.
    Ok(unsafe { std::slice::from_raw_parts_mut(ptr, n) })
}

/// A NUL-terminated UTF-8 string, `None` for null or invalid UTF-8.
///
/// # Safety
/// A non-null `ptr` points to a NUL-terminated string that outlives the returned `&str`.
unsafe fn text<'a>(ptr: Fmi2String) -> Option<&'a str> {
    if ptr.is_null() {
        return None;
    }
    // SAFETY: non-null and NUL-terminated by the caller's contract.
    unsafe { CStr::from_ptr(ptr) }.to_str().ok()
}

/// Runs `body` on the instance behind `c` and turns the outcome into a status: an unknown
/// instance is `fmi2Error`; a failure is logged and its status returned; a panic is caught,
/// logged, and puts the instance in the error state.
///
/// # Safety
/// `c` is null or a live instance of this library.
unsafe fn call(
    c: Fmi2Component,
    function: &str,
    body: impl FnOnce(&mut Instance) -> Result<(), Failure>,
) -> Fmi2Status {
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: forwarded from this function's contract.
        let Some(instance) = (unsafe { instance(c) }) else {
            return ERROR;
        };
        match body(&mut *instance) {
            Ok(()) => OK,
            Err(failure) => {
                let message = if failure.message.starts_with(function) {
                    failure.message
                } else {
                    format!("{function}: {}", failure.message)
                };
                instance.logger.log(failure.status, &message);
                failure.status as Fmi2Status
            }
        }
    }));
    match outcome {
        Ok(status) => status,
        Err(payload) => {
            let message = format!(
                "{function}: internal error (Rust panic: {}); the instance is in the error state",
                panic_message(payload.as_ref())
            );
            // A second panic (in the logger's string handling) must not escape either.
            let _ = catch_unwind(AssertUnwindSafe(|| {
                // SAFETY: as above; the borrow taken before the panic ended with the unwind.
                if let Some(instance) = unsafe { instance(c) } {
                    let failure = instance.slave.fail(Failure::error(message));
                    instance.logger.log(Status::Error, &failure.message);
                }
            }));
            ERROR
        }
    }
}

/// `fmi2Error` with `why` for a function this FMU does not support.
///
/// # Safety
/// `c` is null or a live instance of this library.
unsafe fn unsupported(c: Fmi2Component, function: &str, why: &str) -> Fmi2Status {
    let why = why.to_owned();
    // SAFETY: forwarded from this function's contract.
    unsafe { call(c, function, move |_| Err(Failure::error(why))) }
}

// ---------------------------------------------------------------------------------------------
// Inquire platform and version number of the header files

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetTypesPlatform() -> *const c_char {
    c"default".as_ptr()
}

#[unsafe(no_mangle)]
pub extern "C" fn fmi2GetVersion() -> *const c_char {
    c"2.0".as_ptr()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetDebugLogging(
    c: Fmi2Component,
    logging_on: Fmi2Boolean,
    n_categories: usize,
    categories: *const Fmi2String,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        let on = logging_on != 0;
        if n_categories == 0 {
            instance.logger.set_all(on);
            return Ok(());
        }
        // SAFETY: `n_categories` strings by the module's contract.
        let names = unsafe { slice(categories, n_categories, "categories") }?;
        for &name in names {
            // SAFETY: each a NUL-terminated string by the module's contract.
            let Some(name) = (unsafe { text(name) }) else {
                return Err(Failure::error("a category is a null pointer or not UTF-8"));
            };
            if !instance.logger.set(name, on) {
                let known: Vec<&str> = LOG_CATEGORIES.iter().map(|(n, _)| *n).collect();
                return Err(Failure::error(format!(
                    "unknown log category `{name}`; the categories are: {}",
                    known.join(", ")
                )));
            }
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetDebugLogging", body) }
}

// ---------------------------------------------------------------------------------------------
// Creation and destruction of FMU instances

fn refuse(logger: &Logger, message: &str) -> Fmi2Component {
    logger.log(Status::Error, &format!("fmi2Instantiate: {message}"));
    std::ptr::null_mut()
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Instantiate(
    instance_name: Fmi2String,
    fmu_type: c_int,
    fmu_guid: Fmi2String,
    fmu_resource_location: Fmi2String,
    functions: *const Fmi2CallbackFunctions,
    _visible: Fmi2Boolean,
    logging_on: Fmi2Boolean,
) -> Fmi2Component {
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: null or a callback struct valid during this call (FMI 2.0 §2.1.5); only the
        // logger pointer and the environment are copied out.
        let callbacks = unsafe { functions.as_ref() };
        let (callback, environment) = callbacks.map_or((None, std::ptr::null_mut()), |f| {
            (f.logger, f.component_environment)
        });
        // SAFETY: null or NUL-terminated by the module's contract.
        let name = unsafe { text(instance_name) }.unwrap_or("");
        let logger = Logger::new(
            callback,
            environment,
            if name.trim().is_empty() {
                crate::MODEL_IDENTIFIER
            } else {
                name
            },
            logging_on != 0,
        );
        if name.trim().is_empty() {
            return refuse(&logger, "instanceName must be a non-empty string");
        }
        if fmu_type != FMI2_CO_SIMULATION {
            return refuse(
                &logger,
                &format!("fmuType = {fmu_type}: {NO_MODEL_EXCHANGE}"),
            );
        }
        // SAFETY: null or NUL-terminated by the module's contract.
        let Some(guid) = (unsafe { text(fmu_guid) }) else {
            return refuse(&logger, "fmuGUID is null or not UTF-8");
        };
        // SAFETY: null or NUL-terminated by the module's contract.
        let Some(location) = (unsafe { text(fmu_resource_location) }) else {
            return refuse(&logger, "fmuResourceLocation is null or not UTF-8");
        };
        let path = match crate::uri::resource_file(location, RESOURCE_FILE) {
            Ok(path) => path,
            Err(reason) => return refuse(&logger, &reason),
        };
        let prepared = std::fs::read_to_string(&path)
            .map_err(|e| format!("reading {}: {e}", path.display()))
            .and_then(|text| ExportConfig::from_toml(&text).map_err(|e| e.to_string()))
            .and_then(|config| Prepared::new(config).map_err(|e| e.to_string()));
        let prepared = match prepared {
            Ok(p) => p,
            Err(reason) => {
                return refuse(&logger, &format!("{}: {reason}", path.display()));
            }
        };
        if prepared.guid != guid {
            return refuse(
                &logger,
                &format!(
                    "GUID mismatch: the host passed {guid}, but {} and this library ({}) give {}: modelDescription.xml, resources and binary come from different exports — export the FMU again with `airsus fmu`",
                    path.display(),
                    crate::BUILD_MARKER,
                    prepared.guid
                ),
            );
        }
        let summary = format!(
            "instantiated model {} with {} parameters from {}",
            prepared.config.model,
            prepared.model.parameter_info().len(),
            path.display()
        );
        let instance = Box::new(Instance {
            magic: INSTANCE_MAGIC,
            logger,
            slave: Slave::new(prepared),
        });
        instance.logger.log(Status::Ok, &summary);
        Box::into_raw(instance).cast::<c_void>()
    }));
    outcome.unwrap_or(std::ptr::null_mut())
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeInstance(c: Fmi2Component) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: the module's contract.
        if unsafe { instance(c) }.is_none() {
            return;
        }
        let ptr = c.cast::<Instance>();
        // SAFETY: `ptr` is a live instance from `Box::into_raw` (checked above); the magic
        // number is cleared first so that a second free of the same pointer is more likely
        // caught than not.
        unsafe {
            (*ptr).magic = 0;
            drop(Box::from_raw(ptr));
        }
    }));
}

// ---------------------------------------------------------------------------------------------
// Enter and exit initialization mode, terminate and reset

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetupExperiment(
    c: Fmi2Component,
    tolerance_defined: Fmi2Boolean,
    tolerance: Fmi2Real,
    start_time: Fmi2Real,
    stop_time_defined: Fmi2Boolean,
    stop_time: Fmi2Real,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        instance.slave.setup_experiment(
            (tolerance_defined != 0).then_some(tolerance),
            start_time,
            (stop_time_defined != 0).then_some(stop_time),
        )
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetupExperiment", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2EnterInitializationMode(c: Fmi2Component) -> Fmi2Status {
    let body = |instance: &mut Instance| instance.slave.enter_initialization_mode();
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2EnterInitializationMode", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2ExitInitializationMode(c: Fmi2Component) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        instance.slave.exit_initialization_mode()?;
        let state = instance.slave.state().unwrap_or(&[]);
        let message = format!(
            "initialised in static equilibrium at t = {} s: state {state:?}",
            instance.slave.time()
        );
        instance.logger.log(Status::Ok, &message);
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2ExitInitializationMode", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Terminate(c: Fmi2Component) -> Fmi2Status {
    let body = |instance: &mut Instance| instance.slave.terminate();
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2Terminate", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2Reset(c: Fmi2Component) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        instance.slave.reset();
        instance
            .logger
            .log(Status::Ok, "reset to the instantiated state");
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2Reset", body) }
}

// ---------------------------------------------------------------------------------------------
// Getting and setting variable values

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: room for `nvr` values by the module's contract.
        let values = unsafe { slice_mut(value, nvr, "value") }?;
        for (r, v) in vrs.iter().zip(values.iter_mut()) {
            *v = instance.slave.get_real(*r)?;
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetReal", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetInteger(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *mut Fmi2Integer,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: room for `nvr` values by the module's contract.
        let values = unsafe { slice_mut(value, nvr, "value") }?;
        for (r, v) in vrs.iter().zip(values.iter_mut()) {
            *v = instance.slave.get_integer(*r)?;
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetInteger", body) }
}

/// Booleans and strings: the FMU has none, so only empty requests succeed.
fn no_variables_of(kind: &str, vrs: &[Fmi2ValueReference]) -> Result<(), Failure> {
    match vrs.first() {
        None => Ok(()),
        Some(r) => Err(Failure::error(format!(
            "value reference {r}: this FMU has no {kind} variables"
        ))),
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2Boolean,
) -> Fmi2Status {
    let body = |_: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        no_variables_of("Boolean", vrs)
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetBoolean", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetString(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    let body = |_: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        no_variables_of("String", vrs)
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetString", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetReal(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Real,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: `nvr` values by the module's contract.
        let values = unsafe { slice(value, nvr, "value") }?;
        for (r, v) in vrs.iter().zip(values) {
            instance.slave.set_real(*r, *v)?;
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetReal", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetInteger(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    value: *const Fmi2Integer,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        // SAFETY: `nvr` values by the module's contract.
        let values = unsafe { slice(value, nvr, "value") }?;
        for (r, v) in vrs.iter().zip(values) {
            instance.slave.set_integer(*r, *v)?;
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetInteger", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetBoolean(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2Boolean,
) -> Fmi2Status {
    let body = |_: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        no_variables_of("Boolean", vrs)
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetBoolean", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetString(
    c: Fmi2Component,
    vr: *const Fmi2ValueReference,
    nvr: usize,
    _value: *const Fmi2String,
) -> Fmi2Status {
    let body = |_: &mut Instance| -> Result<(), Failure> {
        // SAFETY: `nvr` value references by the module's contract.
        let vrs = unsafe { slice(vr, nvr, "vr") }?;
        no_variables_of("String", vrs)
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetString", body) }
}

// ---------------------------------------------------------------------------------------------
// Getting and setting the internal FMU state

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetFMUstate(
    c: Fmi2Component,
    fmu_state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        if fmu_state.is_null() {
            return Err(Failure::error("FMUstate is a null pointer"));
        }
        let snapshot = instance.slave.snapshot();
        // SAFETY: non-null, pointing to the host's `fmi2FMUstate` variable.
        let current = unsafe { *fmu_state };
        if current.is_null() {
            let boxed = Box::new(StateBox {
                magic: STATE_MAGIC,
                snapshot,
            });
            // SAFETY: as above; the host owns the new state until fmi2FreeFMUstate.
            unsafe { *fmu_state = Box::into_raw(boxed).cast::<c_void>() };
        } else {
            // SAFETY: a non-null `*FMUstate` was returned by fmi2GetFMUstate and not freed
            // (FMI 2.0 §2.1.8); it is reused.
            let Some(existing) = (unsafe { state_box(current) }) else {
                return Err(Failure::error(
                    "*FMUstate is neither null nor a state of this FMU",
                ));
            };
            existing.snapshot = snapshot;
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetFMUstate", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetFMUstate(c: Fmi2Component, fmu_state: Fmi2FmuState) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        // SAFETY: a state from fmi2GetFMUstate by the module's contract (checked by its magic).
        let Some(state) = (unsafe { state_box(fmu_state) }) else {
            return Err(Failure::error(
                "FMUstate is null or not a state of this FMU",
            ));
        };
        instance.slave.restore(&state.snapshot)?;
        instance.logger.log(
            Status::Ok,
            &format!("state restored at t = {} s", instance.slave.time()),
        );
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2SetFMUstate", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2FreeFMUstate(
    c: Fmi2Component,
    fmu_state: *mut Fmi2FmuState,
) -> Fmi2Status {
    let body = |_: &mut Instance| -> Result<(), Failure> {
        if fmu_state.is_null() {
            return Ok(());
        }
        // SAFETY: non-null, pointing to the host's `fmi2FMUstate` variable.
        let current = unsafe { *fmu_state };
        if current.is_null() {
            return Ok(());
        }
        // SAFETY: a state from fmi2GetFMUstate by the module's contract (checked by its magic).
        if unsafe { state_box(current) }.is_none() {
            return Err(Failure::error("*FMUstate is not a state of this FMU"));
        }
        let ptr = current.cast::<StateBox>();
        // SAFETY: `ptr` came from `Box::into_raw` in fmi2GetFMUstate (checked above) and is
        // released once: the host's variable is nulled.
        unsafe {
            (*ptr).magic = 0;
            drop(Box::from_raw(ptr));
            *fmu_state = std::ptr::null_mut();
        }
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2FreeFMUstate", body) }
}

const NO_SERIALIZATION: &str = "canSerializeFMUstate is false: FMU states cannot be serialised";

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
    c: Fmi2Component,
    _fmu_state: Fmi2FmuState,
    _size: *mut usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2SerializedFMUstateSize", NO_SERIALIZATION) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SerializeFMUstate(
    c: Fmi2Component,
    _fmu_state: Fmi2FmuState,
    _serialized_state: *mut Fmi2Byte,
    _size: usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2SerializeFMUstate", NO_SERIALIZATION) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
    c: Fmi2Component,
    _serialized_state: *const Fmi2Byte,
    _size: usize,
    _fmu_state: *mut Fmi2FmuState,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2DeSerializeFMUstate", NO_SERIALIZATION) }
}

// ---------------------------------------------------------------------------------------------
// Getting partial derivatives

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
    c: Fmi2Component,
    _v_unknown_ref: *const Fmi2ValueReference,
    _n_unknown: usize,
    _v_known_ref: *const Fmi2ValueReference,
    _n_known: usize,
    _dv_known: *const Fmi2Real,
    _dv_unknown: *mut Fmi2Real,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe {
        unsupported(
            c,
            "fmi2GetDirectionalDerivative",
            "providesDirectionalDerivative is false",
        )
    }
}

// ---------------------------------------------------------------------------------------------
// Model Exchange (not provided: fmi2Instantiate refuses fmi2ModelExchange)

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2EnterEventMode(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2EnterEventMode", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2NewDiscreteStates(
    c: Fmi2Component,
    _event_info: *mut c_void,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2NewDiscreteStates", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2EnterContinuousTimeMode", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
    c: Fmi2Component,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
    _enter_event_mode: *mut Fmi2Boolean,
    _terminate_simulation: *mut Fmi2Boolean,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2CompletedIntegratorStep", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetTime(c: Fmi2Component, _time: Fmi2Real) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2SetTime", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetContinuousStates(
    c: Fmi2Component,
    _x: *const Fmi2Real,
    _nx: usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2SetContinuousStates", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetDerivatives(
    c: Fmi2Component,
    _derivatives: *mut Fmi2Real,
    _nx: usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2GetDerivatives", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetEventIndicators(
    c: Fmi2Component,
    _event_indicators: *mut Fmi2Real,
    _ni: usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2GetEventIndicators", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetContinuousStates(
    c: Fmi2Component,
    _x: *mut Fmi2Real,
    _nx: usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2GetContinuousStates", NO_MODEL_EXCHANGE) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetNominalsOfContinuousStates(
    c: Fmi2Component,
    _x_nominal: *mut Fmi2Real,
    _nx: usize,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe { unsupported(c, "fmi2GetNominalsOfContinuousStates", NO_MODEL_EXCHANGE) }
}

// ---------------------------------------------------------------------------------------------
// Co-Simulation

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *const Fmi2Real,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe {
        unsupported(
            c,
            "fmi2SetRealInputDerivatives",
            "canInterpolateInputs is false: inputs are held over each step (the road moves at road_rate_mm_s)",
        )
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
    c: Fmi2Component,
    _vr: *const Fmi2ValueReference,
    _nvr: usize,
    _order: *const Fmi2Integer,
    _value: *mut Fmi2Real,
) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe {
        unsupported(
            c,
            "fmi2GetRealOutputDerivatives",
            "maxOutputDerivativeOrder is 0",
        )
    }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2DoStep(
    c: Fmi2Component,
    current_communication_point: Fmi2Real,
    communication_step_size: Fmi2Real,
    _no_set_fmu_state_prior_to_current_point: Fmi2Boolean,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        instance
            .slave
            .do_step(current_communication_point, communication_step_size)
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2DoStep", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2CancelStep(c: Fmi2Component) -> Fmi2Status {
    // SAFETY: the module's contract.
    unsafe {
        unsupported(
            c,
            "fmi2CancelStep",
            "fmi2DoStep runs synchronously and never returns fmi2Pending",
        )
    }
}

/// `fmi2Discard` for a status this slave cannot give (FMI 2.0 §4.2.3).
fn no_status(function: &str, kind: c_int) -> Result<(), Failure> {
    Err(Failure::discard(format!(
        "{function}: status kind {kind} is not available (the slave runs synchronously)"
    )))
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStatus(
    c: Fmi2Component,
    kind: c_int,
    _value: *mut Fmi2Status,
) -> Fmi2Status {
    let body = |_: &mut Instance| no_status("fmi2GetStatus", kind);
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetStatus", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetRealStatus(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Real,
) -> Fmi2Status {
    let body = |instance: &mut Instance| -> Result<(), Failure> {
        if kind != FMI2_LAST_SUCCESSFUL_TIME {
            return no_status("fmi2GetRealStatus", kind);
        }
        // SAFETY: one writable value by the module's contract.
        let out = unsafe { slice_mut(value, 1, "value") }?;
        out[0] = instance.slave.time();
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetRealStatus", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetIntegerStatus(
    c: Fmi2Component,
    kind: c_int,
    _value: *mut Fmi2Integer,
) -> Fmi2Status {
    let body = |_: &mut Instance| no_status("fmi2GetIntegerStatus", kind);
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetIntegerStatus", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetBooleanStatus(
    c: Fmi2Component,
    kind: c_int,
    value: *mut Fmi2Boolean,
) -> Fmi2Status {
    let body = |_: &mut Instance| -> Result<(), Failure> {
        if kind != FMI2_TERMINATED {
            return no_status("fmi2GetBooleanStatus", kind);
        }
        // SAFETY: one writable value by the module's contract.
        let out = unsafe { slice_mut(value, 1, "value") }?;
        // The slave never asks to end the simulation.
        out[0] = 0;
        Ok(())
    };
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetBooleanStatus", body) }
}

#[unsafe(no_mangle)]
pub unsafe extern "C" fn fmi2GetStringStatus(
    c: Fmi2Component,
    kind: c_int,
    _value: *mut Fmi2String,
) -> Fmi2Status {
    let body = |_: &mut Instance| no_status("fmi2GetStringStatus", kind);
    // SAFETY: the module's contract.
    unsafe { call(c, "fmi2GetStringStatus", body) }
}

/// Marks the library for `airsus fmu`, which looks for [`crate::BUILD_MARKER`] in a library
/// before packing it. Exported, so that no linker drops it.
#[unsafe(no_mangle)]
pub static AIRSUS_FMU_BUILD: &[u8] = crate::BUILD_MARKER.as_bytes();

#[cfg(test)]
mod tests {
    //! The C API driven from Rust as a host would drive it (without a logger: a C-variadic
    //! callback cannot be written in stable Rust; FMPy's tests in tools/fmu cover logging).

    use super::*;
    use crate::config::DEFAULT_INITIAL_HEIGHT_MM;
    use crate::description::vr;
    use airsus_data::TruckParameters;

    struct Unzipped {
        _dir: tempfile::TempDir,
        uri: CString,
        guid: CString,
    }

    fn unzipped(model: &str) -> Unzipped {
        let config = ExportConfig::new(
            model,
            &TruckParameters::reference(),
            DEFAULT_INITIAL_HEIGHT_MM,
        )
        .unwrap();
        let prepared = Prepared::new(config).unwrap();
        let dir = tempfile::tempdir().unwrap();
        let resources = dir.path().join("resources");
        std::fs::create_dir(&resources).unwrap();
        std::fs::write(resources.join(RESOURCE_FILE), prepared.config.to_toml()).unwrap();
        Unzipped {
            uri: CString::new(format!("file://{}", resources.display())).unwrap(),
            guid: CString::new(prepared.guid.clone()).unwrap(),
            _dir: dir,
        }
    }

    fn instantiate(fmu: &Unzipped, fmu_type: c_int) -> Fmi2Component {
        // SAFETY: valid strings, no callbacks.
        unsafe {
            fmi2Instantiate(
                c"test".as_ptr(),
                fmu_type,
                fmu.guid.as_ptr(),
                fmu.uri.as_ptr(),
                std::ptr::null(),
                0,
                0,
            )
        }
    }

    #[test]
    fn a_host_session_runs_and_misuse_is_an_error_not_a_crash() {
        let fmu = unzipped("m2");
        assert!(instantiate(&fmu, 0).is_null(), "Model Exchange is refused");
        let c = instantiate(&fmu, FMI2_CO_SIMULATION);
        assert!(!c.is_null());
        let other = instantiate(&fmu, FMI2_CO_SIMULATION);
        assert!(!other.is_null(), "several instances at once");
        // SAFETY: `c` and `other` are live instances; arrays match their lengths.
        unsafe {
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 1, 10.0), OK);
            assert_eq!(fmi2EnterInitializationMode(c), OK);
            assert_eq!(fmi2ExitInitializationMode(c), OK);
            let refs = [vr::HEIGHT_MM, vr::PRESSURE_KPA];
            let mut out = [0.0; 2];
            assert_eq!(fmi2GetReal(c, refs.as_ptr(), 2, out.as_mut_ptr()), OK);
            assert!((out[0] - DEFAULT_INITIAL_HEIGHT_MM).abs() < 1e-6, "{out:?}");
            let fill = [1];
            assert_eq!(
                fmi2SetInteger(c, [vr::VALVE].as_ptr(), 1, fill.as_ptr()),
                OK
            );
            assert_eq!(fmi2DoStep(c, 0.0, 0.1, 1), OK);
            assert_eq!(fmi2DoStep(c, 0.1, 0.9, 1), OK);
            let before = out[1];
            assert_eq!(fmi2GetReal(c, refs.as_ptr(), 2, out.as_mut_ptr()), OK);
            assert!(out[1] > before, "filling raises the pressure: {out:?}");
            // Misuse.
            assert_eq!(fmi2GetReal(c, std::ptr::null(), 2, out.as_mut_ptr()), ERROR);
            assert_eq!(
                fmi2GetReal(std::ptr::null_mut(), refs.as_ptr(), 2, out.as_mut_ptr()),
                ERROR
            );
            assert_eq!(
                fmi2SetInteger(c, [vr::VALVE].as_ptr(), 1, [7].as_ptr()),
                ERROR
            );
            assert_eq!(fmi2DoStep(c, 1.0, 20.0, 1), ERROR, "past stopTime");
            assert_eq!(fmi2EnterEventMode(c), ERROR);
            assert_eq!(
                fmi2GetBoolean(c, std::ptr::null(), 0, std::ptr::null_mut()),
                OK
            );
            let mut last = 0.0;
            assert_eq!(
                fmi2GetRealStatus(c, FMI2_LAST_SUCCESSFUL_TIME, &mut last),
                OK
            );
            assert!((last - 1.0).abs() < 1e-12);
            // FMU state round trip.
            let mut state: Fmi2FmuState = std::ptr::null_mut();
            assert_eq!(fmi2GetFMUstate(c, &mut state), OK);
            assert_eq!(fmi2DoStep(c, 1.0, 1.0, 1), OK);
            assert_eq!(fmi2SetFMUstate(c, state), OK);
            assert_eq!(
                fmi2GetRealStatus(c, FMI2_LAST_SUCCESSFUL_TIME, &mut last),
                OK
            );
            assert!((last - 1.0).abs() < 1e-12);
            assert_eq!(fmi2FreeFMUstate(c, &mut state), OK);
            assert!(state.is_null());
            assert_eq!(fmi2Terminate(c), OK);
            assert_eq!(fmi2Reset(c), OK);
            assert_eq!(fmi2SetupExperiment(c, 0, 0.0, 0.0, 0, 0.0), OK);
            fmi2FreeInstance(c);
            fmi2FreeInstance(std::ptr::null_mut());
            fmi2FreeInstance(other);
        }
    }

    #[test]
    fn a_wrong_guid_or_missing_resources_refuse_instantiation() {
        let fmu = unzipped("m1");
        let wrong = Unzipped {
            guid: c"{00000000-0000-0000-0000-000000000001}".to_owned(),
            uri: fmu.uri.clone(),
            _dir: tempfile::tempdir().unwrap(),
        };
        assert!(instantiate(&wrong, FMI2_CO_SIMULATION).is_null());
        let nowhere = Unzipped {
            guid: fmu.guid.clone(),
            uri: c"file:///nonexistent/resources".to_owned(),
            _dir: tempfile::tempdir().unwrap(),
        };
        assert!(instantiate(&nowhere, FMI2_CO_SIMULATION).is_null());
    }
}
