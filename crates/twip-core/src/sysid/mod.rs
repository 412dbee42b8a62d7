//! System identification's numerical kernel: predictions of a logged run by multiple
//! shooting. The run is cut into segments; each segment is integrated from its own start
//! state with the logged input held between samples (zero-order hold), so an unstable
//! plant is only ever followed over one short segment. The estimator (Python,
//! `twip.sysid`) makes the start states unknowns beside the robot's parameters.
use nalgebra::{SVector, Vector4};

use crate::hardware::backlash::{GearEvent, PlayState};
use crate::model::dynamics::Dynamics;
use crate::model::integrate::rk4_step_from_k1;
use crate::{Real, SlopeModel, TwipError};

pub mod geared;
#[cfg(feature = "parallel")]
pub mod parallel;

/// A model as a shooting run carries it along a segment. A plain model has no state of
/// its own. A PWM-driven one whose winding has inductance carries the winding's current
/// from step to step, and its RK4 stages feel it within the step, as the simulator's
/// plant does (`RealPlant::step_start`, `step_ended`): the predictions are then the
/// simulator's own steps. One with gear play (`geared::rig_plant`) carries its rotors, and an impact
/// at a step's start jumps the state.
pub trait ShootingModel<T: Real>: Dynamics<T, 4, 1> + Copy {
    /// A segment starts at `x`; `before` is the input held up to its first sample.
    fn start_segment(&mut self, _x: &Vector4<T>, _before: T) {}

    /// An RK4 step of `dt` starts at `x` under the input `u`: `x` may jump (an impact in
    /// the gear play). Returns the step's first stage when the model has it at hand.
    fn start_step(&mut self, _x: &mut Vector4<T>, _u: T, _dt: T) -> Option<Vector4<T>> {
        None
    }

    /// The RK4 step under way ended at `x`.
    fn end_step(&mut self, _x: &Vector4<T>) {}

    /// The gear play's state between steps (None: the model has no play).
    fn play(&self) -> Option<PlayState<T, 1>> {
        None
    }

    /// The gear play in `state`.
    fn set_play(&mut self, _state: &PlayState<T, 1>) {}

    /// The motor shafts' angle minus the wheels' [rad at the wheel]: the encoder counts the shaft.
    fn shaft_offset(&self) -> T {
        T::zero()
    }

    /// The gear play's events at the next step's start imposed ([`GearEvent`]; None: its
    /// motion decides them).
    fn script(&mut self, _events: Option<GearEvent>) {}

    /// What the last step's start did to the gear play (None: the model has no play).
    fn events(&self) -> Option<GearEvent> {
        None
    }
}

/// How a shooting run with gear play starts its segments and schedules its impacts
/// ([`Shooting::run`]). Without play all three are the same run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Play {
    /// Each later segment from the play the one before left (recorded in `Outputs::plays`),
    /// the impacts and openings where the motion puts them (recorded in `Outputs::events`):
    /// a run of the robot as it is, the base of a finite difference.
    Carry,
    /// Each later segment from `Outputs::plays` as given, the events where the motion puts them.
    Held,
    /// The segments from `Outputs::plays` and every plant step's events from `Outputs::events`
    /// as given (the base run's): a finite difference then differences the motion with the
    /// impacts' schedule held, not the jump of an impact that a perturbation moved by a step.
    Replay,
}

impl<T: Real> ShootingModel<T> for SlopeModel<T> {}

/// A logged run's time base and held inputs, cut into segments.
#[derive(Clone, Copy, Debug)]
pub struct Shooting<'a, T> {
    t: &'a [T],
    u: &'a [T],
    segments: &'a [usize],
    max_step: T,
    /// How many plant steps a run takes (one gear event each).
    steps: usize,
}

/// Where one shooting run puts its outputs ([`Shooting::run`]): per sample the state, its
/// rate and what the sensors see besides ([shaft offset, pitch rate at the IMU]); per
/// segment its end and the gear play it started from; per plant step the gear play's
/// events ([`Shooting::plant_steps`] of them with play carried or replayed; else unused).
pub struct Outputs<'o, T> {
    pub states: &'o mut [Vector4<T>],
    pub rates: &'o mut [Vector4<T>],
    pub sensed: &'o mut [[T; 2]],
    pub ends: &'o mut [Vector4<T>],
    pub plays: &'o mut [Option<PlayState<T, 1>>],
    pub events: &'o mut [GearEvent],
}

impl<T> Outputs<'_, T> {
    /// The same places, borrowed again: for a run that does not take them for good.
    pub fn reborrow(&mut self) -> Outputs<'_, T> {
        Outputs {
            states: self.states,
            rates: self.rates,
            sensed: self.sensed,
            ends: self.ends,
            plays: self.plays,
            events: self.events,
        }
    }
}

fn invalid(name: &'static str, value: f64, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value, reason }
}

impl<'a, T: Real> Shooting<'a, T> {
    /// `t` strictly increasing and finite; `u[i]` held over [t_i, t_i+1); `segments` the
    /// first sample of each segment (0 first, strictly increasing, each < n); intervals
    /// longer than `max_step` are split into equal RK4 steps.
    pub fn new(t: &'a [T], u: &'a [T], segments: &'a [usize], max_step: T) -> Result<Self, TwipError> {
        let n = t.len();
        if n < 2 {
            return Err(invalid("t", n as f64, "needs at least 2 samples"));
        }
        if u.len() != n {
            return Err(invalid("u", u.len() as f64, "needs one value per sample of t"));
        }
        for i in 0..n {
            if !t[i].is_finite() || (i > 0 && t[i] <= t[i - 1]) {
                return Err(invalid("t", i as f64, "row where t is not finite and strictly increasing"));
            }
            if !u[i].is_finite() {
                return Err(invalid("u", i as f64, "row where u is not finite"));
            }
        }
        if segments.first() != Some(&0) {
            return Err(invalid("segments", segments.first().map_or(-1.0, |&s| s as f64), "the first segment starts at sample 0"));
        }
        for (k, w) in segments.windows(2).enumerate() {
            if w[1] <= w[0] || w[1] >= n {
                return Err(invalid("segments", (k + 1) as f64, "segment starts must increase and stay below the sample count"));
            }
        }
        if !(max_step.is_finite() && max_step > T::zero()) {
            return Err(invalid("max_step", crate::to_f64(max_step), "must be finite and > 0"));
        }
        let mut shooting = Self { t, u, segments, max_step, steps: 1 };
        // Every interval's steps, and the last sample's start (its rate).
        shooting.steps += t.windows(2).map(|w| crate::to_f64(shooting.split(w[1] - w[0]).0) as usize).sum::<usize>();
        Ok(shooting)
    }

    /// How many plant steps a run takes: each interval's RK4 steps and the last sample's
    /// start. A run with gear play has one [`GearEvent`] per step.
    pub fn plant_steps(&self) -> usize {
        self.steps
    }

    pub fn samples(&self) -> usize {
        self.t.len()
    }

    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    /// The samples of segment `k`.
    pub fn range(&self, k: usize) -> core::ops::Range<usize> {
        let end = self.segments.get(k + 1).copied().unwrap_or(self.t.len());
        self.segments[k]..end
    }

    /// Predicts every sample into `out` ([`Outputs`]): `states[i]` the state as logged
    /// at sample i (before its step starts), `rates[i]` its derivative under the input held
    /// from sample i (with an inductive winding, under the winding's current at the sample,
    /// as an accelerometer in the simulator feels it; after an impact in the gear play, at
    /// the state it left), `sensed[i]` the motor shafts' offset from the wheels as logged
    /// and the pitch rate the IMU samples (after an impact), and `ends[k]` segment k's state
    /// carried on to the next segment's first sample (what continuity compares with that
    /// segment's start; the last segment's is NaN). A segment that leaves the finite numbers
    /// stays NaN to its end.
    ///
    /// A model with gear play starts its first segment with the play as it is, and each
    /// later one as `play` says ([`Play`]): from the previous segment's play at its end
    /// (recorded in `out.plays`, and every step's events in `out.events`), or from
    /// `out.plays` as given (and with `Replay` every step's events from `out.events`).
    pub fn run<M: ShootingModel<T>>(&self, model: &M, starts: &[Vector4<T>], out: Outputs<'_, T>, play: Play) -> Result<(), TwipError> {
        let n = self.samples();
        if starts.len() != self.segment_count() {
            return Err(invalid("starts", starts.len() as f64, "needs one start state per segment"));
        }
        if out.states.len() != n || out.rates.len() != n || out.sensed.len() != n {
            return Err(invalid("states", out.states.len() as f64, "needs one row per sample"));
        }
        if out.ends.len() != starts.len() || out.plays.len() != starts.len() {
            return Err(invalid("ends", out.ends.len() as f64, "needs one row per segment"));
        }
        let geared = model.play().is_some();
        if geared && play != Play::Held && out.events.len() != self.steps {
            return Err(invalid("events", out.events.len() as f64, "needs one gear event per plant step of the log (Shooting::plant_steps)"));
        }
        let mut events = Schedule { play: if geared { play } else { Play::Held }, events: out.events, next: 0 };
        let mut carried = model.play();
        for (k, start) in starts.iter().enumerate() {
            let range = self.range(k);
            // Each segment carries its own copy: its winding's current is its own. It starts
            // from the duty held before the segment (the first segment's own: none before).
            let mut model = *model;
            let start_play = if play == Play::Carry || k == 0 { carried } else { out.plays[k] };
            if let Some(p) = &start_play {
                model.set_play(p);
            }
            out.plays[k] = start_play;
            model.start_segment(start, self.u[range.start.saturating_sub(1)]);
            let mut x = *start;
            for i in range.clone() {
                let u = SVector::<T, 1>::new(self.u[i]);
                // The last sample has no interval of its own: its step is as long as the one
                // before's (its rate does not depend on it).
                let interval = if i + 1 < n { self.t[i + 1] - self.t[i] } else { self.t[i] - self.t[i - 1] };
                let (steps, h) = self.split(interval);
                out.states[i] = x;
                let shaft = model.shaft_offset();
                let k1 = events.start_step(&mut model, &mut x, &u, h);
                out.rates[i] = k1;
                out.sensed[i] = [shaft, x[1]];
                out.ends[k] = Vector4::repeat(crate::c::<T>(f64::NAN));
                if i + 1 == n {
                    break;
                }
                x = Self::advance(&mut model, &x, &u, &k1, steps, h, &mut events);
                if !x.iter().all(|v| v.is_finite()) {
                    x = Vector4::repeat(crate::c::<T>(f64::NAN));
                }
                if i + 1 == range.end {
                    out.ends[k] = x;
                }
            }
            carried = model.play();
        }
        Ok(())
    }

    /// A sample interval as (the number of equal RK4 steps, their length): one step when it
    /// is no longer than `max_step`, else as many as it takes (a whole number of max steps,
    /// up to rounding, takes that many).
    fn split(&self, interval: T) -> (T, T) {
        if interval <= self.max_step * crate::c::<T>(1.0 + 1e-9) {
            return (T::one(), interval);
        }
        let steps = (interval / self.max_step - crate::c::<T>(1e-9)).ceil();
        (steps, interval / steps)
    }

    /// `steps` RK4 steps of `h` from `x` under `u`, the first from its first stage `k1`
    /// (evaluated after the model's `start_step`); each further step starts the model's,
    /// and each ends it.
    #[allow(clippy::too_many_arguments)]
    fn advance<M: ShootingModel<T>>(model: &mut M, x: &Vector4<T>, u: &SVector<T, 1>, k1: &Vector4<T>, steps: T, h: T, events: &mut Schedule<'_>) -> Vector4<T> {
        let mut y = rk4_step_from_k1(model, x, u, h, k1);
        model.end_step(&y);
        let mut done = T::one();
        while done < steps {
            let k1 = events.start_step(model, &mut y, u, h);
            y = rk4_step_from_k1(model, &y, u, h, &k1);
            model.end_step(&y);
            done += T::one();
        }
        y
    }
}

/// A run's gear events, step by step: recorded (`Carry`), imposed (`Replay`) or left to
/// the motion (`Held`, or a model without play).
struct Schedule<'e> {
    play: Play,
    events: &'e mut [GearEvent],
    next: usize,
}

impl Schedule<'_> {
    /// The model's step of `h` starts at `x` under `u`, with the next step's events imposed
    /// or recorded; returns its first stage.
    #[inline]
    fn start_step<T: Real, M: ShootingModel<T>>(&mut self, model: &mut M, x: &mut Vector4<T>, u: &SVector<T, 1>, h: T) -> Vector4<T> {
        if self.play == Play::Replay {
            model.script(Some(self.events[self.next]));
        }
        let k1 = model.start_step(x, u[0], h).unwrap_or_else(|| model.deriv(x, u));
        if self.play == Play::Carry {
            self.events[self.next] = model.events().unwrap_or_default();
        }
        self.next += 1;
        k1
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::model::integrate::rk4_step;
    use crate::{RobotParams, SlopeModel};

    #[test]
    fn each_segment_follows_rk4_from_its_start() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        let t: Vec<f64> = (0..50).map(|i| i as f64 * 2e-3).collect();
        let u: Vec<f64> = (0..50).map(|i| 0.3 * (i as f64 * 0.2).sin()).collect();
        let segments = [0, 20];
        let shooting = Shooting::new(&t, &u, &segments, 1e-3).unwrap();
        let starts = [Vector4::new(0.05, 0.0, 0.0, 0.0), Vector4::new(-0.02, 0.1, 0.3, 1.0)];
        let (mut states, mut rates, mut sensed) = (vec![Vector4::zeros(); 50], vec![Vector4::zeros(); 50], vec![[0.0; 2]; 50]);
        let (mut ends, mut plays) = ([Vector4::zeros(); 2], [None; 2]);
        let out = Outputs { states: &mut states, rates: &mut rates, sensed: &mut sensed, ends: &mut ends, plays: &mut plays, events: &mut [] };
        shooting.run(&model, &starts, out, Play::Held).unwrap();
        for (k, range) in [(0, 0..20), (1, 20..50)] {
            let mut x = starts[k];
            for i in range {
                assert_eq!(states[i], x, "sample {i}");
                let uu = SVector::<f64, 1>::new(u[i]);
                assert_eq!(rates[i], model.deriv(&x, &uu));
                // 2 ms between samples: two steps of half the interval.
                let h = (t.get(i + 1).copied().unwrap_or(0.0) - t[i]) / 2.0;
                x = rk4_step(&model, &rk4_step(&model, &x, &uu, h), &uu, h);
            }
            // Segment 0 carried on to sample 20; the last segment has no next one.
            if k == 0 {
                assert_eq!(ends[0], x);
            }
        }
        assert!(ends[1].iter().all(|v| v.is_nan()));
    }

    /// With an inductive driver a segment is the simulator's plant step for step: the
    /// realism rig's `between_steps` (the winding's step started), RK4 (its stages feel the
    /// winding's current within the step) and `step_ended`, from the same current. Bit for bit: the time base is exact in binary (dt = 2^-10).
    /// A sample every plant step, and one every 4 (`max_step` = dt splits the interval).
    #[test]
    fn an_inductive_segment_is_the_simulators_plant_bit_for_bit() {
        use crate::hardware::driver::MotorDriver;
        use crate::hardware::realism::{Realism, RigPlant};
        use crate::sim::runner::Plant;
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        let driver = MotorDriver::thesis_like();
        let driven = geared::rig_plant(&model, Some(&driver), None).unwrap();
        let (dt, n, segments) = (1.0 / 1024.0, 60, [0, 25]);
        // Duties that swing through full scale: the 2 A limit clamps the current.
        let u: Vec<f64> = (0..n).map(|i| (255.0 * (i as f64 * 0.3).sin()).round()).collect();
        let starts = [Vector4::new(0.05, 0.0, 0.0, 0.0), Vector4::new(-0.02, 0.4, 0.3, 6.0)];
        for every in [1, 4] {
            let t: Vec<f64> = (0..n).map(|i| (i * every) as f64 * dt).collect();
            let shooting = Shooting::new(&t, &u, &segments, dt).unwrap();
            let (mut states, mut rates, mut sensed) = (vec![Vector4::zeros(); n], vec![Vector4::zeros(); n], vec![[0.0; 2]; n]);
            let (mut ends, mut plays) = ([Vector4::zeros(); 2], [None; 2]);
            let out = Outputs { states: &mut states, rates: &mut rates, sensed: &mut sensed, ends: &mut ends, plays: &mut plays, events: &mut [] };
            shooting.run(&driven, &starts, out, Play::Held).unwrap();
            let mut limited = 0;
            for (k, range) in [(0, 0..25), (1, 25..n)] {
                let mut plant = Realism { motor: Some(driver), ..Realism::ideal() }.build(&model, dt).unwrap().plant;
                let mut x = starts[k];
                plant.settle(&x, &SVector::<f64, 1>::new(u[range.start.saturating_sub(1)]));
                for i in range {
                    let uu = SVector::<f64, 1>::new(u[i]);
                    for step in 0..every {
                        plant.between_steps(t[i] + step as f64 * dt, dt, &mut x, &uu);
                        let k1 = plant.deriv(&x, &uu);
                        if step == 0 {
                            assert_eq!((states[i], rates[i]), (x, k1), "every {every}, sample {i}");
                        }
                        limited += usize::from(plant.currents(&x, &uu)[0].abs() == 2.0 * driver.efficiency * driver.current_limit);
                        if i + 1 == n {
                            break;
                        }
                        x = rk4_step_from_k1(&plant, &x, &uu, dt, &k1);
                        plant.step_ended(&x);
                    }
                }
                if k == 0 {
                    assert_eq!(ends[0], x, "every {every}");
                }
            }
            assert!(limited > 10, "the limit clamped {limited} steps");
        }
    }

    /// With gear play (and gearhead friction, and a current-limited driver) a run is the
    /// simulator's plant step for step: the rig's `between_steps` (the open rotors' elapsed
    /// step and impacts, the winding, the trains that open), RK4 and `step_ended`. Carried,
    /// each segment starts from the play the one before left, so that segments started at
    /// the plant's own states are its run, bit for bit: states as logged (before the step's
    /// impact), the shaft's offset as the encoder counts it, and the pitch rate the IMU
    /// samples (after it). Held, a segment starts from the play given. (The winding has no
    /// inductance here: its current is not carried from segment to segment.)
    #[test]
    fn a_geared_run_is_the_simulators_plant_bit_for_bit() {
        use crate::hardware::backlash::Backlash;
        use crate::hardware::driver::MotorDriver;
        use crate::hardware::realism::Realism;
        use crate::sim::runner::Plant;
        let friction = Realism::<f64>::thesis_like_friction();
        let model = SlopeModel::new(RobotParams::balanbot(), 0.05).unwrap().with_friction(Some(friction)).unwrap();
        let driver = MotorDriver { inductance: 0.0, ..MotorDriver::thesis_like() };
        let backlash = Backlash { gap: 2f64.to_radians() };
        let (dt, n) = (1.0 / 1024.0, 400);
        // Duties that reverse often: the trains open and cross the play.
        let u: Vec<f64> = (0..n).map(|i| (200.0 * (i as f64 * 0.05).sin() + 40.0 * (i as f64 * 0.7).cos()).round()).collect();
        let t: Vec<f64> = (0..n).map(|i| i as f64 * dt).collect();
        let mut plant = Realism { motor: Some(driver), backlash: Some(backlash), ..Realism::ideal() }.build(&model, dt).unwrap().plant;
        let mut x = Vector4::new(0.05, 0.0, 0.0, 0.0);
        let (mut truth, mut rates, mut sensed, mut open, mut plant_events) = (vec![], vec![], vec![], 0, vec![]);
        for i in 0..n {
            let uu = SVector::<f64, 1>::new(u[i]);
            truth.push(x);
            let shaft = plant.shaft_offsets()[0];
            let k1 = plant.between_steps_with_derivative(t[i], dt, &mut x, &uu).unwrap_or_else(|| plant.deriv(&x, &uu));
            open += usize::from(!plant.engaged());
            plant_events.push(plant.play().unwrap().events()[0]);
            rates.push(k1);
            sensed.push([shaft, x[1]]);
            x = rk4_step_from_k1(&plant, &x, &uu, dt, &k1);
            plant.step_ended(&x);
        }
        assert!(open > 20, "the trains were open {open} steps");
        let segments = [0, 130, 260];
        let starts: Vec<_> = segments.iter().map(|&s| truth[s]).collect();
        let shooting = Shooting::new(&t, &u, &segments, dt).unwrap();
        let shooter = geared::rig_plant(&model, Some(&driver), Some(backlash)).unwrap();
        let (mut states, mut rs, mut ss) = (vec![Vector4::zeros(); n], vec![Vector4::zeros(); n], vec![[0.0; 2]; n]);
        let (mut ends, mut plays) = ([Vector4::zeros(); 3], [None; 3]);
        assert_eq!(shooting.plant_steps(), n);
        let mut events = vec![GearEvent::default(); n];
        let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut events };
        shooting.run(&shooter, &starts, out, Play::Carry).unwrap();
        for i in 0..n {
            assert_eq!((states[i], rs[i], ss[i]), (truth[i], rates[i], sensed[i]), "sample {i}");
        }
        assert_eq!(ends[0], truth[130]);
        assert!(plays.iter().all(|p| p.is_some()));
        // The run's impacts and openings were recorded, step by step, as the plant had them.
        let hits = events.iter().filter(|e| e.hit != 0).count();
        let openings = events.iter().filter(|e| e.opened).count();
        assert_eq!(events, plant_events);
        assert!(hits > 3 && openings > 3, "{hits} impacts, {openings} openings");
        // Replayed, its own events give the same run, bit for bit.
        let (kept, recorded) = (plays, events.clone());
        let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut events };
        shooting.run(&shooter, &starts, out, Play::Replay).unwrap();
        for i in 0..n {
            assert_eq!((states[i], rs[i], ss[i]), (truth[i], rates[i], sensed[i]), "replayed, sample {i}");
        }
        assert_eq!(events, recorded);
        // Held: the same plays given, the same run; another play given, another run.
        let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut [] };
        shooting.run(&shooter, &starts, out, Play::Held).unwrap();
        assert_eq!(states[n - 1], truth[n - 1]);
        plays[2] = kept[1];
        let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut [] };
        shooting.run(&shooter, &starts, out, Play::Held).unwrap();
        assert_ne!(states[n - 1], truth[n - 1]);
        // Another robot, carried, has its impacts elsewhere; replaying the first's schedule
        // is another run (the script is obeyed), finite to its end.
        let heavier = SlopeModel::new(RobotParams { m_body: 1.2, ..RobotParams::balanbot() }, 0.05).unwrap().with_friction(Some(friction)).unwrap();
        let shooter = geared::rig_plant(&heavier, Some(&driver), Some(backlash)).unwrap();
        plays = kept;
        let mut own = vec![GearEvent::default(); n];
        let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut own };
        shooting.run(&shooter, &starts, out, Play::Carry).unwrap();
        assert_ne!(own, recorded);
        let carried = states.clone();
        plays = kept;
        let mut replayed = recorded.clone();
        let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut replayed };
        shooting.run(&shooter, &starts, out, Play::Replay).unwrap();
        assert_ne!(states, carried);
        assert!(states.iter().all(|x| x.iter().all(|v| v.is_finite())));
        // A wrong event count is refused by name, carried or replayed.
        for play in [Play::Carry, Play::Replay] {
            let mut short = vec![GearEvent::default(); n - 1];
            let out = Outputs { states: &mut states, rates: &mut rs, sensed: &mut ss, ends: &mut ends, plays: &mut plays, events: &mut short };
            let err = shooting.run(&shooter, &starts, out, play).unwrap_err();
            assert!(matches!(err, TwipError::InvalidParameter { name: "events", .. }), "{err:?}");
        }
    }

    #[test]
    fn bad_logs_are_refused_by_name() {
        let t = [0.0, 1e-3, 1e-3];
        let u = [0.0; 3];
        let err = Shooting::new(&t, &u, &[0], 1e-3).unwrap_err();
        assert!(matches!(err, TwipError::InvalidParameter { name: "t", value, .. } if value == 2.0));
        let t = [0.0, 1e-3, 2e-3];
        assert!(Shooting::new(&t, &u[..2], &[0], 1e-3).is_err());
        assert!(Shooting::new(&t, &u, &[1], 1e-3).is_err());
        assert!(Shooting::new(&t, &u, &[0, 3], 1e-3).is_err());
        assert!(Shooting::new(&t, &u, &[0], 0.0).is_err());
    }
}
