//! Neighbour search of the deposition box: a cell list periodic in x and y, open in z.
//!
//! Cells are at least `reach` wide (the largest possible centre distance of two overlapping
//! particles, twice the largest bounding radius), so the overlap partners of a particle lie in
//! its own and the adjacent cells. Along z the cells cover [0, top) and a centre above the top
//! is kept in the highest cell (clamping keeps adjacent particles in adjacent cells). With
//! fewer than three cells across the box (a narrow column), every particle is one cell in x-y
//! and the periodic images are enumerated explicitly.

use nalgebra::Vector3;

/// The cell list.
#[derive(Debug, Clone)]
pub struct Cells {
    box_side_m: f64,
    n_xy: usize,
    n_z: usize,
    cell_xy_m: f64,
    cell_z_m: f64,
    members: Vec<Vec<u32>>,
    cell_of: Vec<u32>,
    /// Periodic images to try on each side when n_xy == 1.
    images: i32,
}

impl Cells {
    /// Cells for `positions` in a box of side `box_side_m`, with `reach_m` the largest centre
    /// distance at which two particles can overlap and `top_m` the height the z cells cover.
    pub fn new(box_side_m: f64, reach_m: f64, top_m: f64, positions: &[Vector3<f64>]) -> Cells {
        let mut n_xy = (box_side_m / reach_m).floor().max(1.0) as usize;
        if n_xy < 3 {
            n_xy = 1;
        }
        // At most ~ 64^3 cells: more buys nothing for the box sizes of the model.
        let n_xy = n_xy.min(256);
        let n_z = ((top_m / reach_m).floor().max(1.0) as usize).min(4096);
        let images = if n_xy == 1 {
            (reach_m / box_side_m).ceil() as i32
        } else {
            0
        };
        let mut c = Cells {
            box_side_m,
            n_xy,
            n_z,
            cell_xy_m: box_side_m / n_xy as f64,
            cell_z_m: top_m.max(reach_m) / n_z as f64,
            members: vec![Vec::new(); n_xy * n_xy * n_z],
            cell_of: vec![0; positions.len()],
            images,
        };
        for (i, p) in positions.iter().enumerate() {
            let k = c.cell_index(p);
            c.members[k].push(i as u32);
            c.cell_of[i] = k as u32;
        }
        c
    }

    /// The part of the list that depends on the run's history, for a checkpoint: the z
    /// layering fixed when the list was built (from the top then) and every cell's members in
    /// their order (moves reorder them, and the order decides which pair test settles a
    /// trial first, hence the prefilter counts).
    pub fn history(&self) -> (usize, f64, &[Vec<u32>]) {
        (self.n_z, self.cell_z_m, &self.members)
    }

    /// Replaces the history of a list built for the same box, reach and particles by a saved
    /// one ([`Cells::history`]); refuses members that are not each particle once, in the cell
    /// of its position.
    pub fn restore_history(
        &mut self,
        n_z: usize,
        cell_z_m: f64,
        members: Vec<Vec<u32>>,
        positions: &[Vector3<f64>],
    ) -> Result<(), String> {
        if n_z == 0 || members.len() != self.n_xy * self.n_xy * n_z || !(cell_z_m > 0.0) {
            return Err(format!(
                "{} cells in {n_z} layers of {cell_z_m} m do not fit a box of {} x {} columns",
                members.len(),
                self.n_xy,
                self.n_xy
            ));
        }
        self.n_z = n_z;
        self.cell_z_m = cell_z_m;
        let n = positions.len();
        let mut seen = vec![false; n];
        for (k, list) in members.iter().enumerate() {
            for &i in list {
                let i = i as usize;
                if i >= n || seen[i] || self.cell_index(&positions[i]) != k {
                    return Err(format!(
                        "particle {i} is not once in the cell of its position"
                    ));
                }
                seen[i] = true;
                self.cell_of[i] = k as u32;
            }
        }
        if let Some(i) = seen.iter().position(|s| !s) {
            return Err(format!("particle {i} is in no cell"));
        }
        self.members = members;
        Ok(())
    }

    fn cell_index(&self, p: &Vector3<f64>) -> usize {
        let ix = ((p.x / self.cell_xy_m) as usize).min(self.n_xy - 1);
        let iy = ((p.y / self.cell_xy_m) as usize).min(self.n_xy - 1);
        let iz = if p.z <= 0.0 {
            0
        } else {
            ((p.z / self.cell_z_m) as usize).min(self.n_z - 1)
        };
        (iz * self.n_xy + iy) * self.n_xy + ix
    }

    /// Records that particle `i` now sits at `p` (a wrapped position).
    pub fn moved(&mut self, i: usize, p: &Vector3<f64>) {
        let k = self.cell_index(p);
        let old = self.cell_of[i] as usize;
        if k != old {
            let list = &mut self.members[old];
            if let Some(at) = list.iter().position(|&m| m as usize == i) {
                list.swap_remove(at);
            }
            self.members[k].push(i as u32);
            self.cell_of[i] = k as u32;
        }
    }

    /// Calls `visit(j, d)` for every particle j (j != i, or a periodic image of i itself in a
    /// narrow column) near the point `p`, with d = (image of j) - p. Stops early and returns
    /// true as soon as `visit` returns true.
    pub fn any_near(
        &self,
        i: usize,
        p: &Vector3<f64>,
        positions: &[Vector3<f64>],
        mut visit: impl FnMut(usize, Vector3<f64>) -> bool,
    ) -> bool {
        let l = self.box_side_m;
        let n = self.n_xy;
        let k = self.cell_index(p);
        let iz = k / (n * n);
        let iy = (k / n) % n;
        let ix = k % n;
        let z_lo = iz.saturating_sub(1);
        let z_hi = (iz + 1).min(self.n_z - 1);
        if n == 1 {
            for cz in z_lo..=z_hi {
                for &j in &self.members[cz] {
                    let j = j as usize;
                    // a sphere's own periodic images move with it: they sit at whole periods
                    // from the trial position, not from the position it leaves
                    let base = if j == i {
                        Vector3::zeros()
                    } else {
                        positions[j] - p
                    };
                    for sx in -self.images..=self.images {
                        for sy in -self.images..=self.images {
                            if j == i && sx == 0 && sy == 0 {
                                continue;
                            }
                            let d = base + Vector3::new(sx as f64 * l, sy as f64 * l, 0.0);
                            if visit(j, d) {
                                return true;
                            }
                        }
                    }
                }
            }
            return false;
        }
        for cz in z_lo..=z_hi {
            for dy in [n - 1, 0, 1] {
                let cy = (iy + dy) % n;
                for dx in [n - 1, 0, 1] {
                    let cx = (ix + dx) % n;
                    for &j in &self.members[(cz * n + cy) * n + cx] {
                        let j = j as usize;
                        if j == i {
                            continue;
                        }
                        let mut d = positions[j] - p;
                        d.x -= l * (d.x / l).round();
                        d.y -= l * (d.y / l).round();
                        if visit(j, d) {
                            return true;
                        }
                    }
                }
            }
        }
        false
    }
}

/// Wraps x and y into [0, side).
pub fn wrap_xy(p: &mut Vector3<f64>, side: f64) {
    p.x = wrap1(p.x, side);
    p.y = wrap1(p.y, side);
}

#[inline]
fn wrap1(c: f64, side: f64) -> f64 {
    if (0.0..side).contains(&c) {
        return c;
    }
    let w = c - side * (c / side).floor();
    if w >= side {
        0.0
    } else {
        w
    }
}
