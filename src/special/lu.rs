//! Solution of a small dense linear system by LU decomposition with partial pivoting, with the
//! operations of nalgebra's `m.lu().solve(&b)` in the same order, so bit for bit its result
//! (tested below against nalgebra on random, badly scaled and singular matrices).
//!
//! Why not nalgebra's: its generic LU on a 6x6 matrix (views, permutation sequence, generic
//! dimensions) took 20% of a superball packing run (`perf`, built-in `packing-superballs`:
//! `LU::new` 14%, `LU::solve` 6%), for about 150 floating-point operations. The superquadric
//! contact solver (`contact::contact_superquadric_superquadric`, thesis eq. 4.12) solves one
//! such system per Newton step.
//!
//! The order, as in nalgebra 0.33: for each column i, the pivot is the first row r >= i of
//! largest |a_ri|; a zero pivot skips the column (the solve then fails). The pivot row is
//! swapped in (also in the columns of L already computed), the entries below the pivot are
//! multiplied by 1 / pivot, and each later column k gets a_rk = (-a_ik) l_ri + a_rk. The solve
//! applies the row swaps in order, then forward substitution with the unit lower triangle
//! (b_r = (-b_i) l_ri + b_r) and back substitution with the upper one (b_i = b_i / u_ii, then
//! b_r = (-b_i) u_ri + b_r for r < i); a zero on the diagonal gives None.

use nalgebra::{SMatrix, SVector};

/// x with m x = b, or None when a pivot is zero (see the module docs).
pub fn lu_solve<const N: usize>(
    m: &SMatrix<f64, N, N>,
    b: &SVector<f64, N>,
) -> Option<SVector<f64, N>> {
    // a[c][r]: column-major, as nalgebra stores it.
    let mut a: [[f64; N]; N] = std::array::from_fn(|c| std::array::from_fn(|r| m[(r, c)]));
    let mut swaps = [(0usize, 0usize); N];
    let mut n_swaps = 0;
    for i in 0..N {
        let mut piv = i;
        let mut largest = a[i][i].abs();
        for (r, v) in a[i].iter().enumerate().skip(i + 1) {
            if v.abs() > largest {
                largest = v.abs();
                piv = r;
            }
        }
        let diag = a[i][piv];
        if diag == 0.0 {
            continue;
        }
        if piv != i {
            swaps[n_swaps] = (i, piv);
            n_swaps += 1;
            for col in a.iter_mut().take(i + 1) {
                col.swap(i, piv);
            }
        }
        let inv_diag = 1.0 / diag;
        for v in a[i].iter_mut().skip(i + 1) {
            *v *= inv_diag;
        }
        let (done, rest) = a.split_at_mut(i + 1);
        let l = &done[i];
        for col in rest.iter_mut() {
            if piv != i {
                col.swap(i, piv);
            }
            // (x + y and y + x are the same bits: axpy's a x + y as +=.)
            let p = col[i];
            for r in i + 1..N {
                col[r] += -p * l[r];
            }
        }
    }
    let mut x = *b;
    for &(i, j) in &swaps[..n_swaps] {
        x.swap_rows(i, j);
    }
    for i in 0..N {
        let c = x[i];
        for r in i + 1..N {
            x[r] += -c * a[i][r];
        }
    }
    for i in (0..N).rev() {
        let diag = a[i][i];
        if diag == 0.0 {
            return None;
        }
        let c = x[i] / diag;
        x[i] = c;
        for r in 0..i {
            x[r] += -c * a[i][r];
        }
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn same_bits<const N: usize>(
        ours: Option<SVector<f64, N>>,
        theirs: Option<SVector<f64, N>>,
    ) -> bool {
        match (ours, theirs) {
            (None, None) => true,
            (Some(x), Some(y)) => x
                .iter()
                .zip(y.iter())
                .all(|(p, q)| p.to_bits() == q.to_bits()),
            _ => false,
        }
    }

    /// Bit for bit nalgebra's `lu().solve()` on 6x6 and 3x3 systems: random entries over 24
    /// decades with random signs, rows of equal magnitude (ties between pivot candidates),
    /// zero columns and exactly singular matrices (None from both), and the Jacobians' shape
    /// of an exactly zero entry here and there.
    #[test]
    fn lu_solve_is_nalgebra_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(46);
        let (mut solved, mut singular, mut swapped) = (0, 0, 0);
        for case in 0..20_000 {
            let entry = |rng: &mut ChaCha8Rng| {
                let x = rng.gen_range(-1.0..1.0) * 10f64.powf(rng.gen_range(-12.0..12.0));
                if rng.gen_range(0..10) == 0 {
                    0.0
                } else {
                    x
                }
            };
            let mut m = SMatrix::<f64, 6, 6>::from_fn(|_, _| entry(&mut rng));
            let b = SVector::<f64, 6>::from_fn(|_, _| entry(&mut rng));
            match case % 5 {
                1 => {
                    // Ties: every entry of a column has the same magnitude.
                    let c = rng.gen_range(0..6);
                    let v = m[(0, c)].abs().max(1.0);
                    for r in 0..6 {
                        m[(r, c)] = if rng.gen() { v } else { -v };
                    }
                }
                2 => m.set_column(rng.gen_range(0..6), &SVector::zeros()),
                3 => {
                    // Two equal rows: singular, though no column is zero.
                    let (r1, r2) = (rng.gen_range(0..6), rng.gen_range(0..6));
                    let row = m.row(r1).into_owned();
                    m.set_row(r2, &row);
                }
                _ => {}
            }
            let ours = lu_solve(&m, &b);
            assert!(same_bits(ours, m.lu().solve(&b)), "case {case}: {m} {b}");
            match ours {
                Some(_) => solved += 1,
                None => singular += 1,
            }
            swapped += (m.column(0).iamax() != 0) as u32;
            let m3 = SMatrix::<f64, 3, 3>::from_fn(|r, c| m[(r, c)]);
            let b3 = SVector::<f64, 3>::from_fn(|r, _| b[r]);
            assert!(
                same_bits(lu_solve(&m3, &b3), m3.lu().solve(&b3)),
                "case {case}, 3x3"
            );
        }
        assert!(
            solved > 10_000 && singular > 1000 && swapped > 10_000,
            "{solved} solved, {singular} singular, {swapped} with a first swap"
        );
    }
}
