//! The four controller families: `twip_X_init`, `twip_X_update`, `twip_X_reset` on a
//! caller-owned `TwipX` state. The 2-DOF controllers (LQR, fuzzy) measure
//! y = [φ, φ̇, θ, θ̇] [rad, rad/s] and follow a [`TwipSpeedRef`]; the 3-DOF trackers (PID,
//! sliding mode) measure y = [x, y, ψ, φ, φ̇, v, ω] [m, m, rad, rad, rad/s, m/s, rad/s] and
//! follow a [`TwipPlanarRef`]. Call `update` once per `period` with the time `t` [s].
use core::slice;

use nalgebra::SVector;
use twip_core::control::fuzzy::FuzzyController;
use twip_core::control::lqr::LqrController;
use twip_core::control::pid::PidTracker;
use twip_core::control::reference::SpeedRef;
use twip_core::control::smc::SmcTracker;
use twip_core::control::trajectory::PlanarRef;
use twip_core::control::Controller;
use twip_core::TwipError;

use crate::config::{TwipFuzzyConfig, TwipLqrConfig, TwipPidConfig, TwipSmcConfig, Versioned};
use crate::slot::{self, fits};
use crate::{TwipStatus, TWIP_ABI_VERSION, TWIP_ERR_ABI, TWIP_ERR_INVALID, TWIP_ERR_NOT_FINITE, TWIP_ERR_NULL, TWIP_ERR_OVERFLOW, TWIP_OK};

/// The wheel reference of the 2-DOF controllers: angle θ_ref [rad] and speed θ̇_ref [rad/s].
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipSpeedRef {
    pub theta: f32,
    pub theta_dot: f32,
}

/// The planar reference of the 3-DOF trackers: pose, speeds and accelerations.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TwipPlanarRef {
    pub x: f32,
    pub y: f32,
    pub psi: f32,
    pub v: f32,
    pub omega: f32,
    pub v_dot: f32,
    pub omega_dot: f32,
}

/// A C reference that converts to the core's, refusing NaN and infinities.
pub trait CReference: Copy {
    type Core;
    fn to_core(self) -> Option<Self::Core>;
}

fn all_finite(values: &[f32]) -> bool {
    values.iter().all(|v| v.is_finite())
}

impl CReference for TwipSpeedRef {
    type Core = SpeedRef<f32>;
    fn to_core(self) -> Option<SpeedRef<f32>> {
        all_finite(&[self.theta, self.theta_dot]).then_some(SpeedRef { theta: self.theta, theta_dot: self.theta_dot })
    }
}

impl CReference for TwipPlanarRef {
    type Core = PlanarRef<f32>;
    fn to_core(self) -> Option<PlanarRef<f32>> {
        let Self { x, y, psi, v, omega, v_dot, omega_dot } = self;
        all_finite(&[x, y, psi, v, omega, v_dot, omega_dot]).then_some(PlanarRef { x, y, psi, v, omega, v_dot, omega_dot })
    }
}

/// A controller the C ABI drives: it says whether what it carries to its next update
/// (integrators, adaptive weights) is finite, so that an update that overflowed can be undone.
pub trait Carried {
    fn state_is_finite(&self) -> bool;
}

impl Carried for LqrController<f32> {
    fn state_is_finite(&self) -> bool {
        LqrController::state_is_finite(self)
    }
}

impl Carried for FuzzyController<f32> {
    fn state_is_finite(&self) -> bool {
        FuzzyController::state_is_finite(self)
    }
}

impl Carried for PidTracker<f32> {
    fn state_is_finite(&self) -> bool {
        PidTracker::state_is_finite(self)
    }
}

impl Carried for SmcTracker<f32> {
    fn state_is_finite(&self) -> bool {
        SmcTracker::state_is_finite(self)
    }
}

/// As [`init`], for a controller's configuration: one of another ABI version is refused
/// (`TWIP_ERR_ABI`) having read only its first field, since a stale firmware's struct may be
/// shorter than this library's.
///
/// # Safety
/// `words` is NULL or caller-owned storage that fits a `V`; `config` is NULL or points to at
/// least its version, and to a valid `C` when that version is this library's.
unsafe fn init_versioned<C: Versioned, V>(
    words: *mut u64,
    tag: u64,
    config: *const C,
    build: impl FnOnce(&C) -> Result<V, TwipError>,
) -> TwipStatus {
    if !(words.is_null() || config.is_null()) && config.cast::<i32>().read() != TWIP_ABI_VERSION {
        slot::clear(words);
        return TWIP_ERR_ABI;
    }
    init(words, tag, config, build)
}

/// Builds `V` from the configuration at `config` into the words at `words`.
///
/// # Safety
/// `words` is NULL or caller-owned storage that fits a `V`; `config` is NULL or valid.
pub(crate) unsafe fn init<C, V>(
    words: *mut u64,
    tag: u64,
    config: *const C,
    build: impl FnOnce(&C) -> Result<V, TwipError>,
) -> TwipStatus {
    if words.is_null() || config.is_null() {
        return TWIP_ERR_NULL;
    }
    match build(&*config) {
        Ok(value) => slot::put(words, tag, value),
        Err(_) => {
            slot::clear(words);
            TWIP_ERR_INVALID
        }
    }
}

/// One update of the controller in the words at `words`: `u` gets `NU` commands. An update
/// whose command or carried state is not finite is undone (`TWIP_ERR_OVERFLOW`).
///
/// # Safety
/// Pointers are NULL or valid: `y` for `NX` floats, `u` for `NU`, `words` as in [`init`].
pub(crate) unsafe fn update<V, R, const NX: usize, const NU: usize>(
    words: *mut u64,
    tag: u64,
    t: f32,
    y: *const f32,
    reference: *const R,
    u: *mut f32,
) -> TwipStatus
where
    V: Controller<f32, NX, NU> + Carried + Copy,
    R: CReference<Core = V::Reference>,
{
    if y.is_null() || reference.is_null() || u.is_null() {
        return TWIP_ERR_NULL;
    }
    let controller = match slot::get::<V>(words, tag) {
        Ok(c) => c,
        Err(status) => return status,
    };
    let y = slice::from_raw_parts(y, NX);
    let Some(r) = (*reference).to_core() else {
        return TWIP_ERR_NOT_FINITE;
    };
    if !t.is_finite() || !all_finite(y) {
        return TWIP_ERR_NOT_FINITE;
    }
    // Finite inputs can still overflow (a glitch of 3e38): kept as it was, the state
    // cannot carry a NaN weight or a wound-up integrator into every later update.
    let before = *controller;
    let out = controller.update(t, &SVector::<f32, NX>::from_column_slice(y), &r);
    if !(all_finite(out.as_slice()) && controller.state_is_finite()) {
        *controller = before;
        return TWIP_ERR_OVERFLOW;
    }
    slice::from_raw_parts_mut(u, NU).copy_from_slice(out.as_slice());
    TWIP_OK
}

/// Back to the controller's initial internal state (integrators, adaptive weights).
///
/// # Safety
/// As [`init`].
pub(crate) unsafe fn reset<V: Controller<f32, NX, NU>, const NX: usize, const NU: usize>(
    words: *mut u64,
    tag: u64,
) -> TwipStatus {
    match slot::get::<V>(words, tag) {
        Ok(c) => {
            c.reset();
            TWIP_OK
        }
        Err(status) => status,
    }
}

// Each state's size in 8-byte words (the value, its tag and room to grow), checked
// against the Rust value at compile time. The fuzzy controller and the sliding-mode tracker
// are exactly what they hold on a 64-bit host (their 7 x 7 grids' capacity is their room:
// 2 KiB and more is a microcontroller's whole RAM); `states_are_sized_to_what_they_hold`.
pub const TWIP_LQR_WORDS: usize = 32;
pub const TWIP_FUZZY_WORDS: usize = 213;
pub const TWIP_PID_WORDS: usize = 24;
pub const TWIP_SMC_WORDS: usize = 312;
const _: () = assert!(fits::<LqrController<f32>>(TWIP_LQR_WORDS));
const _: () = assert!(fits::<FuzzyController<f32>>(TWIP_FUZZY_WORDS));
const _: () = assert!(fits::<PidTracker<f32>>(TWIP_PID_WORDS));
const _: () = assert!(fits::<SmcTracker<f32>>(TWIP_SMC_WORDS));

// Tags: "twipLQR\0" and kin as little-endian words.
const LQR_TAG: u64 = u64::from_le_bytes(*b"twipLQR\0");
const FUZZY_TAG: u64 = u64::from_le_bytes(*b"twipFUZ\0");
const PID_TAG: u64 = u64::from_le_bytes(*b"twipPID\0");
const SMC_TAG: u64 = u64::from_le_bytes(*b"twipSMC\0");

/// State of an LQR + integral controller (opaque; `TWIP_LQR_WORDS` words).
#[repr(C)]
pub struct TwipLqr {
    pub words: [u64; TWIP_LQR_WORDS],
}

/// State of a fuzzy adaptive backstepping + PD controller (opaque).
#[repr(C)]
pub struct TwipFuzzy {
    pub words: [u64; TWIP_FUZZY_WORDS],
}

/// State of a PID tracker (opaque).
#[repr(C)]
pub struct TwipPid {
    pub words: [u64; TWIP_PID_WORDS],
}

/// State of a sliding-mode tracker (opaque).
#[repr(C)]
pub struct TwipSmc {
    pub words: [u64; TWIP_SMC_WORDS],
}

/// Initialises `state` from `config`: TWIP_OK, TWIP_ERR_NULL, TWIP_ERR_ABI (`config` was
/// written for another version of the C ABI than this library's) or TWIP_ERR_INVALID (a value
/// out of its domain); after an error `state` is marked not initialised.
///
/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_lqr_init(state: *mut TwipLqr, config: *const TwipLqrConfig) -> TwipStatus {
    init_versioned(state.cast(), LQR_TAG, config, TwipLqrConfig::build)
}

/// One update: `y` holds 4 floats, `u` receives 1 (the lumped motor current [A]). Returns
/// TWIP_OK, TWIP_ERR_NULL, TWIP_ERR_NOT_INITIALISED, TWIP_ERR_NOT_FINITE (a NaN or infinite
/// input) or TWIP_ERR_OVERFLOW (finite inputs, but the command or the integrator came out
/// NaN or infinite: the state is unchanged). `u` is written only with TWIP_OK.
/// The time `t` [s] is checked (NaN or infinite: TWIP_ERR_NOT_FINITE) but not otherwise
/// used: the integrators step by the configuration's `period`, so call it at that period.
///
/// # Safety
/// Pointers are NULL or valid for the sizes above.
#[no_mangle]
pub unsafe extern "C" fn twip_lqr_update(
    state: *mut TwipLqr,
    t: f32,
    y: *const f32,
    reference: *const TwipSpeedRef,
    u: *mut f32,
) -> TwipStatus {
    update::<LqrController<f32>, TwipSpeedRef, 4, 1>(state.cast(), LQR_TAG, t, y, reference, u)
}

/// # Safety
/// `state` is NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_lqr_reset(state: *mut TwipLqr) -> TwipStatus {
    reset::<LqrController<f32>, 4, 1>(state.cast(), LQR_TAG)
}

/// As [`twip_lqr_init`], for the fuzzy adaptive backstepping + PD controller.
///
/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_fuzzy_init(state: *mut TwipFuzzy, config: *const TwipFuzzyConfig) -> TwipStatus {
    init_versioned(state.cast(), FUZZY_TAG, config, TwipFuzzyConfig::build)
}

/// One update: `y` holds 4 floats, `u` receives 1 (the lumped motor current [A]).
/// `t` and statuses as [`twip_lqr_update`]'s (`t` unused but checked; TWIP_ERR_OVERFLOW:
/// the state is unchanged).
///
/// # Safety
/// Pointers are NULL or valid for the sizes above.
#[no_mangle]
pub unsafe extern "C" fn twip_fuzzy_update(
    state: *mut TwipFuzzy,
    t: f32,
    y: *const f32,
    reference: *const TwipSpeedRef,
    u: *mut f32,
) -> TwipStatus {
    update::<FuzzyController<f32>, TwipSpeedRef, 4, 1>(state.cast(), FUZZY_TAG, t, y, reference, u)
}

/// # Safety
/// `state` is NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_fuzzy_reset(state: *mut TwipFuzzy) -> TwipStatus {
    reset::<FuzzyController<f32>, 4, 1>(state.cast(), FUZZY_TAG)
}

/// As [`twip_lqr_init`], for the PID tracker.
///
/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_pid_init(state: *mut TwipPid, config: *const TwipPidConfig) -> TwipStatus {
    init_versioned(state.cast(), PID_TAG, config, TwipPidConfig::build)
}

/// One update: `y` holds 7 floats, `u` receives 2 (right and left wheel torques [N m]).
/// `t` and statuses as [`twip_lqr_update`]'s (`t` unused but checked; TWIP_ERR_OVERFLOW:
/// the state is unchanged).
///
/// # Safety
/// Pointers are NULL or valid for the sizes above.
#[no_mangle]
pub unsafe extern "C" fn twip_pid_update(
    state: *mut TwipPid,
    t: f32,
    y: *const f32,
    reference: *const TwipPlanarRef,
    u: *mut f32,
) -> TwipStatus {
    update::<PidTracker<f32>, TwipPlanarRef, 7, 2>(state.cast(), PID_TAG, t, y, reference, u)
}

/// # Safety
/// `state` is NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_pid_reset(state: *mut TwipPid) -> TwipStatus {
    reset::<PidTracker<f32>, 7, 2>(state.cast(), PID_TAG)
}

/// As [`twip_lqr_init`], for the sliding-mode tracker with fuzzy adaptive backstepping.
///
/// # Safety
/// `state` and `config` are NULL or valid pointers.
#[no_mangle]
pub unsafe extern "C" fn twip_smc_init(state: *mut TwipSmc, config: *const TwipSmcConfig) -> TwipStatus {
    init_versioned(state.cast(), SMC_TAG, config, TwipSmcConfig::build)
}

/// One update: `y` holds 7 floats, `u` receives 2 (right and left wheel torques [N m]).
/// `t` and statuses as [`twip_lqr_update`]'s (`t` unused but checked; TWIP_ERR_OVERFLOW:
/// the state is unchanged).
///
/// # Safety
/// Pointers are NULL or valid for the sizes above.
#[no_mangle]
pub unsafe extern "C" fn twip_smc_update(
    state: *mut TwipSmc,
    t: f32,
    y: *const f32,
    reference: *const TwipPlanarRef,
    u: *mut f32,
) -> TwipStatus {
    update::<SmcTracker<f32>, TwipPlanarRef, 7, 2>(state.cast(), SMC_TAG, t, y, reference, u)
}

/// # Safety
/// `state` is NULL or valid.
#[no_mangle]
pub unsafe extern "C" fn twip_smc_reset(state: *mut TwipSmc) -> TwipStatus {
    reset::<SmcTracker<f32>, 7, 2>(state.cast(), SMC_TAG)
}

#[cfg(all(test, target_pointer_width = "64"))]
mod tests {
    use super::*;

    /// The fuzzy and sliding-mode states hold their value and tag and not a word more (on a
    /// 64-bit host; a 32-bit target's values are no larger).
    #[test]
    fn states_are_sized_to_what_they_hold() {
        assert!(fits::<FuzzyController<f32>>(TWIP_FUZZY_WORDS) && !fits::<FuzzyController<f32>>(TWIP_FUZZY_WORDS - 1));
        assert!(fits::<SmcTracker<f32>>(TWIP_SMC_WORDS) && !fits::<SmcTracker<f32>>(TWIP_SMC_WORDS - 1));
    }
}
