//! Ground shapes for the 3-DOF model: a height z = h(x, y) [m] over the horizontal plane
//! and its gradient, which give the local plane the robot stands on (docs/terrain.md).
//!
//! A plane, a ramp (level ground, then a plane past a line, the grade rising smoothly
//! over a blend length), an egg-crate of bumps, and a height map on a rectangular grid
//! with a C¹ bicubic Hermite interpolant (needs `alloc`). Off a grid there is no ground:
//! [`Terrain::local`] says so (None), it never extrapolates.
#[cfg(feature = "alloc")]
use alloc::{sync::Arc, vec::Vec};

use crate::{c, Real, TwipError};

/// The ground under one point: its height and gradient (∂h/∂x, ∂h/∂y).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Local<T> {
    pub height: T,
    pub gx: T,
    pub gy: T,
}

/// A ground shape; `Plane` with a zero slope is flat ground.
#[derive(Clone, Debug, PartialEq)]
pub enum Terrain<T> {
    /// h = gx x + gy y: `slope` [rad] up towards `uphill_heading` [rad].
    Plane { gx: T, gy: T },
    /// Level before the line s = `start` (s the distance along the uphill heading (ux, uy)),
    /// then a plane of grade `grade` = tan(slope); the grade rises as a cubic smoothstep
    /// over `blend` metres past the line (0: a kink).
    Ramp { ux: T, uy: T, start: T, grade: T, blend: T },
    /// h = (height / 2) sin(k x) sin(k y), k = 2π / wavelength: crests and hollows
    /// `height` apart, level at the origin.
    Bumps { half_height: T, k: T },
    /// A height map (see [`Grid`]).
    #[cfg(feature = "alloc")]
    Grid(Arc<Grid<T>>),
}

fn bad(name: &'static str, value: f64, reason: &'static str) -> TwipError {
    TwipError::InvalidParameter { name, value, reason }
}

/// A slope in [0, 90°), finite.
fn check_slope<T: Real>(slope: T) -> Result<T, TwipError> {
    if !slope.is_finite() || slope < T::zero() || slope >= T::frac_pi_2() {
        return Err(bad("slope", crate::to_f64(slope), "must be finite and in [0, pi/2) rad (a slope of 90 degrees or more is a wall)"));
    }
    Ok(slope)
}

fn check_finite<T: Real>(name: &'static str, v: T) -> Result<T, TwipError> {
    if !v.is_finite() {
        return Err(bad(name, crate::to_f64(v), "must be finite"));
    }
    Ok(v)
}

impl<T: Real> Terrain<T> {
    /// Level ground.
    pub fn flat() -> Self {
        Terrain::Plane { gx: T::zero(), gy: T::zero() }
    }

    /// A plane rising at `slope` [rad] towards `uphill_heading` [rad, from +x].
    pub fn plane(slope: T, uphill_heading: T) -> Result<Self, TwipError> {
        let tan = check_slope(slope)?.tan();
        let (s, co) = check_finite("uphill_heading", uphill_heading)?.sin_cos();
        Ok(Terrain::Plane { gx: tan * co, gy: tan * s })
    }

    /// Level ground up to the line `start` metres from the origin along `uphill_heading`,
    /// then a plane of `slope`; the grade reaches it `blend` metres past the line.
    pub fn ramp(slope: T, uphill_heading: T, start: T, blend: T) -> Result<Self, TwipError> {
        let grade = check_slope(slope)?.tan();
        let (uy, ux) = check_finite("uphill_heading", uphill_heading)?.sin_cos();
        check_finite("start", start)?;
        if !blend.is_finite() || blend < T::zero() {
            return Err(bad("blend", crate::to_f64(blend), "must be finite and >= 0 m"));
        }
        Ok(Terrain::Ramp { ux, uy, start, grade, blend })
    }

    /// An egg-crate of bumps `height` [m] from hollow to crest, `wavelength` [m] apart.
    pub fn bumps(height: T, wavelength: T) -> Result<Self, TwipError> {
        if !height.is_finite() || height < T::zero() {
            return Err(bad("height", crate::to_f64(height), "must be finite and >= 0 m"));
        }
        if !wavelength.is_finite() || wavelength <= T::zero() {
            return Err(bad("wavelength", crate::to_f64(wavelength), "must be finite and > 0 m"));
        }
        let k = c::<T>(core::f64::consts::TAU) / wavelength;
        Ok(Terrain::Bumps { half_height: height * c::<T>(0.5), k })
    }

    /// The ground at (x, y), or None off the terrain (outside a grid).
    #[inline(always)]
    pub fn local(&self, x: T, y: T) -> Option<Local<T>> {
        match self {
            Terrain::Plane { gx, gy } => Some(Local { height: *gx * x + *gy * y, gx: *gx, gy: *gy }),
            Terrain::Ramp { ux, uy, start, grade, blend } => {
                let s = *ux * x + *uy * y - *start;
                let (height, slope) = ramp_profile(s, *grade, *blend);
                Some(Local { height, gx: slope * *ux, gy: slope * *uy })
            }
            Terrain::Bumps { half_height, k } => {
                let (sx, cx) = (*k * x).sin_cos();
                let (sy, cy) = (*k * y).sin_cos();
                Some(Local { height: *half_height * sx * sy, gx: *half_height * *k * cx * sy, gy: *half_height * *k * sx * cy })
            }
            #[cfg(feature = "alloc")]
            Terrain::Grid(g) => g.local(x, y),
        }
    }

    /// The ground's local plane at (x, y) clamped onto the terrain (a grid's edge): what an
    /// RK4 stage past the edge sees during the step that ends the run off the grid.
    #[inline(always)]
    pub(crate) fn local_clamped(&self, x: T, y: T) -> Local<T> {
        match self {
            #[cfg(feature = "alloc")]
            Terrain::Grid(g) => g.local(clamp(x, g.x[0], g.x[g.x.len() - 1]), clamp(y, g.y[0], g.y[g.y.len() - 1])).unwrap_or(Local { height: T::zero(), gx: T::zero(), gy: T::zero() }),
            _ => self.local(x, y).unwrap_or(Local { height: T::zero(), gx: T::zero(), gy: T::zero() }),
        }
    }

    /// Whether (x, y) is on the terrain (always, except off a grid).
    pub fn contains(&self, x: T, y: T) -> bool {
        self.local(x, y).is_some()
    }
}

#[cfg(feature = "alloc")]
fn clamp<T: Real>(v: T, lo: T, hi: T) -> T {
    // A NaN passes through (every comparison is false).
    if v < lo {
        lo
    } else if v > hi {
        hi
    } else {
        v
    }
}

/// The ramp's height and grade at distance `s` past its line: a cubic smoothstep of the
/// grade over the blend, S(u) = 3u² − 2u³, whose integral is u³ − u⁴/2.
#[inline(always)]
fn ramp_profile<T: Real>(s: T, grade: T, blend: T) -> (T, T) {
    if s <= T::zero() {
        return (T::zero(), T::zero());
    }
    if s >= blend {
        // Past the blend: the plane, continuing the blend's height (blend/2 of grade lost).
        return (grade * (s - blend * c::<T>(0.5)), grade);
    }
    let u = s / blend;
    let u2 = u * u;
    let slope = grade * u2 * (c::<T>(3.0) - c::<T>(2.0) * u);
    let height = grade * blend * u2 * u * (T::one() - c::<T>(0.5) * u);
    (height, slope)
}

/// A height map z[i][j] at (x[i], y[j]) with a bicubic Hermite interpolant: the slopes at
/// the nodes by finite differences (central inside, one-sided at the edges), so the height
/// and its gradient are continuous (C¹) and the interpolant passes through every node.
#[cfg(feature = "alloc")]
#[derive(Clone, Debug, PartialEq)]
pub struct Grid<T> {
    x: Vec<T>,
    y: Vec<T>,
    /// Per node, row-major (i over x, j over y): z, ∂z/∂x, ∂z/∂y, ∂²z/∂x∂y.
    nodes: Vec<[T; 4]>,
}

#[cfg(feature = "alloc")]
impl<T: Real> Grid<T> {
    /// The grid from axes `x`, `y` (each at least 2 points, strictly increasing, finite)
    /// and heights `z` (`x.len() * y.len()` values, row-major: z[i * y.len() + j] at
    /// (x[i], y[j]), finite).
    pub fn new(x: Vec<T>, y: Vec<T>, z: &[T]) -> Result<Self, TwipError> {
        for (name, axis) in [("x", &x), ("y", &y)] {
            if axis.len() < 2 {
                return Err(bad(name, axis.len() as f64, "a grid axis needs at least 2 points"));
            }
            if let Some(v) = axis.iter().find(|v| !v.is_finite()) {
                return Err(bad(name, crate::to_f64(*v), "grid coordinates must be finite"));
            }
            if let Some(w) = axis.windows(2).find(|w| w[1] <= w[0]) {
                return Err(bad(name, crate::to_f64(w[1]), "grid coordinates must be strictly increasing"));
            }
        }
        let (nx, ny) = (x.len(), y.len());
        if z.len() != nx * ny {
            return Err(TwipError::Shape { name: "z", expected: (nx, ny), got: (z.len(), 1) });
        }
        if let Some(v) = z.iter().find(|v| !v.is_finite()) {
            return Err(bad("z", crate::to_f64(*v), "grid heights must be finite (no NaN)"));
        }
        let at = |i: usize, j: usize| z[i * ny + j];
        // d/dx at node i of any column `f(i)`: central inside, one-sided at the ends.
        let diff = |axis: &[T], i: usize, f: &dyn Fn(usize) -> T| {
            let (lo, hi) = (i.saturating_sub(1), (i + 1).min(axis.len() - 1));
            (f(hi) - f(lo)) / (axis[hi] - axis[lo])
        };
        let mut zx = Vec::with_capacity(nx * ny);
        for i in 0..nx {
            for j in 0..ny {
                zx.push(diff(&x, i, &|k| at(k, j)));
            }
        }
        let mut nodes = Vec::with_capacity(nx * ny);
        for i in 0..nx {
            for j in 0..ny {
                let zy = diff(&y, j, &|k| at(i, k));
                let zxy = diff(&y, j, &|k| zx[i * ny + k]);
                nodes.push([at(i, j), zx[i * ny + j], zy, zxy]);
            }
        }
        Ok(Self { x, y, nodes })
    }

    /// The axes' extents: ((x_min, x_max), (y_min, y_max)).
    pub fn extent(&self) -> ((T, T), (T, T)) {
        ((self.x[0], self.x[self.x.len() - 1]), (self.y[0], self.y[self.y.len() - 1]))
    }

    /// Height and gradient at (x, y), None outside the grid (or at NaN).
    pub fn local(&self, x: T, y: T) -> Option<Local<T>> {
        let (i, u, hx) = cell(&self.x, x)?;
        let (j, v, hy) = cell(&self.y, y)?;
        let ny = self.y.len();
        let n = |di: usize, dj: usize| self.nodes[(i + di) * ny + j + dj];
        // Hermite bases and their derivatives in u and v; the slopes scale by the cell size.
        let (bu, du) = hermite(u);
        let (bv, dv) = hermite(v);
        let (mut z, mut zx, mut zy) = (T::zero(), T::zero(), T::zero());
        for (di, dj) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
            let [f, fx, fy, fxy] = n(di, dj);
            // Per corner: value, x-slope, y-slope, twist, with the bases of that corner.
            let (a0, a1, d0, d1) = (bu[2 * di], bu[2 * di + 1] * hx, du[2 * di], du[2 * di + 1] * hx);
            let (b0, b1, e0, e1) = (bv[2 * dj], bv[2 * dj + 1] * hy, dv[2 * dj], dv[2 * dj + 1] * hy);
            z += f * a0 * b0 + fx * a1 * b0 + fy * a0 * b1 + fxy * a1 * b1;
            zx += (f * d0 * b0 + fx * d1 * b0 + fy * d0 * b1 + fxy * d1 * b1) / hx;
            zy += (f * a0 * e0 + fx * a1 * e0 + fy * a0 * e1 + fxy * a1 * e1) / hy;
        }
        Some(Local { height: z, gx: zx, gy: zy })
    }
}

/// The cell of `axis` holding `v`: its index, the position in it in [0, 1] and its width.
#[cfg(feature = "alloc")]
fn cell<T: Real>(axis: &[T], v: T) -> Option<(usize, T, T)> {
    let (first, last) = (axis[0], axis[axis.len() - 1]);
    if !(v >= first && v <= last) {
        return None;
    }
    // The last i with axis[i] <= v, kept below the last node.
    let i = axis.partition_point(|a| *a <= v).saturating_sub(1).min(axis.len() - 2);
    let h = axis[i + 1] - axis[i];
    Some((i, (v - axis[i]) / h, h))
}

/// The cubic Hermite bases at u in [0, 1] (value at 0, slope at 0, value at 1, slope at 1)
/// and their derivatives in u.
#[cfg(feature = "alloc")]
fn hermite<T: Real>(u: T) -> ([T; 4], [T; 4]) {
    let (u2, one, two, three) = (u * u, T::one(), c::<T>(2.0), c::<T>(3.0));
    let u3 = u2 * u;
    let six = c::<T>(6.0);
    (
        [two * u3 - three * u2 + one, u3 - two * u2 + u, three * u2 - two * u3, u3 - u2],
        [six * u2 - six * u, three * u2 - c::<T>(4.0) * u + one, six * u - six * u2, three * u2 - two * u],
    )
}

// The grid needs a heap; the std build runs these.
#[cfg(all(test, feature = "alloc"))]
mod tests {
    use super::*;

    /// The gradient each terrain reports is its height's derivative (central differences).
    #[test]
    fn gradients_are_the_heights_derivatives() {
        let mut terrains = alloc::vec![
            Terrain::plane(0.2, 0.7).unwrap(),
            Terrain::ramp(0.15, -0.4, 0.3, 0.5).unwrap(),
            Terrain::bumps(0.05, 1.3).unwrap(),
        ];
        let xs: Vec<f64> = (0..7).map(|i| -1.0 + 0.37 * i as f64 + 0.01 * (i * i) as f64).collect();
        let ys: Vec<f64> = (0..5).map(|j| -0.8 + 0.45 * j as f64).collect();
        let z: Vec<f64> = xs.iter().flat_map(|x| ys.iter().map(move |y| (1.3 * x).sin() * (0.9 * y).cos() * 0.1)).collect();
        terrains.push(Terrain::Grid(Arc::new(Grid::new(xs, ys, &z).unwrap())));
        let h = 1e-6;
        for t in &terrains {
            for k in 0..40 {
                let (x, y) = (-0.9 + 0.043 * k as f64, -0.7 + 0.031 * k as f64);
                let l = t.local(x, y).unwrap();
                let gx = (t.local(x + h, y).unwrap().height - t.local(x - h, y).unwrap().height) / (2.0 * h);
                let gy = (t.local(x, y + h).unwrap().height - t.local(x, y - h).unwrap().height) / (2.0 * h);
                assert!((gx - l.gx).abs() < 1e-7 && (gy - l.gy).abs() < 1e-7, "{t:?} at ({x}, {y}): {gx} {gy} vs {l:?}");
            }
        }
    }

    #[test]
    fn grid_passes_through_its_nodes_and_ends_at_its_edges() {
        let (xs, ys) = (alloc::vec![0.0, 1.0, 3.0], alloc::vec![-1.0, 0.0]);
        let z = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0];
        let g = Grid::new(xs.clone(), ys.clone(), &z).unwrap();
        for (i, x) in xs.iter().enumerate() {
            for (j, y) in ys.iter().enumerate() {
                assert_eq!(g.local(*x, *y).unwrap().height, z[i * 2 + j]);
            }
        }
        assert!(g.local(3.0 + 1e-12, 0.0).is_none() && g.local(0.5, -1.0 - 1e-12).is_none() && g.local(f64::NAN, 0.0).is_none());
        // A plane's heights give back the plane.
        let zp: Vec<f64> = xs.iter().flat_map(|x| ys.iter().map(move |y| 0.3 * x - 0.2 * y)).collect();
        let l = Grid::new(xs, ys, &zp).unwrap().local(2.2, -0.4).unwrap();
        assert!((l.height - (0.66 + 0.08)).abs() < 1e-15 && (l.gx - 0.3).abs() < 1e-15 && (l.gy + 0.2).abs() < 1e-15);
    }

    #[test]
    fn bad_terrains_are_refused_by_name() {
        let name = |e: TwipError| match e {
            TwipError::InvalidParameter { name, .. } | TwipError::Shape { name, .. } => name,
            other => panic!("{other:?}"),
        };
        assert_eq!(name(Terrain::plane(core::f64::consts::FRAC_PI_2, 0.0).unwrap_err()), "slope");
        assert_eq!(name(Terrain::plane(f64::NAN, 0.0).unwrap_err()), "slope");
        assert_eq!(name(Terrain::plane(0.1, f64::INFINITY).unwrap_err()), "uphill_heading");
        assert_eq!(name(Terrain::ramp(2.0, 0.0, 0.0, 0.1).unwrap_err()), "slope");
        assert_eq!(name(Terrain::ramp(0.1, 0.0, 0.0, -0.1).unwrap_err()), "blend");
        assert_eq!(name(Terrain::bumps(0.1, 0.0).unwrap_err()), "wavelength");
        assert_eq!(name(Grid::new(alloc::vec![0.0, 0.0], alloc::vec![0.0, 1.0], &[0.0; 4]).unwrap_err()), "x");
        assert_eq!(name(Grid::new(alloc::vec![0.0, 1.0], alloc::vec![1.0, 0.5], &[0.0; 4]).unwrap_err()), "y");
        assert_eq!(name(Grid::new(alloc::vec![0.0, 1.0], alloc::vec![0.0, 1.0], &[0.0, f64::NAN, 0.0, 0.0]).unwrap_err()), "z");
        assert_eq!(name(Grid::new(alloc::vec![0.0, 1.0], alloc::vec![0.0, 1.0], &[0.0; 3]).unwrap_err()), "z");
    }
}
