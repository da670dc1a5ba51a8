//! Finite-difference oracle for porous plane Couette flow (seed 002 Fig. 6a); writes
//! `reference/porous_couette.csv`.
//!
//! Nothing here calls the lattice-Boltzmann solver. The steady, fully developed flow between
//! a resting wall (y = 0) and a wall sliding at U0 (y = H), filled with a medium of porosity
//! eps and permeability K, obeys the generalized Navier-Stokes equation of Nithiarasu et al.
//! as used by Guo & Zhao (2002) and seed 002 eq. 10 (effective viscosity = fluid viscosity;
//! the convective and pressure terms vanish for this flow):
//!
//! nu u'' = (eps nu / K) u + (eps F_eps / sqrt K) |u| u,   F_eps = 1.75 / sqrt(150 eps^3),
//!
//! in units U = u/U0, eta = y/H: U'' = (eps/Da) U + (eps F_eps Re / sqrt Da) |U| U, U(0) = 0,
//! U(1) = 1, with Re = U0 H / nu and Da = K / H^2.
//!
//! Method: second-order central differences on N uniform intervals, the nonlinear system
//! solved by Newton's method (tridiagonal Jacobian, Thomas algorithm) to a correction below
//! 1e-16; N = 4096, 8192 and 16384; the table holds the Richardson extrapolation
//! R = (4 U_16384 - U_8192)/3 at eta = j/128 (points of every grid), and `est_abs_err` is
//! |R - (4 U_8192 - U_4096)/3| plus 1e-14 for rounding.

use crate::Result;
use std::fmt::Write as _;
use std::path::Path;

/// (eps, Re, Da) of the rows.
pub const CASES: &[(f64, f64, f64)] = &[
    (0.1, 0.1, 1e-2),
    (0.1, 0.1, 1e-3),
    (0.1, 10.0, 1e-2),
    (0.1, 10.0, 1e-3),
    (0.5, 10.0, 1e-2),
];

/// Points of the table: eta = j / SAMPLES, j = 0..=SAMPLES.
pub const SAMPLES: usize = 128;

/// The finite-difference solution at the N + 1 nodes eta = i/N.
pub fn solve(n: usize, eps: f64, re: f64, da: f64) -> Vec<f64> {
    let lin = eps / da;
    let quad = eps * 1.75 / (150.0 * eps * eps * eps).sqrt() * re / da.sqrt();
    let h2 = 1.0 / (n * n) as f64;
    let mut u: Vec<f64> = (0..=n).map(|i| i as f64 / n as f64).collect();
    let m = n - 1;
    let (mut a, mut b, mut c, mut r) = (vec![0.0; m], vec![0.0; m], vec![0.0; m], vec![0.0; m]);
    for _ in 0..100 {
        // residual of (U_{i-1} - 2 U_i + U_{i+1})/h^2 - lin U_i - quad |U_i| U_i at i = 1..n-1
        for k in 0..m {
            let i = k + 1;
            let ui = u[i];
            r[k] = -((u[i - 1] - 2.0 * ui + u[i + 1]) / h2 - lin * ui - quad * ui.abs() * ui);
            a[k] = 1.0 / h2;
            c[k] = 1.0 / h2;
            b[k] = -2.0 / h2 - lin - 2.0 * quad * ui.abs();
        }
        // Thomas algorithm for J d = r (d = 0 at both walls)
        for k in 1..m {
            let w = a[k] / b[k - 1];
            b[k] -= w * c[k - 1];
            r[k] -= w * r[k - 1];
        }
        let mut d = vec![0.0; m];
        d[m - 1] = r[m - 1] / b[m - 1];
        for k in (0..m - 1).rev() {
            d[k] = (r[k] - c[k] * d[k + 1]) / b[k];
        }
        let mut change: f64 = 0.0;
        for k in 0..m {
            u[k + 1] += d[k];
            change = change.max(d[k].abs());
        }
        if change < 1e-16 {
            break;
        }
    }
    u
}

/// The extrapolated profile at eta = j/SAMPLES and its error estimate.
pub fn oracle(eps: f64, re: f64, da: f64) -> Vec<(f64, f64)> {
    let grids = [4096, 8192, 16384];
    let sols: Vec<Vec<f64>> = grids.iter().map(|&n| solve(n, eps, re, da)).collect();
    (0..=SAMPLES)
        .map(|j| {
            let at = |g: usize| sols[g][j * grids[g] / SAMPLES];
            let r1 = (4.0 * at(1) - at(0)) / 3.0;
            let r2 = (4.0 * at(2) - at(1)) / 3.0;
            (r2, (r2 - r1).abs() + 1e-14)
        })
        .collect()
}

pub fn regen_porous_couette(reference_dir: &Path) -> Result<()> {
    let mut csv = String::from("eps,Re,Da,y_over_H,u_over_U0,est_abs_err\n");
    let mut worst: f64 = 0.0;
    for &(eps, re, da) in CASES {
        for (j, (u, e)) in oracle(eps, re, da).into_iter().enumerate() {
            worst = worst.max(e);
            let _ = writeln!(
                csv,
                "{eps},{re},{da:e},{},{u:.17e},{e:.2e}",
                j as f64 / SAMPLES as f64
            );
        }
    }
    super::write_file(reference_dir, "porous_couette.csv", csv)?;
    eprintln!(
        "porous_couette.csv: {} profiles of {} points, worst est_abs_err {worst:.2e}",
        CASES.len(),
        SAMPLES + 1
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without the Forchheimer term the equation has the closed form sinh(r eta)/sinh(r),
    /// r = sqrt(eps/Da); the same finite differences (Re = 0) must reach it at second order.
    #[test]
    fn linear_limit_is_the_sinh_profile() {
        let (eps, da): (f64, f64) = (0.1, 1e-3);
        let r = (eps / da).sqrt();
        let err = |n: usize| {
            let u = solve(n, eps, 0.0, da);
            (0..=n)
                .map(|i| {
                    let y = i as f64 / n as f64;
                    (u[i] - (r * y).sinh() / r.sinh()).abs()
                })
                .fold(0.0, f64::max)
        };
        let (e1, e2) = (err(512), err(1024));
        assert!(e2 < 1e-5, "{e2}");
        assert!(((e1 / e2).log2() - 2.0).abs() < 0.05, "{e1} {e2}");
        let o = oracle(eps, 0.0, da);
        for (j, (u, est)) in o.iter().enumerate() {
            let y = j as f64 / SAMPLES as f64;
            let exact = (r * y).sinh() / r.sinh();
            assert!((u - exact).abs() < 1e-11, "{y}: {u} vs {exact}");
            assert!(*est < 1e-9, "{est}");
        }
    }
}
