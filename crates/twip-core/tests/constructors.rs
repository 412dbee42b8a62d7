//! Property tests over the core's public constructors: whatever numbers they are given
//! (NaN, infinities, zero, negative, huge, tiny), they return `Ok` or a `TwipError` that
//! names a parameter; they never panic, and what they accept steps to finite numbers.
use nalgebra::{DMatrix, SVector};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use twip_core::control::fuzzy::{Adaptation, FuzzyController, FuzzyGains};
use twip_core::control::fuzzy_basis::ThesisBasis;
use twip_core::control::lqr::{DesignPoint, LqrController};
use twip_core::control::pid::{PidGains, PidTracker, PidUnits};
use twip_core::control::reference::{Leg, SpeedSchedule};
use twip_core::control::smc::{SmcGains, SmcOptions, SmcTracker};
use twip_core::control::trajectory::{Circle, Direction, FigureEight, Line, Waypoints};
use twip_core::hardware::encoder::Encoder;
use twip_core::hardware::imu::Dlpf;
use twip_core::hardware::motor::DcMotor;
use twip_core::hardware::tilt::{TiltEstimator, TiltFilter};
use twip_core::model::params::FIELD_NAMES;
use twip_core::model::dynamics::Dynamics;
use twip_core::{care, PlanarModel, RobotParams, SlopeModel, TwipError};

/// Any double, weighted towards the values that break code: NaN, ±inf, 0, -0, tiny,
/// huge, negative, and plausible robot sizes.
fn wild() -> impl Strategy<Value = f64> {
    prop_oneof![
        3 => proptest::num::f64::ANY,
        2 => Just(f64::NAN),
        1 => Just(f64::INFINITY),
        1 => Just(f64::NEG_INFINITY),
        1 => Just(0.0),
        1 => Just(-0.0),
        1 => Just(1e-300),
        1 => Just(1e300),
        4 => -10.0..10.0f64,
        4 => 1e-3..1.0f64,
    ]
}

/// The Balanbot with up to three fields replaced by wild values.
fn robot() -> impl Strategy<Value = RobotParams<f64>> {
    proptest::collection::vec((0..FIELD_NAMES.len(), wild()), 0..4).prop_map(|changes| {
        let mut fields = RobotParams::<f64>::balanbot().to_array();
        for (i, v) in changes {
            fields[i] = v;
        }
        RobotParams::from_array(&fields)
    })
}

fn seed() -> RngSeed {
    std::env::var("PROPTEST_RNG_SEED").ok().and_then(|s| s.parse().ok()).unwrap_or(RngSeed::Fixed(20261124))
}

/// A named error: the variants that carry a parameter name give a non-empty one.
fn named(e: &TwipError) -> bool {
    match e {
        TwipError::InvalidParameter { name, .. } | TwipError::Shape { name, .. } | TwipError::NonFinite { name, .. } => {
            !name.is_empty()
        }
        _ => !e.to_string().is_empty(),
    }
}

proptest! {
    // A fixed seed: CI reruns the same 2000 cases (a random one found i_motor = 1.8e38 only
    // on some runs); PROPTEST_RNG_SEED=random explores new ones.
    #![proptest_config(ProptestConfig { cases: 2000, rng_seed: seed(), ..ProptestConfig::default() })]

    #[test]
    fn slope_model(params in robot(), slope in wild()) {
        match SlopeModel::new(params, slope) {
            Ok(model) => {
                // The model computes; whether RK4 is stable at a given dt is the runner's to
                // report (Outcome::Diverged: a friction of 1e38 is stiff at any step).
                let x = model.deriv(&SVector::<f64, 4>::new(0.01, 0.0, 0.0, 0.0), &SVector::<f64, 1>::new(0.0));
                prop_assert!(x.iter().all(|v| v.is_finite()), "{params:?} slope {slope}: {x}");
            }
            Err(e) => prop_assert!(named(&e), "{e:?}"),
        }
    }

    #[test]
    fn planar_model(params in robot()) {
        match PlanarModel::new(params) {
            Ok(model) => {
                let x0 = SVector::<f64, 7>::from_column_slice(&[0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0]);
                let x = model.deriv(&x0, &SVector::<f64, 2>::zeros());
                prop_assert!(x.iter().all(|v| v.is_finite()), "{params:?}: {x}");
            }
            Err(e) => prop_assert!(named(&e), "{e:?}"),
        }
    }

    #[test]
    fn lqr_controller(k in proptest::array::uniform4(wild()), period in wild()) {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.0).unwrap();
        if let Err(e) = LqrController::new(k, model, DesignPoint::OperatingPoint, period) {
            prop_assert!(named(&e), "{e:?}");
        }
    }

    #[test]
    fn fuzzy_controller(g in proptest::array::uniform5(wild()), gamma in wild(), sigma in wild(), period in wild()) {
        let model = SlopeModel::new(RobotParams::balanbot(), 0.1).unwrap();
        let gains = FuzzyGains { k1: g[0], k2: g[1], kp: g[2], kd: g[3], ki: g[4] };
        let adaptation = Adaptation { gamma, sigma, enabled: true };
        if let Err(e) = FuzzyController::new(model, gains, adaptation, ThesisBasis::thesis(), period) {
            prop_assert!(named(&e), "{e:?}");
        }
    }

    #[test]
    fn pid_tracker(g in proptest::array::uniform7(wild()), period in wild(), params in robot()) {
        let gains = PidGains { kp_pitch: g[0], kd_pitch: g[1], kp_speed: g[2], ki_speed: g[3], kp_yaw: g[4], ki_yaw: g[5], kd_yaw: g[6] };
        let units = PidUnits::arduino(params.wheel_radius, period);
        if let Err(e) = PidTracker::new(gains, units, DcMotor::gb37y3530(), &params, period) {
            prop_assert!(named(&e), "{e:?}");
        }
    }

    #[test]
    fn smc_tracker(unit in wild(), k1 in wild(), r1 in wild(), period in wild(), params in robot()) {
        let mut gains = SmcGains::thesis(if unit.is_finite() { unit } else { 1.0 });
        gains.k1 = k1;
        gains.r1 = r1;
        if let Ok(model) = PlanarModel::new(params) {
            if let Err(e) = SmcTracker::new(gains, SmcOptions::default(), model, None, None, period) {
                prop_assert!(named(&e), "{e:?}");
            }
        }
    }

    #[test]
    fn trajectories(a in wild(), b in wild(), c in wild(), d in wild()) {
        let results = [
            Circle::new([a, b], c, d, Direction::CounterClockwise, 0.0).err(),
            Line::new([a, b], c, d).err(),
            FigureEight::new([a, b], c, d).err(),
            Waypoints::new(&[[0.0, 0.0], [a, b], [c, d]], 0.2, 0.1).err(),
            SpeedSchedule::new(&[Leg { goal: a, speed: b, hold: c }]).err(),
        ];
        for e in results.iter().flatten() {
            prop_assert!(named(e), "{e:?}");
        }
    }

    #[test]
    fn sensors_and_motor(a in wild(), b in wild(), c in wild()) {
        let results = [
            Encoder::new(a).err(),
            Dlpf::new(a, b, c).err(),
            TiltFilter::new(TiltEstimator::Complementary { time_constant: a }).err(),
            TiltFilter::new(TiltEstimator::Kalman { q_angle: a, q_bias: b, r_angle: c }).err(),
            DcMotor::new(a, b, c, 0.0, 12.0, 255.0).err(),
        ];
        for e in results.iter().flatten() {
            prop_assert!(named(e), "{e:?}");
        }
    }

    #[test]
    fn care_on_wild_matrices(n in 1usize..5, m in 1usize..3, entries in proptest::collection::vec(wild(), 64)) {
        let take = |rows, cols, at: usize| DMatrix::from_fn(rows, cols, |i, j| entries[(at + i * cols + j) % entries.len()]);
        let a = take(n, n, 0);
        let b = take(n, m, 17);
        let q = { let q = take(n, n, 29); &q + q.transpose() };
        let r = { let r = take(m, m, 41); &r * r.transpose() + DMatrix::identity(m, m) };
        match care(&a, &b, &q, &r) {
            Ok(x) => prop_assert!(x.iter().all(|v| v.is_finite())),
            Err(e) => prop_assert!(named(&e), "{e:?}"),
        }
    }
}
