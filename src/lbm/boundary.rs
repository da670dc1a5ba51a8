//! Velocity and density (pressure) boundaries by non-equilibrium extrapolation (Guo, Zheng &
//! Shi, Chin. Phys. 11, 366, 2002; the same construction as their Phys. Fluids 14, 2007, 2002,
//! seed 002 ref. 12, for a wall on the lattice nodes).
//!
//! A boundary is a plane of lattice nodes (x, y or z = 0 or n - 1) whose populations are not
//! streamed but rebuilt every step: with x_1 and x_2 the first and second nodes inside along
//! the inward normal,
//!
//! f_q(x_b) = f_q^eq(rho_b, u_b) + [f_q(x_1) - f_q^eq(rho(x_1), u(x_1))]
//!
//! (the non-equilibrium part is taken from x_1), then the node collides like any fluid node.
//! A velocity boundary prescribes u_b and takes rho_b = rho(x_1); a density boundary
//! prescribes rho_b (pressure p = c_s^2 rho_b) and extrapolates u_b = 2 u(x_1) - u(x_2).
//!
//! The planes are a separate piece: the fused kernel streams and collides every fluid node as
//! usual (the boundary nodes too, at the cost of a wasted collision, so the kernel has no
//! branch per cell), and [`Boundaries::apply`] then overwrites the boundary nodes' post-collision
//! populations from the previous step's array, which the kernel only read.

use super::collision::{equilibrium, relax_cell, Collision};
use super::forcing::Forcing;
use super::geometry::{Dims, Geometry};
use super::lattice::{density_momentum, Lattice};
use super::memory::Layout;
use crate::error::{invalid, Result};

/// A face of the box: the plane `axis` = 0 (`high = false`) or `axis` = n - 1 (`high = true`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Face {
    /// 0, 1, 2 for x, y, z.
    pub axis: usize,
    pub high: bool,
}

impl Face {
    /// Parses "x-", "x+", "y-", ... (the low or high plane of an axis); `key` names the input.
    pub fn parse(s: &str, key: &str) -> Result<Face> {
        let b = s.as_bytes();
        let axis = match b.first() {
            Some(b'x') => 0,
            Some(b'y') => 1,
            Some(b'z') => 2,
            _ => 3,
        };
        let high = match b.get(1) {
            Some(b'-') => Some(false),
            Some(b'+') => Some(true),
            _ => None,
        };
        match (axis, high, b.len()) {
            (a, Some(h), 2) if a < 3 => Ok(Face { axis: a, high: h }),
            _ => invalid(format!(
                "{key} = \"{s}\": must be a face \"x-\", \"x+\", \"y-\", \"y+\", \"z-\" or \"z+\""
            )),
        }
    }

    fn extent(&self, d: &Dims) -> usize {
        [d.nx, d.ny, d.nz][self.axis]
    }

    /// The node `steps` cells inside from the plane node `p` (along the inward normal).
    fn inward(&self, p: [usize; 3], steps: usize) -> [usize; 3] {
        let mut q = p;
        q[self.axis] = if self.high {
            p[self.axis] - steps
        } else {
            p[self.axis] + steps
        };
        q
    }

    /// Cells of the face (solid ones included).
    pub fn cells_in(&self, d: &Dims) -> usize {
        d.cells() / self.extent(d)
    }

    /// The index of cell `p` of the face among the face's cells in the order of the cell
    /// index: the two other coordinates, the slower one (larger axis) first.
    pub fn index_of(&self, d: &Dims, p: [usize; 3]) -> usize {
        let n = [d.nx, d.ny, d.nz];
        let (lo, hi) = match self.axis {
            0 => (1, 2),
            1 => (0, 2),
            _ => (0, 1),
        };
        p[hi] * n[lo] + p[lo]
    }

    /// "x-", "x+", "y-", ...
    pub fn name(&self) -> String {
        format!(
            "{}{}",
            ["x", "y", "z"][self.axis],
            if self.high { "+" } else { "-" }
        )
    }
}

/// What a plane prescribes.
#[derive(Debug, Clone, PartialEq)]
pub enum Condition {
    /// Velocity of each node of the plane, in the order of [`Plane::nodes`] (lattice units).
    Velocity(Vec<[f64; 3]>),
    /// Density (lattice units; pressure c_s^2 rho), uniform over the plane.
    Density(f64),
}

/// One node of a boundary plane: its cell and the two cells inside along the normal.
#[derive(Debug, Clone, Copy)]
struct Node {
    cell: usize,
    inner1: [usize; 3],
    inner2: [usize; 3],
}

/// A plane of boundary nodes with its condition.
#[derive(Debug, Clone)]
pub struct Plane {
    face: Face,
    condition: Condition,
    nodes: Vec<Node>,
    /// (rho_b, u_b) each node was rebuilt with in the last step (lattice units).
    last: Vec<(f64, [f64; 3])>,
}

impl Plane {
    /// The plane of `face` over the fluid cells of `geom`; `velocity(x, y, z)` gives the
    /// prescribed velocity of a velocity plane. Refuses a plane without fluid nodes, a box
    /// less than 3 cells deep along the normal, and a node whose two inner neighbours are not
    /// fluid.
    fn build(
        geom: &Geometry,
        face: Face,
        velocity: Option<&dyn Fn([usize; 3]) -> [f64; 3]>,
        rho: f64,
    ) -> Result<Plane> {
        let d = geom.dims;
        let depth = face.extent(&d);
        if depth < 3 {
            return invalid(format!(
                "boundary plane {}: the lattice is {depth} cells deep along the normal, it must \
                 be at least 3 (the extrapolation reads two nodes inside)",
                face.name()
            ));
        }
        let fixed = if face.high { depth - 1 } else { 0 };
        let mut nodes = Vec::new();
        let mut vel = Vec::new();
        for cell in 0..d.cells() {
            let p = d.coords(cell);
            if p[face.axis] != fixed || geom.is_solid(cell) {
                continue;
            }
            let (inner1, inner2) = (face.inward(p, 1), face.inward(p, 2));
            for q in [inner1, inner2] {
                if geom.is_solid(d.cell(q[0], q[1], q[2])) {
                    return invalid(format!(
                        "boundary plane {}: node {p:?} has the solid cell {q:?} inside along \
                         the normal; a boundary node needs two fluid nodes behind it",
                        face.name()
                    ));
                }
            }
            if let Some(v) = velocity {
                let u = v(p);
                if !u.iter().all(|c| c.is_finite()) {
                    return invalid(format!(
                        "boundary plane {}: velocity {u:?} at node {p:?} must be finite",
                        face.name()
                    ));
                }
                vel.push(u);
            }
            nodes.push(Node {
                cell,
                inner1,
                inner2,
            });
        }
        if nodes.is_empty() {
            return invalid(format!(
                "boundary plane {}: the plane has no fluid node (it lies in the solid)",
                face.name()
            ));
        }
        let condition = match velocity {
            Some(_) => Condition::Velocity(vel),
            None => Condition::Density(rho),
        };
        let last = vec![(1.0, [0.0; 3]); nodes.len()];
        Ok(Plane {
            face,
            condition,
            nodes,
            last,
        })
    }

    /// A velocity plane: `velocity([x, y, z])` in lattice units at each fluid node of `face`.
    pub fn velocity(
        geom: &Geometry,
        face: Face,
        velocity: impl Fn([usize; 3]) -> [f64; 3],
    ) -> Result<Plane> {
        Plane::build(geom, face, Some(&velocity), 1.0)
    }

    /// A density (pressure) plane with density `rho` (lattice units, > 0).
    pub fn density(geom: &Geometry, face: Face, rho: f64) -> Result<Plane> {
        if !(rho.is_finite() && rho > 0.0) {
            return invalid(format!(
                "boundary plane {}: density {rho} (lattice units) must be positive and finite",
                face.name()
            ));
        }
        Plane::build(geom, face, None, rho)
    }

    pub fn face(&self) -> Face {
        self.face
    }

    pub fn condition(&self) -> &Condition {
        &self.condition
    }

    /// The cells of the plane's nodes.
    pub fn cells(&self) -> impl Iterator<Item = usize> + '_ {
        self.nodes.iter().map(|n| n.cell)
    }
}

/// The boundary planes of one solver.
#[derive(Debug, Clone, Default)]
pub struct Boundaries {
    planes: Vec<Plane>,
}

/// A node's density and the forcing's state from its pulled populations.
struct Pulled<L: Lattice> {
    pop: L::Pop,
    rho: f64,
    u: [f64; 3],
    inv_eps: f64,
}

impl Boundaries {
    /// Refuses two planes on the same face or sharing a node.
    pub fn new(planes: Vec<Plane>) -> Result<Boundaries> {
        let mut seen = std::collections::HashSet::new();
        for p in &planes {
            for c in p.cells() {
                if !seen.insert(c) {
                    return invalid(format!(
                        "boundary plane {}: cell {c} already belongs to another boundary plane \
                         (planes on adjacent faces must not share an edge of fluid nodes)",
                        p.face.name()
                    ));
                }
            }
        }
        Ok(Boundaries { planes })
    }

    pub fn is_empty(&self) -> bool {
        self.planes.is_empty()
    }

    pub fn planes(&self) -> &[Plane] {
        &self.planes
    }

    /// Every boundary cell with the (rho_b, u_b) it was last rebuilt with.
    pub fn last_states(&self) -> impl Iterator<Item = (usize, (f64, [f64; 3]))> + '_ {
        self.planes
            .iter()
            .flat_map(|p| p.nodes.iter().map(|n| n.cell).zip(p.last.iter().copied()))
    }

    /// The populations arriving at `p` from `src` (post-collision, layout of the solver), with
    /// the bounce-back links of `geom`: what the kernel pulled for that node.
    fn pull_cell<L: Lattice>(
        src: &[f64],
        layout: &Layout,
        geom: &Geometry,
        p: [usize; 3],
    ) -> L::Pop {
        let d = geom.dims;
        let idx = |c: [usize; 3], q: usize| layout.index(c[2], q, c[1], c[0]);
        let mut pop = L::Pop::default();
        for (q, v) in pop.as_mut().iter_mut().enumerate() {
            let c = L::C[q];
            *v = src[idx(d.shifted(p, [-c[0], -c[1], -c[2]]), q)];
        }
        let row = layout.index(p[2], 0, p[1], 0);
        for l in geom.links(p[2] * d.ny + p[1]) {
            if l.x as usize == p[0] {
                pop.as_mut()[l.q as usize] = l.value(src, row, layout.q_stride);
            }
        }
        pop
    }

    fn pulled<L: Lattice, F: Forcing>(
        src: &[f64],
        layout: &Layout,
        geom: &Geometry,
        force: &F,
        p: [usize; 3],
    ) -> Pulled<L> {
        let pop = Self::pull_cell::<L>(src, layout, geom, p);
        let (rho, j) = density_momentum::<L>(&pop);
        let s = force.state(geom.dims.cell(p[0], p[1], p[2]), rho, j);
        Pulled {
            pop,
            rho,
            u: s.u,
            inv_eps: s.inv_eps,
        }
    }

    /// Rebuilds the post-collision populations of every boundary node in `dst` from the
    /// populations `src` of the previous step (Guo, Zheng & Shi 2002: equilibrium at the
    /// boundary state plus the non-equilibrium part of the first inner node, then the
    /// collision of the node with the forcing's state at the prescribed velocity).
    pub fn apply<L: Lattice, C: Collision, F: Forcing>(
        &mut self,
        src: &[f64],
        dst: &mut [f64],
        layout: &Layout,
        geom: &Geometry,
        coll: &C,
        force: &F,
    ) {
        let d = geom.dims;
        let mut pre = vec![0.0; L::Q];
        let mut out = vec![0.0; L::Q];
        for plane in &mut self.planes {
            for (k, node) in plane.nodes.iter().enumerate() {
                let one = Self::pulled::<L, F>(src, layout, geom, force, node.inner1);
                let (rho_b, u_b) = match &plane.condition {
                    Condition::Velocity(v) => (one.rho, v[k]),
                    Condition::Density(rho) => {
                        let two = Self::pulled::<L, F>(src, layout, geom, force, node.inner2);
                        let u = [0, 1, 2].map(|a| 2.0 * one.u[a] - two.u[a]);
                        (*rho, u)
                    }
                };
                plane.last[k] = (rho_b, u_b);
                let s = force.state_at_velocity(node.cell, rho_b, u_b);
                let feq_b = equilibrium::<L>(rho_b, u_b, s.inv_eps);
                let feq_1 = equilibrium::<L>(one.rho, one.u, one.inv_eps);
                for q in 0..L::Q {
                    pre[q] = feq_b.as_ref()[q] + one.pop.as_ref()[q] - feq_1.as_ref()[q];
                }
                relax_cell::<L, C, F>(coll, rho_b, &s, &pre, &mut out);
                let p = d.coords(node.cell);
                for (q, v) in out.iter().enumerate() {
                    dst[layout.index(p[2], q, p[1], p[0])] = *v;
                }
            }
        }
    }
}

/// Whether some fluid node of plane `a` is joined to some fluid node of plane `b` through
/// fluid nodes along the lattice's links, not wrapping across the planes' axes (a mask with no such path carries no flow between
/// them: its permeability is 0).
pub fn connected<L: Lattice>(geom: &Geometry, a: &Plane, b: &Plane) -> bool {
    let d = geom.dims;
    let target: std::collections::HashSet<usize> = b.cells().collect();
    let mut seen = vec![false; d.cells()];
    let mut stack: Vec<usize> = a.cells().collect();
    for &c in &stack {
        seen[c] = true;
    }
    while let Some(c) = stack.pop() {
        if target.contains(&c) {
            return true;
        }
        let p = d.coords(c);
        for cq in L::C.iter().skip(1) {
            // no wrap across the boundary planes' axes: they are not periodic
            let wraps = |ax: usize| {
                let v = p[ax] as i64 + cq[ax] as i64;
                v < 0 || v >= [d.nx, d.ny, d.nz][ax] as i64
            };
            if wraps(a.face.axis) || wraps(b.face.axis) {
                continue;
            }
            let n = d.shifted(p, *cq);
            let nc = d.cell(n[0], n[1], n[2]);
            if !seen[nc] && !geom.is_solid(nc) {
                seen[nc] = true;
                stack.push(nc);
            }
        }
    }
    false
}
