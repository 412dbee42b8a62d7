//! The 3-DOF robot's real parts, for the trackers: [`Realism::build_planar`] turns a
//! [`Realism`] into
//! - a plant, [`PlanarPlant`]: the planar model with pushes and a constant force, each
//!   wheel driven through its own L298 bridge and motor when there is a driver (input:
//!   the two duties), else by the commanded torques;
//! - a sensor, [`PlanarSensors`]: the MPU-6050 (pitch-plane accelerometer and pitch
//!   gyro, and the gyro's z axis for the yaw rate, each through the DLPF), the tilt
//!   estimator, and an encoder per wheel from which the firmware gets the speed, the
//!   heading ψ̂ = R (β̂_r − β̂_l)/(2b) and the position by dead reckoning; the truth for
//!   each part left out;
//! - an actuator, [`PlanarActuator`]: each wheel's torque → duty by the firmware's
//!   feed-forward on the measured wheel speed, or none;
//!
//! run by the one loop (`runner::run_loop`) through [`Rig::simulate`]. Nothing
//! allocates; the noise comes from the one (seed, stream) [`Sfc64`] stream: each IMU sample
//! takes the pitch channel's four normals, then the yaw gyro's four.
//!
//! Approximations, each far below what the firmware can see: the accelerometer feels
//! the pitch-plane motion (the centripetal v ω is lateral, along the axis it does not
//! read); the sensor follows each wheel's angle relative to the body by the trapezoid
//! rule on the plant's steps (error ~dt³, against 9 mrad per encoder count).
use nalgebra::{SVector, Vector2, Vector3};

use crate::hardware::disturbance::{Force, Push};
#[cfg(all(test, feature = "std"))]
use crate::hardware::disturbance::Pushes;
use crate::hardware::driver::{MotorDriver, PwmActuator};
use crate::hardware::encoder::Encoder;
use crate::hardware::imu::{specific_force_of, ImuClock, ImuReading, ImuSettings, Mpu6050, NoiseBatch};
use crate::hardware::realism::{Realism, Rig};
use crate::hardware::rig_plant::{RealPlant, RigGround};
use crate::model::dynamics::Halt;
use crate::model::friction::Friction;
use crate::hardware::settle::{Settle, Settles, Settling};
use crate::hardware::tilt::{accel_tilt, TiltEstimator, TiltFilter};
use crate::model::lane::Lane;
use crate::model::planar::{PlanarState, WheelRows};
use crate::model::terrain::Terrain;
use crate::model::terrain_model::{frame_of, in_plane, pitch_acceleration_of, plane_state, Frame, TerrainModel};
use crate::rng::Sfc64;
use crate::sim::runner::{Actuator, Sensor};
use crate::{c, Dynamics, PlanarModel, Real, RobotParams, TwipError};

/// What the 3-DOF rig logs after the controller's internals.
pub const PLANAR_RIG_SIGNALS: [&str; 11] = [
    "x_hat", "y_hat", "psi_hat", "phi_hat", "phi_dot_hat", "v_hat", "omega_hat", "drive_r", "drive_l", "current_r",
    "current_l",
];

/// The 3-DOF model on its ground: flat, or on terrain. The ground of the 3-DOF rig's
/// plant, [`PlanarPlant`].
#[derive(Clone, Debug)]
pub struct PlanarGround<T: Real> {
    model: PlanarModel<T>,
    /// The model on its terrain (the same parameters and friction), or flat ground (None:
    /// the flat model's code, unchanged).
    terrain: Option<TerrainModel<T>>,
}

impl<T: Real> PlanarGround<T> {
    /// `model` on `terrain` (None: flat ground).
    pub fn new(model: PlanarModel<T>, terrain: Option<&Terrain<T>>) -> Self {
        Self { terrain: terrain.map(|t| TerrainModel::new(model, t.clone())), model }
    }

    /// Each wheel's acceleration relative to the body from the derivative `d` at `x`.
    #[inline(always)]
    fn wheel_accelerations(&self, x: &PlanarState<T>, d: &PlanarState<T>) -> (T, T) {
        let zero = T::zero();
        let phi_dd = match &self.terrain {
            None => d[4],
            Some(g) => TerrainModel::pitch_acceleration(x, d, &g.frame(x)),
        };
        self.model.wheel_speeds(&PlanarState::from([zero, zero, zero, zero, phi_dd, d[5], d[6]]))
    }
}

/// Each train's flank contact torque τ_m − τ_f − J ẇ: the motors' torques `u`, the gearhead
/// torques `friction`, the rotor inertia `j` and the wheels' accelerations `acc`.
#[inline(always)]
pub(crate) fn flank_contact<T: Real>(u: &SVector<T, 2>, friction: [T; 2], j: T, acc: [T; 2]) -> [T; 2] {
    [u[0] - friction[0] - j * acc[0], u[1] - friction[1] - j * acc[1]]
}

/// The body force's generalised forces on (φ, v) at (sin φ, cos φ), if any.
#[inline(always)]
fn extra<T: Real>(force: Option<&Force<T>>, s: T, cp: T) -> Option<Vector2<T>> {
    force.map(|f| Vector2::from(body_force(f, s, cp)))
}

impl<T: Real> RigGround<T, 7, 2> for PlanarGround<T> {
    const PITCH: usize = 3;

    /// On terrain, relative to the body's pitch rate about the axle.
    #[inline(always)]
    fn wheel_speeds(&self, x: &PlanarState<T>) -> [T; 2] {
        let (right, left) = match &self.terrain {
            None => self.model.wheel_speeds(x),
            Some(g) => g.wheel_speeds(x),
        };
        [right, left]
    }

    /// One geared derivative, every train engaged without play (one copy of the motion's
    /// code per RK4 stage: a second, for no play, grew each 3-DOF rig run by 44 KB).
    #[inline(always)]
    fn deriv(&self, x: &PlanarState<T>, u: &SVector<T, 2>, engaged: Option<[bool; 2]>, force: Option<&Force<T>>) -> PlanarState<T> {
        self.deriv_geared(x, u, engaged.unwrap_or([true; 2]), force).0
    }

    #[inline(always)]
    fn deriv_geared(&self, x: &PlanarState<T>, u: &SVector<T, 2>, engaged: [bool; 2], force: Option<&Force<T>>) -> (PlanarState<T>, [T; 2]) {
        match &self.terrain {
            None => self.model.deriv_geared(x, u, engaged, |s, cp| extra(force, s, cp)),
            Some(g) => g.deriv_geared(x, u, engaged, |s, cp| extra(force, s, cp).map(|q| [q[0], q[1]])),
        }
    }

    #[inline(always)]
    fn contact(&self, x: &PlanarState<T>, d: &PlanarState<T>, u: &SVector<T, 2>, friction: [T; 2], j: T) -> [T; 2] {
        let (acc_r, acc_l) = self.wheel_accelerations(x, d);
        flank_contact(u, friction, j, [acc_r, acc_l])
    }

    #[inline(always)]
    fn motor_torques(&self, u: &SVector<T, 2>) -> [T; 2] {
        [u[0], u[1]]
    }

    #[inline(always)]
    fn input_of(&self, torques: [T; 2]) -> SVector<T, 2> {
        SVector::from(torques)
    }

    #[inline(always)]
    fn impact(&self, x: &mut PlanarState<T>, train: usize, rotor_speed: T, engaged: [bool; 2]) {
        match &self.terrain {
            None => impact(&self.model, x, train, rotor_speed, engaged),
            Some(g) => g.jump_in_plane(x, |xp| impact(&self.model, xp, train, rotor_speed, engaged)),
        };
    }

    #[inline(always)]
    fn push(&self, x: &mut PlanarState<T>, p: &Push<T>) {
        match &self.terrain {
            None => push(&self.model, x, p),
            // On terrain the push acts in the plane's frame, at the pitch φ' from its normal.
            Some(g) => g.jump_in_plane(x, |xp| push(&self.model, xp, p)),
        }
    }

    #[inline(always)]
    fn friction(&self) -> Option<&Friction<T>> {
        self.model.friction()
    }

    fn rotors(&self) -> (T, T) {
        (self.model.rotor_per_wheel(), T::one())
    }

    /// ε η τ_i: a wheel's torque per motor ampere.
    fn input_per_amp(&self, driver: &MotorDriver<T>, params: &RobotParams<T>) -> T {
        driver.efficiency * params.torque_per_amp()
    }

    /// Each motor's current; without a driver, the torques commanded as the motor currents
    /// of an ideal drive.
    #[inline(always)]
    fn logged_currents(&self, u: &SVector<T, 2>, windings: Option<(SVector<T, 2>, T)>) -> SVector<T, 2> {
        windings.map_or_else(|| *u / self.model.params().torque_per_amp(), |(amps, _)| amps)
    }

    #[inline(always)]
    fn shafts(offsets: [T; 2]) -> [T; 2] {
        offsets
    }

    fn energy(&self, x: &PlanarState<T>) -> T {
        match &self.terrain {
            None => self.model.energy(x),
            Some(g) => g.energy(x),
        }
    }

    /// On terrain: off a grid, or a wheel's normal force below zero under the torques `u()`
    /// with the gear trains `engaged`.
    #[inline]
    fn halted(&self, x: &PlanarState<T>, u: impl FnOnce() -> SVector<T, 2>, engaged: [bool; 2], force: Option<&Force<T>>) -> Option<Halt> {
        let g = self.terrain.as_ref()?;
        if !g.terrain().contains(x[0], x[1]) {
            return Some(Halt::OffTerrain);
        }
        let [n_r, n_l] = g.normal_forces_geared(x, &u(), engaged, |s, cp| extra(force, s, cp).map(|q| [q[0], q[1]]));
        (n_r < T::zero() || n_l < T::zero()).then_some(Halt::Lifted)
    }
}

/// The 3-DOF rig's plant: the planar model on its ground with the rig's parts
/// ([`RealPlant`]), each wheel driven through its own bridge and motor when there is a
/// driver (input: the two duties), else by the commanded torques.
pub type PlanarPlant<T> = RealPlant<T, PlanarGround<T>, 7, 2>;

// What a sweep's 3-DOF rig lanes ask of each lane's plant.
#[cfg_attr(not(feature = "std"), allow(dead_code))]
impl<T: Real> PlanarPlant<T> {
    /// The planar model this plant moves by (its gearhead friction included).
    pub(crate) fn model(&self) -> &PlanarModel<T> {
        &self.ground().model
    }
}

// The impact and the push are out of line and cold: inlined, the compiler computed
// their sin φ and cos φ (libm) on every step, ahead of the rare branch that needs them
// (the 3-DOF rig's lanes spent 12 % of their time there).
/// The plastic impact of wheel `wheel`'s rotor at `rotor_speed` ([`PlanarModel::engage`]).
#[cold]
#[inline(never)]
fn impact<T: Real>(model: &PlanarModel<T>, x: &mut PlanarState<T>, wheel: usize, rotor_speed: T, engaged: [bool; 2]) -> T {
    model.engage(x, wheel, rotor_speed, engaged)
}

/// The push `p`'s impulse on the body at `x`: the velocities jump.
#[cold]
#[inline(never)]
fn push<T: Real>(model: &PlanarModel<T>, x: &mut PlanarState<T>, p: &Push<T>) {
    let (s, cp) = x[3].sin_cos();
    let q = body_force(&Force { horizontal: p.impulse, vertical: T::zero(), height: p.height }, s, cp);
    let jump = model.solve_mass(x[3], &Vector3::new(q[0], q[1], T::zero()));
    x[4] += jump[0];
    x[5] += jump[1];
}

/// The generalised forces of a force on the body (flat ground) on (φ, v) at (sin φ, cos φ).
#[inline(always)]
pub(crate) fn body_force<S: Lane>(force: &Force<S>, sin_phi: S, cos_phi: S) -> [S; 2] {
    [force.on_pitch(sin_phi, cos_phi), force.horizontal]
}

/// The IMU, tilt estimator and encoders of the 3-DOF robot, as one sensor.
#[derive(Clone, Debug)]
pub struct PlanarSensors<T: Real> {
    /// The pitch-plane channels, and the gyro's z axis (its accelerometer unused).
    imu: Option<(Mpu6050<T>, Mpu6050<T>)>,
    tilt: TiltFilter<T>,
    encoders: Option<[Encoder<T>; 2]>,
    /// Each wheel's angle relative to the body [rad] and its speed at the last sample.
    beta: [T; 2],
    beta_dot: [T; 2],
    /// The firmware's dead-reckoned pose and last counted angles.
    pose: [T; 3],
    last_beta_hat: Option<[T; 2]>,
    radius: T,
    half_track: T,
    /// The model's wheel rows: the wheels' speeds relative to the body, and 1/R.
    wheels: WheelRows<T>,
    g: T,
    /// When the IMUs sample.
    clock: ImuClock<T>,
    dt: T,
    rng: Sfc64,
    last_read: Option<T>,
    /// Each motor shaft's angle minus its wheel's (backlash): the encoders count the shafts.
    shaft: [T; 2],
    /// The ground the robot is on (None: flat): the body's pitch about the axle and the
    /// gravity the accelerometer feels follow its local plane.
    terrain: Option<Terrain<T>>,
    /// The firmware's start at rest before the run ([`Settle`]; None: none).
    settle: Option<Settle<T>>,
}

impl<T: Real> PlanarSensors<T> {
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        imu: Option<&ImuSettings<T>>,
        estimator: TiltEstimator<T>,
        encoder_cpr: Option<T>,
        params: &RobotParams<T>,
        dt: T,
        seed: u64,
        stream: u64,
    ) -> Result<Self, TwipError> {
        let imu = match imu {
            Some(s) => {
                // The yaw IMU is the pitch one as built (the same settings): its filters designed once.
                let pitch = Mpu6050::new(s)?;
                crate::hardware::realism::check_imu_grid(pitch.settings(), dt)?;
                Some((pitch, pitch))
            }
            None => None,
        };
        // Without an IMU the clock is never asked: any period.
        let clock = ImuClock::new(imu.as_ref().map_or(T::one(), |(p, _)| p.settings().sample_period), dt);
        let encoders = match encoder_cpr {
            Some(cpr) => Some([Encoder::new(cpr)?, Encoder::new(cpr)?]),
            None => None,
        };
        Ok(Self {
            imu,
            tilt: TiltFilter::new(estimator)?,
            encoders,
            beta: [T::zero(); 2],
            beta_dot: [T::zero(); 2],
            pose: [T::zero(); 3],
            last_beta_hat: None,
            radius: params.wheel_radius,
            half_track: params.half_track,
            wheels: PlanarModel::new(*params)?.coefficients().wheels(),
            g: params.g,
            clock,
            dt,
            rng: Sfc64::new(seed, stream),
            last_read: None,
            shaft: [T::zero(); 2],
            terrain: None,
            settle: None,
        })
    }

    /// These sensors with a firmware's start at rest before the run ([`Settle`]).
    pub fn settled(self, settle: Option<Settle<T>>) -> Self {
        Self { settle, ..self }
    }

    /// These sensors on `terrain` (None: flat ground).
    pub fn on(self, terrain: Option<Terrain<T>>) -> Self {
        Self { terrain, ..self }
    }

    /// Follows each wheel's angle relative to the body to `x` at time `t` (the trapezoid
    /// rule on the plant's steps): the sampling the encoders need.
    #[inline]
    pub(crate) fn follow_wheels(&mut self, t: T, x: &PlanarState<T>) {
        let speeds = match &self.terrain {
            None => self.wheels.speeds(&(*x).into()),
            Some(g) => self.wheels.speeds(&in_plane(x, &frame_of(g, x))),
        };
        self.follow_speeds(t, speeds);
    }

    /// [`Self::follow_wheels`] given the wheels' speeds relative to the body there (on flat
    /// ground a sweep's lanes work them out side by side, with the model's `WheelRows`,
    /// which are these sensors').
    #[inline(always)]
    pub(crate) fn follow_speeds(&mut self, t: T, speeds: [T; 2]) {
        if t > T::zero() {
            let half = self.dt * c::<T>(0.5);
            for ((beta, was), now) in self.beta.iter_mut().zip(self.beta_dot).zip(speeds) {
                *beta += half * (was + now);
            }
        }
        self.beta_dot = speeds;
    }

    /// The IMUs (pitch channels, yaw gyro), their clock, this rig's stream and the IMUs'
    /// normals drawn ahead, as they stand (None without an IMU): a sweep's lanes sample
    /// for the IMUs from copies of them, and draw the same numbers.
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    pub(crate) fn imu_noise_parts(&self) -> Option<ImuNoiseParts<T>> {
        self.imu.as_ref().map(|(pitch, yaw)| ([*pitch, *yaw], self.clock, self.rng, [pitch.noise(), yaw.noise()]))
    }

    /// Sets the IMUs' registers, pitch channels and yaw gyro (a sweep's lanes sample for them).
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    pub(crate) fn set_imu_readings(&mut self, pitch: ImuReading<T>, yaw: ImuReading<T>) {
        if let Some((p, y)) = self.imu.as_mut() {
            p.set_reading(pitch);
            y.set_reading(yaw);
        }
    }
}

/// What a sweep's lanes copy of a 3-DOF rig's IMUs ([`PlanarSensors::imu_noise_parts`]).
pub(crate) type ImuNoiseParts<T> = ([Mpu6050<T>; 2], ImuClock<T>, Sfc64, [NoiseBatch; 2]);

/// The IMUs' sample at state `x` with derivative `xdot` (the pitch plane as the 2-DOF
/// model has it, θ̇ = v/R; the gyro's z axis turns with the body's pitch: it reads
/// ω cos φ, `cos_phi` libm's in a run, the lanes' polynomial in a sweep), written once over
/// `Lane`: a run's and a sweep's lanes. The four normals `n` of each IMU; `radius`,
/// 1/radius, the sensor's height and gravity.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_imus<S: Lane>(
    (pitch, yaw): (&mut Mpu6050<S>, &mut Mpu6050<S>),
    x: &[S; 7],
    xdot: &[S; 7],
    cos_phi: S,
    [n_pitch, n_yaw]: [[S; 4]; 2],
    (radius, inv_r, height, g): (S, S, S, S),
) {
    let zero = S::splat(0.0);
    let x4 = [x[3], x[4], zero, x[5] * inv_r];
    let xdot4 = [x[4], xdot[4], x[5] * inv_r, xdot[5] * inv_r];
    let (fx, fz) = specific_force_of(&x4, &xdot4, zero, S::splat(1.0), radius, height, g);
    pitch.sample_with(fx, fz, x[4], n_pitch);
    yaw.sample_gyro_with(x[6] * cos_phi, n_yaw);
}

/// The IMUs' sample on terrain at state `x` with derivative `xdot` (docs/terrain.md, "The
/// rig on terrain"). The sensor's axes are the body's: x forward and z up the body, the
/// body pitched φ' = φ + δ from the plane's normal about the axle. Gravity in those axes is
/// g cos ρ (−sin φ, cos φ) (ρ the roll the cross slope gives; the rest, g sin ρ, lies along
/// the axle, which the pitch channels do not read), and the pitch-plane motion is the flat
/// model's in the plane's frame: so the flat formula with the pitch rates φ̇', φ̈', the
/// ground tilted by δ under the body and gravity g cos ρ. The pitch gyro reads φ̇', the z
/// gyro ω cos φ' (the yaw ω is about the plane's normal). Level ground gives the flat
/// sample bit for bit.
#[inline]
fn sample_imus_on_terrain<T: Real>(
    (pitch, yaw): (&mut Mpu6050<T>, &mut Mpu6050<T>),
    terrain: &Terrain<T>,
    x: &PlanarState<T>,
    xdot: &PlanarState<T>,
    n: [[T; 4]; 2],
    dims: (T, T, T, T),
) {
    let f = frame_of(terrain, x);
    let lean = x[3] + f.delta;
    sample_imus_in_frame((pitch, yaw), &f, &(*x).into(), &(*xdot).into(), (f.delta.sin_cos(), lean.cos()), n, dims);
}

/// [`sample_imus_on_terrain`] in the local plane's frame `f` over [`Lane`] (a run's and a
/// sweep's lanes), given (sin δ, cos δ) and cos φ' (`trig`: a run's libm's, the lanes' own).
#[inline(always)]
#[allow(clippy::type_complexity)]
pub(crate) fn sample_imus_in_frame<S: Lane>(
    (pitch, yaw): (&mut Mpu6050<S>, &mut Mpu6050<S>),
    f: &Frame<S>,
    x: &[S; 7],
    xdot: &[S; 7],
    (delta, cos_lean): ((S, S), S),
    n: [[S; 4]; 2],
    dims: (S, S, S, S),
) {
    let [fx, fz, pitch_rate, yaw_rate] = imu_inputs_in_frame(f, x, xdot, delta, cos_lean, dims);
    pitch.sample_with(fx, fz, pitch_rate, n[0]);
    yaw.sample_gyro_with(yaw_rate, n[1]);
}

/// What the IMUs sense on terrain ([`sample_imus_on_terrain`]): the specific force along
/// the sensor's x and z, the pitch gyro's rate and the z gyro's.
#[cfg(all(test, feature = "std"))]
fn imu_inputs_on_terrain<T: Real>(terrain: &Terrain<T>, x: &PlanarState<T>, xdot: &PlanarState<T>, dims: (T, T, T, T)) -> [T; 4] {
    let f = frame_of(terrain, x);
    let xp = in_plane(x, &f);
    imu_inputs_in_frame(&f, &(*x).into(), &(*xdot).into(), f.delta.sin_cos(), xp[3].cos(), dims)
}

/// [`imu_inputs_on_terrain`] in the local plane's frame `f` over [`Lane`] (a run's and a
/// sweep's lanes), given sin δ, cos δ and cos φ' (a run's libm's, the lanes' own).
#[inline(always)]
pub(crate) fn imu_inputs_in_frame<S: Lane>(f: &Frame<S>, x: &[S; 7], xdot: &[S; 7], (sin_d, cos_d): (S, S), cos_lean: S, (radius, inv_r, height, g): (S, S, S, S)) -> [S; 4] {
    let xp = plane_state(x, f);
    let cos_roll = (f.cos_slope * f.cos_slope + f.sin_grade * f.sin_grade).square_root();
    // The pitch from the most vertical direction (φ, which gravity's direction gives), and
    // the body's pitch rates about the axle (φ̇', φ̈').
    let phi_dd = pitch_acceleration_of(x, xdot, f);
    let zero = S::splat(0.0);
    let x4 = [x[3], xp[4], zero, x[5] * inv_r];
    let xdot4 = [xp[4], phi_dd, x[5] * inv_r, xdot[5] * inv_r];
    let (fx, fz) = specific_force_of(&x4, &xdot4, sin_d, cos_d, radius, height, g * cos_roll);
    [fx, fz, xp[4], x[6] * cos_lean]
}

impl<T: Real> PlanarSensors<T> {
    /// What a settle at pitch `phi` reads and sets: the pitch IMU's (None without a settle
    /// or an IMU).
    fn settling_at(&mut self, phi: T) -> Option<Settling<'_, T>> {
        let (Some(settle), Some((pitch, _))) = (&self.settle, &self.imu) else { return None };
        Some(Settling { settle, tilt: &mut self.tilt, imu: pitch, phi, g: self.g, last_read: &mut self.last_read })
    }
}

impl Settles for PlanarSensors<f64> {
    fn settling(&mut self, phi: f64) -> Option<Settling<'_, f64>> {
        self.settling_at(phi)
    }
}

impl<T: Real> Sensor<T, 7> for PlanarSensors<T> {
    /// Follows the wheels' angles; samples the IMUs when their period has come round.
    #[inline]
    fn sample(&mut self, t: T, x: &PlanarState<T>, xdot: &PlanarState<T>) {
        self.follow_wheels(t, x);
        if let Some((pitch, yaw)) = self.imu.as_mut() {
            if self.clock.due(t) {
                let n = [pitch.draw(&mut self.rng), yaw.draw(&mut self.rng)];
                let height = pitch.settings().height;
                match &self.terrain {
                    None => {
                        let dims = (self.radius, self.wheels.inv_r, height, self.g);
                        sample_imus((pitch, yaw), &(*x).into(), &(*xdot).into(), x[3].cos(), n, dims);
                    }
                    Some(g) => sample_imus_on_terrain((pitch, yaw), g, x, xdot, n, (self.radius, self.wheels.inv_r, height, self.g)),
                }
            }
        }
    }

    /// The estimator reads the pitch IMU at rest at `x0`'s pitch ([`Settle`]).
    fn settle(&mut self, x0: &PlanarState<T>, period: T) {
        if let Some(mut s) = self.settling_at(x0[3]) {
            s.run(period);
        }
    }

    fn read(&mut self, t: T, x: &PlanarState<T>) -> PlanarState<T> {
        let dt = self.last_read.map_or(T::zero(), |last| t - last);
        self.last_read = Some(t);
        let (phi, phi_dot, omega_gyro) = match &self.imu {
            Some((pitch, yaw)) => {
                let r = pitch.reading();
                let (phi, phi_dot) = self.tilt.update(accel_tilt(r.accel_x, r.accel_z), r.gyro, dt);
                (phi, phi_dot, yaw.reading().gyro / phi.cos())
            }
            None => (x[3], x[4], x[6]),
        };
        let Some(encoders) = self.encoders.as_mut() else {
            return PlanarState::from([x[0], x[1], x[2], phi, phi_dot, x[5], omega_gyro]);
        };
        let (b_r, w_r) = encoders[0].read(self.beta[0] + self.shaft[0], dt);
        let (b_l, w_l) = encoders[1].read(self.beta[1] + self.shaft[1], dt);
        let (r, b) = (self.radius, self.half_track);
        let two = c::<T>(2.0);
        let psi = r * (b_r - b_l) / (two * b);
        let v = r * ((w_r + w_l) / two + phi_dot);
        // Dead reckoning: the path the wheels counted since the last read, along the
        // mean heading (the body's pitch change moves the axle by R Δφ̂ too).
        let last = self.last_beta_hat.unwrap_or([b_r, b_l]);
        let ds = r * ((b_r - last[0]) + (b_l - last[1])) / two;
        let mid = (self.pose[2] + psi) / two;
        self.pose = [self.pose[0] + ds * mid.cos(), self.pose[1] + ds * mid.sin(), psi];
        self.last_beta_hat = Some([b_r, b_l]);
        let omega = if self.imu.is_some() { omega_gyro } else { r * (w_r - w_l) / (two * b) };
        PlanarState::from([self.pose[0], self.pose[1], psi, phi, phi_dot, v, omega])
    }

    #[inline(always)]
    fn shaft_offsets(&mut self, offsets: [T; 2]) {
        self.shaft = offsets;
    }
}

/// The actuator of a 3-DOF realism run.
#[derive(Clone, Copy, Debug)]
pub enum PlanarActuator<T> {
    Ideal,
    /// Each wheel's torque → duty at its measured relative speed.
    Pwm { pwm: PwmActuator<T>, inv_r: T, b_r: T, limit: T, efficiency: T },
}

impl<T: Real> PlanarActuator<T> {
    /// Each wheel's motor speed relative to the body as measured in `y` (right, left).
    #[inline]
    fn measured_speeds(y: &PlanarState<T>, inv_r: T, b_r: T) -> [T; 2] {
        let roll = y[5] * inv_r - y[4];
        let turn = b_r * y[6];
        [roll + turn, roll - turn]
    }
}

impl<T: Real> Actuator<T, 7, 2> for PlanarActuator<T> {
    #[inline]
    fn drive(&mut self, _t: T, command: &SVector<T, 2>, y: &PlanarState<T>) -> SVector<T, 2> {
        match self {
            Self::Ideal => *command,
            Self::Pwm { pwm, inv_r, b_r, .. } => {
                let [right, left] = Self::measured_speeds(y, *inv_r, *b_r);
                SVector::<T, 2>::new(pwm.duty(command[0], right), pwm.duty(command[1], left))
            }
        }
    }

    #[inline]
    fn beyond(&self, command: &SVector<T, 2>, y: &PlanarState<T>) -> bool {
        match self {
            Self::Ideal => false,
            Self::Pwm { pwm, inv_r, b_r, limit, .. } => {
                let [right, left] = Self::measured_speeds(y, *inv_r, *b_r);
                pwm.beyond(command[0], right, *limit) || pwm.beyond(command[1], left, *limit)
            }
        }
    }

    #[inline]
    fn efficiency(&self) -> T {
        match self {
            Self::Ideal => T::one(),
            Self::Pwm { efficiency, .. } => *efficiency,
        }
    }
}

/// The 3-DOF rig ([`Realism::build_planar`]); [`Rig::simulate`] runs it.
pub type PlanarRig<T> = Rig<PlanarPlant<T>, PlanarSensors<T>, PlanarActuator<T>>;

impl<T: Real> Realism<T> {
    /// The plant, sensor and actuator for a run of the 3-DOF `model` at plant step `dt`.
    /// The planar model is flat: a slope profile is refused.
    pub fn build_planar(&self, model: &PlanarModel<T>, dt: T) -> Result<PlanarRig<T>, TwipError> {
        self.build_planar_on(model, None, dt)
    }

    /// [`Self::build_planar`] on `terrain` (None: flat ground, the same rig): the plant moves
    /// by the terrain model ([`TerrainModel`], its gear trains and forces as on flat
    /// ground) and the sensors read the body on the terrain's local plane. A slope profile
    /// (the 2-DOF model's) is refused either way: the terrain is the ground.
    pub fn build_planar_on(&self, model: &PlanarModel<T>, terrain: Option<&Terrain<T>>, dt: T) -> Result<PlanarRig<T>, TwipError> {
        let s = self.validate()?;
        let profile = s.slope_profile;
        if profile.base() != T::zero() || profile.changes().next().is_some() {
            return Err(TwipError::InvalidParameter {
                name: "slope_profile",
                value: crate::to_f64(profile.base()),
                reason: "the 3-DOF model is on flat ground: no slope profile",
            });
        }
        let params = *model.params();
        let actuator = match &s.motor {
            None => PlanarActuator::Ideal,
            Some(m) => {
                let pwm = PwmActuator::per_wheel_torque(m, &params)?;
                let inv_r = T::one() / params.wheel_radius;
                PlanarActuator::Pwm { pwm, inv_r, b_r: params.half_track * inv_r, limit: m.current_limit, efficiency: m.efficiency }
            }
        };
        let model = model.with_friction(s.friction_on(model.friction()))?;
        let plant = PlanarPlant::new(PlanarGround::new(model, terrain), s.force, s.pushes)?
            .with_driver(s.motor.as_ref(), &params)?
            .with_backlash(s.backlash)?
            // Before the first step the motors turn as the trains say, as they always did
            // here (the 2-DOF rig's with their wheels: the report's follow-up unifies them).
            .motors_as_trains();
        let sensors = PlanarSensors::new(s.imu.as_ref(), s.estimator, s.encoder_cpr, &params, dt, s.seed, s.stream)?.on(terrain.cloned())
            .settled(Settle::new(s.settle, dt, s.seed, s.stream)?);
        Ok(Rig { plant, sensors, actuator, delay: s.delay })
    }
}

#[cfg(all(test, feature = "std"))]
mod tests {
    use super::*;
    use crate::control::pid::PidTracker;
    use crate::control::trajectory::{Circle, Direction};
    use crate::hardware::motor::DcMotor;
    use crate::sim::runner::{simulate, Observer, Outcome, SimConfig};
    use crate::sim::tracking_metrics::TrackingMetrics;

    /// Records states and inputs.
    #[derive(Default)]
    struct Trace(std::vec::Vec<(f64, PlanarState<f64>, SVector<f64, 2>)>);

    impl<S> Observer<f64, 7, 2, S> for Trace {
        fn observe(&mut self, t: f64, x: &PlanarState<f64>, u: &SVector<f64, 2>, _: &S, _: &[f64]) {
            self.0.push((t, *x, *u));
        }
    }

    fn setup() -> (PlanarModel<f64>, PidTracker<f64>, Circle<f64>) {
        let params = RobotParams::balanbot();
        let ctrl = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
        let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
        (PlanarModel::new(params).unwrap(), ctrl, circle)
    }

    fn run<O: Observer<f64, 7, 2, crate::control::trajectory::PlanarRef<f64>>>(
        realism: &Realism<f64>,
        t_final: f64,
        observer: &mut O,
    ) -> Outcome<f64> {
        let (model, mut ctrl, circle) = setup();
        let config = SimConfig { dt: 1e-3, t_final, fall_limit: 1.0 };
        let mut rig = realism.build_planar(&model, config.dt).unwrap();
        rig.simulate(&mut ctrl, &circle, &PlanarState::zeros(), &config, observer, || false).unwrap().0
    }

    #[test]
    fn ideal_realism_is_the_plain_runner_bit_for_bit() {
        let (model, mut ctrl, circle) = setup();
        let config = SimConfig { dt: 1e-3, t_final: 3.0, fall_limit: 1.0 };
        let mut plain = Trace::default();
        simulate(&model, &mut ctrl, &circle, &PlanarState::zeros(), &config, &mut plain).unwrap();
        let mut rig = Trace::default();
        run(&Realism::ideal(), 3.0, &mut rig);
        assert_eq!(plain.0, rig.0);
    }

    /// As the 2-DOF rig's: the derivative the gear trains weighed is RK4's first stage when
    /// they stay as they were, and the run is bit for bit one that evaluates every first
    /// stage; with backlash both kinds of step occur (each wheel's train opens on its own).
    #[test]
    fn the_derivative_the_gear_trains_weighed_is_shared_bit_for_bit() {
        use crate::hardware::realism::Unshared;
        let (model, ctrl, circle) = setup();
        let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
        for (name, realism) in [("thesis-like", Realism::thesis_like()), ("no backlash", Realism { backlash: None, ..Realism::thesis_like() })] {
            let mut rig = realism.build_planar(&model, config.dt).unwrap();
            let mut checked = crate::hardware::realism::Rig {
                plant: Unshared { plant: rig.plant.clone(), shared: 0, not_shared: 0 },
                sensors: rig.sensors.clone(),
                actuator: rig.actuator,
                delay: rig.delay,
            };
            let (mut a, mut b) = (Trace::default(), Trace::default());
            assert_eq!(rig.simulate(&mut ctrl.clone(), &circle, &PlanarState::zeros(), &config, &mut a, || false).unwrap().0, Outcome::Completed);
            checked.simulate(&mut ctrl.clone(), &circle, &PlanarState::zeros(), &config, &mut b, || false).unwrap();
            assert_eq!(a.0, b.0, "{name}");
            checked.plant.assert_counts(name, realism.backlash.is_some());
        }
    }

    #[test]
    fn thesis_like_tracks_the_circle_and_repeats_bit_for_bit() {
        let (_, _, circle) = setup();
        let path_error = |realism: &Realism<f64>| {
            let mut metrics = TrackingMetrics::new(circle, 10.0);
            assert_eq!(run(realism, 36.0, &mut metrics), Outcome::Completed);
            metrics.summary().max_path_error_settled
        };
        let hardware = path_error(&Realism { friction: None, backlash: None, ..Realism::thesis_like() });
        let real = path_error(&Realism::thesis_like());
        let coulomb = path_error(&Realism { friction: Some(Friction::gb37().with_stick(0.1)), ..Realism::thesis_like() });
        let ideal = path_error(&Realism::ideal());
        std::println!(
            "circle-pid, one lap: max path error after 10 s {:.1} mm ideal, {:.1} mm with thesis-like sensors and \
             drive, {:.1} mm with its gearheads' friction and backlash too, {:.1} mm with all of the no-load torque \
             as Coulomb friction",
            1e3 * ideal,
            1e3 * hardware,
            1e3 * real,
            1e3 * coulomb
        );
        // The sensors and drive cost some accuracy, the gearheads more; Coulomb friction (more
        // than the tracker's steady torques) costs most, yet the robot stays near the circle.
        assert!(ideal < hardware && hardware < real && real < coulomb && coulomb < 0.6, "{ideal} {hardware} {real} {coulomb}");
        let (mut a, mut b, mut other) = (Trace::default(), Trace::default(), Trace::default());
        run(&Realism::thesis_like(), 2.0, &mut a);
        run(&Realism::thesis_like(), 2.0, &mut b);
        run(&Realism::thesis_like().with_stream(1), 2.0, &mut other);
        assert_eq!(a.0, b.0);
        assert_ne!(a.0, other.0);
    }

    #[test]
    fn odometry_follows_the_truth_within_counts() {
        // Encoders only: no noise, so the dead-reckoned pose drifts by quantisation alone.
        let realism = Realism { encoder_cpr: Some(700.0), ..Realism::ideal() };
        let (model, mut ctrl, circle) = setup();
        let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
        let mut rig = realism.build_planar(&model, config.dt).unwrap();
        let mut trace = Trace::default();
        rig.simulate(&mut ctrl, &circle, &PlanarState::zeros(), &config, &mut trace, || false).unwrap();
        let x = trace.0.last().unwrap().1;
        let y = rig.sensors.read(10.0, &x);
        let count = core::f64::consts::TAU / 700.0 * model.params().wheel_radius;
        std::println!("after 10 s: position error {:.2e} m, heading error {:.2e} rad", ((y[0] - x[0]).powi(2) + (y[1] - x[1]).powi(2)).sqrt(), y[2] - x[2]);
        assert!(((y[0] - x[0]).powi(2) + (y[1] - x[1]).powi(2)).sqrt() < 20.0 * count);
        assert!((y[2] - x[2]).abs() < 2.0 * count / model.params().half_track);
    }

    #[test]
    fn a_slope_profile_is_refused_by_name() {
        let (model, _, _) = setup();
        let realism = Realism { slope_profile: crate::hardware::disturbance::SlopeProfile::constant(0.1), ..Realism::ideal() };
        assert!(matches!(
            realism.build_planar(&model, 1e-3),
            Err(TwipError::InvalidParameter { name: "slope_profile", .. })
        ));
    }
}

#[cfg(all(test, feature = "std"))]
mod f32_tests {
    use super::*;
    use crate::control::pid::PidTracker;
    use crate::control::trajectory::{Circle, Direction};
    use crate::hardware::motor::DcMotor;
    use crate::sim::runner::{Outcome, SimConfig};

    /// The rig in f32 (a microcontroller's precision) tracks like the f64 one. Without
    /// the IMU: `ImuSettings::validate` refuses the f32 rounding of its ranges.
    #[test]
    fn f32_rig_runs_like_f64() {
        fn end<T: Real>() -> (Outcome<T>, [f64; 2]) {
            let params = RobotParams::<T>::balanbot();
            let mut ctrl = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), c(0.005)).unwrap();
            let speed = c::<T>(core::f64::consts::PI) * params.wheel_radius;
            let circle = Circle::from_origin(c(0.6), speed, Direction::CounterClockwise).unwrap();
            let config = SimConfig { dt: c(1e-3), t_final: c(10.0), fall_limit: T::one() };
            let model = PlanarModel::new(params).unwrap();
            let realism = Realism::<T> { imu: None, ..Realism::thesis_like() };
            let mut rig = realism.build_planar(&model, config.dt).unwrap();
            let mut last = PlanarState::<T>::zeros();
            struct Last<'a, T: Real>(&'a mut PlanarState<T>);
            impl<T: Real, S> crate::sim::runner::Observer<T, 7, 2, S> for Last<'_, T> {
                fn observe(&mut self, _: T, x: &PlanarState<T>, _: &SVector<T, 2>, _: &S, _: &[T]) {
                    *self.0 = *x;
                }
            }
            let (outcome, _) = rig.simulate(&mut ctrl, &circle, &PlanarState::zeros(), &config, &mut Last(&mut last), || false).unwrap();
            (outcome, [crate::to_f64(last[0]), crate::to_f64(last[1])])
        }
        let (o64, p64) = end::<f64>();
        let (o32, p32) = end::<f32>();
        assert_eq!((o64, o32), (Outcome::Completed, Outcome::Completed));
        let gap = ((p64[0] - p32[0]).powi(2) + (p64[1] - p32[1]).powi(2)).sqrt();
        std::println!("after 10 s on the circle: f32 and f64 rigs {gap:.1e} m apart");
        assert!(gap < 0.05, "{gap}");
    }
}

/// The 3-DOF rig on terrain (`Realism::build_planar_on`).
#[cfg(all(test, feature = "std"))]
mod terrain_tests {
    use super::*;
    use crate::control::pid::PidTracker;
    use crate::control::trajectory::{Circle, Direction};
    use crate::hardware::motor::DcMotor;
    use crate::sim::runner::{simulate, Observer, Outcome, SimConfig};

    #[derive(Default)]
    struct Trace(std::vec::Vec<(f64, PlanarState<f64>, SVector<f64, 2>, std::vec::Vec<f64>)>);

    impl<S> Observer<f64, 7, 2, S> for Trace {
        fn observe(&mut self, t: f64, x: &PlanarState<f64>, u: &SVector<f64, 2>, _: &S, signals: &[f64]) {
            self.0.push((t, *x, *u, signals.to_vec()));
        }
    }

    fn run(realism: &Realism<f64>, terrain: Option<&Terrain<f64>>, t_final: f64) -> (Outcome<f64>, Trace) {
        let params = RobotParams::balanbot();
        let mut ctrl = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
        let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
        let config = SimConfig { dt: 1e-3, t_final, fall_limit: 1.0 };
        let mut rig = realism.build_planar_on(&PlanarModel::new(params).unwrap(), terrain, config.dt).unwrap();
        let mut trace = Trace::default();
        let outcome = rig.simulate(&mut ctrl, &circle, &PlanarState::zeros(), &config, &mut trace, || false).unwrap().0;
        (outcome, trace)
    }

    fn rigs() -> [(&'static str, Realism<f64>); 3] {
        let pushed = Realism {
            force: Force { horizontal: 0.05, vertical: -0.2, height: 0.1 },
            pushes: Pushes::new(&[Push { t: 1.0, impulse: 0.03, height: 0.15 }]).unwrap(),
            ..Realism::thesis_like()
        };
        let stick = Realism { friction: Some(crate::model::friction::Friction::gb37().with_stick(0.1)), ..Realism::thesis_like() };
        [("thesis-like", Realism::thesis_like()), ("force and a push", pushed), ("stick band", stick)]
    }

    /// Level ground given as a terrain (a plane of zero slope, any uphill heading) runs the
    /// flat rig bit for bit: states, commands and every signal, with backlash's impacts, a
    /// body force, a push and a stick band.
    #[test]
    fn level_terrain_is_the_flat_rig_bitwise() {
        let level = Terrain::plane(0.0, 0.7).unwrap();
        for (name, realism) in rigs() {
            let (a, flat) = run(&realism, None, 6.0);
            let (b, on) = run(&realism, Some(&level), 6.0);
            assert_eq!(a, Outcome::Completed, "{name}");
            assert_eq!((a, &flat.0), (b, &on.0), "{name}");
        }
    }

    /// With the ideal realism, the rig on terrain is the plain runner on the terrain model,
    /// bit for bit; with the thesis-like rig a 5° slope changes the run, which still holds.
    #[test]
    fn the_rig_on_a_slope_is_the_terrain_model() {
        let hill = Terrain::plane(5f64.to_radians(), 0.5).unwrap();
        let params = RobotParams::balanbot();
        let model = TerrainModel::new(PlanarModel::new(params).unwrap(), hill.clone());
        let mut ctrl = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
        let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
        let config = SimConfig { dt: 1e-3, t_final: 4.0, fall_limit: 1.0 };
        let mut plain = Trace::default();
        simulate(&model, &mut ctrl, &circle, &PlanarState::zeros(), &config, &mut plain).unwrap();
        let (_, ideal) = run(&Realism::ideal(), Some(&hill), 4.0);
        let states = |t: &Trace| t.0.iter().map(|r| (r.0, r.1, r.2)).collect::<std::vec::Vec<_>>();
        assert_eq!(states(&plain), states(&ideal));
        let (flat_outcome, flat) = run(&Realism::thesis_like(), None, 4.0);
        let (outcome, sloped) = run(&Realism::thesis_like(), Some(&hill), 4.0);
        assert_eq!((flat_outcome, outcome), (Outcome::Completed, Outcome::Completed));
        let gap = flat.0.iter().zip(&sloped.0).map(|(a, b)| (a.1 - b.1).amax()).fold(0.0, f64::max);
        std::println!("thesis-like rig, 4 s of circle-pid: flat and a 5 degree plane differ by {gap:.3} at most (state)");
        assert!(gap > 1e-3, "{gap}");
    }

    /// The IMUs' inputs on terrain against the sensor's motion in 3-D: its position from
    /// the contact point, the normal and the body's axis along a run on a plane with a cross
    /// slope (ω = 0 at the middle sample, ω̇ not: the yaw torque of the lean), differentiated
    /// twice; the specific force (acceleration plus g up) along the body's x and z axes. At
    /// rest the accelerometer's tilt is φ, the pitch from the most vertical direction.
    #[test]
    fn the_imu_on_terrain_reads_the_bodys_motion_in_3d() {
        let p = RobotParams::<f64>::balanbot();
        let (radius, height, g) = (p.wheel_radius, 0.12, p.g);
        let dims = (radius, 1.0 / radius, height, g);
        let hill = Terrain::plane(0.35, 0.4).unwrap();
        let model = TerrainModel::new(PlanarModel::new(p).unwrap(), hill.clone());
        let Terrain::Plane { gx, gy } = hill else { unreachable!() };
        // The sensor's position in 3-D and the body's x and z axes.
        let axes = |x: &PlanarState<f64>| {
            let norm = |v: [f64; 3]| {
                let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                v.map(|c| c / l)
            };
            let n = norm([-gx, -gy, 1.0]);
            let (s, c) = x[2].sin_cos();
            let d = norm([c, s, gx * c + gy * s]);
            let f = model.frame(x);
            let (sp, cp) = (x[3] + f.delta).sin_cos();
            let bz: [f64; 3] = core::array::from_fn(|i| n[i] * cp + d[i] * sp);
            let bx: [f64; 3] = core::array::from_fn(|i| d[i] * cp - n[i] * sp);
            let h = gx * x[0] + gy * x[1];
            let pos: [f64; 3] = core::array::from_fn(|i| [x[0], x[1], h][i] + radius * n[i] + height * bz[i]);
            (pos, bx, bz)
        };
        let dot = |a: [f64; 3], b: [f64; 3]| a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        let mut worst: f64 = 0.0;
        for (psi, phi, phi_dot, v) in [(1.4, 0.1, 0.5, 0.4), (-0.9, -0.3, -1.0, 1.0), (2.5, 0.0, 0.0, 0.0), (0.4, 0.2, 0.0, -0.3)] {
            let x = PlanarState::from([0.3, -0.2, psi, phi, phi_dot, v, 0.0]);
            let u = SVector::from([0.05, 0.02]);
            let d = model.deriv(&x, &u);
            let h = 1e-3;
            let (back, fwd) = (crate::rk4_step(&model, &x, &u, -h), crate::rk4_step(&model, &x, &u, h));
            let ((p0, bx, bz), (pb, _, _), (pf, _, _)) = (axes(&x), axes(&back), axes(&fwd));
            let acc: [f64; 3] = core::array::from_fn(|i| (pf[i] - 2.0 * p0[i] + pb[i]) / (h * h));
            let force = [acc[0], acc[1], acc[2] + g];
            let [fx, fz, rate, yaw] = imu_inputs_on_terrain(&hill, &x, &d, dims);
            let e = ((fx - dot(force, bx)).abs()).max((fz - dot(force, bz)).abs());
            worst = worst.max(e);
            assert!(e < 1e-5 * g, "psi {psi}: ({fx}, {fz}) against ({}, {})", dot(force, bx), dot(force, bz));
            assert_eq!((rate, yaw), (phi_dot, 0.0));
        }
        std::println!("IMU on a 0.35 rad plane: specific force within {worst:.1e} m/s^2 of the 3-D sensor's");
        let rest = PlanarState::from([0.0, 0.0, 0.4 + core::f64::consts::FRAC_PI_2, 0.0, 0.0, 0.0, 0.0]);
        let [fx, fz, _, _] = imu_inputs_on_terrain(&hill, &rest, &model.deriv(&rest, &SVector::zeros()), dims);
        // Across the slope, upright: the accelerometer reads g cos(roll) up the body, no tilt.
        assert!(fx.abs() < 1e-12 && (fz - g * 0.35f64.cos()).abs() < 1e-12, "{fx} {fz}");
        // At rest on the grade at any heading (its rest pitch and torques): the tilt is φ,
        // the pitch from the most vertical direction, not φ' from the normal.
        for heading in [0.4, 1.2, 3.0] {
            let (phi, u) = model.rest(0.0, 0.0, heading).unwrap();
            let x = PlanarState::from([0.0, 0.0, heading, phi, 0.0, 0.0, 0.0]);
            let d = model.deriv(&x, &SVector::from(u));
            assert!(d.amax() < 1e-12, "{d}");
            let [fx, fz, _, _] = imu_inputs_on_terrain(&hill, &x, &d, dims);
            assert!((accel_tilt(fx, fz) - phi).abs() < 1e-12 && phi.abs() > 0.01, "{} vs {phi}", accel_tilt(fx, fz));
        }
    }
}
