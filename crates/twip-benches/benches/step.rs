//! One RK4 step of each model, f64 and f32, and a closed-loop LQR run: in wall time, and
//! per closed-loop step in this thread's CPU time (`closed_loop_step`, robust on a busy
//! machine: ns per step = 1e3 / its Melem/s).
//! Run: cargo bench -p twip-benches --bench step
use std::hint::black_box;

use criterion::measurement::Measurement;
use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use nalgebra::{SVector, Vector4};
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::sim::metrics::SlopeMetrics;
use twip_core::control::reference::SpeedSchedule;
use twip_core::sim::runner::{simulate, SimConfig};
use twip_core::{rk4_step, PlanarModel, Real, RobotParams, SlopeModel};

fn slope_step<T: Real>(c: &mut Criterion, name: &str) {
    let m = SlopeModel::<T>::new(RobotParams::balanbot(), nalgebra::convert(0.1)).unwrap();
    let x = Vector4::<T>::from_fn(|i, _| nalgebra::convert(0.1 * (i as f64 + 1.0)));
    let u = SVector::<T, 1>::new(nalgebra::convert(0.2));
    let dt: T = nalgebra::convert(1e-3);
    c.bench_function(name, |b| b.iter(|| rk4_step(black_box(&m), black_box(&x), black_box(&u), dt)));
}

fn planar_step<T: Real>(c: &mut Criterion, name: &str) {
    let m = PlanarModel::<T>::new(RobotParams::balanbot()).unwrap();
    let x = SVector::<T, 7>::from_fn(|i, _| nalgebra::convert(0.1 * (i as f64 + 1.0)));
    let u = SVector::<T, 2>::new(nalgebra::convert(0.2), nalgebra::convert(-0.1));
    let dt: T = nalgebra::convert(1e-3);
    c.bench_function(name, |b| b.iter(|| rk4_step(black_box(&m), black_box(&x), black_box(&u), dt)));
}

fn steps(c: &mut Criterion) {
    slope_step::<f64>(c, "slope_rk4_step_f64");
    slope_step::<f32>(c, "slope_rk4_step_f32");
    planar_step::<f64>(c, "planar_rk4_step_f64");
    planar_step::<f32>(c, "planar_rk4_step_f32");
}

/// 10 s of flat-lqr at dt = 1 ms (10,000 closed-loop steps) with metrics, no log: each
/// step the plant's RK4 step, the observer's metrics, and every 5th the LQR law.
fn closed_loop<M: Measurement + 'static>(c: &mut Criterion<M>, name: &str) {
    let model = SlopeModel::<f64>::new(RobotParams::balanbot(), 0.0).unwrap();
    let speed = 180f64.to_radians();
    let q = nalgebra::Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
    let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
    let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 0.005).unwrap();
    let schedule = SpeedSchedule::constant(speed).unwrap();
    let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
    let mut group = c.benchmark_group(name);
    group.throughput(Throughput::Elements(10_000));
    group.bench_function("flat_lqr_10s", |b| {
        b.iter(|| {
            let mut ctrl = ctrl;
            let mut metrics = SlopeMetrics::new(model);
            simulate(&model, &mut ctrl, &schedule, &Vector4::zeros(), &config, &mut metrics).unwrap()
        })
    });
    group.finish();
}

fn closed_loop_wall(c: &mut Criterion) {
    closed_loop(c, "closed_loop");
}

criterion_group!(benches, steps, closed_loop_wall);

/// The closed loop per step in this thread's CPU time: Linux only (its thread CPU clock).
#[cfg(target_os = "linux")]
mod cpu {
    use super::*;
    use criterion::measurement::{Measurement, ValueFormatter, WallTime};

    /// The time this thread ran [ns], from the OS (Linux's thread CPU clock): other
    /// processes' time on the core does not count, as it does in wall time.
    struct ThreadCpu;

    impl Measurement for ThreadCpu {
        type Intermediate = u64;
        type Value = u64;

        fn start(&self) -> u64 {
            let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
            // SAFETY: `t` is a valid, writable timespec and the clock id is libc's own.
            let status = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
            assert_eq!(status, 0, "the thread CPU clock is not available");
            t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
        }

        fn end(&self, start: u64) -> u64 {
            self.start() - start
        }

        fn add(&self, a: &u64, b: &u64) -> u64 {
            a + b
        }

        fn zero(&self) -> u64 {
            0
        }

        fn to_f64(&self, value: &u64) -> f64 {
            *value as f64
        }

        fn formatter(&self) -> &dyn ValueFormatter {
            // Nanoseconds, as wall time's.
            static WALL: WallTime = WallTime;
            WALL.formatter()
        }
    }

    fn closed_loop_cpu(c: &mut Criterion<ThreadCpu>) {
        closed_loop(c, "closed_loop_step");
    }

    criterion_group! {
        name = cpu_benches;
        config = Criterion::default().with_measurement(ThreadCpu);
        targets = closed_loop_cpu
    }
}

#[cfg(target_os = "linux")]
criterion_main!(benches, cpu::cpu_benches);
#[cfg(not(target_os = "linux"))]
criterion_main!(benches);
