//! Bulirsch's general complete elliptic integral, generic over [`Real`] (for automatic
//! differentiation) and fused: several (a, b) pairs share one Landen/AGM loop, because the
//! recurrence is linear in (a, b) for fixed (kc, p).
//!
//! cel(kc, p, a, b) = int_0^{pi/2} (a cos^2 t + b sin^2 t) /
//!                    ((cos^2 t + p sin^2 t) sqrt(cos^2 t + kc^2 sin^2 t)) dt   (thesis eq. 5.36)
//!
//! Algorithm: R. Bulirsch, Numer. Math. 13 (1969) 305-315, "cel", for p > 0. The loop stops when
//! successive arithmetic means agree to `Real::AGM_TOLERANCE` (1e-9 for values: the convergence
//! is quadratic, so the result is then good to rounding; 1e-15 for derivatives). The `ellip` crate's `cel` (f64 only, one pair) is the
//! reference it is tested against.

use super::autodiff::Real;

/// cel(kc, p, a_i, b_i) for every pair; requires kc != 0 and p > 0 (by value).
#[inline]
pub fn cel_multi<T: Real, const N: usize>(kc: T, p: T, ab: [(T, T); N]) -> [T; N] {
    debug_assert!(kc.val() != 0.0 && p.val() > 0.0);
    let mut kc = if kc.val() < 0.0 { -kc } else { kc };
    let mut e = kc;
    let mut m = T::cst(1.0);
    let mut pp = p.sqrt();
    let mut a: [T; N] = [T::cst(0.0); N];
    let mut b: [T; N] = [T::cst(0.0); N];
    for i in 0..N {
        a[i] = ab[i].0;
        b[i] = ab[i].1 / pp;
    }
    for _ in 0..40 {
        let inv_pp = T::cst(1.0) / pp;
        let g = e * inv_pp;
        for i in 0..N {
            let f = a[i];
            a[i] = a[i] + b[i] * inv_pp;
            b[i] = (b[i] + f * g).scale(2.0);
        }
        pp = g + pp;
        let g_old = m;
        m = kc + m;
        if (g_old.val() - kc.val()).abs() <= g_old.val() * T::AGM_TOLERANCE {
            break;
        }
        kc = e.sqrt().scale(2.0);
        e = kc * m;
    }
    let den = m * (m + pp);
    let mut out = [T::cst(0.0); N];
    for i in 0..N {
        out[i] = (a[i] * m + b[i]).scale(std::f64::consts::FRAC_PI_2) / den;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn agrees_with_the_ellip_crate() {
        let mut worst = 0.0f64;
        for &kc in &[1e-9, 1e-4, 0.1, 0.5, 0.9, 1.0] {
            for &p in &[1e-12, 1e-3, 0.3, 1.0, 5.0] {
                for &(a, b) in &[(1.0, 1.0), (1.0, -1.0), (0.0, 1.0), (1.0, 0.3)] {
                    let got = cel_multi(kc, p, [(a, b)])[0];
                    let want = ellip::cel(kc, p, a, b).unwrap();
                    worst = worst.max((got - want).abs() / want.abs().max(1e-300));
                }
            }
        }
        assert!(worst < 1e-13, "worst relative difference {worst}");
    }
}

/// Two [`cel_multi`] calls with the same kc and different p, sharing the kc/AGM recursion
/// (one square root per iteration instead of two).
#[inline]
pub fn cel_multi2<T: Real, const N: usize, const M: usize>(
    kc: T,
    p1: T,
    ab1: [(T, T); N],
    p2: T,
    ab2: [(T, T); M],
) -> ([T; N], [T; M]) {
    debug_assert!(kc.val() != 0.0 && p1.val() > 0.0 && p2.val() > 0.0);
    let mut kc = if kc.val() < 0.0 { -kc } else { kc };
    let mut e = kc;
    let mut m = T::cst(1.0);
    let (mut pp1, mut pp2) = (p1.sqrt(), p2.sqrt());
    let mut a1: [T; N] = [T::cst(0.0); N];
    let mut b1: [T; N] = [T::cst(0.0); N];
    let mut a2: [T; M] = [T::cst(0.0); M];
    let mut b2: [T; M] = [T::cst(0.0); M];
    for i in 0..N {
        a1[i] = ab1[i].0;
        b1[i] = ab1[i].1 / pp1;
    }
    for i in 0..M {
        a2[i] = ab2[i].0;
        b2[i] = ab2[i].1 / pp2;
    }
    for _ in 0..40 {
        let (inv1, inv2) = (T::cst(1.0) / pp1, T::cst(1.0) / pp2);
        let (g1, g2) = (e * inv1, e * inv2);
        for i in 0..N {
            let f = a1[i];
            a1[i] = a1[i] + b1[i] * inv1;
            b1[i] = (b1[i] + f * g1).scale(2.0);
        }
        for i in 0..M {
            let f = a2[i];
            a2[i] = a2[i] + b2[i] * inv2;
            b2[i] = (b2[i] + f * g2).scale(2.0);
        }
        pp1 = g1 + pp1;
        pp2 = g2 + pp2;
        let g_old = m;
        m = kc + m;
        if (g_old.val() - kc.val()).abs() <= g_old.val() * T::AGM_TOLERANCE {
            break;
        }
        kc = e.sqrt().scale(2.0);
        e = kc * m;
    }
    let (den1, den2) = (m * (m + pp1), m * (m + pp2));
    let mut out1 = [T::cst(0.0); N];
    let mut out2 = [T::cst(0.0); M];
    for i in 0..N {
        out1[i] = (a1[i] * m + b1[i]).scale(std::f64::consts::FRAC_PI_2) / den1;
    }
    for i in 0..M {
        out2[i] = (a2[i] * m + b2[i]).scale(std::f64::consts::FRAC_PI_2) / den2;
    }
    (out1, out2)
}

/// [`cel_multi2`] for two complementary moduli at once (the two ends of a cylinder share p and
/// the (a, b) pairs): the two independent AGM chains run interleaved, which roughly halves the
/// latency-bound time of evaluating them one after the other. Iterates until both converge
/// (extra steps on an already converged chain leave it converged).
#[inline]
pub fn cel_multi2_x2<T: Real, const N: usize, const M: usize>(
    kc: [T; 2],
    p1: T,
    ab1: [(T, T); N],
    p2: T,
    ab2: [(T, T); M],
) -> [([T; N], [T; M]); 2] {
    let zero = T::cst(0.0);
    let sp1 = p1.sqrt();
    let sp2 = p2.sqrt();
    let mut kcs = [zero; 2];
    let mut e = [zero; 2];
    let mut m = [T::cst(1.0); 2];
    let mut pp1 = [sp1; 2];
    let mut pp2 = [sp2; 2];
    let mut a1 = [[zero; N]; 2];
    let mut b1 = [[zero; N]; 2];
    let mut a2 = [[zero; M]; 2];
    let mut b2 = [[zero; M]; 2];
    for k in 0..2 {
        kcs[k] = if kc[k].val() < 0.0 { -kc[k] } else { kc[k] };
        e[k] = kcs[k];
        for i in 0..N {
            a1[k][i] = ab1[i].0;
            b1[k][i] = ab1[i].1 / sp1;
        }
        for i in 0..M {
            a2[k][i] = ab2[i].0;
            b2[k][i] = ab2[i].1 / sp2;
        }
    }
    for _ in 0..40 {
        let mut done = true;
        for k in 0..2 {
            let (inv1, inv2) = (T::cst(1.0) / pp1[k], T::cst(1.0) / pp2[k]);
            let (g1, g2) = (e[k] * inv1, e[k] * inv2);
            for i in 0..N {
                let f = a1[k][i];
                a1[k][i] = a1[k][i] + b1[k][i] * inv1;
                b1[k][i] = (b1[k][i] + f * g1).scale(2.0);
            }
            for i in 0..M {
                let f = a2[k][i];
                a2[k][i] = a2[k][i] + b2[k][i] * inv2;
                b2[k][i] = (b2[k][i] + f * g2).scale(2.0);
            }
            pp1[k] = g1 + pp1[k];
            pp2[k] = g2 + pp2[k];
            let g_old = m[k];
            m[k] = kcs[k] + m[k];
            if (g_old.val() - kcs[k].val()).abs() > g_old.val() * T::AGM_TOLERANCE {
                done = false;
            }
            kcs[k] = e[k].sqrt().scale(2.0);
            e[k] = kcs[k] * m[k];
        }
        if done {
            break;
        }
    }
    let mut out = [([zero; N], [zero; M]); 2];
    for k in 0..2 {
        let (den1, den2) = (m[k] * (m[k] + pp1[k]), m[k] * (m[k] + pp2[k]));
        for i in 0..N {
            out[k].0[i] = (a1[k][i] * m[k] + b1[k][i]).scale(std::f64::consts::FRAC_PI_2) / den1;
        }
        for i in 0..M {
            out[k].1[i] = (a2[k][i] * m[k] + b2[k][i]).scale(std::f64::consts::FRAC_PI_2) / den2;
        }
    }
    out
}
