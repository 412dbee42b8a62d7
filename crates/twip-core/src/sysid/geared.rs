//! A shooting model with the rig's parts: the realism rig's own plant ([`SlopePlant`]), the
//! motor driver when the log's input is a PWM duty, and gear trains with backlash and
//! gearhead friction. Each step starts as the simulator starts it (`between_steps`: the
//! open rotors' elapsed step and impacts, the winding's step, the trains that open), so
//! that an exact log of the rig is predicted step for step.
use nalgebra::{SVector, Vector4};

use super::ShootingModel;
use crate::hardware::backlash::{Backlash, GearEvent, PlayState};
use crate::hardware::disturbance::SlopePlant;
use crate::hardware::driver::MotorDriver;
use crate::hardware::rig_plant::RealPlant;
use crate::sim::runner::Plant;
use crate::{Real, SlopeModel, TwipError};

/// `model` (with its gearhead friction) driven through `driver` (a PWM log; None: by the
/// lumped current), its gear trains with `backlash`'s play (None: none), as a realism rig
/// builds it.
pub fn rig_plant<T: Real>(model: &SlopeModel<T>, driver: Option<&MotorDriver<T>>, backlash: Option<Backlash<T>>) -> Result<SlopePlant<T>, TwipError> {
    SlopePlant::plain(model).with_backlash(backlash)?.with_driver(driver, model.params())
}

impl<T: Real> ShootingModel<T> for SlopePlant<T> {
    /// The motors turn with the open rotors. The current a segment starts with is unknown;
    /// the steady current of the duty held before it, at its start state's speed, is what
    /// an inductive winding has converged to when that duty was held for several time
    /// constants (L/R ≈ 0.6 ms against a 5 ms control loop).
    fn start_segment(&mut self, x: &Vector4<T>, before: T) {
        self.settle(x, &SVector::<T, 1>::new(before));
    }

    fn start_step(&mut self, x: &mut Vector4<T>, u: T, dt: T) -> Option<Vector4<T>> {
        // No pushes: the time does not matter.
        self.between_steps_with_derivative(T::zero(), dt, x, &SVector::<T, 1>::new(u))
    }

    fn end_step(&mut self, x: &Vector4<T>) {
        self.step_ended(x);
    }

    fn play(&self) -> Option<PlayState<T, 1>> {
        RealPlant::play(self).map(|p| p.state())
    }

    fn set_play(&mut self, state: &PlayState<T, 1>) {
        if let Some(p) = self.play_mut() {
            p.set_state(state);
        }
    }

    fn shaft_offset(&self) -> T {
        self.shaft_offsets()[0]
    }

    fn script(&mut self, events: Option<GearEvent>) {
        if let Some(p) = self.play_mut() {
            p.script(events.map(|e| [e]));
        }
    }

    fn events(&self) -> Option<GearEvent> {
        RealPlant::play(self).map(|p| p.events()[0])
    }
}
