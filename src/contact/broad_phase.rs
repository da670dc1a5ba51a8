//! Periodic cell list (orthorhombic box, minimum image) as the broad phase: all pairs of
//! centres closer than a cutoff.
//!
//! The box [0, Lx) x [0, Ly) x [0, Lz) is cut into mx x my x mz cells with m_k = floor(L_k /
//! cutoff) (with fewer than 3 cells along any axis every pair is checked by minimum image
//! directly). Each pair is reported once, i < j, with the minimum-image separation vector
//! r_j - r_i.

use nalgebra::Vector3;

#[derive(Debug, Clone)]
pub struct CellList {
    /// Box edges Lx, Ly, Lz.
    pub lengths: [f64; 3],
    pub cutoff: f64,
    m: [usize; 3],
}

impl CellList {
    /// A cell list for a cubic periodic box of side `box_length` and pair cutoff `cutoff`
    /// (both positive and finite; cutoff <= box_length / 2 so the minimum image is unique).
    pub fn new(box_length: f64, cutoff: f64) -> crate::Result<CellList> {
        CellList::orthorhombic([box_length; 3], cutoff)
    }

    /// A cell list for the periodic box of edges `lengths` (positive and finite) and pair
    /// cutoff `cutoff` (positive, at most half the shortest edge: the minimum image is unique).
    pub fn orthorhombic(lengths: [f64; 3], cutoff: f64) -> crate::Result<CellList> {
        if let Some(l) = lengths.iter().find(|l| !(l.is_finite() && **l > 0.0)) {
            return crate::error::invalid(format!("box_length = {l}: must be positive and finite"));
        }
        let shortest = lengths.iter().cloned().fold(f64::INFINITY, f64::min);
        if !(cutoff.is_finite() && cutoff > 0.0 && cutoff <= 0.5 * shortest) {
            return crate::error::invalid(format!(
                "cutoff = {cutoff}: must be positive and at most half the box length {shortest}"
            ));
        }
        let m = lengths.map(|l| (l / cutoff).floor() as usize);
        Ok(CellList { lengths, cutoff, m })
    }

    /// Minimum-image separation b - a.
    pub fn minimum_image(&self, a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
        let d = b - a;
        Vector3::from_fn(|k, _| {
            let l = self.lengths[k];
            d[k] - l * (d[k] / l).round()
        })
    }

    /// All pairs (i, j, r_j - r_i) with |r_j - r_i| < cutoff (minimum image), i < j, sorted.
    pub fn pairs(&self, pos: &[Vector3<f64>]) -> Vec<(usize, usize, Vector3<f64>)> {
        let c2 = self.cutoff * self.cutoff;
        let mut out = Vec::new();
        if self.m.iter().any(|&m| m < 3) {
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
        let (m, len) = (self.m, self.lengths);
        let cell_of = |p: &Vector3<f64>| -> [usize; 3] {
            let mut c = [0usize; 3];
            for k in 0..3 {
                let l = len[k];
                let w = p[k] - l * (p[k] / l).floor();
                c[k] = (((w / l) * m[k] as f64) as usize).min(m[k] - 1);
            }
            c
        };
        let idx = |c: [usize; 3]| (c[0] * m[1] + c[1]) * m[2] + c[2];
        let mut head = vec![usize::MAX; m[0] * m[1] * m[2]];
        let mut next = vec![usize::MAX; pos.len()];
        let cells: Vec<[usize; 3]> = pos.iter().map(cell_of).collect();
        for (i, c) in cells.iter().enumerate() {
            let h = idx(*c);
            next[i] = head[h];
            head[h] = i;
        }
        for (i, c) in cells.iter().enumerate() {
            for dx in [m[0] - 1, 0, 1] {
                for dy in [m[1] - 1, 0, 1] {
                    for dz in [m[2] - 1, 0, 1] {
                        let nc = [(c[0] + dx) % m[0], (c[1] + dy) % m[1], (c[2] + dz) % m[2]];
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

    /// Unequal edges (3 cells along one axis, many along another) against brute force.
    #[test]
    fn orthorhombic_matches_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (len, rc, n) = ([12.0, 3.3, 7.5], 1.1, 500);
        let pos: Vec<Vector3<f64>> = (0..n)
            .map(|_| Vector3::from_fn(|k, _| (rng.gen::<f64>() * 3.0 - 1.0) * len[k]))
            .collect();
        let cl = CellList::orthorhombic(len, rc).unwrap();
        let got: Vec<(usize, usize)> = cl.pairs(&pos).iter().map(|p| (p.0, p.1)).collect();
        let mut want = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let d = pos[j] - pos[i];
                // the nearest image by search over the 27 neighbouring boxes
                let near = (0..27)
                    .map(|s| {
                        let shift = Vector3::new(
                            ((s % 3) as f64 - 1.0) * len[0],
                            (((s / 3) % 3) as f64 - 1.0) * len[1],
                            ((s / 9) as f64 - 1.0) * len[2],
                        );
                        let w = Vector3::from_fn(|k, _| d[k] - len[k] * (d[k] / len[k]).round());
                        (w + shift).norm()
                    })
                    .fold(f64::INFINITY, f64::min);
                if near < rc {
                    want.push((i, j));
                }
            }
        }
        assert!(want.len() > 100, "{} pairs", want.len());
        assert_eq!(got, want);
    }

    #[test]
    fn rejects_bad_input() {
        assert!(CellList::new(-1.0, 0.1).is_err());
        assert!(CellList::new(1.0, 0.6).is_err());
        assert!(CellList::orthorhombic([4.0, 1.0, 4.0], 0.6).is_err());
        assert!(CellList::orthorhombic([4.0, 0.0, 4.0], 0.1).is_err());
    }
}
