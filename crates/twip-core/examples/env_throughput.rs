//! Env-steps per CPU second of the envs' robots through the thesis-like rig (or the ideal
//! plant), zero actions, a fallen robot started anew at the next step as Gymnasium's
//! NEXT_STEP autoreset does; small enough to run under an instruction counter:
//!   cargo run --release --features parallel --example env_throughput -- balance-rig 4096 200 1
//! (kinds: balance-rig, balance-ideal, track-rig, track-ideal; then N, steps, threads).
use std::sync::Arc;

use nalgebra::Vector4;
use twip_core::control::trajectory::{Circle, Direction, Trajectory};
use twip_core::envs::{BalanceEnvs, BalanceSpec, RealismFor, TrackEnvs, TrackSpec};
use twip_core::hardware::realism::Realism;
use twip_core::model::planar::PlanarState;
use twip_core::sweep::planar::PlanarNominal;
use twip_core::sweep::{Nominal, Perturbation, Spread, Target};
use twip_core::RobotParams;

fn cpu_seconds() -> f64 {
    // /proc/self/stat fields 14 and 15: user and system time in clock ticks (100 Hz).
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |i: usize| fields.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
}

/// Steps `envs` `steps` times under zero actions, starting anew the lanes that fell.
macro_rules! run {
    ($envs:expr, $nu:expr, $n:expr, $steps:expr) => {{
        let mut envs = $envs;
        let lanes: Vec<usize> = (0..$n).collect();
        let seeds: Vec<u64> = (0..$n as u64).collect();
        envs.reset_many(&lanes, Some(&seeds)).unwrap();
        let actions = vec![0.0; $nu * $n];
        let mut fell = vec![false; $n];
        let mut resets = 0;
        for _ in 0..$steps {
            let again: Vec<usize> = (0..$n).filter(|&l| fell[l]).collect();
            resets += again.len();
            envs.reset_many(&again, None).unwrap();
            envs.step(&actions, &mut fell).unwrap();
        }
        (envs.state(0)[0], resets)
    }};
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("balance-rig");
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(4096);
    let steps: usize = args.get(3).and_then(|s| s.parse().ok()).unwrap_or(200);
    let threads: usize = args.get(4).and_then(|s| s.parse().ok()).unwrap_or(1);
    let rig: RealismFor = Arc::new(|_: &RobotParams<f64>| Ok(Realism::thesis_like()));
    let realism = which.ends_with("-rig").then_some(rig);
    let params = RobotParams::balanbot();
    // As the envs' default: φ0 uniform in ±0.1 rad.
    let spread = |entry| vec![Perturbation { target: Target::Initial(entry), spread: Spread::Uniform { low: -0.1, high: 0.1 } }];
    let start = cpu_seconds();
    let (check, resets) = if which.starts_with("balance") {
        let spec = BalanceSpec {
            nominal: Nominal { params, slope: 0.0, x0: Vector4::zeros() },
            perturbations: spread(0),
            realism,
            dt: 1e-3,
            substeps: 5,
            fall_limit: 0.5,
        };
        run!(BalanceEnvs::new(spec, n, threads).unwrap(), 1, n, steps)
    } else {
        let spec = TrackSpec {
            nominal: PlanarNominal { params, x0: PlanarState::zeros() },
            perturbations: spread(3),
            realism,
            path: Trajectory::Circle(Circle::from_origin(0.6, 0.2, Direction::CounterClockwise).unwrap()),
            dt: 1e-3,
            substeps: 5,
            fall_limit: 0.5,
        };
        run!(TrackEnvs::new(spec, n, threads).unwrap(), 2, n, steps)
    };
    let secs = cpu_seconds() - start;
    println!("{which}: {:.3} M env-steps per CPU second ({n} robots, {steps} steps, {threads} threads, {resets} restarts, check {check:.6e})", (n * steps) as f64 / secs / 1e6);
}
