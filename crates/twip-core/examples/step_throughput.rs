//! ns per RK4 step of each model, timed by CPU time (robust on a busy machine):
//!   cargo run --release --example step_throughput -- slope64 10000000
use std::hint::black_box;

use nalgebra::{SVector, Vector4};
use twip_core::{rk4_step, PlanarModel, RobotParams, SlopeModel};

fn cpu_seconds() -> f64 {
    // /proc/self/stat fields 14 and 15: user and system time in clock ticks (100 Hz).
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks: f64 = fields.get(11).and_then(|v| v.parse().ok()).unwrap_or(0.0);
    ticks / 100.0
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let which = args.get(1).map(String::as_str).unwrap_or("slope64");
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10_000_000);
    let start = cpu_seconds();
    let check = match which {
        "slope64" => {
            let m = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.1).unwrap();
            let mut x = Vector4::new(0.1, 0.0, 0.0, 1.0);
            let u = SVector::<f64, 1>::new(0.05);
            for _ in 0..n {
                x = rk4_step(black_box(&m), &x, &u, 1e-6);
            }
            x[0]
        }
        "slope32" => {
            let m = SlopeModel::<f32>::new(RobotParams::balanbot(), 0.1).unwrap();
            let mut x = Vector4::new(0.1f32, 0.0, 0.0, 1.0);
            let u = SVector::<f32, 1>::new(0.05);
            for _ in 0..n {
                x = rk4_step(black_box(&m), &x, &u, 1e-6);
            }
            x[0] as f64
        }
        "planar64" => {
            let m = PlanarModel::<f64>::new(RobotParams::balanbot()).unwrap();
            let mut x = SVector::<f64, 7>::from_column_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.1, 0.1]);
            let u = SVector::<f64, 2>::new(0.01, 0.0);
            for _ in 0..n {
                x = rk4_step(black_box(&m), &x, &u, 1e-6);
            }
            x[3]
        }
        _ => {
            let m = PlanarModel::<f32>::new(RobotParams::balanbot()).unwrap();
            let mut x = SVector::<f32, 7>::from_column_slice(&[0.0, 0.0, 0.0, 0.1, 0.0, 0.1, 0.1]);
            let u = SVector::<f32, 2>::new(0.01, 0.0);
            for _ in 0..n {
                x = rk4_step(black_box(&m), &x, &u, 1e-6);
            }
            x[3] as f64
        }
    };
    let secs = cpu_seconds() - start;
    println!("{which}: {:.1} ns per RK4 step (CPU time, {n} steps, check {check:.3e})", secs / n as f64 * 1e9);
}
