//! What a closed loop keeps between controller updates: the input the plant holds and the
//! controller's command that gave it, with the one period late copies a delayed loop applies.
//! The scalar runner's (one lane) and the rigs' lanes' (`sweep::block`) alike.

/// The plant's input (`U`: the runner's vector, or a block's arrays of lanes) and the
/// controller's command, each applied and pending; whether each of the `W` lanes' command
/// applied, and the one pending, is beyond its drivers.
pub(crate) struct Held<U, const W: usize> {
    pub(crate) u: U,
    pending: U,
    pub(crate) command: U,
    pending_command: U,
    pub(crate) beyond: [bool; W],
    pending_beyond: [bool; W],
}

impl<U: Copy, const W: usize> Held<U, W> {
    /// Nothing applied (`zero` held).
    pub(crate) fn new(zero: U) -> Self {
        Self { u: zero, pending: zero, command: zero, pending_command: zero, beyond: [false; W], pending_beyond: [false; W] }
    }

    /// Lane `l` holds nothing (a robot started anew): `zero` clears lane `l` of a `U`.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn clear(&mut self, l: usize, zero: impl Fn(&mut U)) {
        for v in [&mut self.u, &mut self.pending, &mut self.command, &mut self.pending_command] {
            zero(v);
        }
        (self.beyond[l], self.pending_beyond[l]) = (false, false);
    }

    /// The drive a controller update gives (`drive` for the command `cmd`, `clamped` where it
    /// is beyond a driver), applied from now on, or (`delay`) once the next update comes.
    #[inline(always)]
    pub(crate) fn hold(&mut self, delay: bool, drive: U, cmd: U, clamped: [bool; W]) {
        if delay {
            (self.u, self.pending, self.command, self.pending_command) = (self.pending, drive, self.pending_command, cmd);
            (self.beyond, self.pending_beyond) = (self.pending_beyond, clamped);
        } else {
            (self.u, self.command, self.beyond) = (drive, cmd, clamped);
        }
    }
}
