//! The sliding-mode tracker's fuzzy grids through the C ABI: the configuration carries n × n
//! grids of any set kind (round trip from the core's f64 tracker), the C update answers what
//! the core's f32 tracker answers, bad grids are refused, and a configuration of another
//! ABI version is refused before its fields are read.
use twip_core::control::fuzzy_basis::Membership;
use twip_core::control::fuzzy_grid::{FuzzyGrid, SetKind};
use twip_core::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
use twip_core::control::trajectory::PlanarRef;
use twip_core::control::Controller;
use twip_core::hardware::motor::DcMotor;
use twip_core::{PlanarModel, RobotParams, TwipError};
use twip_ffi::*;

const PERIOD: f64 = 0.005;

/// circle-smc-fuzzy's tracker (the thesis's gains, the GB37's limits, adapting), with the
/// thesis's 3 × 3 bases.
fn thesis_tracker() -> SmcTracker<f64> {
    let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
    let gb37 = DcMotor::gb37y3530();
    let gains = SmcGains::thesis(gb37.torque_per_count());
    SmcTracker::new(gains, SmcOptions::default(), model, Some(gb37), Some(Adaptation::default()), PERIOD).unwrap()
}

/// The fuzzy-sets study's 5 × 5 Gaussian grids (docs/fuzzy_sets.md): yaw over (φ, ω),
/// pitch over (φ, φ̇), σ half the spacing.
fn gaussian_5x5() -> SmcTracker<f64> {
    let phi = [-0.3, -0.15, 0.0, 0.15, 0.3];
    let omega = [-1.0, -0.5, 0.0, 0.5, 1.0];
    let rate = [-2.0, -1.0, 0.0, 1.0, 2.0];
    let yaw = FuzzyGrid::regular(SetKind::Gaussian, [&phi, &omega], [&[0.075; 5], &[0.25; 5]]).unwrap();
    let pitch = FuzzyGrid::regular(SetKind::Gaussian, [&phi, &rate], [&[0.075; 5], &[0.5; 5]]).unwrap();
    thesis_tracker().with_bases(yaw, pitch).unwrap()
}

fn triangles_7x7() -> SmcTracker<f64> {
    let phi = [-0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45];
    let omega = [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5];
    let yaw = FuzzyGrid::regular(SetKind::Triangle, [&phi, &omega], [&[], &[]]).unwrap();
    let pitch = FuzzyGrid::regular(SetKind::Triangle, [&phi, &omega.map(|w| 2.0 * w)], [&[], &[]]).unwrap();
    thesis_tracker().with_bases(yaw, pitch).unwrap()
}

fn new_smc() -> TwipSmc {
    TwipSmc { words: [0; TWIP_SMC_WORDS] }
}

/// The f64 sets as the f32 configuration holds them.
fn narrowed(sets: [&[Membership<f64>]; 2]) -> Vec<Vec<Membership<f32>>> {
    let f = |v: f64| v as f32;
    sets.iter()
        .map(|row| {
            row.iter()
                .map(|m| match *m {
                    Membership::Trapezoid { a, b, c, d } => Membership::Trapezoid { a: f(a), b: f(b), c: f(c), d: f(d) },
                    Membership::Gaussian { mean, sigma } => Membership::Gaussian { mean: f(mean), sigma: f(sigma) },
                })
                .collect()
        })
        .collect()
}

#[test]
fn the_grids_round_trip_through_the_configuration() {
    for (tracker, n) in [(thesis_tracker(), 3), (gaussian_5x5(), 5), (triangles_7x7(), 7)] {
        let config = TwipSmcConfig::from_core(&tracker).unwrap();
        assert_eq!((config.abi_version, config.n_sets), (TwipAbiVersion(TWIP_ABI_VERSION), n));
        let built = config.build().unwrap();
        let (yaw, pitch) = built.bases();
        let (yaw64, pitch64) = tracker.bases();
        assert_eq!(yaw.n(), n as usize);
        let rows = |sets: [&[Membership<f32>]; 2]| sets.map(<[_]>::to_vec).to_vec();
        assert_eq!(rows(yaw.sets()), narrowed(yaw64.sets()), "{n} x {n} yaw sets");
        assert_eq!(rows(pitch.sets()), narrowed(pitch64.sets()), "{n} x {n} pitch sets");
        assert_eq!(built.weights().0.len(), n as usize * n as usize);
        // The slots past n are left zero: nothing of another grid is carried.
        assert!(config.yaw_sets.iter().all(|row| row[n as usize..].iter().all(|m| *m == TwipMembership::default())));
    }
    assert_eq!(TwipSmcConfig::from_core(&gaussian_5x5()).unwrap().yaw_sets[1][4].kind, 1, "a Gaussian's kind");
}

/// Measurements that keep both surfaces busy (the weights adapt) along a turning reference.
fn drive(k: usize) -> ([f32; 7], TwipPlanarRef) {
    let t = k as f32 * PERIOD as f32;
    let y = [0.3 * t, 0.05 * t * t, 0.2 * t, 0.04 * (3.0 * t).sin(), 0.3 * (3.0 * t).cos(), 0.25, 0.4];
    (y, TwipPlanarRef { x: 0.35 * t, y: 0.0, psi: 0.5 * t, v: 0.3, omega: 0.5, v_dot: 0.0, omega_dot: 0.0 })
}

#[test]
fn the_c_update_answers_what_the_core_tracker_answers_with_every_grid() {
    for tracker in [thesis_tracker(), gaussian_5x5(), triangles_7x7()] {
        let config = TwipSmcConfig::from_core(&tracker).unwrap();
        let mut core = config.build().unwrap();
        let mut state = new_smc();
        assert_eq!(unsafe { twip_smc_init(&mut state, &config) }, TWIP_OK);
        for k in 0..400 {
            let (y, r) = drive(k);
            let mut u = [f32::NAN; 2];
            let t = k as f32 * PERIOD as f32;
            assert_eq!(unsafe { twip_smc_update(&mut state, t, y.as_ptr(), &r, u.as_mut_ptr()) }, TWIP_OK);
            let core_ref = PlanarRef { x: r.x, y: r.y, psi: r.psi, v: r.v, omega: r.omega, v_dot: r.v_dot, omega_dot: r.omega_dot };
            let expected = core.update(t, &y.into(), &core_ref);
            assert_eq!(u, [expected[0], expected[1]], "update {k} with {} sets", config.n_sets);
        }
        assert!(core.weights().1.iter().any(|w| *w != 0.0), "the pitch weights adapted");
    }
}

#[test]
fn the_grids_change_the_commands() {
    // The sets are read: the 5 x 5 Gaussian tracker answers otherwise than the thesis's.
    let answers = |tracker: SmcTracker<f64>| {
        let mut c = TwipSmcConfig::from_core(&tracker).unwrap().build().unwrap();
        (0..200).map(|k| {
            let (y, r) = drive(k);
            let r = PlanarRef { x: r.x, y: r.y, psi: r.psi, v: r.v, omega: r.omega, v_dot: r.v_dot, omega_dot: r.omega_dot };
            c.update(k as f32 * PERIOD as f32, &y.into(), &r)
        }).last().unwrap()
    };
    assert_ne!(answers(thesis_tracker()), answers(gaussian_5x5()));
}

#[test]
fn bad_grids_are_refused_and_leave_the_state_uninitialised() {
    let good = TwipSmcConfig::from_core(&gaussian_5x5()).unwrap();
    let mut bad_kind = good;
    bad_kind.pitch_sets[1][3].kind = 2;
    let mut bad_sigma = good;
    bad_sigma.yaw_sets[0][0].p[1] = -0.1;
    let mut nan_centre = good;
    nan_centre.yaw_sets[1][2].p[0] = f32::NAN;
    let mut state = new_smc();
    for (bad, name) in [
        (TwipSmcConfig { n_sets: 1, ..good }, "n_sets"),
        (TwipSmcConfig { n_sets: 8, ..good }, "n_sets"),
        (TwipSmcConfig { n_sets: -3, ..good }, "n_sets"),
        (bad_kind, "pitch_sets[1][3]"),
        (bad_sigma, "yaw_sets[0][0]"),
        (nan_centre, "yaw_sets[1][2]"),
    ] {
        match bad.build() {
            Err(TwipError::InvalidParameter { name: got, .. }) => assert_eq!(got, name),
            other => panic!("{name}: {other:?}"),
        }
        assert_eq!(unsafe { twip_smc_init(&mut state, &good) }, TWIP_OK);
        assert_eq!(unsafe { twip_smc_init(&mut state, &bad) }, TWIP_ERR_INVALID, "{name}");
        assert_eq!(unsafe { twip_smc_reset(&mut state) }, TWIP_ERR_NOT_INITIALISED);
    }
    // n = 3 reads only the first three sets of each row: the 5 x 5 grid's first three
    // Gaussians are a valid 3 x 3 grid.
    assert_eq!(TwipSmcConfig { n_sets: 3, ..good }.build().unwrap().bases().0.n(), 3);
}

#[test]
fn an_f64_set_that_f32_cannot_hold_is_named_at_export() {
    let phi = [-0.3, 0.0, 0.3];
    let tiny = FuzzyGrid::regular(SetKind::Gaussian, [&phi, &phi], [&[0.1; 3], &[0.1, 1e-50, 0.1]]).unwrap();
    let err = TwipSmcConfig::from_core(&thesis_tracker().with_bases(tiny, tiny).unwrap()).unwrap_err().to_string();
    assert!(err.starts_with("invalid yaw_sets[1][1] = 1e-50: does not fit in f32"), "{err}");
}

#[test]
fn a_configuration_of_another_abi_version_is_refused_before_it_is_read() {
    let good = TwipSmcConfig::from_core(&thesis_tracker()).unwrap();
    let mut state = new_smc();
    assert_eq!(twip_abi_version(), TWIP_ABI_VERSION);
    for version in [0, 1, TWIP_ABI_VERSION + 1] {
        assert_eq!(unsafe { twip_smc_init(&mut state, &good) }, TWIP_OK);
        let stale = TwipSmcConfig { abi_version: TwipAbiVersion(version), ..good };
        assert_eq!(unsafe { twip_smc_init(&mut state, &stale) }, TWIP_ERR_ABI, "version {version}");
        assert_eq!(unsafe { twip_smc_reset(&mut state) }, TWIP_ERR_NOT_INITIALISED);
    }
    // A version-1 firmware's configuration began with the robot's mass (1.13 kg as f32 bits)
    // and was shorter than today's: only its first word is read.
    let v1 = [good.robot.m_body.to_bits() as i32];
    let status = unsafe { twip_smc_init(&mut state, v1.as_ptr().cast::<TwipSmcConfig>()) };
    assert_eq!(status, TWIP_ERR_ABI);
    let text = unsafe { core::ffi::CStr::from_ptr(twip_status_text(TWIP_ERR_ABI)) }.to_str().unwrap();
    assert!(text.contains("another version of the C ABI"), "{text}");
    // Every controller family checks it.
    let mut lqr = TwipLqr { words: [0; TWIP_LQR_WORDS] };
    let lqr_config = TwipLqrConfig { abi_version: TwipAbiVersion(1), ..Default::default() };
    assert_eq!(unsafe { twip_lqr_init(&mut lqr, &lqr_config) }, TWIP_ERR_ABI);
    let mut fuzzy = TwipFuzzy { words: [0; TWIP_FUZZY_WORDS] };
    let fuzzy_config = TwipFuzzyConfig { abi_version: TwipAbiVersion(1), ..Default::default() };
    assert_eq!(unsafe { twip_fuzzy_init(&mut fuzzy, &fuzzy_config) }, TWIP_ERR_ABI);
    let mut pid = TwipPid { words: [0; TWIP_PID_WORDS] };
    let pid_config = TwipPidConfig { abi_version: TwipAbiVersion(1), ..Default::default() };
    assert_eq!(unsafe { twip_pid_init(&mut pid, &pid_config) }, TWIP_ERR_ABI);
}
