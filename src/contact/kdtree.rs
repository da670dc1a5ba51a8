//! A small static 3-d tree for nearest-neighbour queries over surface samples (thesis 003
//! sec. 4.4.2). Built once per shape; queries are exact nearest neighbours.

use nalgebra::Vector3;

#[derive(Debug, Clone)]
pub struct KdTree {
    pts: Vec<Vector3<f64>>,
    /// Original index of each stored point.
    idx: Vec<usize>,
    /// Split axis per node of the implicit balanced tree over `pts` (node = median of a range).
    axis: Vec<u8>,
}

impl KdTree {
    /// Builds the tree (O(n log^2 n)).
    pub fn new(points: &[Vector3<f64>]) -> KdTree {
        let mut items: Vec<(Vector3<f64>, usize)> = points
            .iter()
            .cloned()
            .enumerate()
            .map(|(i, p)| (p, i))
            .collect();
        let mut axis = vec![0u8; items.len()];
        fn build(items: &mut [(Vector3<f64>, usize)], axis: &mut [u8]) {
            if items.len() <= 1 {
                return;
            }
            // split on the axis of largest extent
            let mut lo = Vector3::repeat(f64::INFINITY);
            let mut hi = Vector3::repeat(f64::NEG_INFINITY);
            for (p, _) in items.iter() {
                lo = lo.inf(p);
                hi = hi.sup(p);
            }
            let ext = hi - lo;
            let ax = if ext.x >= ext.y && ext.x >= ext.z {
                0
            } else if ext.y >= ext.z {
                1
            } else {
                2
            };
            let mid = items.len() / 2;
            items.select_nth_unstable_by(mid, |a, b| a.0[ax].partial_cmp(&b.0[ax]).unwrap());
            axis[mid] = ax as u8;
            let (l, r) = items.split_at_mut(mid);
            let (la, ra) = axis.split_at_mut(mid);
            build(l, la);
            build(&mut r[1..], &mut ra[1..]);
        }
        build(&mut items, &mut axis);
        KdTree {
            pts: items.iter().map(|x| x.0).collect(),
            idx: items.iter().map(|x| x.1).collect(),
            axis,
        }
    }

    pub fn len(&self) -> usize {
        self.pts.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pts.is_empty()
    }

    /// Nearest stored point to `q`: (original index, squared distance). None if empty.
    pub fn nearest(&self, q: &Vector3<f64>) -> Option<(usize, f64)> {
        if self.pts.is_empty() {
            return None;
        }
        let mut best = (usize::MAX, f64::INFINITY);
        self.search(0, self.pts.len(), q, &mut best);
        Some((self.idx[best.0], best.1))
    }

    fn search(&self, lo: usize, hi: usize, q: &Vector3<f64>, best: &mut (usize, f64)) {
        if lo >= hi {
            return;
        }
        let mid = lo + (hi - lo) / 2;
        let p = &self.pts[mid];
        let d2 = (p - q).norm_squared();
        if d2 < best.1 {
            *best = (mid, d2);
        }
        if hi - lo == 1 {
            return;
        }
        let ax = self.axis[mid] as usize;
        let diff = q[ax] - p[ax];
        let (near, far) = if diff < 0.0 {
            ((lo, mid), (mid + 1, hi))
        } else {
            ((mid + 1, hi), (lo, mid))
        };
        self.search(near.0, near.1, q, best);
        if diff * diff < best.1 {
            self.search(far.0, far.1, q, best);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn nearest_matches_brute_force() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let pts: Vec<Vector3<f64>> = (0..500)
            .map(|_| Vector3::new(rng.gen(), rng.gen::<f64>() * 3.0, rng.gen::<f64>() - 0.5))
            .collect();
        let tree = KdTree::new(&pts);
        for _ in 0..500 {
            let q = Vector3::new(
                rng.gen::<f64>() * 2.0 - 0.5,
                rng.gen::<f64>() * 4.0 - 0.5,
                rng.gen::<f64>() * 2.0 - 1.0,
            );
            let (i, d2) = tree.nearest(&q).unwrap();
            let (bi, bd2) = pts
                .iter()
                .enumerate()
                .map(|(i, p)| (i, (p - q).norm_squared()))
                .min_by(|a, b| a.1.partial_cmp(&b.1).unwrap())
                .unwrap();
            assert_eq!(d2, bd2);
            assert_eq!((pts[i] - q).norm_squared(), (pts[bi] - q).norm_squared());
        }
    }
}
