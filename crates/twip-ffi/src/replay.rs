//! Host only (feature `std`): a closed-loop run of a configured `f32` controller on the
//! `f32` plant, recording what the controller read and answered at every update. A C
//! harness replays the measurements and references through the C ABI and must answer the
//! same commands (`twip export`'s `make check`).
use std::vec::Vec;

use nalgebra::SVector;
use twip_core::control::reference::SpeedRef;
use twip_core::control::trajectory::PlanarRef;
use twip_core::control::{Controller, Reference};
use twip_core::model::dynamics::Dynamics;
use twip_core::sim::runner::{simulate, Outcome, SimConfig};
use twip_core::{PlanarModel, SlopeModel, TwipError};

use crate::config::{narrow, TwipFriction, TwipRobot};
use crate::controllers::{TwipPlanarRef, TwipSpeedRef};

/// The `f32` plant of an `f64` model, through the C configuration's conversions.
pub fn slope_f32(m: &SlopeModel<f64>) -> Result<SlopeModel<f32>, TwipError> {
    SlopeModel::new(TwipRobot::from_core(m.params())?.to_core(), narrow("slope", m.slope())?)?
        .with_friction(TwipFriction::from_core(m.friction())?.to_core())
}

/// The `f32` plant of an `f64` planar model.
pub fn planar_f32(m: &PlanarModel<f64>) -> Result<PlanarModel<f32>, TwipError> {
    PlanarModel::new(TwipRobot::from_core(m.params())?.to_core())?.with_friction(TwipFriction::from_core(m.friction())?.to_core())
}

/// Every controller update of a run: time, measurement, reference and command.
#[derive(Clone, Debug, Default)]
pub struct Record<const NX: usize, const NU: usize, R> {
    pub t: Vec<f32>,
    pub y: Vec<[f32; NX]>,
    pub reference: Vec<R>,
    pub u: Vec<[f32; NU]>,
}

impl<const NX: usize, const NU: usize, R> Record<NX, NU, R> {
    /// Room for `updates` updates, reserved fallibly: a run too long for memory is an error
    /// naming `t_final`, never an abort.
    fn with_capacity(updates: usize) -> Result<Self, TwipError> {
        let row = core::mem::size_of::<f32>() + core::mem::size_of::<[f32; NX]>() + core::mem::size_of::<R>()
            + core::mem::size_of::<[f32; NU]>();
        let oom = |_| TwipError::OutOfMemory { name: "t_final", bytes: (updates as u64).saturating_mul(row as u64) };
        let mut record = Self { t: Vec::new(), y: Vec::new(), reference: Vec::new(), u: Vec::new() };
        record.t.try_reserve_exact(updates).map_err(oom)?;
        record.y.try_reserve_exact(updates).map_err(oom)?;
        record.reference.try_reserve_exact(updates).map_err(oom)?;
        record.u.try_reserve_exact(updates).map_err(oom)?;
        Ok(record)
    }
}

/// A reference sample as the C ABI takes it, from the `f64` sample.
pub trait ToC: Copy {
    type C: Copy;
    type F32: Copy;
    fn to_c(self) -> Self::C;
    fn to_f32(self) -> Self::F32;
}

impl ToC for SpeedRef<f64> {
    type C = TwipSpeedRef;
    type F32 = SpeedRef<f32>;
    fn to_c(self) -> TwipSpeedRef {
        TwipSpeedRef { theta: self.theta as f32, theta_dot: self.theta_dot as f32 }
    }
    fn to_f32(self) -> SpeedRef<f32> {
        SpeedRef { theta: self.theta as f32, theta_dot: self.theta_dot as f32 }
    }
}

impl ToC for PlanarRef<f64> {
    type C = TwipPlanarRef;
    type F32 = PlanarRef<f32>;
    fn to_c(self) -> TwipPlanarRef {
        let c = self.to_f32();
        TwipPlanarRef { x: c.x, y: c.y, psi: c.psi, v: c.v, omega: c.omega, v_dot: c.v_dot, omega_dot: c.omega_dot }
    }
    fn to_f32(self) -> PlanarRef<f32> {
        PlanarRef {
            x: self.x as f32,
            y: self.y as f32,
            psi: self.psi as f32,
            v: self.v as f32,
            omega: self.omega as f32,
            v_dot: self.v_dot as f32,
            omega_dot: self.omega_dot as f32,
        }
    }
}

/// An `f64` schedule sampled in `f64` at the `f32` time and handed over in `f32` (a
/// firmware computes its reference in its own code; the replay gives it as input).
struct InF32<'a, R>(&'a R);

impl<R> Reference<f32> for InF32<'_, R>
where
    R: Reference<f64>,
    R::Sample: ToC,
{
    type Sample = (<R::Sample as ToC>::F32, <R::Sample as ToC>::C);
    fn sample(&self, t: f32) -> Self::Sample {
        let s = self.0.sample(t as f64);
        (s.to_f32(), s.to_c())
    }
}

/// The controller, recording each update.
struct Recorder<'a, C, RC, const NX: usize, const NU: usize> {
    inner: C,
    record: &'a mut Record<NX, NU, RC>,
}

impl<C, RF, RC, const NX: usize, const NU: usize> Controller<f32, NX, NU> for Recorder<'_, C, RC, NX, NU>
where
    C: Controller<f32, NX, NU, Reference = RF>,
    RF: Copy,
    RC: Copy,
{
    type Reference = (RF, RC);

    fn period(&self) -> f32 {
        self.inner.period()
    }

    fn reset(&mut self) {
        self.inner.reset();
    }

    fn update(&mut self, t: f32, y: &SVector<f32, NX>, reference: &(RF, RC)) -> SVector<f32, NU> {
        let u = self.inner.update(t, y, &reference.0);
        self.record.t.push(t);
        self.record.y.push((*y).into());
        self.record.reference.push(reference.1);
        self.record.u.push(u.into());
        u
    }

    fn internals(&self) -> &[f32] {
        self.inner.internals()
    }

    fn internal_names(&self) -> &'static [&'static str] {
        self.inner.internal_names()
    }
}

/// Runs `controller` (reset first) on `plant` from `x0` for `t_final` [s] at steps of `dt`,
/// ideal sensing, recording every update. The run stops early if the robot falls.
/// A recorded run of a controller whose reference samples have C form `Cr`, and how it ended.
pub type Recorded<const NX: usize, const NU: usize, Cr> = (Record<NX, NU, Cr>, Outcome<f32>);

#[allow(clippy::too_many_arguments)]
pub fn record<P, C, R, const NX: usize, const NU: usize>(
    plant: &P,
    mut controller: C,
    reference: &R,
    x0: [f32; NX],
    dt: f32,
    t_final: f32,
) -> Result<Recorded<NX, NU, <R::Sample as ToC>::C>, TwipError>
where
    P: Dynamics<f32, NX, NU> + Clone,
    C: Controller<f32, NX, NU, Reference = <R::Sample as ToC>::F32>,
    R: Reference<f64>,
    R::Sample: ToC,
{
    controller.reset();
    let config = SimConfig::new(dt, t_final, None);
    let (steps, per_update) = config.steps(controller.period())?;
    let mut record = Record::with_capacity(steps / per_update + 1)?;
    let mut recorder = Recorder { inner: controller, record: &mut record };
    let (outcome, _) = simulate(plant, &mut recorder, &InF32(reference), &SVector::from(x0), &config, &mut ())?;
    Ok((record, outcome))
}
