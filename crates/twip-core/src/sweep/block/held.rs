//! What both rigs' lanes keep between control periods: the input the plants hold and the
//! controller's command that gave it, with the one period late copies a delayed rig applies.
use crate::sweep::lanes::LANES;

/// The plant's input (duties or currents, `U`: one or two arrays of lanes) and the
/// controller's command, each applied and pending; whether each lane's command applied,
/// and the one pending, is beyond its drivers.
pub(super) struct Held<U> {
    pub(super) u: U,
    pending: U,
    pub(super) command: U,
    pending_command: U,
    pub(super) beyond: [bool; LANES],
    pending_beyond: [bool; LANES],
}

impl<U: Copy> Held<U> {
    /// Nothing applied (`zero` held).
    pub(super) fn new(zero: U) -> Self {
        Self { u: zero, pending: zero, command: zero, pending_command: zero, beyond: [false; LANES], pending_beyond: [false; LANES] }
    }

    /// Lane `l` holds nothing (a robot started anew): `zero` clears lane `l` of a `U`.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(super) fn clear(&mut self, l: usize, zero: impl Fn(&mut U)) {
        for v in [&mut self.u, &mut self.pending, &mut self.command, &mut self.pending_command] {
            zero(v);
        }
        (self.beyond[l], self.pending_beyond[l]) = (false, false);
    }

    /// The drive a controller update gives (`drive` for the command `cmd`, `clamped` where it
    /// is beyond a driver), applied from now on, or (`delay`) once the next update comes.
    #[inline(always)]
    pub(super) fn hold(&mut self, delay: bool, drive: U, cmd: U, clamped: [bool; LANES]) {
        if delay {
            (self.u, self.pending, self.command, self.pending_command) = (self.pending, drive, self.pending_command, cmd);
            (self.beyond, self.pending_beyond) = (self.pending_beyond, clamped);
        } else {
            (self.u, self.command, self.beyond) = (drive, cmd, clamped);
        }
    }
}
