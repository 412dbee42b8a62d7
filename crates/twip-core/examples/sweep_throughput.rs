//! Throughput of one sweep path, for timing with CPU time on a busy machine:
//!   /usr/bin/time -f "%U s user" cargo run --release --features parallel \
//!       --example sweep_throughput -- PATH 256
//! PATH: lanes (LQR on lanes), fuzzy-lanes, fuzzy-gaussian-lanes (benches/families.py's
//! Gaussian sets), scalar (LQR, general runner), fuzzy-scalar,
//! pid (circle-pid on the 3-DOF runner; the checksum sums its mean |x error| instead),
//! pid-lanes (the same on the planar lane kernel), pid-realism (circle-pid through the
//! thesis-like rig on the general runner), pid-realism-lanes (the same on the planar rig's lane kernel),
//! smc-fuzzy-lanes (circle-smc-fuzzy, 5 ms loop, on the planar lane kernel),
//! pid-terrain (circle-pid with the grade's feed-forward on planes drawn per sample, slope
//! 0-10 deg at any uphill heading, on the general runner), pid-terrain-lanes (the same on the
//! planar lanes on terrain), pid-terrain-realism (the same through the thesis-like rig on the
//! general runner), pid-terrain-realism-lanes (the same on the planar rig's lanes on terrain),
//! realism (LQR through the thesis-like rig,
//! 5 ms loop), realism-lanes (the same on the rig's lane kernel), realism-lanes-no-imu (that rig
//! without its IMU: what the IMU costs), realism-lanes-slip (that rig with the data sheet's
//! gearhead friction, slip law only: `Friction::gb37()`, no stick band), realism-lanes-hills
//! (that rig with benches/families.py's two slope changes along the path), fuzzy-realism-lanes
//! (the thesis's fuzzy law, 5 ms loop, through the thesis-like rig on lanes).
//! TWIP_KERNEL_COPY=avx2 (or avx512, baseline) runs that copy of the lane kernels.
//! RIG_DROP=imu,encoder,motor,delay,friction,backlash (any of them) takes those parts out of
//! the 2-DOF rig paths' realism: what each part costs.
//! The checksum's bits tell two builds' results apart (the same bits: the same numbers); the
//! 3-DOF paths print a digest of every metric of every sample too.
use nalgebra::{Matrix4, Vector4};
use twip_core::control::fuzzy::FuzzyController;
use twip_core::control::lqr::{design, DesignPoint, LqrController};
use twip_core::control::reference::SpeedSchedule;
use twip_core::hardware::realism::Realism;
use twip_core::sim::runner::SimConfig;
use twip_core::sweep::block::FuzzyLanes;
use twip_core::sweep::{draw, run_lane_samples, run_lqr_samples, run_slope_sample, Nominal, Perturbation, Spread, Target};
use twip_core::{RobotParams, SlopeModel};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map(String::as_str).unwrap_or("lanes");
    let n: u64 = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(256);
    let params = RobotParams::balanbot();
    let model = SlopeModel::new(params, 0.0).unwrap();
    let speed = 180f64.to_radians();
    let q = Matrix4::from_diagonal(&Vector4::new(100.0, 1.0, 1.0, 1.0));
    let d = design(&model, speed, &q, 480.0, DesignPoint::OperatingPoint).unwrap();
    let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 1e-3).unwrap();
    let perturb = [Perturbation { target: Target::Param(0), spread: Spread::Uniform { low: 0.66, high: 1.0 } }];
    let nominal = Nominal { params, slope: 0.0, x0: Vector4::zeros() };
    let schedule = SpeedSchedule::constant(speed).unwrap();
    let config = SimConfig { dt: 1e-3, t_final: 10.0, fall_limit: 1.0 };
    let fuzzy = FuzzyController::thesis_flat(model, 1e-3).unwrap();
    // TWIP_KERNEL_COPY=avx512|avx2|baseline runs that copy (`twip.use_kernel_copy`'s names).
    if let Ok(name) = std::env::var("TWIP_KERNEL_COPY") {
        use twip_core::sweep::block::KernelCopy;
        let chosen = KernelCopy::ALL.into_iter().find(|c| c.name() == name).map(|c| KernelCopy::choose(Some(c)));
        if !matches!(chosen, Some(Ok(_))) {
            eprintln!("TWIP_KERNEL_COPY={name:?}: not a copy that runs here (avx512, avx2, baseline)");
            std::process::exit(2);
        }
    }
    let start = std::time::Instant::now();
    let total: f64 = match path {
        "lanes" => run_lqr_samples(&ctrl, &schedule, &config, &nominal, &perturb, 1, 0..n, &|| false)
            .unwrap()
            .unwrap()
            .iter()
            .map(|m| m.mean_abs_pitch_error)
            .sum(),
        "fuzzy-gaussian-lanes" => {
            // benches/families.py's Gaussian sets.
            use twip_core::control::fuzzy_basis::{Membership, ThesisBasis};
            let inf = f64::INFINITY;
            let (g, tri, trap) = (Membership::gaussian, Membership::triangle, Membership::trapezoid);
            let sets = [
                [g(-0.3, 0.15).unwrap(), tri(-0.3, 0.0, 0.3).unwrap(), g(0.3, 0.15).unwrap()],
                [trap(-inf, -inf, -2.0, -0.5).unwrap(), tri(-2.0, 0.0, 2.0).unwrap(), trap(0.5, 2.0, inf, inf).unwrap()],
            ];
            let gaussian = FuzzyController::new(*fuzzy.model(), fuzzy.gains(), fuzzy.adaptation(), ThesisBasis::new(sets).unwrap(), 1e-3).unwrap();
            run_lane_samples(&FuzzyLanes::new(&gaussian), &schedule, &config, &nominal, &perturb, 1, 0..n, &|| false)
                .unwrap()
                .unwrap()
                .iter()
                .map(|m| m.mean_abs_pitch_error)
                .sum()
        }
        "fuzzy-lanes" => run_lane_samples(&FuzzyLanes::new(&fuzzy), &schedule, &config, &nominal, &perturb, 1, 0..n, &|| false)
            .unwrap()
            .unwrap()
            .iter()
            .map(|m| m.mean_abs_pitch_error)
            .sum(),
        "pid" | "pid-lanes" | "pid-realism" | "pid-realism-lanes" => {
            use twip_core::control::pid::PidTracker;
            use twip_core::control::trajectory::{Circle, Direction};
            use twip_core::hardware::motor::DcMotor;
            use twip_core::sweep::block::PidLanes;
            use twip_core::sweep::planar::{self, PlanarNominal};
            let pid = PidTracker::table_4_1(&params, DcMotor::gb37y3530(), 0.005).unwrap();
            let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
            let nominal = PlanarNominal { params, x0: nalgebra::SVector::zeros() };
            let rig = Realism::thesis_like();
            let runs = if path == "pid-realism-lanes" {
                let law = PidLanes::new(&pid);
                planar::run_planar_rig_lane_samples(&law, &circle, &config, &nominal, &perturb, 1, 0..n, 0.0, &|_| Ok(rig), &|| false, None).unwrap().unwrap()
            } else if path != "pid-lanes" {
                let realism = (path == "pid-realism").then_some(&rig);
                (0..n)
                    .map(|i| planar::run_planar_sample(&pid, &circle, &config, &planar::draw(&nominal, &perturb, 1, i), 0.0, realism, &|| false).unwrap())
                    .collect()
            } else {
                planar::run_planar_lane_samples(&PidLanes::new(&pid), &circle, &config, &nominal, &perturb, 1, 0..n, 0.0, &|| false, None).unwrap().unwrap()
            };
            digest(&runs);
            runs.iter().map(|m| m.mean_abs_x_error).sum()
        }
        "pid-terrain" | "pid-terrain-lanes" | "pid-terrain-realism" | "pid-terrain-realism-lanes" => {
            use twip_core::control::grade::GradeFeedForward;
            use twip_core::control::pid::PidTracker;
            use twip_core::control::trajectory::{Circle, Direction};
            use twip_core::hardware::motor::DcMotor;
            use twip_core::model::terrain::Terrain;
            use twip_core::model::terrain_model::TerrainModel;
            use twip_core::sweep::block::{FeedForwardLanes, PidLanes};
            use twip_core::sweep::planar::{self, PlanarNominal};
            use twip_core::sweep::terrain::{self, SweepTerrain};
            let motor = DcMotor::gb37y3530();
            let pid = PidTracker::table_4_1(&params, motor, 0.005).unwrap();
            let ff = GradeFeedForward::new(pid, TerrainModel::new(twip_core::PlanarModel::new(params).unwrap(), Terrain::flat()), Some(motor));
            let circle = Circle::from_origin(0.6, core::f64::consts::PI * params.wheel_radius, Direction::CounterClockwise).unwrap();
            let nominal = PlanarNominal { params, x0: nalgebra::SVector::zeros() };
            let ground = SweepTerrain::Plane { slope: 0.0, uphill_heading: 0.0 };
            let perturb = [
                perturb[0],
                Perturbation { target: Target::Slope, spread: Spread::Uniform { low: 0.0, high: 10f64.to_radians() } },
                Perturbation { target: Target::Heading, spread: Spread::Uniform { low: -core::f64::consts::PI, high: core::f64::consts::PI } },
            ];
            // As a sweep sets the rig up: noise key the seed, stream the sample's index.
            let rig = twip_core::sweep::rig::for_sweep(&Realism::thesis_like(), 1);
            let feed = Some(FeedForwardLanes::new(&ff));
            let runs: Vec<_> = match path {
                "pid-terrain" | "pid-terrain-realism" => {
                    let realism = (path == "pid-terrain-realism").then_some(&rig);
                    (0..n)
                        .map(|i| {
                            let (sample, drawn) = terrain::draw(&nominal, &ground, &perturb, 1, i);
                            terrain::run_terrain_sample(|t| ff.on(t.clone()), &circle, &config, &sample, &ground, drawn, 0.0, realism, &|| false).unwrap()
                        })
                        .collect()
                }
                "pid-terrain-lanes" => planar::run_planar_lane_samples(&PidLanes::new(&pid), &circle, &config, &nominal, &perturb, 1, 0..n, 0.0, &|| false, Some((&ground, feed))).unwrap().unwrap(),
                _ => planar::run_planar_rig_lane_samples(&PidLanes::new(&pid), &circle, &config, &nominal, &perturb, 1, 0..n, 0.0, &|_| Ok(rig), &|| false, Some((&ground, feed)))
                    .unwrap()
                    .unwrap(),
            };
            digest(&runs);
            runs.iter().map(|m| m.mean_abs_x_error).sum()
        }
        "smc-fuzzy-lanes" => {
            // circle-smc-fuzzy's tracker (the scenario's defaults, 5 ms loop) and circle (r = 0.45 m
            // at pi/30 m/s), as benches/families.py sweeps it, but 10 s per sample, not three laps.
            use twip_core::control::smc::{Adaptation, SmcGains, SmcOptions, SmcTracker};
            use twip_core::control::trajectory::{Circle, Direction};
            use twip_core::hardware::motor::DcMotor;
            use twip_core::sweep::block::SmcLanes;
            use twip_core::sweep::planar::{self, PlanarNominal};
            let motor = DcMotor::gb37y3530();
            let planar_model = twip_core::PlanarModel::new(params).unwrap();
            let smc = SmcTracker::new(SmcGains::thesis(motor.torque_per_count()), SmcOptions::default(), planar_model, Some(motor), Some(Adaptation::default()), 0.005).unwrap();
            let circle = Circle::from_origin(0.45, core::f64::consts::PI / 30.0, Direction::CounterClockwise).unwrap();
            let nominal = PlanarNominal { params, x0: nalgebra::SVector::zeros() };
            let law = SmcLanes::new(&smc).unwrap();
            let runs = planar::run_planar_lane_samples(&law, &circle, &config, &nominal, &perturb, 1, 0..n, 0.0, &|| false, None).unwrap().unwrap();
            digest(&runs);
            runs.iter().map(|m| m.mean_abs_x_error).sum()
        }
        "realism" | "realism-lanes" | "realism-lanes-no-imu" | "realism-lanes-slip" | "realism-lanes-hills" | "fuzzy-realism-lanes" => {
            use twip_core::sweep::block::LqrLanes;
            use twip_core::sweep::rig::{for_sweep, run_rig_lane_samples, run_rig_sample};
            let ctrl = LqrController::new(d.gains, model, DesignPoint::OperatingPoint, 5e-3).unwrap();
            let rig = match path {
                "realism-lanes-no-imu" => Realism { imu: None, ..Realism::thesis_like() },
                // The data sheet's gearhead friction, slip law only (no stick band).
                "realism-lanes-slip" => Realism { friction: Some(twip_core::model::friction::Friction::gb37()), ..Realism::thesis_like() },
                // benches/families.py's two slope changes along the path.
                "realism-lanes-hills" => Realism {
                    slope_profile: twip_core::hardware::disturbance::SlopeProfile::new(0.0, &[(0.3, 0.02), (0.6, -0.02)]).unwrap(),
                    ..Realism::thesis_like()
                },
                _ => Realism::thesis_like(),
            };
            let realism = for_sweep(&without_parts(rig), 1);
            let runs: Vec<_> = if path == "realism" {
                (0..n).map(|i| run_rig_sample(&ctrl, &schedule, &config, &draw(&nominal, &perturb, 1, i), &realism, &|| false).unwrap()).collect()
            } else if path == "fuzzy-realism-lanes" {
                let fuzzy = FuzzyController::thesis_flat(model, 5e-3).unwrap();
                run_rig_lane_samples(&FuzzyLanes::new(&fuzzy), &schedule, &config, &nominal, &perturb, 1, 0..n, &|_| Ok(realism), &|| false).unwrap().unwrap()
            } else {
                run_rig_lane_samples(&LqrLanes::new(&ctrl), &schedule, &config, &nominal, &perturb, 1, 0..n, &|_| Ok(realism), &|| false).unwrap().unwrap()
            };
            runs.iter().map(|m| m.mean_abs_pitch_error).sum()
        }
        "fuzzy-scalar" => (0..n)
            .map(|i| run_slope_sample(&fuzzy, &schedule, &config, &draw(&nominal, &perturb, 1, i), &|| false).unwrap())
            .map(|m| m.mean_abs_pitch_error)
            .sum(),
        _ => (0..n)
            .map(|i| run_slope_sample(&ctrl, &schedule, &config, &draw(&nominal, &perturb, 1, i), &|| false).unwrap())
            .map(|m| m.mean_abs_pitch_error)
            .sum(),
    };
    let secs = start.elapsed().as_secs_f64();
    let copy = twip_core::sweep::block::KernelCopy::active().name();
    println!("{path}: {n} samples x 10000 steps in {secs:.3} s wall = {:.2} M sample-steps/s, kernel copy {copy} (checksum {total:.6e}; bits {:016x})", n as f64 * 1e4 / secs / 1e6, total.to_bits());
}

/// Prints a digest of every sample's metrics (their `Debug` text, so every bit of every field).
fn digest<M: std::fmt::Debug>(runs: &[M]) {
    use std::hash::{Hash, Hasher};
    let mut h = std::collections::hash_map::DefaultHasher::new();
    format!("{runs:?}").hash(&mut h);
    println!("digest of every metric: {:016x}", h.finish());
}

/// `rig` without the parts the environment's RIG_DROP names (comma-separated).
fn without_parts(mut rig: Realism<f64>) -> Realism<f64> {
    let names = std::env::var("RIG_DROP").unwrap_or_default();
    for part in names.split(',').filter(|p| !p.is_empty()) {
        match part {
            "imu" => rig.imu = None,
            "encoder" => rig.encoder_cpr = None,
            "motor" => rig.motor = None,
            "delay" => rig.delay = false,
            "friction" => rig.friction = None,
            "backlash" => rig.backlash = None,
            _ => {
                eprintln!("RIG_DROP: unknown part {part:?}; the parts are imu, encoder, motor, delay, friction, backlash");
                std::process::exit(2);
            }
        }
    }
    rig
}
