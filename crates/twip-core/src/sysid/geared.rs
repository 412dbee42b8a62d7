//! A shooting model with gear play: the realism rig's own plant ([`RealPlant`]), its gear
//! trains' backlash and gearhead friction, and the motor driver when the log's input is a
//! PWM duty. Each step starts as the simulator starts it (`between_steps`: the open rotors'
//! elapsed step and impacts, the winding's step, the trains that open), so that an exact
//! log of the rig is predicted step for step.
use nalgebra::{SVector, Vector4};

use super::ShootingModel;
use crate::hardware::backlash::{Backlash, GearEvent, PlayState};
use crate::hardware::disturbance::Disturbed;
use crate::hardware::driver::{Driven, MotorDriver};
use crate::sim::runner::Plant;
use crate::hardware::realism::RealPlant;
use crate::{Real, SlopeModel, TwipError};

/// `model` (with its gearhead friction) through gear trains with `backlash`'s play, driven
/// through `driver` (a PWM log) or by the lumped current (None), as a realism rig builds it.
pub fn geared<T: Real>(model: &SlopeModel<T>, driver: Option<&MotorDriver<T>>, backlash: Backlash<T>) -> Result<RealPlant<T>, TwipError> {
    let ground = Disturbed::plain(model).with_backlash(Some(backlash))?;
    Ok(match driver {
        None => RealPlant::Current(ground),
        Some(d) => RealPlant::Driven(Driven::new(ground, d, model.params())?),
    })
}

impl<T: Real> ShootingModel<T> for RealPlant<T> {
    /// The motors turn with the open rotors; an inductive winding starts at the steady
    /// current of the duty held before the segment (as `Driven`'s).
    fn start_segment(&mut self, x: &Vector4<T>, before: T) {
        if let Self::Driven(p) = self {
            let open = p.plant().open_rotor_speed(x);
            p.turn_motors_at(open);
            p.settle(x, before);
        }
    }

    fn start_step(&mut self, x: &mut Vector4<T>, u: T, dt: T) -> Option<Vector4<T>> {
        // No pushes: the time does not matter.
        self.between_steps_with_derivative(T::zero(), dt, x, &SVector::<T, 1>::new(u))
    }

    fn end_step(&mut self, x: &Vector4<T>) {
        self.step_ended(x);
    }

    fn play(&self) -> Option<PlayState<T, 1>> {
        self.ground().play_state()
    }

    fn set_play(&mut self, state: &PlayState<T, 1>) {
        self.ground_mut().set_play_state(state);
    }

    fn shaft_offset(&self) -> T {
        self.ground().shaft_offset()
    }

    fn script(&mut self, events: Option<GearEvent>) {
        self.ground_mut().script_gears(events);
    }

    fn events(&self) -> Option<GearEvent> {
        self.ground().gear_events()
    }
}
