//! Planar trajectories for the trackers (thesis 4.3): a circle, a straight line, a
//! figure-eight and a path through waypoints. Each is a [`Reference`] whose sample is
//! where the robot should be (x_r, y_r, ψ_r), how fast it moves along and turns (v_r, ω_r)
//! and the derivatives of those the sliding-mode tracker needs (v̇_r, ω̇_r); each is also a
//! [`Path`] (distance to the curve, for the metrics). Fixed-size, no allocation.
use crate::error::invalid;
use crate::control::Reference;
use crate::model::lane::Lane;
use crate::{c, Real, TwipError};

/// Where the robot should be at time t and how the reference moves there.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlanarRef<T> {
    /// Position [m].
    pub x: T,
    pub y: T,
    /// Heading [rad], continuous along the path (not wrapped).
    pub psi: T,
    /// Speed along the path [m/s] and turn rate [rad/s].
    pub v: T,
    pub omega: T,
    /// Their time derivatives [m/s², rad/s²].
    pub v_dot: T,
    pub omega_dot: T,
}

/// A curve in the plane: how far a point is from it.
pub trait Path<T: Real> {
    fn distance(&self, x: T, y: T) -> T;
}

/// Which way a circle turns.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Direction {
    /// Left turns, ψ increasing (ω > 0).
    CounterClockwise,
    Clockwise,
}

impl Direction {
    fn sign<T: Real>(self) -> T {
        match self {
            Self::CounterClockwise => T::one(),
            Self::Clockwise => -T::one(),
        }
    }
}

/// `angle` mod 2π in [−π, π): the heading error the trackers act on.
#[inline(always)]
pub fn wrap_angle<S: Lane>(angle: S) -> S {
    let two_pi = S::splat(core::f64::consts::TAU);
    angle - two_pi * ((angle + S::splat(core::f64::consts::PI)) / two_pi).floor()
}

fn finite<T: Real>(name: &'static str, v: T) -> Result<T, TwipError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(invalid(name, v, "must be finite"))
    }
}

fn positive<T: Real>(name: &'static str, v: T) -> Result<T, TwipError> {
    if v.is_finite() && v > T::zero() {
        Ok(v)
    } else {
        Err(invalid(name, v, "must be finite and > 0"))
    }
}

fn point<T: Real>(name: &'static str, p: [T; 2]) -> Result<[T; 2], TwipError> {
    Ok([finite(name, p[0])?, finite(name, p[1])?])
}

// --- circle --------------------------------------------------------------------------------

/// Constant speed round a circle (the thesis's references).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Circle<T> {
    centre: [T; 2],
    radius: T,
    speed: T,
    direction: Direction,
    /// Angle of the start point seen from the centre [rad].
    phase: T,
}

impl<T: Real> Circle<T> {
    pub fn new(centre: [T; 2], radius: T, speed: T, direction: Direction, phase: T) -> Result<Self, TwipError> {
        // The radius first: a default centre (`from_origin`, Python's Circle) is made from it,
        // so a bad radius would otherwise be reported as a bad centre.
        let radius = positive("radius", radius)?;
        Ok(Self {
            centre: point("centre", centre)?,
            radius,
            speed: positive("speed", speed)?,
            direction,
            phase: finite("phase", phase)?,
        })
    }

    /// Starts at the origin heading along +x; the centre is on the side it turns to.
    pub fn from_origin(radius: T, speed: T, direction: Direction) -> Result<Self, TwipError> {
        let s = direction.sign::<T>();
        Self::new([T::zero(), s * radius], radius, speed, direction, -s * T::frac_pi_2())
    }

    /// One lap [s].
    pub fn period(&self) -> T {
        T::two_pi() * self.radius / self.speed
    }

    pub fn centre(&self) -> [T; 2] {
        self.centre
    }

    pub fn radius(&self) -> T {
        self.radius
    }

    pub fn speed(&self) -> T {
        self.speed
    }

    pub fn direction(&self) -> Direction {
        self.direction
    }

    pub fn phase(&self) -> T {
        self.phase
    }
}

impl<T: Real> Reference<T> for Circle<T> {
    type Sample = PlanarRef<T>;

    fn sample(&self, t: T) -> PlanarRef<T> {
        let s = self.direction.sign::<T>();
        let rate = s * self.speed / self.radius;
        let angle = self.phase + rate * t;
        let (sin, cos) = crate::model::math::sin_cos(angle);
        PlanarRef {
            x: self.centre[0] + self.radius * cos,
            y: self.centre[1] + self.radius * sin,
            psi: angle + s * T::frac_pi_2(),
            v: self.speed,
            omega: rate,
            v_dot: T::zero(),
            omega_dot: T::zero(),
        }
    }
}

impl<T: Real> Path<T> for Circle<T> {
    fn distance(&self, x: T, y: T) -> T {
        let (dx, dy) = (x - self.centre[0], y - self.centre[1]);
        ((dx * dx + dy * dy).sqrt() - self.radius).abs()
    }
}

// --- line ----------------------------------------------------------------------------------

/// A straight line from `start` along `heading` at constant speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line<T> {
    start: [T; 2],
    heading: T,
    speed: T,
}

impl<T: Real> Line<T> {
    pub fn new(start: [T; 2], heading: T, speed: T) -> Result<Self, TwipError> {
        Ok(Self { start: point("start", start)?, heading: finite("heading", heading)?, speed: positive("speed", speed)? })
    }

    pub fn start(&self) -> [T; 2] {
        self.start
    }

    pub fn heading(&self) -> T {
        self.heading
    }

    pub fn speed(&self) -> T {
        self.speed
    }
}

impl<T: Real> Reference<T> for Line<T> {
    type Sample = PlanarRef<T>;

    fn sample(&self, t: T) -> PlanarRef<T> {
        let (sin, cos) = self.heading.sin_cos();
        let s = self.speed * t;
        // Along an axis the line does not move on (sin or cos exactly 0) the robot stays at
        // its start, also where s overflows: inf times 0 would make it NaN. Any other
        // product is the one it was (the same bits).
        let along = |c: T| if c == T::zero() { T::zero() } else { s * c };
        PlanarRef {
            x: self.start[0] + along(cos),
            y: self.start[1] + along(sin),
            psi: self.heading,
            v: self.speed,
            omega: T::zero(),
            v_dot: T::zero(),
            omega_dot: T::zero(),
        }
    }
}

impl<T: Real> Path<T> for Line<T> {
    fn distance(&self, x: T, y: T) -> T {
        let (sin, cos) = self.heading.sin_cos();
        (cos * (y - self.start[1]) - sin * (x - self.start[0])).abs()
    }
}

// --- figure-eight ------------------------------------------------------------------------------

/// The lemniscate of Gerono `x = a sin Wt, y = (a/2) sin 2Wt`, W = 2π/period, about
/// `centre`: smooth, never at rest (v² = a²W²(cos² Wt + cos² 2Wt) > 0), the right lobe
/// clockwise and the left one counter-clockwise. The heading stays on its one continuous
/// branch, [−5π/4, π/4], so it never jumps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FigureEight<T> {
    centre: [T; 2],
    half_width: T,
    period: T,
}

/// Position and its first three derivatives at one time.
struct Jet<T> {
    p: [T; 2],
    d1: [T; 2],
    d2: [T; 2],
    d3: [T; 2],
}

impl<T: Real> FigureEight<T> {
    pub fn new(centre: [T; 2], half_width: T, period: T) -> Result<Self, TwipError> {
        let eight = Self { centre: point("centre", centre)?, half_width: positive("half_width", half_width)?, period: positive("period", period)? };
        // The samples' yaw rate and its derivative divide powers of the speed (a w) into
        // products of its derivatives (a w^k): far enough from 1, inf over inf, NaN from the
        // start. Checked on the samples themselves, at eight phases of the period.
        let finite = |r: PlanarRef<T>| [r.x, r.y, r.psi, r.v, r.omega, r.v_dot, r.omega_dot].iter().all(|v| v.is_finite());
        if !(0..8).all(|k| finite(eight.sample(period * c::<T>(k as f64 / 8.0)))) {
            return Err(invalid("period", period, "with half_width gives a reference beyond floating point's range"));
        }
        Ok(eight)
    }

    pub fn centre(&self) -> [T; 2] {
        self.centre
    }

    pub fn half_width(&self) -> T {
        self.half_width
    }

    pub fn period(&self) -> T {
        self.period
    }

    fn jet(&self, t: T) -> Jet<T> {
        let w = T::two_pi() / self.period;
        let a = self.half_width;
        let (s1, c1) = crate::model::math::sin_cos(w * t);
        let (s2, c2) = crate::model::math::sin_cos(c::<T>(2.0) * w * t);
        let (w2, w3) = (w * w, w * w * w);
        Jet {
            p: [self.centre[0] + a * s1, self.centre[1] + c::<T>(0.5) * a * s2],
            d1: [a * w * c1, a * w * c2],
            d2: [-a * w2 * s1, -c::<T>(2.0) * a * w2 * s2],
            d3: [-a * w3 * c1, -c::<T>(4.0) * a * w3 * c2],
        }
    }
}

impl<T: Real> Reference<T> for FigureEight<T> {
    type Sample = PlanarRef<T>;

    fn sample(&self, t: T) -> PlanarRef<T> {
        let Jet { p, d1, d2, d3 } = self.jet(t);
        let speed2 = d1[0] * d1[0] + d1[1] * d1[1];
        let speed = speed2.sqrt();
        // Curvature numerator (ẋÿ − ẏẍ) and ½ d(v²)/dt.
        let cross = d1[0] * d2[1] - d1[1] * d2[0];
        let dot = d1[0] * d2[0] + d1[1] * d2[1];
        let mut psi = d1[1].atan2(d1[0]);
        if psi > T::frac_pi_2() {
            // The continuous branch never visits (π/2, π]: there it is ψ − 2π.
            psi -= T::two_pi();
        }
        PlanarRef {
            x: p[0],
            y: p[1],
            psi,
            v: speed,
            omega: cross / speed2,
            v_dot: dot / speed,
            omega_dot: (d1[0] * d3[1] - d1[1] * d3[0]) / speed2 - c::<T>(2.0) * cross * dot / (speed2 * speed2),
        }
    }
}

impl<T: Real> Path<T> for FigureEight<T> {
    /// A scan of 64 points over one period, then Newton on the squared distance from every
    /// local minimum of the scan (the curve crosses itself: the nearest sample may lie on
    /// the other branch).
    fn distance(&self, x: T, y: T) -> T {
        const SCAN: usize = 64;
        let step = self.period / c::<T>(SCAN as f64);
        let mut d2 = [T::zero(); SCAN];
        for (k, d) in d2.iter_mut().enumerate() {
            let p = self.jet(step * c::<T>(k as f64)).p;
            *d = (p[0] - x) * (p[0] - x) + (p[1] - y) * (p[1] - y);
        }
        let mut best = T::one() / T::zero();
        for k in 0..SCAN {
            let (prev, next) = (d2[(k + SCAN - 1) % SCAN], d2[(k + 1) % SCAN]);
            best = best.min(d2[k]);
            if d2[k] > prev || d2[k] > next {
                continue;
            }
            let mut t = step * c::<T>(k as f64);
            for _ in 0..4 {
                let j = self.jet(t);
                let (ex, ey) = (j.p[0] - x, j.p[1] - y);
                let grad = ex * j.d1[0] + ey * j.d1[1];
                let hess = j.d1[0] * j.d1[0] + j.d1[1] * j.d1[1] + ex * j.d2[0] + ey * j.d2[1];
                if hess <= T::zero() {
                    break;
                }
                t -= grad / hess;
            }
            let p = self.jet(t).p;
            best = best.min((p[0] - x) * (p[0] - x) + (p[1] - y) * (p[1] - y));
        }
        best.sqrt()
    }
}

// --- waypoints ---------------------------------------------------------------------------------

/// Most points a [`Waypoints`] path holds (fixed size: no allocation, no_std).
pub const MAX_WAYPOINTS: usize = 16;
/// Straight legs and the corner arcs between them.
const MAX_PIECES: usize = 2 * MAX_WAYPOINTS - 3;

/// A straight leg (curvature 0) or a corner arc, from its start.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Piece<T> {
    /// Arc length at which it starts [m] and its length [m].
    start: T,
    length: T,
    x: T,
    y: T,
    heading: T,
    /// Signed curvature [1/m], > 0 turning left.
    curvature: T,
}

impl<T: Real> Piece<T> {
    /// Position and heading `along` metres in.
    fn at(&self, along: T) -> (T, T, T) {
        if self.curvature == T::zero() {
            let (sin, cos) = self.heading.sin_cos();
            return (self.x + along * cos, self.y + along * sin, self.heading);
        }
        let k = self.curvature;
        let h = self.heading + k * along;
        let (s0, c0) = self.heading.sin_cos();
        let (s, co) = h.sin_cos();
        (self.x + (s - s0) / k, self.y - (co - c0) / k, h)
    }

    fn distance(&self, x: T, y: T) -> T {
        if self.curvature == T::zero() {
            let (sin, cos) = self.heading.sin_cos();
            let along = ((x - self.x) * cos + (y - self.y) * sin).max(T::zero()).min(self.length);
            return (x - self.x - along * cos).hypot(y - self.y - along * sin);
        }
        let k = self.curvature;
        let (s0, c0) = self.heading.sin_cos();
        let (cx, cy) = (self.x - s0 / k, self.y + c0 / k);
        let start = (self.y - cy).atan2(self.x - cx);
        let here = (y - cy).atan2(x - cx);
        // How far round from the start, in the arc's own direction, in [0, 2π).
        let turn = (here - start) * k.signum();
        let swept = turn - T::two_pi() * (turn / T::two_pi()).floor();
        if swept <= k.abs() * self.length {
            ((x - cx).hypot(y - cy) - T::one() / k.abs()).abs()
        } else {
            let (ex, ey, _) = self.at(self.length);
            (x - self.x).hypot(y - self.y).min((x - ex).hypot(y - ey))
        }
    }
}

/// The smallest share of `corner_radius` a corner's arc may shrink to (to fit its legs)
/// before the corner is left sharp: a near-reversal's arc would be a point.
const MIN_CORNER_SHARE: f64 = 1e-3;

/// Straight legs through the points at constant speed, each inner corner rounded by a
/// circular arc of `corner_radius` (smaller where a leg is too short: an arc's tangent
/// length is at most half of either leg; sharp where that leaves under a thousandth of
/// it, as at a reversal). A corner radius of 0 gives sharp corners, where the heading
/// jumps. After the last point the reference stands there (v_r = 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Waypoints<T> {
    points: [[T; 2]; MAX_WAYPOINTS],
    count: usize,
    speed: T,
    corner_radius: T,
    pieces: [Piece<T>; MAX_PIECES],
    n_pieces: usize,
    length: T,
}

impl<T: Real> Waypoints<T> {
    /// At least 2 and at most [`MAX_WAYPOINTS`] finite points, consecutive ones distinct.
    pub fn new(points: &[[T; 2]], speed: T, corner_radius: T) -> Result<Self, TwipError> {
        let n = points.len();
        if n < 2 {
            return Err(TwipError::InvalidParameter { name: "waypoints", value: n as f64, reason: "needs at least 2 points" });
        }
        if n > MAX_WAYPOINTS {
            return Err(TwipError::InvalidParameter { name: "waypoints", value: n as f64, reason: "at most 16 points" });
        }
        for p in points {
            for v in p {
                if !v.is_finite() {
                    return Err(invalid("waypoints", *v, "every coordinate must be finite"));
                }
            }
        }
        let speed = positive("speed", speed)?;
        if !(corner_radius.is_finite() && corner_radius >= T::zero()) {
            return Err(invalid("corner_radius", corner_radius, "must be finite and >= 0"));
        }
        // Legs: length and heading.
        let mut lengths = [T::zero(); MAX_WAYPOINTS];
        let mut headings = [T::zero(); MAX_WAYPOINTS];
        for i in 0..n - 1 {
            let (dx, dy) = (points[i + 1][0] - points[i][0], points[i + 1][1] - points[i][1]);
            lengths[i] = dx.hypot(dy);
            if lengths[i] == T::zero() {
                return Err(invalid("waypoints", lengths[i], "consecutive points must differ"));
            }
            headings[i] = dy.atan2(dx);
        }
        // Corner i (between legs i and i + 1): arc radius, turn, and the tangent length it
        // cuts from both legs.
        let mut arcs = [(T::zero(), T::zero()); MAX_WAYPOINTS];
        let mut cut = [T::zero(); MAX_WAYPOINTS];
        for i in 0..n.saturating_sub(2) {
            let turn = wrap_angle(headings[i + 1] - headings[i]);
            let half = (turn.abs() * c::<T>(0.5)).tan();
            let mut rho = T::zero();
            if half > T::zero() && corner_radius > T::zero() {
                rho = corner_radius.min(c::<T>(0.5) * lengths[i].min(lengths[i + 1]) / half);
                // Near a reversal the fitted arc shrinks to nothing (3e-17 m at 180°: a yaw
                // rate of 3e16 rad/s) while still cutting half of each leg, so the path turned
                // back half-way: such a corner is sharp, at the waypoint.
                if rho < c::<T>(MIN_CORNER_SHARE) * corner_radius {
                    rho = T::zero();
                }
            }
            arcs[i] = (rho, turn);
            cut[i] = rho * half;
        }
        let z = T::zero();
        let mut pieces = [Piece { start: z, length: z, x: z, y: z, heading: z, curvature: z }; MAX_PIECES];
        let (mut count, mut s) = (0, T::zero());
        for i in 0..n - 1 {
            let (sin, cos) = headings[i].sin_cos();
            let cut_in = if i > 0 { cut[i - 1] } else { T::zero() };
            let cut_out = if i + 2 < n { cut[i] } else { T::zero() };
            let straight = lengths[i] - cut_in - cut_out;
            let (x0, y0) = (points[i][0] + cut_in * cos, points[i][1] + cut_in * sin);
            pieces[count] = Piece { start: s, length: straight, x: x0, y: y0, heading: headings[i], curvature: T::zero() };
            count += 1;
            s += straight;
            let (rho, turn) = arcs[i];
            if i + 2 < n && rho > T::zero() {
                let arc = rho * turn.abs();
                pieces[count] = Piece {
                    start: s,
                    length: arc,
                    x: x0 + straight * cos,
                    y: y0 + straight * sin,
                    heading: headings[i],
                    curvature: turn.signum() / rho,
                };
                count += 1;
                s += arc;
            }
        }
        let mut stored = [[T::zero(); 2]; MAX_WAYPOINTS];
        stored[..n].copy_from_slice(points);
        Ok(Self { points: stored, count: n, speed, corner_radius, pieces, n_pieces: count, length: s })
    }

    pub fn points(&self) -> &[[T; 2]] {
        &self.points[..self.count]
    }

    pub fn speed(&self) -> T {
        self.speed
    }

    pub fn corner_radius(&self) -> T {
        self.corner_radius
    }

    /// Length of the (rounded) path [m].
    pub fn length(&self) -> T {
        self.length
    }

    /// Time to the last point [s].
    pub fn duration(&self) -> T {
        self.length / self.speed
    }

    fn pieces(&self) -> &[Piece<T>] {
        &self.pieces[..self.n_pieces]
    }
}

impl<T: Real> Reference<T> for Waypoints<T> {
    type Sample = PlanarRef<T>;

    fn sample(&self, t: T) -> PlanarRef<T> {
        let s = self.speed * t;
        let pieces = self.pieces();
        if s >= self.length {
            let last = pieces[pieces.len() - 1];
            let (x, y, psi) = last.at(last.length);
            let z = T::zero();
            return PlanarRef { x, y, psi, v: z, omega: z, v_dot: z, omega_dot: z };
        }
        // The last piece that has started (pieces are few: a linear scan).
        let piece = pieces.iter().rev().find(|p| p.start <= s).unwrap_or(&pieces[0]);
        let (x, y, psi) = piece.at((s - piece.start).max(T::zero()));
        PlanarRef { x, y, psi, v: self.speed, omega: self.speed * piece.curvature, v_dot: T::zero(), omega_dot: T::zero() }
    }
}

impl<T: Real> Path<T> for Waypoints<T> {
    fn distance(&self, x: T, y: T) -> T {
        self.pieces().iter().fold(T::one() / T::zero(), |best, p| best.min(p.distance(x, y)))
    }
}

// --- any of them -----------------------------------------------------------------------------

/// Any trajectory, so that one runner serves them all.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Trajectory<T> {
    Circle(Circle<T>),
    Line(Line<T>),
    FigureEight(FigureEight<T>),
    Waypoints(Waypoints<T>),
}

impl<T: Real> Trajectory<T> {
    /// One lap of a closed trajectory [s]; `None` for a line or waypoints.
    pub fn period(&self) -> Option<T> {
        match self {
            Self::Circle(c) => Some(c.period()),
            Self::FigureEight(f) => Some(f.period()),
            Self::Line(_) | Self::Waypoints(_) => None,
        }
    }
}

impl<T: Real> Reference<T> for Trajectory<T> {
    type Sample = PlanarRef<T>;

    #[inline]
    fn sample(&self, t: T) -> PlanarRef<T> {
        match self {
            Self::Circle(r) => r.sample(t),
            Self::Line(r) => r.sample(t),
            Self::FigureEight(r) => r.sample(t),
            Self::Waypoints(r) => r.sample(t),
        }
    }
}

impl<T: Real> Path<T> for Trajectory<T> {
    fn distance(&self, x: T, y: T) -> T {
        match self {
            Self::Circle(r) => r.distance(x, y),
            Self::Line(r) => r.distance(x, y),
            Self::FigureEight(r) => r.distance(x, y),
            Self::Waypoints(r) => r.distance(x, y),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    fn close(a: f64, b: f64, tol: f64) -> bool {
        (a - b).abs() <= tol * b.abs().max(1.0)
    }

    /// Central differences of the sample in time agree with its own derivatives.
    fn check_derivatives<R: Reference<f64, Sample = PlanarRef<f64>>>(r: &R, t: f64) {
        let h = 1e-5;
        let (a, b, m) = (r.sample(t - h), r.sample(t + h), r.sample(t));
        let d = |f: fn(&PlanarRef<f64>) -> f64| (f(&b) - f(&a)) / (2.0 * h);
        assert!(close(d(|s| s.x), m.v * m.psi.cos(), 1e-7), "x_dot at {t}");
        assert!(close(d(|s| s.y), m.v * m.psi.sin(), 1e-7), "y_dot at {t}");
        assert!(close(d(|s| s.psi), m.omega, 1e-7), "psi_dot at {t}");
        assert!(close(d(|s| s.v), m.v_dot, 1e-6), "v_dot at {t}");
        assert!(close(d(|s| s.omega), m.omega_dot, 1e-6), "omega_dot at {t}");
    }

    #[test]
    fn circle_starts_at_the_origin_and_laps() {
        let c = Circle::from_origin(0.45, PI / 30.0, Direction::CounterClockwise).unwrap();
        let s = c.sample(0.0);
        assert!(s.x.abs() < 1e-15 && s.y.abs() < 1e-15 && s.psi.abs() < 1e-15);
        assert!(close(s.omega, PI / 13.5, 1e-14), "the thesis's yaw rate");
        let lap = c.sample(c.period());
        assert!(lap.x.abs() < 1e-12 && lap.y.abs() < 1e-12 && close(lap.psi, 2.0 * PI, 1e-12));
        let cw = Circle::from_origin(0.6, 0.1, Direction::Clockwise).unwrap();
        assert!(cw.sample(1.0).y < 0.0 && cw.sample(1.0).omega < 0.0);
        for t in [0.3, 7.0, 20.0] {
            check_derivatives(&c, t);
            check_derivatives(&cw, t);
            assert!(c.distance(c.sample(t).x, c.sample(t).y) < 1e-12);
        }
    }

    #[test]
    fn line_and_figure_eight_derivatives() {
        let l = Line::new([1.0, -2.0], 0.7, 0.3).unwrap();
        check_derivatives(&l, 4.0);
        assert!(close(l.distance(1.0 - 0.7f64.sin(), -2.0 + 0.7f64.cos()), 1.0, 1e-14));
        let f = FigureEight::new([0.5, 0.5], 1.0, 40.0).unwrap();
        let mut t = 0.0;
        while t < 80.0 {
            check_derivatives(&f, t);
            let s = f.sample(t);
            assert!(s.psi >= -1.25 * PI - 1e-12 && s.psi <= 0.25 * PI + 1e-12);
            assert!(f.distance(s.x, s.y) < 1e-9);
            t += 0.37;
        }
        // A point off the curve: the distance matches a dense scan.
        let (px, py) = (0.9, 0.9);
        let dense = (0..100_000)
            .map(|k| {
                let s = f.sample(40.0 * k as f64 / 100_000.0);
                (s.x - px).hypot(s.y - py)
            })
            .fold(f64::INFINITY, f64::min);
        assert!(close(f.distance(px, py), dense, 1e-6));
    }

    #[test]
    fn a_line_beyond_range_moves_only_along_itself() {
        // speed * t overflows: x is infinite, y stays at its start (inf * 0 would be NaN).
        let l = Line::new([0.5, -2.0], 0.0, 1e300).unwrap();
        let s = l.sample(1e300);
        assert!(s.x == f64::INFINITY && s.y == -2.0);
        let back = Line::new([0.5, -2.0], PI, 1e300).unwrap();
        let s = back.sample(1e300);
        // sin(pi) is 1.2e-16, not 0: both overflow, neither is NaN.
        assert!(s.x == f64::NEG_INFINITY && s.y == f64::INFINITY);
        // Within range the sample is the product it always was.
        let l = Line::new([1.0, -2.0], 0.0, 0.3).unwrap();
        assert_eq!(l.sample(4.0).x, 1.0 + 0.3 * 4.0 * 1.0);
        assert_eq!(l.sample(4.0).y, -2.0);
    }

    #[test]
    fn waypoints_round_their_corners() {
        let pts = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]];
        let w = Waypoints::new(&pts, 0.1, 0.2).unwrap();
        // Two quarter arcs of 0.2 m replace 2 × 0.4 m of corner.
        assert!(close(w.length(), 3.0 - 0.8 + PI * 0.2, 1e-12));
        let mut prev = w.sample(0.0);
        let dt = 1e-3;
        let mut t = dt;
        while t < w.duration() {
            let s = w.sample(t);
            // Continuous position and heading.
            assert!((s.x - prev.x).hypot(s.y - prev.y) <= 0.1 * dt * 1.0001, "jump at {t}");
            assert!((s.psi - prev.psi).abs() <= 0.5 * dt * 1.0001, "heading jump at {t}");
            assert!(w.distance(s.x, s.y) < 1e-9);
            prev = s;
            t += dt;
        }
        let end = w.sample(1e3);
        assert!(close(end.x, 0.0, 1e-12) && close(end.y, 1.0, 1e-12) && end.v == 0.0);
        assert!(close(w.distance(0.5, 0.5), 0.5, 1e-12));
        // Sharp corners: the heading jumps by a quarter turn.
        let sharp = Waypoints::new(&pts, 0.1, 0.0).unwrap();
        assert!(close(sharp.length(), 3.0, 1e-12));
        assert!(close(sharp.sample(10.0 + 1e-9).psi, PI / 2.0, 1e-9));
    }

    #[test]
    fn a_reversal_is_a_sharp_corner_at_its_waypoint_not_a_turn_half_way() {
        // Rounded, the arc of a 180° corner was 3e-17 m (a yaw rate of 3e16 rad/s) and cut
        // half of each leg: the path was 1 m long and turned back at x = 0.5.
        for last in [[0.0, 0.0], [0.0, 1e-9]] {
            let w = Waypoints::new(&[[0.0, 0.0], [1.0, 0.0], last], 1.0, 0.1).unwrap();
            assert!(close(w.length(), 1.0 + 1.0f64.hypot(last[1]), 1e-12), "{}", w.length());
            let at = w.sample(1.0 - 1e-9);
            assert!(close(at.x, 1.0, 1e-6) && at.omega.abs() < 1.0, "{at:?}");
        }
        // A tight corner that still fits keeps its (smaller) arc.
        let tight = Waypoints::new(&[[0.0, 0.0], [1.0, 0.0], [0.0, 0.1]], 1.0, 0.1).unwrap();
        assert!(tight.length() < 1.0 + 1.0f64.hypot(0.1) - 1e-3);
    }

    #[test]
    fn degenerate_references_are_named() {
        let name = |e: TwipError| match e {
            TwipError::InvalidParameter { name, .. } => name,
            _ => "",
        };
        assert_eq!(name(Circle::from_origin(0.0, 1.0, Direction::Clockwise).unwrap_err()), "radius");
        assert_eq!(name(Circle::from_origin(1.0, -1.0, Direction::Clockwise).unwrap_err()), "speed");
        assert_eq!(name(Line::new([0.0, f64::NAN], 0.0, 1.0).unwrap_err()), "start");
        assert_eq!(name(FigureEight::new([0.0, 0.0], 1.0, 0.0).unwrap_err()), "period");
        // Its samples were inf and NaN from the start.
        assert_eq!(name(FigureEight::new([0.0, 0.0], 1.0, 1e-200).unwrap_err()), "period");
        // 1e-60 passed a bound on half_width (2π/period)⁴ and sampled an infinite omega_dot.
        assert_eq!(name(FigureEight::new([0.0, 0.0], 1.0, 1e-60).unwrap_err()), "period");
        assert!(FigureEight::new([0.0, 0.0], 1.0, 1e-20).is_ok());
        assert_eq!(name(Waypoints::new(&[[0.0, 0.0]], 1.0, 0.0).unwrap_err()), "waypoints");
        assert_eq!(name(Waypoints::new(&[[0.0, 0.0], [f64::INFINITY, 0.0]], 1.0, 0.0).unwrap_err()), "waypoints");
        assert_eq!(name(Waypoints::new(&[[0.0, 0.0], [0.0, 0.0]], 1.0, 0.0).unwrap_err()), "waypoints");
        assert_eq!(name(Waypoints::new(&[[0.0, 0.0], [1.0, 0.0]], 0.0, 0.0).unwrap_err()), "speed");
        assert_eq!(name(Waypoints::new(&[[0.0, 0.0], [1.0, 0.0]], 1.0, -1.0).unwrap_err()), "corner_radius");
    }

    #[test]
    fn wrap_angle_is_in_range() {
        for a in [-10.0, -PI, -1.0, 0.0, 1.0, PI, 7.0, 100.0] {
            let w = wrap_angle(a);
            assert!((-PI..PI).contains(&w) && close((a - w) / (2.0 * PI), ((a - w) / (2.0 * PI)).round(), 1e-12));
        }
    }
}
