//! The periodic cell binning shared by the pair searches (pair gaps, g(r)).

use super::Configuration;
use nalgebra::Vector3;

/// A periodic cell binning of the centres for the pair searches: cells of edge at least
/// `reach`, so every partner within `reach` of a particle (nearest image) lies in the 27 cells
/// around its own, and only one image of it can be within reach.
pub(super) struct PeriodicCells {
    /// Cells per box edge (at least 3, so the 27 cells around one are distinct).
    per_edge: usize,
    box_length: f64,
    members: Vec<Vec<usize>>,
}

impl PeriodicCells {
    /// None when fewer than three cells of edge `reach` fit along the box.
    pub(super) fn new(c: &Configuration, reach: f64) -> Option<PeriodicCells> {
        // (A relative margin of 1e-9 keeps the cell edge above the reach through the rounding
        // of the cell coordinates.)
        let per_edge = (c.box_length / (reach * (1.0 + 1e-9))).floor();
        if per_edge.is_nan() || per_edge < 3.0 {
            return None;
        }
        let mut cells = PeriodicCells {
            per_edge: per_edge as usize,
            box_length: c.box_length,
            members: Vec::new(),
        };
        cells.members = vec![Vec::new(); cells.per_edge.pow(3)];
        for (j, x) in c.positions.iter().enumerate() {
            let k = cells.index(cells.cell_of(x));
            cells.members[k].push(j);
        }
        Some(cells)
    }

    fn cell_of(&self, x: &Vector3<f64>) -> [usize; 3] {
        let (m, bl) = (self.per_edge, self.box_length);
        let k = |t: f64| ((t / bl * m as f64).floor() as i64).rem_euclid(m as i64) as usize;
        [k(x.x), k(x.y), k(x.z)]
    }

    fn index(&self, k: [usize; 3]) -> usize {
        (k[0] * self.per_edge + k[1]) * self.per_edge + k[2]
    }

    /// The particles j > i in the 27 cells around particle i's, in increasing order.
    pub(super) fn partners_above(&self, c: &Configuration, i: usize) -> Vec<usize> {
        let m = self.per_edge;
        let k = self.cell_of(&c.positions[i]);
        let mut partners: Vec<usize> = Vec::new();
        for a in [m - 1, 0, 1] {
            for b in [m - 1, 0, 1] {
                for z in [m - 1, 0, 1] {
                    let cell = [(k[0] + a) % m, (k[1] + b) % m, (k[2] + z) % m];
                    partners.extend(self.members[self.index(cell)].iter().filter(|&&j| j > i));
                }
            }
        }
        partners.sort_unstable();
        partners
    }
}
