//! What a richer fuzzy grid costs the sliding-mode tracker per update, through the C ABI and
//! in the core's f32 tracker beside it: the thesis's 3 × 3 trapezoids, the fuzzy-sets study's
//! 5 × 5 Gaussians (docs/fuzzy_sets.md) and 7 × 7 triangles, side by side in one run.
//! Run: cargo bench -p twip-benches --bench smc_grids [-- rounds]
//!
//! Each round replays the same 2000 updates (a circle's reference, measurements wandering
//! about it so that every set fires) from a reset state, once per grid in a rotating order,
//! timed by the thread's CPU clock (a busy machine's other processes are not counted). The
//! medians over the rounds and their ratios to the 3 × 3 grid are printed.
use std::hint::black_box;

use twip_core::control::fuzzy_grid::{FuzzyGrid, SetKind};
use twip_core::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
use twip_core::control::trajectory::{Circle, Direction, PlanarRef};
use twip_core::control::{Controller, Reference};
use twip_core::hardware::motor::DcMotor;
use twip_core::{PlanarModel, RobotParams};
use twip_ffi::*;

const PERIOD: f32 = 0.005;
const UPDATES: usize = 2000;

fn thesis() -> SmcTracker<f64> {
    let model = PlanarModel::new(RobotParams::balanbot()).unwrap();
    let motor = DcMotor::gb37y3530();
    let gains = SmcGains::thesis(motor.torque_per_count());
    SmcTracker::new(gains, SmcOptions::default(), model, Some(motor), Some(Adaptation::default()), PERIOD as f64).unwrap()
}

fn grids() -> Vec<(&'static str, SmcTracker<f64>)> {
    let (phi5, omega5, rate5) = ([-0.3, -0.15, 0.0, 0.15, 0.3], [-1.0, -0.5, 0.0, 0.5, 1.0], [-2.0, -1.0, 0.0, 1.0, 2.0]);
    let yaw5 = FuzzyGrid::regular(SetKind::Gaussian, [&phi5, &omega5], [&[0.075; 5], &[0.25; 5]]).unwrap();
    let pitch5 = FuzzyGrid::regular(SetKind::Gaussian, [&phi5, &rate5], [&[0.075; 5], &[0.5; 5]]).unwrap();
    let phi7 = [-0.45, -0.3, -0.15, 0.0, 0.15, 0.3, 0.45];
    let omega7 = [-1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5];
    let yaw7 = FuzzyGrid::regular(SetKind::Triangle, [&phi7, &omega7], [&[], &[]]).unwrap();
    let pitch7 = FuzzyGrid::regular(SetKind::Triangle, [&phi7, &omega7.map(|w| 2.0 * w)], [&[], &[]]).unwrap();
    vec![
        ("3 x 3 trapezoids (thesis)", thesis()),
        ("5 x 5 Gaussians", thesis().with_bases(yaw5, pitch5).unwrap()),
        ("7 x 7 triangles", thesis().with_bases(yaw7, pitch7).unwrap()),
    ]
}

/// The updates every round replays: (t, y, the C reference, the core's).
fn drive() -> Vec<(f32, [f32; 7], TwipPlanarRef, PlanarRef<f32>)> {
    let circle = Circle::from_origin(0.45f32, core::f32::consts::PI / 30.0, Direction::CounterClockwise).unwrap();
    (0..UPDATES)
        .map(|k| {
            let t = k as f32 * PERIOD;
            let r = circle.sample(t);
            let wobble = (7.0 * t).sin();
            let y = [r.x + 0.01 * wobble, r.y, r.psi + 0.05 * wobble, 0.3 * wobble, 2.5 * (7.0 * t).cos(), r.v, r.omega + 0.8 * wobble];
            let c = TwipPlanarRef { x: r.x, y: r.y, psi: r.psi, v: r.v, omega: r.omega, v_dot: r.v_dot, omega_dot: r.omega_dot };
            (t, y, c, r)
        })
        .collect()
}

/// The thread's CPU time [ns].
fn cpu_ns() -> u64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: a valid timespec to write.
    let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    assert_eq!(status, 0, "the thread CPU clock is not available");
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let rounds: usize = std::env::args().skip(1).find_map(|a| a.parse().ok()).unwrap_or(31);
    let drive = drive();
    let grids = grids();
    let configs: Vec<TwipSmcConfig> = grids.iter().map(|(_, t)| TwipSmcConfig::from_core(t).unwrap()).collect();
    let mut states: Vec<TwipSmc> = configs
        .iter()
        .map(|c| {
            let mut s = TwipSmc { words: [0; TWIP_SMC_WORDS] };
            assert_eq!(unsafe { twip_smc_init(&mut s, c) }, TWIP_OK);
            s
        })
        .collect();
    let mut cores: Vec<SmcTracker<f32>> = configs.iter().map(|c| c.build().unwrap()).collect();
    // Per grid: ns per update of each round, through the C ABI and in the core.
    let (mut abi, mut core) = (vec![Vec::new(); grids.len()], vec![Vec::new(); grids.len()]);
    for round in 0..rounds {
        for i in (0..grids.len()).map(|i| (i + round) % grids.len()) {
            let state = &mut states[i];
            assert_eq!(unsafe { twip_smc_reset(state) }, TWIP_OK);
            let mut u = [0.0f32; 2];
            let start = cpu_ns();
            for (t, y, c, _) in &drive {
                let status = unsafe { twip_smc_update(state, *t, black_box(y.as_ptr()), black_box(c), u.as_mut_ptr()) };
                assert_eq!(status, TWIP_OK);
            }
            abi[i].push((cpu_ns() - start) as f64 / UPDATES as f64);
            black_box(u);
            let tracker = &mut cores[i];
            tracker.reset();
            let start = cpu_ns();
            for (t, y, _, r) in &drive {
                black_box(tracker.update(*t, &black_box(*y).into(), black_box(r)));
            }
            core[i].push((cpu_ns() - start) as f64 / UPDATES as f64);
        }
    }
    let (abi, core): (Vec<f64>, Vec<f64>) = (abi.into_iter().map(median).collect(), core.into_iter().map(median).collect());
    println!("{rounds} rounds of {UPDATES} updates per grid; medians of the thread's CPU time per update");
    println!("{:<28} {:>12} {:>10} {:>12} {:>10}", "grids", "C ABI [ns]", "ratio", "core [ns]", "ratio");
    for (i, (name, _)) in grids.iter().enumerate() {
        println!("{name:<28} {:>12.1} {:>10.2} {:>12.1} {:>10.2}", abi[i], abi[i] / abi[0], core[i], core[i] / core[0]);
    }
}
