//! Neighbour search: a cell list (periodic in x and y, open in z) builds a half Verlet list of
//! the pairs closer than R_i + R_j + skin; the list is rebuilt when some particle has moved more
//! than skin / 2 since the last build. Each pair carries its tangential history, which is
//! copied into the new list at a rebuild (pairs are sorted by (i, j), so the look-up is a binary
//! search in i's old range). The list also holds, for every particle, the pairs in which it is
//! the second member, so that forces are gathered per particle in a fixed order (results are
//! the same at any thread count).

use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;
use rayon::prelude::*;

/// One listed pair i < j with its contact history (40 bytes: the pair loop streams the whole
/// list every step).
#[derive(Debug, Clone, Copy)]
pub struct Pair {
    pub i: u32,
    pub j: u32,
    /// Overlap (m), <= 0 when apart.
    pub delta: f64,
    /// Tangential spring displacement (m).
    pub xi: Vector3<f64>,
}

/// The force a pair's contact exerted in the current step (zero when apart), kept for the
/// per-particle gather when the pair loop runs on several threads (on one thread the loop adds
/// it into both members at once and nothing is stored).
#[derive(Debug, Clone, Copy, Default)]
pub struct PairForce {
    /// Force on i (on j: minus this) (N).
    pub force: Vector3<f64>,
    /// n x F_t (N); the torque on either member is -(its radius) times this.
    pub n_cross_ft: Vector3<f64>,
}

/// Below this many items a loop runs serially (rayon's overhead dominates).
pub(crate) const PAR_MIN: usize = 1024;

/// Minimum-image wrap of one lateral component.
/// Valid for |d| < 1.5 l (positions are kept in [0, l), so differences are within (-l, l)).
#[inline(always)]
pub(crate) fn wrap_delta(d: f64, l: f64) -> f64 {
    if d > 0.5 * l {
        d - l
    } else if d < -0.5 * l {
        d + l
    } else {
        d
    }
}

/// True when a particle now at `p`, at `q` when the list was built, moved more than
/// sqrt(`lim2`) (periodic in x and y): the list must be rebuilt.
#[inline(always)]
pub(crate) fn moved_beyond(
    p: &Vector3<f64>,
    q: &Vector3<f64>,
    lx: f64,
    ly: f64,
    lim2: f64,
) -> bool {
    let d = Vector3::new(
        wrap_delta(p.x - q.x, lx),
        wrap_delta(p.y - q.y, ly),
        p.z - q.z,
    );
    d.norm_squared() > lim2
}

/// The half Verlet list with per-particle gather ranges.
#[derive(Debug, Clone, Default)]
pub struct NeighbourList {
    pub pairs: Vec<Pair>,
    /// The step's force of each pair (index as `pairs`; zero for pairs that are apart),
    /// written and read within a step on several threads.
    pub forces: Vec<PairForce>,
    /// pairs[first_start[i]..first_start[i + 1]] have i as first member.
    pub first_start: Vec<u32>,
    /// second_pairs[second_start[i]..second_start[i + 1]] index the pairs with i second.
    pub second_start: Vec<u32>,
    pub second_pairs: Vec<u32>,
    /// Positions at the last build.
    pub(crate) pos_at_build: Vec<Vector3<f64>>,
    pub skin: f64,
    pub builds: usize,
}

impl NeighbourList {
    pub fn new(skin: f64) -> NeighbourList {
        NeighbourList {
            skin,
            ..Default::default()
        }
    }

    /// The pairs' force entries, as many as pairs, moved out for a step's loops to write.
    pub(crate) fn take_forces(&mut self) -> Vec<PairForce> {
        let mut forces = std::mem::take(&mut self.forces);
        forces.resize(self.pairs.len(), PairForce::default());
        forces
    }

    /// The positions of the last build, when it was made for `n` particles (None: a rebuild
    /// is due), and the squared distance, (skin / 2)^2, a particle may move before the next.
    pub fn built_positions(&self, n: usize) -> Option<(&[Vector3<f64>], f64)> {
        (self.pos_at_build.len() == n)
            .then(|| (&self.pos_at_build[..], 0.25 * self.skin * self.skin))
    }

    /// Rebuilds the list for positions `pos` (x in [0, lx), y in [0, ly)), keeping the history
    /// of pairs that stay listed.
    pub fn build(&mut self, pos: &[Vector3<f64>], radius: &[f64], lx: f64, ly: f64) -> Result<()> {
        let n = pos.len();
        let r_max = radius.iter().cloned().fold(0.0, f64::max);
        let cut = 2.0 * r_max + self.skin;
        if lx < 2.0 * cut || ly < 2.0 * cut {
            return invalid(format!(
                "lateral box {lx} m x {ly} m: must be at least twice the neighbour cutoff \
                 2 r_max + skin = {cut} m in each periodic direction"
            ));
        }
        let (z_lo, z_hi) = pos
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
                (a.min(p.z), b.max(p.z))
            });
        let cells = |l: f64| {
            let m = (l / cut).floor() as usize;
            if m >= 3 {
                m
            } else {
                1
            }
        };
        let (nx, ny) = (cells(lx), cells(ly));
        let nz = if n == 0 {
            1
        } else {
            (((z_hi - z_lo) / cut).floor() as usize + 1).min(1 << 20)
        };
        let (cx, cy) = (lx / nx as f64, ly / ny as f64);
        let cell_of = |p: &Vector3<f64>| -> (usize, usize, usize) {
            let ix = ((p.x / cx) as isize).clamp(0, nx as isize - 1) as usize;
            let iy = ((p.y / cy) as isize).clamp(0, ny as isize - 1) as usize;
            let iz = (((p.z - z_lo) / cut) as isize).clamp(0, nz as isize - 1) as usize;
            (ix, iy, iz)
        };
        let ncell = nx * ny * nz;
        let idx = |c: (usize, usize, usize)| (c.2 * ny + c.1) * nx + c.0;
        // counting sort of particles into cells
        let mut count = vec![0u32; ncell + 1];
        let cell_ids: Vec<usize> = pos.iter().map(|p| idx(cell_of(p))).collect();
        for &c in &cell_ids {
            count[c + 1] += 1;
        }
        for c in 0..ncell {
            count[c + 1] += count[c];
        }
        let mut fill = count.clone();
        let mut members = vec![0u32; n];
        for (i, &c) in cell_ids.iter().enumerate() {
            members[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        let skin = self.skin;
        let offs = |m: usize| -> &'static [isize] {
            if m >= 3 {
                &[-1, 0, 1]
            } else {
                &[0]
            }
        };
        let neighbours_of = |i: usize| -> Vec<u32> {
            let p = pos[i];
            let (ix, iy, iz) = cell_of(&p);
            let mut js = Vec::new();
            for &dz in &[-1isize, 0, 1] {
                let z = iz as isize + dz;
                if z < 0 || z >= nz as isize {
                    continue;
                }
                for &dy in offs(ny) {
                    let y = (iy as isize + dy).rem_euclid(ny as isize) as usize;
                    for &dx in offs(nx) {
                        let x = (ix as isize + dx).rem_euclid(nx as isize) as usize;
                        let c = idx((x, y, z as usize));
                        for &j in &members[count[c] as usize..count[c + 1] as usize] {
                            if (j as usize) <= i {
                                continue;
                            }
                            let q = pos[j as usize];
                            let d = Vector3::new(
                                wrap_delta(p.x - q.x, lx),
                                wrap_delta(p.y - q.y, ly),
                                p.z - q.z,
                            );
                            let rc = radius[i] + radius[j as usize] + skin;
                            if d.norm_squared() < rc * rc {
                                js.push(j);
                            }
                        }
                    }
                }
            }
            js.sort_unstable();
            js
        };
        let lists: Vec<Vec<u32>> = if n >= PAR_MIN {
            (0..n).into_par_iter().map(neighbours_of).collect()
        } else {
            (0..n).map(neighbours_of).collect()
        };
        let total: usize = lists.iter().map(Vec::len).sum();
        let mut pairs = Vec::with_capacity(total);
        let mut first_start = Vec::with_capacity(n + 1);
        let old = std::mem::take(&mut self.pairs);
        let old_start = std::mem::take(&mut self.first_start);
        for (i, js) in lists.iter().enumerate() {
            first_start.push(pairs.len() as u32);
            let old_range: &[Pair] = if old_start.len() == n + 1 {
                &old[old_start[i] as usize..old_start[i + 1] as usize]
            } else {
                &[]
            };
            for &j in js {
                let xi = old_range
                    .binary_search_by_key(&j, |p| p.j)
                    .map_or(Vector3::zeros(), |k| old_range[k].xi);
                pairs.push(Pair {
                    i: i as u32,
                    j,
                    delta: f64::NEG_INFINITY,
                    xi,
                });
            }
        }
        first_start.push(pairs.len() as u32);
        // pairs in which each particle is second, in pair order
        let mut second_start = vec![0u32; n + 1];
        for p in &pairs {
            second_start[p.j as usize + 1] += 1;
        }
        for i in 0..n {
            second_start[i + 1] += second_start[i];
        }
        let mut fill = second_start.clone();
        let mut second_pairs = vec![0u32; pairs.len()];
        for (k, p) in pairs.iter().enumerate() {
            second_pairs[fill[p.j as usize] as usize] = k as u32;
            fill[p.j as usize] += 1;
        }
        self.pairs = pairs;
        self.first_start = first_start;
        self.second_start = second_start;
        self.second_pairs = second_pairs;
        self.pos_at_build = pos.to_vec();
        self.builds += 1;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn list_matches_brute_force_and_keeps_history() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let (lx, ly) = (10.0, 8.0);
        let n = 300;
        let pos: Vec<Vector3<f64>> = (0..n)
            .map(|_| {
                Vector3::new(
                    rng.gen::<f64>() * lx,
                    rng.gen::<f64>() * ly,
                    rng.gen::<f64>() * 12.0,
                )
            })
            .collect();
        let radius: Vec<f64> = (0..n).map(|_| 0.2 + 0.3 * rng.gen::<f64>()).collect();
        let mut nl = NeighbourList::new(0.1);
        nl.build(&pos, &radius, lx, ly).unwrap();
        let mut brute = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                let d = Vector3::new(
                    wrap_delta(pos[i].x - pos[j].x, lx),
                    wrap_delta(pos[i].y - pos[j].y, ly),
                    pos[i].z - pos[j].z,
                );
                if d.norm() < radius[i] + radius[j] + 0.1 {
                    brute.push((i as u32, j as u32));
                }
            }
        }
        let got: Vec<(u32, u32)> = nl.pairs.iter().map(|p| (p.i, p.j)).collect();
        assert_eq!(got, brute);
        for p in nl.pairs.iter_mut() {
            p.xi = Vector3::new(p.i as f64, p.j as f64, 1.0);
        }
        nl.build(&pos, &radius, lx, ly).unwrap();
        assert!(nl
            .pairs
            .iter()
            .all(|p| p.xi == Vector3::new(p.i as f64, p.j as f64, 1.0)));
        // every pair appears once in the second-member index of its j
        for i in 0..n {
            for &k in &nl.second_pairs[nl.second_start[i] as usize..nl.second_start[i + 1] as usize]
            {
                assert_eq!(nl.pairs[k as usize].j as usize, i);
            }
        }
    }
}
