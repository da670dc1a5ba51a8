//! Correlated random displacements with covariance 2 kB T dt M = 2 D dt (eq. 6.14).
//!
//! Both methods build a matrix B with B B^T = M (exactly for Cholesky, approximately for
//! TEA-HI); a step's random displacement is sqrt(2 kB T dt) B g with g a vector of independent
//! standard normal numbers (eq. 6.15–6.16, with C = sqrt(kB T) B). Without hydrodynamic
//! interactions M is diagonal and the integrator draws sqrt(2 D dt) g directly: no generator is
//! built.

use crate::error::{invalid, Result};
use nalgebra::{DMatrix, DVector};

/// How the correlated noise is generated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NoiseMethod {
    /// Exact: lower-triangular Cholesky factor of M (eq. 6.16), O(N^3) per factorisation.
    Cholesky,
    /// Truncated expansion ansatz (Geyer & Winter 2009), O(N^2).
    TeaHi,
}

/// A factor B of the mobility, B B^T (approximately) = M.
#[derive(Debug, Clone)]
pub struct NoiseGenerator {
    pub method: NoiseMethod,
    b: DMatrix<f64>,
}

impl NoiseGenerator {
    /// Factorises the 3N x 3N mobility `m` (m/(N s)) by `method`.
    pub fn new(method: NoiseMethod, m: &DMatrix<f64>) -> Result<NoiseGenerator> {
        check_square_symmetric(m)?;
        let b = match method {
            NoiseMethod::Cholesky => cholesky(m)?,
            NoiseMethod::TeaHi => tea_hi(m)?,
        };
        Ok(NoiseGenerator { method, b })
    }
    /// The factor B (B B^T = M for Cholesky).
    pub fn factor(&self) -> &DMatrix<f64> {
        &self.b
    }
    /// `scale * B g`; `g` holds independent standard normal numbers.
    pub fn apply(&self, g: &DVector<f64>, scale: f64) -> DVector<f64> {
        (&self.b * g) * scale
    }
}

fn check_square_symmetric(m: &DMatrix<f64>) -> Result<()> {
    let n = m.nrows();
    if m.ncols() != n || !n.is_multiple_of(3) || n == 0 {
        return invalid(format!(
            "mobility matrix is {}x{}: must be square with a positive multiple of 3 rows",
            n,
            m.ncols()
        ));
    }
    if let Some(k) = (0..n).find(|&k| !(m[(k, k)].is_finite() && m[(k, k)] > 0.0)) {
        return invalid(format!(
            "mobility diagonal entry {k} (particle {}) = {} m/(N s): must be positive and finite",
            k / 3,
            m[(k, k)]
        ));
    }
    Ok(())
}

/// Lower Cholesky factor L of M, M = L L^T. When M is not positive definite, the error names
/// the particle whose row produced a non-positive pivot and the partner it is most strongly
/// coupled to (largest normalized 3x3 block norm), i.e. the offending pair.
fn cholesky(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    if let Some(c) = m.clone().cholesky() {
        return Ok(c.l());
    }
    // Locate the first failing pivot with a plain left-looking factorisation.
    let n = m.nrows();
    let mut l = DMatrix::<f64>::zeros(n, n);
    let mut fail = None;
    'outer: for j in 0..n {
        let mut d = m[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 0.0 {
            fail = Some((j, d));
            break 'outer;
        }
        let djj = d.sqrt();
        l[(j, j)] = djj;
        for i in (j + 1)..n {
            let mut s = m[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / djj;
        }
    }
    let (row, pivot) = fail.unwrap_or((n - 1, f64::NAN));
    let p = row / 3;
    let np = n / 3;
    let block_norm = |a: usize, b: usize| -> f64 {
        let mut s = 0.0;
        for x in 0..3 {
            for y in 0..3 {
                s += m[(3 * a + x, 3 * b + y)].powi(2);
            }
        }
        s.sqrt() / (m[(3 * a, 3 * a)] * m[(3 * b, 3 * b)]).sqrt()
    };
    let partner = (0..np)
        .filter(|&q| q != p)
        .max_by(|&x, &y| block_norm(p, x).total_cmp(&block_norm(p, y)));
    match partner {
        Some(q) => invalid(format!(
            "mobility (diffusion) tensor is not positive definite: Cholesky pivot {pivot:e} <= 0 \
             at row {row} (particle {p}); the offending pair is particles {} and {} (normalized \
             coupling {:.4}); an Oseen tensor at short range does this, use RPY",
            q.min(p),
            q.max(p),
            block_norm(p, q)
        )),
        None => invalid(format!(
            "mobility (diffusion) tensor is not positive definite: Cholesky pivot {pivot:e} <= 0 \
             at row {row} (particle {p})"
        )),
    }
}

/// TEA-HI factor (T. Geyer and U. Winter, J. Chem. Phys. 130, 114905 (2009), eq. 17–22 there,
/// truncated expansion ansatz). With n = 3N and the normalized coupling of the entries
///   eps = (1 / (n (n - 1))) sum_{k != l} M_kl / sqrt(M_kk M_ll)      (mean off-diagonal coupling),
///   x = (n - 1) eps^2 - (n - 2) eps,
///   beta = (1 - sqrt(1 - x)) / x = 1 / (1 + sqrt(1 - x))           (beta -> 1/2 as eps -> 0),
///   C_k = (1 + beta^2 sum_{l != k} M_kl^2 / (M_kk M_ll))^(-1/2),
///   B_kk = C_k sqrt(M_kk),   B_kl = C_k beta M_kl / sqrt(M_ll)  (k != l).
/// For identical spheres sqrt(M_kk M_ll) = M_kk and this is the published scheme; the
/// normalisation by sqrt(M_kk M_ll) and the 1/sqrt(M_ll) make the variances (B B^T)_kk = M_kk
/// exact for any diagonal. B B^T = M holds exactly for a diagonal M (eps = 0, beta = 1/2,
/// C = 1) and for a matrix with all off-diagonal entries equal (beta solves
/// x beta^2 - 2 beta + 1 = 0, which is the condition (B B^T)_kl = M_kl there).
fn tea_hi(m: &DMatrix<f64>) -> Result<DMatrix<f64>> {
    let n = m.nrows();
    let sd: Vec<f64> = (0..n).map(|k| m[(k, k)].sqrt()).collect();
    let mut sum = 0.0;
    for k in 0..n {
        for l in 0..n {
            if k != l {
                sum += m[(k, l)] / (sd[k] * sd[l]);
            }
        }
    }
    let nf = n as f64;
    let eps = if n > 1 { sum / (nf * (nf - 1.0)) } else { 0.0 };
    let x = (nf - 1.0) * eps * eps - (nf - 2.0) * eps;
    if x.is_nan() || x > 1.0 {
        return invalid(format!(
            "TEA-HI: mean normalized off-diagonal coupling eps = {eps} gives \
             (3N-1) eps^2 - (3N-2) eps = {x} > 1: beta is not real (the mobility is too \
             strongly coupled; use Cholesky)"
        ));
    }
    let beta = 1.0 / (1.0 + (1.0 - x).sqrt());
    let mut b = DMatrix::<f64>::zeros(n, n);
    for k in 0..n {
        let mut s = 0.0;
        for l in 0..n {
            if l != k {
                let c = m[(k, l)] / (sd[k] * sd[l]);
                s += c * c;
            }
        }
        let ck = 1.0 / (1.0 + beta * beta * s).sqrt();
        for l in 0..n {
            b[(k, l)] = if l == k {
                ck * sd[k]
            } else {
                ck * beta * m[(k, l)] / sd[l]
            };
        }
    }
    Ok(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_reproduces() {
        let m = DMatrix::from_row_slice(3, 3, &[4.0, 1.0, 0.5, 1.0, 3.0, 0.2, 0.5, 0.2, 2.0]);
        let g = NoiseGenerator::new(NoiseMethod::Cholesky, &m).unwrap();
        let b = g.factor();
        assert!((b * b.transpose() - &m).abs().max() < 1e-15);
    }

    #[test]
    fn cholesky_failure_names_pair() {
        // Particles 0 and 2 fully correlated beyond 1: not positive definite.
        let mut m = DMatrix::<f64>::identity(9, 9);
        for p in 0..3 {
            m[(p, 6 + p)] = 1.2;
            m[(6 + p, p)] = 1.2;
        }
        let e = NoiseGenerator::new(NoiseMethod::Cholesky, &m)
            .unwrap_err()
            .to_string();
        assert!(e.contains("particles 0 and 2"), "{e}");
    }

    #[test]
    fn tea_hi_exact_cases() {
        let d = DMatrix::from_diagonal(&DVector::from_vec(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
        let b = tea_hi(&d).unwrap();
        assert!((&b * b.transpose() - &d).abs().max() < 1e-15);
        let c = 0.3;
        let mut e = DMatrix::<f64>::from_element(6, 6, 2.0 * c);
        for k in 0..6 {
            e[(k, k)] = 2.0;
        }
        let b = tea_hi(&e).unwrap();
        assert!((&b * b.transpose() - &e).abs().max() < 1e-15);
    }
}
