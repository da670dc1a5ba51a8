//! Incremental Verlet lists for the overlap removal.
//!
//! The overlap removal moves one particle at a time (thesis sec. 2.2.1), so rebuilding every
//! list when one particle has drifted (the classic Verlet criterion) costs O(N) per rebuild
//! and, near jamming where a few particles keep moving, dominated the run time (about 60% for
//! N = 1000 spheres, measured with `perf`). Here each particle keeps its own reference
//! position and axis; when particle i has moved more than skin/4 from its reference, only
//! i's list is rebuilt (from a cell grid of the reference positions) and i is added to or
//! removed from the lists of the particles it gained or lost.
//!
//! The grid holds each particle in the cell of its reference position and is updated only at
//! the particle's own rebuild, not at every move: following every move cost a cell lookup per
//! move (11% of a 10000-sphere jamming run with the list bookkeeping, `perf`). Its cells have
//! edge >= list cutoff + skin/4: a particle j within the list cutoff of x_i is within
//! cutoff + skin/4 of its reference (it has drifted at most skin/4 from it, see below), so its
//! cell is one of the 27 around the cell of x_i and the search still finds it.
//!
//! Why skin/4: a pair (i, j) is last decided at the later of the two particles' rebuilds,
//! t* (both lists are updated then), with both positions current. After t* each particle stays
//! within skin/4 of its reference, and its position at t* was too, so each has moved less than
//! skin/2 since t*; a pair not listed at t* was apart by more than the skin then and still does
//! not touch now.
//!
//! Which pairs are listed is decided by a caller-given lower bound on the surface gap of a pair
//! (`ListGap`): for rods the distance of the axis segments minus both radii, otherwise the
//! centre distance minus both bounding radii. A point of a rod's axis moves by at most
//! |dx| + (L/2) |da| (centre shift plus end-point swing), which is the displacement compared
//! with skin/4 (for spheres and bounding spheres, |dx|). For long rods this lists only the
//! rods that can meet (about rho (pi/2) L^2 D of them, 13 at L/D = 25 and phi = 0.2) instead of
//! every centre within L + D (about 770 there).

use super::{Container, Packing};
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;

/// A uniform cell grid over the container: periodic along the periodic directions, clamped
/// (cells at the edge take everything beyond it) across the cylinder.
#[derive(Debug, Clone)]
pub(super) struct Grid {
    /// Cells per direction (1 where there are fewer than 3 cells of the list cutoff, so each
    /// pair is searched once).
    dims: [usize; 3],
    lower: [f64; 3],
    /// 1 / cell edge length (a multiplication per coordinate instead of a division).
    inv_cell_size: [f64; 3],
    periodic: [bool; 3],
    members: Vec<Vec<usize>>,
    cell_of: Vec<usize>,
}

impl Grid {
    pub(super) fn new(
        container: &Container,
        box_length: f64,
        cutoff: f64,
        pos: &[Vector3<f64>],
    ) -> Grid {
        let (lower, extent, periodic) = container.grid_bounds(box_length);
        let mut dims = [1usize; 3];
        let mut cell_size = [0.0; 3];
        for k in 0..3 {
            let m = (extent[k] / cutoff).floor() as usize;
            // Periodic: fewer than 3 cells would visit a neighbour cell twice.
            dims[k] = if periodic[k] && m < 3 { 1 } else { m.max(1) };
            cell_size[k] = extent[k] / dims[k] as f64;
        }
        let mut g = Grid {
            dims,
            lower,
            inv_cell_size: cell_size.map(|c| 1.0 / c),
            periodic,
            members: vec![Vec::new(); dims[0] * dims[1] * dims[2]],
            cell_of: vec![0; pos.len()],
        };
        for (i, x) in pos.iter().enumerate() {
            let c = g.cell_index(x);
            g.cell_of[i] = c;
            g.members[c].push(i);
        }
        g
    }

    fn coords(&self, x: &Vector3<f64>) -> [usize; 3] {
        let mut c = [0usize; 3];
        for k in 0..3 {
            let m = self.dims[k] as i64;
            // floor and the periodic wrap in integers: f64::floor and rem_euclid are libm
            // calls on the baseline x86-64 target, and this runs once per particle move
            // (13% of a sphere jamming run). Saturating casts keep NaN and huge values in
            // range; the wall and periodic clamps below then apply as before.
            let t = (x[k] - self.lower[k]) * self.inv_cell_size[k];
            let mut s = t as i64;
            if (s as f64) > t {
                s -= 1;
            }
            c[k] = if self.periodic[k] {
                // A wrapped position is inside the box: one comparison, no integer division.
                let w = if (0..m).contains(&s) {
                    s
                } else {
                    s.rem_euclid(m)
                };
                w.min(m - 1) as usize
            } else {
                s.clamp(0, m - 1) as usize
            };
        }
        c
    }

    fn cell_index(&self, x: &Vector3<f64>) -> usize {
        let c = self.coords(x);
        (c[0] * self.dims[1] + c[1]) * self.dims[2] + c[2]
    }

    /// Moves particle i to the cell of its new position.
    fn update(&mut self, i: usize, x: &Vector3<f64>) {
        let c = self.cell_index(x);
        let old = self.cell_of[i];
        if c != old {
            let v = &mut self.members[old];
            let at = v
                .iter()
                .position(|&j| j == i)
                .expect("particle in its cell");
            v.swap_remove(at);
            self.members[c].push(i);
            self.cell_of[i] = c;
        }
    }

    /// Adds particle `cell_of.len()` (the next index) at x.
    pub(super) fn push(&mut self, x: &Vector3<f64>) {
        let c = self.cell_index(x);
        self.members[c].push(self.cell_of.len());
        self.cell_of.push(c);
    }

    /// Calls `f(j)` for every particle in the cells around the cell of `x` (each once).
    pub(super) fn for_each_near(&self, x: &Vector3<f64>, mut f: impl FnMut(usize)) {
        let c = self.coords(x);
        let mut range = [[0usize; 3]; 3];
        let mut count = [0usize; 3];
        for k in 0..3 {
            let m = self.dims[k];
            if m == 1 {
                range[k][0] = 0;
                count[k] = 1;
            } else if self.periodic[k] {
                range[k] = [(c[k] + m - 1) % m, c[k], (c[k] + 1) % m];
                count[k] = 3;
            } else {
                let lo = c[k].saturating_sub(1);
                let hi = (c[k] + 1).min(m - 1);
                for (n, v) in (lo..=hi).enumerate() {
                    range[k][n] = v;
                }
                count[k] = hi - lo + 1;
            }
        }
        for a in &range[0][..count[0]] {
            for b in &range[1][..count[1]] {
                for z in &range[2][..count[2]] {
                    let cell = (a * self.dims[1] + b) * self.dims[2] + z;
                    for &j in &self.members[cell] {
                        f(j);
                    }
                }
            }
        }
    }
}

/// A lower bound on the surface gap of particles i and j at centre separation `d` = x_j - x_i
/// (the list criterion; see the module docs).
pub(super) type ListGap<'a> = dyn Fn(&Packing, usize, usize, &Vector3<f64>) -> f64 + 'a;

/// The neighbour lists of all particles in one buffer: particle i's list, sorted, is
/// `data[start[i]..start[i] + len[i]]`, with room to grow to `cap[i]` in place. A pass over
/// the particles in index order (the relaxation's force loop) then reads the lists as one
/// stream instead of N heap blocks scattered by their growth, and building them costs no
/// allocation per particle. A list that outgrows its room moves to the end of the buffer;
/// the buffer is compacted when more than half of it is left behind by such moves.
#[derive(Debug, Clone, Default)]
pub(super) struct Lists {
    data: Vec<usize>,
    start: Vec<usize>,
    len: Vec<u32>,
    cap: Vec<u32>,
    /// Slots of `data` that no list holds any more (left behind by moved lists).
    unused: usize,
}

impl Lists {
    /// Free slots given to a list at a build or a move (GS rebuilds change a list by a few
    /// entries).
    fn room(len: usize) -> usize {
        len + len / 4 + 4
    }

    /// The lists of `n` particles holding both (i, j) and (j, i) for every given pair, sorted.
    fn from_pairs(n: usize, pairs: &[(u32, u32)]) -> Lists {
        let mut len = vec![0u32; n];
        for &(i, j) in pairs {
            len[i as usize] += 1;
            len[j as usize] += 1;
        }
        let cap: Vec<u32> = len
            .iter()
            .map(|&l| Lists::room(l as usize) as u32)
            .collect();
        let mut start = Vec::with_capacity(n);
        let mut total = 0usize;
        for &c in &cap {
            start.push(total);
            total += c as usize;
        }
        let mut lists = Lists {
            data: vec![0; total],
            start,
            len: vec![0; n],
            cap,
            unused: 0,
        };
        for &(i, j) in pairs {
            lists.push_unsorted(i as usize, j as usize);
            lists.push_unsorted(j as usize, i as usize);
        }
        for i in 0..n {
            lists.slice_mut(i).sort_unstable();
        }
        lists
    }

    fn push_unsorted(&mut self, i: usize, j: usize) {
        let at = self.start[i] + self.len[i] as usize;
        self.data[at] = j;
        self.len[i] += 1;
    }

    fn slice_mut(&mut self, i: usize) -> &mut [usize] {
        let s = self.start[i];
        &mut self.data[s..s + self.len[i] as usize]
    }

    /// Makes room for `need` entries in list i, moving it to the end of the buffer if needed.
    fn reserve(&mut self, i: usize, need: usize) {
        if need <= self.cap[i] as usize {
            return;
        }
        let (s, l) = (self.start[i], self.len[i] as usize);
        let cap = Lists::room(need);
        let at = self.data.len();
        self.data.resize(at + cap, 0);
        self.data.copy_within(s..s + l, at);
        self.unused += self.cap[i] as usize;
        self.start[i] = at;
        self.cap[i] = cap as u32;
        if 2 * self.unused > self.data.len() {
            self.compact();
        }
    }

    /// Rewrites the buffer in index order with fresh room after every list.
    fn compact(&mut self) {
        let mut data = Vec::with_capacity(self.data.len() - self.unused);
        for i in 0..self.start.len() {
            let (s, l) = (self.start[i], self.len[i] as usize);
            let cap = Lists::room(l);
            self.start[i] = data.len();
            self.cap[i] = cap as u32;
            data.extend_from_slice(&self.data[s..s + l]);
            data.resize(data.len() + cap - l, 0);
        }
        self.data = data;
        self.unused = 0;
    }

    /// Inserts j into the sorted list i (no effect when it is there).
    fn insert(&mut self, i: usize, j: usize) {
        if let Err(at) = self[i].binary_search(&j) {
            let l = self.len[i] as usize;
            self.reserve(i, l + 1);
            let s = self.start[i];
            self.data.copy_within(s + at..s + l, s + at + 1);
            self.data[s + at] = j;
            self.len[i] += 1;
        }
    }

    /// Removes j from the sorted list i (no effect when it is not there).
    fn remove(&mut self, i: usize, j: usize) {
        if let Ok(at) = self[i].binary_search(&j) {
            let (s, l) = (self.start[i], self.len[i] as usize);
            self.data.copy_within(s + at + 1..s + l, s + at);
            self.len[i] -= 1;
        }
    }

    /// Replaces list i by `fresh` (sorted).
    fn set(&mut self, i: usize, fresh: &[usize]) {
        self.len[i] = 0;
        self.reserve(i, fresh.len());
        let s = self.start[i];
        self.data[s..s + fresh.len()].copy_from_slice(fresh);
        self.len[i] = fresh.len() as u32;
    }
}

impl std::ops::Index<usize> for Lists {
    type Output = [usize];
    fn index(&self, i: usize) -> &[usize] {
        let s = self.start[i];
        &self.data[s..s + self.len[i] as usize]
    }
}

/// Per-particle Verlet lists with per-particle references (see the module docs).
#[derive(Debug, Clone)]
pub(super) struct Neighbours {
    /// Neighbour list of each particle (`lists[i]`, sorted): every j whose gap bound was below
    /// the skin at the later of the two particles' last rebuilds.
    pub lists: Lists,
    /// Centre-distance cutoff of the grid search (largest pair cutoff plus skin).
    list_cutoff: f64,
    skin: f64,
    grid: Grid,
    ref_x: Vec<Vector3<f64>>,
    ref_a: Vec<Vector3<f64>>,
    /// Half axis length L/2 of each particle (0 for spheres and bounding spheres).
    half: Vec<f64>,
    /// Rebuilds of single lists since construction (for tests and profiling).
    pub rebuilds: u64,
    /// Scratch list of a rebuild (no allocation per rebuild).
    scratch: Vec<usize>,
}

impl Neighbours {
    /// Lists for the largest centre-distance pair cutoff `cutoff`, the skin `skin` (both
    /// positive), the half axis lengths `half` and the gap bound `gap`.
    pub fn new(
        p: &Packing,
        cutoff: f64,
        skin: f64,
        half: Vec<f64>,
        gap: &ListGap,
    ) -> Result<Neighbours> {
        if !(skin > 0.0 && cutoff > 0.0 && (cutoff + skin) <= 0.5 * p.box_length) {
            return invalid(format!(
                "neighbour lists: cutoff {cutoff} + skin {skin} must be positive and at most \
                 half the periodic length {}",
                p.box_length
            ));
        }
        let list_cutoff = cutoff + skin;
        // Cells of edge >= list_cutoff + skin/4: the grid holds reference positions (module
        // docs).
        let grid = Grid::new(
            &p.container,
            p.box_length,
            list_cutoff + 0.25 * skin,
            &p.positions,
        );
        if u32::try_from(p.n()).is_err() {
            return invalid(format!(
                "neighbour lists: {} particles (at most 2^32)",
                p.n()
            ));
        }
        let mut nb = Neighbours {
            lists: Lists::default(),
            list_cutoff,
            skin,
            grid,
            ref_x: p.positions.clone(),
            ref_a: p.axes(),
            half,
            rebuilds: 0,
            scratch: Vec::new(),
        };
        let mut pairs = Vec::new();
        for i in 0..p.n() {
            let xi = p.positions[i];
            nb.grid.for_each_near(&xi, |j| {
                if j > i && nb.listed(p, i, j, gap) {
                    pairs.push((i as u32, j as u32));
                }
            });
        }
        nb.lists = Lists::from_pairs(p.n(), &pairs);
        Ok(nb)
    }

    /// True when the pair (i, j) belongs in the lists now: centres within the grid cutoff and
    /// the gap bound below the skin (plus the 1e-6 margin of the pair cutoffs).
    #[inline(always)]
    fn listed(&self, p: &Packing, i: usize, j: usize, gap: &ListGap) -> bool {
        let d = p
            .container
            .separation(&p.positions[i], &p.positions[j], p.box_length);
        d.norm_squared() < self.list_cutoff * self.list_cutoff
            && gap(p, i, j, &d) < self.skin + 1e-6
    }

    /// To be called after particle i moved: when it has drifted more than skin/4 from its
    /// reference, moves its reference (and its grid cell) to where it is and rebuilds its list.
    /// The drift test is inlined into the callers' loops (a relaxation calls this for every
    /// particle of every iteration, and nearly always returns here); the rebuild is not.
    #[inline(always)]
    pub fn moved(&mut self, p: &Packing, i: usize, gap: &ListGap) {
        let xi = p.positions[i];
        let shift = p.container.separation(&self.ref_x[i], &xi, p.box_length);
        let drift = 0.25 * self.skin;
        let ai = if self.half[i] > 0.0 {
            let ai = p.axis(i);
            if shift.norm() + self.half[i] * (ai - self.ref_a[i]).norm() <= drift {
                return;
            }
            ai
        } else {
            // Spheres: the squared distance, without the square root's latency (14% of the
            // relaxation's update loop at N = 10000, `perf annotate`). The roundings differ
            // from |shift| <= drift by about 1e-16 relative, far inside the 1e-6 margin of the
            // list criterion, so the lists stay complete; which lists also hold pairs apart
            // changes no force and no move.
            if shift.norm_squared() <= drift * drift {
                return;
            }
            self.ref_a[i]
        };
        self.rebuild(p, i, xi, ai, gap);
    }

    /// Rebuilds the list of particle i, now at `xi` with axis `ai` (see [`Neighbours::moved`]).
    #[inline(never)]
    fn rebuild(
        &mut self,
        p: &Packing,
        i: usize,
        xi: Vector3<f64>,
        ai: Vector3<f64>,
        gap: &ListGap,
    ) {
        self.rebuilds += 1;
        let mut list = std::mem::take(&mut self.scratch);
        list.clear();
        list.extend_from_slice(&self.lists[i]);
        for &j in &list {
            self.lists.remove(j, i);
        }
        list.clear();
        self.grid.update(i, &xi);
        self.grid.for_each_near(&xi, |j| {
            if j != i && self.listed(p, i, j, gap) {
                list.push(j);
            }
        });
        list.sort_unstable();
        for &j in &list {
            self.lists.insert(j, i);
        }
        self.lists.set(i, &list);
        self.scratch = list;
        self.ref_x[i] = xi;
        self.ref_a[i] = ai;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::closest_points_segments;
    use crate::packing::random_start_in;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// The one-buffer lists against a vector per list under random inserts, removals and
    /// replacements (lists that outgrow their room, compactions): the same sorted lists.
    #[test]
    fn one_buffer_lists_match_a_vector_per_list() {
        let n = 50;
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        let mut model: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut pairs = Vec::new();
        for _ in 0..200 {
            let (i, j) = (rng.gen_range(0..n), rng.gen_range(0..n));
            if i < j && !model[i].contains(&j) {
                pairs.push((i as u32, j as u32));
                model[i].push(j);
                model[j].push(i);
            }
        }
        model.iter_mut().for_each(|v| v.sort_unstable());
        let mut lists = Lists::from_pairs(n, &pairs);
        let (mut moved, mut compactions) = (0, 0);
        for _ in 0..20_000 {
            let (i, j) = (rng.gen_range(0..n), rng.gen_range(0..n));
            let (start, unused) = (lists.start[i], lists.unused);
            match rng.gen_range(0..10) {
                0..=4 => {
                    lists.insert(i, j);
                    if let Err(at) = model[i].binary_search(&j) {
                        model[i].insert(at, j);
                    }
                }
                5..=8 => {
                    lists.remove(i, j);
                    model[i].retain(|&k| k != j);
                }
                _ => {
                    let mut fresh: Vec<usize> = (0..rng.gen_range(0..3 * n))
                        .map(|_| rng.gen_range(0..n))
                        .collect();
                    fresh.sort_unstable();
                    fresh.dedup();
                    lists.set(i, &fresh);
                    model[i] = fresh;
                }
            }
            moved += (lists.start[i] != start) as u32;
            compactions += (lists.unused < unused) as u32;
            assert_eq!(&lists[i], &model[i][..]);
        }
        // Lists that keep growing leave their old room behind until the buffer is compacted.
        for round in 0..300 {
            let i = round % n;
            let (unused, room) = (lists.unused, lists.cap[i] as usize);
            let grown: Vec<usize> = (0..room + 1).collect();
            lists.set(i, &grown);
            model[i] = grown;
            compactions += (lists.unused < unused) as u32;
        }
        for (i, v) in model.iter().enumerate() {
            assert_eq!(&lists[i], &v[..], "list {i}");
        }
        assert!(
            moved > 50 && compactions > 2,
            "{moved} moves, {compactions} compactions"
        );
    }

    /// The grid holds reference positions and follows a particle only at its rebuilds; a
    /// search around any particle must still find every particle within the list cutoff of
    /// it (what the rebuilt lists rely on). The box is 8 list cutoffs (plus 1e-9) wide, so a
    /// grid of cells one list cutoff wide (no skin/4 margin) misses pairs here.
    #[test]
    fn lazy_grid_finds_every_particle_within_the_list_cutoff() {
        let (cutoff, skin) = (1.0, 1.0);
        let mut p = random_start_in(Container::Periodic, 600, 0.0, 0.1, 5).unwrap();
        let wide = 8.0 * (cutoff + skin) + 1e-9;
        let scale = wide / p.box_length;
        for x in p.positions.iter_mut() {
            *x *= scale;
        }
        p.box_length = wide;
        let gap = |_: &Packing, _: usize, _: usize, d: &Vector3<f64>| d.norm() - 1.0;
        let mut nb = Neighbours::new(&p, cutoff, skin, vec![0.0; p.n()], &gap).unwrap();
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let mut checked = 0usize;
        for step in 0..20_000 {
            let i = rng.gen_range(0..p.n());
            let shift = Vector3::new(rng.gen(), rng.gen(), rng.gen()).map(|u: f64| u - 0.5);
            p.positions[i] = p
                .container
                .wrap(&(p.positions[i] + 0.2 * shift), p.box_length);
            nb.moved(&p, i, &gap);
            if step % 200 != 199 {
                continue;
            }
            for a in 0..p.n() {
                let mut found = vec![false; p.n()];
                nb.grid.for_each_near(&p.positions[a], |j| found[j] = true);
                for (b, &hit) in found.iter().enumerate() {
                    let d = p
                        .container
                        .separation(&p.positions[a], &p.positions[b], p.box_length);
                    if b != a && d.norm() < cutoff + skin {
                        checked += 1;
                        assert!(hit, "step {step}: {b} at {} from {a} not found", d.norm());
                    }
                }
            }
        }
        assert!(
            nb.rebuilds > 1000 && checked > 1000,
            "{} {checked}",
            nb.rebuilds
        );
    }

    /// After many random moves (shifts and rotations), every pair whose rods touch or overlap
    /// is listed both ways (brute force over all pairs), in the box, the cylinder and the
    /// wedge, for spheres and rods.
    #[test]
    fn lists_stay_complete_under_random_moves() {
        for (container, length) in [
            (Container::Periodic, 0.0),
            (Container::Periodic, 1.5),
            (Container::Periodic, 6.0),
            (Container::Cylinder { diameter: 6.0 }, 0.0),
            (Container::Cylinder { diameter: 5.0 }, 1.0),
            (
                Container::Wedge {
                    length: 12.0,
                    angle_rad: 30f64.to_radians(),
                },
                0.0,
            ),
        ] {
            let n = if length > 3.0 { 400 } else { 300 };
            let mut p = random_start_in(container, n, length, 0.1, 3).unwrap();
            let cutoff = length + 1.0;
            let h = 0.5 * length;
            // Surface gap of two rods of radius 1/2: segment distance minus 1.
            let gap = |p: &Packing, i: usize, j: usize, d: &Vector3<f64>| {
                let (ai, aj) = (p.axis(i), p.axis(j));
                let (_, _, a, b) =
                    closest_points_segments(&(-h * ai), &(h * ai), &(d - h * aj), &(d + h * aj));
                (b - a).norm() - 1.0
            };
            let mut nb = Neighbours::new(&p, cutoff, 0.3, vec![h; p.n()], &gap).unwrap();
            let mut rng = ChaCha8Rng::seed_from_u64(9);
            for _ in 0..20_000 {
                let i = rng.gen_range(0..p.n());
                let step = Vector3::new(rng.gen(), rng.gen(), rng.gen()).map(|u: f64| u - 0.5);
                let x = p.positions[i] + 0.05 * step;
                // Wedge: moves may leave it (the grid's edge cells take such centres).
                let x = match container {
                    Container::Periodic | Container::Wedge { .. } => x,
                    Container::Cylinder { diameter } => {
                        let rho = (x.x * x.x + x.y * x.y).sqrt();
                        let s = (0.5 * diameter / rho).min(1.0);
                        Vector3::new(x.x * s, x.y * s, x.z)
                    }
                };
                p.positions[i] = p.container.wrap(&x, p.box_length);
                if length > 0.0 {
                    let rot = nalgebra::UnitQuaternion::from_scaled_axis(0.05 * step);
                    p.orientations[i] = rot * p.orientations[i];
                }
                nb.moved(&p, i, &gap);
            }
            assert!(nb.rebuilds > 100, "rebuilds {}", nb.rebuilds);
            for i in 0..p.n() {
                for j in 0..p.n() {
                    if i == j {
                        continue;
                    }
                    let d = p
                        .container
                        .separation(&p.positions[i], &p.positions[j], p.box_length);
                    if gap(&p, i, j, &d) <= 0.0 {
                        assert!(
                            nb.lists[i].binary_search(&j).is_ok(),
                            "{container:?} L={length}: pair ({i}, {j}) at {} missing",
                            d.norm()
                        );
                    }
                }
            }
        }
    }
}
