//! The LQR + integral controller designed at its own period: the plant held by a zero-order
//! hold over one period (exact, [`c2d`]), the integrator as the controller runs it (forward
//! Euler, `z[k+1] = z[k] + T (θ̇[k] − θ̇_ref)`), then [`dlqr`] with the thesis's weights.
//!
//! With `delay`, the design also knows that the rig applies each command one period late
//! (`Realism::delay`): the model gains the held previous command `v[k] = u[k−1]`,
//! `x[k+1] = Φ x[k] + Γ v[k]`, `v[k+1] = u[k]`. The law the controller runs (lanes, C ABI,
//! firmware) has four gains and no memory of its last command, so the gain on `v` is not
//! available: the four gains are the best *structured* state feedback `u = −K x̂` on the
//! delayed model, minimising the LQ cost `Σ x̂ᵀ Q̂ x̂ + u R̂ u` summed over initial states
//! `E[ξ₀ ξ₀ᵀ] = I` (Levine–Athans). Descent from the delay-free gains by the Anderson–Moore
//! step (a preconditioned gradient step) with backtracking, each cost from a Stein equation.
#![allow(clippy::neg_cmp_op_on_partial_ord)]
use alloc::vec::Vec;

use nalgebra::{Complex, DMatrix, Matrix4, Vector4};

use crate::control::c2d::c2d;
use crate::control::care::schur::{schur, sorted_eigenvalues};
use crate::control::dare::dlqr;
use crate::control::dare::stein::stein_schur;
use crate::control::lqr::{linear_model, DesignPoint, LqrDesign};
use crate::model::slope::SlopeModel;
use crate::{c, Real, TwipError};

/// Cap on the descent steps of the delay-aware design (it takes ~10–50).
const DELAY_MAX_ITER: usize = 500;
/// Cap on the step halvings within one descent step.
const DELAY_MAX_HALVINGS: usize = 40;

/// Designs K̂ for `model` at `theta_dot_ref` in discrete time at `period` (see the module
/// docs). The result's `a`, `b` are the discrete Â, B̂ on `[Δφ, Δφ̇, Δθ̇, z]`; with `delay`,
/// `x` is the 5×5 cost matrix of the delayed loop on `[Δx̂, v]` and `poles` its 5 eigenvalues.
pub fn design_discrete<T: Real>(
    model: &SlopeModel<T>,
    theta_dot_ref: T,
    q: &Matrix4<T>,
    r: T,
    point: DesignPoint,
    period: T,
    delay: bool,
) -> Result<LqrDesign<T>, TwipError> {
    let (a3, b3, phi_s, u_s) = linear_model(model, theta_dot_ref, point)?;
    let (phi, gamma) = c2d(&DMatrix::from_fn(3, 3, |i, j| a3[(i, j)]), &DMatrix::from_fn(3, 1, |i, _| b3[i]), period)?;
    let mut a = Matrix4::<T>::zeros();
    a.fixed_view_mut::<3, 3>(0, 0).copy_from(&phi.fixed_view::<3, 3>(0, 0));
    a[(3, 2)] = period;
    a[(3, 3)] = T::one();
    let b = Vector4::new(gamma[0], gamma[1], gamma[2], T::zero());
    let ad = DMatrix::from_fn(4, 4, |i, j| a[(i, j)]);
    let bd = DMatrix::from_fn(4, 1, |i, _| b[i]);
    let qd = DMatrix::from_fn(4, 4, |i, j| q[(i, j)]);
    let plain = dlqr(&ad, &bd, &qd, &DMatrix::from_element(1, 1, r))?;
    let k = &plain.k;
    let gains = [k[(0, 0)], k[(0, 1)], k[(0, 2)], k[(0, 3)]];
    if !delay {
        return Ok(LqrDesign { gains, a, b, x: plain.x, poles: plain.poles, phi_s, u_s });
    }
    let delayed = Delayed::new(&ad, &bd, &qd, r);
    let (gains, x, poles) = delayed.optimise(gains)?;
    Ok(LqrDesign { gains, a, b, x, poles, phi_s, u_s })
}

/// The delayed loop on `ξ = [x̂; v]`: `ξ[k+1] = (F − G K E) ξ[k]` with `F = [[Â, B̂], [0, 0]]`,
/// `G = e₅`, `E = [I₄, 0]`, stage cost `x̂ᵀ (Q̂ + Kᵀ R̂ K) x̂`.
struct Delayed<T: Real> {
    f: DMatrix<T>,
    q: DMatrix<T>,
    r: T,
}

/// A stabilising gain's cost: `J = tr P`, `P` and `L` (the loop's cost and state-sum
/// matrices), and the closed loop.
struct Evaluated<T: Real> {
    j: T,
    p: DMatrix<T>,
    l: DMatrix<T>,
    closed: DMatrix<T>,
}

impl<T: Real> Delayed<T> {
    fn new(a: &DMatrix<T>, b: &DMatrix<T>, q: &DMatrix<T>, r: T) -> Self {
        let mut f = DMatrix::<T>::zeros(5, 5);
        f.view_mut((0, 0), (4, 4)).copy_from(a);
        f.view_mut((0, 4), (4, 1)).copy_from(b);
        Self { f, q: q.clone(), r }
    }

    /// The cost of `k`, or `None` if it does not stabilise the delayed loop.
    fn evaluate(&self, k: &[T; 4]) -> Option<Evaluated<T>> {
        let mut closed = self.f.clone();
        for (j, kj) in k.iter().enumerate() {
            closed[(4, j)] = -*kj;
        }
        let (u, t) = schur(closed.clone())?;
        let stable = crate::control::care::schur::quasi_eigenvalues(&t).iter().all(|l| l.re.hypot(l.im) < T::one() - c::<T>(1e-12));
        if !stable {
            return None;
        }
        let mut stage = DMatrix::<T>::zeros(5, 5);
        for i in 0..4 {
            for j in 0..4 {
                stage[(i, j)] = self.q[(i, j)] + k[i] * self.r * k[j];
            }
        }
        // Aᵀ P A − P = −stage, and A L Aᵀ − L = −I (on Aᵀ's Schur form).
        let p = stein_schur(&u, &t, &(-stage));
        let (ut, tt) = schur(closed.transpose())?;
        let l = stein_schur(&ut, &tt, &(-DMatrix::<T>::identity(5, 5)));
        let j = p.trace();
        (j.is_finite() && l.iter().all(|v| v.is_finite())).then_some(Evaluated { j, p, l, closed })
    }

    /// The Anderson–Moore point `K* = (R + Gᵀ P G)⁻¹ Gᵀ P F L Eᵀ (E L Eᵀ)⁻¹`, where the
    /// gradient `2 (R + Gᵀ P G)(K − K*) E L Eᵀ` vanishes for fixed P and L.
    fn target(&self, e: &Evaluated<T>) -> Option<[T; 4]> {
        let pf = e.p.row(4) * &self.f;
        let num = pf * &e.l.view((0, 0), (5, 4));
        let ele = e.l.view((0, 0), (4, 4)).into_owned();
        let k = ele.lu().solve(&num.transpose())?;
        let scale = self.r + e.p[(4, 4)];
        Some([k[0] / scale, k[1] / scale, k[2] / scale, k[3] / scale])
    }

    /// Descends from `k0` (the delay-free gains) to a stationary point of the cost.
    #[allow(clippy::type_complexity)]
    fn optimise(&self, k0: [T; 4]) -> Result<([T; 4], DMatrix<T>, Vec<Complex<T>>), TwipError> {
        let unstable_start = TwipError::NoConvergence {
            what: "delay-aware LQR design (the delay-free gains do not stabilise the delayed model; try a shorter period)",
            iterations: 0,
        };
        let mut k = k0;
        let mut current = self.evaluate(&k).ok_or(unstable_start)?;
        let tol = c::<T>(1e-13);
        for _ in 0..DELAY_MAX_ITER {
            let Some(target) = self.target(&current) else { break };
            let mut step = T::one();
            let mut accepted = None;
            for _ in 0..DELAY_MAX_HALVINGS {
                let trial: [T; 4] = core::array::from_fn(|i| k[i] + step * (target[i] - k[i]));
                if let Some(e) = self.evaluate(&trial) {
                    if e.j < current.j {
                        accepted = Some((trial, e));
                        break;
                    }
                }
                step *= c::<T>(0.5);
            }
            let Some((trial, e)) = accepted else { break };
            let gained = current.j - e.j;
            k = trial;
            current = e;
            if !(gained > tol * current.j) {
                break;
            }
        }
        let poles = sorted_eigenvalues(current.closed.clone())?;
        Ok((k, current.p, poles))
    }
}
