//! Periodic cell list (cubic box, minimum image) as the broad phase: all pairs of centres
//! closer than a cutoff.
//!
//! The box [0, L)^3 is cut into m^3 cells with m = floor(L / cutoff) (m >= 3; with fewer
//! cells every pair is checked by minimum image directly). Each pair is reported once, i < j,
//! with the minimum-image separation vector r_j - r_i.

use nalgebra::Vector3;

#[derive(Debug, Clone)]
pub struct CellList {
    pub box_length: f64,
    pub cutoff: f64,
    m: usize,
}

impl CellList {
    /// A cell list for a cubic periodic box of side `box_length` and pair cutoff `cutoff`
    /// (both positive and finite; cutoff <= box_length / 2 so the minimum image is unique).
    pub fn new(box_length: f64, cutoff: f64) -> crate::Result<CellList> {
        if !(box_length.is_finite() && box_length > 0.0) {
            return crate::error::invalid(format!(
                "box_length = {box_length}: must be positive and finite"
            ));
        }
        if !(cutoff.is_finite() && cutoff > 0.0 && cutoff <= 0.5 * box_length) {
            return crate::error::invalid(format!(
                "cutoff = {cutoff}: must be positive and at most half the box length {box_length}"
            ));
        }
        let m = (box_length / cutoff).floor() as usize;
        Ok(CellList {
            box_length,
            cutoff,
            m,
        })
    }

    /// Minimum-image separation b - a.
    pub fn minimum_image(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
        let l = self.box_length;
        (b - a).map(|d| d - l * (d / l).round())
    }

    /// All pairs (i, j, r_j - r_i) with |r_j - r_i| < cutoff (minimum image), i < j, sorted.
    pub fn pairs(&self, pos: &[Vector3<f64>]) -> Vec<(usize, usize, Vector3<f64>)> {
        let l = self.box_length;
        let c2 = self.cutoff * self.cutoff;
        let mut out = Vec::new();
        if self.m < 3 {
            for i in 0..pos.len() {
                for j in i + 1..pos.len() {
                    let d = self.minimum_image(&pos[i], &pos[j]);
                    if d.norm_squared() < c2 {
                        out.push((i, j, d));
                    }
                }
            }
            return out;
        }
        let m = self.m;
        let cell_of = |p: &Vector3<f64>| -> [usize; 3] {
            let mut c = [0usize; 3];
            for k in 0..3 {
                let w = p[k] - l * (p[k] / l).floor();
                c[k] = (((w / l) * m as f64) as usize).min(m - 1);
            }
            c
        };
        let idx = |c: [usize; 3]| (c[0] * m + c[1]) * m + c[2];
        let mut head = vec![usize::MAX; m * m * m];
        let mut next = vec![usize::MAX; pos.len()];
        let cells: Vec<[usize; 3]> = pos.iter().map(cell_of).collect();
        for (i, c) in cells.iter().enumerate() {
            let h = idx(*c);
            next[i] = head[h];
            head[h] = i;
        }
        for (i, c) in cells.iter().enumerate() {
            for dx in [m - 1, 0, 1] {
                for dy in [m - 1, 0, 1] {
                    for dz in [m - 1, 0, 1] {
                        let nc = [(c[0] + dx) % m, (c[1] + dy) % m, (c[2] + dz) % m];
                        let mut j = head[idx(nc)];
                        while j != usize::MAX {
                            if j > i {
                                let d = self.minimum_image(&pos[i], &pos[j]);
                                if d.norm_squared() < c2 {
                                    out.push((i, j, d));
                                }
                            }
                            j = next[j];
                        }
                    }
                }
            }
        }
        out.sort_by_key(|p| (p.0, p.1));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn matches_brute_force_minimum_image() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for &(l, rc, n) in &[
            (10.0, 1.0, 800),
            (5.0, 2.4, 100),
            (3.0, 1.5, 60),
            (7.0, 1.1, 400),
        ] {
            let pos: Vec<Vector3<f64>> = (0..n)
                .map(|_| {
                    Vector3::new(
                        rng.gen::<f64>() * l,
                        rng.gen::<f64>() * l - l,
                        rng.gen::<f64>() * 3.0 * l,
                    )
                })
                .collect();
            let cl = CellList::new(l, rc).unwrap();
            let got: Vec<(usize, usize)> = cl.pairs(&pos).iter().map(|p| (p.0, p.1)).collect();
            let mut want = Vec::new();
            for i in 0..n {
                for j in i + 1..n {
                    if cl.minimum_image(&pos[i], &pos[j]).norm() < rc {
                        want.push((i, j));
                    }
                }
            }
            assert_eq!(got, want, "L={l} rc={rc}");
        }
    }

    #[test]
    fn rejects_bad_input() {
        assert!(CellList::new(-1.0, 0.1).is_err());
        assert!(CellList::new(1.0, 0.6).is_err());
    }
}
