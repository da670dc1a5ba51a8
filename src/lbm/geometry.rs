//! The lattice's extent, its solid mask and what the kernel derives from it: the runs of
//! fluid cells along x in every row (the kernel collides only those, so solid cells cost
//! nothing and no cell asks "am I solid?") and the halfway bounce-back links, i.e. the
//! (fluid cell, direction q) whose upstream neighbour x - c_q is solid.

use super::lattice::{opposite, Lattice};
use super::memory::Layout;
use super::walls::{cli_kappa, WallFractions};
use crate::error::{invalid, Result};

pub use super::dims::Dims;

/// One bounce-back link: population q of fluid cell x (in its row) comes back from its own
/// opposite, plus `delta` = 6 w_q rho_0 c_q . u_wall for a moving wall (Ladd 1994); on a
/// curved wall (CLI, [`super::walls`]) plus `kappa` [f*_opp(q)(x + c_q) - f*_q(x)], the first
/// read at `far` in the population array. kappa = 0: halfway bounce-back.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    pub x: u32,
    pub q: u8,
    pub delta: f64,
    pub kappa: f64,
    pub far: usize,
}

impl Link {
    /// The population this link gives its cell, read from the post-collision array `src`
    /// whose row (y, z) starts at `row` (population 0) with populations `q_stride` apart.
    #[inline(always)]
    pub fn value(&self, src: &[f64], row: usize, q_stride: usize) -> f64 {
        let (x, q) = (self.x as usize, self.q as usize);
        let v = src[row + opposite(q) * q_stride + x] + self.delta;
        if self.kappa == 0.0 {
            v
        } else {
            v + self.kappa * (src[self.far] - src[row + q * q_stride + x])
        }
    }
}

/// Solid mask with its fluid runs and bounce-back links for lattice `L`.
#[derive(Debug, Clone)]
pub struct Geometry {
    pub dims: Dims,
    solid: Vec<bool>,
    /// Row r = z * ny + y holds runs run_start[r]..run_start[r + 1] of `runs`: [x0, x1).
    run_start: Vec<u32>,
    runs: Vec<(u32, u32)>,
    link_start: Vec<u32>,
    links: Vec<Link>,
    fluid_cells: usize,
    /// Links and interpolated links, counted where they were built (kept by
    /// [`Geometry::forget_links`]).
    link_count: usize,
    interpolated: usize,
}

impl Geometry {
    /// All fluid, fully periodic.
    pub fn open<L: Lattice>(dims: Dims) -> Geometry {
        Geometry::new::<L>(dims, vec![false; dims.cells()], |_| [0.0; 3]).expect("mask length")
    }

    /// From a solid mask (one bool per cell, index `Dims::cell`); `wall_velocity(cell)` is the
    /// velocity of a solid cell (lattice units; zero for resting walls).
    pub fn new<L: Lattice>(
        dims: Dims,
        solid: Vec<bool>,
        wall_velocity: impl Fn(usize) -> [f64; 3],
    ) -> Result<Geometry> {
        Geometry::with_walls::<L>(dims, solid, wall_velocity, None)
    }

    /// [`Geometry::new`] with curved walls where `fractions` is given: each link whose wall
    /// fraction is known and whose second node x + c_q is fluid interpolates (CLI,
    /// [`super::walls`]); the others stay halfway bounce-back.
    pub fn with_walls<L: Lattice>(
        dims: Dims,
        solid: Vec<bool>,
        wall_velocity: impl Fn(usize) -> [f64; 3],
        fractions: Option<&WallFractions>,
    ) -> Result<Geometry> {
        if solid.len() != dims.cells() {
            return invalid(format!(
                "solid mask has {} cells, the lattice {}",
                solid.len(),
                dims.cells()
            ));
        }
        let rows = dims.ny * dims.nz;
        let layout = Layout::new(&dims, L::Q);
        let mut run_start = Vec::with_capacity(rows + 1);
        let mut runs = Vec::new();
        let mut link_start = Vec::with_capacity(rows + 1);
        let mut links = Vec::new();
        let mut fluid_cells = 0;
        for z in 0..dims.nz {
            for y in 0..dims.ny {
                run_start.push(runs.len() as u32);
                link_start.push(links.len() as u32);
                let mut x = 0;
                while x < dims.nx {
                    if solid[dims.cell(x, y, z)] {
                        x += 1;
                        continue;
                    }
                    let x0 = x;
                    while x < dims.nx && !solid[dims.cell(x, y, z)] {
                        x += 1;
                    }
                    runs.push((x0 as u32, x as u32));
                    fluid_cells += x - x0;
                }
                for x in 0..dims.nx {
                    if solid[dims.cell(x, y, z)] {
                        continue;
                    }
                    for q in 1..L::Q {
                        let c = L::C[q];
                        let up = dims.shifted([x, y, z], [-c[0], -c[1], -c[2]]);
                        let up_cell = dims.cell(up[0], up[1], up[2]);
                        if solid[up_cell] {
                            let uw = wall_velocity(up_cell);
                            let cu =
                                c[0] as f64 * uw[0] + c[1] as f64 * uw[1] + c[2] as f64 * uw[2];
                            let cell = dims.cell(x, y, z);
                            let second = dims.shifted([x, y, z], c);
                            let (mut kappa, mut far) = (0.0, 0);
                            if let Some(wq) = fractions
                                .and_then(|f| f.get(cell, [-c[0], -c[1], -c[2]]))
                                .filter(|_| !solid[dims.cell(second[0], second[1], second[2])])
                            {
                                kappa = cli_kappa(wq);
                                far = layout.index(second[2], opposite(q), second[1], second[0]);
                            }
                            links.push(Link {
                                x: x as u32,
                                q: q as u8,
                                delta: 6.0 * L::W[q] * cu,
                                kappa,
                                far,
                            });
                        }
                    }
                }
            }
        }
        run_start.push(runs.len() as u32);
        link_start.push(links.len() as u32);
        Ok(Geometry {
            dims,
            solid,
            run_start,
            runs,
            link_start,
            fluid_cells,
            link_count: links.len(),
            interpolated: links.iter().filter(|l| l.kappa != 0.0).count(),
            links,
        })
    }

    /// Frees the links (32 bytes each, about five per fluid node of a packing) for a kernel
    /// that has resolved them into its own tables ([`super::fluid`]): [`Geometry::links`] is
    /// then empty for every row; the counts stay.
    pub fn forget_links(&mut self) {
        self.links = Vec::new();
        self.link_start.iter_mut().for_each(|s| *s = 0);
    }

    pub fn is_solid(&self, cell: usize) -> bool {
        self.solid[cell]
    }
    pub fn solid_mask(&self) -> &[bool] {
        &self.solid
    }
    pub fn fluid_cells(&self) -> usize {
        self.fluid_cells
    }
    /// Fluid runs [x0, x1) of row r = z * ny + y.
    #[inline(always)]
    pub fn runs(&self, row: usize) -> &[(u32, u32)] {
        &self.runs[self.run_start[row] as usize..self.run_start[row + 1] as usize]
    }
    /// Bounce-back links of row r.
    #[inline(always)]
    pub fn links(&self, row: usize) -> &[Link] {
        &self.links[self.link_start[row] as usize..self.link_start[row + 1] as usize]
    }
    /// Bytes of the mask, the runs and the links.
    pub fn bytes(&self) -> usize {
        self.solid.len()
            + 4 * (self.run_start.len() + self.link_start.len())
            + std::mem::size_of::<(u32, u32)>() * self.runs.len()
            + std::mem::size_of::<Link>() * self.links.len()
    }
    pub fn link_count(&self) -> usize {
        self.link_count
    }
    /// Links that interpolate (CLI) rather than bounce back halfway.
    pub fn interpolated_links(&self) -> usize {
        self.interpolated
    }
    /// Whether a fluid cluster joined along the links of lattice `L` wraps round the periodic
    /// box along `axis` ([`percolates`]).
    pub fn percolates<L: Lattice>(&self, axis: usize) -> bool {
        percolates(self.dims, &self.solid, L::C, axis)
    }

    /// The opposite of link direction q (re-exported for the kernel).
    #[inline(always)]
    pub fn opp(q: usize) -> usize {
        opposite(q)
    }
}

/// Whether a fluid cluster of the mask `solid` on `d`, joined along the lattice velocities
/// `c`, wraps round the periodic box along `axis`: a path of fluid cells from a cell to one
/// of its own images one period away. Without one, a body force along `axis` drives no steady
/// flow (permeability 0), however much fluid the mask holds. Each cluster is searched once,
/// its cells labelled with their unwrapped coordinate along `axis`; reaching a labelled cell
/// with another coordinate closes a wrapping path.
pub fn percolates(d: Dims, solid: &[bool], c: &[[i32; 3]], axis: usize) -> bool {
    const UNSEEN: i32 = i32::MIN;
    let mut unwrapped = vec![UNSEEN; d.cells()];
    let mut stack = Vec::new();
    for start in 0..d.cells() {
        if solid[start] || unwrapped[start] != UNSEEN {
            continue;
        }
        unwrapped[start] = d.coords(start)[axis] as i32;
        stack.push(start);
        while let Some(cell) = stack.pop() {
            let p = d.coords(cell);
            let here = unwrapped[cell];
            for cq in c.iter().skip(1) {
                let n = d.shifted(p, *cq);
                let nc = d.cell(n[0], n[1], n[2]);
                if solid[nc] {
                    continue;
                }
                let there = here + cq[axis];
                if unwrapped[nc] == UNSEEN {
                    unwrapped[nc] = there;
                    stack.push(nc);
                } else if unwrapped[nc] != there {
                    return true;
                }
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lbm::{D3Q15, D3Q19};

    /// Open boxes and tubes wrap; a solid plane across x blocks x only; a closed spherical
    /// shell's inside and outside are pockets that do not wrap; the same shell with a hole
    /// joined to a tube along x wraps again.
    #[test]
    fn percolation_along_an_axis() {
        let d = Dims::new(8, 6, 5).unwrap();
        let open = Geometry::open::<D3Q19>(d);
        assert!((0..3).all(|a| open.percolates::<D3Q19>(a)));
        let wall = |x: usize| {
            (0..d.cells())
                .map(|c| d.coords(c)[0] == x)
                .collect::<Vec<_>>()
        };
        let g = Geometry::new::<D3Q15>(d, wall(3), |_| [0.0; 3]).unwrap();
        assert!(!g.percolates::<D3Q15>(0));
        assert!(g.percolates::<D3Q15>(1) && g.percolates::<D3Q15>(2));
        // a 1-cell-long box along x wraps onto itself
        let thin = Dims::new(1, 4, 4).unwrap();
        assert!(Geometry::open::<D3Q19>(thin).percolates::<D3Q19>(0));
        // solid everywhere except an enclosed cavity (a pocket) and its own wrapped images
        let n = 9;
        let d = Dims::new(n, n, n).unwrap();
        let pocket: Vec<bool> = (0..d.cells())
            .map(|c| {
                let p = d.coords(c);
                !(p.iter().all(|&v| (3..=5).contains(&v)))
            })
            .collect();
        let g = Geometry::new::<D3Q19>(d, pocket.clone(), |_| [0.0; 3]).unwrap();
        assert!(g.fluid_cells() == 27 && !(0..3).any(|a| g.percolates::<D3Q19>(a)));
        // a tube along x through the pocket
        let mut tube = pocket;
        for x in 0..n {
            tube[d.cell(x, 4, 4)] = false;
        }
        let g = Geometry::new::<D3Q19>(d, tube, |_| [0.0; 3]).unwrap();
        assert!(g.percolates::<D3Q19>(0) && !g.percolates::<D3Q19>(1));
    }
}
