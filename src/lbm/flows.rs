//! Geometries and closed forms of the standard flows: the plane channel (Poiseuille, Couette),
//! the porous channel (Brinkman), the Taylor-Green vortex, the simple cubic sphere array and the
//! square array of cylinders.

use super::geometry::Dims;
use super::walls::{sphere_crossing, WallFractions};
use crate::error::Result;

/// Solid mask of a plane channel: walls are the rows y = 0 and y = ny - 1 (all x, z); with
/// halfway bounce-back the walls sit at y = 1/2 and y = ny - 3/2, width H = ny - 2.
pub fn channel_mask(d: Dims) -> Vec<bool> {
    (0..d.cells())
        .map(|c| {
            let y = d.coords(c)[1];
            y == 0 || y == d.ny - 1
        })
        .collect()
}

/// Distance of cell centre y from the lower wall of [`channel_mask`] (in cells).
pub fn channel_coordinate(y: usize) -> f64 {
    y as f64 - 0.5
}

/// Plane Poiseuille profile between walls at 0 and h under acceleration g: g y (h - y) / (2 nu).
pub fn poiseuille(y: f64, h: f64, g: f64, nu: f64) -> f64 {
    g * y * (h - y) / (2.0 * nu)
}

/// Guo & Zhao (2002) porous Poiseuille solution of the Brinkman equation (no Forchheimer
/// term, effective viscosity = nu): u = (G K / nu) [1 - cosh(r (y - H/2)) / cosh(r H/2)],
/// r = sqrt(eps / K) = sqrt(eps / (Da H^2)). Written with exponentials that cannot overflow.
pub fn brinkman_poiseuille(y: f64, h: f64, g: f64, nu: f64, eps: f64, k: f64) -> f64 {
    let r = (eps / k).sqrt();
    let s = y - 0.5 * h;
    // cosh(r s)/cosh(r h/2) = (e^{r(|s|-h/2)} + e^{-r(|s|+h/2)}) / (1 + e^{-r h})
    let ratio = ((r * (s.abs() - 0.5 * h)).exp() + (-r * (s.abs() + 0.5 * h)).exp())
        / (1.0 + (-r * h).exp());
    g * k / nu * (1.0 - ratio)
}

/// Plane Couette flow through a uniform porous medium without the Forchheimer term: the
/// Brinkman equation nu u'' - (eps nu / K) u = 0 (effective viscosity = nu, as in Guo & Zhao
/// 2002) with u(0) = 0, u(h) = U has u = U sinh(r y) / sinh(r h), r = sqrt(eps / K); written
/// as U e^{r (y - h)} (1 - e^{-2 r y}) / (1 - e^{-2 r h}), which cannot overflow.
pub fn brinkman_couette(y: f64, h: f64, u_wall: f64, eps: f64, k: f64) -> f64 {
    let r = (eps / k).sqrt();
    u_wall * (r * (y - h)).exp() * (-(-2.0 * r * y).exp_m1()) / (-(-2.0 * r * h).exp_m1())
}

/// Solid mask of one sphere of radius `radius` (cells) centred in the periodic n^3 box (a
/// simple cubic array of period n): cell (i, j, k) is solid when its centre (i + 1/2, ...)
/// lies inside.
pub fn sphere_array_mask(n: usize, radius: f64) -> Vec<bool> {
    let d = Dims {
        nx: n,
        ny: n,
        nz: n,
    };
    let c = 0.5 * n as f64;
    (0..d.cells())
        .map(|cell| {
            let p = d.coords(cell);
            let r2: f64 = p.iter().map(|&v| (v as f64 + 0.5 - c).powi(2)).sum();
            r2 < radius * radius
        })
        .collect()
}

/// The first crossing of the link from cell centre `a` along `c` (cell units) with any of the
/// 27 periodic images (period `n` in x and y, and in z unless `flat`) of the ball of radius
/// `radius` about `centre`; `flat`: the disc in the xy-plane (a cylinder along z).
fn array_crossing(
    a: [f64; 3],
    c: [i32; 3],
    (centre, radius, n, flat): ([f64; 3], f64, f64, bool),
) -> Option<f64> {
    let keep = |v: [f64; 3]| if flat { [v[0], v[1], 0.0] } else { v };
    let d = keep(c.map(|v| v as f64));
    let mut best: Option<f64> = None;
    for s in 0..27 {
        let shift = [s % 3, (s / 3) % 3, s / 9].map(|k| (k as f64 - 1.0) * n);
        if flat && shift[2] != 0.0 {
            continue;
        }
        let image = keep([0, 1, 2].map(|k| centre[k] + shift[k]));
        if let Some(t) = sphere_crossing(keep(a), d, image, radius) {
            best = Some(best.map_or(t, |b: f64| b.min(t)));
        }
    }
    best
}

/// Wall fractions of [`sphere_array_mask`]: each link's first crossing with the sphere (or a
/// periodic image), exact.
pub fn sphere_array_fractions(n: usize, radius: f64) -> Result<WallFractions> {
    let d = Dims::new(n, n, n)?;
    let c = 0.5 * n as f64;
    WallFractions::from_crossings(d, &sphere_array_mask(n, radius), |a, dir| {
        array_crossing(a, dir, ([c; 3], radius, n as f64, false))
    })
}

/// Wall fractions of [`cylinder_array_mask`]: each link's first crossing with the cylinder (or
/// a periodic image), exact.
pub fn cylinder_array_fractions(n: usize, nz: usize, radius: f64) -> Result<WallFractions> {
    let d = Dims::new(n, n, nz)?;
    let c = 0.5 * n as f64;
    WallFractions::from_crossings(d, &cylinder_array_mask(n, nz, radius), |a, dir| {
        array_crossing(a, dir, ([c, c, 0.0], radius, n as f64, true))
    })
}

/// Solid mask of one cylinder of radius `radius` (cells), axis along z, centred in the periodic
/// n x n x nz box (a square array of period n, flow transverse to the axis): cell (i, j, k) is
/// solid when its centre (i + 1/2, j + 1/2) lies inside the disc.
pub fn cylinder_array_mask(n: usize, nz: usize, radius: f64) -> Vec<bool> {
    let d = Dims { nx: n, ny: n, nz };
    let c = 0.5 * n as f64;
    (0..d.cells())
        .map(|cell| {
            let p = d.coords(cell);
            let r2 = (p[0] as f64 + 0.5 - c).powi(2) + (p[1] as f64 + 0.5 - c).powi(2);
            r2 < radius * radius
        })
        .collect()
}

/// Drummond & Tahir (1984) transverse permeability of the square array of cylinders of radius
/// a at solid fraction c, as k / a^2 = [-ln c - 1.476 + (2c - 0.796 c^2) / (1 + 0.489 c -
/// 1.605 c^2)] / (8 c) (Int. J. Multiphase Flow 10, 515; a low-concentration expansion). The
/// dimensionless drag per unit length F/(mu U) = L^2/k = 8 pi / [...] (L^2 = pi a^2 / c).
pub fn drummond_tahir_square_drag(c: f64) -> f64 {
    let bracket = -c.ln() - 1.476 + (2.0 * c - 0.796 * c * c) / (1.0 + 0.489 * c - 1.605 * c * c);
    8.0 * std::f64::consts::PI / bracket
}

/// Drag coefficient of a periodic array: K = f L^3 / (6 pi mu a U) with f the driving force
/// per unit volume, L^3 the cell volume per sphere and U the superficial velocity; equivalently
/// K = 2 a^2 / (9 phi k) with the permeability k = mu U / f (Zick & Homsy 1982, eq. 4.2).
pub fn drag_coefficient(permeability: f64, radius: f64, solid_fraction: f64) -> f64 {
    2.0 * radius * radius / (9.0 * solid_fraction * permeability)
}

/// Sangani & Acrivos (1982) dilute series for the simple cubic array, c = solid fraction:
/// K = 1 / (1 - 1.7601 c^{1/3} + c - 1.5593 c^2 + 3.9799 c^{8/3} - 3.0734 c^{10/3}); its first
/// two terms are Hasimoto's (1959).
pub fn sangani_acrivos_sc(c: f64) -> f64 {
    let t = c.cbrt();
    1.0 / (1.0 - 1.7601 * t + c - 1.5593 * c * c + 3.9799 * c * c * t * t - 3.0734 * c * c * c * t)
}

/// Fully developed flow in a rectangular duct |y| < a, |z| < b under acceleration g (kinematic
/// viscosity nu), by the Fourier series of White (Viscous Fluid Flow, 2nd ed., eq. 3-48):
/// u = (16 g a^2 / (nu pi^3)) sum_{n odd} (-1)^((n-1)/2) [1 - cosh(n pi z/2a)/cosh(n pi b/2a)]
/// cos(n pi y/2a) / n^3, written as the plane Poiseuille profile g (a^2 - y^2)/(2 nu) minus the
/// cosh series, whose terms fall as exp(-n pi (b - |z|)/2a) / n^3; summed until the bound of
/// the remaining terms is below 1e-17 of the plane profile's peak. For a square duct the
/// coordinates are swapped where that makes the series shorter (u is symmetric).
pub fn duct_series(y: f64, z: f64, a: f64, b: f64, g: f64, nu: f64) -> f64 {
    let (y, z) = if a == b && z.abs() > y.abs() {
        (z, y)
    } else {
        (y, z)
    };
    let pi = std::f64::consts::PI;
    let peak = g * a * a / (2.0 * nu);
    let pre = 16.0 * g * a * a / (nu * pi * pi * pi);
    // the plane profile's coefficient series, cosh ratio written without overflow
    let decay = (b - z.abs()) * pi / (2.0 * a);
    let mut sum = 0.0;
    let mut n = 1u64;
    loop {
        let nf = n as f64;
        let k = nf * pi / (2.0 * a);
        // cosh(k z)/cosh(k b) = (e^{k(|z|-b)} + e^{-k(|z|+b)}) / (1 + e^{-2kb})
        let ratio =
            ((k * (z.abs() - b)).exp() + (-k * (z.abs() + b)).exp()) / (1.0 + (-2.0 * k * b).exp());
        let sign = if (n / 2) % 2 == 0 { 1.0 } else { -1.0 };
        sum += sign * ratio * (k * y).cos() / (nf * nf * nf);
        // remaining terms: |t_m| <= 2 e^{-m decay}/m^3, a geometric tail in odd m >= n + 2
        let m = nf + 2.0;
        let q = (-2.0 * decay).exp();
        let tail = pre * 2.0 * (-m * decay).exp() / (m * m * m * (1.0 - q).max(1e-300));
        if tail < 1e-17 * peak || n > 2_000_000 {
            break;
        }
        n += 2;
    }
    g * (a * a - y * y) / (2.0 * nu) - pre * sum
}

/// Solid mask of a duct along x: the rows y = 0, y = ny - 1, z = 0, z = nz - 1 (walls halfway,
/// at y, z = 1/2 and n - 3/2).
pub fn duct_mask(d: Dims) -> Vec<bool> {
    (0..d.cells())
        .map(|c| {
            let p = d.coords(c);
            p[1] == 0 || p[1] == d.ny - 1 || p[2] == 0 || p[2] == d.nz - 1
        })
        .collect()
}
