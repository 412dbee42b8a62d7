//! A decimated trajectory log for the runner, allocated once before the run.
use alloc::vec::Vec;

use nalgebra::SVector;

use crate::control::reference::SpeedRef;
use crate::control::trajectory::PlanarRef;
use crate::sim::runner::Observer;
use crate::{Real, TwipError};

/// A reference sample flattened into a row of the log.
pub trait LogRow<T> {
    /// Column names.
    const NAMES: &'static [&'static str];
    fn push_row(&self, out: &mut Vec<T>);
}

impl<T: Real> LogRow<T> for SpeedRef<T> {
    const NAMES: &'static [&'static str] = &["theta", "theta_dot"];
    fn push_row(&self, out: &mut Vec<T>) {
        out.push(self.theta);
        out.push(self.theta_dot);
    }
}

impl<T: Real> LogRow<T> for PlanarRef<T> {
    const NAMES: &'static [&'static str] = &["x", "y", "psi", "v", "omega", "v_dot", "omega_dot"];
    fn push_row(&self, out: &mut Vec<T>) {
        out.extend_from_slice(&[self.x, self.y, self.psi, self.v, self.omega, self.v_dot, self.omega_dot]);
    }
}

/// Row-major buffers: one row per kept sample.
#[derive(Clone, Debug, Default)]
pub struct TrajectoryLog<T> {
    pub every: usize,
    pub t: Vec<T>,
    pub x: Vec<T>,
    pub u: Vec<T>,
    pub reference: Vec<T>,
    pub internals: Vec<T>,
    seen: usize,
}

impl<T: Real> TrajectoryLog<T> {
    /// Room for `samples` samples, keeping one in `every` (the last one always). The
    /// buffers are reserved fallibly: a log too large for memory is an error naming
    /// `record_every` (what shrinks it), never an abort.
    pub fn with_capacity(samples: usize, every: usize, widths: [usize; 4]) -> Result<Self, TwipError> {
        let every = every.max(1);
        let rows = samples / every + 2;
        let mut log = Self { every, t: Vec::new(), x: Vec::new(), u: Vec::new(), reference: Vec::new(), internals: Vec::new(), seen: 0 };
        let bytes = |width: usize| (rows as u64).saturating_mul(width as u64).saturating_mul(core::mem::size_of::<T>() as u64);
        let total = bytes(1 + widths.iter().sum::<usize>());
        let oom = |_| TwipError::OutOfMemory { name: "record_every", bytes: total };
        let size = |width: usize| rows.checked_mul(width).ok_or(TwipError::OutOfMemory { name: "record_every", bytes: total });
        log.t.try_reserve_exact(rows).map_err(oom)?;
        log.x.try_reserve_exact(size(widths[0])?).map_err(oom)?;
        log.u.try_reserve_exact(size(widths[1])?).map_err(oom)?;
        log.reference.try_reserve_exact(size(widths[2])?).map_err(oom)?;
        log.internals.try_reserve_exact(size(widths[3])?).map_err(oom)?;
        Ok(log)
    }

    pub fn len(&self) -> usize {
        self.t.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t.is_empty()
    }

    fn push<const NX: usize, const NU: usize, S: LogRow<T>>(
        &mut self,
        t: T,
        x: &SVector<T, NX>,
        u: &SVector<T, NU>,
        r: &S,
        internals: &[T],
    ) {
        self.t.push(t);
        self.x.extend_from_slice(x.as_slice());
        self.u.extend_from_slice(u.as_slice());
        r.push_row(&mut self.reference);
        self.internals.extend_from_slice(internals);
    }
}

impl<T: Real, const NX: usize, const NU: usize, S: LogRow<T>> Observer<T, NX, NU, S> for TrajectoryLog<T> {
    fn observe(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]) {
        if self.seen % self.every == 0 {
            self.push(t, x, u, r, internals);
        }
        self.seen += 1;
    }

    fn observe_last(&mut self, t: T, x: &SVector<T, NX>, u: &SVector<T, NU>, r: &S, internals: &[T]) {
        self.push(t, x, u, r, internals);
        self.seen += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::runner::{simulate, SimConfig};
    use crate::control::lqr::{DesignPoint, LqrController};
    use crate::control::Controller;
    use crate::{RobotParams, SlopeModel};
    use crate::control::reference::SpeedSchedule;
    use nalgebra::Vector4;

    /// With any stride the log ends with the run's final sample: the end, or the fall.
    #[test]
    fn the_last_sample_is_kept_whatever_the_stride() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
        let schedule = SpeedSchedule::constant(0.0).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 0.1, fall_limit: 0.5 };
        let upright = LqrController::new([-11.0, -1.7, -0.05, -0.045], model, DesignPoint::OperatingPoint, 1e-3).unwrap();
        let limp = LqrController::new([0.0; 4], model, DesignPoint::OperatingPoint, 1e-3).unwrap();
        for (mut ctrl, x0) in [(upright, Vector4::zeros()), (limp, Vector4::new(0.45, 2.0, 0.0, 0.0))] {
            for every in [1, 7, 50, 1000] {
                let mut log = TrajectoryLog::with_capacity(101, every, [4, 1, 2, ctrl.internal_names().len()]).unwrap();
                let (_, steps) = simulate(&model, &mut ctrl, &schedule, &x0, &config, &mut log).unwrap();
                assert_eq!(*log.t.last().unwrap(), config.dt * steps as f64, "every {every}");
                assert_eq!(log.len(), steps / every + 1 + usize::from(steps % every != 0), "every {every}");
            }
        }
    }
}
