//! Collisions: BGK (seed 002 eq. 3, 5, 8) and two-relaxation-time (TRT; Ginzburg, Verhaeghe &
//! d'Humieres, Commun. Comput. Phys. 3, 427, 2008), both written on the pairs (q, opp q).
//!
//! For a pair with c = c_q the equilibrium (seed 002 eq. 5, with the porosity of Guo & Zhao
//! eq. 13) splits into the even part e+ = w rho (1 + 9/2 (c.u)^2/eps - 3/2 u.u/eps) and the odd
//! part e- = 3 w rho c.u; the source term (Guo & Zhao eq. 14) into
//! S+ = w rho (9 (c.u)(c.a)/eps - 3 u.a/eps) and S- = 3 w rho c.a. The even part relaxes at rate
//! omega+ = 1/tau (the viscosity, eq. 8: nu = (tau - 1/2)/3), the odd part at omega-; each
//! source part carries its factor (1 - omega/2). BGK is omega- = omega+.

use super::forcing::{CellState, Forcing};
use super::lattice::{each_pair, each_q, Lattice, QMAX};
use super::simd::{v3, Real};

/// A collision operator: its two rates (even, odd).
pub trait Collision: Copy + Send + Sync {
    const NAME: &'static str;
    fn omega_plus(&self) -> f64;
    fn omega_minus(&self) -> f64;
}

/// Single relaxation time: omega = 1 / tau.
#[derive(Debug, Clone, Copy)]
pub struct Bgk {
    pub omega: f64,
}

impl Bgk {
    pub fn from_tau(tau: f64) -> Bgk {
        Bgk { omega: 1.0 / tau }
    }
}

impl Collision for Bgk {
    const NAME: &'static str = "BGK";
    #[inline(always)]
    fn omega_plus(&self) -> f64 {
        self.omega
    }
    #[inline(always)]
    fn omega_minus(&self) -> f64 {
        self.omega
    }
}

/// Two relaxation times with the "magic" parameter Lambda = (tau+ - 1/2)(tau- - 1/2).
/// Lambda = 3/16 puts a halfway bounce-back wall exactly midway in plane Poiseuille flow,
/// and makes steady solutions (so permeabilities) independent of the viscosity.
#[derive(Debug, Clone, Copy)]
pub struct Trt {
    pub omega_plus: f64,
    pub omega_minus: f64,
}

/// The magic parameter of [`Trt::magic`].
pub const MAGIC_LAMBDA: f64 = 3.0 / 16.0;

impl Trt {
    /// TRT with even relaxation time `tau` and Lambda = 3/16.
    pub fn magic(tau: f64) -> Trt {
        Trt::with_lambda(tau, MAGIC_LAMBDA)
    }
    pub fn with_lambda(tau: f64, lambda: f64) -> Trt {
        let tau_minus = 0.5 + lambda / (tau - 0.5);
        Trt {
            omega_plus: 1.0 / tau,
            omega_minus: 1.0 / tau_minus,
        }
    }
}

impl Collision for Trt {
    const NAME: &'static str = "TRT";
    #[inline(always)]
    fn omega_plus(&self) -> f64 {
        self.omega_plus
    }
    #[inline(always)]
    fn omega_minus(&self) -> f64 {
        self.omega_minus
    }
}

/// Populations of a block of `N` cells, population-major: row q holds f_q of every cell (a
/// lattice uses its first Q rows).
pub type Block<const N: usize> = [[f64; N]; QMAX];

/// Pairs (q, opp q) of the velocity sets here: (QMAX - 1) / 2.
pub const PMAX: usize = (QMAX - 1) / 2;

/// The pulled populations of a block (or of one cell), as the collision and the moments use
/// them: the rest population and, for each pair p (q = 2p + 1 and its opposite q + 1), the sum
/// s = f_q + f_opp and the difference d = f_q - f_opp.
#[derive(Clone, Copy)]
pub struct Pairs<R> {
    pub f0: R,
    pub s: [R; PMAX],
    pub d: [R; PMAX],
}

impl<R: Real> Pairs<R> {
    /// The pair sums and differences of the populations `f` (Q of them).
    #[inline(always)]
    pub fn of<L: Lattice>(f: &[R; QMAX]) -> Pairs<R> {
        let zero = R::splat(0.0);
        let mut p = Pairs {
            f0: f[0],
            s: [zero; PMAX],
            d: [zero; PMAX],
        };
        each_pair!(L, q, {
            p.s[q / 2] = f[q] + f[q + 1];
            p.d[q / 2] = f[q] - f[q + 1];
        });
        p
    }

    /// Density and momentum (seed 002 eq. 6-7): rho = f_0 + sum over pairs of s, and
    /// j = sum f c = sum over pairs of c_q d (c_opp = -c_q), pairs in order, zero terms skipped.
    #[inline(always)]
    pub fn moments<L: Lattice>(&self) -> (R, [R; 3]) {
        let mut rho = self.f0;
        each_pair!(L, q, {
            rho = rho + self.s[q / 2];
        });
        let j = v3!(k => {
            let mut jk: Option<R> = None;
            each_pair!(L, q, {
                jk = add_signed(jk, L::C[q][k], self.d[q / 2]);
            });
            jk.unwrap_or(R::splat(0.0))
        });
        (rho, j)
    }
}

/// The sign that makes the first nonzero component of `c` positive: +-1.
#[inline(always)]
pub const fn leading_sign(c: [i32; 3]) -> i32 {
    if c[0] != 0 {
        c[0]
    } else if c[1] != 0 {
        c[1]
    } else {
        c[2]
    }
}

/// c . v with the lattice's integer c (components 0, +-1), taken with the sign that makes its
/// first nonzero component positive ([`leading_sign`]; the caller puts that sign back into a
/// constant): only the nonzero terms, in the order x, y, z. So (1, 1, 1) and (1, 1, -1) share
/// vx + vy, and D3Q15's four diagonal pairs cost six operations, not eight. With c a constant
/// of the unrolled kernel every test on it folds away.
#[inline(always)]
pub fn dot_c<R: Real>(c: [i32; 3], v: &[R; 3]) -> R {
    let sign = leading_sign(c);
    let mut s: Option<R> = None;
    for k in 0..3 {
        s = add_signed(s, c[k] * sign, v[k]);
    }
    s.unwrap_or(R::splat(0.0))
}

/// acc + c v for c in {0, 1, -1}: c v alone for the first nonzero term (None so far), no
/// operation for c = 0; the sign flip is exact.
#[inline(always)]
fn add_signed<R: Real>(acc: Option<R>, c: i32, v: R) -> Option<R> {
    match (c, acc) {
        (0, _) => acc,
        (1, None) => Some(v),
        (_, None) => Some(-v),
        (1, Some(t)) => Some(t + v),
        (_, Some(t)) => Some(t - v),
    }
}

/// Relaxes a block of cells (or one cell: `R = f64`) of density `rho` and forcing state `s`,
/// pulled populations `p`, into the post-collision populations `out`, with the source term
/// when `FORCED`.
///
/// With e+ and e- of the module doc, f+ = s/2 and f- = d/2 of a pair, the post-collision
/// populations are f_q = P + M and f_opp = P - M, where
/// P = f+ + omega+ (e+ - f+) + (1 - omega+/2) S+ = (1 - omega+) s/2 + w (E0 + (c.u)(c.n)),
/// M = f- + omega- (e- - f-) + (1 - omega-/2) S- = (1 - omega-) d/2 + w c.m,
/// with the per-cell E0 = rho (omega+ (1 - 3/2 u.u/eps) - 3 (1 - omega+/2) u.a/eps) and vectors
/// n = (rho/eps) (9/2 omega+ u + 9 (1 - omega+/2) a), m = rho (3 omega- u + 3 (1 - omega-/2) a);
/// the rest population becomes (1 - omega+) f_0 + w_0 E0. P is even in c and M odd, so each
/// pair takes its three dot products with the sign of [`dot_c`] and puts it back into w of M.
#[inline(always)]
pub fn relax<L: Lattice, C: Collision, R: Real, const FORCED: bool>(
    coll: &C,
    rho: R,
    s: &CellState<R>,
    p: &Pairs<R>,
    out: &mut [R; QMAX],
) {
    let wp = coll.omega_plus();
    let wm = coll.omega_minus();
    let sp = 1.0 - 0.5 * wp;
    let sm = 1.0 - 0.5 * wm;
    let u = &s.u;
    let uu = u[2].mul_add(u[2], u[1].mul_add(u[1], u[0] * u[0])) * s.inv_eps;
    let mut e0 = uu.mul_add(R::splat(-1.5 * wp), R::splat(wp));
    if FORCED {
        let a = &s.a;
        let ua = u[2].mul_add(a[2], u[1].mul_add(a[1], u[0] * a[0])) * s.inv_eps;
        e0 = ua.mul_add(R::splat(-3.0 * sp), e0);
    }
    let e0 = rho * e0;
    let rie = rho * s.inv_eps;
    let (x, y) = (rie * R::splat(4.5 * wp), rie * R::splat(9.0 * sp));
    let (r, sa) = (rho * R::splat(3.0 * wm), rho * R::splat(3.0 * sm));
    let n = v3!(k => if FORCED { s.a[k].mul_add(y, u[k] * x) } else { u[k] * x });
    let m = v3!(k => if FORCED { s.a[k].mul_add(sa, u[k] * r) } else { u[k] * r });
    let (hp, hm) = (R::splat(0.5 * (1.0 - wp)), R::splat(0.5 * (1.0 - wm)));
    out[0] = p.f0.mul_add(R::splat(1.0 - wp), e0 * R::splat(L::W[0]));
    each_pair!(L, q, {
        let c = L::C[q];
        let w = L::W[q];
        let (cu, cn, cm) = (dot_c(c, u), dot_c(c, &n), dot_c(c, &m));
        let even = cu.mul_add(cn, e0).mul_add(R::splat(w), p.s[q / 2] * hp);
        let odd = cm.mul_add(R::splat(w * leading_sign(c) as f64), p.d[q / 2] * hm);
        out[q] = even + odd;
        out[q + 1] = even - odd;
    });
}

/// Relaxes one cell of density `rho` and forcing state `s`: pulled populations `pre` (Q of
/// them) into `out` (a boundary node's update, and the kernel's reference).
pub fn relax_cell<L: Lattice, C: Collision, F: Forcing>(
    coll: &C,
    rho: f64,
    s: &CellState,
    pre: &[f64],
    out: &mut [f64],
) {
    let mut f = [0.0; QMAX];
    f[..L::Q].copy_from_slice(&pre[..L::Q]);
    let p = Pairs::of::<L>(&f);
    let mut post = [0.0; QMAX];
    if F::ACTIVE {
        relax::<L, C, f64, true>(coll, rho, s, &p, &mut post);
    } else {
        relax::<L, C, f64, false>(coll, rho, s, &p, &mut post);
    }
    out[..L::Q].copy_from_slice(&post[..L::Q]);
}

/// The equilibrium populations of (rho, u) in a fluid of porosity 1 / inv_eps.
pub fn equilibrium<L: Lattice>(rho: f64, u: [f64; 3], inv_eps: f64) -> L::Pop {
    let mut f = L::Pop::default();
    let uu = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * inv_eps;
    for (q, fq) in f.as_mut().iter_mut().enumerate() {
        let c = L::C[q];
        let cu = c[0] as f64 * u[0] + c[1] as f64 * u[1] + c[2] as f64 * u[2];
        *fq = L::W[q] * rho * (1.0 + 3.0 * cu + 4.5 * cu * cu * inv_eps - 1.5 * uu);
    }
    f
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lbm::forcing::Porous;
    use crate::lbm::lattice::{opposite, D3Q15, D3Q19};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The textbook collision, direction by direction: the equilibrium of Guo & Zhao eq. 13
    /// and their source term (eq. 14), F_q = w rho (3 c.a + 9 (c.u)(c.a)/eps - 3 u.a/eps),
    /// each split into its even and odd parts over (q, opp q), the even part relaxed at
    /// omega+ and the odd part at omega- (BGK: omega+ = omega-).
    fn textbook<L: Lattice, C: Collision>(coll: &C, pre: &[f64], s: &CellState) -> Vec<f64> {
        let (wp, wm) = (coll.omega_plus(), coll.omega_minus());
        let rho: f64 = pre[..L::Q].iter().sum();
        let feq = equilibrium::<L>(rho, s.u, s.inv_eps);
        let feq = feq.as_ref();
        let (u, a, ie) = (s.u, s.a, s.inv_eps);
        let ua = u[0] * a[0] + u[1] * a[1] + u[2] * a[2];
        let src: Vec<f64> = (0..L::Q)
            .map(|q| {
                let c = L::C[q].map(f64::from);
                let cu = c[0] * u[0] + c[1] * u[1] + c[2] * u[2];
                let ca = c[0] * a[0] + c[1] * a[1] + c[2] * a[2];
                L::W[q] * rho * (3.0 * ca + 9.0 * cu * ca * ie - 3.0 * ua * ie)
            })
            .collect();
        (0..L::Q)
            .map(|q| {
                let o = opposite(q);
                let even = |v: &[f64]| 0.5 * (v[q] + v[o]);
                let odd = |v: &[f64]| 0.5 * (v[q] - v[o]);
                pre[q] - wp * (even(pre) - even(feq)) - wm * (odd(pre) - odd(feq))
                    + (1.0 - 0.5 * wp) * even(&src)
                    + (1.0 - 0.5 * wm) * odd(&src)
            })
            .collect()
    }

    /// The pair form of [`relax`] (coefficients folded, dot products with the leading sign)
    /// against the textbook collision on random populations, velocities, accelerations and
    /// porosities, BGK and TRT, both lattices: equal to rounding (1e-14 of the largest
    /// population).
    fn pair_form_equals_textbook<L: Lattice>(rng: &mut ChaCha8Rng) {
        for _ in 0..500 {
            let tau = rng.gen_range(0.51..2.0);
            let pre: Vec<f64> = (0..L::Q)
                .map(|q| L::W[q] * rng.gen_range(0.8..1.2))
                .collect();
            let s = CellState {
                u: [0; 3].map(|_| rng.gen_range(-0.1..0.1)),
                a: [0; 3].map(|_| rng.gen_range(-1e-2..1e-2)),
                inv_eps: 1.0 / rng.gen_range(0.05..=1.0),
            };
            let rho: f64 = pre.iter().sum();
            let mut post = vec![0.0; L::Q];
            let bgk = Bgk::from_tau(tau);
            let trt = Trt::magic(tau);
            relax_cell::<L, Bgk, Porous>(&bgk, rho, &s, &pre, &mut post);
            let want = textbook::<L, Bgk>(&bgk, &pre, &s);
            for q in 0..L::Q {
                assert!((post[q] - want[q]).abs() < 1e-14, "BGK {} q {q}", L::NAME);
            }
            relax_cell::<L, Trt, Porous>(&trt, rho, &s, &pre, &mut post);
            let want = textbook::<L, Trt>(&trt, &pre, &s);
            for q in 0..L::Q {
                assert!((post[q] - want[q]).abs() < 1e-14, "TRT {} q {q}", L::NAME);
            }
        }
    }

    #[test]
    fn pair_form_equals_textbook_collision() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        pair_form_equals_textbook::<D3Q15>(&mut rng);
        pair_form_equals_textbook::<D3Q19>(&mut rng);
    }
}
