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

/// The loop behind every variant: L independent complementary moduli (L AGM chains run
/// interleaved, which hides the latency of their square roots and divisions), each with the same
/// two characteristics p1, p2 and the same (a, b) pairs (N for p1, M for p2). Iterates until all
/// chains converge (an extra step on an already converged chain leaves it converged).
/// Requires kc != 0 and p1, p2 > 0 (by value).
#[inline]
pub fn cel_lanes<T: Real, const L: usize, const N: usize, const M: usize>(
    kc: [T; L],
    p1: T,
    ab1: [(T, T); N],
    p2: T,
    ab2: [(T, T); M],
) -> [([T; N], [T; M]); L] {
    let zero = T::cst(0.0);
    let sp1 = p1.sqrt();
    let sp2 = p2.sqrt();
    let mut kcs = [zero; L];
    let mut e = [zero; L];
    let mut m = [T::cst(1.0); L];
    let mut pp1 = [sp1; L];
    let mut pp2 = [sp2; L];
    let mut a1 = [[zero; N]; L];
    let mut b1 = [[zero; N]; L];
    let mut a2 = [[zero; M]; L];
    let mut b2 = [[zero; M]; L];
    for k in 0..L {
        debug_assert!(kc[k].val() != 0.0 && p1.val() > 0.0 && p2.val() > 0.0);
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
        for k in 0..L {
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
    let mut out = [([zero; N], [zero; M]); L];
    for k in 0..L {
        let inv_den1 = T::cst(std::f64::consts::FRAC_PI_2) / (m[k] * (m[k] + pp1[k]));
        let inv_den2 = T::cst(std::f64::consts::FRAC_PI_2) / (m[k] * (m[k] + pp2[k]));
        for i in 0..N {
            out[k].0[i] = (a1[k][i] * m[k] + b1[k][i]) * inv_den1;
        }
        for i in 0..M {
            out[k].1[i] = (a2[k][i] * m[k] + b2[k][i]) * inv_den2;
        }
    }
    out
}

/// cel(kc, p1, a_i, b_i) and cel(kc, p2, c_j, d_j) with one shared AGM chain.
#[inline]
pub fn cel_multi2<T: Real, const N: usize, const M: usize>(
    kc: T,
    p1: T,
    ab1: [(T, T); N],
    p2: T,
    ab2: [(T, T); M],
) -> ([T; N], [T; M]) {
    let [out] = cel_lanes([kc], p1, ab1, p2, ab2);
    out
}

/// [`cel_multi2`] for the two ends of a cylinder (two moduli, shared p and pairs).
#[inline]
pub fn cel_multi2_x2<T: Real, const N: usize, const M: usize>(
    kc: [T; 2],
    p1: T,
    ab1: [(T, T); N],
    p2: T,
    ab2: [(T, T); M],
) -> [([T; N], [T; M]); 2] {
    cel_lanes(kc, p1, ab1, p2, ab2)
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
                    let got = cel_multi2(kc, p, [(a, b)], 1.0, [(1.0, 1.0)]).0[0];
                    let want = ellip::cel(kc, p, a, b).unwrap();
                    worst = worst.max((got - want).abs() / want.abs().max(1e-300));
                }
            }
        }
        assert!(worst < 1e-13, "worst relative difference {worst}");
    }
}
