//! The planar lanes on terrain (docs/terrain.md): each lane its own robot on its own ground
//! (a sweep's drawn plane, or the sweep's one terrain), the terrain model's derivative
//! (`deriv_on_ground`, the run's own source) on [`Fused`] lanes with each lane's local plane
//! looked up at every RK4 stage; after each step the run's own tests end a lane "lifted" (a
//! wheel's normal force below zero) or "off_terrain" (off a grid), and the grade's feed-forward
//! (`GradeFeedForward`) is the run's own rest (`rest_drive`, `rest_torques`) on lanes.
use super::law::{update_out_of_line, LaneLaw, Planar};
use super::planar::{BlockGround, Plants};
use crate::control::grade::GradeFeedForward;
use crate::control::pid::relative_wheel_speeds;
use crate::control::trajectory::PlanarRef;
use crate::control::Controller;
use crate::hardware::motor::DcMotor;
use crate::model::dynamics::Halt;
use crate::model::friction::Gearhead;
use crate::model::integrate::{rk4, Field};
use crate::model::lane::{clamp, fill, Fused, Lane, Wide};
use crate::model::terrain::Terrain;
use crate::model::terrain_model::{deriv_on_ground, normal_forces_on_ground, rest_drive, rest_torques, Contact, Frame, RestTerms};
use crate::sweep::lanes::{Lanes, LANES};
use crate::sweep::planar::PlanarSample;

use alloc::vec::Vec;

/// Each lane's ground: planes, whose gradients are the lanes' constants (a sweep's drawn
/// planes, flat ground), or any terrains, looked up lane by lane by the run's own code.
#[derive(Clone, Debug)]
enum Grounds {
    Planes { gx: Lanes, gy: Lanes },
    Any(Vec<Terrain<f64>>),
}

impl Grounds {
    fn new(terrains: &[Terrain<f64>; LANES]) -> Self {
        let mut g = [[0.0; LANES]; 2];
        for (l, t) in terrains.iter().enumerate() {
            let Terrain::Plane { gx, gy } = *t else {
                return Grounds::Any(terrains.to_vec());
            };
            (g[0][l], g[1][l]) = (gx, gy);
        }
        Grounds::Planes { gx: g[0], gy: g[1] }
    }

    /// Every lane's gradient at (`x`, `y`), clamped onto a grid (the run's plant's).
    #[inline(always)]
    fn gradients(&self, x: &Lanes, y: &Lanes) -> [Lanes; 2] {
        match self {
            Grounds::Planes { gx, gy } => [*gx, *gy],
            Grounds::Any(t) => {
                let mut g = [[0.0; LANES]; 2];
                for l in 0..LANES {
                    let local = t[l].local_clamped(x[l], y[l]);
                    (g[0][l], g[1][l]) = (local.gx, local.gy);
                }
                g
            }
        }
    }

    /// Every lane's gradient at (`x`, `y`) and whether it is on its terrain (a grid's edge).
    #[inline(always)]
    fn local(&self, x: &Lanes, y: &Lanes) -> ([Lanes; 2], [bool; LANES]) {
        match self {
            Grounds::Planes { gx, gy } => ([*gx, *gy], [true; LANES]),
            Grounds::Any(t) => {
                let (mut g, mut on) = ([[0.0; LANES]; 2], [false; LANES]);
                for l in 0..LANES {
                    if let Some(local) = t[l].local(x[l], y[l]) {
                        (g[0][l], g[1][l], on[l]) = (local.gx, local.gy, true);
                    }
                }
                (g, on)
            }
        }
    }
}

/// The grade's feed-forward on lanes: the prototype's robot (the rest's numbers) and motor.
#[derive(Clone, Copy, Debug)]
pub struct FeedForwardLanes {
    rest: RestTerms<f64>,
    motor: Option<DcMotor<f64>>,
}

impl FeedForwardLanes {
    /// `prototype`'s feed-forward (its tracker goes on lanes apart).
    pub fn new<C: Controller<f64, 7, 2, Reference = PlanarRef<f64>>>(prototype: &GradeFeedForward<f64, C>) -> Self {
        let (ground, motor) = prototype.parts();
        Self { rest: RestTerms::of(ground.flat().params()), motor: motor.copied() }
    }
}

/// A block's lanes on their terrains, with the grade's feed-forward or without.
#[derive(Clone, Debug)]
pub struct TerrainLanes {
    grounds: Grounds,
    valid: [bool; LANES],
    /// (M_b + M_w) g of each lane's robot.
    weight: Lanes,
    contact: [Contact<f64>; LANES],
    feed: Option<FeedForwardLanes>,
}

impl TerrainLanes {
    /// Lane `l` runs `samples[l]` on `terrains[l]` (None: a terrain no draw should give; the
    /// lane is invalid, as it is when its start is off its terrain); `feed` the tracker's
    /// feed-forward, if any.
    pub fn new(samples: &[PlanarSample], terrains: &[Option<Terrain<f64>>], feed: Option<FeedForwardLanes>) -> Self {
        assert!(samples.len() <= LANES && terrains.len() == samples.len(), "a block holds at most {LANES} samples, each with its terrain");
        let valid: [bool; LANES] = core::array::from_fn(|l| l < samples.len() && terrains[l].as_ref().is_some_and(|t| t.contains(samples[l].x0[0], samples[l].x0[1])));
        // Idle lanes run a copy of a valid one (never kept).
        let first = valid.iter().position(|&v| v).unwrap_or(0);
        let of = |l: usize| if valid[l] { l } else { first };
        let terrain = |l: usize| terrains.get(of(l)).cloned().flatten().unwrap_or_else(Terrain::flat);
        let params = |l: usize| samples.get(of(l)).map_or_else(crate::RobotParams::balanbot, |s| s.params);
        Self {
            grounds: Grounds::new(&core::array::from_fn(terrain)),
            valid,
            weight: core::array::from_fn(|l| {
                let p = params(l);
                (p.m_body + p.m_wheels) * p.g
            }),
            contact: core::array::from_fn(|l| Contact::of(&params(l))),
            feed,
        }
    }
}

impl TerrainLanes {
    /// Every lane's gradient at (`x`, `y`), clamped onto a grid (the run's plant's): what an
    /// RK4 stage looks up.
    #[inline(always)]
    pub(super) fn gradients(&self, x: &Lanes, y: &Lanes) -> [Lanes; 2] {
        self.grounds.gradients(x, y)
    }

    /// Lane `l`'s gradient at (`x`, `y`), clamped onto a grid, as [`Self::gradients`] gives it.
    #[inline(always)]
    pub(super) fn gradient(&self, l: usize, x: f64, y: f64) -> [f64; 2] {
        match &self.grounds {
            Grounds::Planes { gx, gy } => [gx[l], gy[l]],
            Grounds::Any(t) => {
                let local = t[l].local_clamped(x, y);
                [local.gx, local.gy]
            }
        }
    }

    /// (M_b + M_w) g of lane `l`'s robot.
    #[inline(always)]
    pub(super) fn weight(&self, l: usize) -> f64 {
        self.weight[l]
    }

    /// What ends each lane at `next`, as the terrain model's and the rig's `halted`: off its
    /// terrain, else a wheel's normal force below zero, `normal_forces(l, gradient, contact)`
    /// giving lane `l`'s on the gradient under it (the ideal lanes' plant, or the rig's).
    #[inline(always)]
    pub(super) fn halts_where(&self, next: &[Lanes; 7], normal_forces: impl Fn(usize, [Fused; 2], &Contact<Fused>) -> [Fused; 2]) -> [Option<Halt>; LANES] {
        let (_, on) = self.grounds.local(&next[0], &next[1]);
        let [gx, gy] = self.grounds.gradients(&next[0], &next[1]);
        let mut lifted = [false; LANES];
        for l in 0..LANES {
            let [n_r, n_l] = normal_forces(l, [Fused(gx[l]), Fused(gy[l])], &self.contact[l].map(Fused));
            lifted[l] = n_r.0 < 0.0 || n_l.0 < 0.0;
        }
        core::array::from_fn(|l| if !on[l] { Some(Halt::OffTerrain) } else if lifted[l] { Some(Halt::Lifted) } else { None })
    }
}

/// Every lane's plant on its ground, the inputs `u` held over a step: the field of all the
/// lanes at once (one RK4 stage is one lookup of the lanes' grounds, then one loop over
/// lanes that the compiler vectorises).
struct OnGround<'a> {
    plants: &'a Plants,
    lanes: &'a TerrainLanes,
    u: &'a [Lanes; 2],
}

impl Field<Wide<LANES>, 7> for OnGround<'_> {
    #[inline(always)]
    fn at(&self, x: &[Wide<LANES>; 7]) -> [Wide<LANES>; 7] {
        let [gx, gy] = self.lanes.grounds.gradients(&x[0].0, &x[1].0);
        let mut out = [Wide([0.0; LANES]); 7];
        for l in 0..LANES {
            let xl = fill(|i| Fused(x[i].0[l]));
            let u = [Fused(self.u[0][l]), Fused(self.u[1][l])];
            let d = deriv_on_ground(&self.plants.lane(l), Fused(self.lanes.weight[l]), Gearhead::of(None), &xl, u, Fused(gx[l]), Fused(gy[l]));
            for i in 0..7 {
                out[i].0[l] = d[i].0;
            }
        }
        out
    }
}

impl BlockGround for TerrainLanes {
    #[inline(always)]
    fn valid(&self, l: usize) -> bool {
        self.valid[l]
    }

    /// RK4 over all the lanes at once ([`Wide`]'s arithmetic is [`Fused`]'s lane by lane).
    #[inline(always)]
    fn rk4(&self, plants: &Plants, x: &[Lanes; 7], u: &[Lanes; 2], dt: f64) -> [Lanes; 7] {
        let field = OnGround { plants, lanes: self, u };
        let x = x.map(Wide);
        rk4(&field, &x, &field.at(&x), Wide::splat(dt)).map(|w| w.0)
    }

    /// As the terrain model's `halted`: off its terrain, else a wheel's normal force below zero.
    #[inline(always)]
    fn halts(&self, plants: &Plants, next: &[Lanes; 7], u: &[Lanes; 2]) -> Option<[Option<Halt>; LANES]> {
        // `inline(always)`: out of line, the closure was baseline code, each multiply-add a call
        // of the software fma: ~37 % of the lanes' instructions on terrain (`callgrind`).
        Some(self.halts_where(next, #[inline(always)] |l, [gx, gy], contact| {
            let xl = fill(|i| Fused(next[i][l]));
            let ul = [Fused(u[0][l]), Fused(u[1][l])];
            normal_forces_on_ground(&plants.lane(l), Fused(self.weight[l]), Gearhead::of(None), contact, &xl, ul, gx, gy)
        }))
    }

    /// With the feed-forward, as `GradeFeedForward::update`: the tracker sees its pitch from
    /// the rest pitch of each lane's local grade and gets the rest torques added (zero off the
    /// terrain or where no rest exists), the sum held within the motor's torques.
    #[inline(always)]
    fn update<C: LaneLaw<Shape = Planar>, const COPY: u8>(&self, controller: &mut C, state: &mut C::State, x: &[Lanes; 7], r: &PlanarRef<f64>, u: &mut [Lanes; 2]) {
        let Some(feed) = &self.feed else {
            return update_out_of_line::<C, COPY>(controller, state, x, r, u);
        };
        let ([gx, gy], on) = self.grounds.local(&x[0], &x[1]);
        let k = feed.rest.map(Fused);
        let (mut seen, mut torque) = (*x, [[0.0; LANES]; 2]);
        for l in 0..LANES {
            let (s, c) = Fused::sincos(Fused(x[2][l]));
            let f = Frame::new(Fused(gx[l]), Fused(gy[l]), s, c);
            let (drive, sin_phi) = rest_drive(&k, &f);
            // As the run's `rest`: none where |sin φ_s| ≥ 1 (a NaN passes, as there).
            let holds = on[l] && !(sin_phi.0.abs() >= 1.0);
            let phi = sin_phi.arcsine();
            let t = rest_torques(&k, &f, drive, Fused::sincos(phi + f.delta).0);
            seen[3][l] = x[3][l] - if holds { phi.0 } else { 0.0 };
            for w in 0..2 {
                torque[w][l] = if holds { t[w].0 } else { 0.0 };
            }
        }
        update_out_of_line::<C, COPY>(controller, state, &seen, r, u);
        for l in 0..LANES {
            let mut out = [Fused(u[0][l]) + Fused(torque[0][l]), Fused(u[1][l]) + Fused(torque[1][l])];
            if let Some(m) = &feed.motor {
                let speeds = relative_wheel_speeds(&fill(|i| Fused(x[i][l])), k.radius, k.half_track);
                let m = m.map(Fused);
                for (o, w) in out.iter_mut().zip(speeds) {
                    let (lo, hi) = m.torque_limits(w);
                    *o = clamp(*o, lo, hi);
                }
            }
            (u[0][l], u[1][l]) = (out[0].0, out[1].0);
        }
    }
}
