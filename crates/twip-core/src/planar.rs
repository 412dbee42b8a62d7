//! The 3-DOF planar model (thesis 3.29–3.48), re-derived. Physics being written.
use nalgebra::{Matrix3, SVector};

use crate::{Dynamics, Real, RobotParams, TwipError};

/// State `[x, y, psi, phi, phi_dot, v, omega]`.
pub type PlanarState<T> = SVector<T, 7>;

#[derive(Clone, Copy, Debug)]
pub struct PlanarModel<T> {
    params: RobotParams<T>,
}

impl<T: Real> PlanarModel<T> {
    pub fn new(params: RobotParams<T>) -> Result<Self, TwipError> {
        Ok(Self { params: params.validate()? })
    }

    pub fn params(&self) -> &RobotParams<T> {
        &self.params
    }

    pub fn mass_matrix(&self, _phi: T) -> Matrix3<T> {
        Matrix3::identity()
    }
}

impl<T: Real> Dynamics<T, 7, 2> for PlanarModel<T> {
    fn deriv(&self, _x: &PlanarState<T>, _u: &SVector<T, 2>) -> PlanarState<T> {
        PlanarState::zeros()
    }

    fn energy(&self, _x: &PlanarState<T>) -> T {
        T::zero()
    }
}
