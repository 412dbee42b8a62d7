//! The kinds of a rig lanes' plant (the 2-DOF rig's and the 3-DOF one's), decided once per
//! block from its rigs: the gearhead friction's (`GEAR`) and what drives the plant
//! (`DRIVE`). Each kind is its own loop over lanes, so that no branch inside one keeps the
//! compiler from vectorising it.
use crate::model::friction::Friction;
use crate::model::lane::Fused;
#[cfg(test)]
use crate::sweep::lanes::Lanes;

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

/// Whether a wheel turning at `w` relative to the body is clear of `friction`'s stick band
/// by a margin (twice its half-width from rest), so that it seldom enters the band within a
/// step: the rigs' test for trying `OUTSIDE` first.
pub(super) fn clear_of_band(friction: &Friction<Fused>, w: f64) -> bool {
    w.abs() >= 2.0 * friction.stick_speed.0
}

/// The bits of every lane's state, for the rigs' tests of `OUTSIDE`.
#[cfg(test)]
pub(super) fn state_bits<const N: usize>(x: &[Lanes; N]) -> alloc::vec::Vec<u64> {
    x.iter().flatten().map(|v| v.to_bits()).collect()
}
