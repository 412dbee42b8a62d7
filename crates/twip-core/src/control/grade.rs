//! The grade's feed-forward for a 3-DOF tracker on terrain (docs/terrain.md): the tracker
//! designed on flat ground is wrapped so that it sees its pitch from the rest pitch of the
//! local grade and gets that grade's equilibrium torque added to its output.
//!
//! At the robot's (x, y) and heading ψ the terrain's local plane gives the rest pitch φ_s and
//! the wheel torques (u_r, u_l) that hold the robot still there ([`TerrainModel::rest`]): on a
//! plane the wrapped tracker's own equilibrium (zero errors, zero output) is then the robot's
//! equilibrium on the grade, so nothing has to be wound up in an integral first.
use nalgebra::SVector;

use crate::control::pid::relative_wheel_speeds;
use crate::control::trajectory::PlanarRef;
use crate::control::Controller;
use crate::hardware::motor::DcMotor;
use crate::model::lane::clamp;
use crate::model::terrain_model::TerrainModel;
use crate::Real;

/// A 3-DOF tracker `C` with the grade's feed-forward of a terrain.
#[derive(Clone, Debug)]
pub struct GradeFeedForward<T: Real, C> {
    inner: C,
    ground: TerrainModel<T>,
    /// The motor whose torque range the sum is held in (at each wheel's speed), if any.
    motor: Option<DcMotor<T>>,
}

impl<T: Real, C: Controller<T, 7, 2, Reference = PlanarRef<T>>> GradeFeedForward<T, C> {
    /// `inner` on the terrain of `ground` (its robot's parameters give the rest torques);
    /// the sum of `inner`'s output and the feed-forward is held within `motor`'s torques.
    pub fn new(inner: C, ground: TerrainModel<T>, motor: Option<DcMotor<T>>) -> Self {
        Self { inner, ground, motor }
    }

    /// The same tracker and robot with the feed-forward of `terrain` (a sweep's sample on
    /// its own drawn plane).
    pub fn on(&self, terrain: crate::model::terrain::Terrain<T>) -> Self
    where
        C: Clone,
    {
        Self { inner: self.inner.clone(), ground: TerrainModel::new(self.ground.flat().clone(), terrain), motor: self.motor }
    }

    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// The terrain model whose rest it feeds forward and the motor it holds the sum within
    /// (a sweep's lanes').
    #[cfg(feature = "std")]
    pub(crate) fn parts(&self) -> (&TerrainModel<T>, Option<&DcMotor<T>>) {
        (&self.ground, self.motor.as_ref())
    }

    /// The rest pitch and torques at measurement `y`; zero where there is no rest (a grade
    /// steeper than the body can balance, or off a grid: the run ends there anyway).
    pub fn feed_forward(&self, y: &SVector<T, 7>) -> (T, [T; 2]) {
        self.ground.rest(y[0], y[1], y[2]).unwrap_or((T::zero(), [T::zero(); 2]))
    }
}

impl<T: Real, C: Controller<T, 7, 2, Reference = PlanarRef<T>>> Controller<T, 7, 2> for GradeFeedForward<T, C> {
    type Reference = PlanarRef<T>;

    fn period(&self) -> T {
        self.inner.period()
    }

    fn reset(&mut self) {
        self.inner.reset();
    }

    fn update(&mut self, t: T, y: &SVector<T, 7>, r: &PlanarRef<T>) -> SVector<T, 2> {
        let (phi_s, torque) = self.feed_forward(y);
        let mut seen = *y;
        seen[3] -= phi_s;
        let u = self.inner.update(t, &seen, r);
        let mut out = [u[0] + torque[0], u[1] + torque[1]];
        if let Some(m) = &self.motor {
            let p = self.ground.flat().params();
            let speeds = relative_wheel_speeds(&(*y).into(), p.wheel_radius, p.half_track);
            for (ui, w) in out.iter_mut().zip(speeds) {
                let (lo, hi) = m.torque_limits(w);
                *ui = clamp(*ui, lo, hi);
            }
        }
        SVector::<T, 2>::from(out)
    }

    fn internals(&self) -> &[T] {
        self.inner.internals()
    }

    fn internal_names(&self) -> &'static [&'static str] {
        self.inner.internal_names()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::pid::PidTracker;
    use crate::model::terrain::Terrain;
    use crate::{Dynamics, PlanarModel, RobotParams};

    /// Standing still on a 10° plane (uphill 0.3 rad off the heading): with the feed-forward
    /// the PID's own equilibrium (zero errors, zero output) is the robot's rest on the grade;
    /// without it the same state accelerates.
    #[test]
    fn at_the_rest_state_the_wrapped_pid_holds_still() {
        let p = RobotParams::<f64>::balanbot();
        let motor = DcMotor::gb37y3530();
        let ground = TerrainModel::new(PlanarModel::new(p).unwrap(), Terrain::plane(10f64.to_radians(), 0.3).unwrap());
        let pid = PidTracker::table_4_1(&p, motor, 0.005).unwrap();
        let (phi_s, _) = ground.rest(0.0, 0.0, 0.0).unwrap();
        assert!(phi_s > 0.01, "{phi_s}");
        let x0 = SVector::<f64, 7>::from([0.0, 0.0, 0.0, phi_s, 0.0, 0.0, 0.0]);
        let r = PlanarRef::default();
        let u = GradeFeedForward::new(pid, ground.clone(), Some(motor)).update(0.0, &x0, &r);
        let held = ground.deriv(&x0, &u).amax();
        assert!(held < 1e-12, "{held}");
        let u = pid.clone().update(0.0, &x0, &r);
        assert!(ground.deriv(&x0, &u).amax() > 1.0);
    }
}
