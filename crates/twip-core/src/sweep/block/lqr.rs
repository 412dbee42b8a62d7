//! LQR with integral action on lanes: `control::lqr::law` on each lane.
use super::{LaneLaw, Slope};
use crate::control::lqr::{law, LqrController};
use crate::control::reference::SpeedRef;
use crate::control::Controller;
use crate::model::lane::Fused;
use crate::sweep::lanes::{Lanes, LANES};

/// The prototype's gains and steady state, shared by the lanes; each lane's integrator.
#[derive(Clone, Debug)]
pub struct LqrLanes {
    controller: LqrController<f64>,
    gains: [Fused; 4],
    /// (θ̇_ref, φ_s, u_s) of the last reference speed: speeds change rarely.
    steady: Option<(f64, f64, f64)>,
}

impl LqrLanes {
    pub fn new(prototype: &LqrController<f64>) -> Self {
        Self { controller: *prototype, gains: prototype.gains().map(Fused), steady: None }
    }

    /// (φ_s, u_s) at `speed`, as `LqrController::update` finds it: cached, since speeds
    /// change rarely (the check stays in the lanes' loop, the solve out of it).
    #[inline(always)]
    fn steady_state(&mut self, speed: f64) -> (f64, f64) {
        match self.steady {
            Some((s, phi_s, u_s)) if s == speed => (phi_s, u_s),
            _ => self.solve_steady_state(speed),
        }
    }

    #[cold]
    #[inline(never)]
    fn solve_steady_state(&mut self, speed: f64) -> (f64, f64) {
        let (phi_s, u_s) = self.controller.steady_state(speed).unwrap_or((0.0, 0.0));
        self.steady = Some((speed, phi_s, u_s));
        (phi_s, u_s)
    }
}

impl LaneLaw for LqrLanes {
    type Shape = Slope;
    /// The integrator z of each lane.
    type State = Lanes;

    fn period(&self) -> f64 {
        self.controller.period()
    }

    fn start(&self) -> Lanes {
        [0.0; LANES]
    }

    #[inline(always)]
    fn update<const COPY: u8>(&mut self, z: &mut Lanes, x: &[Lanes; 4], r: &SpeedRef<f64>, u: &mut Lanes) {
        let (phi_s, u_s) = self.steady_state(r.theta_dot);
        let (phi_s, u_s, speed, period) = (Fused(phi_s), Fused(u_s), Fused(r.theta_dot), Fused(self.period()));
        // A loop over lanes that the compiler vectorises.
        for l in 0..LANES {
            let y = [Fused(x[0][l]), Fused(x[1][l]), Fused(x[2][l]), Fused(x[3][l])];
            let (ul, zl) = law(&self.gains, phi_s, u_s, &y, speed, Fused(z[l]), period);
            (u[l], z[l]) = (ul.0, zl.0);
        }
    }
}
