//! The field tensor of a uniformly magnetized cylinder, T = Hess psi with H = T M, where
//! psi(r) = (1/4 pi) int_cyl dV'/|r - r'| (for uniform M the bound-charge potential is
//! -M . grad psi, so every magnetization direction needs the same four functions).
//!
//! In cylindrical form (axisymmetric psi(rho, z)) we need
//!   P = psi_rho / rho,  Q = psi_rhoz / rho,  Z = psi_zz,  Prr = psi_rhorho = -chi - Z - P,
//! with chi = 1 strictly inside. They are assembled into the Cartesian tensor at the end.
//!
//! Each is the difference of a per-end term at xi+ = z + L and xi- = z - L (thesis eq. 5.3-5.6
//! for the longitudinal part, eq. 5.19-5.22 for the transverse part; here rewritten so that no
//! term divides by rho or 1 - gamma^2):
//!   tq = psi_rhoz/rho per end = (R/pi) alpha P1 / rho,  P1 = cel(kc, 1, 1, -1)     (eq. 5.3, 5.39)
//!      = -(4 R^2 / (pi A^3)) J(kc, kc^2)                 (P1 = -m J, integration by parts)
//!   tz = B_z/(mu0 M) per end = R/(pi (R + rho)) beta cel(kc, g^2, 1, g)  (eq. 5.3, 5.42;
//!        Derby-Olbert's sign of g = (R - rho)/(R + rho): with the thesis' g = (rho-R)/(rho+R)
//!        the on-axis solenoid limit fails, so the thesis' footnote sign is not used)
//!   tp = psi_rho/rho per end = -(R/(pi rho)) beta P3 = -(4 R^2/(pi (R+rho)^2)) beta J(kc, g^2)
//!        (eq. 5.20-5.21: P3 = (1 - g^2) J(kc, g^2))
//! where A = sqrt(h^2 + (R+rho)^2), alpha = 1/A, beta = h/A, kc^2 = (h^2 + (R-rho)^2)/A^2,
//! m = 1 - kc^2 = 4 R rho / A^2, and
//!   J(kc, p) = int_0^{pi/2} sin^2 cos^2 / ((cos^2 + p sin^2) sqrt(cos^2 + kc^2 sin^2)) dt,
//! a positive integrand with no cancellation; for 1 - p >= 1/4 it is
//! (cel(kc,1,0,1) - p cel(kc,p,0,1)) / (1 - p) (at most ~1.5 digits lost), and for 1 - p < 1/4
//! (then also m < 1/4: near the axis or far away) the integrand is analytic in a strip of half
//! width acosh(2) and the 16-point periodic trapezoidal rule is exact to ~1e-18.
//!
//! For values, the p = 1 integrals come from the AGM of the one cel loop per end
//! (`bulirsch::agm_cel_lanes`): J(kc, kc^2) = K S/m^2 and cel(kc, 1, 0, 1) = K (1 + S/m)/2 with
//! S = sum_{n>=1} 2^n c_n^2 (eq. 5.39 without its cancellation), so each end costs one division
//! per AGM pass; the loop's pass count is fixed in advance from kc. A longitudinal M needs only
//! Q and Z ([`field_h`]). Dual numbers (the exact gradient, the slab quadrature) keep Bulirsch's
//! two-chain cel, P1 = cel(kc, 1, 1, -1) and the trapezoidal J below m = 0.05.
//!
//! Three regimes keep the two-ended differences from cancelling:
//! * far (r > 4 a, a = sqrt(R^2 + L^2)): the exterior multipole series of psi with exact
//!   moments; truncated where (a/r)^n < 1e-17;
//! * thin slab (the singularity z' = z +- i|R - rho| of the per-end terms is far from
//!   [-L, L] compared with L): Gauss-Legendre quadrature over z' of d/dh of the per-end terms
//!   (derivatives by automatic differentiation), which avoids subtracting nearly equal ends;
//! * otherwise the closed forms; the cap term of Z is taken in charge form
//!   (tz - sign(h)/2 inside rho < R), by a Legendre series of the disk potential when the cap
//!   is farther than 4R, so that the small demagnetizing field inside long cylinders does not
//!   come from 1 - 1.

use crate::special::autodiff::{Dual, Real};
use crate::special::bulirsch::{agm_cel_lanes, cel_lanes, cel_multi2, AgmCel};
use std::f64::consts::PI;
use std::sync::OnceLock;

/// psi_rho/rho, psi_rhoz/rho, psi_zz, psi_rhorho at one point.
#[derive(Debug, Clone, Copy)]
pub struct CylHessian<T> {
    pub p: T,
    pub q: T,
    pub z: T,
    pub prr: T,
    /// Prr - P, formed without the cancellation -chi - 2 P_inf where that is exact (inside a
    /// long cylinder both are ~1 while their difference is the small end effect).
    pub d: T,
}

/// Which formula produced a value (reported by diagnostics and benchmarks).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Regime {
    Multipole,
    SlabQuadrature,
    ClosedForm,
}

/// Per-cylinder constants: radius, semi-length, circumradius and scaled multipole moments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KernelGeometry {
    pub r: f64,
    pub l: f64,
    pub a: f64,
    /// q_n / a^(n+3) for even n = 0, 2, ..., MAX_ORDER - 2, stored at index n/2.
    pub moments: [f64; MAX_ORDER / 2],
}

/// Highest multipole order kept (only reached just outside r = 4a).
const MAX_ORDER: usize = 64;

impl KernelGeometry {
    pub fn new(r: f64, l: f64) -> KernelGeometry {
        let a = r.hypot(l);
        let (rh, lh) = (r / a, l / a);
        // q_n = (1/4pi) int r'^n P_n dV'; r^n P_n = sum_k c_nk z^(n-2k) rho^(2k),
        // c_nk = (-1)^k n! / (4^k (k!)^2 (n-2k)!), and
        // int_cyl z^j rho^(2k) dV = 2 pi R^(2k+2)/(2k+2) * 2 L^(j+1)/(j+1) (j even).
        let mut moments = [0.0; MAX_ORDER / 2];
        let mut n = 0;
        while n < MAX_ORDER {
            let mut c = 1.0f64; // c_n0
            let mut sum = 0.0;
            for k in 0..=n / 2 {
                let j = n - 2 * k;
                let integral =
                    rh.powi(2 * k as i32 + 2) / (2 * k + 2) as f64 * 2.0 * lh.powi(j as i32 + 1)
                        / (j + 1) as f64;
                sum += c * integral * 0.5; // (1/4pi) * 2pi
                                           // c_{n,k+1} = -c_nk (n-2k)(n-2k-1) / (4 (k+1)^2)
                c *= -((j * (j.max(1) - 1)) as f64) / (4.0 * ((k + 1) * (k + 1)) as f64);
            }
            moments[n / 2] = sum;
            n += 2;
        }
        KernelGeometry { r, l, a, moments }
    }
}

/// Legendre P_n(c) and P_n'(c) for n = 0..=nmax.
fn legendre<T: Real>(c: T, nmax: usize, p: &mut [T], dp: &mut [T]) {
    p[0] = T::cst(1.0);
    dp[0] = T::cst(0.0);
    if nmax == 0 {
        return;
    }
    p[1] = c;
    dp[1] = T::cst(1.0);
    for n in 1..nmax {
        let nf = n as f64;
        p[n + 1] =
            (c * p[n]).scale((2.0 * nf + 1.0) / (nf + 1.0)) - p[n - 1].scale(nf / (nf + 1.0));
        dp[n + 1] = p[n].scale(nf + 1.0) + c * dp[n];
    }
}

/// Far regime: exterior multipole series of psi (r > 4a).
fn multipole<T: Real>(g: &KernelGeometry, rho: T, z: T) -> CylHessian<T> {
    let r = (rho * rho + z * z).sqrt();
    let c = z / r;
    let t = T::cst(g.a) / r; // a/r < 1/4
    let tv = t.val();
    // Keep even n while (a/r)^n > 1e-18.
    let mut nmax = 0;
    while nmax + 2 < MAX_ORDER && tv.powi(nmax as i32 + 2) > 1e-18 {
        nmax += 2;
    }
    let mut pl = [T::cst(0.0); MAX_ORDER + 3];
    let mut dpl = [T::cst(0.0); MAX_ORDER + 3];
    legendre(c, nmax + 2, &mut pl, &mut dpl);
    let (mut zz, mut p, mut q) = (T::cst(0.0), T::cst(0.0), T::cst(0.0));
    // q_n / r^(n+3) = (scaled moment) (a/r)^(n+3); accumulate powers.
    let mut tn3 = t * t * t; // t^(n+3) for n = 0
    let t2 = t * t;
    let mut n = 0;
    while n <= nmax {
        let qn = g.moments[n / 2];
        let nf = n as f64;
        let w = tn3.scale(qn);
        zz = zz + (w * pl[n + 2]).scale((nf + 1.0) * (nf + 2.0));
        p = p - w * dpl[n + 1];
        q = q + (w * dpl[n + 2] / r).scale(nf + 1.0);
        tn3 = tn3 * t2;
        n += 2;
    }
    CylHessian {
        p,
        q,
        z: zz,
        prr: -zz - p,
        d: -zz - p - p,
    }
}

/// sin^2(j pi/16), j = 0..=8: the nodes of the 16-point periodic trapezoidal rule on [0, pi/2].
const TRAPEZOID_S: [f64; 9] = [
    0.0,
    0.038060233744356624,
    0.14644660940672624,
    0.3086582838174551,
    0.5,
    0.6913417161825449,
    0.8535533905932737,
    0.9619397662556434,
    1.0,
];

/// By the 16-point periodic trapezoidal rule (exact to ~1e-18 for n, m < 1/4; s = sin^2 t):
/// J(m, m) = int s (1 - s) / (1 - m s)^(3/2) dt, J(n, m) = int s (1 - s) / ((1 - n s) sqrt(1 - m s)) dt
/// and I(n, m, g) = int (cos^2 + g sin^2) / ((1 - n s) sqrt(1 - m s)) dt, sharing one square root
/// and one division per node.
fn trapezoid_j_j_i<T: Real>(n: T, m: T, g: T) -> (T, T, T) {
    let one = T::cst(1.0);
    let (mut j1, mut j2) = (T::cst(0.0), T::cst(0.0));
    // endpoints: s = 0 gives 1 for I and 0 for the J; s = 1 gives g / ((1-n) sqrt(1-m)) for I.
    let mut i = T::cst(0.5) + (g / ((one - n) * (one - m).sqrt())).scale(0.5);
    for &s in &TRAPEZOID_S[1..8] {
        let qm = one - m.scale(s);
        let qn = one - n.scale(s);
        let root = qm.sqrt();
        let inv = one / (qm * qn * root);
        let w_n = qm * inv; // 1 / (qn sqrt(qm))
        let w_m = qn * inv; // 1 / qm^(3/2)
        j1 = j1 + w_m.scale(s * (1.0 - s));
        j2 = j2 + w_n.scale(s * (1.0 - s));
        i = i + w_n * (T::cst(1.0 - s) + g.scale(s));
    }
    let h = PI / 16.0;
    (j1.scale(h), j2.scale(h), i.scale(h))
}

/// J(m, m) alone (see [`trapezoid_j_j_i`]).
fn trapezoid_j1<T: Real>(m: T) -> T {
    let one = T::cst(1.0);
    let mut j1 = T::cst(0.0);
    for &s in &TRAPEZOID_S[1..8] {
        let qm = one - m.scale(s);
        j1 = j1 + (one / (qm * qm.sqrt())).scale(s * (1.0 - s));
    }
    j1.scale(PI / 16.0)
}

/// What one end needs before the elliptic integrals: 1/A^2, 1/A, m, kc and beta.
#[derive(Clone, Copy)]
struct EndPrep<T> {
    inv_a2: T,
    inv_a: T,
    m: T,
    kc: T,
    beta: T,
}

/// What both ends share: R + rho and its inverse, g = (R - rho)/(R + rho), g^2, n = 1 - g^2.
#[derive(Clone, Copy)]
struct PointPrep<T> {
    sum: T,
    inv_sum: T,
    g: T,
    /// |g| = sqrt(g^2), the square root of the characteristic that cel needs.
    g_abs: T,
    g2: T,
    n: T,
    /// 1/n = (R + rho)^2 / (4 R rho) (infinite on the axis, where n is not used as a divisor).
    inv_n: T,
}

#[inline]
fn point_prep<T: Real>(r: f64, rho: T, dif: T) -> PointPrep<T> {
    let sum = T::cst(r) + rho;
    let inv_sum = T::cst(1.0) / sum;
    let g = dif * inv_sum;
    let n = (rho * inv_sum * inv_sum).scale(4.0 * r);
    let inv_n = if rho.val() > 0.0 {
        (sum * sum / rho).scale(0.25 / r)
    } else {
        T::cst(f64::INFINITY)
    };
    PointPrep {
        sum,
        inv_sum,
        g,
        g_abs: if g.val() < 0.0 { -g } else { g },
        g2: g * g,
        n,
        inv_n,
    }
}

#[inline]
fn end_prep<T: Real>(r: f64, rho: T, dif: T, pt: &PointPrep<T>, h: T) -> EndPrep<T> {
    let sum = pt.sum;
    let a2 = h * h + sum * sum;
    let inv_a2 = T::cst(1.0) / a2;
    let a = a2.sqrt();
    let inv_a = a * inv_a2;
    let m = (rho * inv_a2).scale(4.0 * r);
    // kc = sqrt(h^2 + (R - rho)^2)/A. For values directly (accurate to rounding, and no branch
    // on the way into the elliptic integrals, whose latency bounds the kernel). For dual numbers
    // kc^2 = 1 - m where that is exact enough (so that its derivative, used by the slab
    // quadrature and the gradient, is -dm and does not cancel), directly near the rim.
    let kc = if !T::DERIVATIVES {
        (h * h + dif * dif).sqrt() * inv_a
    } else if m.val() < 0.5 {
        (T::cst(1.0) - m).sqrt()
    } else {
        ((h * h + dif * dif) * inv_a2).sqrt()
    };
    // beta = h / A; for dual numbers far from the end (|h| > R + rho) as
    // sign(h) (1 - s^2/(A (A + |h|))), whose derivatives do not cancel (the plain quotient's
    // d/dh is (A^2 - h^2)/A^3). (Values: the quotient, no division or branch.)
    let beta = if T::DERIVATIVES && h.val().abs() > sum.val() {
        let sg = h.val().signum();
        let habs = if sg < 0.0 { -h } else { h };
        (T::cst(1.0) - sum * sum / (a * (a + habs))).scale(sg)
    } else {
        h * inv_a
    };
    EndPrep {
        inv_a2,
        inv_a,
        m,
        kc,
        beta,
    }
}

/// Per-end terms (tq, tz, tp) at signed height h from the end (see module docs).
#[inline]
fn end_terms<T: Real>(r: f64, rho: T, dif: T, h: T) -> (T, T, T) {
    let pt = point_prep(r, rho, dif);
    let e = end_prep(r, rho, dif, &pt, h);
    if e.kc.val() == 0.0 {
        // On the rim circle: the field is logarithmically infinite.
        let inf = T::cst(f64::INFINITY);
        return (inf, inf, inf);
    }
    if pt.n.val() < 0.25 {
        return end_terms_trapezoid(r, &pt, &e);
    }
    if T::DERIVATIVES {
        return end_terms_two_chains(r, &pt, &e);
    }
    let cels = if pt.g2.val() == 0.0 {
        // rho = R exactly: cel(kc, g^2, 1, g) -> K(kc) + sign(g) pi/(2 kc) as g -> 0. Off the
        // lateral surface (|z| > L) the two ends' jumps cancel and the mean K is right; on it
        // `end_terms_at` adds the outside limit's jump. c01 is then not needed.
        let [o] = agm_cel_lanes::<T, 1, 0>([e.kc], [e.m], T::cst(1.0), []);
        AgmCel {
            k: o.k,
            s_over_m2: o.s_over_m2,
            cel: [o.k, T::cst(0.0)],
        }
    } else {
        let [o] = agm_cel_lanes::<T, 1, 2>([e.kc], [e.m], pt.g_abs, end_pairs(&pt));
        o
    };
    end_terms_from_cel(r, &pt, &e, &cels)
}

/// The (a, b) pairs of cel(kc, g^2, a, b) that the closed forms need: (1, g) for tz
/// (thesis eq. 5.40) and, with M = 2, (0, 1) for the transverse J(kc, g^2) (eq. 5.20-5.21).
#[inline]
fn end_pairs<T: Real, const M: usize>(pt: &PointPrep<T>) -> [(T, T); M] {
    std::array::from_fn(|i| {
        if i == 0 {
            (T::cst(1.0), pt.g)
        } else {
            (T::cst(0.0), T::cst(1.0))
        }
    })
}

/// Both ends at once (interleaved elliptic integrals when both take the cel branch). With
/// M = 1 (longitudinal magnetization only) the transverse tp of the cel branch is skipped
/// (returned as 0).
#[inline]
fn end_terms_pair<T: Real, const M: usize>(r: f64, rho: T, dif: T, hp: T, hm: T) -> [(T, T, T); 2] {
    let pt = point_prep(r, rho, dif);
    if pt.n.val() < 0.25 || pt.g2.val() == 0.0 {
        return [end_terms(r, rho, dif, hp), end_terms(r, rho, dif, hm)];
    }
    let ep = end_prep(r, rho, dif, &pt, hp);
    let em = end_prep(r, rho, dif, &pt, hm);
    if ep.kc.val() == 0.0 || em.kc.val() == 0.0 {
        return [end_terms(r, rho, dif, hp), end_terms(r, rho, dif, hm)];
    }
    if T::DERIVATIVES {
        // Both ends' two-chain cel interleaved (see `end_terms_two_chains`).
        let one = T::cst(1.0);
        let [cp, cm] = cel_lanes(
            [ep.kc, em.kc],
            one,
            two_chain_p1_pairs(),
            pt.g2,
            [(one, pt.g), (T::cst(0.0), one)],
        );
        return [
            two_chain_terms(r, &pt, &ep, cp),
            two_chain_terms(r, &pt, &em, cm),
        ];
    }
    let [cp, cm] = agm_cel_lanes::<T, 2, M>([ep.kc, em.kc], [ep.m, em.m], pt.g_abs, end_pairs(&pt));
    [
        end_terms_from_cel(r, &pt, &ep, &cp),
        end_terms_from_cel(r, &pt, &em, &cm),
    ]
}

/// The cel branch (n >= 1/4), from K, S/m^2 (see [`AgmCel`]), cz = cel(kc, g^2, 1, g) and
/// c01 = cel(kc, g^2, 0, 1) (unused when g = 0):
/// tq uses J(kc, kc^2) = K S/m^2 (eq. 5.39 without its cancellation: P1 = -m J), tp uses
/// J(kc, g^2) = (cel(kc, 1, 0, 1) - g^2 c01)/n with cel(kc, 1, 0, 1) = K (1 + m S/m^2)/2.
/// With M = 1 (no c01) tp is not formed and returned as 0.
#[inline]
fn end_terms_from_cel<T: Real, const M: usize>(
    r: f64,
    pt: &PointPrep<T>,
    e: &EndPrep<T>,
    c: &AgmCel<T, M>,
) -> (T, T, T) {
    let cz = c.cel[0];
    let j1 = c.k * c.s_over_m2;
    let tq = (j1 * e.inv_a2 * e.inv_a).scale(-4.0 * r * r / PI);
    let tz = (e.beta * cz * pt.inv_sum).scale(r / PI);
    if M < 2 {
        return (tq, tz, T::cst(0.0));
    }
    let c01 = c.cel[M - 1];
    let c101 = (c.k + j1 * e.m).scale(0.5);
    let j2 = if pt.g2.val() == 0.0 {
        c101
    } else {
        (c101 - pt.g2 * c01) * pt.inv_n
    };
    let pref_p = (pt.inv_sum * pt.inv_sum).scale(-4.0 * r * r / PI);
    let tp = pref_p * e.beta * j2;
    (tq, tz, tp)
}

/// Below this m, the two-chain form takes tq from the trapezoidal J(kc, kc^2) instead of
/// P1 = cel(kc, 1, 1, -1) = -m J, whose absolute rounding would then be ~eps/(m J) relative.
const TQ_TRAPEZOID_BELOW_M: f64 = 0.05;

/// The cel branch for dual numbers: Bulirsch's cel with its own chain for p = 1, P1 =
/// cel(kc, 1, 1, -1) (eq. 5.39) and cel(kc, 1, 0, 1) from it, as the exact gradient was
/// validated with. (The AGM-sum form of [`end_terms_from_cel`] is as accurate for values, but
/// its derivatives near the lateral surface and for small m round differently, up to 1.7 times
/// the two-chain form's worst gradient error in cases 105 and 108.)
fn end_terms_two_chains<T: Real>(r: f64, pt: &PointPrep<T>, e: &EndPrep<T>) -> (T, T, T) {
    let one = T::cst(1.0);
    let zero = T::cst(0.0);
    let cels = if pt.g2.val() == 0.0 {
        // rho = R exactly: see `end_terms`; c01 is then not needed.
        let (p1c101, [k]) = cel_multi2(e.kc, one, two_chain_p1_pairs(), one, [(one, one)]);
        (p1c101, [k, zero])
    } else {
        cel_multi2(
            e.kc,
            one,
            two_chain_p1_pairs(),
            pt.g2,
            [(one, pt.g), (zero, one)],
        )
    };
    two_chain_terms(r, pt, e, cels)
}

/// The (a, b) pairs of cel(kc, 1, a, b) of the two-chain form: P1 (eq. 5.39), cel(kc, 1, 0, 1).
fn two_chain_p1_pairs<T: Real>() -> [(T, T); 2] {
    let one = T::cst(1.0);
    [(one, -one), (T::cst(0.0), one)]
}

/// Per-end terms from p1 = cel(kc,1,1,-1), c101 = cel(kc,1,0,1), cz = cel(kc,g^2,1,g) and
/// c01 = cel(kc,g^2,0,1) (unused when g = 0).
fn two_chain_terms<T: Real>(
    r: f64,
    pt: &PointPrep<T>,
    e: &EndPrep<T>,
    ([p1, c101], [cz, c01]): ([T; 2], [T; 2]),
) -> (T, T, T) {
    let tq = if e.m.val() < TQ_TRAPEZOID_BELOW_M {
        (trapezoid_j1(e.m) * e.inv_a2 * e.inv_a).scale(-4.0 * r * r / PI)
    } else {
        // p1 / (A rho) = 4 R p1 / (m A^3)
        (p1 * e.inv_a2 * e.inv_a / e.m).scale(4.0 * r * r / PI)
    };
    let tz = (e.beta * cz * pt.inv_sum).scale(r / PI);
    let j2 = if pt.g2.val() == 0.0 {
        c101
    } else {
        (c101 - pt.g2 * c01) * pt.inv_n
    };
    let pref_p = (pt.inv_sum * pt.inv_sum).scale(-4.0 * r * r / PI);
    (tq, tz, pref_p * e.beta * j2)
}

/// The trapezoid branch (n < 1/4: near the axis or far out, where m <= n < 1/4).
#[inline]
fn end_terms_trapezoid<T: Real>(r: f64, pt: &PointPrep<T>, e: &EndPrep<T>) -> (T, T, T) {
    let (j1, j2, iz) = trapezoid_j_j_i(pt.n, e.m, pt.g);
    let tq = (j1 * e.inv_a2 * e.inv_a).scale(-4.0 * r * r / PI);
    let tz = (e.beta * iz * pt.inv_sum).scale(r / PI);
    let pref_p = (pt.inv_sum * pt.inv_sum).scale(-4.0 * r * r / PI);
    let tp = pref_p * e.beta * j2;
    (tq, tz, tp)
}

/// Charge-form cap term C_z = -Omega/(4 pi) of the disk at signed height h (Omega = solid
/// angle), for r_c = sqrt(rho^2 + h^2) > 10R: Legendre series of the disk potential,
/// Phi_d = 2 pi sum_{l>=1} binom(1/2, l) R^(2l) P_{2l-2}(cos) / r^(2l-1), differentiated in z.
#[inline(never)]
fn cap_series_cz<T: Real>(r: f64, rho: T, h: T) -> T {
    let rc = (rho * rho + h * h).sqrt();
    let c = h / rc;
    let x = T::cst(r) / rc;
    let xv = x.val();
    // the term l is (R/r)^(2l - 2) relative to the first: stop when that is below 1e-18.
    let mut lmax = 1;
    while lmax < CAP_SERIES_MAX_L && xv.powi(2 * lmax as i32) > 1e-18 {
        lmax += 1;
    }
    let x2 = x * x;
    let mut xp = x2; // x^(2l)
    let mut binom = 0.5; // binom(1/2, l)
    let mut sum = T::cst(0.0);
    // Legendre P_n(c) by the upward recurrence; P_{2l-1} is used.
    let (mut p_prev, mut p_cur) = (T::cst(1.0), c); // P_0, P_1
    let mut n = 1;
    for l in 1..=lmax {
        let lf = l as f64;
        while n < 2 * l - 1 {
            let nf = n as f64;
            let p_next =
                (c * p_cur).scale((2.0 * nf + 1.0) / (nf + 1.0)) - p_prev.scale(nf / (nf + 1.0));
            p_prev = p_cur;
            p_cur = p_next;
            n += 1;
        }
        sum = sum + (xp * p_cur).scale(binom * (2.0 * lf - 1.0));
        binom *= (0.5 - lf) / (lf + 1.0);
        xp = xp * x2;
    }
    // C_z = (1/4pi) dPhi_d/dh = -(1/2) sum_l binom(1/2, l) (2l-1) (R/r)^(2l) P_{2l-1}(cos)
    sum.scale(-0.5)
}

/// The cap series is used beyond this many radii from the cap centre (where tz - 1/2 would
/// cancel by more than ~100) and needs at most this many terms there.
const CAP_SERIES_MIN_DISTANCE: f64 = 10.0;
const CAP_SERIES_MAX_L: usize = 12;

/// Gauss-Legendre nodes and weights on [-1, 1] for n = 1..=24 (computed once).
fn gauss_legendre(n: usize) -> &'static [(f64, f64)] {
    static TABLE: OnceLock<Vec<Vec<(f64, f64)>>> = OnceLock::new();
    let t = TABLE.get_or_init(|| {
        (0..=24)
            .map(crate::special::quadrature::gauss_legendre)
            .collect()
    });
    &t[n]
}

/// Bernstein-ellipse parameter of the per-end singularity z' = z + i|R - rho| with respect to
/// the interval [-L, L]: Gauss-Legendre with n nodes converges like rho_B^(-2n).
fn bernstein(l: f64, dif: f64, z: f64) -> f64 {
    let (u, v) = (z / l, dif.abs() / l);
    // s = sqrt(w^2 - 1), w = u + i v
    let (re, im) = (u * u - v * v - 1.0, 2.0 * u * v);
    let modulus = (re * re + im * im).sqrt();
    let mut sr = ((modulus + re) * 0.5).max(0.0).sqrt();
    let mut si = ((modulus - re) * 0.5).max(0.0).sqrt();
    if im < 0.0 {
        si = -si;
    }
    if sr * u + si * v < 0.0 {
        sr = -sr;
        si = -si;
    }
    ((u + sr) * (u + sr) + (v + si) * (v + si)).sqrt()
}

/// Use the slab quadrature when the closed form would cancel by more than this factor.
const SLAB_BERNSTEIN_MIN: f64 = 8.0;

/// R - rho to full relative precision from the Cartesian point: (R^2 - x^2 - y^2)/(R + rho)
/// with the numerator in compensated arithmetic (rho itself carries an absolute rounding error
/// of eps R, which near the lateral surface would be most of R - rho).
pub fn radial_gap(r: f64, x: f64, y: f64) -> f64 {
    use crate::special::double_double::{two_prod, two_sum};
    let rho2 = x * x + y * y;
    let naive = r * r - rho2;
    if naive.abs() > 0.1 * r * r {
        // Far from the lateral surface the plain difference is good to a few eps.
        return naive / (r + rho2.sqrt());
    }
    let (r2, r2e) = two_prod(r, r);
    let (x2, x2e) = two_prod(x, x);
    let (y2, y2e) = two_prod(y, y);
    let (s1, e1) = two_sum(r2, -x2);
    let (s2, e2) = two_sum(s1, -y2);
    let num = s2 + (e1 + e2 + (r2e - x2e - y2e));
    num / (r + rho2.sqrt())
}

/// Hess psi in cylindrical form at (rho, z); `dif` = R - rho (value from [`radial_gap`]).
pub fn cyl_hessian<T: Real>(g: &KernelGeometry, rho: T, dif: T, z: T) -> (CylHessian<T>, Regime) {
    cyl_hessian_parts::<T, 2>(g, rho, dif, z)
}

/// [`cyl_hessian`] with M = 2; with M = 1 only what a longitudinal magnetization needs, Q and Z
/// (thesis eq. 5.3-5.6): the closed forms then skip the transverse per-end terms (eq. 5.19-5.22)
/// and their cancellation test, and p, prr and d are NaN.
fn cyl_hessian_parts<T: Real, const M: usize>(
    g: &KernelGeometry,
    rho: T,
    dif: T,
    z: T,
) -> (CylHessian<T>, Regime) {
    let (r, l) = (g.r, g.l);
    let (rv, zv, dv) = (rho.val(), z.val(), dif.val());
    let inside = dv > 0.0 && zv.abs() < l;
    let chi = if inside { 1.0 } else { 0.0 };
    if rv * rv + zv * zv > 16.0 * g.a * g.a {
        return (multipole(g, rho, z), Regime::Multipole);
    }
    // rho_B <= 2|w| with w = (z + i|R - rho|)/L, so only |w| > SLAB_BERNSTEIN_MIN/2 can qualify.
    if zv * zv + dv * dv > (0.25 * SLAB_BERNSTEIN_MIN * SLAB_BERNSTEIN_MIN) * (l * l) && dv != 0.0 {
        let rb = bernstein(l, dv, zv);
        if rb > SLAB_BERNSTEIN_MIN {
            return (
                slab_quadrature(g, rho, dif, z, chi, rb),
                Regime::SlabQuadrature,
            );
        }
    }
    // Closed forms at the two ends (side: which sign h = 0 counts as, the outside of that cap).
    let xp = z + T::cst(l);
    let xm = z - T::cst(l);
    let [(tq_p, tz_p, tp_p), (tq_m, tz_m, tp_m)] = if dv == 0.0 && zv.abs() <= l {
        [
            end_terms_at(r, rho, dif, xp, zv, l),
            end_terms_at(r, rho, dif, xm, zv, l),
        ]
    } else {
        end_terms_pair::<T, M>(r, rho, dif, xp, xm)
    };
    let cz_p = cap_cz(r, rho, dif, xp, tz_p, -1.0);
    let cz_m = cap_cz(r, rho, dif, xm, tz_m, 1.0);
    let q = tq_p - tq_m;
    let zz = cz_p - cz_m;
    let zero = T::cst(0.0);
    // If the two ends still cancel (e.g. far from a thin slab), and Gauss-Legendre along the
    // axis converges to rounding with at most 24 nodes, integrate instead of subtracting.
    let cancels = |a: T, b: T, c: T| {
        a.val().abs() + b.val().abs() + c.val().abs()
            > CANCELLATION_MAX * (a.val() - b.val() + c.val()).abs().max(1e-300)
    };
    let slab_fallback = |cancelling: bool| {
        if cancelling && dv != 0.0 {
            let rb = bernstein(l, dv, zv);
            if rb > SLAB_BERNSTEIN_FALLBACK {
                return Some((
                    slab_quadrature(g, rho, dif, z, chi, rb),
                    Regime::SlabQuadrature,
                ));
            }
        }
        None
    };
    if M < 2 {
        if let Some(out) = slab_fallback(cancels(tq_p, tq_m, zero) || cancels(cz_p, cz_m, zero)) {
            return out;
        }
        let nan = T::cst(f64::NAN);
        return (
            CylHessian {
                p: nan,
                q,
                z: zz,
                prr: nan,
                d: nan,
            },
            Regime::ClosedForm,
        );
    }
    // Transverse per-end terms tend to sign(h) tp_inf far from their end; subtract it.
    let tp_inf = if dv >= 0.0 {
        T::cst(-0.25)
    } else {
        let ratio = T::cst(r) / rho;
        (ratio * ratio).scale(-0.25)
    };
    let (dp_p, s_p) = offset_tp(r, rho, dif, xp, tp_p, tp_inf, -1.0);
    let (dp_m, s_m) = offset_tp(r, rho, dif, xm, tp_m, tp_inf, 1.0);
    let p_inf = tp_inf.scale(s_p - s_m);
    let p = dp_p - dp_m + p_inf;
    if let Some(out) = slab_fallback(
        cancels(dp_p, dp_m, p_inf) || cancels(tq_p, tq_m, zero) || cancels(cz_p, cz_m, zero),
    ) {
        return out;
    }
    // Prr - P = -chi - Z - 2 P = (-chi - 2 P_inf) - Z - 2 (dp_p - dp_m): the bracket is exact.
    let d = (-T::cst(chi) - p_inf.scale(2.0)) - zz - (dp_p - dp_m).scale(2.0);
    (
        CylHessian {
            p,
            q,
            z: zz,
            prr: -T::cst(chi) - zz - p,
            d,
        },
        Regime::ClosedForm,
    )
}

/// sign(h), with h = 0 counted as `side` (the outside of the cap in question: +1 above the top
/// cap, -1 below the bottom one), as everywhere on the surface.
fn side_sign(h: f64, side: f64) -> f64 {
    if h > 0.0 {
        1.0
    } else if h < 0.0 {
        -1.0
    } else {
        side
    }
}

/// dp = tp(h) - s tp_inf with s = sign(h) (`side` at h = 0), and s. Where the subtraction would
/// cancel (far from the end, |h| > 4R) dp is computed as the tail integral
/// dp(h) = -s int_{|h|}^inf tp'(s u) du, with u = |h|/t and 10-point Gauss-Legendre in t on
/// [0, 1] (the integrand ~ t/h^2 is analytic there; its singularities sit at |t| >= 4).
#[inline]
fn offset_tp<T: Real>(r: f64, rho: T, dif: T, h: T, tp: T, tp_inf: T, side: f64) -> (T, f64) {
    let hv = h.val();
    let s = side_sign(hv, side);
    let direct = tp - tp_inf.scale(s);
    // Derivatives of the difference cancel sooner than its value: switch earlier for duals.
    let limit = if T::DERIVATIVES {
        30.0
    } else {
        CANCELLATION_MAX
    };
    if hv.abs() <= 4.0 * r || tp_inf.val().abs() <= limit * direct.val().abs() {
        return (direct, s);
    }
    (offset_tp_tail(r, rho, dif, h, s), s)
}

/// The tail-integral form of [`offset_tp`] (rarely needed: kept out of the inlined path).
#[inline(never)]
fn offset_tp_tail<T: Real>(r: f64, rho: T, dif: T, h: T, s: f64) -> T {
    let habs = if h.val() < 0.0 { -h } else { h };
    let rho_d = Dual::<T, 1>::constant(rho);
    let dif_d = Dual::<T, 1>::constant(dif);
    let mut acc = T::cst(0.0);
    for &(x, w) in gauss_legendre(TAIL_NODES) {
        let t = 0.5 * (x + 1.0);
        let u = habs.scale(1.0 / t);
        let hh = Dual::<T, 1>::variable(u.scale(s), 0);
        let (_, _, tpd) = end_terms(r, rho_d, dif_d, hh);
        acc = acc + (tpd.d[0] * habs).scale(0.5 * w / (t * t));
    }
    -acc.scale(s)
}

const TAIL_NODES: usize = 10;

/// Closed-form ends cancelling by more than this factor are replaced by the slab quadrature.
const CANCELLATION_MAX: f64 = 300.0;
/// ... when 24 Gauss-Legendre nodes then reach 1e-17 (rho_B^-48 < 1e-17).
const SLAB_BERNSTEIN_FALLBACK: f64 = 2.3;

/// psi quantities as integrals over z' in [-L, L] of d/dh of the (smooth, current-form)
/// per-end terms, by Gauss-Legendre with enough nodes for rho_B^(-2n) < 1e-17.
fn slab_quadrature<T: Real>(
    g: &KernelGeometry,
    rho: T,
    dif: T,
    z: T,
    chi: f64,
    rb: f64,
) -> CylHessian<T> {
    let (r, l) = (g.r, g.l);
    let n = ((17.0 * std::f64::consts::LN_10) / (2.0 * rb.ln())).ceil() as usize + 1;
    let n = n.clamp(2, 24);
    let rho_d = Dual::<T, 1>::constant(rho);
    let dif_d = Dual::<T, 1>::constant(dif);
    let (mut p, mut q, mut zz) = (T::cst(0.0), T::cst(0.0), T::cst(0.0));
    for &(x, w) in gauss_legendre(n) {
        let h = Dual::<T, 1>::variable(z - T::cst(l * x), 0);
        let (tq, tz, tp) = end_terms(r, rho_d, dif_d, h);
        p = p + tp.d[0].scale(w * l);
        q = q + tq.d[0].scale(w * l);
        zz = zz + tz.d[0].scale(w * l);
    }
    let zz = zz - T::cst(chi);
    let prr = -T::cst(chi) - zz - p;
    CylHessian {
        p,
        q,
        z: zz,
        prr,
        d: prr - p,
    }
}

/// Per-end terms, taking the outside limit on the lateral surface (rho = R, |z| <= L).
fn end_terms_at<T: Real>(r: f64, rho: T, dif: T, h: T, zv: f64, l: f64) -> (T, T, T) {
    if dif.val() == 0.0 && zv.abs() <= l {
        // Outside limit: cel(kc, g^2, 1, g) -> K(kc) - pi/(2 kc) as g -> 0-.
        let (tq, tz, tp) = end_terms(r, rho, dif, h);
        let rr = T::cst(r);
        let a2 = h * h + (rr + rho) * (rr + rho);
        let kc = (h * h / a2).sqrt();
        let beta = h / a2.sqrt();
        let jump = (beta / (kc * (rr + rho))).scale(-r * 0.5);
        return (tq, tz + jump, tp);
    }
    end_terms(r, rho, dif, h)
}

/// Charge-form cap term: C_z = tz - sign(h)/2 for rho < R (sign at h = 0 chosen by `side`:
/// +1 for the top cap, whose outside is h > 0, -1 for the bottom cap), series when far.
#[inline]
fn cap_cz<T: Real>(r: f64, rho: T, dif: T, h: T, tz: T, side: f64) -> T {
    let (rv, hv) = (rho.val(), h.val());
    // (For rho > R the closed form tends to 0 from O(1) pieces, for rho < R to 1/2: both cancel
    // far from the cap.)
    if rv * rv + hv * hv > (CAP_SERIES_MIN_DISTANCE * r) * (CAP_SERIES_MIN_DISTANCE * r) {
        return cap_series_cz(r, rho, h);
    }
    if dif.val() > 0.0 {
        let s = side_sign(hv, side);
        tz - T::cst(0.5 * s)
    } else {
        tz
    }
}

/// The Cartesian tensor T = Hess psi at (x, y, z) (cylinder frame), H = T M.
pub fn field_tensor<T: Real>(g: &KernelGeometry, x: T, y: T, z: T) -> ([[T; 3]; 3], Regime) {
    let rho2 = x * x + y * y;
    let on_axis = rho2.val() == 0.0;
    let rho = if on_axis { T::cst(0.0) } else { rho2.sqrt() };
    let dif = (T::cst(g.r) - rho).with_value(radial_gap(g.r, x.val(), y.val()));
    let (hc, regime) = cyl_hessian(g, rho, dif, z);
    (assemble(x, y, &hc), regime)
}

/// H = T M at (x, y, z) (cylinder frame) for magnetization `m` (the tensor assembled here,
/// inline, rather than returned by [`field_tensor`]). For a longitudinal M (m_x = m_y = 0)
/// only Q and Z are formed, H = m_z (x Q, y Q, Z) (thesis eq. 5.3-5.6); otherwise also the
/// transverse parts (eq. 5.19-5.22).
pub fn field_h(g: &KernelGeometry, x: f64, y: f64, z: f64, m: [f64; 3]) -> [f64; 3] {
    let rho2 = x * x + y * y;
    let rho = rho2.sqrt();
    let dif = radial_gap(g.r, x, y);
    if m[0] == 0.0 && m[1] == 0.0 {
        let (hc, _) = cyl_hessian_parts::<f64, 1>(g, rho, dif, z);
        let qm = hc.q * m[2];
        return [x * qm, y * qm, hc.z * m[2]];
    }
    let (hc, _) = cyl_hessian(g, rho, dif, z);
    let t = assemble(x, y, &hc);
    let row = |i: usize| t[i][0] * m[0] + t[i][1] * m[1] + t[i][2] * m[2];
    [row(0), row(1), row(2)]
}

/// The Cartesian tensor from its cylindrical parts at (x, y):
/// T = P I_xy + (Prr - P) e_rho e_rho^T + Q (x, y) e_z^T + sym. + Z e_z e_z^T.
#[inline]
pub fn assemble<T: Real>(x: T, y: T, hc: &CylHessian<T>) -> [[T; 3]; 3] {
    let rho2 = x * x + y * y;
    let (c2, s2, cs) = if rho2.val() == 0.0 {
        (T::cst(1.0), T::cst(0.0), T::cst(0.0))
    } else {
        let inv = T::cst(1.0) / rho2;
        (x * x * inv, y * y * inv, x * y * inv)
    };
    let d = hc.d;
    let txx = hc.p + c2 * d;
    let tyy = hc.p + s2 * d;
    let txy = cs * d;
    let txz = x * hc.q;
    let tyz = y * hc.q;
    [[txx, txy, txz], [txy, tyy, tyz], [txz, tyz, hc.z]]
}

/// The tensor with its exact gradient (entries: value, d/dx, d/dy, d/dz) away from the axis.
///
/// Automatic differentiation in rho of the closed forms loses digits near the lateral surface
/// (the characteristic p = g^2 -> 0 enters as g/|g|), so only psi_rho/rho is differentiated in
/// rho; every other rho-derivative follows from z-derivatives (which never touch g) through
/// Laplace's equation (psi_rhorho + psi_rho/rho + psi_zz = -chi) and the symmetry of mixed
/// derivatives:  d_rho Z = rho d_z Q,  d_rho(rho Q) = -d_z Z - d_z P,  d_rho Prr = -d_rho Z - d_rho P.
pub fn tensor_with_gradient(g: &KernelGeometry, x: f64, y: f64, z: f64) -> [[Dual<f64, 3>; 3]; 3] {
    type D2 = Dual<f64, 2>;
    type D3 = Dual<f64, 3>;
    let rho = (x * x + y * y).sqrt();
    let rho_d = D2::variable(rho, 0);
    let dif = (D2::cst(g.r) - rho_d).with_value(radial_gap(g.r, x, y));
    let (hc, _) = cyl_hessian(g, rho_d, dif, D2::variable(z, 1));
    let (p, p_r, p_z) = (hc.p.v, hc.p.d[0], hc.p.d[1]);
    let (q, q_z) = (hc.q.v, hc.q.d[1]);
    let (zz, z_z) = (hc.z.v, hc.z.d[1]);
    let z_r = rho * q_z;
    // On the axis itself (rho = 0 exactly; reached here only in the far regime, since
    // `near_axis` takes the points within 1e-3 R of the axis inside r = 4a) q is even in rho,
    // so q_r = 0, and the radial unit vector below multiplies rho-derivatives that vanish there:
    // 0 in place of 0/0. Off the axis the quotient is used; its rounding error ~eps |q| / rho
    // enters the tensor's gradient only multiplied by x or y (T_xz = x q), so it stays ~eps |q|.
    let q_r = if rho == 0.0 {
        0.0
    } else {
        (-z_z - p_z - q) / rho
    };
    let prr_r = -z_r - p_r;
    let prr_z = -z_z - p_z;
    let (d_r, d_z) = (prr_r - p_r, prr_z - p_z);
    let (ux, uy) = if rho == 0.0 {
        (0.0, 0.0)
    } else {
        (x / rho, y / rho)
    };
    let lift = |v: f64, dr: f64, dz: f64| D3 {
        v,
        d: [ux * dr, uy * dr, dz],
    };
    let hc3 = CylHessian {
        p: lift(p, p_r, p_z),
        q: lift(q, q_r, q_z),
        z: lift(zz, z_r, z_z),
        prr: lift(hc.prr.v, prr_r, prr_z),
        d: lift(hc.d.v, d_r, d_z),
    };
    assemble(D3::variable(x, 0), D3::variable(y, 1), &hc3)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tensor(r: f64, l: f64, x: f64, y: f64, z: f64) -> ([[f64; 3]; 3], Regime) {
        field_tensor(&KernelGeometry::new(r, l), x, y, z)
    }

    /// On-axis longitudinal field: H_z/M = (1/2)[xi+/sqrt(xi+^2+R^2) - xi-/sqrt(xi-^2+R^2)] - chi.
    #[test]
    fn on_axis_solenoid() {
        let mut worst: f64 = 0.0;
        for &(r, l) in &[(1.0, 1.0), (1.0, 30.0), (0.5, 0.01)] {
            for &z in &[0.0, 0.3, 0.9999, 1.5, 3.0, 7.0, -2.0, 100.0] {
                for &rho in &[0.0, 1e-12, 1e-6] {
                    let (t, _) = tensor(r, l, rho, 0.0, z);
                    let (xp, xm) = (z + l, z - l);
                    let inside = if z.abs() < l { 1.0 } else { 0.0 };
                    let (sp, sm) = (xp.hypot(r), xm.hypot(r));
                    // xp/sp - xm/sm without cancellation when xp, xm have one sign.
                    let diff = if xp * xm > 0.0 {
                        r * r * (xp - xm) * (xp + xm) / (sp * sm * (xp * sm + xm * sp))
                    } else {
                        xp / sp - xm / sm
                    };
                    let want = 0.5 * diff - inside;
                    let err = (t[2][2] - want).abs() / want.abs().max(1e-300);
                    worst = worst.max(err);
                    assert!(
                        err < 1e-10,
                        "r={r} l={l} z={z} rho={rho}: got {} want {want}",
                        t[2][2]
                    );
                }
            }
        }
        eprintln!("on-axis worst {worst:e}");
    }

    /// Infinite-cylinder limit (thesis eq. 5.24): transverse T_xx = -1/2 inside,
    /// T_xx = R^2 cos(2 phi)/(2 rho^2) style outside.
    #[test]
    fn long_cylinder_midplane() {
        let (r, l) = (1.0, 1e6);
        let (t, _) = tensor(r, l, 0.3, 0.2, 0.1);
        assert!((t[0][0] + 0.5).abs() < 1e-10, "{:?}", t);
        assert!((t[1][1] + 0.5).abs() < 1e-10, "{:?}", t);
        let (x, y) = (1.7, 0.9);
        let (t, _) = tensor(r, l, x, y, 0.0);
        let rho2: f64 = x * x + y * y;
        // potential of a 2D dipole: H = (R^2/(2 rho^2)) (2 (M.e) e - M)
        let want_xx = r * r / (2.0 * rho2) * (2.0 * x * x / rho2 - 1.0);
        let want_xy = r * r / (2.0 * rho2) * (2.0 * x * y / rho2);
        assert!((t[0][0] - want_xx).abs() < 1e-10, "{} {}", t[0][0], want_xx);
        assert!((t[0][1] - want_xy).abs() < 1e-10, "{} {}", t[0][1], want_xy);
    }

    /// Trace of Hess psi: -1 inside, 0 outside, in every regime.
    #[test]
    fn trace_is_minus_chi() {
        for &(r, l) in &[(1.0, 1.0), (1.0, 1e-4), (1.0, 1e4)] {
            for &(x, y, z) in &[
                (0.2, 0.1, 0.0),
                (3.0, 1.0, 0.5),
                (0.5, 0.0, 2.0),
                (1e3, 2e3, 5e3),
                (0.9, 0.0, 0.0),
            ] {
                let (t, reg) = tensor(r, l, x, y, z);
                let inside = x.hypot(y) < r && z.abs() < l;
                let tr = t[0][0] + t[1][1] + t[2][2];
                let want = if inside { -1.0 } else { 0.0 };
                let scale = t.iter().flatten().map(|v| v.abs()).fold(0.0, f64::max);
                assert!(
                    (tr - want).abs() <= 1e-13 * scale.max(1.0),
                    "{r} {l} ({x},{y},{z}) {reg:?}: trace {tr}"
                );
            }
        }
    }

    /// The regimes agree where they meet.
    #[test]
    fn regimes_agree() {
        let g = KernelGeometry::new(1.0, 0.7);
        for &(rho, z) in &[(2.0, 1.5), (0.5, 3.0), (3.5, 0.0)] {
            let rho = rho * 1.0;
            let mp = multipole(&g, rho, z);
            let (cf, reg) = cyl_hessian(&g, rho, g.r - rho, z);
            let scale = mp.p.abs().max(mp.z.abs()).max(mp.q.abs() * rho);
            for (a, b) in [(mp.p, cf.p), (mp.q * rho, cf.q * rho), (mp.z, cf.z)] {
                assert!(
                    (a - b).abs() < 1e-14 * scale,
                    "rho={rho} z={z} {reg:?}: {a} vs {b}"
                );
            }
        }
    }
}

/// Taylor coefficients c_0..c_{N-1} of (R^2 + (h0 + t)^2)^(-3/2) in t (J.C.P. Miller's
/// power recurrence: y = w^alpha, k w0 y_k = sum_{j=1}^{k} (alpha j - k + j) w_j y_{k-j}).
fn inv_s3_taylor<const N: usize>(r: f64, h0: f64) -> [f64; N] {
    let w = [r * r + h0 * h0, 2.0 * h0, 1.0];
    let alpha = -1.5;
    let mut y = [0.0; N];
    y[0] = w[0].powf(alpha);
    for k in 1..N {
        let mut acc = 0.0;
        for j in 1..=k.min(2) {
            acc += (alpha * j as f64 - (k - j) as f64) * w[j] * y[k - j];
        }
        y[k] = acc / (k as f64 * w[0]);
    }
    y
}

/// d^k psi(0, z)/dz^k for k = 0..=8 (entries 0 and 1 unused): the on-axis Newtonian potential
/// psi0(z) = (1/2) int_{z-L}^{z+L} g(h) dh with g(h) = sqrt(R^2 + h^2) - |h|, so
/// psi0^(k) = (g^(k-1)(z+L) - g^(k-1)(z-L))/2, g' = -sign(h) R^2/(s (s + |h|)),
/// g^(j) = R^2 (j-2)! [t^(j-2)] (R^2 + (h+t)^2)^(-3/2) for j >= 2.
fn on_axis_derivatives(r: f64, l: f64, z: f64) -> [f64; 9] {
    // sign(h): h = 0 is a point on a cap face, taken from outside (see `side_sign`).
    let g = |h: f64, sign_at_zero: f64| -> [f64; 8] {
        let s = r.hypot(h);
        let mut out = [0.0; 8];
        let sg = side_sign(h, sign_at_zero);
        out[1] = -sg * r * r / (s * (s + h.abs()));
        let c = inv_s3_taylor::<6>(r, h);
        let mut fact = 1.0;
        for j in 2..8 {
            if j > 2 {
                fact *= (j - 2) as f64;
            }
            out[j] = r * r * fact * c[j - 2];
        }
        out
    };
    let (gp, gm) = (g(z + l, -1.0), g(z - l, 1.0));
    let mut d = [0.0; 9];
    for k in 2..9 {
        d[k] = 0.5 * (gp[k - 1] - gm[k - 1]);
    }
    d
}

/// Near-axis form of the tensor and its exact gradient, from the off-axis expansion of the
/// harmonic u = psi + chi rho^2/4: u = sum_k (-1)^k (rho^2/4)^k/(k!)^2 u0^(2k)(z), kept to
/// rho^4 (valid for rho < 1e-3 R, see [`near_axis`]; the next term is below 1e-18 relatively). Entries are (value, d/dx, d/dy, d/dz).
pub fn near_axis_tensor(g: &KernelGeometry, x: f64, y: f64, z: f64) -> [[Dual<f64, 3>; 3]; 3] {
    type D3 = Dual<f64, 3>;
    let (r, l) = (g.r, g.l);
    let chi = if z.abs() < l { 1.0 } else { 0.0 };
    let u = on_axis_derivatives(r, l, z);
    // u0^(k) as a dual: value u[k], d/dz = u[k+1].
    let uk = |k: usize| D3 {
        v: u[k],
        d: [0.0, 0.0, u[k + 1]],
    };
    let xd = D3::variable(x, 0);
    let yd = D3::variable(y, 1);
    let rho2 = xd * xd + yd * yd;
    let rho4 = rho2 * rho2;
    let (a1, a2, a3) = (-0.25, 1.0 / 64.0, -1.0 / 2304.0);
    let p = uk(2).scale(2.0 * a1) + (rho2 * uk(4)).scale(4.0 * a2) + (rho4 * uk(6)).scale(6.0 * a3)
        - D3::cst(0.5 * chi);
    let dd = uk(4).scale(8.0 * a2) + (rho2 * uk(6)).scale(24.0 * a3);
    let q = uk(3).scale(2.0 * a1) + (rho2 * uk(5)).scale(4.0 * a2) + (rho4 * uk(7)).scale(6.0 * a3);
    let zz = uk(2) + (rho2 * uk(4)).scale(a1) + (rho4 * uk(6)).scale(a2);
    let txx = p + xd * xd * dd;
    let tyy = p + yd * yd * dd;
    let txy = xd * yd * dd;
    let txz = xd * q;
    let tyz = yd * q;
    [[txx, txy, txz], [txy, tyy, tyz], [txz, tyz, zz]]
}

/// True where [`near_axis_tensor`] applies.
/// The expansion's radius of convergence is the distance to the rim circles (the on-axis
/// function, continued analytically from either side of a cap, is singular only at
/// z = +-L +- iR), so it holds within 1e-3 R of the axis everywhere but on the caps themselves.
pub fn near_axis(g: &KernelGeometry, rho: f64, z: f64) -> bool {
    rho < 1e-3 * g.r && rho * rho + z * z <= 16.0 * g.a * g.a
}

#[cfg(test)]
mod near_axis_tests {
    use super::*;
    #[test]
    fn near_axis_form_matches_the_closed_forms() {
        // At rho = 1e-4 R both forms are accurate for the value.
        for &(r, l, z) in &[(1.0, 1.0, 0.3), (1.0, 2.0, 2.6), (0.5, 3.0, -1.0)] {
            let g = KernelGeometry::new(r, l);
            let (x, y) = (6e-5 * r, -8e-5 * r);
            let near = near_axis_tensor(&g, x, y, z);
            let (cf, _) = field_tensor(&g, x, y, z);
            for i in 0..3 {
                for j in 0..3 {
                    assert!(
                        (near[i][j].v - cf[i][j]).abs() < 1e-14,
                        "{r} {l} {z} [{i}{j}] {} {}",
                        near[i][j].v,
                        cf[i][j]
                    );
                }
            }
        }
    }
}
