//! Independent brute-force oracle for the H field (and its gradient) of a uniformly magnetized
//! finite cylinder (radius R, semi-length L, centred at the origin, axis z), and the generator
//! of `reference/cylinder_field.csv`, `reference/cylinder_gradient.csv` and
//! `reference/three_cylinders.csv`.
//!
//! Nothing here uses elliptic integrals or `crate::magnetics`. Two formulations are used:
//!
//! **Quadrature (near field, |p| < 4 a, a = sqrt(R^2 + L^2)).** Work in the frame rotated
//! about z so that the point is at (rho, 0, z); Delta = phi' - phi.
//! * Transverse M (bound charge sigma = M.n on the lateral surface): the z' integral of
//!   (r - r')/|r - r'|^3 is elementary, giving per Delta the factor
//!   D = f(xi+) - f(xi-), f(xi) = xi / sqrt(s^2 + xi^2), xi+- = z +- L,
//!   s^2 = (rho - R)^2 + 4 rho R sin^2(Delta/2), multiplied by (rho - R cos Delta, -R sin Delta)/s^2,
//!   and 1/r- - 1/r+ for the z component (r+- = sqrt(s^2 + xi+-^2)).
//! * Longitudinal M: the caps' in-plane field is reduced by the 2-D divergence theorem to a line
//!   integral over the rim (kernel 1/r- - 1/r+), and H_z is taken from the equivalent surface
//!   current (Ampere) on the lateral surface, B_z/mu0 with kernel (R - rho cos Delta) D / s^2,
//!   minus M_z inside.
//! * Between the cap planes (|z| < L) the part "2" of D = 2 - s^2 (g(xi+) + g(-xi-)),
//!   g(x) = 1/(r (r + x)), is the infinite cylinder, integrated in closed form (-M_t/2 inside,
//!   (R^2/2 rho^2)(M_x', -M_y') outside; for longitudinal M it cancels -M_z inside exactly); the
//!   remainder has no 1/s^2 singularity, so points near the lateral surface or the caps give
//!   smooth integrands. Outside the cap planes D/s^2 = 4|z|L / (r+ r- (|xi+| r- + |xi-| r+)),
//!   again without cancellation (thin disks, L/R = 1e-4). Only near a rim circle is the
//!   integrand peaked (width ~ distance); the Delta interval [0, pi] (the integrand is even) is
//!   pre-split geometrically towards Delta = 0 down to that width and then refined by the
//!   adaptive Gauss-Kronrod rule of `special::quadrature` to 1e-15 of |H|.
//! * rho = sqrt(x^2 + y^2) and rho - R are formed in double-double, z -+ L are exact near the
//!   caps (Sterbenz), so the oracle is exact to rounding at the given f64 point.
//! * The gradient: the same integrands in forward-mode dual numbers (d/d rho, d/dz), giving the
//!   x' and z' columns; the y' column follows from curl H = 0 and div H = 0 off the surface.
//!
//! **Multipole (far field, |p| >= 4 a).** H = Hess(psi) M with psi the Newtonian potential of
//! the solid cylinder, psi = sum_{n even} q_n P_n(cos theta) / r^(n+1),
//! q_n = sum_k (-1)^k n!/(4^k k!^2 (n-2k)!) R^(2k+2) L^(n+1-2k) / ((2k+2)(n+1-2k)); the
//! derivatives are taken exactly by truncated Taylor (jet) arithmetic of order 3 in x, y, z.
//! Terms are added until a bound on the tail (|q_n| <= q_0 a^n,
//! |d^k (P_n / r^(n+1))| <= (n+1)...(n+k) / r^(n+k+1)) is below 1e-18 of the dipole scale.

use crate::special::arith::Arith;
use crate::special::double_double::hypot_dd;
use crate::special::quadrature::integrate;
use crate::Result;
use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::fmt::Write as _;
use std::ops::{Add, Div, Mul, Neg, Sub};
use std::path::Path;

const EPS: f64 = f64::EPSILON;
/// Relative tolerance asked of the quadrature (of |H|, resp. of the Frobenius norm of grad H).
const QUAD_RTOL: f64 = 1e-15;
/// The multipole series is used at |p| >= MULTIPOLE_MIN * a.
pub const MULTIPOLE_MIN: f64 = 4.0;

// ---------------------------------------------------------------------------------------------
// Numbers: f64 and first-order dual numbers in (rho, z).

trait Num: Arith {
    fn cst(x: f64) -> Self;
    fn sqrt(self) -> Self;
    fn v(self) -> f64;
    fn k(self, s: f64) -> Self;
    /// A value with the given derivatives (ignored for f64).
    fn lift(v: f64, d: [f64; 2]) -> Self;
    fn grad(self) -> [f64; 2];
    fn abs(self) -> Self {
        if self.v() < 0.0 {
            -self
        } else {
            self
        }
    }
}

impl Num for f64 {
    fn cst(x: f64) -> f64 {
        x
    }
    fn sqrt(self) -> f64 {
        f64::sqrt(self)
    }
    fn v(self) -> f64 {
        self
    }
    fn k(self, s: f64) -> f64 {
        self * s
    }
    fn lift(v: f64, _d: [f64; 2]) -> f64 {
        v
    }
    fn grad(self) -> [f64; 2] {
        [0.0; 2]
    }
}

#[derive(Clone, Copy, Debug)]
struct Dual {
    v: f64,
    d: [f64; 2],
}

impl Add for Dual {
    type Output = Dual;
    fn add(self, o: Dual) -> Dual {
        Dual {
            v: self.v + o.v,
            d: [self.d[0] + o.d[0], self.d[1] + o.d[1]],
        }
    }
}
impl Sub for Dual {
    type Output = Dual;
    fn sub(self, o: Dual) -> Dual {
        Dual {
            v: self.v - o.v,
            d: [self.d[0] - o.d[0], self.d[1] - o.d[1]],
        }
    }
}
impl Mul for Dual {
    type Output = Dual;
    fn mul(self, o: Dual) -> Dual {
        Dual {
            v: self.v * o.v,
            d: [
                self.d[0] * o.v + self.v * o.d[0],
                self.d[1] * o.v + self.v * o.d[1],
            ],
        }
    }
}
impl Div for Dual {
    type Output = Dual;
    fn div(self, o: Dual) -> Dual {
        let q = self.v / o.v;
        Dual {
            v: q,
            d: [
                (self.d[0] - q * o.d[0]) / o.v,
                (self.d[1] - q * o.d[1]) / o.v,
            ],
        }
    }
}
impl Neg for Dual {
    type Output = Dual;
    fn neg(self) -> Dual {
        Dual {
            v: -self.v,
            d: [-self.d[0], -self.d[1]],
        }
    }
}
impl Num for Dual {
    fn cst(x: f64) -> Dual {
        Dual {
            v: x,
            d: [0.0, 0.0],
        }
    }
    fn sqrt(self) -> Dual {
        let s = self.v.sqrt();
        let h = 0.5 / s;
        Dual {
            v: s,
            d: [self.d[0] * h, self.d[1] * h],
        }
    }
    fn v(self) -> f64 {
        self.v
    }
    fn lift(v: f64, d: [f64; 2]) -> Dual {
        Dual { v, d }
    }
    fn grad(self) -> [f64; 2] {
        self.d
    }
    fn k(self, s: f64) -> Dual {
        Dual {
            v: self.v * s,
            d: [self.d[0] * s, self.d[1] * s],
        }
    }
}

// ---------------------------------------------------------------------------------------------
// Quadrature formulation.

/// The point in the rotated frame: rho, rho - R, z, z + L, z - L.
#[derive(Clone, Copy)]
struct Frame<T> {
    rho: T,
    drho: T,
    z: T,
    xp: T,
    xm: T,
}

/// A quantity F(t) together with F(0) and the difference F(t) - F(0), the latter propagated
/// without subtraction (slope arithmetic). Used to integrate cos(Delta) F over [0, pi] as
/// cos(Delta) (F - F(0)) when rho >= 2R, which removes the cancellation of the azimuthal
/// integral far from a thin cylinder (it would cost log10(rho/R) digits).
#[derive(Clone, Copy)]
struct Sl<T> {
    v: T,
    v0: T,
    d: T,
}

impl<T: Num> Sl<T> {
    fn add(self, o: Sl<T>) -> Sl<T> {
        Sl {
            v: self.v + o.v,
            v0: self.v0 + o.v0,
            d: self.d + o.d,
        }
    }
    fn addc(self, c: T) -> Sl<T> {
        Sl {
            v: self.v + c,
            v0: self.v0 + c,
            d: self.d,
        }
    }
    fn mul(self, o: Sl<T>) -> Sl<T> {
        Sl {
            v: self.v * o.v,
            v0: self.v0 * o.v0,
            d: self.d * o.v + self.v0 * o.d,
        }
    }
    fn mulc(self, c: T) -> Sl<T> {
        Sl {
            v: self.v * c,
            v0: self.v0 * c,
            d: self.d * c,
        }
    }
    fn recip(self) -> Sl<T> {
        let one = T::cst(1.0);
        Sl {
            v: one / self.v,
            v0: one / self.v0,
            d: -(self.d / (self.v * self.v0)),
        }
    }
    fn sqrt(self) -> Sl<T> {
        let (s, s0) = (self.v.sqrt(), self.v0.sqrt());
        Sl {
            v: s,
            v0: s0,
            d: self.d / (s + s0),
        }
    }
}

/// D = xi+/r+ + |xi-|/r- between the cap planes, with its derivatives formed without the
/// cancellation of dD/dz = s^2 (1/r+^3 - 1/r-^3) that plain dual arithmetic would suffer in a
/// thin slab: dD/dz = -4 z L s^2 (r-^2 + r- r+ + r+^2) / ((r- + r+) r+^3 r-^3),
/// dD/ds^2 = -(xi+/r+^3 + |xi-|/r-^3) / 2.
fn d_planes<T: Num>(s2: Sl<T>, g: &Frame<T>, ll: f64) -> Sl<T> {
    let (xp, xa, z) = (g.xp.v(), -g.xm.v(), g.z.v());
    let one = |s2v: f64, s2g: [f64; 2]| -> (T, f64, f64) {
        let rp = (s2v + xp * xp).sqrt();
        let rm = (s2v + xa * xa).sqrt();
        let v = xp / rp + xa / rm;
        let dds = -0.5 * (xp / (rp * rp * rp) + xa / (rm * rm * rm));
        let ddz = -4.0 * z * ll * s2v * (rm * rm + rm * rp + rp * rp)
            / ((rm + rp) * (rp * rp * rp) * (rm * rm * rm));
        (T::lift(v, [dds * s2g[0], dds * s2g[1] + ddz]), rp, rm)
    };
    let (dv, rp, rm) = one(s2.v.v(), s2.v.grad());
    let (d0, rp0, rm0) = one(s2.v0.v(), s2.v0.grad());
    // D(t) - D(0) = -(s2 - s2_0) (xi+/(r+ r+0 (r+ + r+0)) + |xi-|/(r- r-0 (r- + r-0)))
    let ds = s2.d.v();
    let diff = -ds * (xp / (rp * rp0 * (rp + rp0)) + xa / (rm * rm0 * (rm + rm0)));
    let (gv, g0) = (dv.grad(), d0.grad());
    Sl {
        v: dv,
        v0: d0,
        d: T::lift(diff, [gv[0] - g0[0], gv[1] - g0[1]]),
    }
}

/// Integrand over Delta in [0, pi] (the even extension to [-pi, pi] is accounted for by the
/// prefactor R/(2 pi)); returns the three components of H' per unit of the prefactor.
/// `sub`: integrate the cos(Delta)-weighted parts as cos(Delta) (F - F(0)); used when the
/// kernels vary little with Delta (rho >= 2R, or 4 rho R < squared distance to the rims),
/// never where they are peaked (near a rim).
#[allow(clippy::too_many_arguments)]
fn integrand<T: Num>(
    g: &Frame<T>,
    rr: f64,
    ll: f64,
    mp: &[f64; 3],
    split: bool,
    sub: bool,
    delta: f64,
) -> [T; 3] {
    let [a, b, c] = *mp;
    let t = (0.5 * delta).sin();
    let t2 = t * t;
    let cosd = 1.0 - 2.0 * t2;
    let sind = delta.sin();
    let sin2 = sind * sind;
    let d0 = g.drho * g.drho;
    let ds = g.rho.k(4.0 * rr * t2);
    let s2 = Sl {
        v: d0 + ds,
        v0: d0,
        d: ds,
    };
    let rp = s2.addc(g.xp * g.xp).sqrt();
    let rm = s2.addc(g.xm * g.xm).sqrt();
    let kk = rp.mul(rm).mul(rp.add(rm)).recip().mulc(g.z.k(4.0 * ll));
    // F = kern (e or D/s^2); the components, with dx = rho - R cos, w = R - rho cos:
    //   case A: Fx = cos (c kk - a dx e), Fy = b R sin^2 e, Fz = a cos kk - c w e
    //   case B: Fx = cos (c kk + a dx dn), Fy = -b R sin^2 dn, Fz = a cos kk + c w dn
    let (kern, sgn) = if split {
        let e = rp
            .mul(rp.addc(g.xp))
            .recip()
            .add(rm.mul(rm.addc(-g.xm)).recip());
        (e, -1.0)
    } else if g.xp.v() > 0.0 && g.xm.v() < 0.0 {
        // between the cap planes, unsplit: D / s^2 = (xi+/r+ + |xi-|/r-) / s^2
        let d = d_planes(s2, g, ll);
        (d.mul(s2.recip()), 1.0)
    } else {
        let den = rp.mul(rm).mul(rm.mulc(g.xp.abs()).add(rp.mulc(g.xm.abs())));
        (den.recip().mulc(g.z.abs().k(4.0 * ll)), 1.0)
    };
    if sub {
        // cos-weighted parts as differences; dx cos = rho cos - R cos^2, w = R - rho cos.
        [
            kk.d.k(c * cosd) + (g.rho * kern.d).k(sgn * a * cosd)
                - kern.v.k(sgn * a * rr * cosd * cosd),
            kern.v.k(-sgn * b * rr * sin2),
            kk.d.k(a * cosd) + (kern.v.k(rr) - (g.rho * kern.d).k(cosd)).k(sgn * c),
        ]
    } else {
        let dx = g.drho + T::cst(2.0 * rr * t2);
        let w = g.rho.k(2.0 * t2) - g.drho;
        [
            (kk.v.k(c) + (dx * kern.v).k(sgn * a)).k(cosd),
            kern.v.k(-sgn * b * rr * sin2),
            kk.v.k(a * cosd) + (w * kern.v).k(sgn * c),
        ]
    }
}

struct Local {
    rho: f64,
    drho: f64,
    cphi: f64,
    sphi: f64,
    z: f64,
    xp: f64,
    xm: f64,
    split: bool,
    inside: bool,
    inside_radius: bool,
    sub: bool,
    breaks: Vec<f64>,
}

/// The frame of `lc` as duals: rho-derivative (d[0]) seeded on rho and drho, z-derivative
/// (d[1]) on z, xp and xm.
fn dual_frame(lc: &Local) -> Frame<Dual> {
    let dr = |v: f64| Dual { v, d: [1.0, 0.0] };
    let dz = |v: f64| Dual { v, d: [0.0, 1.0] };
    Frame {
        rho: dr(lc.rho),
        drho: dr(lc.drho),
        z: dz(lc.z),
        xp: dz(lc.xp),
        xm: dz(lc.xm),
    }
}

fn local(rr: f64, ll: f64, p: &Vector3<f64>) -> Local {
    let rd = hypot_dd(p.x, p.y);
    let rho = rd.hi + rd.lo;
    let drho = (rd.hi - rr) + rd.lo;
    let (cphi, sphi) = if rho > 0.0 {
        (p.x / rho, p.y / rho)
    } else {
        (1.0, 0.0)
    };
    let z = p.z;
    let xp = z + ll;
    let xm = z - ll;
    let case_a = xp > 0.0 && xm < 0.0; // between the cap planes
                                       // Split off the infinite cylinder only where it dominates: closer to the lateral surface
                                       // than to the cap planes (for thin disks it would cancel the remainder).
    let split = case_a && drho.abs() < xp.min(-xm);
    // Geometric breakpoints towards Delta = 0 down to the angular width of a rim peak.
    let d_rim = drho.hypot(xp.abs().min(xm.abs()));
    let width = if rho > 0.0 {
        d_rim / (rho * rr).sqrt()
    } else {
        10.0
    };
    let mut breaks = Vec::new();
    let mut x = 0.5 * PI;
    while x > 0.05 * width && breaks.len() < 80 {
        breaks.push(x);
        x *= 0.5;
    }
    breaks.reverse();
    Local {
        rho,
        drho,
        cphi,
        sphi,
        z,
        xp,
        xm,
        split,
        inside: case_a && drho < 0.0,
        inside_radius: drho < 0.0,
        sub: rho >= 2.0 * rr || 4.0 * rho * rr < d_rim * d_rim,
        breaks,
    }
}

/// H by quadrature (any point off the surface; accurate to ~1e-15 |H| except far away, where
/// cancellation costs about log10(|p|/a) digits; use [`oracle_h`] which switches to the
/// multipole series there). Returns (H, estimated absolute error).
pub fn oracle_h_quadrature(
    rr: f64,
    ll: f64,
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Vector3<f64>, f64) {
    let lc = local(rr, ll, p);
    let (c, s) = (lc.cphi, lc.sphi);
    let mp = [m.x * c + m.y * s, -m.x * s + m.y * c, m.z];
    // Closed-form part: the infinite cylinder when split, else -M_z inside (B/mu0 - M).
    let two_d = if lc.split {
        if lc.inside_radius {
            [-0.5 * mp[0], -0.5 * mp[1], 0.0]
        } else {
            let k = 0.5 * (rr / lc.rho) * (rr / lc.rho);
            [k * mp[0], -k * mp[1], 0.0]
        }
    } else if lc.inside {
        [0.0, 0.0, -mp[2]]
    } else {
        [0.0; 3]
    };
    let fr = Frame {
        rho: lc.rho,
        drho: lc.drho,
        z: lc.z,
        xp: lc.xp,
        xm: lc.xm,
    };
    let pref = rr / (2.0 * PI);
    let res = integrate::<3, _, _>(
        |d| integrand::<f64>(&fr, rr, ll, &mp, lc.split, lc.sub, d),
        0.0,
        PI,
        &lc.breaks,
        |v| {
            let h = Vector3::new(
                pref * v[0] + two_d[0],
                pref * v[1] + two_d[1],
                pref * v[2] + two_d[2],
            );
            (QUAD_RTOL * h.norm() / pref).max(1e-300)
        },
        20000,
    );
    let hl = Vector3::new(
        pref * res.value[0] + two_d[0],
        pref * res.value[1] + two_d[1],
        pref * res.value[2] + two_d[2],
    );
    let h = Vector3::new(hl.x * c - hl.y * s, hl.x * s + hl.y * c, hl.z);
    // rounding of the prefactor, of the offset and of the two rotations: 4 eps
    let err = pref * res.abs_err + 4.0 * EPS * (h.norm() + Vector3::from(two_d).norm());
    (
        h,
        if res.converged {
            err
        } else {
            err.max(1e-6 * h.norm())
        },
    )
}

/// grad H by quadrature of the dual-number integrand ([(i,j)] = dH_i/dx_j). Returns
/// (gradient, estimated absolute error in the Frobenius norm).
pub fn oracle_h_gradient_quadrature(
    rr: f64,
    ll: f64,
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Matrix3<f64>, f64) {
    let lc = local(rr, ll, p);
    let (c, s) = (lc.cphi, lc.sphi);
    let mp = [m.x * c + m.y * s, -m.x * s + m.y * c, m.z];
    // d/drho of the closed-form 2-D part (outside only; it is constant inside).
    let two_d_rho = if lc.split && !lc.inside_radius {
        let k = -(rr / lc.rho) * (rr / lc.rho) / lc.rho;
        [k * mp[0], -k * mp[1], 0.0]
    } else {
        [0.0; 3]
    };
    let fr = dual_frame(&lc);
    let pref = rr / (2.0 * PI);
    let assemble = |v: &[f64; 6]| -> [f64; 6] {
        [
            pref * v[0] + two_d_rho[0],
            pref * v[1] + two_d_rho[1],
            pref * v[2] + two_d_rho[2],
            pref * v[3],
            pref * v[4],
            pref * v[5],
        ]
    };
    let res = integrate::<6, _, _>(
        |d| {
            let f = integrand::<Dual>(&fr, rr, ll, &mp, lc.split, lc.sub, d);
            [
                f[0].d[0], f[1].d[0], f[2].d[0], f[0].d[1], f[1].d[1], f[2].d[1],
            ]
        },
        0.0,
        PI,
        &lc.breaks,
        |v| {
            let g = assemble(v);
            let n = (g.iter().map(|x| x * x).sum::<f64>() + (g[0] + g[5]).powi(2)).sqrt();
            (QUAD_RTOL * n / pref).max(1e-300)
        },
        20000,
    );
    let g = assemble(&res.value);
    // g = [dhx/drho, dhy/drho, dhz/drho, dhx/dz, dhy/dz, dhz/dz]
    let gl = Matrix3::new(
        g[0],
        g[1],
        g[3],
        g[1],
        -(g[0] + g[5]),
        g[4],
        g[2],
        g[4],
        g[5],
    );
    let q = Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0);
    let gw = q * gl * q.transpose();
    let err = 2.0 * pref * res.abs_err + 8.0 * EPS * gw.norm();
    (
        gw,
        if res.converged {
            err
        } else {
            err.max(1e-6 * gw.norm())
        },
    )
}

/// Asymmetry |dHz/drho - dHx/dz| / |grad H| of the quadrature gradient (a self-check: the
/// two are computed from different integrands and must agree since curl H = 0).
pub fn gradient_symmetry_defect(rr: f64, ll: f64, m: &Vector3<f64>, p: &Vector3<f64>) -> f64 {
    let lc = local(rr, ll, p);
    let (c, s) = (lc.cphi, lc.sphi);
    let mp = [m.x * c + m.y * s, -m.x * s + m.y * c, m.z];
    let fr = dual_frame(&lc);
    let res = integrate::<2, _, _>(
        |d| {
            let f = integrand::<Dual>(&fr, rr, ll, &mp, lc.split, lc.sub, d);
            [f[2].d[0], f[0].d[1]]
        },
        0.0,
        PI,
        &lc.breaks,
        |v| 1e-16 * (v[0].abs() + v[1].abs()),
        20000,
    );
    let (g, _) = oracle_h_gradient_quadrature(rr, ll, m, p);
    (rr / (2.0 * PI)) * (res.value[0] - res.value[1]).abs() / g.norm()
}

// ---------------------------------------------------------------------------------------------
// Multipole formulation: order-3 Taylor jets in three variables.

const NJ: usize = 20;
/// Rounding of the jet derivatives in units of eps times their Frobenius norm: 4x the worst
/// seen for 1/r over 2000 random points (self-check `jet_rounding`).
const JET_ROUND: f64 = 16.0;

struct JetTables {
    exps: [[usize; 3]; NJ],
    mul: Vec<(usize, usize, usize)>,
}

fn jet_tables() -> &'static JetTables {
    static T: std::sync::OnceLock<JetTables> = std::sync::OnceLock::new();
    T.get_or_init(|| {
        let mut exps = [[0usize; 3]; NJ];
        let mut n = 0;
        for deg in 0..=3 {
            for i in (0..=deg).rev() {
                for j in (0..=(deg - i)).rev() {
                    exps[n] = [i, j, deg - i - j];
                    n += 1;
                }
            }
        }
        let find = |e: [usize; 3]| exps.iter().position(|x| *x == e);
        let mut mul = Vec::new();
        for a in 0..NJ {
            for b in 0..NJ {
                let e = [
                    exps[a][0] + exps[b][0],
                    exps[a][1] + exps[b][1],
                    exps[a][2] + exps[b][2],
                ];
                if e[0] + e[1] + e[2] <= 3 {
                    mul.push((a, b, find(e).unwrap()));
                }
            }
        }
        JetTables { exps, mul }
    })
}

#[derive(Clone, Copy)]
struct Jet([f64; NJ]);

impl Jet {
    fn cst(x: f64) -> Jet {
        let mut c = [0.0; NJ];
        c[0] = x;
        Jet(c)
    }
    fn var(x: f64, i: usize) -> Jet {
        let mut c = [0.0; NJ];
        c[0] = x;
        c[1 + i] = 1.0;
        Jet(c)
    }
    fn add(&self, o: &Jet) -> Jet {
        let mut c = self.0;
        for (x, y) in c.iter_mut().zip(o.0.iter()) {
            *x += y;
        }
        Jet(c)
    }
    fn scale(&self, s: f64) -> Jet {
        let mut c = self.0;
        for x in c.iter_mut() {
            *x *= s;
        }
        Jet(c)
    }
    fn mul(&self, o: &Jet) -> Jet {
        let mut c = [0.0; NJ];
        for &(a, b, k) in &jet_tables().mul {
            c[k] += self.0[a] * o.0[b];
        }
        Jet(c)
    }
    /// f(a0 + h) = sum_k coef[k] h^k for the nilpotent part h.
    fn compose(&self, coef: [f64; 4]) -> Jet {
        let mut h = *self;
        h.0[0] = 0.0;
        let h2 = h.mul(&h);
        let h3 = h2.mul(&h);
        Jet::cst(coef[0])
            .add(&h.scale(coef[1]))
            .add(&h2.scale(coef[2]))
            .add(&h3.scale(coef[3]))
    }
    fn recip(&self) -> Jet {
        let a = self.0[0];
        self.compose([
            1.0 / a,
            -1.0 / (a * a),
            1.0 / (a * a * a),
            -1.0 / (a * a * a * a),
        ])
    }
    fn sqrt(&self) -> Jet {
        let a = self.0[0];
        let s = a.sqrt();
        self.compose([s, 0.5 / s, -0.125 / (s * a), 0.0625 / (s * a * a)])
    }
    /// Frobenius norms of the Hessian and of the third-derivative tensor.
    fn fro23(&self) -> (f64, f64) {
        let mut f2 = 0.0;
        let mut f3 = 0.0;
        for i in 0..3 {
            for j in 0..3 {
                let mut e = [0usize; 3];
                e[i] += 1;
                e[j] += 1;
                f2 += self.deriv(e).powi(2);
                for k in 0..3 {
                    let mut e3 = e;
                    e3[k] += 1;
                    f3 += self.deriv(e3).powi(2);
                }
            }
        }
        (f2.sqrt(), f3.sqrt())
    }
    /// d^|e| f / dx^e at the expansion point.
    fn deriv(&self, e: [usize; 3]) -> f64 {
        let t = jet_tables();
        let i = t.exps.iter().position(|x| *x == e).unwrap();
        let fact = |n: usize| (1..=n).product::<usize>() as f64;
        self.0[i] * fact(e[0]) * fact(e[1]) * fact(e[2])
    }
}

/// q_n / a^(n+3) for even n (zero for odd n), with a bound on its rounding error.
fn moments(rr: f64, ll: f64, nmax: usize) -> Vec<(f64, f64)> {
    let a = rr.hypot(ll);
    let (rh, lh) = (rr / a, ll / a);
    let mut out = Vec::with_capacity(nmax + 1);
    for n in 0..=nmax {
        if n % 2 == 1 {
            out.push((0.0, 0.0));
            continue;
        }
        let mut cnk = 1.0f64; // n!/(4^k k!^2 (n-2k)!)
        let mut sum = 0.0;
        let mut sabs = 0.0;
        for k in 0..=n / 2 {
            let term = cnk * rh.powi(2 * k as i32 + 2) * lh.powi((n + 1 - 2 * k) as i32)
                / ((2 * k + 2) as f64 * (n + 1 - 2 * k) as f64);
            let term = if k % 2 == 0 { term } else { -term };
            sum += term;
            sabs += term.abs();
            let nk = (n - 2 * k) as f64;
            cnk *= nk * (nk - 1.0) / (4.0 * ((k + 1) as f64).powi(2));
        }
        out.push((sum, (n as f64 + 4.0) * EPS * sabs));
    }
    out
}

/// psi's second and third derivatives (dimensionless Hessian; third derivatives per metre)
/// by the multipole series; returns (hess, third[i][j][k], abs error bound of hess entries
/// relative to 1, and of third-derivative entries).
fn multipole_derivs(
    rr: f64,
    ll: f64,
    p: &Vector3<f64>,
) -> (Matrix3<f64>, [[[f64; 3]; 3]; 3], f64, f64) {
    let a = rr.hypot(ll);
    let xs = p / a;
    let rs = xs.norm();
    let q0 = 0.5 * (rr / a) * (rr / a) * (ll / a); // = V / (4 pi a^3), bounds |q_n| / a^(n+3)
                                                   // Tail bound relative to the dipole scale: sum_{j > n, even} (j+3)^3 rs^-j.
    let tail_after = |n: usize| -> f64 {
        let mut t = 0.0;
        let mut j = n + 2;
        loop {
            let term = ((j + 3) as f64).powi(3) * rs.powf(-(j as f64));
            t += term;
            if term < 1e-30 * t || j > n + 2000 {
                break;
            }
            j += 2;
        }
        t
    };
    let mut nmax = 0;
    while tail_after(nmax) > 1e-18 && nmax < 400 {
        nmax += 2;
    }
    let qs = moments(rr, ll, nmax);
    let x = Jet::var(xs.x, 0);
    let y = Jet::var(xs.y, 1);
    let z = Jet::var(xs.z, 2);
    let r2 = x.mul(&x).add(&y.mul(&y)).add(&z.mul(&z));
    let u = r2.sqrt().recip();
    let t = z.mul(&u);
    let mut p_prev = Jet::cst(1.0); // P_{n-1}
    let mut p_cur = Jet::cst(1.0); // P_n
    let mut upow = u; // u^(n+1)
    let mut psi = Jet::cst(0.0);
    let (mut round2, mut round3) = (0.0, 0.0);
    for n in 0..=nmax {
        if n == 0 {
            // the monopole term q_0 / r is added in closed form below
            round2 += qs[0].1 * 3.0 * rs.powi(-3);
            round3 += qs[0].1 * 15.0 * rs.powi(-4);
        } else if n % 2 == 0 {
            let unit_term = p_cur.mul(&upow);
            let term = unit_term.scale(qs[n].0);
            psi = psi.add(&term);
            let (f2, f3) = unit_term.fro23();
            // JET_ROUND eps of the Frobenius norms (calibrated by the self-check
            // `jet_rounding`), plus the rounding error of q_n.
            let qa = qs[n].0.abs() * JET_ROUND * EPS + qs[n].1;
            round2 += qa * f2;
            round3 += qa * f3;
        }
        // P_{n+1} = ((2n+1) t P_n - n P_{n-1}) / (n+1)
        let next = t
            .mul(&p_cur)
            .scale((2 * n + 1) as f64)
            .add(&p_prev.scale(-(n as f64)))
            .scale(1.0 / (n as f64 + 1.0));
        p_prev = p_cur;
        p_cur = next;
        upow = upow.mul(&u);
    }
    let mut hess = Matrix3::zeros();
    let mut third = [[[0.0; 3]; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            let mut e = [0usize; 3];
            e[i] += 1;
            e[j] += 1;
            hess[(i, j)] = psi.deriv(e);
            for k in 0..3 {
                let mut e3 = e;
                e3[k] += 1;
                third[i][j][k] = psi.deriv(e3) / a;
            }
        }
    }
    // q_0 / r in closed form: d_ij (1/r) = (3 x_i x_j - r^2 d_ij) / r^5,
    // d_ijk (1/r) = -15 x_i x_j x_k / r^7 + 3 (d_ij x_k + d_ik x_j + d_jk x_i) / r^5.
    let q = qs[0].0;
    let (r2, r5, r7) = (rs * rs, rs.powi(5), rs.powi(7));
    let dl = |i: usize, j: usize| if i == j { 1.0 } else { 0.0 };
    let (mut f2, mut f3) = (0.0f64, 0.0f64);
    for i in 0..3 {
        for j in 0..3 {
            let h0 = q * (3.0 * xs[i] * xs[j] - r2 * dl(i, j)) / r5;
            hess[(i, j)] += h0;
            f2 += h0 * h0;
            for k in 0..3 {
                let t0 = q
                    * (-15.0 * xs[i] * xs[j] * xs[k] / r7
                        + 3.0 * (dl(i, j) * xs[k] + dl(i, k) * xs[j] + dl(j, k) * xs[i]) / r5);
                third[i][j][k] += t0 / a;
                f3 += t0 * t0;
            }
        }
    }
    round2 += 4.0 * EPS * f2.sqrt();
    round3 += 6.0 * EPS * f3.sqrt();
    let tail = tail_after(nmax);
    // Frobenius-norm bounds (the tail bound is per entry: 3x for 9 entries, 6x for 27).
    let e2 = 3.0 * q0 * tail * rs.powi(-3) + round2;
    let e3 = (6.0 * q0 * tail * rs.powi(-4) + round3) / a;
    (hess, third, e2, e3)
}

/// H by the multipole series (valid for |p| > a; used for |p| >= 4 a). Returns (H, est. abs err).
pub fn oracle_h_multipole(
    rr: f64,
    ll: f64,
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Vector3<f64>, f64) {
    let (hess, _, e, _) = multipole_derivs(rr, ll, p);
    let h = hess * m;
    (h, e * m.norm() + 4.0 * EPS * h.norm())
}

/// grad H by the multipole series. Returns (gradient, est. abs err, Frobenius).
pub fn oracle_h_gradient_multipole(
    rr: f64,
    ll: f64,
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Matrix3<f64>, f64) {
    let (_, third, _, e) = multipole_derivs(rr, ll, p);
    let mut g = Matrix3::zeros();
    for i in 0..3 {
        for k in 0..3 {
            g[(i, k)] = (0..3).map(|j| third[i][j][k] * m[j]).sum();
        }
    }
    (g, e * m.norm() + 4.0 * EPS * g.norm())
}

fn use_multipole(rr: f64, ll: f64, p: &Vector3<f64>) -> bool {
    p.norm() >= MULTIPOLE_MIN * rr.hypot(ll)
}

/// The oracle: H (A/m) at p (m) of a cylinder of radius `radius_m` and semi-length
/// `half_length_m` (axis z, centred at the origin) uniformly magnetized with `m` (A/m), and
/// the estimated absolute error of H (A/m). Points on the surface are not allowed.
pub fn oracle_h(
    radius_m: f64,
    half_length_m: f64,
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Vector3<f64>, f64) {
    if m.norm() == 0.0 {
        return (Vector3::zeros(), 0.0);
    }
    if use_multipole(radius_m, half_length_m, p) {
        oracle_h_multipole(radius_m, half_length_m, m, p)
    } else {
        oracle_h_quadrature(radius_m, half_length_m, m, p)
    }
}

/// The gradient oracle: [(i,j)] = dH_i/dx_j (A/m^2) and its estimated absolute error
/// (Frobenius norm, A/m^2).
pub fn oracle_h_gradient(
    radius_m: f64,
    half_length_m: f64,
    m: &Vector3<f64>,
    p: &Vector3<f64>,
) -> (Matrix3<f64>, f64) {
    if m.norm() == 0.0 {
        return (Matrix3::zeros(), 0.0);
    }
    if use_multipole(radius_m, half_length_m, p) {
        oracle_h_gradient_multipole(radius_m, half_length_m, m, p)
    } else {
        oracle_h_gradient_quadrature(radius_m, half_length_m, m, p)
    }
}

// ---------------------------------------------------------------------------------------------
// Three posed cylinders (thesis section 5.6).

/// Radius (m), semi-length (m) and |M| (A/m) of the three-cylinder case (thesis 5.6).
pub const THREE_R: f64 = 0.3;
pub const THREE_L: f64 = 6.0;
pub const THREE_M: f64 = 800_000.0;

/// One pose: centre (m) and rotation (axis-angle: unit axis, angle in degrees) taking the
/// cylinder frame to the world.
pub struct Pose {
    pub centre: [f64; 3],
    pub rot_axis: [f64; 3],
    pub rot_deg: f64,
}

/// The three poses (documented in reference/README.md).
pub const THREE_POSES: [Pose; 3] = [
    Pose {
        centre: [0.0, 0.0, 0.0],
        rot_axis: [0.0, 0.0, 1.0],
        rot_deg: 0.0,
    },
    Pose {
        centre: [1.2, 0.0, 0.5],
        rot_axis: [1.0, 0.0, 0.0],
        rot_deg: 90.0,
    },
    Pose {
        centre: [-1.5, 1.0, -0.8],
        rot_axis: [0.0, 1.0, 0.0],
        rot_deg: 35.0,
    },
];

impl Pose {
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        let ax = nalgebra::Unit::new_normalize(Vector3::from(self.rot_axis));
        UnitQuaternion::from_axis_angle(&ax, self.rot_deg.to_radians())
    }
    /// M in the world frame: the rotated cylinder-frame magnetization THREE_M (1,1,0)/sqrt 2.
    pub fn magnetization_world(&self) -> Vector3<f64> {
        let s = THREE_M / 2f64.sqrt();
        self.rotation() * Vector3::new(s, s, 0.0)
    }
    pub fn axis_world(&self) -> Vector3<f64> {
        self.rotation() * Vector3::z()
    }
}

/// Sum of the oracle fields of the three posed cylinders at world point p.
pub fn three_cylinders_h(p: &Vector3<f64>) -> (Vector3<f64>, f64) {
    let s = THREE_M / 2f64.sqrt();
    let ml = Vector3::new(s, s, 0.0);
    let mut h = Vector3::zeros();
    let mut err = 0.0;
    for pose in &THREE_POSES {
        let q = pose.rotation();
        let pl = q.inverse() * (p - Vector3::from(pose.centre));
        let (hl, e) = oracle_h(THREE_R, THREE_L, &ml, &pl);
        h += q * hl;
        err += e + 4.0 * EPS * hl.norm();
    }
    (h, err)
}

/// Distance of a local point to the surface of the cylinder (R, L).
fn surface_distance(rr: f64, ll: f64, p: &Vector3<f64>) -> f64 {
    let rho = p.x.hypot(p.y);
    let dr = rho - rr;
    let dz = p.z.abs() - ll;
    if dr <= 0.0 && dz <= 0.0 {
        (-dr).min(-dz)
    } else {
        dr.max(0.0).hypot(dz.max(0.0))
    }
}

// ---------------------------------------------------------------------------------------------
// Point sets.

/// One row of input: region, R, L, M, p.
#[derive(Clone, Debug)]
pub struct Sample {
    pub region: &'static str,
    pub r: f64,
    pub l: f64,
    pub m: Vector3<f64>,
    pub p: Vector3<f64>,
}

const SCALES: [f64; 3] = [1e-6, 3e-4, 1.0];
const ASPECTS: [f64; 4] = [0.5, 1.0, 2.5, 10.0];
const MAGS: [f64; 8] = [1e6, 1e6, 8e5, 1e6, 1.0, 1e6, 3.3e3, 2.5e7];

fn unit(rng: &mut ChaCha8Rng) -> Vector3<f64> {
    loop {
        let v = Vector3::new(
            rng.gen::<f64>() * 2.0 - 1.0,
            rng.gen::<f64>() * 2.0 - 1.0,
            rng.gen::<f64>() * 2.0 - 1.0,
        );
        let n = v.norm();
        if n > 0.2 && n <= 1.0 && v.iter().all(|c| c.abs() > 0.05 * n) {
            return v / n;
        }
    }
}

/// Magnetization of kind i % 4: longitudinal, transverse x, transverse y, oblique.
fn mag(i: usize, rng: &mut ChaCha8Rng) -> Vector3<f64> {
    let mm = MAGS[(i / 4) % MAGS.len()];
    match i % 4 {
        0 => Vector3::new(0.0, 0.0, mm),
        1 => Vector3::new(mm, 0.0, 0.0),
        2 => Vector3::new(0.0, mm, 0.0),
        _ => unit(rng) * mm,
    }
}

fn at_phi(rho: f64, phi: f64, z: f64) -> Vector3<f64> {
    Vector3::new(rho * phi.cos(), rho * phi.sin(), z)
}

/// Exact azimuths for points near a rim (rho is then exactly representable).
fn at_quadrant(rho: f64, k: usize, z: f64) -> Vector3<f64> {
    match k % 4 {
        0 => Vector3::new(rho, 0.0, z),
        1 => Vector3::new(0.0, rho, z),
        2 => Vector3::new(-rho, 0.0, z),
        _ => Vector3::new(0.0, -rho, z),
    }
}

fn log_uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    10f64.powf(lo + (hi - lo) * rng.gen::<f64>())
}

/// The input points of the field table (`per` points per region; the gradient table uses a
/// different seed and the same regions).
pub fn samples(seed: u64, per: usize, min_log_dist: f64) -> Vec<Sample> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    let geo = |i: usize| (SCALES[i % 3], ASPECTS[(i / 3) % 4] * SCALES[i % 3]);
    // far: 10 .. 1e6 times the size 2a, random directions.
    for i in 0..per {
        let (r, l) = geo(i);
        let m = mag(i, &mut rng);
        let size = 2.0 * r.hypot(l);
        let d = size * log_uniform(&mut rng, 1.0, 6.0);
        out.push(Sample {
            region: "far",
            r,
            l,
            m,
            p: unit(&mut rng) * d,
        });
    }
    // axis: rho from 1e-12 R to 1e-3 R, inside and outside, several z.
    for i in 0..per {
        let (r, l) = geo(i + 1);
        let m = mag(i, &mut rng);
        let rho = r * log_uniform(&mut rng, -12.0, -3.0);
        let phi = 2.0 * PI * rng.gen::<f64>();
        let z = match i % 3 {
            0 => l * 0.95 * (2.0 * rng.gen::<f64>() - 1.0),
            1 => l + r * log_uniform(&mut rng, -2.0, 0.5),
            _ => -(l + r * log_uniform(&mut rng, -2.0, 0.5)),
        };
        out.push(Sample {
            region: "axis",
            r,
            l,
            m,
            p: at_phi(rho, phi, z),
        });
    }
    // lateral: distance 1e-9 R .. 1e-3 R to the lateral surface, both sides.
    for i in 0..per {
        let (r, l) = geo(i + 2);
        let m = mag(i, &mut rng);
        let d = log_uniform(&mut rng, min_log_dist, -3.0);
        let rho = if (i / 2) % 2 == 0 {
            r * (1.0 + d)
        } else {
            r * (1.0 - d)
        };
        let phi = 2.0 * PI * rng.gen::<f64>();
        let z = l * 0.9 * (2.0 * rng.gen::<f64>() - 1.0);
        out.push(Sample {
            region: "lateral",
            r,
            l,
            m,
            p: at_phi(rho, phi, z),
        });
    }
    // caps: distance 1e-9 R .. 1e-3 R to an end cap, both sides, several rho.
    for i in 0..per {
        let (r, l) = geo(i);
        let m = mag(i, &mut rng);
        let d = r * log_uniform(&mut rng, min_log_dist, -3.0);
        let outside = (i / 2) % 2 == 0;
        let top = (i / 4) % 2 == 0;
        let zabs = if outside { l + d } else { l - d };
        let z = if top { zabs } else { -zabs };
        let rho = r * 0.95 * rng.gen::<f64>();
        let phi = 2.0 * PI * rng.gen::<f64>();
        out.push(Sample {
            region: "caps",
            r,
            l,
            m,
            p: at_phi(rho, phi, z),
        });
    }
    // rims: distance 1e-9 R .. 1e-3 R to an edge circle, directions all round it.
    for i in 0..per {
        let (r, l) = geo(i + 1);
        let m = mag(i, &mut rng);
        let d = r * log_uniform(&mut rng, min_log_dist, -3.0);
        // angle in the (rho, z) half plane; avoid the two surfaces (theta = pi, 3 pi / 2)
        let theta = loop {
            let th = 2.0 * PI * rng.gen::<f64>();
            if (th - PI).abs() > 0.05 && (th - 1.5 * PI).abs() > 0.05 {
                break th;
            }
        };
        let rho = r + d * theta.cos();
        let zabs = l + d * theta.sin();
        let z = if (i / 4) % 2 == 0 { zabs } else { -zabs };
        out.push(Sample {
            region: "rims",
            r,
            l,
            m,
            p: at_quadrant(rho, i / 2, z),
        });
    }
    // aspect: L/R over 1e-4 .. 1e4, points near and far, inside and outside.
    let aspects = [1e-4, 1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0, 1e3, 1e4];
    let mut k = 0;
    for (ia, &ar) in aspects.iter().enumerate() {
        let r = SCALES[ia % 3];
        let l = ar * r;
        let a = r.hypot(l);
        let pts = [
            (0.37 * r, 0.41 * l),
            (1.7 * r, 0.63 * l),
            (0.52 * r, l + 0.25 * r.min(l)),
            (r * (1.0 + 1e-3), l + 0.5e-3 * r.min(l)),
            (0.9 * r, 0.999 * l),
        ];
        for (rho, z) in pts {
            let m = mag(k, &mut rng);
            k += 1;
            let phi = 2.0 * PI * rng.gen::<f64>();
            out.push(Sample {
                region: "aspect",
                r,
                l,
                m,
                p: at_phi(rho, phi, z),
            });
        }
        for f in [2.5, 40.0] {
            let m = mag(k, &mut rng);
            k += 1;
            out.push(Sample {
                region: "aspect",
                r,
                l,
                m,
                p: unit(&mut rng) * (f * a),
            });
        }
    }
    // oblique: M not along an axis, assorted points within 2 a.
    for i in 0..per {
        let (r, l) = geo(i + 2);
        let m = unit(&mut rng) * MAGS[i % MAGS.len()];
        let p = loop {
            let p = Vector3::new(
                2.0 * r * (2.0 * rng.gen::<f64>() - 1.0),
                2.0 * r * (2.0 * rng.gen::<f64>() - 1.0),
                2.0 * l * (2.0 * rng.gen::<f64>() - 1.0),
            );
            if surface_distance(r, l, &p) > 1e-3 * r {
                break p;
            }
        };
        out.push(Sample {
            region: "oblique",
            r,
            l,
            m,
            p,
        });
    }
    out
}

/// Points of the three-cylinder table: on the planes z = 0, x = 0 and y = 0.
pub fn three_cylinder_points(seed: u64, per_plane: usize) -> Vec<(&'static str, Vector3<f64>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = Vec::new();
    for plane in ["xy", "yz", "zx"] {
        let mut n = 0;
        while n < per_plane {
            let u = 3.0 * (2.0 * rng.gen::<f64>() - 1.0);
            let v = 7.0 * (2.0 * rng.gen::<f64>() - 1.0);
            let p = match plane {
                "xy" => Vector3::new(u, v, 0.0),
                "yz" => Vector3::new(0.0, u, v),
                _ => Vector3::new(u, 0.0, v),
            };
            let ok = THREE_POSES.iter().all(|pose| {
                let pl = pose.rotation().inverse() * (p - Vector3::from(pose.centre));
                surface_distance(THREE_R, THREE_L, &pl) > 0.01
            });
            if ok {
                out.push((plane, p));
                n += 1;
            }
        }
    }
    out
}

// ---------------------------------------------------------------------------------------------
// Generator.

fn e17(x: f64) -> String {
    format!("{x:.16e}")
}

/// Seeds of the three tables.
pub const SEED_FIELD: u64 = 20_260_503;
pub const SEED_GRADIENT: u64 = 20_260_504;
pub const SEED_THREE: u64 = 20_260_505;
/// Rows whose estimated relative error exceeds this are flagged (see README).
pub const FLAG_REL: f64 = 1e-14;

/// The leading CSV fields of a sample row: region, radius, half-length, magnetization, point.
fn sample_csv_fields(s: &Sample) -> String {
    format!(
        "{},{},{},{},{},{},{},{},{}",
        s.region,
        e17(s.r),
        e17(s.l),
        e17(s.m.x),
        e17(s.m.y),
        e17(s.m.z),
        e17(s.p.x),
        e17(s.p.y),
        e17(s.p.z)
    )
}

/// `porelab reference regen cylinder-field`: writes cylinder_field.csv, cylinder_gradient.csv
/// and three_cylinders.csv into `reference_dir`.
pub fn regen_cylinder_field(reference_dir: &Path) -> Result<()> {
    let t0 = std::time::Instant::now();
    // Field table.
    let pts = samples(SEED_FIELD, 48, -9.0);
    let rows: Vec<(Vector3<f64>, f64)> = pts
        .par_iter()
        .map(|s| oracle_h(s.r, s.l, &s.m, &s.p))
        .collect();
    let mut csv = String::from(
        "region,radius_m,half_length_m,mx_A_per_m,my_A_per_m,mz_A_per_m,x_m,y_m,z_m,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m,est_rel_err\n",
    );
    let mut flagged = 0;
    for (s, (h, e)) in pts.iter().zip(&rows) {
        let rel = e / h.norm();
        if rel > FLAG_REL {
            flagged += 1;
        }
        let _ = writeln!(
            csv,
            "{},{},{},{},{:.2e}",
            sample_csv_fields(s),
            e17(h.x),
            e17(h.y),
            e17(h.z),
            rel
        );
    }
    super::write_file(reference_dir, "cylinder_field.csv", csv)?;
    eprintln!(
        "cylinder_field.csv: {} rows, {flagged} flagged (est_rel_err > {FLAG_REL:e})",
        pts.len()
    );

    // Gradient table.
    let pts = samples(SEED_GRADIENT, 40, -9.0);
    let rows: Vec<(Matrix3<f64>, f64)> = pts
        .par_iter()
        .map(|s| oracle_h_gradient(s.r, s.l, &s.m, &s.p))
        .collect();
    let mut csv = String::from(
        "region,radius_m,half_length_m,mx_A_per_m,my_A_per_m,mz_A_per_m,x_m,y_m,z_m,\
dHx_dx_A_per_m2,dHx_dy_A_per_m2,dHx_dz_A_per_m2,dHy_dx_A_per_m2,dHy_dy_A_per_m2,dHy_dz_A_per_m2,\
dHz_dx_A_per_m2,dHz_dy_A_per_m2,dHz_dz_A_per_m2,est_rel_err\n",
    );
    let mut flagged = 0;
    for (s, (g, e)) in pts.iter().zip(&rows) {
        let rel = e / g.norm();
        if rel > FLAG_REL {
            flagged += 1;
        }
        let mut line = sample_csv_fields(s);
        for i in 0..3 {
            for j in 0..3 {
                let _ = write!(line, ",{}", e17(g[(i, j)]));
            }
        }
        let _ = writeln!(csv, "{line},{rel:.2e}");
    }
    super::write_file(reference_dir, "cylinder_gradient.csv", csv)?;
    eprintln!(
        "cylinder_gradient.csv: {} rows, {flagged} flagged",
        pts.len()
    );

    // Three cylinders.
    let pts = three_cylinder_points(SEED_THREE, 34);
    let rows: Vec<(Vector3<f64>, f64)> =
        pts.par_iter().map(|(_, p)| three_cylinders_h(p)).collect();
    let mut csv = String::from("plane,x_m,y_m,z_m,Hx_A_per_m,Hy_A_per_m,Hz_A_per_m,est_rel_err\n");
    for ((plane, p), (h, e)) in pts.iter().zip(&rows) {
        let _ = writeln!(
            csv,
            "{plane},{},{},{},{},{},{},{:.2e}",
            e17(p.x),
            e17(p.y),
            e17(p.z),
            e17(h.x),
            e17(h.y),
            e17(h.z),
            e / h.norm()
        );
    }
    super::write_file(reference_dir, "three_cylinders.csv", csv)?;
    eprintln!(
        "three_cylinders.csv: {} rows; total {:.1} s",
        pts.len(),
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

#[cfg(test)]
mod self_checks {
    //! Independent self-checks of the oracle (run with `--ignored --nocapture` to see numbers).
    use super::*;
    use crate::special::quadrature::integrate_scalar;

    fn inside(r: f64, l: f64, p: &Vector3<f64>) -> bool {
        p.x.hypot(p.y) < r && p.z.abs() < l
    }

    fn all_samples() -> Vec<Sample> {
        samples(SEED_FIELD, 48, -9.0)
    }

    /// Direct 2-D quadrature of the raw surface-charge kernel (no analytic step at all).
    fn brute(r: f64, l: f64, m: &Vector3<f64>, p: &Vector3<f64>) -> Vector3<f64> {
        let mut h = Vector3::zeros();
        for comp in 0..3 {
            // lateral surface
            let (lat, _) = integrate_scalar(
                |ph| {
                    let sig = m.x * ph.cos() + m.y * ph.sin();
                    let (v, _) = integrate_scalar(
                        |zp| {
                            let d = p - Vector3::new(r * ph.cos(), r * ph.sin(), zp);
                            sig * d[comp] / d.norm().powi(3)
                        },
                        -l,
                        l,
                        1e-13,
                        1e-300,
                    );
                    v * r
                },
                0.0,
                2.0 * PI,
                1e-12,
                1e-300,
            );
            let mut caps = 0.0;
            for (zc, sg) in [(l, m.z), (-l, -m.z)] {
                let (v, _) = integrate_scalar(
                    |ph| {
                        let (w, _) = integrate_scalar(
                            |rp| {
                                let d = p - Vector3::new(rp * ph.cos(), rp * ph.sin(), zc);
                                sg * rp * d[comp] / d.norm().powi(3)
                            },
                            0.0,
                            r,
                            1e-13,
                            1e-300,
                        );
                        w
                    },
                    0.0,
                    2.0 * PI,
                    1e-12,
                    1e-300,
                );
                caps += v;
            }
            h[comp] = (lat + caps) / (4.0 * PI);
        }
        h
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn brute_force_agreement() {
        let pts = [
            (1.0, 2.0, Vector3::new(0.4, 0.3, 0.7)),
            (1.0, 2.0, Vector3::new(1.3, -0.2, 1.1)),
            (1.0, 0.5, Vector3::new(0.2, 0.5, 0.9)),
            (1.0, 0.5, Vector3::new(-1.6, 0.4, -0.3)),
            (2e-3, 1e-3, Vector3::new(1e-3, -2.5e-3, -2e-3)),
        ];
        let ms = [
            Vector3::new(0.0, 0.0, 1e6),
            Vector3::new(1e6, 0.0, 0.0),
            Vector3::new(0.0, 1e6, 0.0),
            Vector3::new(3e5, -7e5, 5e5),
        ];
        let mut worst: f64 = 0.0;
        for (r, l, p) in pts {
            for m in &ms {
                let (h, _) = oracle_h_quadrature(r, l, m, &p);
                let b = brute(r, l, m, &p);
                let e = (h - b).norm() / h.norm();
                worst = worst.max(e);
            }
        }
        println!("brute-force 2-D quadrature vs oracle: worst rel diff {worst:.2e}");
        assert!(worst < 1e-9);
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn trace_and_symmetry() {
        let mut worst_tr: f64 = 0.0;
        let mut worst_sym: f64 = 0.0;
        for s in all_samples() {
            let hx = oracle_h(s.r, s.l, &Vector3::x(), &s.p).0;
            let hy = oracle_h(s.r, s.l, &Vector3::y(), &s.p).0;
            let hz = oracle_h(s.r, s.l, &Vector3::z(), &s.p).0;
            let want = if inside(s.r, s.l, &s.p) { -1.0 } else { 0.0 };
            let scale = hx.norm().max(hy.norm()).max(hz.norm());
            let tr = (hx.x + hy.y + hz.z - want).abs() / scale;
            if tr > 1e-14 {
                println!(
                    "trace dev {tr:.2e} {} r={} l={} p={:?}",
                    s.region,
                    s.r,
                    s.l,
                    s.p.as_slice()
                );
            }
            worst_tr = worst_tr.max(tr);
            let sym = ((hx.y - hy.x).abs() + (hx.z - hz.x).abs() + (hy.z - hz.y).abs()) / scale;
            worst_sym = worst_sym.max(sym);
        }
        println!("trace(Hess psi) = -1/0: worst |dev| / |Hess| = {worst_tr:.2e}; Hess asymmetry {worst_sym:.2e}");
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn infinite_and_axis_limits() {
        // L/R = 1e4, midplane.
        let (r, l) = (1.0, 1e4);
        let mut w_in: f64 = 0.0;
        let mut w_out: f64 = 0.0;
        let mut w_long: f64 = 0.0;
        for (i, rho) in [0.1, 0.5, 0.9, 0.999, 1.001, 1.5, 3.0, 10.0]
            .iter()
            .enumerate()
        {
            let phi = 0.3 + i as f64;
            let p = at_phi(*rho, phi, 0.0);
            for m in [Vector3::x(), Vector3::y(), Vector3::new(0.6, -0.8, 0.0)] {
                let h = oracle_h(r, l, &m, &p).0;
                let want = if *rho < r {
                    -m / 2.0
                } else {
                    let n = Vector3::new(phi.cos(), phi.sin(), 0.0);
                    (2.0 * m.dot(&n) * n - m) * (r * r / (2.0 * rho * rho))
                };
                let e = (h - want).norm();
                if *rho < r {
                    w_in = w_in.max(e);
                } else {
                    w_out = w_out.max(e / want.norm());
                }
            }
            let hl = oracle_h(r, l, &Vector3::z(), &p).0;
            if *rho < r {
                w_long = w_long.max(hl.norm());
            }
        }
        println!(
            "infinite cylinder (L/R=1e4, z=0): transverse inside |H+M/2|/M = {w_in:.2e}, outside rel = {w_out:.2e}; longitudinal inside |H|/M = {w_long:.2e} (expected O((R/L)^2) = 1e-8)"
        );
        // on-axis solenoid formula.
        let mut worst: f64 = 0.0;
        for (r, l) in [(1.0, 3.0), (3e-4, 3e-8), (1e-6, 1e-2), (1.0, 1.0)] {
            for f in [
                -5.0, -1.2, -1.0000001, -0.9999999, -0.5, 0.0, 0.3, 0.999, 1.001, 2.0, 3.5,
            ] {
                let z = f * l;
                let p = Vector3::new(0.0, 0.0, z);
                let h = oracle_h(r, l, &Vector3::z(), &p).0;
                // the textbook formula, evaluated in double-double (it cancels in f64)
                use crate::special::double_double::DD;
                let (zd, ld, rd) = (DD::from_f64(z), DD::from_f64(l), DD::from_f64(r));
                let f = |x: DD| x / (x * x + rd * rd).sqrt();
                let mut want = (f(zd + ld) - f(zd - ld)) * DD::from_f64(0.5);
                if z.abs() < l {
                    want = want - DD::from_f64(1.0);
                }
                let want = want.to_f64();
                worst = worst
                    .max((h.z - want).abs() / want.abs().max(h.norm()) + h.x.hypot(h.y) / h.norm());
            }
        }
        println!("on-axis solenoid formula: worst rel dev {worst:.2e}");
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn jet_rounding() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let (mut w2, mut w3): (f64, f64) = (0.0, 0.0);
        for _ in 0..2000 {
            let rs = log_uniform(&mut rng, 0.5, 6.0);
            let x = unit(&mut rng) * rs;
            let (jx, jy, jz) = (Jet::var(x.x, 0), Jet::var(x.y, 1), Jet::var(x.z, 2));
            let u = jx
                .mul(&jx)
                .add(&jy.mul(&jy))
                .add(&jz.mul(&jz))
                .sqrt()
                .recip();
            let r2 = rs * rs;
            let (mut m2, mut m3, mut n2, mut n3) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
            for i in 0..3 {
                for j in 0..3 {
                    let mut e = [0usize; 3];
                    e[i] += 1;
                    e[j] += 1;
                    let d = if i == j { 1.0 } else { 0.0 };
                    let want = (3.0 * x[i] * x[j] - d * r2) / rs.powi(5);
                    m2 += (u.deriv(e) - want).powi(2);
                    n2 += want.powi(2);
                    for k in 0..3 {
                        let mut e3 = e;
                        e3[k] += 1;
                        let dik = if i == k { 1.0 } else { 0.0 };
                        let djk = if j == k { 1.0 } else { 0.0 };
                        let want = -15.0 * x[i] * x[j] * x[k] / rs.powi(7)
                            + 3.0 * (d * x[k] + dik * x[j] + djk * x[i]) / rs.powi(5);
                        m3 += (u.deriv(e3) - want).powi(2);
                        n3 += want.powi(2);
                    }
                }
            }
            w2 = w2.max((m2 / n2).sqrt() / EPS);
            w3 = w3.max((m3 / n3).sqrt() / EPS);
        }
        println!("jet derivatives of 1/r vs closed form: worst error {w2:.1} eps (2nd), {w3:.1} eps (3rd) of the Frobenius norm (JET_ROUND = {JET_ROUND})");
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn jumps() {
        let mut worst: f64 = 0.0;
        let d = 1e-12;
        let ms = [
            Vector3::new(0.0, 0.0, 1.0),
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.3, -0.5, 0.8),
        ];
        for (r, l) in [(1.0, 2.0), (3e-4, 3e-5)] {
            for m in &ms {
                // lateral at phi = 0.7, z = 0.3 L: n = rho-hat
                let n = Vector3::new(0.7f64.cos(), 0.7f64.sin(), 0.0);
                let po = at_phi(r * (1.0 + d), 0.7, 0.3 * l);
                let pi = at_phi(r * (1.0 - d), 0.7, 0.3 * l);
                let jump = oracle_h(r, l, m, &po).0 - oracle_h(r, l, m, &pi).0;
                worst = worst.max((jump - m.dot(&n) * n).norm() / m.norm());
                // top cap at rho = 0.4 R
                let po = at_phi(0.4 * r, 1.9, l + d * r);
                let pi = at_phi(0.4 * r, 1.9, l - d * r);
                let jump = oracle_h(r, l, m, &po).0 - oracle_h(r, l, m, &pi).0;
                worst = worst.max((jump - m.z * Vector3::z()).norm() / m.norm());
            }
        }
        println!("jump conditions at 1e-12 R: worst |[H] - (M.n) n| / |M| = {worst:.2e}");
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn overlap_quadrature_multipole() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut worst_h = Vec::new();
        let mut worst_g = Vec::new();
        for (r, l) in [
            (1.0f64, 1.0),
            (1e-6, 1e-10),
            (3e-4, 3.0),
            (1.0, 0.3),
            (1.0, 2.5),
        ] {
            let a = r.hypot(l);
            for dist in [5.0, 10.0, 20.0, 50.0] {
                let mut wh: f64 = 0.0;
                let mut wg: f64 = 0.0;
                for _ in 0..6 {
                    let p = unit(&mut rng) * (dist * a);
                    let m = unit(&mut rng) * 1e6;
                    let (hq, _) = oracle_h_quadrature(r, l, &m, &p);
                    let (hm, _) = oracle_h_multipole(r, l, &m, &p);
                    wh = wh.max((hq - hm).norm() / hm.norm());
                    let (gq, _) = oracle_h_gradient_quadrature(r, l, &m, &p);
                    let (gm, _) = oracle_h_gradient_multipole(r, l, &m, &p);
                    wg = wg.max((gq - gm).norm() / gm.norm());
                }
                worst_h.push((l / r, dist, wh));
                worst_g.push((l / r, dist, wg));
            }
        }
        for ((ar, d, wh), (_, _, wg)) in worst_h.iter().zip(&worst_g) {
            println!(
                "overlap L/R={ar:.0e} |p|={d} a: H rel diff {wh:.2e}, grad H rel diff {wg:.2e}"
            );
        }
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn gradient_vs_finite_differences() {
        let mut worst: f64 = 0.0;
        let mut worst_sym: f64 = 0.0;
        for s in samples(SEED_GRADIENT, 40, -9.0).iter().step_by(7) {
            let (g, _) = oracle_h_gradient(s.r, s.l, &s.m, &s.p);
            // distance scale for the step
            let dsurf = surface_distance(s.r, s.l, &s.p).max(1e-300);
            if dsurf < 1e-4 * s.r {
                continue;
            }
            let h = 1e-2 * dsurf.min(s.p.norm().max(s.r));
            let mut fd = Matrix3::zeros();
            for j in 0..3 {
                let mut e = Vector3::zeros();
                e[j] = h;
                let f = |k: f64| oracle_h(s.r, s.l, &s.m, &(s.p + e * k)).0;
                // 4th-order central difference
                let d = (f(-2.0) - f(2.0) + (f(1.0) - f(-1.0)) * 8.0) / (12.0 * h);
                for i in 0..3 {
                    fd[(i, j)] = d[i];
                }
            }
            let e = (fd - g).norm() / g.norm();
            if e > 1e-8 {
                println!(
                    "FD mismatch {e:.2e} {} R={} L={} m={:?} p={:?} dsurf/R={:.1e}",
                    s.region,
                    s.r,
                    s.l,
                    s.m.as_slice(),
                    s.p.as_slice(),
                    dsurf / s.r
                );
            }
            worst = worst.max(e);
            if !use_multipole(s.r, s.l, &s.p) {
                worst_sym = worst_sym.max(gradient_symmetry_defect(s.r, s.l, &s.m, &s.p));
            }
        }
        println!("gradient vs 4th-order finite differences of H: worst rel diff {worst:.2e}; dHz/drho vs dHx/dz asymmetry {worst_sym:.2e}");
    }

    #[test]
    #[ignore = "oracle self-check, slow: cargo test --release --lib cylinder_field::self_checks -- --ignored"]
    fn error_estimates_by_region() {
        let t = std::time::Instant::now();
        let worst = worst_estimate_by_region(all_samples(), "H", 1e-14, |s| {
            let (h, e) = oracle_h(s.r, s.l, &s.m, &s.p);
            (e, h.norm())
        });
        println!("field: {:?} ({:.2} s)", worst, t.elapsed().as_secs_f64());
        let t = std::time::Instant::now();
        let worst = worst_estimate_by_region(samples(SEED_GRADIENT, 40, -9.0), "G", 1e-13, |s| {
            let (g, e) = oracle_h_gradient(s.r, s.l, &s.m, &s.p);
            (e, g.norm())
        });
        println!("gradient: {:?} ({:.2} s)", worst, t.elapsed().as_secs_f64());
    }

    /// Worst estimated relative error e / |value| and sample count by region, where `est`
    /// returns (e, |value|); samples above `flag` are printed with the tag.
    fn worst_estimate_by_region(
        samples: Vec<Sample>,
        tag: &str,
        flag: f64,
        est: impl Fn(&Sample) -> (f64, f64),
    ) -> std::collections::BTreeMap<&'static str, (f64, usize)> {
        let mut worst: std::collections::BTreeMap<&str, (f64, usize)> = Default::default();
        for s in samples {
            let (e, norm) = est(&s);
            let w = worst.entry(s.region).or_insert((0.0, 0));
            if e / norm > flag {
                println!(
                    "flag {tag} {:.2e} {} r={} l={} m={:?} p={:?}",
                    e / norm,
                    s.region,
                    s.r,
                    s.l,
                    s.m.as_slice(),
                    s.p.as_slice()
                );
            }
            w.0 = w.0.max(e / norm);
            w.1 += 1;
        }
        worst
    }
}
