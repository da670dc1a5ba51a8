//! Forcing: what a cell's velocity is and which acceleration enters the collision.
//!
//! All three share one form (Guo & Zhao, Phys. Rev. E 66, 036304, 2002, eq. 14-22; with
//! eps = 1 and no drag it is the body force of Guo, Zheng & Shi, Phys. Rev. E 65, 046308, 2002):
//! the velocity is u = v / (c0 + sqrt(c0^2 + c1 |v|)) with v = sum f c / rho + eps G / 2, and
//! the collision adds the source term with acceleration
//! a = -(eps nu / K) u - (eps F_eps / sqrt K) |u| u + eps G (seed 002 eq. 10).
//! `ACTIVE = false` lets the compiler drop the source term of an unforced fluid.

use super::collision::BlockState;

/// What the forcing sees of a block of cells: lane l is cell `cells[l]` with density `rho[l]`
/// and momentum `j[k][l]` (lattice units).
pub struct BlockMoments<const N: usize> {
    pub cells: [usize; N],
    /// Whether cells[l] = cells[0] + l for every lane.
    pub contiguous: bool,
    pub rho: [f64; N],
    pub j: [[f64; N]; 3],
}

/// The state of one cell that the collision needs.
#[derive(Debug, Clone, Copy)]
pub struct CellState {
    /// Fluid velocity (lattice units).
    pub u: [f64; 3],
    /// Acceleration in the source term (lattice units).
    pub a: [f64; 3],
    /// 1 / porosity (1 for a clear fluid).
    pub inv_eps: f64,
}

/// A forcing scheme: the velocity of a cell from its density and momentum.
pub trait Forcing: Send + Sync {
    /// False when the source term is identically zero.
    const ACTIVE: bool;
    const NAME: &'static str;
    fn state(&self, cell: usize, rho: f64, j: [f64; 3]) -> CellState;
    /// The state of a cell whose velocity `u` is prescribed (a boundary node): the source
    /// term's acceleration at that velocity.
    fn state_at_velocity(&self, cell: usize, rho: f64, u: [f64; 3]) -> CellState;
    /// The states of a block of cells written into `st`. Lane by lane through
    /// [`Forcing::state`] by default; a forcing may override it with lane-parallel arithmetic
    /// of the same operations in the same order, so that the bits do not change.
    #[inline(always)]
    fn block_states<const N: usize>(&self, m: &BlockMoments<N>, st: &mut BlockState<N>) {
        let (cells, rho, j) = (&m.cells, &m.rho, &m.j);
        for l in 0..N {
            let s = self.state(cells[l], rho[l], [j[0][l], j[1][l], j[2][l]]);
            st.set(l, rho[l], &s);
        }
    }
}

/// No force: u = j / rho.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unforced;

impl Forcing for Unforced {
    const ACTIVE: bool = false;
    const NAME: &'static str = "none";
    #[inline(always)]
    fn state(&self, _cell: usize, rho: f64, j: [f64; 3]) -> CellState {
        let r = 1.0 / rho;
        CellState {
            u: [j[0] * r, j[1] * r, j[2] * r],
            a: [0.0; 3],
            inv_eps: 1.0,
        }
    }
    #[inline(always)]
    fn state_at_velocity(&self, _cell: usize, _rho: f64, u: [f64; 3]) -> CellState {
        CellState {
            u,
            a: [0.0; 3],
            inv_eps: 1.0,
        }
    }
}

/// Uniform body force per unit mass `g` (lattice units), Guo's scheme: u = (j + rho g / 2) / rho.
#[derive(Debug, Clone, Copy)]
pub struct BodyForce {
    pub g: [f64; 3],
}

impl Forcing for BodyForce {
    const ACTIVE: bool = true;
    const NAME: &'static str = "Guo body force";
    #[inline(always)]
    fn state(&self, _cell: usize, rho: f64, j: [f64; 3]) -> CellState {
        let r = 1.0 / rho;
        let g = self.g;
        CellState {
            u: [
                j[0] * r + 0.5 * g[0],
                j[1] * r + 0.5 * g[1],
                j[2] * r + 0.5 * g[2],
            ],
            a: g,
            inv_eps: 1.0,
        }
    }
    #[inline(always)]
    fn state_at_velocity(&self, _cell: usize, _rho: f64, u: [f64; 3]) -> CellState {
        CellState {
            u,
            a: self.g,
            inv_eps: 1.0,
        }
    }
    /// [`Forcing::state`] and [`BlockState::set`] lane-parallel, the same operations in the
    /// same order (the lane-by-lane default compiles to shuffles across lanes).
    #[inline(always)]
    fn block_states<const N: usize>(&self, m: &BlockMoments<N>, st: &mut BlockState<N>) {
        let (rho, j, g) = (&m.rho, &m.j, self.g);
        for l in 0..N {
            let r = 1.0 / rho[l];
            let u = [0, 1, 2].map(|k| j[k][l] * r + 0.5 * g[k]);
            st.rho[l] = rho[l];
            for k in 0..3 {
                st.u[k][l] = u[k];
                st.a[k][l] = g[k];
            }
            st.inv_eps[l] = 1.0;
            st.uu[l] = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * 1.0;
            st.ua[l] = (u[0] * g[0] + u[1] * g[1] + u[2] * g[2]) * 1.0;
        }
    }
}

/// Guo-Zhao porous medium (Brinkman-Forchheimer), porosity and permeability per cell.
///
/// Stored per cell: eps, the linear drag coefficient eps nu / K and the Forchheimer
/// coefficient eps F_eps / sqrt(K), F_eps = 1.75 / sqrt(150 eps^3) (Ergun; Guo & Zhao eq. 4),
/// so that a cell costs three loads and one square root more than a clear fluid.
///
/// The solid matrix of a cell may move: with the matrix velocity w (superficial, i.e. eps
/// times the solid velocity; zero by default) the drag acts on the relative velocity,
/// a = -(lin + quad |u - w|) (u - w) + eps G, and the implicit velocity of Guo & Zhao eq. 20-22
/// is solved for u - w (with w = 0 every operation is the fixed medium's, bit for bit).
#[derive(Debug, Clone)]
pub struct Porous {
    /// Body force per unit mass G (lattice units).
    pub g: [f64; 3],
    /// Kinematic viscosity (lattice units), fixed by the collision.
    nu: f64,
    /// Whether the Forchheimer term is on.
    forchheimer: bool,
    eps: Vec<f64>,
    lin: Vec<f64>,
    quad: Vec<f64>,
    w: Vec<[f64; 3]>,
    /// Whether any cell was given a nonzero matrix velocity (else the kernel skips w).
    moving: bool,
}

/// The Guo-Zhao drag coefficients (lin, quad) = (eps nu / K, eps F_eps / sqrt K) of a cell of
/// porosity `eps` and permeability `k` (lattice units; k = infinity: no drag), F_eps =
/// 1.75 / sqrt(150 eps^3) (Ergun; Guo & Zhao eq. 4); quad = 0 without the Forchheimer term.
pub fn guo_zhao_coefficients(eps: f64, k: f64, nu: f64, forchheimer: bool) -> (f64, f64) {
    let lin = eps * nu / k;
    let quad = if forchheimer && k.is_finite() {
        eps * 1.75 / (150.0 * eps * eps * eps).sqrt() / k.sqrt()
    } else {
        0.0
    };
    (lin, quad)
}

impl Porous {
    /// A medium of `cells` cells, all clear fluid (eps = 1, K = infinity).
    pub fn clear(cells: usize, nu: f64, g: [f64; 3], forchheimer: bool) -> Porous {
        Porous {
            g,
            nu,
            forchheimer,
            eps: vec![1.0; cells],
            lin: vec![0.0; cells],
            quad: vec![0.0; cells],
            w: vec![[0.0; 3]; cells],
            moving: false,
        }
    }

    /// Kinematic viscosity (lattice units) the coefficients of [`Porous::set`] use.
    pub fn nu(&self) -> f64 {
        self.nu
    }

    /// Whether [`Porous::set`] includes the Forchheimer term.
    pub fn forchheimer(&self) -> bool {
        self.forchheimer
    }

    /// Sets porosity `eps` (0 < eps <= 1) and the drag coefficients of one cell directly:
    /// a = -(lin + quad |u - w|) (u - w) + eps G (lattice units, lin, quad >= 0 and finite).
    /// Returns the rule broken, if any.
    pub fn set_coefficients(
        &mut self,
        cell: usize,
        eps: f64,
        lin: f64,
        quad: f64,
    ) -> Result<(), String> {
        if eps.is_nan() || eps <= 0.0 || eps > 1.0 {
            return Err(format!("porosity eps = {eps}: must be in (0, 1]"));
        }
        if !(lin.is_finite() && lin >= 0.0 && quad.is_finite() && quad >= 0.0) {
            return Err(format!(
                "drag coefficients lin = {lin}, quad = {quad} (lattice units): must be finite and >= 0"
            ));
        }
        self.eps[cell] = eps;
        self.lin[cell] = lin;
        self.quad[cell] = quad;
        Ok(())
    }

    /// Sets the matrix velocity w of one cell (superficial: eps times the solid velocity;
    /// lattice units, finite).
    pub fn set_matrix_velocity(&mut self, cell: usize, w: [f64; 3]) -> Result<(), String> {
        if !w.iter().all(|c| c.is_finite()) {
            return Err(format!(
                "matrix velocity {w:?} (lattice units): must be finite"
            ));
        }
        self.w[cell] = w;
        self.moving |= w != [0.0; 3];
        Ok(())
    }

    /// The matrix velocity w of a cell.
    pub fn matrix_velocity(&self, cell: usize) -> [f64; 3] {
        self.w[cell]
    }

    /// Sets porosity `eps` (0 < eps <= 1) and permeability `k` (lattice units, > 0; infinity
    /// for no drag) of one cell. Returns the rule broken, if any.
    pub fn set(&mut self, cell: usize, eps: f64, k: f64) -> Result<(), String> {
        if eps.is_nan() || eps <= 0.0 || eps > 1.0 {
            return Err(format!("porosity eps = {eps}: must be in (0, 1]"));
        }
        if k.is_nan() || k <= 0.0 {
            return Err(format!("permeability K = {k} (lattice units): must be > 0"));
        }
        let (lin, quad) = guo_zhao_coefficients(eps, k, self.nu, self.forchheimer);
        self.eps[cell] = eps;
        self.lin[cell] = lin;
        self.quad[cell] = quad;
        Ok(())
    }

    pub fn eps(&self, cell: usize) -> f64 {
        self.eps[cell]
    }

    /// The porosity field.
    pub fn eps_field(&self) -> &[f64] {
        &self.eps
    }
}

impl Forcing for Porous {
    const ACTIVE: bool = true;
    const NAME: &'static str = "Guo-Zhao porous medium";
    #[inline(always)]
    fn state(&self, cell: usize, rho: f64, j: [f64; 3]) -> CellState {
        let eps = self.eps[cell];
        let lin = self.lin[cell];
        let quad = self.quad[cell];
        let r = 1.0 / rho;
        let g = self.g;
        let w = self.w[cell];
        // Guo & Zhao eq. 20-22 for u - w: v = j/rho + eps G/2, c0 = (1 + eps nu/(2K))/2,
        // c1 = eps F_eps/(2 sqrt K), u - w = (v - w) / (c0 + sqrt(c0^2 + c1 |v - w|)).
        let v = [
            j[0] * r + 0.5 * eps * g[0] - w[0],
            j[1] * r + 0.5 * eps * g[1] - w[1],
            j[2] * r + 0.5 * eps * g[2] - w[2],
        ];
        let c0 = 0.5 * (1.0 + 0.5 * lin);
        let c1 = 0.5 * quad;
        let vn = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        let s = 1.0 / (c0 + (c0 * c0 + c1 * vn).sqrt());
        let rel = [v[0] * s, v[1] * s, v[2] * s];
        let un = vn * s;
        // Seed 002 eq. 10 on the relative velocity: F = -(eps nu/K + eps F_eps/sqrt K |u - w|)
        // (u - w) + eps G.
        let drag = lin + quad * un;
        CellState {
            u: [rel[0] + w[0], rel[1] + w[1], rel[2] + w[2]],
            a: [
                eps * g[0] - drag * rel[0],
                eps * g[1] - drag * rel[1],
                eps * g[2] - drag * rel[2],
            ],
            inv_eps: 1.0 / eps,
        }
    }
    /// [`Porous::state`] for a block, one operation at a time over the lanes (so that the
    /// square roots and divisions run as vector instructions), each lane's operations those
    /// of `state` and `BlockState::set` in the same order: the same bits. The fields of a
    /// block of consecutive cells are read as slices, and the matrix velocity only where a
    /// cell has one (w = +0 changes no bit: x - 0 = x, and u = rel + 0 is still added).
    #[inline(always)]
    fn block_states<const N: usize>(&self, m: &BlockMoments<N>, st: &mut BlockState<N>) {
        let (cells, rho, j) = (&m.cells, &m.rho, &m.j);
        let g = self.g;
        let (mut eps, mut lin, mut quad) = ([0.0; N], [0.0; N], [0.0; N]);
        let mut w = [[0.0; N]; 3];
        let c0 = cells[0];
        if m.contiguous {
            eps.copy_from_slice(&self.eps[c0..c0 + N]);
            lin.copy_from_slice(&self.lin[c0..c0 + N]);
            quad.copy_from_slice(&self.quad[c0..c0 + N]);
        } else {
            for l in 0..N {
                let c = cells[l];
                eps[l] = self.eps[c];
                lin[l] = self.lin[c];
                quad[l] = self.quad[c];
            }
        }
        if self.moving {
            for l in 0..N {
                for k in 0..3 {
                    w[k][l] = self.w[cells[l]][k];
                }
            }
        }
        for l in 0..N {
            let r = 1.0 / rho[l];
            let v = [0, 1, 2].map(|k| j[k][l] * r + 0.5 * eps[l] * g[k] - w[k][l]);
            let c0 = 0.5 * (1.0 + 0.5 * lin[l]);
            let c1 = 0.5 * quad[l];
            let vn = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            let s = 1.0 / (c0 + (c0 * c0 + c1 * vn).sqrt());
            let rel = [v[0] * s, v[1] * s, v[2] * s];
            let drag = lin[l] + quad[l] * (vn * s);
            let u = [0, 1, 2].map(|k| rel[k] + w[k][l]);
            let a = [0, 1, 2].map(|k| eps[l] * g[k] - drag * rel[k]);
            let inv_eps = 1.0 / eps[l];
            st.rho[l] = rho[l];
            for k in 0..3 {
                st.u[k][l] = u[k];
                st.a[k][l] = a[k];
            }
            st.inv_eps[l] = inv_eps;
            st.uu[l] = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) * inv_eps;
            st.ua[l] = (u[0] * a[0] + u[1] * a[1] + u[2] * a[2]) * inv_eps;
        }
    }
    /// Seed 002 eq. 10 at the prescribed velocity u (relative to the matrix velocity w).
    fn state_at_velocity(&self, cell: usize, _rho: f64, u: [f64; 3]) -> CellState {
        let eps = self.eps[cell];
        let w = self.w[cell];
        let rel = [u[0] - w[0], u[1] - w[1], u[2] - w[2]];
        let un = (rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]).sqrt();
        let drag = self.lin[cell] + self.quad[cell] * un;
        CellState {
            u,
            a: [0, 1, 2].map(|k| eps * self.g[k] - drag * rel[k]),
            inv_eps: 1.0 / eps,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The block form of the Guo–Zhao state gives the bits of the cell-by-cell form, on
    /// random porosities, coefficients, matrix velocities (a medium with and one without),
    /// densities and momenta, for scattered cells (the loads are gathers) and for runs of
    /// consecutive cells (slice loads).
    #[test]
    fn porous_block_states_equal_cell_states_bitwise() {
        const N: usize = 8;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let cells_total = 64;
        let mut fixed = Porous::clear(cells_total, 0.1, [1e-5, -2e-6, 3e-7], true);
        for c in 0..cells_total {
            let eps = rng.gen_range(0.05..=1.0);
            fixed
                .set(c, eps, 10f64.powf(rng.gen_range(-6.0..2.0)))
                .unwrap();
        }
        let mut moving = fixed.clone();
        for c in (0..cells_total).step_by(3) {
            let w = [0; 3].map(|_| rng.gen_range(-0.05..0.05));
            moving.set_matrix_velocity(c, w).unwrap();
        }
        assert!(moving.moving && !fixed.moving);
        let bits = |b: &BlockState<N>| {
            let mut v: Vec<u64> = b.rho.iter().map(|x| x.to_bits()).collect();
            for k in 0..3 {
                v.extend(b.u[k].iter().chain(&b.a[k]).map(|x| x.to_bits()));
            }
            v.extend(
                b.inv_eps
                    .iter()
                    .chain(&b.uu)
                    .chain(&b.ua)
                    .map(|x| x.to_bits()),
            );
            v
        };
        for _ in 0..200 {
            let scattered = [0; N].map(|_| rng.gen_range(0..cells_total));
            let start = rng.gen_range(0..=cells_total - N);
            let run: [usize; N] = std::array::from_fn(|l| start + l);
            let rho = [0; N].map(|_| rng.gen_range(0.9..1.1));
            let j = [0; 3].map(|_| [0; N].map(|_| rng.gen_range(-0.1..0.1)));
            for medium in [&fixed, &moving] {
                for (cells, contiguous) in [(scattered, false), (run, true)] {
                    let m = BlockMoments {
                        cells,
                        contiguous,
                        rho,
                        j,
                    };
                    let mut block = BlockState::<N>::default();
                    medium.block_states(&m, &mut block);
                    let mut each = BlockState::<N>::default();
                    for l in 0..N {
                        let s = medium.state(cells[l], rho[l], [j[0][l], j[1][l], j[2][l]]);
                        each.set(l, rho[l], &s);
                    }
                    assert_eq!(bits(&block), bits(&each));
                }
            }
        }
    }
}
