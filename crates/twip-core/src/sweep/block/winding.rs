//! The motor windings of a block's rigs on lanes, as `rig_lanes::ImuLanes` keeps the IMUs: each
//! lane's rig's `Winding` (its factors for the block's step size), side by side. With
//! inductance their steps are taken here, by `Winding`'s own code over [`Wide`] lanes, as a
//! run's plant takes them (`RealPlant::step_ended` and `step_start`, both models'): the
//! per-step work is vectorised and an RK4 stage reads the lanes' numbers side by side.
//! (A lane's winding per RK4 stage, copied by value, ran the 3-DOF rig's kernel 3x slower.)
use crate::hardware::driver::Winding;
use crate::model::integrate::Stage;
use crate::model::lane::{Fused, Wide};
use crate::sweep::lanes::{Lanes, LANES};

pub(super) struct WindingLanes {
    windings: Winding<Wide<LANES>>,
    /// The plant's input per motor ampere: 2 ε for the 2-DOF lumped current, ε η k_t for
    /// a wheel torque.
    per_amp: Wide<LANES>,
}

impl WindingLanes {
    /// Each lane's winding and the plant's input per motor ampere.
    pub(super) fn new(each: &[(Winding<f64>, f64); LANES]) -> Self {
        Self { windings: Winding::side_by_side(&each.map(|(w, _)| w)), per_amp: Wide(each.map(|(_, a)| a)) }
    }

    /// Lane `l`'s winding and the plant's input per motor ampere.
    #[inline(always)]
    pub(super) fn lane(&self, l: usize) -> (Winding<Fused>, Fused) {
        (self.windings.lane(l), Fused(self.per_amp.0[l]))
    }

    /// Lane `l`'s winding and input per ampere set to `winding`'s (a robot started anew),
    /// the other lanes' as they are: lane `l` of [`Self::new`] given it there.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(super) fn set_lane(&mut self, l: usize, (winding, per_amp): (Winding<f64>, f64)) {
        self.windings = self.windings.zip(&winding, |&lanes, &v| {
            let mut lanes = lanes;
            lanes.0[l] = v;
            lanes
        });
        self.per_amp.0[l] = per_amp;
    }

    /// With inductance: the last step ended with the motors at `ended` (on the lanes
    /// `after_one`: none before a lane's first step), and this one starts under the duties
    /// `u` with the motors at `starts`; `input` gets each lane's plant input at its first stage.
    #[inline(always)]
    pub(super) fn step(&mut self, after_one: &[bool; LANES], ended: &Lanes, u: &Lanes, starts: &Lanes, input: &mut Lanes) {
        let w = &mut self.windings;
        if after_one.iter().all(|&a| a) {
            w.finish_step(Wide(*ended));
        } else if after_one.iter().any(|&a| a) {
            // Lanes that start apart (an env's robots): the others keep their current.
            let before = *w;
            w.finish_step(Wide(*ended));
            *w = w.zip(&before, |now, was| Wide(core::array::from_fn(|l| if after_one[l] { now.0[l] } else { was.0[l] })));
        }
        w.begin_step(Wide(*u), Wide(*starts));
        *input = (self.per_amp * w.stepped_current(Stage::Start, Wide(*starts))).0;
    }

    /// With inductance: each lane's plant input from its current now (after [`Self::step`]:
    /// where the last step ended), as `RealPlant::delivered`.
    #[inline(always)]
    pub(super) fn delivered(&self, out: &mut Lanes) {
        for (l, v) in out.iter_mut().enumerate() {
            let (w, per_amp) = self.lane(l);
            *v = (per_amp * w.step_current()).0;
        }
    }

    /// With inductance: lane `l`'s plant input at a step's start once the step under way has
    /// ended with its motor at `speed`: what a run's `halted` reads after `step_ended`
    /// (`RealPlant::inputs_at` then), which the lanes take at the next step's start.
    #[inline(always)]
    pub(super) fn ended_input(&self, l: usize, speed: f64) -> f64 {
        let (mut w, per_amp) = self.lane(l);
        w.finish_step(Fused(speed));
        (per_amp * w.stepped_current(Stage::Start, Fused(speed))).0
    }

    /// With inductance: lane `l`'s plant input from the current's mean over the step (what
    /// an open gear train's rotor is driven by), as `RealPlant::mean_inputs`.
    #[inline(always)]
    pub(super) fn mean(&self, l: usize) -> f64 {
        let (w, per_amp) = self.lane(l);
        (per_amp * w.stepped_mean()).0
    }
}
