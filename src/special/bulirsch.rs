//! Bulirsch's general complete elliptic integral, generic over [`Real`] (for automatic
//! differentiation) and fused: several (a, b) pairs share one Landen/AGM loop, because the
//! recurrence is linear in (a, b) for fixed (kc, p).
//!
//! cel(kc, p, a, b) = int_0^{pi/2} (a cos^2 t + b sin^2 t) /
//!                    ((cos^2 t + p sin^2 t) sqrt(cos^2 t + kc^2 sin^2 t)) dt   (thesis eq. 5.36)
//!
//! Algorithm: R. Bulirsch, Numer. Math. 13 (1969) 305-315, "cel", for p > 0. The loop stops when
//! successive arithmetic means agree to `Real::AGM_TOLERANCE` (1e-8 for values: the convergence
//! is quadratic, so the result is then good to rounding; 1e-15 for derivatives). The `ellip`
//! crate's `cel` (f64 only, one pair) is the reference it is tested against.

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

/// The number of passes after which Bulirsch's test |m_n - kc_n| <= AGM_TOLERANCE m_n (for
/// values, 1e-8) first holds for AGM(1, kc): it holds after 3 passes exactly from
/// kc = 0.953543, 4 from 0.536976, 5 from 0.0848356, 6 from 0.00180577 (bisection in 50-digit
/// arithmetic); the bounds here are rounded up. 0 below: left to the test.
fn agm_passes(kc: f64) -> usize {
    if kc >= 0.95355 {
        3
    } else if kc >= 0.53698 {
        4
    } else if kc >= 0.084836 {
        5
    } else if kc >= 0.0018058 {
        6
    } else {
        0
    }
}

/// What [`agm_cel_lanes`] gives for one complementary modulus kc (m = 1 - kc^2).
#[derive(Debug, Clone, Copy)]
pub struct AgmCel<T, const M: usize> {
    /// K = cel(kc, 1, 1, 1) = pi / (2 AGM(1, kc)).
    pub k: T,
    /// S / m^2 with S = sum_{n>=1} 2^n c_n^2 the AGM sum of E = K (1 - (m + S)/2)
    /// (Abramowitz-Stegun 17.6.4, c_0^2 = m): a sum of positive terms, so that
    ///   P1 = cel(kc, 1, 1, -1) = K - 2 (K - E)/m = -K S/m           (thesis eq. 5.39)
    ///   J(kc, kc^2) = -P1/m = K S/m^2,   cel(kc, 1, 0, 1) = (K - E)/m = K (1 + S/m)/2
    /// carry no cancellation even for m -> 0, where eq. 5.39 as written loses everything.
    pub s_over_m2: T,
    /// cel(kc, p, a_j, b_j) for the pairs given.
    pub cel: [T; M],
}

/// The Landen/AGM loop of Bulirsch's cel for one characteristic p (M pairs (a_j, b_j)), run
/// for L complementary moduli kc_k > 0 at once, which also yields the plain AGM
/// quantities of [`AgmCel`]: the p = 1 integrals of eq. 5.39 then need no chain of their own
/// (for p = 1 Bulirsch's p-sequence equals the arithmetic means, so it would only repeat them).
/// `m` is 1 - kc^2 (passed separately, accurate where kc is near 1); `sqrt_p` = sqrt(p) > 0.
/// Requires kc > 0 and m > 0 (by value). With M = 0, p and sqrt_p are not used.
#[inline]
pub fn agm_cel_lanes<T: Real, const L: usize, const M: usize>(
    kc: [T; L],
    m: [T; L],
    sqrt_p: T,
    ab: [(T, T); M],
) -> [AgmCel<T, M>; L] {
    let zero = T::cst(0.0);
    let one = T::cst(1.0);
    let mut kcs = [zero; L];
    // 4 e of Bulirsch's e = kc_n m_n (carried as 4 e, so that kc_(n+1) = 2 sqrt(e) = sqrt(4 e)
    // and 4 e = kc (4 m): one multiplication less on the loop's critical path).
    let mut e4 = [zero; L];
    let mut mm = [one; L];
    let mut pp = [sqrt_p; L];
    let mut a = [[zero; M]; L];
    let mut b = [[zero; M]; L];
    // sum_{n>=2} (m_n - kc_n)^2 / 2^(n+1) in the loop's unnormalized variables
    // (m_n = 2^n a_n, kc_n = 2^n b_n, so 2^(n+1) c_(n+1)^2 = (m_n - kc_n)^2 / 2^(n+1)): the
    // terms of S from c_3 on. (c_1 and c_2 are formed below without cancellation.)
    let mut tail = [zero; L];
    let mut kc0 = [zero; L];
    // sqrt kc, from the first pass (kc_1 = 2 sqrt kc); it only enters the c_2 term, so the
    // placeholder 1 is harmless where the loop stops at once (m < 2e-9 for values).
    let mut rkc = [one; L];
    // Values share reciprocals (each costs a division); derivative parts would cancel in the
    // shared forms where p -> 0 or m -> 0 (see below), so dual numbers divide separately.
    let inv_sp = one / sqrt_p;
    for k in 0..L {
        debug_assert!(kc[k].val() > 0.0 && m[k].val() > 0.0 && sqrt_p.val() > 0.0);
        kc0[k] = kc[k];
        kcs[k] = kc0[k];
        e4[k] = kcs[k].scale(4.0);
        for i in 0..M {
            a[k][i] = ab[i].0;
            // (for duals a quotient: with b = sqrt p -> 0 the derivative of b * (1/sqrt p)
            // is a difference of two terms ~ 1/sqrt p)
            b[k][i] = if T::DERIVATIVES {
                ab[i].1 / sqrt_p
            } else {
                ab[i].1 * inv_sp
            };
        }
    }
    // For values the number of passes follows from the smallest kc in advance (as the test
    // would find it, see `agm_passes`): the loop's exit then no longer waits for the square
    // roots of the pass, so a mispredicted exit costs little. 0: decide by the test.
    let npass = if T::DERIVATIVES {
        0
    } else {
        agm_passes(kc.iter().map(|v| v.val()).fold(f64::INFINITY, f64::min))
    };
    // 2^n and 1/2^(n+1) for the current pass n.
    let mut pow2 = 1.0;
    let mut weight = 0.5;
    for pass in 0..40 {
        let mut done = true;
        for k in 0..L {
            let inv = one / pp[k];
            // (e4/4 first: it comes from the square-root chain, off the 1/p chain)
            let g = e4[k].scale(0.25) * inv;
            for i in 0..M {
                let f = a[k][i];
                a[k][i] = a[k][i] + b[k][i] * inv;
                b[k][i] = (b[k][i] + f * g).scale(2.0);
            }
            pp[k] = g + pp[k];
            let u = mm[k] - kcs[k];
            if pass > 1 {
                tail[k] = tail[k] + (u * u).scale(weight);
            }
            if u.val().abs() > mm[k].val() * T::AGM_TOLERANCE {
                done = false;
            }
            mm[k] = kcs[k] + mm[k];
        }
        if (npass == 0 && done) || pass + 1 == npass {
            break;
        }
        for k in 0..L {
            kcs[k] = e4[k].sqrt();
            e4[k] = kcs[k] * mm[k].scale(4.0);
            if pass == 0 {
                rkc[k] = kcs[k].scale(0.5);
            }
        }
        pow2 *= 2.0;
        weight *= 0.5;
    }
    let mut out = [AgmCel {
        k: zero,
        s_over_m2: zero,
        cel: [zero; M],
    }; L];
    for k in 0..L {
        // Values: one division for 1/(mm (mm + p)) and 1/mm, one for 1/m and
        // y = 1/((1 + kc)(1 + sqrt kc)). Duals divide separately: 1/mm = (mm + p)/(mm (mm + p))
        // cancels in the derivatives when p >> mm (g -> 0), and y = m/(X m) when m -> 0.
        let inv_den = one / (mm[k] * (mm[k] + pp[k]));
        let one_rkc = one + rkc[k];
        let x = (one + kc0[k]) * one_rkc;
        let (inv_mm, y, inv_m) = if T::DERIVATIVES {
            (one / mm[k], one / x, one / m[k])
        } else {
            let inv_xm = one / (x * m[k]);
            ((mm[k] + pp[k]) * inv_den, m[k] * inv_xm, x * inv_xm)
        };
        let inv_one_kc = one_rkc * y;
        out[k].k = inv_mm.scale(std::f64::consts::PI * pow2);
        // 2 c_1^2/m^2 = (1 - kc)^2/(2 m^2) = 1/(2 (1 + kc)^2) and, with
        // 1 - sqrt kc = m y, 4 c_2^2/m^2 = (1 - sqrt kc)^4/(4 m^2) = (m y^2)^2/4. The later
        // terms are O(m^2) smaller still; below m = 1e-3 (where they are < 1e-25 of the sum)
        // they are dropped, since the rounding of m_n - kc_n (absolute, ~eps) would enter the
        // derivatives as eps^2/m^3.
        let my2 = m[k] * y * y;
        let mut s = (inv_one_kc * inv_one_kc).scale(0.5) + (my2 * my2).scale(0.25);
        if m[k].val() > 1e-3 {
            s = s + tail[k] * inv_m * inv_m;
        }
        out[k].s_over_m2 = s;
        for i in 0..M {
            out[k].cel[i] =
                ((a[k][i] * mm[k] + b[k][i]) * inv_den).scale(std::f64::consts::FRAC_PI_2);
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

    /// K, cel(kc, 1, 0, 1), cel(kc, 1, 1, -1) (eq. 5.39) and cel(kc, p, a, b) from
    /// [`agm_cel_lanes`], for values and through the dual-number path.
    #[test]
    fn agm_lanes_agree_with_the_ellip_crate() {
        use crate::special::autodiff::Dual;
        let mut worst = 0.0f64;
        for &m in &[1e-9, 1e-4, 0.03, 0.3, 0.7, 0.99, 1.0 - 1e-8] {
            for &p in &[1e-12, 1e-3, 0.3, 1.0, 5.0] {
                let kc = (1.0f64 - m).sqrt();
                let sp = p.sqrt();
                let pairs = [(1.0, sp), (0.0, 1.0)];
                let [o] = agm_cel_lanes::<f64, 1, 2>([kc], [m], sp, pairs);
                let [od] = agm_cel_lanes::<Dual<f64, 1>, 1, 2>(
                    [Dual::cst(kc)],
                    [Dual::cst(m)],
                    Dual::cst(sp),
                    pairs.map(|(a, b)| (Dual::cst(a), Dual::cst(b))),
                );
                let j = o.k * o.s_over_m2;
                let got = [o.k, 0.5 * (o.k + j * m), -j * m, o.cel[0], o.cel[1]];
                let want = [
                    ellip::cel(kc, 1.0, 1.0, 1.0).unwrap(),
                    ellip::cel(kc, 1.0, 0.0, 1.0).unwrap(),
                    ellip::cel(kc, 1.0, 1.0, -1.0).unwrap(),
                    ellip::cel(kc, p, 1.0, sp).unwrap(),
                    ellip::cel(kc, p, 0.0, 1.0).unwrap(),
                ];
                // P1 = -m J is small for small m: the reference's absolute rounding ~ eps K.
                let scale = [want[0], want[1], want[0], want[3], want[4]];
                for i in 0..5 {
                    worst = worst.max((got[i] - want[i]).abs() / scale[i].abs());
                }
                let dual = [od.k.v, od.s_over_m2.v, od.cel[0].v, od.cel[1].v];
                for (a, b) in dual.iter().zip([o.k, o.s_over_m2, o.cel[0], o.cel[1]]) {
                    worst = worst.max((a - b).abs() / b.abs());
                }
            }
        }
        assert!(worst < 1e-13, "worst relative difference {worst}");
    }
}
