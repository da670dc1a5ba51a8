//! Collisions: BGK (seed 002 eq. 3, 5, 8) and two-relaxation-time (TRT; Ginzburg, Verhaeghe &
//! d'Humieres, Commun. Comput. Phys. 3, 427, 2008), both written on the pairs (q, opp q).
//!
//! For a pair with c = c_q the equilibrium (seed 002 eq. 5, with the porosity of Guo & Zhao
//! eq. 13) splits into the even part e+ = w rho (1 + 9/2 (c.u)^2/eps - 3/2 u.u/eps) and the odd
//! part e- = 3 w rho c.u; the source term (Guo & Zhao eq. 14) into
//! S+ = w rho (9 (c.u)(c.a)/eps - 3 u.a/eps) and S- = 3 w rho c.a. The even part relaxes at rate
//! omega+ = 1/tau (the viscosity, eq. 8: nu = (tau - 1/2)/3), the odd part at omega-; each
//! source part carries its factor (1 - omega/2). BGK is omega- = omega+.

use super::forcing::CellState;
use super::lattice::Lattice;

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

/// Macroscopic state of a run of cells (structure of arrays, one entry per cell).
#[derive(Debug, Clone, Default)]
pub struct RowState {
    pub rho: Vec<f64>,
    pub u: [Vec<f64>; 3],
    pub a: [Vec<f64>; 3],
    pub inv_eps: Vec<f64>,
    /// u.u / eps and u.a / eps, shared by every direction.
    pub uu: Vec<f64>,
    pub ua: Vec<f64>,
}

impl RowState {
    pub fn with_len(n: usize) -> RowState {
        let v = || vec![0.0; n];
        RowState {
            rho: v(),
            u: [v(), v(), v()],
            a: [v(), v(), v()],
            inv_eps: v(),
            uu: v(),
            ua: v(),
        }
    }

    /// Entry `i`: density `rho` and the forcing's state `s` (velocity, acceleration, 1/eps),
    /// with the shared products u.u / eps and u.a / eps (the latter makes the source term of
    /// Guo & Zhao eq. 14 massless).
    #[inline(always)]
    pub fn set(&mut self, i: usize, rho: f64, s: &CellState) {
        self.rho[i] = rho;
        for k in 0..3 {
            self.u[k][i] = s.u[k];
            self.a[k][i] = s.a[k];
        }
        self.inv_eps[i] = s.inv_eps;
        self.uu[i] = (s.u[0] * s.u[0] + s.u[1] * s.u[1] + s.u[2] * s.u[2]) * s.inv_eps;
        self.ua[i] = (s.u[0] * s.a[0] + s.u[1] * s.a[1] + s.u[2] * s.a[2]) * s.inv_eps;
    }
}

/// Relaxes the run [x0, x1) of one row: incoming populations in `inp` (q-major rows of `nx`),
/// post-collision populations written to row `y` of the z-plane `out` (q-major planes of
/// ny x nx), with the source term when `FORCED`. The loops run over the cells innermost, so
/// they vectorise.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn relax_run<L: Lattice, C: Collision, const FORCED: bool>(
    coll: &C,
    s: &RowState,
    inp: &[f64],
    nx: usize,
    (x0, x1): (usize, usize),
    out: &mut [f64],
    ny: usize,
    y: usize,
) {
    let n = x1 - x0;
    let wp = coll.omega_plus();
    let wm = coll.omega_minus();
    let sp = 1.0 - 0.5 * wp;
    let sm = 1.0 - 0.5 * wm;
    let rho = &s.rho[..n];
    let (ux, uy, uz) = (&s.u[0][..n], &s.u[1][..n], &s.u[2][..n]);
    let (ax, ay, az) = (&s.a[0][..n], &s.a[1][..n], &s.a[2][..n]);
    let (ie, uu, ua) = (&s.inv_eps[..n], &s.uu[..n], &s.ua[..n]);
    let row = |q: usize| (q * ny + y) * nx + x0;
    // rest population: even part only
    {
        let w0 = L::W[0];
        let f0 = &inp[x0..x1];
        let o = &mut out[row(0)..row(0) + n];
        for i in 0..n {
            let wr = w0 * rho[i];
            let mut d = -wp * (f0[i] - wr * (1.0 - 1.5 * uu[i]));
            if FORCED {
                d += sp * wr * (-3.0 * ua[i]);
            }
            o[i] = f0[i] + d;
        }
    }
    let mut q = 1;
    while q < L::Q {
        let c = L::C[q];
        let (cx, cy, cz) = (c[0] as f64, c[1] as f64, c[2] as f64);
        let w = L::W[q];
        let fq = &inp[q * nx + x0..q * nx + x1];
        let fo = &inp[(q + 1) * nx + x0..(q + 1) * nx + x1];
        let (lo, hi) = out.split_at_mut(row(q + 1));
        let oq = &mut lo[row(q)..row(q) + n];
        let oo = &mut hi[..n];
        for i in 0..n {
            let wr = w * rho[i];
            let cu = cx * ux[i] + cy * uy[i] + cz * uz[i];
            let ep = wr * (1.0 + 4.5 * cu * cu * ie[i] - 1.5 * uu[i]);
            let em = wr * 3.0 * cu;
            let fp = 0.5 * (fq[i] + fo[i]);
            let fm = 0.5 * (fq[i] - fo[i]);
            let mut dp = -wp * (fp - ep);
            let mut dm = -wm * (fm - em);
            if FORCED {
                let ca = cx * ax[i] + cy * ay[i] + cz * az[i];
                dp += sp * wr * (9.0 * cu * ca * ie[i] - 3.0 * ua[i]);
                dm += sm * wr * 3.0 * ca;
            }
            oq[i] = fq[i] + dp + dm;
            oo[i] = fo[i] + dp - dm;
        }
        q += 2;
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
