//! The Balance Shield's MPU-6050 (thesis 2.2.2): the accelerometer and gyroscope of the
//! pitch plane with their noise, bias, full scale, LSB and digital low-pass filter.
//!
//! The sensor sits on the body's axis at `height` above the axle, x forward and z up the
//! body. Its specific force (acceleration minus gravity) in its own axes follows from the
//! state and its derivative, with `p = r θ (cos α, sin α) + h (sin φ, cos φ)`:
//!
//! ```text
//! f_x = r θ̈ cos(φ + α) + h φ̈ − g sin φ
//! f_z = r θ̈ sin(φ + α) − h φ̇² + g cos φ
//! ```
//!
//! and the gyroscope measures φ̇ (φ is from the true vertical). Each 1 kHz sample adds
//! the bias and white noise of the data sheet's densities (σ = density · √(fs/2)), clips to
//! the full scale, runs the DLPF and rounds to the LSB of the 16-bit output registers.
//!
//! The DLPF of Table 2.2 is given by a bandwidth and a delay. A second-order low-pass
//! has a DC group delay 2ζ/ω_n and a −3 dB bandwidth ω_n g(ζ); solving both for (ζ, ω_n)
//! works when delay · ω_b ≤ √2 (the 44 Hz rows and below: ζ from 0.58 down to 0.19, so
//! the slow rows ring). The fast rows need more delay than any second-order section:
//! there the section is a Butterworth (ζ = 1/√2) at the bandwidth followed by the rest
//! as a pure delay (whole samples and a first-order Thiran all-pass for the fraction).
//! The section is discretised by the bilinear transform prewarped at the bandwidth, which
//! scales the DC delay by κ = (ω_b T/2)/tan(ω_b T/2); the design targets delay/κ so that
//! both numbers hold for the discrete filter. The 260 Hz accelerometer row (delay 0)
//! passes samples through.
use crate::model::lane::{clamp, saturate, Lane};
use crate::rng::{Sfc64, Ziggurat};
use crate::{c, Real, TwipError};

/// Standard gravity: the unit of the accelerometer's LSB [m/s²].
pub const STANDARD_GRAVITY: f64 = 9.80665;

/// One row of Table 2.2 (DLPF_CFG = index): bandwidths [Hz] and delays [s].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DlpfRow {
    pub accel_hz: f64,
    pub accel_delay: f64,
    pub gyro_hz: f64,
    pub gyro_delay: f64,
}

/// Table 2.2 (the MPU-6050's register map, CONFIG.DLPF_CFG 0–6).
pub const DLPF_TABLE: [DlpfRow; 7] = [
    DlpfRow { accel_hz: 260.0, accel_delay: 0.0, gyro_hz: 256.0, gyro_delay: 0.98e-3 },
    DlpfRow { accel_hz: 184.0, accel_delay: 2.0e-3, gyro_hz: 188.0, gyro_delay: 1.9e-3 },
    DlpfRow { accel_hz: 94.0, accel_delay: 3.0e-3, gyro_hz: 98.0, gyro_delay: 2.8e-3 },
    DlpfRow { accel_hz: 44.0, accel_delay: 4.9e-3, gyro_hz: 42.0, gyro_delay: 4.8e-3 },
    DlpfRow { accel_hz: 21.0, accel_delay: 8.5e-3, gyro_hz: 20.0, gyro_delay: 8.3e-3 },
    DlpfRow { accel_hz: 10.0, accel_delay: 13.8e-3, gyro_hz: 10.0, gyro_delay: 13.4e-3 },
    DlpfRow { accel_hz: 5.0, accel_delay: 19.0e-3, gyro_hz: 5.0, gyro_delay: 18.6e-3 },
];

/// The DLPF_CFG whose accelerometer or gyroscope bandwidth is `hz` (either column).
pub fn dlpf_config(hz: f64) -> Result<usize, TwipError> {
    DLPF_TABLE
        .iter()
        .position(|r| (r.accel_hz - hz).abs() < 0.5 || (r.gyro_hz - hz).abs() < 0.5)
        .ok_or(TwipError::InvalidParameter {
            name: "dlpf_hz",
            value: hz,
            reason: "must be a bandwidth of Table 2.2: 260/256, 184/188, 94/98, 44/42, 21/20, 10 or 5 Hz",
        })
}

/// Which of the two sensors a filter belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    Accel,
    Gyro,
}

/// Longest whole-sample pure delay a [`Dlpf`] holds.
pub const MAX_DELAY_SAMPLES: usize = 8;

/// −3 dB bandwidth of a unit second-order low-pass, over ω_n.
fn bandwidth_ratio<T: Real>(zeta: T) -> T {
    let a = T::one() - c::<T>(2.0) * zeta * zeta;
    (a + (a * a + T::one()).sqrt()).sqrt()
}

/// A Table 2.2 filter: a second-order section, then a pure delay (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dlpf<T> {
    bypass: bool,
    /// b0 (= b2, b1 = 2 b0), a1, a2 of the section; direct form II transposed.
    b0: T,
    a1: T,
    a2: T,
    s1: T,
    s2: T,
    /// Thiran all-pass coefficient for the fractional sample (None when whole).
    allpass: Option<T>,
    ap_x: T,
    ap_y: T,
    /// The pure delay's samples, newest first (a shift register, not a ring with a head:
    /// every lane of a sweep's or an env's lanes then keeps its own at the same places, even
    /// when lanes sample at different steps).
    ring: [T; MAX_DELAY_SAMPLES],
    whole: usize,
    zeta: T,
    natural: T,
    pure: T,
}

impl<T: Real> Dlpf<T> {
    /// The filter with −3 dB `bandwidth` [Hz] and DC delay `delay` [s] at sample period
    /// `period` [s]. A zero delay passes samples through.
    pub fn new(bandwidth: T, delay: T, period: T) -> Result<Self, TwipError> {
        let bad = |name, v: T, reason| Err(TwipError::InvalidParameter { name, value: crate::to_f64(v), reason });
        if !(period.is_finite() && period > T::zero()) {
            return bad("sample_period", period, "must be finite and > 0");
        }
        if !(delay.is_finite() && delay >= T::zero()) {
            return bad("delay", delay, "must be finite and >= 0");
        }
        let z = T::zero();
        let mut f = Self {
            bypass: delay == z,
            b0: z, a1: z, a2: z, s1: z, s2: z,
            allpass: None, ap_x: z, ap_y: z,
            ring: [z; MAX_DELAY_SAMPLES], whole: 0,
            zeta: z, natural: z, pure: z,
        };
        if f.bypass {
            return Ok(f);
        }
        let wb = T::two_pi() * bandwidth;
        let half = wb * period * c::<T>(0.5);
        if !(bandwidth.is_finite() && bandwidth > z && half < T::frac_pi_2()) {
            return bad("bandwidth", bandwidth, "must be > 0 and below half the sample rate");
        }
        let kappa = half / half.tan();
        let target = delay * wb / kappa;
        let root2 = c::<T>(2.0).sqrt();
        let (zeta, natural, pure) = if target >= root2 {
            let zeta = T::one() / root2;
            (zeta, wb, delay - kappa * root2 / wb)
        } else {
            // 2ζ g(ζ) rises from 0 to √2 on (0, 1/√2]: bisection, at most 80 halvings.
            let (mut lo, mut hi) = (z, T::one() / root2);
            for _ in 0..80 {
                let mid = (lo + hi) * c::<T>(0.5);
                let ends = (lo, hi);
                if c::<T>(2.0) * mid * bandwidth_ratio(mid) < target { lo = mid } else { hi = mid }
                // A midpoint that rounds onto an end leaves (lo, hi) fixed from here on (the same
                // midpoint and test again, or lo = hi): the 80 halvings' bits, in ~55 (f64). Every
                // new robot of an env's rig designs its IMUs' filters anew.
                if mid == ends.0 || mid == ends.1 {
                    break;
                }
            }
            let zeta = (lo + hi) * c::<T>(0.5);
            (zeta, wb / bandwidth_ratio(zeta), z)
        };
        // Bilinear transform prewarped at the bandwidth.
        let k = wb / half.tan();
        let (k2, wn2, cross) = (k * k, natural * natural, c::<T>(2.0) * zeta * natural * k);
        let a0 = k2 + cross + wn2;
        f.b0 = wn2 / a0;
        f.a1 = c::<T>(2.0) * (wn2 - k2) / a0;
        f.a2 = (k2 - cross + wn2) / a0;
        let samples = pure / period;
        let whole = samples.floor();
        let frac = samples - whole;
        if crate::to_f64(whole) > MAX_DELAY_SAMPLES as f64 {
            return bad("delay", delay, "needs a pure delay longer than 8 samples");
        }
        f.whole = crate::to_f64(whole) as usize;
        if frac > c::<T>(1e-12) {
            f.allpass = Some((T::one() - frac) / (T::one() + frac));
        }
        f.zeta = zeta;
        f.natural = natural;
        f.pure = pure;
        Ok(f)
    }

    /// Row `cfg` of Table 2.2 for one sensor.
    pub fn mpu6050(cfg: usize, channel: Channel, period: T) -> Result<Self, TwipError> {
        let row = DLPF_TABLE.get(cfg).ok_or(TwipError::InvalidParameter {
            name: "dlpf",
            value: cfg as f64,
            reason: "must be a DLPF_CFG of Table 2.2 (0 to 6)",
        })?;
        let (hz, delay) = match channel {
            Channel::Accel => (row.accel_hz, row.accel_delay),
            Channel::Gyro => (row.gyro_hz, row.gyro_delay),
        };
        Self::new(c(hz), c(delay), period)
    }

    /// Damping of the second-order section (0 when passing through).
    pub fn zeta(&self) -> T {
        self.zeta
    }

    /// Natural frequency of the analogue section [rad/s].
    pub fn natural_frequency(&self) -> T {
        self.natural
    }

    /// The pure delay after the section [s].
    pub fn pure_delay(&self) -> T {
        self.pure
    }
}

// The filter's step, written once over `Lane` (plain arithmetic: a sweep's lanes give the
// run's bits); its configuration (bypass, all-pass, whole delay) is the same for every lane.
impl<S: Lane> Dlpf<S> {
    /// Sets every state to the steady state of a constant input `v` (a filter that has
    /// been running since power-up).
    pub fn prime(&mut self, v: S) {
        let two = S::splat(2.0);
        self.s2 = (self.b0 - self.a2) * v;
        self.s1 = (two * self.b0 - self.a1) * v + self.s2;
        self.ap_x = v;
        self.ap_y = v;
        self.ring = [v; MAX_DELAY_SAMPLES];
    }

    /// One sample in, one out.
    #[inline(always)]
    pub fn filter(&mut self, x: S) -> S {
        if self.bypass {
            return x;
        }
        let y = self.b0 * x + self.s1;
        self.s1 = S::splat(2.0) * self.b0 * x - self.a1 * y + self.s2;
        self.s2 = self.b0 * x - self.a2 * y;
        let mut out = y;
        if let Some(eta) = self.allpass {
            out = eta * y + self.ap_x - eta * self.ap_y;
            self.ap_x = y;
            self.ap_y = out;
        }
        if self.whole > 0 {
            let delayed = self.ring[self.whole - 1];
            self.ring.copy_within(0..self.whole - 1, 1);
            self.ring[0] = out;
            out = delayed;
        }
        out
    }

    /// Each state of this filter set to `f(its own, the same state of `other`)`: a lane's
    /// state taken from another copy of the same filter.
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // the lanes use it
    fn zip_state(&mut self, other: &Self, f: impl Fn(S, S) -> S + Copy) {
        (self.s1, self.s2, self.ap_x, self.ap_y) = (f(self.s1, other.s1), f(self.s2, other.s2), f(self.ap_x, other.ap_x), f(self.ap_y, other.ap_y));
        for (mine, theirs) in self.ring.iter_mut().zip(&other.ring) {
            *mine = f(*mine, *theirs);
        }
    }
}

impl<T: Copy> Dlpf<T> {
    /// The same filter in another number type (a sweep's lanes).
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    fn map<S>(&self, f: impl Fn(T) -> S + Copy) -> Dlpf<S> {
        Dlpf {
            bypass: self.bypass,
            b0: f(self.b0),
            a1: f(self.a1),
            a2: f(self.a2),
            s1: f(self.s1),
            s2: f(self.s2),
            allpass: self.allpass.map(f),
            ap_x: f(self.ap_x),
            ap_y: f(self.ap_y),
            ring: self.ring.map(f),
            whole: self.whole,
            zeta: f(self.zeta),
            natural: f(self.natural),
            pure: f(self.pure),
        }
    }
}

/// How the MPU-6050 is set up and how it errs. SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuSettings<T> {
    /// DLPF_CFG: the row of Table 2.2.
    pub dlpf: usize,
    /// Sample period of the filters and output registers [s].
    pub sample_period: T,
    /// Height of the sensor on the body's axis above the axle [m].
    pub height: T,
    /// Gyroscope rate noise density [rad/s/√Hz].
    pub gyro_noise: T,
    /// Accelerometer noise density [m/s²/√Hz].
    pub accel_noise: T,
    /// Gyroscope bias at the start [rad/s].
    pub gyro_bias: T,
    /// Gyroscope bias random walk [rad/s/√s].
    pub gyro_bias_walk: T,
    /// Accelerometer biases along the sensor's x and z [m/s²].
    pub accel_bias: [T; 2],
    /// Full scale of the gyroscope [rad/s] (FS_SEL: 250, 500, 1000 or 2000 °/s).
    pub gyro_range: T,
    /// Full scale of the accelerometer [m/s²] (AFS_SEL: 2, 4, 8 or 16 g).
    pub accel_range: T,
    /// Round the outputs to the 16-bit registers' LSB.
    pub quantise: bool,
}

const GYRO_RANGES_DPS: [f64; 4] = [250.0, 500.0, 1000.0, 2000.0];
const ACCEL_RANGES_G: [f64; 4] = [2.0, 4.0, 8.0, 16.0];

impl<T: Real> ImuSettings<T> {
    /// The data sheet's sensor (PS-MPU-6000A-00 rev 3.4) at DLPF_CFG = 3 (44/42 Hz),
    /// ±250 °/s and ±2 g, 1 kHz, no bias; mounted 0.12 m up the body (the top plate).
    pub fn data_sheet() -> Self {
        let dps = core::f64::consts::PI / 180.0;
        Self {
            dlpf: 3,
            sample_period: c(1e-3),
            height: c(0.12),
            gyro_noise: c(0.005 * dps),
            accel_noise: c(400e-6 * STANDARD_GRAVITY),
            gyro_bias: T::zero(),
            gyro_bias_walk: T::zero(),
            accel_bias: [T::zero(); 2],
            gyro_range: c(250.0 * dps),
            accel_range: c(2.0 * STANDARD_GRAVITY),
            quantise: true,
        }
    }

    /// [`Self::data_sheet`] with the residual errors of a start-up calibration: gyro bias
    /// 0.1 °/s drifting 0.005 °/s/√s, accelerometer x bias 5 mg (0.3° of tilt left by
    /// trimming the balance point by hand; docs/parameters.md).
    pub fn thesis_like() -> Self {
        let dps = core::f64::consts::PI / 180.0;
        Self {
            gyro_bias: c(0.1 * dps),
            gyro_bias_walk: c(0.005 * dps),
            accel_bias: [c(0.005 * STANDARD_GRAVITY), T::zero()],
            ..Self::data_sheet()
        }
    }

    /// Checks every field and names the first bad one.
    pub fn validate(&self) -> Result<Self, TwipError> {
        let bad = |name, v: T, reason| Err(TwipError::InvalidParameter { name, value: crate::to_f64(v), reason });
        if self.dlpf >= DLPF_TABLE.len() {
            return bad("dlpf", c(self.dlpf as f64), "must be a DLPF_CFG of Table 2.2 (0 to 6)");
        }
        if !(self.sample_period.is_finite() && self.sample_period > T::zero()) {
            return bad("sample_period", self.sample_period, "must be finite and > 0");
        }
        // The filters' own condition (`Dlpf::new`), here rather than at the first run.
        let row = DLPF_TABLE[self.dlpf];
        let period = crate::to_f64(self.sample_period);
        for (hz, delay) in [(row.accel_hz, row.accel_delay), (row.gyro_hz, row.gyro_delay)] {
            if delay > 0.0 && hz * period >= 0.5 {
                return bad("sample_period", self.sample_period, "must be below half the DLPF bandwidth's period (the sample rate above twice the bandwidth)");
            }
        }
        if !self.height.is_finite() {
            return bad("height", self.height, "must be finite");
        }
        for (name, v) in [
            ("gyro_noise", self.gyro_noise),
            ("accel_noise", self.accel_noise),
            ("gyro_bias_walk", self.gyro_bias_walk),
        ] {
            if !(v.is_finite() && v >= T::zero()) {
                return bad(name, v, "must be finite and >= 0");
            }
        }
        for (name, v) in [("gyro_bias", self.gyro_bias), ("accel_bias", self.accel_bias[0]), ("accel_bias", self.accel_bias[1])] {
            if !v.is_finite() {
                return bad(name, v, "must be finite");
            }
        }
        let dps = core::f64::consts::PI / 180.0;
        let near = |v: T, options: &[f64], unit: f64| options.iter().any(|o| (crate::to_f64(v) - o * unit).abs() < 1e-9 * o * unit);
        if !near(self.gyro_range, &GYRO_RANGES_DPS, dps) {
            return bad("gyro_range", self.gyro_range, "must be 250, 500, 1000 or 2000 deg/s (FS_SEL)");
        }
        if !near(self.accel_range, &ACCEL_RANGES_G, STANDARD_GRAVITY) {
            return bad("accel_range", self.accel_range, "must be 2, 4, 8 or 16 g (AFS_SEL)");
        }
        Ok(*self)
    }
}

/// The specific force at the sensor in its axes (module docs) from the state `x`, its
/// derivative `xdot`, sin and cos of the ground's slope, the wheel radius and gravity.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn specific_force<T: Real>(
    x: &nalgebra::Vector4<T>,
    xdot: &nalgebra::Vector4<T>,
    sin_slope: T,
    cos_slope: T,
    radius: T,
    height: T,
    g: T,
) -> (T, T) {
    let (x, xdot) = ([x[0], x[1], x[2], x[3]], [xdot[0], xdot[1], xdot[2], xdot[3]]);
    specific_force_of(&x, &xdot, sin_slope, cos_slope, radius, height, g)
}

/// [`specific_force`], written once over `Lane` (a sweep's lanes).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn specific_force_of<S: Lane>(x: &[S; 4], xdot: &[S; 4], sin_slope: S, cos_slope: S, radius: S, height: S, g: S) -> (S, S) {
    let (sin_phi, cos_phi) = S::sincos(x[0]);
    let sin_pa = sin_phi * cos_slope + cos_phi * sin_slope;
    let cos_pa = cos_phi * cos_slope - sin_phi * sin_slope;
    let wheel = radius * xdot[3];
    (
        wheel * cos_pa + height * xdot[1] - g * sin_phi,
        wheel * sin_pa - height * x[1] * x[1] + g * cos_phi,
    )
}

/// The output registers in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImuReading<T> {
    pub accel_x: T,
    pub accel_z: T,
    pub gyro: T,
}

/// The MPU-6050 in the pitch plane.
#[derive(Clone, Copy, Debug)]
pub struct Mpu6050<T> {
    settings: ImuSettings<T>,
    gyro_filter: Dlpf<T>,
    accel_x_filter: Dlpf<T>,
    accel_z_filter: Dlpf<T>,
    bias: T,
    sigma_gyro: T,
    sigma_accel: T,
    sigma_walk: T,
    gyro_lsb: T,
    accel_lsb: T,
    /// 1 / LSB (a product is cheaper than a quotient per sample).
    gyro_per_lsb: T,
    accel_per_lsb: T,
    primed: bool,
    reading: ImuReading<T>,
    noise: NoiseBatch,
}

/// Normals an IMU draws from its stream at a time: eight samples' worth (four each).
pub const NOISE_BATCH: usize = 32;

/// An IMU's normals, drawn ahead in batches from its stream (the same sequence, drawn
/// faster in a tight loop): four per sample.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NoiseBatch {
    gauss: Ziggurat,
    noise: [f64; NOISE_BATCH],
    used: usize,
}

impl NoiseBatch {
    fn new() -> Self {
        Self { gauss: Ziggurat::new(), noise: [0.0; NOISE_BATCH], used: NOISE_BATCH }
    }

    /// The next sample's four standard normals (gyro, accel x, accel z, bias walk).
    #[inline]
    pub(crate) fn draw<T: Real>(&mut self, rng: &mut Sfc64) -> [T; 4] {
        if self.used == NOISE_BATCH {
            let noise = &mut self.noise;
            self.gauss.fill(rng, NOISE_BATCH / 2, |n, [v]| noise[n] = v);
            self.used = 0;
        }
        let k = self.used;
        self.used += 4;
        [c(self.noise[k]), c(self.noise[k + 1]), c(self.noise[k + 2]), c(self.noise[k + 3])]
    }
}

/// Samples a [`NoiseBatch`] holds (four normals each).
const BATCH_SAMPLES: usize = NOISE_BATCH / 4;

/// The [`NoiseBatch`]es of `N` robots' IMUs that sample together (a sweep's lanes), `K`
/// IMUs per robot drawing in turn from the robot's own stream (the 3-DOF robot's pitch
/// channels, then its yaw gyro): refilled together, each sample's four normals per IMU
/// are four rows over the robots. Lanes that restart apart (an env's robots, each started
/// at its own step) each keep their own place in their rows and refill alone.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NoiseLanes<const N: usize, const K: usize> {
    gauss: Ziggurat,
    rows: [[[[f64; N]; 4]; K]; BATCH_SAMPLES],
    /// Samples of the rows used: every lane's while they are in step (`apart` None), else
    /// each lane's own, and the rows each lane's place gave (what `draw` hands out).
    used: usize,
    apart: Option<Apart<N, K>>,
    streams: Sfc64<N>,
}

/// Each lane's place in its rows, and the rows their places gave, of lanes apart.
type Apart<const N: usize, const K: usize> = ([usize; N], [[[f64; N]; 4]; K]);

#[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
impl<const N: usize, const K: usize> NoiseLanes<N, K> {
    /// From each robot's stream and its IMUs' batches as they stand. Their batches are in
    /// step (the same normals used) when the IMUs have sampled alike, as rigs built alike have.
    pub(crate) fn new(parts: &[(Sfc64, [NoiseBatch; K]); N]) -> Self {
        let used = parts[0].1[0].used;
        debug_assert!(parts.iter().all(|p| p.1.iter().all(|b| b.used == used)), "the IMUs' batches are in step");
        let mut lanes = Self { gauss: Ziggurat::new(), rows: [[[[0.0; N]; 4]; K]; BATCH_SAMPLES], used: used / 4, apart: None, streams: Sfc64::lanes(parts.map(|p| p.0)) };
        for (l, (_, batches)) in parts.iter().enumerate() {
            lanes.put_rows(l, batches);
        }
        lanes
    }

    fn put_rows(&mut self, l: usize, batches: &[NoiseBatch; K]) {
        for (k, batch) in batches.iter().enumerate() {
            for (n, v) in batch.noise.iter().enumerate() {
                self.rows[n / 4][k][n % 4][l] = *v;
            }
        }
    }

    /// Lane `l` goes on as the robot whose stream and batches these are (a robot started
    /// anew): from now on the lanes keep their places apart.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn restart(&mut self, l: usize, rng: Sfc64, batches: &[NoiseBatch; K]) {
        let (used, _) = self.apart.get_or_insert(([self.used; N], [[[0.0; N]; 4]; K]));
        used[l] = batches[0].used / 4;
        self.streams.set_lane(l, rng);
        self.put_rows(l, batches);
    }

    /// Every robot's next four normals per IMU (gyro, accel x, accel z, bias walk): four
    /// rows per IMU, as [`NoiseBatch::draw`] gives each. Only the lanes `due` draw (the
    /// others' rows are left as they were): lanes that do not all draw go apart.
    #[inline(always)]
    pub(crate) fn draw(&mut self, due: &[bool; N]) -> &[[[f64; N]; 4]; K] {
        if self.apart.is_none() && due.iter().any(|&d| !d) {
            self.apart = Some(([self.used; N], [[[0.0; N]; 4]; K]));
        }
        let Some((used, out)) = self.apart.as_mut() else {
            if self.used == BATCH_SAMPLES {
                let rows = &mut self.rows;
                #[allow(clippy::needless_range_loop)] // k indexes the rows' middle axis
                for k in 0..K {
                    self.gauss.fill(&mut self.streams, NOISE_BATCH / 2, |n, row| rows[n / 4][k][n % 4] = row);
                }
                self.used = 0;
            }
            self.used += 1;
            return &self.rows[self.used - 1];
        };
        for l in (0..N).filter(|&l| due[l]) {
            if used[l] == BATCH_SAMPLES {
                // This lane's stream alone, its IMUs in turn: the normals the lanes' fill
                // gives it.
                let mut rng = self.streams.lane(l);
                #[allow(clippy::needless_range_loop)] // k indexes the rows' middle axis
                for k in 0..K {
                    self.gauss.fill(&mut rng, NOISE_BATCH / 2, |n, [v]| self.rows[n / 4][k][n % 4][l] = v);
                }
                self.streams.set_lane(l, rng);
                used[l] = 0;
            }
            for (out_k, row_k) in out.iter_mut().zip(&self.rows[used[l]]) {
                for (o, r) in out_k.iter_mut().zip(row_k) {
                    o[l] = r[l];
                }
            }
            used[l] += 1;
        }
        out
    }
}

/// When an IMU samples: every sample period from t = 0, on a plant's grid of steps (a
/// sample is due at the step nearest its time).
#[derive(Clone, Copy, Debug)]
pub(crate) struct ImuClock<T> {
    next: T,
    period: T,
    half_step: T,
}

impl<T: Real> ImuClock<T> {
    pub(crate) fn new(period: T, dt: T) -> Self {
        Self { next: T::zero(), period, half_step: dt * c::<T>(0.5) }
    }

    /// Whether a sample is due at `t` (then the clock moves on to the next).
    #[inline(always)]
    pub(crate) fn due(&mut self, t: T) -> bool {
        if t + self.half_step < self.next {
            return false;
        }
        self.next += self.period;
        true
    }
}

impl<T: Real> Mpu6050<T> {
    pub fn new(settings: &ImuSettings<T>) -> Result<Self, TwipError> {
        let s = settings.validate()?;
        let period = s.sample_period;
        let accel = Dlpf::mpu6050(s.dlpf, Channel::Accel, period)?;
        // White noise of density ρ sampled at fs has σ = ρ √(fs / 2).
        let band = (c::<T>(0.5) / period).sqrt();
        let full = c::<T>(32768.0);
        Ok(Self {
            gyro_filter: Dlpf::mpu6050(s.dlpf, Channel::Gyro, period)?,
            accel_x_filter: accel,
            accel_z_filter: accel,
            bias: s.gyro_bias,
            sigma_gyro: s.gyro_noise * band,
            sigma_accel: s.accel_noise * band,
            sigma_walk: s.gyro_bias_walk * period.sqrt(),
            gyro_lsb: s.gyro_range / full,
            accel_lsb: s.accel_range / full,
            gyro_per_lsb: full / s.gyro_range,
            accel_per_lsb: full / s.accel_range,
            primed: false,
            reading: ImuReading { accel_x: T::zero(), accel_z: T::zero(), gyro: T::zero() },
            noise: NoiseBatch::new(),
            settings: s,
        })
    }



    /// The gyroscope's bias now [rad/s].
    pub fn bias(&self) -> T {
        self.bias
    }

    /// One sample of the true specific force (f_x, f_z) and pitch rate. Takes four normals
    /// of the stream (drawn 32 at a time by [`Ziggurat::fill`]) in the order gyro, accel
    /// x, accel z, bias walk, whatever is switched off, so that one source's numbers do
    /// not depend on the others'.
    #[inline]
    pub fn sample(&mut self, fx: T, fz: T, rate: T, rng: &mut Sfc64) {
        let n = self.draw(rng);
        self.sample_with(fx, fz, rate, n);
    }

    /// One sample of the gyroscope alone, for an IMU whose accelerometer nothing reads (the
    /// 3-DOF robot's yaw axis): takes the four normals a whole sample takes, and the
    /// accelerometer's registers stay as they are.
    #[inline]
    pub fn sample_gyro(&mut self, rate: T, rng: &mut Sfc64) {
        let n = self.draw(rng);
        self.sample_gyro_with(rate, n);
    }

    /// The next sample's four standard normals (gyro, accel x, accel z, bias walk), drawn
    /// in batches from `rng`.
    #[inline]
    pub(crate) fn draw(&mut self, rng: &mut Sfc64) -> [T; 4] {
        self.noise.draw(rng)
    }

    /// Where this IMU's normals stand (a sweep's lanes draw them for it).
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    pub(crate) fn noise(&self) -> NoiseBatch {
        self.noise
    }

    /// The latest registers set from elsewhere (a sweep's lanes sample for this IMU).
    #[cfg_attr(not(feature = "std"), allow(dead_code))]
    pub(crate) fn set_reading(&mut self, reading: ImuReading<T>) {
        self.reading = reading;
    }
}

impl<T: Copy> Mpu6050<T> {
    /// The latest output registers.
    pub fn reading(&self) -> ImuReading<T> {
        self.reading
    }

    pub fn settings(&self) -> &ImuSettings<T> {
        &self.settings
    }

    /// This IMU in another number type (a sweep's lanes: one per lane's value), its noise
    /// left behind (each lane draws its own).
    #[cfg_attr(not(feature = "std"), allow(dead_code))] // sweeps' lanes use it
    pub(crate) fn map<S>(&self, f: impl Fn(T) -> S + Copy) -> Mpu6050<S> {
        let s = &self.settings;
        Mpu6050 {
            settings: ImuSettings {
                dlpf: s.dlpf,
                sample_period: f(s.sample_period),
                height: f(s.height),
                gyro_noise: f(s.gyro_noise),
                accel_noise: f(s.accel_noise),
                gyro_bias: f(s.gyro_bias),
                gyro_bias_walk: f(s.gyro_bias_walk),
                accel_bias: s.accel_bias.map(f),
                gyro_range: f(s.gyro_range),
                accel_range: f(s.accel_range),
                quantise: s.quantise,
            },
            gyro_filter: self.gyro_filter.map(f),
            accel_x_filter: self.accel_x_filter.map(f),
            accel_z_filter: self.accel_z_filter.map(f),
            bias: f(self.bias),
            sigma_gyro: f(self.sigma_gyro),
            sigma_accel: f(self.sigma_accel),
            sigma_walk: f(self.sigma_walk),
            gyro_lsb: f(self.gyro_lsb),
            accel_lsb: f(self.accel_lsb),
            gyro_per_lsb: f(self.gyro_per_lsb),
            accel_per_lsb: f(self.accel_per_lsb),
            primed: self.primed,
            reading: ImuReading { accel_x: f(self.reading.accel_x), accel_z: f(self.reading.accel_z), gyro: f(self.reading.gyro) },
            noise: self.noise,
        }
    }
}

/// For [`Mpu6050::zip_state`]: lane `j` of the other copy, the rest kept.
#[cfg(feature = "std")] // the lanes' (`Wide`)
#[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
pub(crate) fn lane_from<const N: usize>(j: usize) -> impl Fn(crate::model::lane::Wide<N>, crate::model::lane::Wide<N>) -> crate::model::lane::Wide<N> + Copy {
    move |mine, theirs| {
        let mut v = mine;
        v.0[j] = theirs.0[j];
        v
    }
}

// Alike IMUs (settle side by side) on lanes.
#[cfg(feature = "std")]
impl Mpu6050<f64> {
    /// Whether this IMU and `other` run on lanes as one: the same settings and priming, and
    /// their normals drawn ahead at the same place (their states may differ).
    pub(crate) fn alike(&self, other: &Self) -> bool {
        self.settings == other.settings && self.primed == other.primed && self.noise.used == other.noise.used
    }

    /// The [`Self::alike`] `imus` as one IMU on lanes, lane `j`'s state `imus[j]`'s; each
    /// lane's noise is drawn apart (`NoiseLanes`).
    pub(crate) fn lanes<const N: usize>(imus: &[&Self; N]) -> Mpu6050<crate::model::lane::Wide<N>> {
        let mut out = imus[0].map(crate::model::lane::Wide::splat);
        for (j, imu) in imus.iter().enumerate().skip(1) {
            out.zip_state(&imu.map(crate::model::lane::Wide::splat), lane_from(j));
        }
        out
    }
}

// A lane's state taken from another copy (an env's robot started anew, or a lane that did
// not sample): the filters, the bias and the registers; the settings are every lane's alike.
#[cfg_attr(not(feature = "std"), allow(dead_code))] // the lanes use it
impl<S: Lane> Mpu6050<S> {
    /// Each state set to `f(its own, the same state of `other`)`.
    pub(crate) fn zip_state(&mut self, other: &Self, f: impl Fn(S, S) -> S + Copy) {
        self.gyro_filter.zip_state(&other.gyro_filter, f);
        self.accel_x_filter.zip_state(&other.accel_x_filter, f);
        self.accel_z_filter.zip_state(&other.accel_z_filter, f);
        self.bias = f(self.bias, other.bias);
        let (r, o) = (self.reading, other.reading);
        self.reading = ImuReading { accel_x: f(r.accel_x, o.accel_x), accel_z: f(r.accel_z, o.accel_z), gyro: f(r.gyro, o.gyro) };
    }

    /// As before the first sample: the next one starts the filters.
    #[cfg_attr(not(feature = "parallel"), allow(dead_code))] // the envs' (built with `parallel`)
    pub(crate) fn unprime(&mut self) {
        self.primed = false;
    }
}

// The converter, the filters and the registers, written once over `Lane` (plain arithmetic:
// a sweep's lanes give the run's bits); priming and quantising are every lane's alike.
impl<S: Lane> Mpu6050<S> {
    /// One sample of the specific force (`fx`, `fz`) and the rate, with the noise `n`
    /// ([`Mpu6050::draw`]). Always inlined: a sweep's lanes run it inside their block, whose
    /// copies for AVX would otherwise call a baseline build.
    #[inline(always)]
    pub(crate) fn sample_with(&mut self, fx: S, fz: S, rate: S, n: [S; 4]) {
        let s = &self.settings;
        let clean = [fx + s.accel_bias[0], fz + s.accel_bias[1]];
        let range = s.accel_range;
        let within = |v: S| saturate(v, range);
        if !self.primed {
            // The filters act on the converter's output, which never leaves the range.
            self.accel_x_filter.prime(within(clean[0]));
            self.accel_z_filter.prime(within(clean[1]));
        }
        let ax = self.accel_x_filter.filter(within(clean[0] + self.sigma_accel * n[1]));
        let az = self.accel_z_filter.filter(within(clean[1] + self.sigma_accel * n[2]));
        if s.quantise {
            let (a, a_inv) = (self.accel_lsb, self.accel_per_lsb);
            (self.reading.accel_x, self.reading.accel_z) = (register(ax, a, a_inv), register(az, a, a_inv));
        } else {
            (self.reading.accel_x, self.reading.accel_z) = (ax, az);
        }
        self.sample_gyro_with(rate, n);
    }

    /// The gyroscope's part of [`Self::sample_with`], alone for an IMU whose accelerometer
    /// nothing reads (the 3-DOF robot's yaw axis): it takes the same four normals, and its
    /// accelerometer's registers stay as they are.
    #[inline(always)]
    pub(crate) fn sample_gyro_with(&mut self, rate: S, n: [S; 4]) {
        let range = self.settings.gyro_range;
        let within = |v: S| saturate(v, range);
        let clean = rate + self.bias;
        if !self.primed {
            self.gyro_filter.prime(within(clean));
            self.primed = true;
        }
        let gyro = self.gyro_filter.filter(within(clean + self.sigma_gyro * n[0]));
        self.bias = self.bias + self.sigma_walk * n[3];
        self.reading.gyro = if self.settings.quantise { register(gyro, self.gyro_lsb, self.gyro_per_lsb) } else { gyro };
    }
}

/// `v` as a 16-bit two's-complement register of resolution `lsb` (`per_lsb` = 1/lsb),
/// back in units. Rounds to nearest, ties to even, by adding and removing 1.5/ε
/// (1.5 · 2^52 in f64; no libm call, and 32768 is far below 1/ε).
#[inline(always)]
fn register<S: Lane>(v: S, lsb: S, per_lsb: S) -> S {
    let magic = S::splat(1.5) / S::epsilon();
    let counts = clamp(v * per_lsb, S::splat(-32768.0), S::splat(32767.0));
    ((counts + magic) - magic) * lsb
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Steady lag of a ramp through the filter [s]: its DC group delay.
    fn ramp_lag(f: &mut Dlpf<f64>, period: f64) -> f64 {
        f.prime(0.0);
        let mut y = 0.0;
        let n = 20_000;
        for k in 0..n {
            y = f.filter(k as f64 * period);
        }
        (n - 1) as f64 * period - y
    }

    #[test]
    fn every_row_keeps_its_delay_and_bandwidth() {
        let period = 1e-3;
        for (cfg, row) in DLPF_TABLE.iter().enumerate() {
            for (channel, hz, delay) in [(Channel::Accel, row.accel_hz, row.accel_delay), (Channel::Gyro, row.gyro_hz, row.gyro_delay)] {
                let mut f = Dlpf::<f64>::mpu6050(cfg, channel, period).unwrap();
                let lag = ramp_lag(&mut f, period);
                assert!((lag - delay).abs() <= 1e-9, "cfg {cfg} {channel:?}: lag {lag} vs {delay}");
                if delay > 0.0 {
                    // |H| at the bandwidth is -3 dB (the all-pass and delay keep the gain).
                    let (b0, a1, a2) = (f.b0, f.a1, f.a2);
                    let w = core::f64::consts::TAU * hz * period;
                    let (cw, sw, c2, s2) = (w.cos(), w.sin(), (2.0 * w).cos(), (2.0 * w).sin());
                    let num = b0 * ((1.0 + 2.0 * cw + c2).powi(2) + (2.0 * sw + s2).powi(2)).sqrt();
                    let den = ((1.0 + a1 * cw + a2 * c2).powi(2) + (a1 * sw + a2 * s2).powi(2)).sqrt();
                    assert!((num / den - 0.5f64.sqrt()).abs() < 1e-9, "cfg {cfg} {channel:?}: gain {}", num / den);
                }
            }
        }
    }

    /// The bisection that stops once its midpoint rounds onto an end gives the damping that
    /// all 80 halvings give, bit for bit: every row and channel at several sample periods,
    /// in f64 and f32, and bandwidths over the range that bisects.
    #[test]
    fn the_bisection_that_stops_early_gives_the_80_halvings_bits() {
        fn halved_80<T: Real>(bandwidth: T, delay: T, period: T) -> T {
            let wb = T::two_pi() * bandwidth;
            let half = wb * period * c::<T>(0.5);
            let target = delay * wb / (half / half.tan());
            let (mut lo, mut hi) = (T::zero(), T::one() / c::<T>(2.0).sqrt());
            for _ in 0..80 {
                let mid = (lo + hi) * c::<T>(0.5);
                if c::<T>(2.0) * mid * bandwidth_ratio(mid) < target { lo = mid } else { hi = mid }
            }
            (lo + hi) * c::<T>(0.5)
        }
        let mut bisected = 0;
        for period in [1e-3, 5e-4, 2e-3, 1.0 / 1024.0, 1e-4] {
            // No Vec: the core's tests also run without alloc.
            let rows = DLPF_TABLE.iter().flat_map(|r| [(r.accel_hz, r.accel_delay), (r.gyro_hz, r.gyro_delay)]);
            for (hz, delay) in rows.chain((1..40).map(|k| (10.0 * k as f64, 0.3 / (10.0 * k as f64)))) {
                let Ok(f) = Dlpf::<f64>::new(hz, delay, period) else { continue };
                if f.pure_delay() == 0.0 && delay > 0.0 {
                    bisected += 1;
                    assert_eq!(f.zeta().to_bits(), halved_80(hz, delay, period).to_bits(), "f64 {hz} Hz {delay} s at {period} s");
                }
                let Ok(f) = Dlpf::<f32>::new(hz as f32, delay as f32, period as f32) else { continue };
                if f.pure_delay() == 0.0 && delay > 0.0 {
                    assert_eq!(f.zeta().to_bits(), halved_80(hz as f32, delay as f32, period as f32).to_bits(), "f32 {hz} Hz {delay} s at {period} s");
                }
            }
        }
        assert!(bisected > 20, "only {bisected} designs bisected");
    }

    #[test]
    fn primed_filter_holds_a_constant() {
        let mut f = Dlpf::<f64>::mpu6050(1, Channel::Gyro, 1e-3).unwrap();
        f.prime(2.5);
        for _ in 0..10 {
            assert!((f.filter(2.5) - 2.5).abs() < 1e-12);
        }
    }

    #[test]
    fn static_tilt_reads_gravity_in_body_axes() {
        let x = nalgebra::Vector4::new(0.2, 0.0, 0.0, 0.0);
        let (fx, fz) = specific_force(&x, &nalgebra::Vector4::zeros(), 0.3f64.sin(), 0.3f64.cos(), 0.033, 0.12, 9.81);
        assert!((fx + 9.81 * 0.2f64.sin()).abs() < 1e-12 && (fz - 9.81 * 0.2f64.cos()).abs() < 1e-12);
    }

    #[test]
    fn registers_quantise_and_saturate() {
        let mut s = ImuSettings::<f64>::data_sheet();
        s.gyro_noise = 0.0;
        s.accel_noise = 0.0;
        let mut imu = Mpu6050::new(&s).unwrap();
        let mut rng = Sfc64::new(0, 0);
        imu.sample(0.0, 9.81, 10.0, &mut rng);
        let r = imu.reading();
        assert_eq!(r.gyro, 32767.0 * s.gyro_range / 32768.0, "saturated");
        let lsb = s.accel_range / 32768.0;
        assert_eq!(r.accel_z, (9.81 / lsb).round() * lsb);
        assert_eq!(register(2.5, 1.0, 1.0), 2.0, "ties to even");
        assert_eq!(register(-7.6, 1.0, 1.0), -8.0);
        // A NaN reads NaN, not a full-scale register that would hide it.
        assert!(register(f64::NAN, 1.0, 1.0).is_nan());
        let mut imu = Mpu6050::new(&s).unwrap();
        imu.sample(f64::NAN, 9.81, f64::NAN, &mut rng);
        assert!(imu.reading().gyro.is_nan() && imu.reading().accel_x.is_nan(), "{:?}", imu.reading());
        assert!(ImuSettings { gyro_range: 1.0, ..s }.validate().is_err());
        // A sample rate the DLPF cannot run at is refused here, not at the first run (where
        // its error named a bandwidth): 44 Hz needs more than 88 samples a second.
        let slow = ImuSettings { sample_period: 1.0 / 88.0, ..s }.validate();
        assert!(matches!(slow, Err(TwipError::InvalidParameter { name: "sample_period", .. })), "{slow:?}");
        assert!(ImuSettings { sample_period: 1.0 / 89.0, ..s }.validate().is_ok());
        assert!(ImuSettings { sample_period: 1.0 / 89.0, dlpf: 0, ..s }.validate().is_err(), "256 Hz gyro");
        assert!(dlpf_config(42.0) == Ok(3) && dlpf_config(44.0) == Ok(3) && dlpf_config(7.0).is_err());
    }

    /// Unquantised, a rate beyond the full scale from the very first sample still reads
    /// at most the full scale: the filters start from the clamped value.
    #[test]
    fn the_first_readings_stay_in_range() {
        let mut s = ImuSettings::<f64>::data_sheet();
        s.gyro_noise = 0.0;
        s.quantise = false;
        let mut imu = Mpu6050::new(&s).unwrap();
        let mut rng = Sfc64::new(0, 0);
        for _ in 0..5 {
            imu.sample(0.0, 9.81, 10.0 * s.gyro_range, &mut rng);
            assert!(imu.reading().gyro <= s.gyro_range, "{} > {}", imu.reading().gyro, s.gyro_range);
        }
    }
}
