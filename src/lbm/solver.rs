//! The fused stream-and-collide kernel (pull scheme, two population arrays), monomorphised for
//! each (lattice, collision, forcing): `Solver<D3Q19, Trt, Porous>` is one kernel, with no
//! per-cell branch on the choice.
//!
//! Storage is a structure of arrays in z-planes: population q of cell (x, y, z) is at
//! `(z Q + q) q_stride + y nx + x`, q_stride = ny nx (one cache line more at power-of-two sizes;
//! [`Layout`]), so each plane (all q) is one contiguous chunk
//! that one rayon task writes. A step walks every row's fluid cells in blocks of [`LANES`]
//! cells: it pulls the Q upstream populations of the block (one contiguous load per q, with
//! one wrapped lane at the row's ends; a gather for the cells of short runs between solids),
//! overwrites the bounce-back links (f_q(x) = f*_opp(q)(x) + delta; halfway bounce-back, seed
//! 002 ref. 12 and Ladd 1994), takes the moments, collides in place and stores, every q
//! written out by [`each_q!`] so the whole block is straight-line vector code. Every cell's
//! update reads only the previous array, so the result is the same at any thread count; sums
//! (mass, mean velocity) are taken per plane and added in plane order.

use super::boundary::Boundaries;
use super::collision::{equilibrium, relax, Block, Collision, Pairs};
use super::forcing::Forcing;
use super::geometry::{Dims, Geometry, Link};
use super::lattice::{density_momentum, each_q, opposite, Lattice, QMAX};
use super::memory::{check_memory, last_level_cache_bytes, Layout, Populations};
use super::simd::{Cells, Real, VArr, LANES};
#[cfg(target_arch = "x86_64")]
use super::simd::{V256x2, V512};
use crate::error::{invalid, Result};
use rayon::prelude::*;
use std::marker::PhantomData;

/// Density and velocity of every cell (solid cells: rho = 0, u = 0).
#[derive(Debug, Clone)]
pub struct Fields {
    pub rho: Vec<f64>,
    pub u: Vec<[f64; 3]>,
}

/// The state each fluid cell's collision used in one step: density, the forcing's velocity and
/// the source term's acceleration (lattice units; solid cells keep zeros).
#[derive(Debug, Clone)]
pub struct Record {
    pub rho: Vec<f64>,
    pub u: Vec<[f64; 3]>,
    pub a: Vec<[f64; 3]>,
}

impl Record {
    pub fn zeros(cells: usize) -> Record {
        Record {
            rho: vec![0.0; cells],
            u: vec![[0.0; 3]; cells],
            a: vec![[0.0; 3]; cells],
        }
    }
}

/// Where one row's populations come from: the start in the source array of the upstream
/// row of each population, the row's own start (population 0), its first cell index and y,
/// and the arrays' layout.
struct RowCtx {
    up: [usize; QMAX],
    here: usize,
    cell0: usize,
    y: usize,
    layout: Layout,
    /// Whether the arrays exceed the caches: a contiguous block's output then bypasses them
    /// (non-temporal stores) and its upstream rows are prefetched.
    stream: bool,
}

/// What every block of a row needs: source array, extent, collision, forcing, the row's
/// [`RowCtx`] and bounce-back links.
type RowArgs<'a, C, F> = (&'a [f64], &'a Dims, &'a C, &'a F, &'a RowCtx, &'a [Link]);

/// One z-plane of a [`Record`].
type PlaneRecord<'a> = (&'a mut [f64], &'a mut [[f64; 3]], &'a mut [[f64; 3]]);

/// Lattice-Boltzmann solver for lattice `L`, collision `C`, forcing `F` (lattice units).
pub struct Solver<L: Lattice, C: Collision, F: Forcing> {
    geometry: Geometry,
    collision: C,
    forcing: F,
    /// Post-collision populations of the current step.
    f: Populations,
    /// Scratch for the next step.
    g: Populations,
    /// Where each population lives in `f` and `g`.
    layout: Layout,
    /// Velocity and density planes (non-equilibrium extrapolation), applied after the kernel.
    boundaries: Boundaries,
    steps: u64,
    /// Whether contiguous blocks are stored non-temporally; None: when the two population
    /// arrays exceed the last-level cache ([`Solver::streaming_stores`]).
    stream_stores: Option<bool>,
    _l: PhantomData<L>,
}

impl<L: Lattice, C: Collision, F: Forcing> Solver<L, C, F> {
    /// A solver at rest with density 1 (populations at their equilibrium). The memory check
    /// runs before anything is allocated. The kernel's own constructor: a run is set up as an
    /// [`super::Setup`] and built by [`super::Lbm::new`], which chooses the kernel.
    pub fn new(geometry: Geometry, collision: C, forcing: F) -> Result<Self> {
        let dims = geometry.dims;
        check_memory(dims, L::Q, 0)?;
        let layout = Layout::new(&dims, L::Q);
        let mut s = Solver {
            geometry,
            collision,
            forcing,
            f: Populations::zeros(layout.values()),
            g: Populations::zeros(layout.values()),
            layout,
            boundaries: Boundaries::default(),
            steps: 0,
            stream_stores: None,
            _l: PhantomData,
        };
        s.init(|_| (1.0, [0.0; 3]));
        Ok(s)
    }

    /// Adds velocity and density planes (refuses a plane cell that is solid in the
    /// geometry); the boundary nodes are rebuilt every step after the fused kernel.
    pub fn with_boundaries(mut self, boundaries: Boundaries) -> Result<Self> {
        for c in boundaries.planes().iter().flat_map(|p| p.cells()) {
            if self.geometry.is_solid(c) {
                return invalid(format!(
                    "boundary node {:?} is solid in the geometry",
                    self.dims().coords(c)
                ));
            }
        }
        self.boundaries = boundaries;
        Ok(self)
    }

    pub fn boundaries(&self) -> &Boundaries {
        &self.boundaries
    }

    pub fn geometry(&self) -> &Geometry {
        &self.geometry
    }

    /// Bytes held: the two population arrays and the geometry's mask and links.
    pub fn bytes(&self) -> usize {
        2 * 8 * self.f.len() + self.geometry.bytes()
    }

    pub fn forcing(&self) -> &F {
        &self.forcing
    }

    /// The forcing, to change its fields between steps (a porous medium's cells validate what
    /// they are given).
    pub fn forcing_mut(&mut self) -> &mut F {
        &mut self.forcing
    }

    /// Whether the kernel writes whole cache lines of its output non-temporally (past the
    /// caches, so that a line is not read before it is overwritten: 2 x 8 Q bytes per cell
    /// update instead of 3 x 8 Q). By default it does when the two population arrays exceed
    /// the last-level cache (read from Linux's sysfs; 32 MiB where unknown). Only the AVX-512
    /// path has such stores; the results are the same bits either way.
    pub fn streaming_stores(&self) -> bool {
        self.stream_stores
            .unwrap_or_else(|| 2 * 8 * self.layout.values() as u64 > last_level_cache_bytes())
    }

    /// Sets [`Solver::streaming_stores`] (None: the default rule).
    pub fn set_streaming_stores(&mut self, on: Option<bool>) {
        self.stream_stores = on;
    }

    pub fn dims(&self) -> Dims {
        self.geometry.dims
    }

    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Sets every fluid cell to the equilibrium of `state(cell) = (rho, u)` (porosity from the
    /// forcing); solid cells hold zeros.
    pub fn init(&mut self, state: impl Fn(usize) -> (f64, [f64; 3])) {
        let (d, layout) = (self.dims(), self.layout);
        for z in 0..d.nz {
            for y in 0..d.ny {
                for x in 0..d.nx {
                    let cell = d.cell(x, y, z);
                    let feq = if self.geometry.is_solid(cell) {
                        L::Pop::default()
                    } else {
                        let (rho, u) = state(cell);
                        let inv_eps = self.forcing.state(cell, 1.0, [0.0; 3]).inv_eps;
                        equilibrium::<L>(rho, u, inv_eps)
                    };
                    for (q, v) in feq.as_ref().iter().enumerate() {
                        self.f[layout.index(z, q, y, x)] = *v;
                    }
                }
            }
        }
    }

    /// Pulls the populations arriving at row (y, z) from `src` into `buf` (q-major, nx each),
    /// with the bounce-back links applied.
    #[inline(always)]
    fn pull_row(src: &[f64], geom: &Geometry, z: usize, y: usize, buf: &mut [f64]) {
        let d = geom.dims;
        let (nx, layout) = (d.nx, Layout::new(&d, L::Q));
        for q in 0..L::Q {
            let c = L::C[q];
            let ys = (y + d.ny - (c[1].rem_euclid(d.ny as i32) as usize)) % d.ny;
            let zs = (z + d.nz - (c[2].rem_euclid(d.nz as i32) as usize)) % d.nz;
            let start = layout.index(zs, q, ys, 0);
            let row = &src[start..start + nx];
            let out = &mut buf[q * nx..(q + 1) * nx];
            if nx == 1 || c[0] == 0 {
                out.copy_from_slice(row);
            } else if c[0] == 1 {
                out[0] = row[nx - 1];
                out[1..].copy_from_slice(&row[..nx - 1]);
            } else {
                out[..nx - 1].copy_from_slice(&row[1..]);
                out[nx - 1] = row[0];
            }
        }
        let r = z * d.ny + y;
        let row = layout.index(z, 0, y, 0);
        for l in geom.links(r) {
            buf[l.q as usize * nx + l.x as usize] = l.value(src, row, layout.q_stride);
        }
    }

    /// Pulls the populations arriving at the cells `xs` of row (y, z), lane l: cell
    /// x = xs[l], with the bounce-back links of those cells applied. `CONTIG`: the cells are
    /// xs[0] + l in a row longer than a block, so each population is one contiguous load
    /// (straight into a register), plus one wrapped lane for a block at either end of the
    /// row; otherwise the lanes are gathered through the plane's `scratch` block.
    /// `rowc.up[q]`: the start of the upstream row of population q in `src`; `links`: the
    /// row's links from the first one at or after xs[0]. Returns the populations and the
    /// number of links used.
    #[inline(always)]
    fn gather<const CONTIG: bool, R: Real>(
        src: &[f64],
        rowc: &RowCtx,
        links: &[Link],
        xs: &[usize; LANES],
        scratch: &mut Block<LANES>,
    ) -> ([R; QMAX], usize) {
        let (up, here, nx) = (&rowc.up, rowc.here, rowc.layout.nx);
        let mut f = [R::splat(0.0); QMAX];
        each_q!(L, q, {
            let cx = L::C[q][0];
            let row = &src[up[q]..up[q] + nx];
            if CONTIG {
                // periodic in x: only a block at either end of the row has one lane whose
                // upstream cell wraps round (cx = 1 at x = 0, cx = -1 at x = nx - 1)
                f[q] = if cx == 1 && xs[0] == 0 {
                    let mut v = [0.0; LANES];
                    v[1..].copy_from_slice(&row[..LANES - 1]);
                    v[0] = row[nx - 1];
                    R::load(&v)
                } else if cx == -1 && xs[0] + LANES == nx {
                    let mut v = [0.0; LANES];
                    v[..LANES - 1].copy_from_slice(&row[nx - LANES + 1..]);
                    v[LANES - 1] = row[0];
                    R::load(&v)
                } else {
                    let x0 = (xs[0] as isize - cx as isize) as usize;
                    if rowc.stream {
                        prefetch(row, x0 + PREFETCH_AHEAD);
                    }
                    R::load(&row[x0..])
                };
            } else {
                for (fl, &x) in scratch[q].iter_mut().zip(xs) {
                    let xu = match cx {
                        1 if x == 0 => nx - 1,
                        -1 if x + 1 == nx => 0,
                        _ => (x as isize - cx as isize) as usize,
                    };
                    *fl = row[xu];
                }
            }
        });
        // halfway bounce-back (links sorted by x): f_q(x) = f*_opp(q)(x) + delta, into the
        // scratch block, each population marked in `mask` taken from there. The lanes' x
        // increase, so a link finds its lane by walking on from the previous link's; a link of
        // a cell that is not in the block (between a gathered block's cells) finds none.
        let last = xs[LANES - 1];
        let mut used = 0;
        let mut lane = 0;
        if links.first().is_some_and(|l| l.x as usize <= last) {
            let mut mask = [false; QMAX];
            if CONTIG {
                each_q!(L, q, {
                    f[q].store(&mut scratch[q]);
                });
            }
            for l in links {
                let x = l.x as usize;
                if x > last {
                    break;
                }
                used += 1;
                let q = l.q as usize;
                let v = l.value(src, here, rowc.layout.q_stride);
                mask[q] = true;
                while xs[lane] < x {
                    lane += 1;
                }
                // a gathered block's padding lanes repeat its last cell and take its value
                let mut k = lane;
                while k < LANES && xs[k] == x {
                    scratch[q][k] = v;
                    k += 1;
                }
            }
            if CONTIG {
                each_q!(L, q, {
                    if mask[q] {
                        f[q] = R::load(&scratch[q]);
                    }
                });
            }
        }
        if !CONTIG {
            each_q!(L, q, {
                f[q] = R::load(&scratch[q]);
            });
        }
        (f, used)
    }

    /// Pull, bounce back, collide and store one block (see [`Self::gather`]): the moments
    /// over the pairs, the forcing's state and the collision, each written once for a cell
    /// and a block ([`Pairs`], [`Forcing::states`], [`relax`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn block<const CONTIG: bool, R: Real>(
        (src, d, coll, force, rowc, links): RowArgs<C, F>,
        xs: &[usize; LANES],
        n: usize,
        scratch: &mut Block<LANES>,
        out: &mut [f64],
        rec: &mut Option<PlaneRecord>,
    ) -> usize {
        let (f, used) = Self::gather::<CONTIG, R>(src, rowc, links, xs, scratch);
        let cells: [usize; LANES] = std::array::from_fn(|l| rowc.cell0 + xs[l]);
        let p = Pairs::of::<L>(&f);
        let (rho, j) = p.moments::<L>();
        let st = force.states(
            Cells {
                idx: &cells,
                contiguous: CONTIG,
            },
            rho,
            j,
        );
        let mut post = [R::splat(0.0); QMAX];
        if F::ACTIVE {
            relax::<L, C, R, true>(coll, rho, &st, &p, &mut post);
        } else {
            relax::<L, C, R, false>(coll, rho, &st, &p, &mut post);
        }
        let plane_q = rowc.layout.q_stride;
        let row0 = rowc.y * d.nx;
        each_q!(L, q, {
            let orow = &mut out[q * plane_q + row0..q * plane_q + row0 + d.nx];
            if CONTIG && rowc.stream {
                post[q].store_stream(&mut orow[xs[0]..]);
            } else if CONTIG {
                post[q].store(&mut orow[xs[0]..]);
            } else {
                let mut v = [0.0; LANES];
                post[q].store(&mut v);
                for l in 0..n {
                    orow[xs[l]] = v[l];
                }
            }
        });
        if let Some((rho_out, u_out, a_out)) = rec {
            let mut r = [0.0; LANES];
            let (mut u, mut a) = ([[0.0; LANES]; 3], [[0.0; LANES]; 3]);
            rho.store(&mut r);
            for k in 0..3 {
                st.u[k].store(&mut u[k]);
                st.a[k].store(&mut a[k]);
            }
            for l in 0..n {
                let k = row0 + xs[l];
                rho_out[k] = r[l];
                u_out[k] = [u[0][l], u[1][l], u[2][l]];
                a_out[k] = [a[0][l], a[1][l], a[2][l]];
            }
        }
        used
    }

    /// The block of the `np` cells `pending` (increasing x, not contiguous), padded with
    /// copies of the last so that every lane holds a real cell. `first`: the index of the
    /// row's first link at or after the previous gathered block's first cell, moved on here
    /// (gathered blocks of a row come in increasing x).
    #[inline(always)]
    fn gathered<R: Real>(
        (src, d, coll, force, rowc, links): RowArgs<C, F>,
        pending: &mut [usize; LANES],
        np: usize,
        first: &mut usize,
        scratch: &mut Block<LANES>,
        out: &mut [f64],
        rec: &mut Option<PlaneRecord>,
    ) {
        for l in np..LANES {
            pending[l] = pending[np - 1];
        }
        skip_links_before(links, first, pending[0]);
        Self::block::<false, R>(
            (src, d, coll, force, rowc, &links[*first..]),
            pending,
            np,
            scratch,
            out,
            rec,
        );
    }

    /// Stream, bounce back and collide the z-plane `z` into `out` (its Q x ny x nx chunk).
    /// Each row's fluid cells go in blocks of [`LANES`]: a run of LANES cells is one
    /// contiguous block (a fluid row of nx = 8 k cells is k blocks that start on cache lines);
    /// the rest (short runs between solids, run tails) are packed into gathered blocks, so a
    /// mostly solid row costs its fluid cells only.
    #[inline(always)]
    fn plane_body<R: Real>(
        src: &[f64],
        geom: &Geometry,
        coll: &C,
        force: &F,
        (z, stream): (usize, bool),
        out: &mut [f64],
        rec: &mut Option<PlaneRecord>,
    ) {
        let d = geom.dims;
        let nx = d.nx;
        let layout = Layout::new(&d, L::Q);
        // a gathered block's populations, and a contiguous block's with bounce-back links
        let mut scratch: Block<LANES> = [[0.0; LANES]; QMAX];
        for y in 0..d.ny {
            let r = z * d.ny + y;
            let mut rowc = RowCtx {
                up: [0; QMAX],
                here: layout.index(z, 0, y, 0),
                cell0: r * nx,
                y,
                layout,
                stream,
            };
            each_q!(L, q, {
                let c = L::C[q];
                let (ys, zs) = (upstream(y, c[1], d.ny), upstream(z, c[2], d.nz));
                rowc.up[q] = layout.index(zs, q, ys, 0);
            });
            let links = geom.links(r);
            if stream && y + 1 < d.ny {
                prefetch_bounce_back(src, geom, &layout, z, y + 1);
            }
            let row = (src, &d, coll, force, &rowc, links);
            let mut li = 0; // first link not before the current block
            let mut lg = 0; // first link not before the last gathered block
            let mut pending = [0usize; LANES];
            let mut np = 0;
            for &(x0, x1) in geom.runs(r) {
                let (x0, x1) = (x0 as usize, x1 as usize);
                let mut x = x0;
                while x < x1 {
                    if x + LANES <= x1 && nx > LANES {
                        let xs: [usize; LANES] = std::array::from_fn(|l| x + l);
                        skip_links_before(links, &mut li, x);
                        li += Self::block::<true, R>(
                            (src, &d, coll, force, &rowc, &links[li..]),
                            &xs,
                            LANES,
                            &mut scratch,
                            out,
                            rec,
                        );
                        x += LANES;
                    } else {
                        pending[np] = x;
                        np += 1;
                        x += 1;
                        if np == LANES {
                            Self::gathered::<R>(
                                row,
                                &mut pending,
                                np,
                                &mut lg,
                                &mut scratch,
                                out,
                                rec,
                            );
                            np = 0;
                        }
                    }
                }
            }
            if np > 0 {
                Self::gathered::<R>(row, &mut pending, np, &mut lg, &mut scratch, out, rec);
            }
        }
        if stream {
            R::fence();
        }
    }

    /// [`Self::plane_body`] compiled for AVX2 + FMA (chosen at run time where the CPU has them),
    /// a block in two AVX2 registers per population.
    ///
    /// # Safety
    /// The caller must have checked that the CPU supports avx2 and fma.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    unsafe fn plane_avx2(
        src: &[f64],
        geom: &Geometry,
        coll: &C,
        force: &F,
        (z, stream): (usize, bool),
        out: &mut [f64],
        rec: &mut Option<PlaneRecord>,
    ) {
        Self::plane_body::<V256x2>(src, geom, coll, force, (z, stream), out, rec)
    }

    /// [`Self::plane_body`] compiled for AVX-512 (one block of [`LANES`] cells per register).
    ///
    /// # Safety
    /// The caller must have checked that the CPU supports avx512f, avx2 and fma.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma")]
    unsafe fn plane_avx512(
        src: &[f64],
        geom: &Geometry,
        coll: &C,
        force: &F,
        (z, stream): (usize, bool),
        out: &mut [f64],
        rec: &mut Option<PlaneRecord>,
    ) {
        Self::plane_body::<V512>(src, geom, coll, force, (z, stream), out, rec)
    }

    /// One time step: stream, bounce back, collide.
    pub fn step(&mut self) {
        self.step_inner(None);
    }

    /// One time step that also records, per fluid cell, the density, velocity and source
    /// acceleration its collision used (the fluid's momentum changes by rho a per cell).
    pub fn step_recording(&mut self, rec: &mut Record) -> Result<()> {
        let cells = self.dims().cells();
        if rec.rho.len() != cells || rec.u.len() != cells || rec.a.len() != cells {
            return invalid(format!(
                "record of {} cells for a lattice of {cells} cells",
                rec.rho.len()
            ));
        }
        self.step_inner(Some(rec));
        Ok(())
    }

    fn step_inner(&mut self, rec: Option<&mut Record>) {
        let d = self.dims();
        let plane = self.layout.z_stride;
        let nxy = d.nx * d.ny;
        #[cfg(target_arch = "x86_64")]
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        #[cfg(target_arch = "x86_64")]
        let avx512 = avx2 && is_x86_feature_detected!("avx512f");
        let (src, geom, coll, force) = (&self.f, &self.geometry, &self.collision, &self.forcing);
        let stream = self.streaming_stores();
        let mut planes: Vec<Option<PlaneRecord>> = match rec {
            Some(r) => r
                .rho
                .chunks_mut(nxy)
                .zip(r.u.chunks_mut(nxy))
                .zip(r.a.chunks_mut(nxy))
                .map(|((a, b), c)| Some((a, b, c)))
                .collect(),
            None => (0..d.nz).map(|_| None).collect(),
        };
        self.g
            .par_chunks_mut(plane)
            .zip(planes.par_iter_mut())
            .enumerate()
            .for_each(|(z, (out, rec))| {
                #[cfg(target_arch = "x86_64")]
                if avx512 {
                    // SAFETY: avx512f, avx2 and fma were detected above.
                    unsafe { Self::plane_avx512(src, geom, coll, force, (z, stream), out, rec) };
                    return;
                }
                #[cfg(target_arch = "x86_64")]
                if avx2 {
                    // SAFETY: avx2 and fma were detected above.
                    unsafe { Self::plane_avx2(src, geom, coll, force, (z, stream), out, rec) };
                    return;
                }
                Self::plane_body::<VArr>(src, geom, coll, force, (z, stream), out, rec)
            });
        if !self.boundaries.is_empty() {
            self.boundaries
                .apply::<L, C, F>(&self.f, &mut self.g, &self.layout, geom, coll, force);
        }
        std::mem::swap(&mut self.f, &mut self.g);
        self.steps += 1;
    }

    /// Total momentum sum f c of the post-collision populations of fluid cells (lattice
    /// units), added plane by plane in order.
    pub fn momentum(&self) -> [f64; 3] {
        let d = self.dims();
        let plane = self.layout.z_stride;
        let sums: Vec<[f64; 3]> = self
            .f
            .par_chunks(plane)
            .enumerate()
            .map(|(z, pl)| {
                let mut s = [0.0; 3];
                for y in 0..d.ny {
                    for &(x0, x1) in self.geometry.runs(z * d.ny + y) {
                        for q in 0..L::Q {
                            let base = self.layout.index(0, q, y, 0);
                            let f: f64 = pl[base + x0 as usize..base + x1 as usize].iter().sum();
                            for (k, sk) in s.iter_mut().enumerate() {
                                *sk += L::C[q][k] as f64 * f;
                            }
                        }
                    }
                }
                s
            })
            .collect();
        let mut t = [0.0; 3];
        for s in sums {
            for k in 0..3 {
                t[k] += s[k];
            }
        }
        t
    }

    /// `n` steps.
    pub fn run(&mut self, n: u64) {
        for _ in 0..n {
            self.step();
        }
    }

    /// Density and velocity (the forcing's velocity, e.g. u = (j + rho g/2)/rho for Guo) of the
    /// populations arriving at each cell, i.e. the state the next collision sees.
    pub fn fields(&self) -> Fields {
        let d = self.dims();
        let nxy = d.nx * d.ny;
        let per_plane: Vec<(Vec<f64>, Vec<[f64; 3]>)> = (0..d.nz)
            .into_par_iter()
            .map(|z| {
                let mut buf = vec![0.0; L::Q * d.nx];
                let mut rho = vec![0.0; nxy];
                let mut u = vec![[0.0; 3]; nxy];
                for y in 0..d.ny {
                    Self::pull_row(&self.f, &self.geometry, z, y, &mut buf);
                    for &(x0, x1) in self.geometry.runs(z * d.ny + y) {
                        for x in x0 as usize..x1 as usize {
                            let mut p = L::Pop::default();
                            for (q, v) in p.as_mut().iter_mut().enumerate() {
                                *v = buf[q * d.nx + x];
                            }
                            let (r, j) = density_momentum::<L>(&p);
                            let s = self.forcing.state(z * nxy + y * d.nx + x, r, j);
                            rho[y * d.nx + x] = r;
                            u[y * d.nx + x] = s.u;
                        }
                    }
                }
                (rho, u)
            })
            .collect();
        let mut f = Fields {
            rho: Vec::with_capacity(d.cells()),
            u: Vec::with_capacity(d.cells()),
        };
        for (r, u) in per_plane {
            f.rho.extend(r);
            f.u.extend(u);
        }
        // boundary nodes: the state they were last rebuilt with
        for (c, (rho, u)) in self.boundaries.last_states() {
            f.rho[c] = rho;
            f.u[c] = u;
        }
        f
    }

    /// Total mass: the sum of all populations of fluid cells (conserved to rounding by
    /// collision, streaming and resting bounce-back walls).
    pub fn mass(&self) -> f64 {
        let d = self.dims();
        let plane = self.layout.z_stride;
        let sums: Vec<f64> = self
            .f
            .par_chunks(plane)
            .enumerate()
            .map(|(z, pl)| {
                let mut s = 0.0;
                for y in 0..d.ny {
                    for &(x0, x1) in self.geometry.runs(z * d.ny + y) {
                        for q in 0..L::Q {
                            let base = self.layout.index(0, q, y, 0);
                            s += pl[base + x0 as usize..base + x1 as usize]
                                .iter()
                                .sum::<f64>();
                        }
                    }
                }
                s
            })
            .collect();
        sums.iter().sum()
    }

    /// The post-collision populations of every cell, value ((z Q + q) ny + y) nx + x: the
    /// layout without its padding, so that a checkpoint does not depend on it.
    pub fn populations(&self) -> Vec<f64> {
        let d = self.dims();
        let mut out = Vec::with_capacity(d.cells() * L::Q);
        for (z, q, y) in self.rows() {
            let i = self.layout.index(z, q, y, 0);
            out.extend_from_slice(&self.f[i..i + d.nx]);
        }
        out
    }

    /// Replaces the post-collision populations (in the order of [`Self::populations`]) and the
    /// step count by those of a saved run of the same lattice (checkpoints of runs that own a
    /// solver: bitwise continuation).
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
        for (k, (z, q, y)) in self.rows().enumerate() {
            let i = self.layout.index(z, q, y, 0);
            self.f[i..i + d.nx].copy_from_slice(&f[k * d.nx..(k + 1) * d.nx]);
        }
        self.steps = steps;
        Ok(())
    }

    /// Every row (z, q, y) of a population array, in storage order.
    fn rows(&self) -> impl Iterator<Item = (usize, usize, usize)> {
        let d = self.dims();
        (0..d.nz).flat_map(move |z| (0..L::Q).flat_map(move |q| (0..d.ny).map(move |y| (z, q, y))))
    }
}

/// How far ahead (values) a contiguous block prefetches each upstream row when the arrays
/// exceed the caches: past the row's end this is the next row of the same population.
const PREFETCH_AHEAD: usize = 32;

/// Prefetches what the halfway bounce-back links of row (y, z) will read: f*_opp(q) at the
/// link's own cell. Only that link reads this value (the neighbour it would stream to is
/// solid), so nothing else brings its line in, and unprefetched each link waited on memory
/// (pore mode, random mask, 64^3: a quarter of the kernel's samples on that one load).
/// Called a row ahead when the arrays exceed the caches.
#[inline(always)]
fn prefetch_bounce_back(src: &[f64], geom: &Geometry, layout: &Layout, z: usize, y: usize) {
    let here = layout.index(z, 0, y, 0);
    for l in geom.links(z * geom.dims.ny + y) {
        prefetch(
            src,
            here + opposite(l.q as usize) * layout.q_stride + l.x as usize,
        );
    }
}

/// Asks for the cache line of `s[i]` (into L1); `i` may lie past the end of `s` (nothing is
/// read). No operation off x86-64.
#[inline(always)]
fn prefetch(s: &[f64], i: usize) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing and cannot fault; the address is only computed
    // (wrapping), never dereferenced.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            s.as_ptr().wrapping_add(i) as *const i8,
        )
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (s, i);
}

/// Moves `first` on past the links (sorted by x) of cells before `x`.
#[inline(always)]
fn skip_links_before(links: &[Link], first: &mut usize, x: usize) {
    while *first < links.len() && (links[*first].x as usize) < x {
        *first += 1;
    }
}

/// The periodic upstream coordinate v - c of v in 0..n, for c in {-1, 0, 1}.
#[inline(always)]
fn upstream(v: usize, c: i32, n: usize) -> usize {
    match c {
        0 => v,
        1 if v == 0 => n - 1,
        1 => v - 1,
        _ if v + 1 == n => 0,
        _ => v + 1,
    }
}

/// Superficial mean velocity: the sum of fluid velocities over all cells (solid ones count as
/// zero) divided by the cell count, added plane by plane in order.
pub fn superficial_mean(f: &Fields) -> [f64; 3] {
    let n = f.u.len() as f64;
    let mut s = [0.0; 3];
    for u in &f.u {
        s[0] += u[0];
        s[1] += u[1];
        s[2] += u[2];
    }
    [s[0] / n, s[1] / n, s[2] / n]
}

#[cfg(test)]
mod kernel_tests {
    use super::*;
    use crate::lbm::collision::{relax_cell, Bgk, Trt};
    use crate::lbm::forcing::{BodyForce, Porous};
    use crate::lbm::lattice::{D3Q15, D3Q19};
    use crate::lbm::walls::WallFractions;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Every (z, q, y, x) has its own index below `values()`, rows start on cache lines where
    /// nx is a multiple of 8, and where ny nx is a multiple of 16 the population planes are an
    /// odd number of cache lines apart (so the Q rows a block reads spread over the sets).
    #[test]
    fn layout_indices_distinct_and_planes_odd_lines_apart() {
        for (n, q) in [
            ((4, 4, 4), 15),
            ((8, 8, 3), 19),
            ((5, 3, 2), 15),
            ((16, 8, 2), 19),
        ] {
            let d = Dims::new(n.0, n.1, n.2).unwrap();
            let l = Layout::new(&d, q);
            let mut seen = vec![false; l.values()];
            for z in 0..d.nz {
                for qq in 0..q {
                    for y in 0..d.ny {
                        for x in 0..d.nx {
                            let i = l.index(z, qq, y, x);
                            assert!(!seen[i], "{n:?} index {i} twice");
                            seen[i] = true;
                        }
                    }
                }
            }
            if d.nx.is_multiple_of(8) {
                assert_eq!(l.index(1, 3, 2, 0) % 8, 0, "{n:?}");
            }
            if (d.ny * d.nx).is_multiple_of(16) {
                assert_eq!((l.q_stride / 8) % 2, 1, "{n:?}");
            }
        }
    }

    /// One step cell by cell, the plainest form of the kernel's arithmetic: the pulled
    /// populations of [`Solver::pull_row`], the moments over the pairs, the forcing's `state`
    /// and [`relax_cell`], all on one f64 at a time; no blocks, no vector loads.
    fn reference_step<L: Lattice, C: Collision, F: Forcing>(s: &Solver<L, C, F>) -> Vec<f64> {
        let d = s.dims();
        let mut out = vec![0.0; s.layout.values()];
        let mut buf = vec![0.0; L::Q * d.nx];
        let mut post = [0.0; QMAX];
        for z in 0..d.nz {
            for y in 0..d.ny {
                Solver::<L, C, F>::pull_row(&s.f, &s.geometry, z, y, &mut buf);
                for &(x0, x1) in s.geometry.runs(z * d.ny + y) {
                    for x in x0 as usize..x1 as usize {
                        let mut pre = [0.0; QMAX];
                        for (q, p) in pre.iter_mut().enumerate().take(L::Q) {
                            *p = buf[q * d.nx + x];
                        }
                        let (rho, j) = Pairs::of::<L>(&pre).moments::<L>();
                        let st = s.forcing.state(d.cell(x, y, z), rho, j);
                        relax_cell::<L, C, F>(&s.collision, rho, &st, &pre, &mut post);
                        for q in 0..L::Q {
                            out[s.layout.index(z, q, y, x)] = post[q];
                        }
                    }
                }
            }
        }
        out
    }

    /// `populations` gives cells x Q values in the unpadded order whatever the padding, and
    /// `restore_populations` puts them back: a restored solver steps to the same bits.
    #[test]
    fn populations_round_trip_through_the_padded_layout() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let d = Dims::new(8, 8, 3).unwrap();
        let new = || {
            Solver::<D3Q19, _, _>::new(
                Geometry::open::<D3Q19>(d),
                Trt::magic(0.7),
                BodyForce {
                    g: [1e-5, 0.0, 0.0],
                },
            )
            .unwrap()
        };
        let mut a = new();
        assert!(
            a.layout.values() > d.cells() * 19,
            "8 x 8 planes are padded"
        );
        let rho: Vec<f64> = (0..d.cells()).map(|_| rng.gen_range(0.9..1.1)).collect();
        a.init(|c| (rho[c], [0.01, -0.02, 0.03]));
        a.step();
        let saved = a.populations();
        assert_eq!(saved.len(), d.cells() * 19);
        assert_eq!(
            saved[(19 + 2) * 64 + 8 + 3],
            a.f[a.layout.index(1, 2, 1, 3)]
        );
        let mut b = new();
        b.restore_populations(&saved, a.steps()).unwrap();
        a.step();
        b.step();
        assert_eq!(a.populations(), b.populations());
        assert!(b.restore_populations(&saved[1..], 0).is_err());
    }

    /// Three steps of the block kernel give the bits of three reference steps.
    fn check<L: Lattice, C: Collision, F: Forcing>(mut s: Solver<L, C, F>, rng: &mut ChaCha8Rng) {
        let a = 0.05;
        let u: Vec<[f64; 3]> = (0..s.dims().cells())
            .map(|_| [0; 3].map(|_| rng.gen_range(-a..a)))
            .collect();
        let rho: Vec<f64> = (0..s.dims().cells())
            .map(|_| rng.gen_range(0.95..1.05))
            .collect();
        s.init(|c| (rho[c], u[c]));
        for step in 0..3 {
            let want = reference_step(&s);
            // the non-temporal stores on every other step
            s.set_streaming_stores(Some(step % 2 == 0));
            s.step();
            let got = &s.f[..];
            let bad = got
                .iter()
                .zip(&want)
                .position(|(g, w)| g.to_bits() != w.to_bits());
            assert!(
                bad.is_none(),
                "{} {} {} {:?}, step {step}: population {} is {:e}, the reference {:e}",
                L::NAME,
                C::NAME,
                F::NAME,
                s.dims(),
                bad.unwrap(),
                got[bad.unwrap()],
                want[bad.unwrap()]
            );
        }
    }

    fn geometry<L: Lattice>(d: Dims, solid_fraction: f64, rng: &mut ChaCha8Rng) -> Geometry {
        let mask: Vec<bool> = (0..d.cells())
            .map(|_| rng.gen_bool(solid_fraction))
            .collect();
        // curved walls (CLI) on the links of every other fluid cell, at fractions spread over
        // (0, 1]
        let fractions = WallFractions::from_crossings(d, &mask, |x, c| {
            let h = x[0] * 7.31 + x[1] * 3.17 + x[2] * 1.93 + (c[0] + 2 * c[1] + 4 * c[2]) as f64;
            ((x[0] + x[1]) as usize % 2 == 1).then(|| 0.05 + 0.95 * h.fract())
        })
        .unwrap();
        // a moving solid (Ladd's delta on its links)
        Geometry::with_walls::<L>(
            d,
            mask,
            |c| {
                if c % 7 == 0 {
                    [0.01, -0.02, 0.0]
                } else {
                    [0.0; 3]
                }
            },
            Some(&fractions),
        )
        .unwrap()
    }

    fn porous(cells: usize, moving: bool, rng: &mut ChaCha8Rng) -> Porous {
        let mut p = Porous::clear(cells, 0.1, [1e-5, -2e-6, 3e-6], true);
        for c in 0..cells {
            p.set(
                c,
                rng.gen_range(0.3..=1.0),
                10f64.powf(rng.gen_range(-2.0..3.0)),
            )
            .unwrap();
            if moving && c % 3 == 0 {
                p.set_matrix_velocity(c, [0.01, 0.0, -0.005]).unwrap();
            }
        }
        p
    }

    fn lattice<L: Lattice>(rng: &mut ChaCha8Rng) {
        // rows of whole blocks (aligned, wrapped lanes at both ends), a ragged row, a row of
        // one block (no contiguous block) and of a block and one cell
        for nx in [16, 24, 13, 8, 9] {
            let d = Dims::new(nx, 5, 4).unwrap();
            for solid in [0.0, 0.3, 0.7] {
                let g = geometry::<L>(d, solid, rng);
                let body = BodyForce {
                    g: [1e-5, 2e-6, -3e-6],
                };
                check(
                    Solver::<L, _, _>::new(g.clone(), Bgk::from_tau(0.8), body).unwrap(),
                    rng,
                );
                check(
                    Solver::<L, _, _>::new(g.clone(), Trt::magic(0.7), body).unwrap(),
                    rng,
                );
                for moving in [false, true] {
                    let p = porous(d.cells(), moving, rng);
                    check(
                        Solver::<L, _, _>::new(g.clone(), Trt::magic(0.8), p).unwrap(),
                        rng,
                    );
                }
            }
        }
    }

    /// The block kernel (contiguous blocks with wrapped end lanes, gathered blocks, aligned
    /// storage, ordinary and non-temporal stores, the Guo–Zhao block state with and without a moving matrix) changes no bit
    /// of the cell-by-cell arithmetic, on both lattices, both collisions, open and
    /// porous-solid geometries, whichever vector path the CPU takes.
    #[test]
    fn block_kernel_equals_cell_by_cell_reference_bitwise() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        lattice::<D3Q15>(&mut rng);
        lattice::<D3Q19>(&mut rng);
    }
}
