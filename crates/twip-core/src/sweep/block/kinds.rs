//! The kinds of a rig lanes' plant (the 2-DOF rig's and the 3-DOF one's), decided once per
//! block from its rigs: the gearhead friction's (`GEAR`) and what drives the plant
//! (`DRIVE`). Each kind is its own loop over lanes, so that no branch inside one keeps the
//! compiler from vectorising it.
use crate::model::friction::Friction;

/// No gearhead friction, the slip law, the slip law with a stick band.
pub(super) const FREE: u8 = 0;
pub(super) const SLIP: u8 = 1;
pub(super) const STICK: u8 = 2;
/// The stick band's law on a step where no lane's wheel is expected in the band
/// (`Gearhead::Outside`): taken again with `STICK` when one was.
pub(super) const OUTSIDE: u8 = 3;
/// The input held over the step (no driver); a driver whose windings have no inductance
/// (the duty turned into current at each stage); with inductance (the current moves within
/// the step).
pub(super) const HELD: u8 = 0;
pub(super) const STEADY: u8 = 1;
pub(super) const STEPPED: u8 = 2;

/// The kind of the gearhead `friction` (None: none).
pub(super) fn gear(friction: Option<&Friction<f64>>) -> u8 {
    match friction {
        None => FREE,
        Some(f) if f.sticks() => STICK,
        Some(_) => SLIP,
    }
}

/// The kind of drive: None without a driver, else whether its windings have inductance.
pub(super) fn drive(inductive: Option<bool>) -> u8 {
    match inductive {
        None => HELD,
        Some(false) => STEADY,
        Some(true) => STEPPED,
    }
}
