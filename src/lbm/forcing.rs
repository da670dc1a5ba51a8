//! Forcing: what a cell's velocity is and which acceleration enters the collision.
//!
//! All three share one form (Guo & Zhao, Phys. Rev. E 66, 036304, 2002, eq. 14-22; with
//! eps = 1 and no drag it is the body force of Guo, Zheng & Shi, Phys. Rev. E 65, 046308, 2002):
//! the velocity is u = v / (c0 + sqrt(c0^2 + c1 |v|)) with v = sum f c / rho + eps G / 2, and
//! the collision adds the source term with acceleration
//! a = -(eps nu / K) u - (eps F_eps / sqrt K) |u| u + eps G (seed 002 eq. 10).
//! `ACTIVE = false` lets the compiler drop the source term of an unforced fluid.

use super::memory::{stride_off_sets, vec_on_huge_pages};
use super::simd::{v3, Cells, Real};

/// The state of a cell (or of a block of cells, one per lane of `R`) that the collision
/// needs.
#[derive(Debug, Clone, Copy)]
pub struct CellState<R = f64> {
    /// Fluid velocity (lattice units).
    pub u: [R; 3],
    /// Acceleration in the source term (lattice units).
    pub a: [R; 3],
    /// 1 / porosity (1 for a clear fluid).
    pub inv_eps: R,
}

/// A forcing scheme: the velocity of a cell from its density and momentum.
pub trait Forcing: Send + Sync {
    /// False when the source term is identically zero.
    const ACTIVE: bool;
    const NAME: &'static str;
    /// The states of the cells `cells` (one per lane of `R`) of density `rho` and momentum `j`
    /// (lattice units). Written once for a cell and for a block, so both give the same bits.
    fn states<R: Real>(&self, cells: Cells, rho: R, j: [R; 3]) -> CellState<R>;
    /// The state of one cell.
    #[inline(always)]
    fn state(&self, cell: usize, rho: f64, j: [f64; 3]) -> CellState {
        let idx = [cell];
        self.states::<f64>(Cells::one(&idx), rho, j)
    }
    /// The state of a cell whose velocity `u` is prescribed (a boundary node): the source
    /// term's acceleration at that velocity.
    fn state_at_velocity(&self, cell: usize, rho: f64, u: [f64; 3]) -> CellState;
}

/// No force: u = j / rho.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unforced;

impl Forcing for Unforced {
    const ACTIVE: bool = false;
    const NAME: &'static str = "none";
    #[inline(always)]
    fn states<R: Real>(&self, _cells: Cells, rho: R, j: [R; 3]) -> CellState<R> {
        let r = R::splat(1.0) / rho;
        CellState {
            u: v3!(k => j[k] * r),
            a: [R::splat(0.0); 3],
            inv_eps: R::splat(1.0),
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
    /// Guo, Zheng & Shi: u = j / rho + g / 2.
    #[inline(always)]
    fn states<R: Real>(&self, _cells: Cells, rho: R, j: [R; 3]) -> CellState<R> {
        let r = R::splat(1.0) / rho;
        let g = self.g;
        CellState {
            u: v3!(k => j[k].mul_add(r, R::splat(0.5 * g[k]))),
            a: v3!(k => R::splat(g[k])),
            inv_eps: R::splat(1.0),
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
    /// eps, lin and quad of every cell: three arrays of `cells` values in one allocation,
    /// `stride` apart ([`Porous::field`]).
    fields: Vec<f64>,
    cells: usize,
    stride: usize,
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

/// Refuses a porosity outside (0, 1], with the rule.
pub fn check_porosity(eps: f64) -> Result<(), String> {
    if eps.is_nan() || eps <= 0.0 || eps > 1.0 {
        return Err(format!("porosity eps = {eps}: must be in (0, 1]"));
    }
    Ok(())
}

/// Refuses a permeability that is not positive (infinity: no drag), with the rule.
pub fn check_permeability(k: f64) -> Result<(), String> {
    if k.is_nan() || k <= 0.0 {
        return Err(format!("permeability K = {k} (lattice units): must be > 0"));
    }
    Ok(())
}

impl Porous {
    /// A medium of `cells` cells, all clear fluid (eps = 1, K = infinity).
    pub fn clear(cells: usize, nu: f64, g: [f64; 3], forchheimer: bool) -> Porous {
        let stride = stride_off_sets(cells);
        let mut fields = vec_on_huge_pages(3 * stride, 0.0);
        fields[..cells].fill(1.0);
        Porous {
            g,
            nu,
            forchheimer,
            fields,
            cells,
            stride,
            w: vec_on_huge_pages(cells, [0.0; 3]),
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
        check_porosity(eps)?;
        if !(lin.is_finite() && lin >= 0.0 && quad.is_finite() && quad >= 0.0) {
            return Err(format!(
                "drag coefficients lin = {lin}, quad = {quad} (lattice units): must be finite and >= 0"
            ));
        }
        self.set_fields(cell, [eps, lin, quad]);
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
        check_porosity(eps)?;
        check_permeability(k)?;
        let (lin, quad) = guo_zhao_coefficients(eps, k, self.nu, self.forchheimer);
        self.set_fields(cell, [eps, lin, quad]);
        Ok(())
    }

    fn set_fields(&mut self, cell: usize, values: [f64; 3]) {
        for (k, v) in values.into_iter().enumerate() {
            self.fields[k * self.stride + cell] = v;
        }
    }

    /// Field `k` of every cell: 0 eps, 1 lin, 2 quad.
    #[inline(always)]
    fn field(&self, k: usize) -> &[f64] {
        &self.fields[k * self.stride..k * self.stride + self.cells]
    }

    pub fn eps(&self, cell: usize) -> f64 {
        self.field(0)[cell]
    }

    /// The porosity field.
    pub fn eps_field(&self) -> &[f64] {
        self.field(0)
    }
}

impl Forcing for Porous {
    const ACTIVE: bool = true;
    const NAME: &'static str = "Guo-Zhao porous medium";
    /// Guo & Zhao eq. 20-22 for u - w: v = j/rho + eps G/2, c0 = (1 + eps nu/(2K))/2,
    /// c1 = eps F_eps/(2 sqrt K), u - w = (v - w) / (c0 + sqrt(c0^2 + c1 |v - w|)); then seed
    /// 002 eq. 10 on the relative velocity: a = -(eps nu/K + eps F_eps/sqrt K |u - w|) (u - w)
    /// + eps G. The matrix velocity is read only where some cell has one.
    #[inline(always)]
    fn states<R: Real>(&self, cells: Cells, rho: R, j: [R; 3]) -> CellState<R> {
        let eps = R::field(self.field(0), cells);
        let lin = R::field(self.field(1), cells);
        let quad = R::field(self.field(2), cells);
        let g = self.g;
        let r = R::splat(1.0) / rho;
        let half_eps = eps * R::splat(0.5);
        let mut v = v3!(k => j[k].mul_add(r, half_eps * R::splat(g[k])));
        let mut w = [R::splat(0.0); 3];
        if self.moving {
            w = v3!(k => {
                let mut wk = [0.0; super::simd::LANES];
                for (wl, &c) in wk.iter_mut().zip(cells.idx) {
                    *wl = self.w[c][k];
                }
                R::load(&wk)
            });
            v = v3!(k => v[k] - w[k]);
        }
        let c0 = lin.mul_add(R::splat(0.25), R::splat(0.5));
        let c1 = quad * R::splat(0.5);
        let vn = v[2].mul_add(v[2], v[1].mul_add(v[1], v[0] * v[0])).sqrt();
        let s = R::splat(1.0) / (c0 + c0.mul_add(c0, c1 * vn).sqrt());
        let rel = v3!(k => v[k] * s);
        let drag = quad.mul_add(vn * s, lin);
        let mut u = rel;
        if self.moving {
            u = v3!(k => rel[k] + w[k]);
        }
        CellState {
            u,
            a: v3!(k => (-drag).mul_add(rel[k], eps * R::splat(g[k]))),
            inv_eps: R::splat(1.0) / eps,
        }
    }
    /// Seed 002 eq. 10 at the prescribed velocity u (relative to the matrix velocity w).
    fn state_at_velocity(&self, cell: usize, _rho: f64, u: [f64; 3]) -> CellState {
        let eps = self.field(0)[cell];
        let w = self.w[cell];
        let rel = [u[0] - w[0], u[1] - w[1], u[2] - w[2]];
        let un = (rel[0] * rel[0] + rel[1] * rel[1] + rel[2] * rel[2]).sqrt();
        let drag = self.field(1)[cell] + self.field(2)[cell] * un;
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

    /// The Guo–Zhao state of a block (the portable eight-lane type) gives the bits of the
    /// cell-by-cell state, on random porosities, coefficients, matrix velocities (a medium
    /// with and one without), densities and momenta, for scattered cells (gathered loads) and
    /// for runs of consecutive cells (slice loads).
    #[test]
    fn porous_block_states_equal_cell_states_bitwise() {
        use crate::lbm::simd::{VArr, LANES as N};
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
        let lanes = |v: VArr| {
            let mut out = [0.0; N];
            v.store(&mut out);
            out.map(f64::to_bits)
        };
        for _ in 0..200 {
            let scattered = [0; N].map(|_| rng.gen_range(0..cells_total));
            let start = rng.gen_range(0..=cells_total - N);
            let run: [usize; N] = std::array::from_fn(|l| start + l);
            let rho = [0; N].map(|_| rng.gen_range(0.9..1.1));
            let j = [0; 3].map(|_| [0; N].map(|_| rng.gen_range(-0.1..0.1)));
            for medium in [&fixed, &moving] {
                for (cells, contiguous) in [(scattered, false), (run, true)] {
                    let block = medium.states(
                        Cells {
                            idx: &cells,
                            contiguous,
                        },
                        VArr::load(&rho),
                        j.map(|jk| VArr::load(&jk)),
                    );
                    for l in 0..N {
                        let s = medium.state(cells[l], rho[l], [j[0][l], j[1][l], j[2][l]]);
                        for k in 0..3 {
                            assert_eq!(lanes(block.u[k])[l], s.u[k].to_bits());
                            assert_eq!(lanes(block.a[k])[l], s.a[k].to_bits());
                        }
                        assert_eq!(lanes(block.inv_eps)[l], s.inv_eps.to_bits());
                    }
                }
            }
        }
    }
}
