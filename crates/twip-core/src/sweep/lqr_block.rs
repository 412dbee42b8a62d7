//! The fast path of a sweep: LQR on the 2-DOF model, [`LANES`] samples at once.
//!
//! Each lane is its own robot (plant coefficients per lane); the controller is the one
//! prototype designed on the nominal robot, so its gains and steady state are shared.
//! The arithmetic is that of `SlopeModel::deriv`, `rk4_step`, `LqrController::update`,
//! the runner and `SlopeMetrics`, with two differences that make it about 1.4× faster:
//! multiply-adds are fused (one rounding instead of two), and constant products are
//! folded per lane. A lane therefore agrees with `runner::simulate` for that robot to
//! rounding (~1e-13 relative over 10 s), not bit for bit; it is bit for bit the same
//! on every CPU, thread count and block neighbour, because a fused multiply-add is
//! exactly rounded wherever it runs. The data layout: one array per quantity, loops
//! over lanes that the compiler vectorises.
use super::lanes::{sin_cos, Lanes, LANES};
use super::{Sample, SampleMetrics, SweepMetrics};
use crate::control::{Controller, Reference};
use crate::control::lqr::LqrController;
use crate::control::reference::{SpeedRef, SpeedSchedule};
use crate::sim::runner::{SimConfig, STOP_CHECK_STEPS};
use crate::model::slope::{SlopeCoefficients, SlopeModel};
use crate::sim::metrics::DrivePeaks;
use crate::TwipError;

/// Plant coefficients, one per lane, folded for the derivative below.
struct Plants {
    m11: Lanes,
    m22: Lanes,
    /// m11 · m22, the constant part of the mass matrix's determinant.
    m11_m22: Lanes,
    /// m r l cos α and m r l sin α: with them sin(φ + α) and cos(φ + α) need only sin φ, cos φ.
    mrl_cos: Lanes,
    mrl_sin: Lanes,
    rotor: Lanes,
    mgl: Lanes,
    grade: Lanes,
    torque_per_amp: Lanes,
    mu_bearing: Lanes,
    mu_ground: Lanes,
}

impl Plants {
    fn new(c: &[SlopeCoefficients<f64>; LANES]) -> Self {
        let get = |f: fn(&SlopeCoefficients<f64>) -> f64| -> Lanes { core::array::from_fn(|l| f(&c[l])) };
        Self {
            m11: get(|c| c.m11),
            m22: get(|c| c.m22),
            m11_m22: get(|c| c.m11 * c.m22),
            mrl_cos: get(|c| c.mrl * c.cos_slope),
            mrl_sin: get(|c| c.mrl * c.sin_slope),
            rotor: get(|c| c.rotor),
            mgl: get(|c| c.mgl),
            grade: get(|c| c.grade),
            torque_per_amp: get(|c| c.torque_per_amp),
            mu_bearing: get(|c| c.mu_bearing),
            mu_ground: get(|c| c.mu_ground),
        }
    }

    /// One lane's plant, with input `u`.
    #[inline(always)]
    fn lane(&self, l: usize, u: f64) -> Lane {
        Lane {
            m11: self.m11[l],
            m22: self.m22[l],
            m11_m22: self.m11_m22[l],
            mrl_cos: self.mrl_cos[l],
            mrl_sin: self.mrl_sin[l],
            rotor: self.rotor[l],
            mgl: self.mgl[l],
            mu_bearing: self.mu_bearing[l],
            mu_ground: self.mu_ground[l],
            motor: self.torque_per_amp[l] * u,
            drive: self.torque_per_amp[l].mul_add(u, -self.grade[l]),
        }
    }

    /// One RK4 step (`rk4_step` of `SlopeModel::deriv`, the input held) on every lane.
    /// The whole step of a lane is one loop body, so that the compiler vectorises it
    /// across lanes with every intermediate kept in registers; each body advances two
    /// lanes (l and l + LANES/2) stage by stage, two independent chains of dependent
    /// operations that the CPU overlaps.
    #[inline(always)]
    fn rk4(&self, x: &[Lanes; 4], u: &Lanes, dt: f64) -> [Lanes; 4] {
        const HALF: usize = LANES / 2;
        let mut out = [[0.0; LANES]; 4];
        let half = dt * 0.5;
        let sixth = dt / 6.0;
        for l in 0..HALF {
            let m = l + HALF;
            let (a, b) = (self.lane(l, u[l]), self.lane(m, u[m]));
            let xa = [x[0][l], x[1][l], x[2][l], x[3][l]];
            let xb = [x[0][m], x[1][m], x[2][m], x[3][m]];
            let (k1a, k1b) = (a.deriv(&xa), b.deriv(&xb));
            let (k2a, k2b) = (a.deriv(&axpy(&xa, &k1a, half)), b.deriv(&axpy(&xb, &k1b, half)));
            let (k3a, k3b) = (a.deriv(&axpy(&xa, &k2a, half)), b.deriv(&axpy(&xb, &k2b, half)));
            let (k4a, k4b) = (a.deriv(&axpy(&xa, &k3a, dt)), b.deriv(&axpy(&xb, &k3b, dt)));
            for i in 0..4 {
                out[i][l] = (k2a[i] + k3a[i]).mul_add(2.0, k1a[i] + k4a[i]).mul_add(sixth, xa[i]);
                out[i][m] = (k2b[i] + k3b[i]).mul_add(2.0, k1b[i] + k4b[i]).mul_add(sixth, xb[i]);
            }
        }
        out
    }
}

/// One lane's plant, and its input for the step.
struct Lane {
    m11: f64,
    m22: f64,
    m11_m22: f64,
    mrl_cos: f64,
    mrl_sin: f64,
    rotor: f64,
    mgl: f64,
    mu_bearing: f64,
    mu_ground: f64,
    /// k_t u, the wheel torque.
    motor: f64,
    /// k_t u − the grade's pull.
    drive: f64,
}

impl Lane {
    /// `SlopeModel::deriv`, with multiply-adds fused.
    #[inline(always)]
    fn deriv(&self, x: &[f64; 4]) -> [f64; 4] {
        let (s, c) = sin_cos(x[0]);
        let (phi_dot, theta_dot) = (x[1], x[3]);
        let bearing = self.mu_bearing * (theta_dot - phi_dot);
        let f_phi = self.mgl.mul_add(s, bearing) - self.motor;
        // m r l sin(φ + α) φ̇², the centripetal term.
        let mrl_sin_pa = self.mrl_cos.mul_add(s, self.mrl_sin * c);
        let friction = (-self.mu_ground).mul_add(theta_dot, self.drive - bearing);
        let f_theta = (mrl_sin_pa * phi_dot).mul_add(phi_dot, friction);
        // m12 = m r l cos(φ + α) − rotor.
        let m12 = self.mrl_cos.mul_add(c, (-self.mrl_sin).mul_add(s, -self.rotor));
        let inv_det = 1.0 / (-m12).mul_add(m12, self.m11_m22);
        [
            phi_dot,
            self.m22.mul_add(f_phi, -(m12 * f_theta)) * inv_det,
            theta_dot,
            self.m11.mul_add(f_theta, -(m12 * f_phi)) * inv_det,
        ]
    }
}

/// x + k h.
#[inline(always)]
fn axpy(x: &[f64; 4], k: &[f64; 4], h: f64) -> [f64; 4] {
    [k[0].mul_add(h, x[0]), k[1].mul_add(h, x[1]), k[2].mul_add(h, x[2]), k[3].mul_add(h, x[3])]
}

/// `SlopeMetrics` on every lane. `observe` is branch-free over the lanes (a lane that
/// has ended adds nothing), so it vectorises like the model.
struct Metrics {
    sum_pitch: Lanes,
    sum_speed: Lanes,
    pitch_band: Lanes,
    pitch_settle: Lanes,
    speed_settle: Lanes,
    final_position_error: Lanes,
    peak_abs_input: Lanes,
    samples: [u64; LANES],
    radius: Lanes,
}

impl Metrics {
    fn new(radius: Lanes, x: &[Lanes; 4], phi_s: &Lanes) -> Self {
        Self {
            sum_pitch: [0.0; LANES],
            sum_speed: [0.0; LANES],
            // Set at the first observation, as `SlopeMetrics` does.
            pitch_band: core::array::from_fn(|l| (0.02 * (phi_s[l] - x[0][l]).abs()).max(0.25f64.to_radians())),
            pitch_settle: [0.0; LANES],
            speed_settle: [0.0; LANES],
            final_position_error: [0.0; LANES],
            peak_abs_input: [0.0; LANES],
            samples: [0; LANES],
            radius,
        }
    }

    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    /// `direction`: the sign of the last nonzero reference speed (see `SlopeMetrics`).
    #[allow(clippy::too_many_arguments)]
    fn observe(
        &mut self,
        live: &[bool; LANES],
        t: f64,
        x: &[Lanes; 4],
        u: &Lanes,
        r: &SpeedRef<f64>,
        phi_s: &Lanes,
        speed_scale: f64,
        direction: f64,
    ) {
        for l in 0..LANES {
            let pitch_error = (x[0][l] - phi_s[l]).abs();
            let speed_error = (x[3][l] - r.theta_dot).abs();
            let on = live[l];
            self.pitch_settle[l] = if on && pitch_error > self.pitch_band[l] { t } else { self.pitch_settle[l] };
            self.speed_settle[l] = if on && speed_error > 0.02 * speed_scale { t } else { self.speed_settle[l] };
            self.sum_pitch[l] = if on { self.sum_pitch[l] + pitch_error } else { self.sum_pitch[l] };
            self.sum_speed[l] = if on { self.sum_speed[l] + speed_error } else { self.sum_speed[l] };
            let position = direction * (r.theta - x[2][l]) * self.radius[l];
            self.final_position_error[l] = if on { position } else { self.final_position_error[l] };
            let peak = self.peak_abs_input[l].max(u[l].abs());
            self.peak_abs_input[l] = if on { peak } else { self.peak_abs_input[l] };
            self.samples[l] += on as u64;
        }
    }
}

/// The plants' own steady pitch at a reference speed, per lane (as `SlopeMetrics`).
fn steady_pitch(models: &[SlopeModel<f64>; LANES], speed: f64) -> Lanes {
    core::array::from_fn(|l| steady_pitch_of(&models[l], speed))
}

fn steady_pitch_of(model: &SlopeModel<f64>, speed: f64) -> f64 {
    model.equilibrium(speed).map(|(x, _)| x[0]).unwrap_or(core::f64::consts::FRAC_PI_2)
}

fn only(l: usize) -> [bool; LANES] {
    core::array::from_fn(|i| i == l)
}

/// Runs up to [`LANES`] samples (fewer fill the rest of the block with idle lanes).
/// `should_stop` is asked every `runner::STOP_CHECK_STEPS` steps; `Ok(None)` means it
/// said yes before the block was done.
///
/// On x86-64 the same code is compiled twice more, for AVX-512 and for AVX2 with FMA,
/// and the widest the CPU has is chosen at run time (wheels are built for the baseline
/// CPU). All copies give the same bits: the baseline copy computes each `mul_add` with
/// libm's exactly rounded `fma`, a call per value (~15× slower, on CPUs older than 2013).
pub fn run_lqr_block(
    controller: &LqrController<f64>,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    samples: &[Sample],
    should_stop: &dyn Fn() -> bool,
) -> Result<Option<[SampleMetrics; LANES]>, TwipError> {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: each copy runs only on a CPU that has its instructions.
        if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
            return unsafe { block_avx512(controller, reference, config, samples, should_stop) };
        }
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            return unsafe { block_avx2(controller, reference, config, samples, should_stop) };
        }
    }
    block_baseline(controller, reference, config, samples, should_stop)
}

type BlockResult = Result<Option<[SampleMetrics; LANES]>, TwipError>;

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
unsafe fn block_avx512(
    c: &LqrController<f64>,
    r: &SpeedSchedule<f64>,
    k: &SimConfig<f64>,
    s: &[Sample],
    stop: &dyn Fn() -> bool,
) -> BlockResult {
    block(c, r, k, s, stop)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn block_avx2(
    c: &LqrController<f64>,
    r: &SpeedSchedule<f64>,
    k: &SimConfig<f64>,
    s: &[Sample],
    stop: &dyn Fn() -> bool,
) -> BlockResult {
    block(c, r, k, s, stop)
}

#[inline(never)]
fn block_baseline(
    c: &LqrController<f64>,
    r: &SpeedSchedule<f64>,
    k: &SimConfig<f64>,
    s: &[Sample],
    stop: &dyn Fn() -> bool,
) -> BlockResult {
    block(c, r, k, s, stop)
}

#[inline(always)]
fn block(
    controller: &LqrController<f64>,
    reference: &SpeedSchedule<f64>,
    config: &SimConfig<f64>,
    samples: &[Sample],
    should_stop: &dyn Fn() -> bool,
) -> Result<Option<[SampleMetrics; LANES]>, TwipError> {
    assert!(samples.len() <= LANES, "a block holds at most {LANES} samples");
    let (n, per_update) = config.steps(controller.period())?;
    let mut out = [SampleMetrics::INVALID; LANES];
    // Invalid or missing samples run an idle copy of a valid robot and are never kept.
    let mut active = [false; LANES];
    let mut models = [None; LANES];
    for (l, s) in samples.iter().enumerate() {
        if s.x0.iter().all(|v| v.is_finite()) {
            models[l] = SlopeModel::new(s.params, s.slope).ok();
            active[l] = models[l].is_some();
        }
    }
    let Some(fallback) = models.iter().flatten().next().copied() else {
        return Ok(Some(out));
    };
    let models: [SlopeModel<f64>; LANES] = core::array::from_fn(|l| models[l].unwrap_or(fallback));
    let plants = Plants::new(&core::array::from_fn(|l| models[l].coefficients()));
    let mut x: [Lanes; 4] = core::array::from_fn(|i| {
        core::array::from_fn(|l| if active[l] { samples[l].x0[i] } else { 0.0 })
    });
    let gains = controller.gains();
    let period = controller.period();
    let dt = config.dt;
    let mut z = [0.0; LANES];
    let mut u = [0.0; LANES];
    let mut alive = active;
    // (fell, t_end, steps) of each lane that has ended.
    let mut ended = [(false, 0.0f64, 0u64); LANES];
    let r0 = reference.sample(0.0);
    let (mut phi_s, mut u_s) = controller.steady_state(r0.theta_dot).unwrap_or((0.0, 0.0));
    let mut cached_speed = r0.theta_dot;
    let mut plant_phi_s = steady_pitch(&models, r0.theta_dot);
    let mut metrics = Metrics::new(core::array::from_fn(|l| models[l].params().wheel_radius), &x, &plant_phi_s);
    let mut speed_scale: f64 = 0.0;
    let mut direction: f64 = 1.0;
    for k in 0..n {
        let t = dt * k as f64;
        if k % STOP_CHECK_STEPS == 0 && k > 0 && should_stop() {
            return Ok(None);
        }
        let r = reference.sample(t);
        if r.theta_dot != cached_speed {
            cached_speed = r.theta_dot;
            (phi_s, u_s) = controller.steady_state(r.theta_dot).unwrap_or((0.0, 0.0));
            plant_phi_s = steady_pitch(&models, r.theta_dot);
        }
        speed_scale = speed_scale.max(r.theta_dot.abs());
        direction = if r.theta_dot != 0.0 { r.theta_dot.signum() } else { direction };
        if k % per_update == 0 {
            // `LqrController::update`, operation for operation.
            let mut finite = true;
            for l in 0..LANES {
                let speed_error = x[3][l] - r.theta_dot;
                u[l] = u_s - (gains[0] * (x[0][l] - phi_s) + gains[1] * x[1][l] + gains[2] * speed_error) - gains[3] * z[l];
                z[l] += speed_error * period;
                finite &= u[l].is_finite() || !alive[l];
            }
            if !finite {
                for l in 0..LANES {
                    if alive[l] && !u[l].is_finite() {
                        alive[l] = false;
                        ended[l] = (true, t, k as u64);
                    }
                }
            }
        }
        metrics.observe(&alive, t, &x, &u, &r, &plant_phi_s, speed_scale, direction);
        let next = plants.rk4(&x, &u, dt);
        // Lanes that go on take the new state; the few that end are handled below.
        let mut goes_on = [false; LANES];
        let mut any_ends = false;
        for l in 0..LANES {
            let finite = next[0][l].is_finite() & next[1][l].is_finite() & next[2][l].is_finite() & next[3][l].is_finite();
            goes_on[l] = alive[l] & finite & (next[0][l].abs() <= config.fall_limit);
            any_ends |= alive[l] & !goes_on[l];
        }
        for i in 0..4 {
            for l in 0..LANES {
                x[i][l] = if goes_on[l] { next[i][l] } else { x[i][l] };
            }
        }
        if any_ends {
            let t_next = dt * (k + 1) as f64;
            for l in 0..LANES {
                if !alive[l] || goes_on[l] {
                    continue;
                }
                alive[l] = false;
                ended[l] = (true, t_next, (k + 1) as u64);
                if (0..4).all(|i| next[i][l].is_finite()) {
                    // Fell: the runner observes the state past the limit, then stops.
                    for i in 0..4 {
                        x[i][l] = next[i][l];
                    }
                    let r_next = reference.sample(t_next);
                    // Only this lane is observed: only its steady pitch is needed.
                    let mut phi_s_next = plant_phi_s;
                    phi_s_next[l] = steady_pitch_of(&models[l], r_next.theta_dot);
                    let towards = if r_next.theta_dot != 0.0 { r_next.theta_dot.signum() } else { direction };
                    let scale = speed_scale.max(r_next.theta_dot.abs());
                    metrics.observe(&only(l), t_next, &x, &u, &r_next, &phi_s_next, scale, towards);
                }
            }
            if !alive.iter().any(|&a| a) {
                break;
            }
        }
    }
    let t_end = dt * n as f64;
    let r_end = reference.sample(t_end);
    let end_phi_s = steady_pitch(&models, r_end.theta_dot);
    let towards = if r_end.theta_dot != 0.0 { r_end.theta_dot.signum() } else { direction };
    metrics.observe(&alive, t_end, &x, &u, &r_end, &end_phi_s, speed_scale.max(r_end.theta_dot.abs()), towards);
    for l in 0..LANES {
        if alive[l] {
            ended[l] = (false, t_end, n as u64);
        }
        if !active[l] {
            continue;
        }
        let count = metrics.samples[l].max(1) as f64;
        let (fell, t_end, steps) = ended[l];
        let peaks = DrivePeaks::from_lumped_current(models[l].params(), metrics.peak_abs_input[l]);
        out[l] = SampleMetrics {
            valid: true,
            fell,
            t_end,
            mean_abs_pitch_error: metrics.sum_pitch[l] / count,
            mean_abs_speed_error: metrics.sum_speed[l] / count,
            pitch_settling_time: metrics.pitch_settle[l],
            speed_settling_time: metrics.speed_settle[l],
            final_position_error: metrics.final_position_error[l],
            peak_abs_input: metrics.peak_abs_input[l],
            peak_current: peaks.current,
            peak_torque: peaks.torque,
            steps,
        };
    }
    Ok(Some(out))
}


#[cfg(test)]
mod tests {
    use super::*;
    use crate::control::lqr::{design, DesignPoint};
    use crate::model::params::RobotParams;
    use nalgebra::{Matrix4, Vector4};

    /// Every compiled copy of the kernel gives the same bits (the baseline one through
    /// libm's fma), so a sweep is the same on any x86-64 CPU.
    #[test]
    fn every_copy_gives_the_same_bits() {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        let q = Matrix4::from_diagonal(&Vector4::new(10.0, 10.0, 1.0, 1.0));
        let d = design(&model, 4.0, &q, 1000.0, DesignPoint::OperatingPoint).unwrap();
        let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 0.005).unwrap();
        let schedule = SpeedSchedule::new(&[crate::control::reference::Leg { goal: 10.0, speed: 4.0, hold: 0.5 }]).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 3.0, fall_limit: 0.45 };
        let samples: Vec<Sample> = (0..LANES as u64)
            .map(|i| {
                let mut params = RobotParams::balanbot();
                params.com_height *= 0.6 + 0.05 * i as f64;
                Sample { index: i, params, slope: 0.1, x0: Vector4::new(0.04 * i as f64, 0.0, 0.0, 0.0) }
            })
            .collect();
        let never = || false;
        let base = format!("{:?}", block_baseline(&ctrl, &schedule, &config, &samples, &never).unwrap());
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { block_avx2(&ctrl, &schedule, &config, &samples, &never) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX2 copy");
            }
            if std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("fma") {
                let got = unsafe { block_avx512(&ctrl, &schedule, &config, &samples, &never) }.unwrap();
                assert_eq!(format!("{got:?}"), base, "AVX-512 copy");
            }
        }
        assert!(base.contains("fell: true") && base.contains("fell: false"), "want both outcomes: {base}");
    }
}
