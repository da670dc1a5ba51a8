//! The containers of an MCM packing (thesis sec. 2.2.4): all their geometry lives here, so a
//! new wall type touches only this file (and the cell grid's bounds in `neighbours.rs`).
//!
//! Hard walls act through virtual particles (Fig. 2.4): a particle that penetrates the wall
//! sees an identical particle on the other side of it, touching the wall from outside, and the
//! ordinary pair overlap removal pushes it back. Spheres and rods get the thesis' virtual
//! particles ([`Container::wall_virtuals`]); ellipsoids and superquadrics the same mirror
//! image in the wall's tangent plane, in closed form through their support function
//! ([`Container::convex_wall_contacts`]).

use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;

/// The simulation container.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Container {
    /// Periodic cubic box [0, L)^3 (L = `box_length`).
    Periodic,
    /// Hard cylindrical wall of fixed diameter D_cyl about the z axis through x = y = 0,
    /// periodic along z with period L = `box_length` (thesis sec. 2.2.4, Fig. 2.3 left);
    /// compression shortens L, D_cyl stays fixed. Wall overlaps are removed through virtual
    /// particles (Fig. 2.4).
    Cylinder { diameter: f64 },
    /// Hard wedge (thesis sec. 2.2.4, Fig. 2.3 right, 2.5): the right triangular prism
    /// 0 <= y <= x tan(alpha), x <= l_w, of fixed length l_w = `length` along x and height
    /// h_w = l_w tan(alpha) along y (acute edge along the z axis through the origin), periodic
    /// along z (the width w_w = `box_length`); compression narrows w_w only. Its three walls
    /// (back x = l_w, bottom y = 0, slope y = x tan(alpha)) act through virtual particles.
    Wedge { length: f64, angle_rad: f64 },
}

impl Container {
    /// Checks the container's own parameters against the particle diameter `particle_d`.
    pub fn check(&self, particle_d: f64) -> Result<()> {
        match *self {
            Container::Periodic => {}
            Container::Cylinder { diameter } => {
                if !(diameter.is_finite() && diameter > particle_d) {
                    return invalid(format!(
                        "cylinder diameter {diameter}: must be finite and larger than the \
                         particle diameter {particle_d}"
                    ));
                }
            }
            Container::Wedge { length, angle_rad } => {
                if !(angle_rad > 0.0 && angle_rad < 0.5 * std::f64::consts::PI) {
                    return invalid(format!(
                        "wedge angle {:.6} degrees: must be between 0 and 90",
                        angle_rad.to_degrees()
                    ));
                }
                let lmin = wedge_min_length(0.5 * particle_d, 0.0, angle_rad);
                if !(length.is_finite() && length > lmin) {
                    return invalid(format!(
                        "wedge length {length}: must be finite and longer than the {lmin:.6} a \
                         sphere of diameter {particle_d} needs at this angle (eq. 2.12)"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Volume of the container of length (or side) `l`.
    pub fn volume(&self, l: f64) -> f64 {
        match self {
            Container::Periodic => l.powi(3),
            Container::Cylinder { diameter } => {
                0.25 * std::f64::consts::PI * diameter * diameter * l
            }
            Container::Wedge { length, angle_rad } => 0.5 * length * length * angle_rad.tan() * l,
        }
    }

    /// The length (side) `l` at which the container has volume `v` (inverse of [`volume`]).
    ///
    /// [`volume`]: Container::volume
    pub fn length_for_volume(&self, v: f64) -> f64 {
        match self {
            Container::Periodic => v.cbrt(),
            Container::Cylinder { diameter } => {
                v / (0.25 * std::f64::consts::PI * diameter * diameter)
            }
            Container::Wedge { length, angle_rad } => v / (0.5 * length * length * angle_rad.tan()),
        }
    }

    /// Scales a position from container length `from` to `to` (compression, sec. 2.2.1): all
    /// coordinates in the cubic box, only the periodic axis in the cylinder (its diameter is
    /// fixed).
    pub fn scale_position(&self, x: &Vector3<f64>, from: f64, to: f64) -> Vector3<f64> {
        let s = to / from;
        match self {
            Container::Periodic => self.wrap(&(x * s), to),
            Container::Cylinder { .. } | Container::Wedge { .. } => {
                self.wrap(&Vector3::new(x.x, x.y, x.z * s), to)
            }
        }
    }

    /// A trial centre for a particle of radius `r` for `u` in [0, 1)^3 (uniform `u`: uniform
    /// over a region that contains every centre allowed by [`sphere_inside`], which the caller
    /// checks): the box; the cylinder's bounding square; in the wedge the triangle of centres
    /// at least r from all three walls (it is small near the minimal wedge length, eq. 2.12).
    ///
    /// [`sphere_inside`]: Container::sphere_inside
    pub fn trial_centre(&self, u: &Vector3<f64>, l: f64, r: f64) -> Vector3<f64> {
        match *self {
            Container::Periodic => u * l,
            Container::Cylinder { diameter } => {
                Vector3::new((u.x - 0.5) * diameter, (u.y - 0.5) * diameter, u.z * l)
            }
            Container::Wedge { length, angle_rad } => {
                // Vertices of the inner triangle: on y = r at the slope offset by r and at the
                // back offset by r, and the back/slope corner.
                let x0 = r / (0.5 * angle_rad).tan();
                let xb = length - r;
                let a = Vector3::new(x0, r, 0.0);
                let b = Vector3::new(xb, r, 0.0);
                let c = Vector3::new(xb, xb * angle_rad.tan() - r / angle_rad.cos(), 0.0);
                // Uniform in a triangle: fold the unit square along its diagonal.
                let (mut s, mut t) = (u.x, u.y);
                if s + t > 1.0 {
                    s = 1.0 - s;
                    t = 1.0 - t;
                }
                a + s * (b - a) + t * (c - a) + Vector3::new(0.0, 0.0, u.z * l)
            }
        }
    }

    /// True when a sphere of radius `r` at `x` does not penetrate any wall.
    pub fn sphere_inside(&self, x: &Vector3<f64>, r: f64) -> bool {
        match *self {
            Container::Periodic => true,
            Container::Cylinder { diameter } => {
                (x.x * x.x + x.y * x.y).sqrt() <= 0.5 * diameter - r
            }
            Container::Wedge { length, angle_rad } => wedge_wall_distances(x, length, angle_rad)
                .iter()
                .all(|d| *d >= r),
        }
    }

    /// The lower corner, extent and periodicity of the region the particle centres occupy
    /// (for the cell grid; centres just outside a wall fall in its edge cells).
    pub fn grid_bounds(&self, l: f64) -> ([f64; 3], [f64; 3], [bool; 3]) {
        match self {
            Container::Periodic => ([0.0; 3], [l; 3], [true; 3]),
            Container::Cylinder { diameter } => {
                let r = 0.5 * diameter;
                (
                    [-r, -r, 0.0],
                    [*diameter, *diameter, l],
                    [false, false, true],
                )
            }
            Container::Wedge { length, angle_rad } => (
                [0.0; 3],
                [*length, length * angle_rad.tan(), l],
                [false, false, true],
            ),
        }
    }

    /// Separation b - a: minimum image along the periodic directions.
    #[inline(always)]
    pub fn separation(&self, a: &Vector3<f64>, b: &Vector3<f64>, l: f64) -> Vector3<f64> {
        match self {
            Container::Periodic => (b - a).map(|d| min_image1(d, l)),
            Container::Cylinder { .. } | Container::Wedge { .. } => {
                let mut d = b - a;
                d.z = min_image1(d.z, l);
                d
            }
        }
    }

    /// Wraps a position into the periodic directions.
    pub fn wrap(&self, x: &Vector3<f64>, l: f64) -> Vector3<f64> {
        match self {
            Container::Periodic => x.map(|c| wrap1(c, l)),
            Container::Cylinder { .. } | Container::Wedge { .. } => {
                Vector3::new(x.x, x.y, wrap1(x.z, l))
            }
        }
    }

    /// Virtual particles for the wall overlaps of a particle at `x` with unit axis `a`, half
    /// cylinder length `h` (0 for a sphere) and radius `r` (thesis sec. 2.2.4, Fig. 2.4): for
    /// each end point p (the centre for a sphere) that penetrates the wall, a particle
    /// identical to it, touching the wall from outside opposite p. Pushes (centre relative to
    /// `x`, unit axis) of each onto `out` (cleared first).
    ///
    /// Cylinder: p penetrates when p_x^2 + p_y^2 > (R_cyl - R)^2; the virtual particle is
    /// aligned with the cylinder axis at the azimuth and height of p. Wedge: see the comments
    /// at each plane.
    ///
    /// An end point more than R/2 beyond a wall (possible after a large move into a narrow
    /// corner) would get a virtual particle on its inner side under the thesis' construction,
    /// which pushes it further out or, beyond R, not at all, so an escaped particle would be
    /// accepted silently. Such a virtual particle is placed R/2 beyond the end point instead:
    /// the push always points inward, and every penetration counts as an overlap, so an
    /// accepted configuration is inside its walls.
    pub fn wall_virtuals(
        &self,
        x: &Vector3<f64>,
        a: &Vector3<f64>,
        h: f64,
        r: f64,
        out: &mut Vec<(Vector3<f64>, Vector3<f64>)>,
    ) {
        out.clear();
        let ends: &[f64] = if h == 0.0 { &[0.0] } else { &[-1.0, 1.0] };
        match *self {
            Container::Periodic => {}
            Container::Cylinder { diameter } => {
                let rcyl = 0.5 * diameter;
                for &s in ends {
                    let e = x + s * h * a;
                    let rho = (e.x * e.x + e.y * e.y).sqrt();
                    if rho > rcyl - r {
                        let u = if rho > 0.0 {
                            Vector3::new(e.x / rho, e.y / rho, 0.0)
                        } else {
                            Vector3::x()
                        };
                        let c = if rcyl - rho >= -ESCAPED * r {
                            (rcyl + r) * u + Vector3::new(0.0, 0.0, e.z)
                        } else {
                            e + ESCAPED * r * u
                        };
                        out.push((c - x, Vector3::z()));
                    }
                }
            }
            Container::Wedge { length, angle_rad } => {
                let (sin, cos) = angle_rad.sin_cos();
                for &s in ends {
                    let e = x + s * h * a;
                    let [back, bottom, slope] = wedge_wall_distances(&e, length, angle_rad);
                    // Back plane x = l_w: p_x > l_w - R; virtual at (l_w + R, p_y, p_z), along y.
                    if back < r {
                        let x_v = if back >= -ESCAPED * r {
                            length + r
                        } else {
                            e.x + ESCAPED * r
                        };
                        let c = Vector3::new(x_v, e.y, e.z);
                        out.push((c - x, Vector3::y()));
                    }
                    // Bottom plane y = 0: p_y < R; virtual at (p_x, -R, p_z), along x.
                    if bottom < r {
                        let y_v = if bottom >= -ESCAPED * r {
                            -r
                        } else {
                            e.y - ESCAPED * r
                        };
                        let c = Vector3::new(e.x, y_v, e.z);
                        out.push((c - x, Vector3::x()));
                    }
                    // Slope: p_y > p_x tan(alpha) - R / cos(alpha), i.e. closer than R to the
                    // plane; virtual at the foot of p on the slope plus R along its outward
                    // normal (-sin, cos, 0), aligned with the slope (Fig. 2.5).
                    if slope < r {
                        let n_out = Vector3::new(-sin, cos, 0.0);
                        let c = e + (slope.max(-ESCAPED * r) + r) * n_out;
                        out.push((c - x, Vector3::new(cos, sin, 0.0)));
                    }
                }
            }
        }
    }
}

/// A wall contact of a convex body (see [`Container::convex_wall_contacts`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WallContact {
    /// Penetration depth beyond the wall (> 0: overlap; the sphere path's virtual-particle
    /// overlap 2R - |c - x| equals it).
    pub depth: f64,
    /// Outward unit normal of the wall at the contact (from the body towards its mirror image).
    pub normal: Vector3<f64>,
    /// The deepest point of the body (its support point along `normal`), relative to the centre.
    pub rc: Vector3<f64>,
}

/// Azimuths sampled across the arc of the cylinder wall a convex body can reach, before the
/// local maxima of the support function are refined (see [`Container::convex_wall_contacts`]).
const CYL_AZIMUTHS: usize = 17;
/// Refinement steps of a cylinder wall contact at most (the fixed-point ascent converges
/// linearly at the ratio of the body's curvature radius at the contact to the cylinder's).
const CYL_ASCENT_STEPS: usize = 100;

impl Container {
    /// Wall contacts of a convex body (ellipsoid, superquadric; spheres among them) centred at
    /// `x` with bounding radius `bound` and world-frame support map `support(u)` = the body
    /// point farthest along the unit vector u, relative to the centre. Pushes onto `out`
    /// (cleared first) every contact whose depth is positive.
    ///
    /// The thesis' virtual particle (sec. 2.2.4, Fig. 2.4; used with eq. 2.12-2.13) is the
    /// mirror image of the particle in the wall's tangent plane. For a plane with outward unit
    /// normal m at signed distance d_c of the centre (positive inside), the body and its mirror
    /// image overlap along m by twice the penetration, and the penetration itself, the depth
    /// each one removes, is that of the body's deepest point beyond the plane, its support
    /// point along m:
    ///
    ///   depth = h(m) - d_c,   h(m) = max over the body of m . (y - x),
    ///   contact point r_c = support(m), normal m (pushes the body along -m).
    ///
    /// For a sphere of radius R this is R - d_c, the overlap 2R - |c - x| of the sphere path's
    /// virtual sphere (so both paths agree, and the pair convention of the overlap removal,
    /// depth + normal from i to j + contact point of i, carries over to the revised scheme and
    /// the relaxation with their torques r_c x F). Unlike the mirror construction, the depth
    /// grows without bound as the body leaves the container: a body far outside is always
    /// pushed inward and always blocks acceptance (the defect [`Container::wall_virtuals`]
    /// guards against for spheres and rods cannot occur).
    ///
    /// Wedge: the three planes of `wedge_wall_distances`, each on its own (the wedge is their
    /// intersection, so a body is inside exactly when no plane reports a contact).
    ///
    /// Cylinder: the penetration is max over the body of rho(y) - R_cyl (rho: distance from the
    /// axis) = max over horizontal unit u of h(u) - R_cyl, the tangent plane at azimuth u. The
    /// function h(u) is sampled at `CYL_AZIMUTHS` azimuths over the arc where u . x + bound
    /// exceeds R_cyl, and each discrete local maximum is refined by the ascent
    /// u <- P s(u) / |P s(u)| (s(u) = x + support(u), P the projection across the axis), which
    /// never decreases h (h(u') >= u' . s(u) = |P s(u)| >= u . s(u) = h(u)) and stops where
    /// P s is parallel to u, i.e. at a stationary point of h. A flat face (superball) touching
    /// the curved wall at two edges gives two contacts, as a rod touching it with both ends does.
    pub fn convex_wall_contacts(
        &self,
        x: &Vector3<f64>,
        bound: f64,
        support: impl Fn(&Vector3<f64>) -> Vector3<f64>,
        out: &mut Vec<WallContact>,
    ) {
        out.clear();
        match *self {
            Container::Periodic => {}
            Container::Wedge { length, angle_rad } => {
                let (sin, cos) = angle_rad.sin_cos();
                let normals = [Vector3::x(), -Vector3::y(), Vector3::new(-sin, cos, 0.0)];
                let dist = wedge_wall_distances(x, length, angle_rad);
                for (m, d_c) in normals.iter().zip(dist) {
                    if d_c >= bound {
                        continue;
                    }
                    let rc = support(m);
                    let depth = m.dot(&rc) - d_c;
                    if depth > 0.0 {
                        out.push(WallContact {
                            depth,
                            normal: *m,
                            rc,
                        });
                    }
                }
            }
            Container::Cylinder { diameter } => {
                let rcyl = 0.5 * diameter;
                let rho = x.x.hypot(x.y);
                if rho + bound <= rcyl {
                    return;
                }
                let phi_c = if rho > 0.0 { x.y.atan2(x.x) } else { 0.0 };
                // Azimuths where u . x + bound > R_cyl: |phi - phi_c| < half (all of them when
                // the bounding sphere reaches the wall on every side).
                let c = if rho > 0.0 {
                    (rcyl - bound) / rho
                } else {
                    -1.0
                };
                let full = c <= -1.0;
                let half = if full {
                    std::f64::consts::PI
                } else {
                    c.min(1.0).acos()
                };
                let m = CYL_AZIMUTHS;
                let azimuth = |k: usize| {
                    if full {
                        phi_c + std::f64::consts::TAU * k as f64 / m as f64
                    } else {
                        phi_c - half + 2.0 * half * k as f64 / (m - 1) as f64
                    }
                };
                let unit = |phi: f64| Vector3::new(phi.cos(), phi.sin(), 0.0);
                let h = |u: &Vector3<f64>| u.dot(x) + u.dot(&support(u));
                let hs: [f64; CYL_AZIMUTHS] = std::array::from_fn(|k| h(&unit(azimuth(k))));
                for k in 0..m {
                    let (prev, next) = if full {
                        (hs[(k + m - 1) % m], hs[(k + 1) % m])
                    } else {
                        (
                            if k > 0 { hs[k - 1] } else { f64::NEG_INFINITY },
                            if k + 1 < m {
                                hs[k + 1]
                            } else {
                                f64::NEG_INFINITY
                            },
                        )
                    };
                    // Discrete local maxima (ties: the first of a plateau).
                    if !(hs[k] > prev && hs[k] >= next) {
                        continue;
                    }
                    let mut u = unit(azimuth(k));
                    let mut rc = support(&u);
                    let mut hu = u.dot(&(x + rc));
                    for _ in 0..CYL_ASCENT_STEPS {
                        let s = x + rc;
                        let ps = Vector3::new(s.x, s.y, 0.0);
                        let pn = ps.norm();
                        if pn == 0.0 {
                            break;
                        }
                        let un = ps / pn;
                        let moved = (un - u).norm();
                        if moved <= 1e-12 {
                            break;
                        }
                        // h rises quadratically slowly near the maximum: an iterate that
                        // lowers it by rounding only is kept (it refines the normal), a real
                        // decrease (impossible in exact arithmetic) stops the ascent.
                        let rn = support(&un);
                        let hn = un.dot(&(x + rn));
                        if hn < hu - 1e-14 * hu.abs().max(1.0) {
                            break;
                        }
                        (u, rc, hu) = (un, rn, hn.max(hu));
                    }
                    let depth = hu - rcyl;
                    // Two starts that reached the same maximum count once.
                    if depth > 0.0 && !out.iter().any(|w| (w.normal - u).norm() < 1e-9) {
                        out.push(WallContact {
                            depth,
                            normal: u,
                            rc,
                        });
                    }
                }
            }
        }
    }
}

/// How far beyond a wall (in particle radii) the thesis' virtual-particle placement is kept
/// (see [`Container::wall_virtuals`]).
const ESCAPED: f64 = 0.5;

/// Minimum wedge length l_w,min = R / tan(alpha/2) + R + L cos(alpha) (thesis eq. 2.12): a
/// single row of particles (radius R, cylinder length L) aligned with the slope just fits.
pub fn wedge_min_length(radius: f64, length: f64, angle_rad: f64) -> f64 {
    radius / (0.5 * angle_rad).tan() + radius + length * angle_rad.cos()
}

/// Packing fraction of that single row, one particle per width 2R (thesis eq. 2.13).
pub fn wedge_min_packing_fraction(radius: f64, length: f64, angle_rad: f64) -> f64 {
    let lmin = wedge_min_length(radius, length, angle_rad);
    std::f64::consts::PI * radius * radius * (4.0 / 3.0 * radius + length)
        / (0.5 * 2.0 * radius * lmin * lmin * angle_rad.tan())
}

/// Signed distances of point `x` from the wedge's back, bottom and slope planes, positive
/// inside.
fn wedge_wall_distances(x: &Vector3<f64>, length: f64, angle_rad: f64) -> [f64; 3] {
    let (sin, cos) = angle_rad.sin_cos();
    [length - x.x, x.y, x.x * sin - x.y * cos]
}

/// Minimum image of one coordinate difference. Positions are kept wrapped into [0, L), so
/// |d| < L and one shift suffices; larger differences fall back to rounding. (A branch instead
/// of `f64::round`, which is a libm call and took 19% of an MCM run.)
#[inline]
pub fn min_image1(d: f64, l: f64) -> f64 {
    let h = 0.5 * l;
    if d > h {
        if d <= 3.0 * h {
            d - l
        } else {
            d - l * (d / l).round()
        }
    } else if d < -h {
        if d >= -3.0 * h {
            d + l
        } else {
            d - l * (d / l).round()
        }
    } else {
        d
    }
}

/// Wraps a coordinate into [0, L).
fn wrap1(c: f64, l: f64) -> f64 {
    // A coordinate already inside (nearly every move) skips `floor`, a libm call on the
    // baseline x86-64 target (2% of a sphere jamming run): for 0 < c / l < 1 the general
    // expression below gives c itself, bit for bit (not for c = -0, which it turns into +0).
    // For a box length l > 0 (or NaN) the rounded c / l is below 1 exactly when c < l (for
    // c < l the exact quotient is at most 1 - ulp(l) / l < 1 - 2^-53, which rounds below 1),
    // so the test needs no division (its latency was 10% of the relaxation's update loop at
    // N = 10000, `perf annotate`).
    if c > 0.0 && c < l {
        return c;
    }
    let w = c - l * (c / l).floor();
    if w >= l {
        0.0
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_image_matches_rounding() {
        let l = 7.3;
        for k in -400..=400 {
            let d = k as f64 * 0.0571;
            let want = d - l * (d / l).round();
            assert!((min_image1(d, l) - want).abs() < 1e-12, "d = {d}");
        }
    }

    /// The early return of `wrap1` gives the general expression's own value, bit for bit,
    /// for every coordinate: at +-0, next to 0 and L, inside and outside.
    #[test]
    fn wrap_inside_is_the_general_expression() {
        for l in [1.0, 7.3, 21.544346900318832, 1e-3, 3e5] {
            let next_down = |x: f64| f64::from_bits(x.to_bits() - 1);
            let mut cs = vec![
                0.0,
                -0.0,
                f64::MIN_POSITIVE,
                next_down(l),
                next_down(next_down(l)),
            ];
            cs.extend((0..10_000).map(|k| l * (k as f64 + 0.5) / 10_000.0));
            for c in cs {
                if c / l < 1.0 {
                    let general = c - l * (c / l).floor();
                    assert_eq!(wrap1(c, l).to_bits(), general.to_bits(), "c = {c}, l = {l}");
                }
                let w = wrap1(c, l);
                assert!((0.0..l).contains(&w) || w == 0.0, "c = {c}, l = {l}: {w}");
            }
            for c in [-1e-300, -next_down(l), l, 2.5 * l, -3.5 * l] {
                let w = wrap1(c, l);
                assert!((0.0..l).contains(&w), "c = {c}, l = {l}: {w}");
            }
        }
    }

    /// `wrap1`'s test c < l decides as c / l < 1 (the early return's condition before the
    /// division was dropped) for positive c and l: random magnitudes over 600 decades, and c
    /// within a few ulps of l, where the quotient rounds nearest to 1.
    #[test]
    fn inside_test_is_the_quotient_test() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12);
        let mut near = 0;
        for _ in 0..200_000 {
            let l = 10f64.powf(rng.gen_range(-300.0..300.0)) * rng.gen_range(1.0..10.0);
            let c = if rng.gen_bool(0.5) {
                let k: i64 = rng.gen_range(-4..=4);
                near += 1;
                f64::from_bits((l.to_bits() as i64 + k) as u64)
            } else {
                l * rng.gen_range(0.0..2.0)
            };
            if c > 0.0 {
                assert_eq!(c < l, c / l < 1.0, "c = {c:e}, l = {l:e}");
            }
        }
        assert!(near > 90_000);
        for l in [1.0, f64::MIN_POSITIVE, f64::MAX, 3.0] {
            for k in 1..100u64 {
                let c = f64::from_bits(l.to_bits() - k);
                assert!(c < l && c / l < 1.0, "c = {c:e}, l = {l:e}");
            }
        }
    }

    #[test]
    fn length_for_volume_inverts_volume() {
        for c in [Container::Periodic, Container::Cylinder { diameter: 4.0 }] {
            let l = 3.7;
            assert!((c.length_for_volume(c.volume(l)) - l).abs() < 1e-14);
        }
    }

    /// Each wedge wall's virtual sphere overlaps a penetrating sphere by exactly its
    /// penetration depth R - d (d: distance of the centre from that wall), along the wall's
    /// normal, and none appears for a sphere clear of the walls.
    #[test]
    fn wedge_virtual_particles_mirror_the_penetration() {
        let alpha = 25f64.to_radians();
        let w = Container::Wedge {
            length: 10.0,
            angle_rad: alpha,
        };
        let r = 0.5;
        let mut out = Vec::new();
        // Clear of the walls (inside triangle centre).
        let inside = w.trial_centre(&Vector3::new(0.3, 0.3, 0.5), 4.0, r);
        assert!(w.sphere_inside(&inside, r));
        w.wall_virtuals(&inside, &Vector3::z(), 0.0, r, &mut out);
        assert!(out.is_empty());
        let (sin, cos) = alpha.sin_cos();
        let x_mid = 8.0;
        for (x, normal_in, d) in [
            // back wall, 0.2 from it
            (
                Vector3::new(9.8, 1.0, 0.3),
                Vector3::new(-1.0, 0.0, 0.0),
                0.2,
            ),
            // bottom, 0.1 above it
            (
                Vector3::new(x_mid, 0.1, 0.3),
                Vector3::new(0.0, 1.0, 0.0),
                0.1,
            ),
            // slope, 0.35 below it
            (
                Vector3::new(x_mid, x_mid * alpha.tan(), 0.3) + 0.35 * Vector3::new(sin, -cos, 0.0),
                Vector3::new(sin, -cos, 0.0),
                0.35,
            ),
        ] {
            w.wall_virtuals(&x, &Vector3::z(), 0.0, r, &mut out);
            assert_eq!(out.len(), 1, "{x:?}");
            let (c, axis) = out[0];
            let overlap = 2.0 * r - c.norm();
            assert!(
                (overlap - (r - d)).abs() < 1e-14,
                "overlap {overlap} vs {}",
                r - d
            );
            assert!((c.normalize() + normal_in).norm() < 1e-14);
            assert!(
                axis.dot(&normal_in).abs() < 1e-15,
                "virtual rod lies along its wall"
            );
        }
    }

    #[test]
    fn wedge_minimum_length_and_packing_fraction() {
        // Spheres (L = 0) at alpha = 90 deg would be a square corner: l_min = R / tan 45 + R
        // = 2R; at 60 deg, R / tan 30 + R. Eq. 2.13 for a sphere row: V / (R l^2 tan(alpha)).
        let r = 0.5;
        let a = 60f64.to_radians();
        let l = wedge_min_length(r, 0.0, a);
        assert!((l - (r / 30f64.to_radians().tan() + r)).abs() < 1e-15);
        let phi = wedge_min_packing_fraction(r, 0.0, a);
        let want = std::f64::consts::PI / 6.0 / (r * l * l * a.tan());
        assert!((phi - want).abs() < 1e-15);
        // The centre allowed in the minimal wedge is one point: the inner triangle collapses.
        let w = Container::Wedge {
            length: l,
            angle_rad: a,
        };
        let c0 = w.trial_centre(&Vector3::new(0.0, 0.0, 0.0), 1.0, r);
        let c1 = w.trial_centre(&Vector3::new(0.9, 0.05, 0.0), 1.0, r);
        assert!((c0 - c1).norm() < 1e-12);
    }
}
