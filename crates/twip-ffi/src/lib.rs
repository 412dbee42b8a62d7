//! twip-ffi: a C ABI over twip-core's `f32` controllers and the firmware-side pieces a
//! self-balancing robot runs, for the same controller code on the robot as in simulation.
//!
//! - `#![no_std]`, no allocation: every state lives in a struct the caller owns (a global
//!   or a stack variable in C), sized by the header's `TWIP_*_WORDS`.
//! - Each thing has `twip_X_init(state, config)`, then `twip_X_update(...)` once per loop
//!   and `twip_X_reset(state)`. Configurations are plain C structs in SI units
//!   (`twip export` writes them in firmware units, each converted next to its value).
//! - No panic crosses the boundary: every function returns a [`TwipStatus`] code, checks its
//!   pointers, and refuses a state that was not initialised or a non-finite input. A
//!   controller or tilt update, or an encoder read, that overflows is refused too, and leaves
//!   the state as it was.
//!
//! The header `include/twip.h` is generated from these declarations by cbindgen and kept
//! in the repository; `tests/header.rs` fails when the two differ.
#![no_std]

#[cfg(feature = "std")]
extern crate std;

pub mod config;
pub mod controllers;
pub mod firmware;
#[cfg(feature = "std")]
pub mod replay;
mod slot;

pub use config::*;
pub use controllers::*;
pub use firmware::*;

/// What every function returns: `TWIP_OK` (0) or a negative error code.
pub type TwipStatus = i32;
/// Done.
pub const TWIP_OK: TwipStatus = 0;
/// A pointer argument was NULL.
pub const TWIP_ERR_NULL: TwipStatus = -1;
/// A configuration value or an argument is outside its domain (negative period or `dt`,
/// inconsistent sets...).
pub const TWIP_ERR_INVALID: TwipStatus = -2;
/// An input (measurement, reference, time) is NaN or infinite; the outputs are untouched.
pub const TWIP_ERR_NOT_FINITE: TwipStatus = -3;
/// The state was not initialised by its `twip_X_init` (or its init failed).
pub const TWIP_ERR_NOT_INITIALISED: TwipStatus = -4;
/// A controller update with finite inputs whose command or carried state (integrator,
/// adaptive weights) came out NaN or infinite (likewise a tilt filter's estimate or state,
/// an encoder read's speed), as a finite but absurd reading (a sensor
/// glitch near f32's limit, 3e38) makes it: refused, with the state unchanged (as before the call) and
/// the outputs untouched, so the next ordinary update answers as if this one never happened.
pub const TWIP_ERR_OVERFLOW: TwipStatus = -5;
/// A controller configuration written for another version of the C ABI than the library's
/// (its `abi_version` is not `TWIP_ABI_VERSION`): refused before any other field is read,
/// since its fields may lie elsewhere (re-export it with this twip).
pub const TWIP_ERR_ABI: TwipStatus = -6;

/// The version of the C ABI: the layout of the configurations and states. It goes up with
/// every change to them; each controller configuration starts with the version it was
/// written for (`abi_version`), which `twip_X_init` checks. Version 2 gave the sliding-mode
/// configuration its fuzzy grids (and every controller configuration its `abi_version`).
pub const TWIP_ABI_VERSION: i32 = 2;

/// The C ABI version of this library, for a firmware to compare with its header's
/// `TWIP_ABI_VERSION` at start-up (a header and a library of two versions disagree on sizes).
#[no_mangle]
pub extern "C" fn twip_abi_version() -> i32 {
    TWIP_ABI_VERSION
}

/// A short English description of a status code (a static, NUL-terminated string).
#[no_mangle]
pub extern "C" fn twip_status_text(status: TwipStatus) -> *const core::ffi::c_char {
    let text: &'static core::ffi::CStr = match status {
        TWIP_OK => c"ok",
        TWIP_ERR_NULL => c"a pointer argument is NULL",
        TWIP_ERR_INVALID => c"a configuration value or argument is out of its domain",
        TWIP_ERR_NOT_FINITE => c"an input is NaN or infinite",
        TWIP_ERR_NOT_INITIALISED => c"the state was not initialised",
        TWIP_ERR_OVERFLOW => c"the update overflowed; the state is unchanged",
        TWIP_ERR_ABI => c"the configuration was written for another version of the C ABI",
        _ => c"unknown status",
    };
    text.as_ptr()
}

#[cfg(all(feature = "panic-halt", not(feature = "std"), not(test)))]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    loop {}
}
