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

/// Lanes of the kernel's blocks: one AVX-512 register of f64 (two AVX2 ones).
pub const LANES: usize = 8;

/// Populations of a block of `N` cells, population-major: row q holds f_q of every cell (a
/// lattice uses its first Q rows).
pub type Block<const N: usize> = [[f64; N]; QMAX];

/// The macroscopic state of a block of `N` cells that the collision needs (one entry per cell).
#[derive(Debug, Clone, Copy)]
pub struct BlockState<const N: usize> {
    pub rho: [f64; N],
    pub u: [[f64; N]; 3],
    pub a: [[f64; N]; 3],
    pub inv_eps: [f64; N],
    /// u.u / eps and u.a / eps, shared by every direction.
    pub uu: [f64; N],
    pub ua: [f64; N],
}

impl<const N: usize> Default for BlockState<N> {
    fn default() -> Self {
        BlockState {
            rho: [0.0; N],
            u: [[0.0; N]; 3],
            a: [[0.0; N]; 3],
            inv_eps: [0.0; N],
            uu: [0.0; N],
            ua: [0.0; N],
        }
    }
}

impl<const N: usize> BlockState<N> {
    /// Entry `l`: density `rho` and the forcing's state `s` (velocity, acceleration, 1/eps),
    /// with the shared products u.u / eps and u.a / eps (the latter makes the source term of
    /// Guo & Zhao eq. 14 massless).
    #[inline(always)]
    pub fn set(&mut self, l: usize, rho: f64, s: &CellState) {
        self.rho[l] = rho;
        for k in 0..3 {
            self.u[k][l] = s.u[k];
            self.a[k][l] = s.a[k];
        }
        self.inv_eps[l] = s.inv_eps;
        self.uu[l] = (s.u[0] * s.u[0] + s.u[1] * s.u[1] + s.u[2] * s.u[2]) * s.inv_eps;
        self.ua[l] = (s.u[0] * s.a[0] + s.u[1] * s.a[1] + s.u[2] * s.a[2]) * s.inv_eps;
    }
}

/// c . v for every cell of a block, with the lattice's integer c (components 0, +-1): only the
/// nonzero terms are added, in the order x, y, z, so the sum is the one of the full dot
/// product to the last bit (up to the sign of a zero) at a third of the operations. Written
/// without a loop over the components so that, with c a constant of the unrolled kernel,
/// every test on it folds away.
#[inline(always)]
pub fn dot_c<const N: usize>(c: [i32; 3], v: &[[f64; N]; 3]) -> [f64; N] {
    let mut s = [0.0; N];
    let mut first = true;
    add_c_term(&mut s, &mut first, c[0], &v[0]);
    add_c_term(&mut s, &mut first, c[1], &v[1]);
    add_c_term(&mut s, &mut first, c[2], &v[2]);
    s
}

/// s += c v for c in {0, 1, -1} (s = c v for the first nonzero term): the sign flip is exact.
#[inline(always)]
fn add_c_term<const N: usize>(s: &mut [f64; N], first: &mut bool, c: i32, v: &[f64; N]) {
    debug_assert!((-1..=1).contains(&c));
    match (c, *first) {
        (0, _) => return,
        (1, true) => *s = *v,
        (_, true) => {
            for l in 0..N {
                s[l] = -v[l];
            }
        }
        (1, false) => {
            for l in 0..N {
                s[l] += v[l];
            }
        }
        (_, false) => {
            for l in 0..N {
                s[l] -= v[l];
            }
        }
    }
    *first = false;
}

/// Relaxes a block of `N` cells in place: pulled populations `f` become post-collision ones,
/// state `s`, with the source term when `FORCED`. Every loop runs over the cells
/// innermost with no branch inside, so each becomes vector instructions.
#[inline(always)]
pub fn relax_block<L: Lattice, C: Collision, const FORCED: bool, const N: usize>(
    coll: &C,
    s: &BlockState<N>,
    f: &mut Block<N>,
) {
    let wp = coll.omega_plus();
    let wm = coll.omega_minus();
    let sp = 1.0 - 0.5 * wp;
    let sm = 1.0 - 0.5 * wm;
    // rest population: even part only
    let w0 = L::W[0];
    for (l, f0) in f[0].iter_mut().enumerate() {
        let wr = w0 * s.rho[l];
        let mut d = -wp * (*f0 - wr * (1.0 - 1.5 * s.uu[l]));
        if FORCED {
            d += sp * wr * (-3.0 * s.ua[l]);
        }
        *f0 += d;
    }
    each_pair!(L, q, {
        let w = L::W[q];
        let cu = dot_c(L::C[q], &s.u);
        let ca = if FORCED {
            dot_c(L::C[q], &s.a)
        } else {
            [0.0; N]
        };
        for l in 0..N {
            let (fq, fo) = (f[q][l], f[q + 1][l]);
            let wr = w * s.rho[l];
            let ep = wr * (1.0 + 4.5 * cu[l] * cu[l] * s.inv_eps[l] - 1.5 * s.uu[l]);
            let em = wr * 3.0 * cu[l];
            let fp = 0.5 * (fq + fo);
            let fm = 0.5 * (fq - fo);
            let mut dp = -wp * (fp - ep);
            let mut dm = -wm * (fm - em);
            if FORCED {
                dp += sp * wr * (9.0 * cu[l] * ca[l] * s.inv_eps[l] - 3.0 * s.ua[l]);
                dm += sm * wr * 3.0 * ca[l];
            }
            f[q][l] = fq + dp + dm;
            f[q + 1][l] = fo + dp - dm;
        }
    });
}

/// Relaxes one cell of density `rho` and forcing state `s`: pulled populations `pre` (Q of
/// them) into `out` (a boundary node's update).
pub fn relax_cell<L: Lattice, C: Collision, F: Forcing>(
    coll: &C,
    rho: f64,
    s: &CellState,
    pre: &[f64],
    out: &mut [f64],
) {
    let mut st = BlockState::<1>::default();
    st.set(0, rho, s);
    let mut f: Block<1> = [[0.0]; QMAX];
    for (fq, p) in f.iter_mut().zip(&pre[..L::Q]) {
        fq[0] = *p;
    }
    if F::ACTIVE {
        relax_block::<L, C, true, 1>(coll, &st, &mut f);
    } else {
        relax_block::<L, C, false, 1>(coll, &st, &mut f);
    }
    for (v, oq) in out[..L::Q].iter_mut().zip(&f) {
        *v = oq[0];
    }
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
