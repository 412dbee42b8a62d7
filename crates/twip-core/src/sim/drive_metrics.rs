//! What the motors got over a run (issue: "drive figures that are what the motor saw"):
//! the largest input the plant received after the driver's clamps, and the share of
//! control periods whose command the driver could not deliver. Written once over
//! [`Lane`]: a run's observer and a sweep's lanes.
use crate::model::lane::Lane;
use crate::Real;

/// The running peak and counts behind [`DrivePeaks`](crate::sim::metrics::DrivePeaks).
#[derive(Clone, Copy, Debug)]
pub(crate) struct DriveTally<S> {
    /// Largest |input| the plant received [the command's units: lumped current, a wheel's
    /// torque], at each step's start.
    pub peak_delivered: S,
    /// Controller updates seen, and those whose command was beyond the driver.
    pub periods: S,
    pub saturated: S,
}

/// How many numbers [`DriveTally`] holds.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
pub(crate) const DRIVE_TALLIES: usize = 3;

impl<S: Lane> DriveTally<S> {
    pub(crate) fn new() -> Self {
        let z = S::splat(0.0);
        Self { peak_delivered: z, periods: z, saturated: z }
    }

    /// A step's start where `on`: the largest |input| the plant gets (`delivered`), and
    /// at a controller update (`update`) whether the command applied from then on is
    /// beyond the driver (`beyond`).
    #[inline(always)]
    pub(crate) fn observe(&mut self, on: S::Mask, delivered: S, update: S::Mask, beyond: S::Mask) {
        self.peak_delivered = S::select(on, self.peak_delivered.larger(delivered), self.peak_delivered);
        let counted = on & update;
        self.periods = S::select(counted, self.periods + S::splat(1.0), self.periods);
        self.saturated = S::select(counted & beyond, self.saturated + S::splat(1.0), self.saturated);
    }
}

#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
impl<S: Copy> DriveTally<S> {
    /// The fields in declaration order (a sweep keeps one array per field).
    #[inline(always)]
    pub(crate) fn to_array(self) -> [S; DRIVE_TALLIES] {
        [self.peak_delivered, self.periods, self.saturated]
    }

    /// The tally from [`Self::to_array`]'s order.
    #[inline(always)]
    pub(crate) fn from_array(a: [S; DRIVE_TALLIES]) -> Self {
        let [peak_delivered, periods, saturated] = a;
        Self { peak_delivered, periods, saturated }
    }
}

impl<T: Real> DriveTally<T> {
    /// The share of control periods whose command was beyond the driver (0 before any).
    pub(crate) fn saturation_share(&self) -> T {
        if self.periods > T::zero() { self.saturated / self.periods } else { T::zero() }
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use crate::control::lqr::{design, DesignPoint, LqrController};
    use crate::control::reference::SpeedSchedule;
    use crate::hardware::driver::MotorDriver;
    use crate::hardware::realism::Realism;
    use crate::sim::metrics::{SlopeMetrics, SlopeSummary};
    use crate::sim::runner::{simulate, SimConfig};
    use crate::{RobotParams, SlopeModel};
    use nalgebra::{Matrix4, Vector4};

    /// The summary of a 2 s run of the Balanbot's LQR from a 0.25 rad lean, ideal or through
    /// `realism`.
    fn run(realism: Option<Realism<f64>>) -> SlopeSummary<f64> {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
        let q = Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
        let d = design(&model, 0.0, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
        let mut ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 5e-3).unwrap();
        let schedule = SpeedSchedule::constant(0.0).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 2.0, fall_limit: 1.2 };
        let x0 = Vector4::new(0.25, 0.0, 0.0, 0.0);
        let mut metrics = SlopeMetrics::new(model);
        match realism {
            None => simulate(&model, &mut ctrl, &schedule, &x0, &config, &mut metrics).unwrap(),
            Some(r) => r.build(&model, config.dt).unwrap().simulate(&mut ctrl, &schedule, &x0, &config, &mut metrics, || false).unwrap(),
        };
        metrics.summary()
    }

    /// The user's case (3.56 A asked of a 3 A driver, `tests/test_drive_figures.py`) in
    /// small: a driver that clamps under a controller that asks more.
    /// The motor's peak is the clamped current, the command's beside it, and some control
    /// periods count as saturated; the ideal loop delivers every command.
    #[test]
    fn the_peak_current_is_after_the_drivers_clamp() {
        let ideal = run(None);
        assert_eq!(ideal.peak_current, ideal.peak_command);
        assert_eq!(ideal.saturation_share, 0.0);
        // The lean asks 1.38 A of each motor: a driver of 0.8 A clamps it.
        let limit = 0.8;
        assert!(ideal.peak_command > limit, "the lean should ask more than {limit} A: {}", ideal.peak_command);
        // A battery that never limits the duty: only the current limit clamps.
        let driver = MotorDriver { current_limit: limit, battery: 60.0, assumed_battery: 60.0, ..MotorDriver::thesis_like() };
        let rig = run(Some(Realism { motor: Some(driver), ..Realism::thesis_like() }));
        assert!(rig.peak_command > limit, "asked {} A", rig.peak_command);
        assert!(rig.peak_current <= limit, "the motor carried {} A past its driver's {limit} A", rig.peak_current);
        // The winding's current, not what the wheel's torque reads as through a lossless
        // gearbox: the thesis-like gearbox passes 0.87 of the torque, and the clamped
        // winding carries the whole limit.
        assert!(driver.efficiency < 1.0);
        assert!((rig.peak_current - limit).abs() < 1e-9, "the clamped winding carried {} A, not {limit} A", rig.peak_current);
        assert!(rig.saturation_share > 0.0 && rig.saturation_share < 1.0, "share {}", rig.saturation_share);
        // Without a limit, the duty at full saturates on a 3 V battery (1 V past the bridge: 0.58 A at stall).
        let unlimited = MotorDriver { current_limit: f64::INFINITY, battery: 3.0, assumed_battery: 3.0, ..MotorDriver::thesis_like() };
        let rail = run(Some(Realism { motor: Some(unlimited), ..Realism::thesis_like() }));
        assert!(rail.saturation_share > 0.0, "share {}", rail.saturation_share);
        // Nothing clamps a driver that can give everything asked.
        let ample = MotorDriver { current_limit: f64::INFINITY, battery: 1e4, assumed_battery: 1e4, ..MotorDriver::thesis_like() };
        let free = run(Some(Realism { motor: Some(ample), ..Realism::thesis_like() }));
        assert_eq!(free.saturation_share, 0.0);
    }
}
