//! Solid volume of spheres per lattice cell (seed 002, "Two-way coupling algorithm": "local
//! porosity values are first obtained for each lattice cell"), in two variants:
//!
//! * [`Overlap::Exact`]: the exact volume of sphere ∩ cube, V = ∫ A(z) dz with A(z) the exact
//!   area of the disc of radius sqrt(r^2 - (z - z_c)^2) inside the cell's square (closed form
//!   in x from the antiderivative of sqrt(r^2 - x^2)), integrated in z by Gauss–Legendre
//!   between the breakpoints where the disc's radius reaches an edge or a corner of the square.
//!   Each piece [p, q] is mapped by z = (p + q)/2 - (q - p)/2 cos(theta), which turns the
//!   (z - p)^(3/2) behaviour of A at a breakpoint (and the sqrt of the sphere's pole) into a
//!   smooth integrand at the ends. The pole of the disc radius (rho = 0 at z = +-r, where
//!   acos(d / rho) has a log singularity) can lie just outside a piece and slows the
//!   convergence: 12 nodes give ~4e-11 of the sphere volume, 24 nodes (used) ~1e-13. The
//!   volumes of one sphere over all cells add up to 4/3 pi r^3 to within 1e-12.
//! * [`Overlap::SeedLens`]: the seed's variant, "analytically in spheres of volumes equal to the
//!   LB cell": the lens volume of the particle with the sphere of volume dx^3 centred on the
//!   cell (closed form). These do not add up to the particle volume (the cell spheres overlap
//!   and leave gaps); the coupling normalises its weights by their sum.
//!
//! Periodic images in x, y and z: a sphere crossing a face of the box counts in the cells on
//! the other side.

use std::f64::consts::PI;
use std::sync::OnceLock;

/// How a sphere's volume is shared among cells.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Overlap {
    Exact,
    SeedLens,
}

impl Overlap {
    pub fn name(&self) -> &'static str {
        match self {
            Overlap::Exact => "exact sphere-cube",
            Overlap::SeedLens => "seed lens (sphere of cell volume)",
        }
    }
}

/// Gauss–Legendre nodes per piece of the z integral.
pub const GL_NODES: usize = 24;

/// Nodes and weights of the n-point Gauss–Legendre rule on [-1, 1] (Newton on P_n from the
/// Chebyshev guesses; Abramowitz & Stegun 25.4.29).
pub fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let mut x = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            // P_n(x) and P_n'(x) by the three-term recurrence
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                p0 = p1;
                p1 = p2;
            }
            let pn = if n == 0 { 1.0 } else { p1 };
            let pm = if n == 1 { 1.0 } else { p0 };
            dp = n as f64 * (x * pn - pm) / (x * x - 1.0);
            let dx = pn / dp;
            x -= dx;
            if dx.abs() < 1e-16 {
                break;
            }
        }
        out.push((x, 2.0 / ((1.0 - x * x) * dp * dp)));
    }
    out
}

fn gl() -> &'static [(f64, f64)] {
    static R: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    R.get_or_init(|| gauss_legendre(GL_NODES))
}

/// ∫ sqrt(r^2 - x^2) dx = (x s + r^2 atan2(x, s)) / 2 at x, with s = sqrt(r^2 - x^2) given
/// (exact at the breakpoints, where s is a rectangle side; atan2 keeps the angle accurate
/// near x = +-r, where asin(x / r) would lose half the digits).
#[inline]
fn semi_antiderivative(x: f64, s: f64, r: f64) -> f64 {
    0.5 * (x * s + r * r * x.atan2(s))
}

/// sqrt(r^2 - x^2) as sqrt((r - x)(r + x)) (no cancellation near |x| = r).
#[inline]
fn chord(r: f64, x: f64) -> f64 {
    ((r - x) * (r + x)).max(0.0).sqrt()
}

/// Exact area of the disc of radius r centred at the origin inside [a0, a1] x [b0, b1].
pub fn disc_rectangle_area(r: f64, a0: f64, a1: f64, b0: f64, b1: f64) -> f64 {
    if r <= 0.0 || a0 >= r || a1 <= -r || b0 >= r || b1 <= -r {
        return 0.0;
    }
    // breakpoints (x, s(x)): the ends of the x range, and where the chord half-height
    // s(x) = sqrt(r^2 - x^2) meets y = b, at x = +-sqrt(r^2 - b^2) with s = |b|
    let lo = if a0 <= -r {
        (-r, 0.0)
    } else {
        (a0, chord(r, a0))
    };
    let hi = if a1 >= r {
        (r, 0.0)
    } else {
        (a1, chord(r, a1))
    };
    let mut xs = [lo, hi, (0.0, 0.0), (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)];
    let mut n = 2;
    for b in [b0, b1] {
        if b.abs() < r {
            let x = chord(r, b);
            for v in [-x, x] {
                if v > lo.0 && v < hi.0 {
                    xs[n] = (v, b.abs());
                    n += 1;
                }
            }
        }
    }
    let xs = &mut xs[..n];
    xs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut area = 0.0;
    for k in 0..n - 1 {
        let (p, q) = (xs[k], xs[k + 1]);
        if q.0 <= p.0 {
            continue;
        }
        // which bound is active is constant between breakpoints: test the midpoint
        let m = 0.5 * (p.0 + q.0);
        let s = chord(r, m);
        let (upper_is_b, upper) = if b1 < s { (true, b1) } else { (false, s) };
        let (lower_is_b, lower) = if b0 > -s { (true, b0) } else { (false, -s) };
        if upper <= lower {
            continue;
        }
        let sq = semi_antiderivative(q.0, q.1, r) - semi_antiderivative(p.0, p.1, r);
        let up = if upper_is_b { b1 * (q.0 - p.0) } else { sq };
        let dn = if lower_is_b { b0 * (q.0 - p.0) } else { -sq };
        area += up - dn;
    }
    area
}

/// Exact volume of the sphere of centre `c` and radius `r` inside the box [lo, hi].
pub fn sphere_box_volume(c: [f64; 3], r: f64, lo: [f64; 3], hi: [f64; 3]) -> f64 {
    // relative to the centre
    let a = [lo[0] - c[0], hi[0] - c[0]];
    let b = [lo[1] - c[1], hi[1] - c[1]];
    let (z0, z1) = ((lo[2] - c[2]).max(-r), (hi[2] - c[2]).min(r));
    if r <= 0.0 || z0 >= z1 {
        return 0.0;
    }
    // nearest point of the box: no intersection beyond r
    let near = |l: f64, h: f64| {
        if l > 0.0 {
            l
        } else if h < 0.0 {
            -h
        } else {
            0.0
        }
    };
    let dmin2 = near(a[0], a[1]).powi(2)
        + near(b[0], b[1]).powi(2)
        + near(lo[2] - c[2], hi[2] - c[2]).powi(2);
    if dmin2 >= r * r {
        return 0.0;
    }
    let sphere = 4.0 / 3.0 * PI * r * r * r;
    if (0..3).all(|k| lo[k] - c[k] <= -r && hi[k] - c[k] >= r) {
        return sphere;
    }
    // box inside the sphere: its 8 corners within r
    let far = |l: f64, h: f64| l.abs().max(h.abs());
    let dmax2 =
        far(a[0], a[1]).powi(2) + far(b[0], b[1]).powi(2) + far(lo[2] - c[2], hi[2] - c[2]).powi(2);
    if dmax2 <= r * r {
        return (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
    }
    if let Some(v) = separate_cuts(c, r, lo, hi) {
        return v;
    }
    // breakpoints: the disc radius rho(z) = sqrt(r^2 - z^2) equals an edge or corner distance
    let mut zs: Vec<f64> = Vec::with_capacity(34);
    zs.push(z0);
    zs.push(z1);
    let mut d2s: [f64; 8] = [0.0; 8];
    let mut nd = 0;
    for v in [a[0], a[1], b[0], b[1]] {
        d2s[nd] = v * v;
        nd += 1;
    }
    for x in a {
        for y in b {
            d2s[nd] = x * x + y * y;
            nd += 1;
        }
    }
    for (k, &d2) in d2s[..nd].iter().enumerate() {
        if d2 < r * r {
            // edges: sqrt((r - d)(r + d)); corners: sqrt(r^2 - d^2)
            let z = if k < 4 {
                chord(r, d2.sqrt())
            } else {
                (r * r - d2).sqrt()
            };
            for v in [-z, z] {
                if v > z0 && v < z1 {
                    zs.push(v);
                }
            }
        }
    }
    zs.sort_by(|x, y| x.total_cmp(y));
    let rule = gl();
    let mut vol = 0.0;
    for k in 0..zs.len() - 1 {
        let (p0, q0) = (zs[k], zs[k + 1]);
        if q0 <= p0 {
            continue;
        }
        let (mid, half) = (0.5 * (p0 + q0), 0.5 * (q0 - p0));
        let mut s = 0.0;
        for &(t, w) in rule {
            // theta in [0, pi]: z = mid - half cos(theta), dz = half sin(theta) dtheta
            let th = 0.5 * PI * (t + 1.0);
            let z = mid - half * th.cos();
            let rho = chord(r, z);
            s += w * th.sin() * disc_rectangle_area(rho, a[0], a[1], b[0], b[1]);
        }
        vol += s * half * 0.5 * PI;
    }
    vol
}

/// Closed form when the faces cut the sphere independently: if no region outside two
/// adjacent faces at once meets the sphere, sphere ∩ box = sphere minus the parts beyond each
/// face, each a spherical cap pi h^2 (3r - h) / 3 (h = r - signed distance to the face).
fn separate_cuts(c: [f64; 3], r: f64, lo: [f64; 3], hi: [f64; 3]) -> Option<f64> {
    // signed distances of the centre inside each face: (axis, distance)
    let d = [
        c[0] - lo[0],
        hi[0] - c[0],
        c[1] - lo[1],
        hi[1] - c[1],
        c[2] - lo[2],
        hi[2] - c[2],
    ];
    for i in 0..6 {
        for j in (i / 2 + 1) * 2..6 {
            // faces i, j on different axes: is {beyond i} ∩ {beyond j} ∩ sphere empty?
            let (a, b) = (d[i], d[j]);
            let empty = a >= r || b >= r || (a > 0.0 && b > 0.0 && a * a + b * b >= r * r);
            if !empty {
                return None;
            }
        }
    }
    let sphere = 4.0 / 3.0 * PI * r * r * r;
    let mut v = sphere;
    for &di in &d {
        if di < r {
            let h = r - di.max(-r);
            v -= PI * h * h * (3.0 * r - h) / 3.0;
        }
    }
    Some(v.max(0.0))
}

/// Volume of the lens where spheres of radii r1, r2 at centre distance d overlap.
pub fn lens_volume(r1: f64, r2: f64, d: f64) -> f64 {
    if d >= r1 + r2 {
        return 0.0;
    }
    let rmin = r1.min(r2);
    if d <= (r1 - r2).abs() {
        return 4.0 / 3.0 * PI * rmin * rmin * rmin;
    }
    let s = r1 + r2 - d;
    PI * s * s * (d * d + 2.0 * d * (r1 + r2) - 3.0 * (r1 - r2) * (r1 - r2)) / (12.0 * d)
}

/// Radius of the sphere of volume dx^3 (the seed's cell sphere).
pub fn cell_sphere_radius(dx: f64) -> f64 {
    dx * (3.0 / (4.0 * PI)).cbrt()
}

/// The cells (index (z ny + y) nx + x of the periodic lattice `n` of spacing `dx`, lower
/// corner at the origin) that one sphere overlaps and its volume in each, pushed to `out`.
pub fn sphere_cells(
    method: Overlap,
    c: [f64; 3],
    r: f64,
    n: [usize; 3],
    dx: f64,
    out: &mut Vec<(u32, f64)>,
) {
    let reach = match method {
        Overlap::Exact => r,
        Overlap::SeedLens => r + cell_sphere_radius(dx),
    };
    let range = |k: usize| {
        let lo = ((c[k] - reach) / dx).floor() as i64;
        let hi = ((c[k] + reach) / dx).floor() as i64;
        lo..=hi
    };
    let rc = cell_sphere_radius(dx);
    for iz in range(2) {
        for iy in range(1) {
            for ix in range(0) {
                let lo = [ix as f64 * dx, iy as f64 * dx, iz as f64 * dx];
                let v = match method {
                    Overlap::Exact => {
                        sphere_box_volume(c, r, lo, [lo[0] + dx, lo[1] + dx, lo[2] + dx])
                    }
                    Overlap::SeedLens => {
                        let d = ((lo[0] + 0.5 * dx - c[0]).powi(2)
                            + (lo[1] + 0.5 * dx - c[1]).powi(2)
                            + (lo[2] + 0.5 * dx - c[2]).powi(2))
                        .sqrt();
                        lens_volume(r, rc, d)
                    }
                };
                if v > 0.0 {
                    let w = |i: i64, m: usize| i.rem_euclid(m as i64) as usize;
                    let cell = (w(iz, n[2]) * n[1] + w(iy, n[1])) * n[0] + w(ix, n[0]);
                    out.push((cell as u32, v));
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cap(r: f64, h: f64) -> f64 {
        PI * h * h * (3.0 * r - h) / 3.0
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let rule = gauss_legendre(GL_NODES);
        for k in 0..2 * GL_NODES {
            let s: f64 = rule.iter().map(|(x, w)| w * x.powi(k as i32)).sum();
            let want = if k % 2 == 1 {
                0.0
            } else {
                2.0 / (k as f64 + 1.0)
            };
            assert!((s - want).abs() < 1e-14, "x^{k}: {s} vs {want}");
        }
    }

    #[test]
    fn disc_rectangle_closed_forms() {
        let r = 0.7;
        // whole disc, half, quarter
        assert!((disc_rectangle_area(r, -1.0, 1.0, -1.0, 1.0) - PI * r * r).abs() < 1e-15);
        assert!((disc_rectangle_area(r, 0.0, 1.0, -1.0, 1.0) - 0.5 * PI * r * r).abs() < 1e-15);
        assert!((disc_rectangle_area(r, 0.0, 1.0, 0.0, 1.0) - 0.25 * PI * r * r).abs() < 1e-15);
        // circular segment cut at x = h: r^2 acos(h/r) - h sqrt(r^2 - h^2)
        let h = 0.3;
        let seg = r * r * (h / r).acos() - h * (r * r - h * h).sqrt();
        assert!((disc_rectangle_area(r, h, 2.0, -2.0, 2.0) - seg).abs() < 1e-15);
        // square inside the disc
        assert!((disc_rectangle_area(r, -0.2, 0.3, -0.1, 0.4) - 0.25).abs() < 1e-15);
    }

    #[test]
    fn sphere_box_closed_forms() {
        let r = 0.4;
        let sphere = 4.0 / 3.0 * PI * r * r * r;
        // inside a cell
        let v = sphere_box_volume([0.5, 0.5, 0.5], r, [0.0; 3], [1.0; 3]);
        assert!((v - sphere).abs() < 1e-15 * sphere, "{v} vs {sphere}");
        // centred on a corner: 1/8
        let v = sphere_box_volume([1.0, 1.0, 1.0], r, [0.0; 3], [1.0; 3]);
        assert!((v - sphere / 8.0).abs() < 1e-12 * sphere, "corner {v}");
        // centred on an edge: 1/4; on a face: 1/2
        let v = sphere_box_volume([1.0, 1.0, 0.5], r, [0.0; 3], [1.0; 3]);
        assert!((v - sphere / 4.0).abs() < 1e-12 * sphere, "edge {v}");
        let v = sphere_box_volume([0.5, 1.0, 0.5], r, [0.0; 3], [1.0; 3]);
        assert!((v - sphere / 2.0).abs() < 1e-12 * sphere, "face {v}");
        // half-space cuts in each direction: spherical caps of height h
        for (k, h) in [(0usize, 0.13), (1, 0.29), (2, 0.61)] {
            let mut c = [0.5; 3];
            c[k] = 1.0 - r + h; // the sphere pokes h beyond the face at 1
            let mut lo = [-5.0; 3];
            let hi = [5.0; 3];
            lo[k] = 1.0;
            let v = sphere_box_volume(c, r, lo, hi);
            assert!(
                (v - cap(r, h)).abs() < 1e-12 * sphere,
                "cap {k} {h}: {v} vs {}",
                cap(r, h)
            );
        }
    }

    #[test]
    fn cells_add_up_to_the_sphere_with_periodic_images() {
        let n = [5, 4, 6];
        let dx = 0.3;
        let mut out = Vec::new();
        for (c, r) in [
            ([0.05, 0.61, 1.77], 0.41),
            ([1.3, 1.19, 0.0], 0.2),
            ([0.77, 0.33, 0.91], 0.15),
            ([0.45, 0.45, 0.45], 0.3),
        ] {
            out.clear();
            sphere_cells(Overlap::Exact, c, r, n, dx, &mut out);
            let sum: f64 = out.iter().map(|e| e.1).sum();
            let want = 4.0 / 3.0 * PI * r * r * r;
            assert!(
                (sum - want).abs() < 1e-12 * want,
                "{c:?} {r}: {sum} vs {want}"
            );
            assert!(out.iter().all(|e| (e.0 as usize) < n[0] * n[1] * n[2]));
        }
    }

    #[test]
    fn lens_closed_forms() {
        // equal spheres touching: 0; coincident: the sphere; d = r for r1 = r2 = r:
        // V = 5 pi r^3 / 12
        assert_eq!(lens_volume(1.0, 1.0, 2.0), 0.0);
        assert!((lens_volume(1.0, 0.5, 0.2) - 4.0 / 3.0 * PI * 0.125).abs() < 1e-15);
        assert!((lens_volume(1.0, 1.0, 1.0) - 5.0 * PI / 12.0).abs() < 1e-15);
        // continuous at internal tangency d = r1 - r2
        let (r1, r2) = (1.0, 0.4);
        let a = lens_volume(r1, r2, 0.6 * (1.0 + 1e-12));
        assert!((a - 4.0 / 3.0 * PI * 0.064).abs() < 1e-9);
    }
}
