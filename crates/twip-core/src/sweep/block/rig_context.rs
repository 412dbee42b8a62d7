//! What a block of rig lanes carries from one step to the next, alike for the 2-DOF and 3-DOF
//! rigs (`RigLanes`, `PlanarRigLanes`): each lane's rig (the very objects a run uses: its
//! sensors, actuator and the plant's parts that act between steps), the state, the sensors'
//! last reading and the input held; and what the firmware does with them once per control
//! period: read the sensors, drive the plant. The lanes' plants (their coefficients on
//! lanes, the windings, the IMUs) are the rigs' own types beside it.
use alloc::vec::Vec;

use nalgebra::SVector;

use crate::hardware::realism::Rig;
use crate::sim::held::Held;
use crate::sim::runner::{Actuator, Plant, Sensor};
use crate::sweep::lanes::{Lanes, LANES};

/// A block's inputs (the plant's, the controller's) as a run's vector of `NU`, lane by lane:
/// one array of lanes for the 2-DOF rig's one input, an array per input for the 3-DOF rig's.
pub(crate) trait LaneInputs<const NU: usize>: Copy {
    const ZERO: Self;
    /// Lane `l`.
    fn at(&self, l: usize) -> SVector<f64, NU>;
    /// Sets lane `l` to `v`.
    fn set(&mut self, l: usize, v: &SVector<f64, NU>);
}

impl LaneInputs<1> for Lanes {
    const ZERO: Self = [0.0; LANES];

    #[inline(always)]
    fn at(&self, l: usize) -> SVector<f64, 1> {
        SVector::<f64, 1>::new(self[l])
    }

    #[inline(always)]
    fn set(&mut self, l: usize, v: &SVector<f64, 1>) {
        self[l] = v[0];
    }
}

impl<const N: usize> LaneInputs<N> for [Lanes; N] {
    const ZERO: Self = [[0.0; LANES]; N];

    #[inline(always)]
    fn at(&self, l: usize) -> SVector<f64, N> {
        lane(self, l)
    }

    #[inline(always)]
    fn set(&mut self, l: usize, v: &SVector<f64, N>) {
        set_lane(self, l, v);
    }
}

/// Lane `l` of a state.
#[inline(always)]
pub(super) fn lane<const N: usize>(x: &[Lanes; N], l: usize) -> SVector<f64, N> {
    SVector::from(core::array::from_fn::<f64, N, _>(|i| x[i][l]))
}

/// Sets lane `l` of a state.
#[inline(always)]
pub(super) fn set_lane<const N: usize>(x: &mut [Lanes; N], l: usize, v: &SVector<f64, N>) {
    for i in 0..N {
        x[i][l] = v[i];
    }
}

/// Every lane's rig (plant `P`, sensors `S`, actuator `A`), the state of `NX`, the sensors'
/// last reading and the `NU` inputs held (`U` on lanes), with the rigs' delay.
pub(crate) struct RigContext<P, S, A, U, const NX: usize, const NU: usize> {
    /// Each lane's rig.
    pub(super) rigs: Vec<Rig<P, S, A>>,
    /// The state.
    pub(crate) x: [Lanes; NX],
    /// The sensors' last reading.
    y: [Lanes; NX],
    /// The plant's input and the controller's command, applied and pending.
    held: Held<U, LANES>,
    /// Every lane's rig applies its commands a period late (the same for all: one realism).
    delay: bool,
}

impl<P, S, A, U, const NX: usize, const NU: usize> RigContext<P, S, A, U, NX, NU>
where
    P: Plant<f64, NX, NU>,
    S: Sensor<f64, NX>,
    A: Actuator<f64, NX, NU>,
    U: LaneInputs<NU>,
{
    /// The `rigs` in the state `x`, nothing read or held yet.
    pub(super) fn new(rigs: Vec<Rig<P, S, A>>, x: [Lanes; NX]) -> Self {
        let delay = rigs[0].delay;
        Self { rigs, x, y: [[0.0; LANES]; NX], held: Held::new(U::ZERO), delay }
    }

    /// Lane `l` runs `rig` from `x0`, nothing read or held (a robot started anew).
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(super) fn restart(&mut self, l: usize, rig: Rig<P, S, A>, x0: &SVector<f64, NX>) {
        self.rigs[l] = rig;
        set_lane(&mut self.x, l, x0);
        set_lane(&mut self.y, l, &SVector::zeros());
        self.held.clear(l, |u| u.set(l, &SVector::zeros()));
    }

    /// The plants' input `drive` held from now on (a period late with a delay), as is: an
    /// env's action, which no actuator turns into a drive.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn hold_drive(&mut self, drive: &U) {
        self.held.hold(self.delay, *drive, *drive, [false; LANES]);
    }

    /// The sensors' last reading.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    #[inline(always)]
    pub(crate) fn reading(&self) -> &[Lanes; NX] {
        &self.y
    }

    /// The plants' input held over the step.
    #[inline(always)]
    pub(super) fn input(&self) -> U {
        self.held.u
    }

    /// The controller's command that the plants get now (a delayed rig's: the last period's).
    #[inline(always)]
    pub(super) fn command(&self) -> &U {
        &self.held.command
    }

    /// Whether each lane's commands applied now are beyond its drivers.
    pub(super) fn beyond(&self) -> &[bool; LANES] {
        &self.held.beyond
    }

    /// Each lane's driver's gearbox efficiency (1 without one).
    pub(super) fn efficiencies(&self) -> Lanes {
        core::array::from_fn(|l| self.rigs[l].actuator.efficiency())
    }

    /// What the firmware reads at each lane's time `ts` (its IMUs' registers in its sensors
    /// already) through each lane's tilt estimator. With `play`, the encoders count the motor
    /// shafts, which the play sets apart from the wheels: set here, where they are read (the
    /// run sets them every step).
    #[inline(always)]
    pub(super) fn read_at(&mut self, ts: &Lanes, play: bool) -> &[Lanes; NX] {
        for (l, &t) in ts.iter().enumerate() {
            self.read_lane(l, t, play);
        }
        &self.y
    }

    /// Lane `l`'s read at `t` ([`Self::read_at`]).
    #[inline(always)]
    pub(super) fn read_lane(&mut self, l: usize, t: f64, play: bool) {
        let rig = &mut self.rigs[l];
        if play {
            rig.sensors.shaft_offsets(rig.plant.shaft_offsets());
        }
        set_lane(&mut self.y, l, &rig.sensors.read(t, &lane(&self.x, l)));
    }

    /// The controller's command `cmd` at `t` through each lane's actuator (on the last
    /// reading), held from now on (a period late with a delay); returns the lanes whose
    /// drive is not finite (diverged).
    #[inline(always)]
    pub(super) fn apply(&mut self, t: f64, cmd: &U) -> [bool; LANES] {
        let (mut drive, mut clamped, mut diverged) = (U::ZERO, [false; LANES], [false; LANES]);
        for (l, rig) in self.rigs.iter_mut().enumerate() {
            let (command_l, yl) = (cmd.at(l), lane(&self.y, l));
            let d = rig.actuator.drive(t, &command_l, &yl);
            clamped[l] = rig.actuator.beyond(&command_l, &yl);
            drive.set(l, &d);
            diverged[l] = !d.iter().all(|v| v.is_finite());
        }
        self.held.hold(self.delay, drive, *cmd, clamped);
        diverged
    }
}
