//! The fluid-list kernel: the same fused pull stream-and-collide as [`super::solver`], storing
//! and updating only the fluid nodes, so that memory and time scale with the fluid, not the
//! box (a packing at phi 0.64 keeps 36 % of the box).
//!
//! The fluid nodes are numbered in the box's order (x fastest, then y, then z), so that the
//! nodes of an x-run are consecutive and most neighbours of a block of [`LANES`] consecutive
//! nodes are again consecutive. Population q of node n is at `q stride + n` (structure of
//! arrays, `stride` the node count padded to whole blocks). The neighbour table holds, per
//! direction and node, where the node pulls its population q from: `q stride + m` for the
//! fluid upstream node m, or, where the upstream cell is solid, `opp(q) stride + n` (halfway
//! bounce-back resolved into the table; seed 002 ref. 12, Ladd 1994). A block whose Q pulls
//! are consecutive loads them as one vector ([`Tables::contiguous`]); the others are gathered.
//! Links that do more than bounce back halfway, moving walls (Ladd's delta) and curved walls
//! (CLI, [`super::walls`]), are listed per block and applied after the pull, with the same
//! operations as [`super::geometry::Link::value`].
//!
//! The moments, the forcing's state and the collision are those of the box kernel
//! ([`Pairs`], [`Forcing::states`], [`relax`]), on the same pulled values: the populations
//! are the box kernel's to the bit, and every node reads only the previous array, so the
//! result is the same at any thread count. Sums (mass, momentum) are taken in the box
//! kernel's order, so they too are its bits.

use super::collision::{relax, Block, Collision, Pairs};
use super::forcing::Forcing;
use super::geometry::{Dims, Geometry};
use super::lattice::{density_momentum, each_q, opposite, Lattice, QMAX};
use super::memory::{last_level_cache_bytes, memory_available, stride_off_sets, Populations};
use super::simd::{Cells, Real, VArr, LANES};
#[cfg(target_arch = "x86_64")]
use super::simd::{V256x2, V512};
use super::solver::{Fields, Record};
use crate::error::{invalid, Result};
use rayon::prelude::*;
use std::marker::PhantomData;

/// The largest fluid fraction at which [`super::setup::Storage::Auto`] takes the fluid list
/// (measured in `benches/RESULTS.md`: the fluid list wins on packings and random masks; an
/// open box keeps the box kernel's straight rows).
pub const AUTO_FLUID_FRACTION: f64 = 0.9;

/// Blocks a thread takes at a time.
const BLOCKS_PER_TASK: usize = 64;

/// A link that does more than bounce back halfway: population q of lane `lane` of its block
/// is f*_opp(q)(x) + delta, plus kappa [f*_opp(q)(x + c_q) - f*_q(x)] on a curved wall (the
/// first read at `far`, the second at `near`).
#[derive(Debug, Clone, Copy)]
struct Fixup {
    lane: u8,
    q: u8,
    delta: f64,
    kappa: f64,
    far: u32,
    near: u32,
}

impl Fixup {
    /// The population it gives, `base` the halfway pull f*_opp(q)(x) (the operations of
    /// [`super::geometry::Link::value`], in its order).
    #[inline(always)]
    fn value(&self, src: &[f64], base: u32) -> f64 {
        let v = src[base as usize] + self.delta;
        if self.kappa == 0.0 {
            v
        } else {
            v + self.kappa * (src[self.far as usize] - src[self.near as usize])
        }
    }
}

/// What a step reads besides the populations: the neighbour table and the per-block facts.
struct Tables {
    /// Fluid nodes, and their count padded to whole blocks (the populations' q stride).
    nodes: usize,
    stride: usize,
    /// pull[q stride + n]: the index in the population array that population q of node n
    /// comes from (padding nodes repeat the last node's).
    pull: Vec<u32>,
    /// Per block: bit q set when its LANES pulls of population q are consecutive.
    contiguous: Vec<u32>,
    /// The box cell of each node (padding: the last node's), and per block whether its cells
    /// are consecutive (a per-cell forcing field is then one load).
    cell: Vec<usize>,
    cells_consecutive: Vec<bool>,
    /// Block b's fixups: fixups[fix_start[b]..fix_start[b + 1]].
    fix_start: Vec<u32>,
    fixups: Vec<Fixup>,
    /// The first node of each z-plane (nz + 1 values), for the sums in the box kernel's order.
    plane_start: Vec<usize>,
}

impl Tables {
    fn new<L: Lattice>(geom: &Geometry) -> Result<Tables> {
        let d = geom.dims;
        let nodes = geom.fluid_cells();
        if nodes == 0 {
            return invalid("the fluid-list kernel needs at least one fluid cell");
        }
        let stride = stride_off_sets(nodes.next_multiple_of(LANES));
        if (L::Q * stride) as u64 > i32::MAX as u64 {
            return invalid(format!(
                "{nodes} fluid nodes x {} velocities: more than 2^31 populations for the \
                 fluid-list kernel's 32-bit neighbour table",
                L::Q
            ));
        }
        let mut node_of = vec![u32::MAX; d.cells()];
        let mut cell = Vec::with_capacity(stride);
        let mut plane_start = Vec::with_capacity(d.nz + 1);
        for z in 0..d.nz {
            plane_start.push(cell.len());
            for y in 0..d.ny {
                for &(x0, x1) in geom.runs(z * d.ny + y) {
                    for x in x0 as usize..x1 as usize {
                        let c = d.cell(x, y, z);
                        node_of[c] = cell.len() as u32;
                        cell.push(c);
                    }
                }
            }
        }
        plane_start.push(cell.len());
        let last = cell[nodes - 1];
        cell.resize(stride, last);
        let mut pull = vec![0u32; L::Q * stride];
        let blocks = stride.div_ceil(LANES);
        let mut fix_start = Vec::with_capacity(blocks + 1);
        let mut fixups = Vec::new();
        let mut n = 0;
        for z in 0..d.nz {
            for y in 0..d.ny {
                let r = z * d.ny + y;
                let mut links = geom.links(r).iter().peekable();
                for &(x0, x1) in geom.runs(r) {
                    for x in x0 as usize..x1 as usize {
                        if n % LANES == 0 {
                            fix_start.push(fixups.len() as u32);
                        }
                        for q in 0..L::Q {
                            let c = L::C[q];
                            let u = d.shifted([x, y, z], [-c[0], -c[1], -c[2]]);
                            let m = node_of[d.cell(u[0], u[1], u[2])];
                            pull[q * stride + n] = if m == u32::MAX {
                                (opposite(q) * stride + n) as u32
                            } else {
                                (q * stride) as u32 + m
                            };
                        }
                        while let Some(l) = links.next_if(|l| l.x as usize == x) {
                            if l.delta == 0.0 && l.kappa == 0.0 {
                                continue;
                            }
                            let q = l.q as usize;
                            let s = d.shifted([x, y, z], L::C[q]);
                            let second = node_of[d.cell(s[0], s[1], s[2])];
                            fixups.push(Fixup {
                                lane: (n % LANES) as u8,
                                q: l.q,
                                delta: l.delta,
                                kappa: l.kappa,
                                // a curved link's second node is fluid (else kappa = 0)
                                far: if l.kappa == 0.0 {
                                    0
                                } else {
                                    (opposite(q) * stride) as u32 + second
                                },
                                near: (q * stride + n) as u32,
                            });
                        }
                        n += 1;
                    }
                }
            }
        }
        while fix_start.len() < blocks + 1 {
            fix_start.push(fixups.len() as u32);
        }
        for q in 0..L::Q {
            let last = pull[q * stride + nodes - 1];
            pull[q * stride + nodes..(q + 1) * stride].fill(last);
        }
        let contiguous = (0..blocks)
            .map(|b| {
                let mut bits = 0u32;
                for q in 0..L::Q {
                    let p = &pull[q * stride + b * LANES..q * stride + (b + 1) * LANES];
                    if p.windows(2).all(|w| w[1] == w[0] + 1) {
                        bits |= 1 << q;
                    }
                }
                bits
            })
            .collect();
        let cells_consecutive = cell
            .chunks(LANES)
            .map(|c| c.windows(2).all(|w| w[1] == w[0] + 1))
            .collect();
        Ok(Tables {
            nodes,
            stride,
            pull,
            contiguous,
            cell,
            cells_consecutive,
            fix_start,
            fixups,
            plane_start,
        })
    }

    /// Bytes of the tables.
    fn bytes(&self) -> usize {
        4 * self.pull.len()
            + 4 * self.contiguous.len()
            + 8 * self.cell.len()
            + self.cells_consecutive.len()
            + 4 * self.fix_start.len()
            + std::mem::size_of::<Fixup>() * self.fixups.len()
            + 8 * self.plane_start.len()
    }

    /// The populations arriving at node n (scalar): the pulls and the node's fixups.
    fn pulled<L: Lattice>(&self, src: &[f64], n: usize) -> L::Pop {
        let mut p = L::Pop::default();
        for (q, v) in p.as_mut().iter_mut().enumerate() {
            *v = src[self.pull[q * self.stride + n] as usize];
        }
        let b = n / LANES;
        for x in &self.fixups[self.fix_start[b] as usize..self.fix_start[b + 1] as usize] {
            if x.lane as usize == n % LANES {
                let q = x.q as usize;
                p.as_mut()[q] = x.value(src, self.pull[q * self.stride + n]);
            }
        }
        p
    }
}

/// What a node's collision used: density, velocity, source acceleration.
type NodeRecord = (f64, [f64; 3], [f64; 3]);

/// One task's output: the Q population rows of its nodes, and where its first node is.
struct Task<'a> {
    first_block: usize,
    out: Vec<&'a mut [f64]>,
}

/// The fluid-list lattice-Boltzmann solver for lattice `L`, collision `C`, forcing `F`
/// (lattice units; periodic box, no boundary planes).
pub struct FluidSolver<L: Lattice, C: Collision, F: Forcing> {
    geometry: Geometry,
    collision: C,
    forcing: F,
    tables: Tables,
    /// Post-collision populations of the current step, and the next step's scratch.
    f: Populations,
    g: Populations,
    steps: u64,
    stream_stores: Option<bool>,
    _l: PhantomData<L>,
}

/// Bytes a fluid-list solver needs: two population arrays of the padded fluid nodes, the
/// neighbour table and the per-node cell, plus the box's mask.
pub fn bytes_needed(fluid: usize, cells: usize, q: usize) -> u128 {
    let n = fluid.next_multiple_of(LANES) as u128;
    n * (2 * 8 * q as u128 + 4 * q as u128 + 8) + cells as u128
}

impl<L: Lattice, C: Collision, F: Forcing> FluidSolver<L, C, F> {
    /// A solver at rest with density 1 (populations at their equilibrium). Refuses a
    /// geometry without fluid, and one whose arrays exceed the memory available (checked
    /// before the populations are allocated).
    pub fn new(geometry: Geometry, collision: C, forcing: F) -> Result<Self> {
        let need = bytes_needed(geometry.fluid_cells(), geometry.dims.cells(), L::Q);
        if let Some(avail) = memory_available() {
            if need > avail {
                let d = geometry.dims;
                return invalid(format!(
                    "lattice {} x {} x {} ({} fluid cells) with Q = {} needs {:.2} GiB, more \
                     than the {:.2} GiB of memory available: use a coarser resolution",
                    d.nx,
                    d.ny,
                    d.nz,
                    geometry.fluid_cells(),
                    L::Q,
                    need as f64 / 1073741824.0,
                    avail as f64 / 1073741824.0
                ));
            }
        }
        let tables = Tables::new::<L>(&geometry)?;
        // the links live on in the table and the fixups
        let mut geometry = geometry;
        geometry.forget_links();
        let len = L::Q * tables.stride;
        let mut s = FluidSolver {
            geometry,
            collision,
            forcing,
            tables,
            f: Populations::zeros(len),
            g: Populations::zeros(len),
            steps: 0,
            stream_stores: None,
            _l: PhantomData,
        };
        s.init(|_| (1.0, [0.0; 3]));
        Ok(s)
    }

    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }
    pub fn forcing(&self) -> &F {
        &self.forcing
    }
    pub fn forcing_mut(&mut self) -> &mut F {
        &mut self.forcing
    }
    pub fn dims(&self) -> Dims {
        self.geometry.dims
    }
    pub fn steps(&self) -> u64 {
        self.steps
    }
    /// Fluid nodes stored.
    pub fn nodes(&self) -> usize {
        self.tables.nodes
    }

    /// Bytes held: the two population arrays, the tables and the geometry's mask and links.
    pub fn bytes(&self) -> usize {
        2 * 8 * self.f.len() + self.tables.bytes() + self.geometry.bytes()
    }

    /// As [`super::Solver::streaming_stores`]: whole cache lines of output stored past the
    /// caches when the two population arrays exceed the last-level cache.
    pub fn streaming_stores(&self) -> bool {
        self.stream_stores
            .unwrap_or_else(|| 2 * 8 * self.f.len() as u64 > last_level_cache_bytes())
    }

    pub fn set_streaming_stores(&mut self, on: Option<bool>) {
        self.stream_stores = on;
    }

    /// Sets every fluid node to the equilibrium of `state(cell) = (rho, u)` (porosity from
    /// the forcing).
    pub fn init(&mut self, state: impl Fn(usize) -> (f64, [f64; 3])) {
        let stride = self.tables.stride;
        for n in 0..self.tables.nodes {
            let cell = self.tables.cell[n];
            let (rho, u) = state(cell);
            let inv_eps = self.forcing.state(cell, 1.0, [0.0; 3]).inv_eps;
            let feq = super::collision::equilibrium::<L>(rho, u, inv_eps);
            for (q, v) in feq.as_ref().iter().enumerate() {
                self.f[q * stride + n] = *v;
            }
        }
    }

    /// Pull, bounce back, collide and store block `b` into `out` (the task's Q rows, the
    /// block at `at`).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn block<R: Real>(
        src: &[f64],
        t: &Tables,
        coll: &C,
        force: &F,
        (b, at, stream): (usize, usize, bool),
        scratch: &mut Block<LANES>,
        out: &mut [&mut [f64]],
        rec: &mut [NodeRecord],
    ) {
        let n0 = b * LANES;
        let bits = t.contiguous[b];
        let mut f = [R::splat(0.0); QMAX];
        each_q!(L, q, {
            let p = &t.pull[q * t.stride + n0..q * t.stride + n0 + LANES];
            f[q] = if bits & (1 << q) != 0 {
                R::load(&src[p[0] as usize..])
            } else {
                R::gather(src, p)
            };
        });
        let fix = &t.fixups[t.fix_start[b] as usize..t.fix_start[b + 1] as usize];
        if !fix.is_empty() {
            each_q!(L, q, {
                f[q].store(&mut scratch[q]);
            });
            let mut touched = 0u32;
            for x in fix {
                let (q, l) = (x.q as usize, x.lane as usize);
                scratch[q][l] = x.value(src, t.pull[q * t.stride + n0 + l]);
                touched |= 1 << q;
            }
            each_q!(L, q, {
                if touched & (1 << q) != 0 {
                    f[q] = R::load(&scratch[q]);
                }
            });
        }
        let p = Pairs::of::<L>(&f);
        let (rho, j) = p.moments::<L>();
        let cells = Cells {
            idx: &t.cell[n0..n0 + LANES],
            contiguous: t.cells_consecutive[b],
        };
        let st = force.states(cells, rho, j);
        let mut post = [R::splat(0.0); QMAX];
        if F::ACTIVE {
            relax::<L, C, R, true>(coll, rho, &st, &p, &mut post);
        } else {
            relax::<L, C, R, false>(coll, rho, &st, &p, &mut post);
        }
        each_q!(L, q, {
            if stream {
                post[q].store_stream(&mut out[q][at..]);
            } else {
                post[q].store(&mut out[q][at..]);
            }
        });
        if !rec.is_empty() {
            let mut r = [0.0; LANES];
            let (mut u, mut a) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
            rho.store(&mut r);
            for k in 0..3 {
                st.u[k].store(&mut u[k]);
                st.a[k].store(&mut a[k]);
            }
            for (l, e) in rec[at..at + LANES].iter_mut().enumerate() {
                *e = (
                    r[l],
                    [u[0][l], u[1][l], u[2][l]],
                    [a[0][l], a[1][l], a[2][l]],
                );
            }
        }
    }

    /// The blocks of one task.
    #[inline(always)]
    fn task_body<R: Real>(
        src: &[f64],
        t: &Tables,
        coll: &C,
        force: &F,
        stream: bool,
        task: &mut Task,
        rec: &mut [NodeRecord],
    ) {
        let mut scratch: Block<LANES> = [[0.0; LANES]; QMAX];
        let blocks = task.out[0].len() / LANES;
        for k in 0..blocks {
            let arg = (task.first_block + k, k * LANES, stream);
            Self::block::<R>(src, t, coll, force, arg, &mut scratch, &mut task.out, rec);
        }
        if stream {
            R::fence();
        }
    }

    /// [`Self::task_body`] compiled for AVX2 + FMA.
    ///
    /// # Safety
    /// The caller must have checked that the CPU supports avx2 and fma.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn task_avx2(
        src: &[f64],
        t: &Tables,
        coll: &C,
        force: &F,
        stream: bool,
        task: &mut Task,
        rec: &mut [NodeRecord],
    ) {
        Self::task_body::<V256x2>(src, t, coll, force, stream, task, rec)
    }

    /// [`Self::task_body`] compiled for AVX-512.
    ///
    /// # Safety
    /// The caller must have checked that the CPU supports avx512f, avx2 and fma.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    unsafe fn task_avx512(
        src: &[f64],
        t: &Tables,
        coll: &C,
        force: &F,
        stream: bool,
        task: &mut Task,
        rec: &mut [NodeRecord],
    ) {
        Self::task_body::<V512>(src, t, coll, force, stream, task, rec)
    }

    /// One time step: stream, bounce back, collide.
    pub fn step(&mut self) {
        self.step_inner(None);
    }

    /// One time step that also records, per fluid cell, the density, velocity and source
    /// acceleration its collision used (refuses a record of another size than the box).
    pub fn step_recording(&mut self, rec: &mut Record) -> Result<()> {
        let cells = self.dims().cells();
        if rec.rho.len() != cells || rec.u.len() != cells || rec.a.len() != cells {
            return invalid(format!(
                "record of {} cells for a lattice of {cells} cells",
                rec.rho.len()
            ));
        }
        let mut per_node = vec![(0.0, [0.0; 3], [0.0; 3]); self.tables.stride];
        self.step_inner(Some(&mut per_node));
        for (n, (r, u, a)) in per_node.into_iter().take(self.tables.nodes).enumerate() {
            let c = self.tables.cell[n];
            (rec.rho[c], rec.u[c], rec.a[c]) = (r, u, a);
        }
        Ok(())
    }

    fn step_inner(&mut self, rec: Option<&mut [NodeRecord]>) {
        #[cfg(target_arch = "x86_64")]
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        #[cfg(target_arch = "x86_64")]
        let avx512 = avx2 && is_x86_feature_detected!("avx512f");
        let stream = self.streaming_stores();
        let (t, coll, force) = (&self.tables, &self.collision, &self.forcing);
        let src: &[f64] = &self.f;
        let chunk = BLOCKS_PER_TASK * LANES;
        let stride = t.stride;
        let ntasks = stride.div_ceil(chunk);
        let mut tasks: Vec<Task> = (0..ntasks)
            .map(|k| Task {
                first_block: k * BLOCKS_PER_TASK,
                out: Vec::with_capacity(L::Q),
            })
            .collect();
        for row in self.g.chunks_mut(stride).take(L::Q) {
            for (task, part) in tasks.iter_mut().zip(row.chunks_mut(chunk)) {
                task.out.push(part);
            }
        }
        let mut recs: Vec<&mut [NodeRecord]> = match rec {
            Some(r) => r.chunks_mut(chunk).collect(),
            None => (0..ntasks).map(|_| &mut [][..]).collect(),
        };
        tasks
            .par_iter_mut()
            .zip(recs.par_iter_mut())
            .for_each(|(task, rec)| {
                #[cfg(target_arch = "x86_64")]
                if avx512 {
                    // SAFETY: avx512f, avx2 and fma were detected above.
                    unsafe { Self::task_avx512(src, t, coll, force, stream, task, rec) };
                    return;
                }
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    // SAFETY: avx2 and fma were detected above.
                    unsafe { Self::task_avx2(src, t, coll, force, stream, task, rec) };
                    return;
                }
                Self::task_body::<VArr>(src, t, coll, force, stream, task, rec)
            });
        drop(tasks);
        std::mem::swap(&mut self.f, &mut self.g);
        self.steps += 1;
    }

    /// `n` steps.
    pub fn run(&mut self, n: u64) {
        for _ in 0..n {
            self.step();
        }
    }

    /// Density and velocity of every cell of the box (solid cells: zeros), the state the next
    /// collision sees (as [`super::Solver::fields`]).
    pub fn fields(&self) -> Fields {
        let t = &self.tables;
        let states: Vec<(f64, [f64; 3])> = (0..t.nodes)
            .into_par_iter()
            .map(|n| {
                let (r, j) = density_momentum::<L>(&t.pulled::<L>(&self.f, n));
                (r, self.forcing.state(t.cell[n], r, j).u)
            })
            .collect();
        let cells = self.dims().cells();
        let mut f = Fields {
            rho: vec![0.0; cells],
            u: vec![[0.0; 3]; cells],
        };
        for (n, (r, u)) in states.into_iter().enumerate() {
            let c = t.cell[n];
            f.rho[c] = r;
            f.u[c] = u;
        }
        f
    }

    /// `per_run(s, q, run)` over every x-run of fluid nodes, per z-plane in the box kernel's
    /// order (rows, runs, q): each plane's sum `s`, in plane order.
    fn plane_sums<S: Send + Default>(
        &self,
        per_run: impl Fn(&mut S, usize, &[f64]) + Sync,
    ) -> Vec<S> {
        let (d, t) = (self.dims(), &self.tables);
        (0..d.nz)
            .into_par_iter()
            .map(|z| {
                let mut s = S::default();
                let mut n = t.plane_start[z];
                for y in 0..d.ny {
                    for &(x0, x1) in self.geometry.runs(z * d.ny + y) {
                        let len = (x1 - x0) as usize;
                        for q in 0..L::Q {
                            let base = q * t.stride + n;
                            per_run(&mut s, q, &self.f[base..base + len]);
                        }
                        n += len;
                    }
                }
                s
            })
            .collect()
    }

    /// Total mass: the sum of all populations (the box kernel's order and bits).
    pub fn mass(&self) -> f64 {
        let planes = self.plane_sums(|s: &mut f64, _, run| *s += run.iter().sum::<f64>());
        planes.iter().sum()
    }

    /// Total momentum sum f c of the post-collision populations (the box kernel's order).
    pub fn momentum(&self) -> [f64; 3] {
        let planes = self.plane_sums(|s: &mut [f64; 3], q, run| {
            let f: f64 = run.iter().sum();
            for (k, sk) in s.iter_mut().enumerate() {
                *sk += L::C[q][k] as f64 * f;
            }
        });
        let mut t = [0.0; 3];
        for s in planes {
            for k in 0..3 {
                t[k] += s[k];
            }
        }
        t
    }

    /// The post-collision populations of every cell of the box, value ((z Q + q) ny + y) nx
    /// + x (solid cells: zeros), as [`super::Solver::populations`] gives them.
    pub fn populations(&self) -> Vec<f64> {
        let d = self.dims();
        let mut out = vec![0.0; d.cells() * L::Q];
        let t = &self.tables;
        for n in 0..t.nodes {
            let [x, y, z] = d.coords(t.cell[n]);
            for q in 0..L::Q {
                out[((z * L::Q + q) * d.ny + y) * d.nx + x] = self.f[q * t.stride + n];
            }
        }
        out
    }

    /// Replaces the post-collision populations (in the order of [`Self::populations`]) and
    /// the step count.
    pub fn restore_populations(&mut self, f: &[f64], steps: u64) -> Result<()> {
        let d = self.dims();
        if f.len() != d.cells() * L::Q {
            return invalid(format!(
                "{} populations for a lattice of {} cells x {} velocities",
                f.len(),
                d.cells(),
                L::Q
            ));
        }
        let t = &self.tables;
        for n in 0..t.nodes {
            let [x, y, z] = d.coords(t.cell[n]);
            for q in 0..L::Q {
                self.f[q * t.stride + n] = f[((z * L::Q + q) * d.ny + y) * d.nx + x];
            }
        }
        self.steps = steps;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lbm::collision::{Bgk, Trt};
    use crate::lbm::forcing::{BodyForce, Porous};
    use crate::lbm::lattice::{D3Q15, D3Q19};
    use crate::lbm::walls::WallFractions;
    use crate::lbm::Solver;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A random mask with curved walls on every other fluid cell's links and moving solid
    /// cells (`moving`), on lattice L.
    fn geometry<L: Lattice>(d: Dims, solid: f64, moving: bool, rng: &mut ChaCha8Rng) -> Geometry {
        let mask: Vec<bool> = (0..d.cells()).map(|_| rng.gen_bool(solid)).collect();
        let fractions = WallFractions::from_crossings(d, &mask, |x, c| {
            let h = x[0] * 7.31 + x[1] * 3.17 + x[2] * 1.93 + (c[0] + 2 * c[1] + 4 * c[2]) as f64;
            ((x[0] + x[1]) as usize % 2 == 1).then(|| 0.05 + 0.95 * h.fract())
        })
        .unwrap();
        let wall = |c: usize| {
            if moving && c.is_multiple_of(7) {
                [0.01, -0.02, 0.0]
            } else {
                [0.0; 3]
            }
        };
        Geometry::with_walls::<L>(d, mask, wall, Some(&fractions)).unwrap()
    }

    /// Steps a box solver and a fluid-list solver from the same random state and compares
    /// populations, fields, mass and momentum bit for bit after each of three steps; the
    /// fluid-list solver again on one thread and on two.
    fn same<L: Lattice, C: Collision, F: Forcing + Clone>(
        g: &Geometry,
        coll: C,
        force: F,
        rng: &mut ChaCha8Rng,
    ) {
        let cells = g.dims.cells();
        let u: Vec<[f64; 3]> = (0..cells)
            .map(|_| [0; 3].map(|_| rng.gen_range(-0.05..0.05)))
            .collect();
        let rho: Vec<f64> = (0..cells).map(|_| rng.gen_range(0.95..1.05)).collect();
        let mut a = Solver::<L, C, F>::new(g.clone(), coll, force.clone()).unwrap();
        a.init(|c| (rho[c], u[c]));
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| {
                let mut b = FluidSolver::<L, C, F>::new(g.clone(), coll, force.clone()).unwrap();
                b.init(|c| (rho[c], u[c]));
                let mut out = Vec::new();
                for step in 0..3 {
                    b.set_streaming_stores(Some(step % 2 == 1));
                    b.step();
                    out.push(b.populations());
                }
                (out, b)
            })
        };
        let (one, b) = run(1);
        let (two, _) = run(2);
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        for (step, (p1, p2)) in one.iter().zip(&two).enumerate() {
            a.step();
            let want = a.populations();
            let bad = p1
                .iter()
                .zip(&want)
                .position(|(x, y)| x.to_bits() != y.to_bits());
            assert!(
                bad.is_none(),
                "{} {} {} {:?} step {step}: population {:?} is {:e}, the box kernel's {:e}",
                L::NAME,
                C::NAME,
                F::NAME,
                g.dims,
                bad,
                p1[bad.unwrap()],
                want[bad.unwrap()]
            );
            assert_eq!(bits(p1), bits(p2), "1 and 2 threads, step {step}");
        }
        let (fa, fb) = (a.fields(), b.fields());
        assert_eq!(bits(&fa.rho), bits(&fb.rho));
        let flat = |u: &[[f64; 3]]| u.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(flat(&fa.u), flat(&fb.u));
        assert_eq!(a.mass().to_bits(), b.mass().to_bits());
        assert_eq!(bits(&a.momentum()), bits(&b.momentum()));
    }

    fn lattice<L: Lattice>(rng: &mut ChaCha8Rng) {
        for (nx, ny, nz) in [(16, 5, 4), (13, 6, 3), (9, 4, 4)] {
            let d = Dims::new(nx, ny, nz).unwrap();
            for solid in [0.0, 0.3, 0.65] {
                for moving in [false, true] {
                    let g = geometry::<L>(d, solid, moving, rng);
                    let body = BodyForce {
                        g: [1e-5, 2e-6, -3e-6],
                    };
                    same::<L, _, _>(&g, Bgk::from_tau(0.8), body, rng);
                    same::<L, _, _>(&g, Trt::magic(0.7), body, rng);
                    let mut p = Porous::clear(d.cells(), 0.1, [1e-5, -2e-6, 3e-6], true);
                    for c in 0..d.cells() {
                        p.set(c, rng.gen_range(0.3..=1.0), rng.gen_range(0.01..100.0))
                            .unwrap();
                    }
                    same::<L, _, _>(&g, Trt::magic(0.8), p, rng);
                }
            }
        }
    }

    /// The fluid-list kernel gives the box kernel's populations, fields, mass and momentum to
    /// the bit (halfway, moving and curved walls; both lattices, both collisions, body force
    /// and Guo-Zhao medium), and the same bits on one thread and on two.
    #[test]
    fn fluid_list_equals_box_kernel_bitwise() {
        let mut rng = ChaCha8Rng::seed_from_u64(51);
        lattice::<D3Q15>(&mut rng);
        lattice::<D3Q19>(&mut rng);
    }

    /// A geometry without fluid is refused by name.
    #[test]
    fn no_fluid_is_refused() {
        let d = Dims::new(4, 4, 4).unwrap();
        let g = Geometry::new::<D3Q19>(d, vec![true; d.cells()], |_| [0.0; 3]).unwrap();
        let e = FluidSolver::<D3Q19, _, _>::new(g, Trt::magic(1.0), BodyForce { g: [0.0; 3] })
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains("at least one fluid cell"), "{e}");
    }
}
