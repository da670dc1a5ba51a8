//! The fused stream-and-collide kernel (pull scheme, two population arrays), monomorphised for
//! each (lattice, collision, forcing): `Solver<D3Q19, Trt, Porous>` is one kernel, with no
//! per-cell branch on the choice.
//!
//! Storage is a structure of arrays in z-planes: population q of cell (x, y, z) is at
//! `((z Q + q) ny + y) nx + x`, so each plane (all q) is one contiguous chunk that one rayon
//! task writes. A step pulls, for every row, the Q upstream rows into a small buffer (periodic
//! wrap in x by three slice copies), overwrites the bounce-back links of the row
//! (f_q(x) = f*_opp(q)(x) + delta; halfway bounce-back, seed 002 ref. 12 and Ladd 1994), then
//! collides the fluid runs. Every cell's update reads only the previous array, so the result
//! is the same at any thread count; sums (mass, mean velocity) are taken per plane and added
//! in plane order.

use super::boundary::Boundaries;
use super::collision::{equilibrium, relax_run, Collision, RowState};
use super::forcing::Forcing;
use super::geometry::{Dims, Geometry};
use super::lattice::{opposite, Lattice};
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

/// One z-plane of a [`Record`].
type PlaneRecord<'a> = (&'a mut [f64], &'a mut [[f64; 3]], &'a mut [[f64; 3]]);

/// Bytes a solver of `cells` cells with `q` populations allocates (two population arrays,
/// mask, and `extra_per_cell` bytes of forcing fields).
pub fn bytes_needed(cells: usize, q: usize, extra_per_cell: usize) -> u128 {
    cells as u128 * (2 * 8 * q as u128 + 1 + extra_per_cell as u128)
}

/// Memory this process may take: MemAvailable of /proc/meminfo, or None where unknown.
pub fn memory_available() -> Option<u128> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u128 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Refuses a lattice whose arrays need more than the available memory, before allocating.
pub fn check_memory(dims: Dims, q: usize, extra_per_cell: usize) -> Result<()> {
    let need = bytes_needed(dims.cells(), q, extra_per_cell);
    if let Some(avail) = memory_available() {
        if need > avail {
            return invalid(format!(
                "lattice {} x {} x {} with Q = {q} needs {:.2} GiB, more than the {:.2} GiB of \
                 memory available: use a coarser resolution",
                dims.nx,
                dims.ny,
                dims.nz,
                need as f64 / 1073741824.0,
                avail as f64 / 1073741824.0
            ));
        }
    }
    Ok(())
}

/// Lattice-Boltzmann solver for lattice `L`, collision `C`, forcing `F` (lattice units).
pub struct Solver<L: Lattice, C: Collision, F: Forcing> {
    pub geometry: Geometry,
    pub collision: C,
    pub forcing: F,
    /// Post-collision populations of the current step.
    f: Vec<f64>,
    /// Scratch for the next step.
    g: Vec<f64>,
    /// Velocity and density planes (non-equilibrium extrapolation), applied after the kernel.
    boundaries: Boundaries,
    steps: u64,
    _l: PhantomData<L>,
}

impl<L: Lattice, C: Collision, F: Forcing> Solver<L, C, F> {
    /// A solver at rest with density 1 (populations at their equilibrium). The memory check
    /// runs before anything is allocated.
    pub fn new(geometry: Geometry, collision: C, forcing: F) -> Result<Self> {
        let dims = geometry.dims;
        check_memory(dims, L::Q, 0)?;
        let n = dims.cells() * L::Q;
        let mut s = Solver {
            geometry,
            collision,
            forcing,
            f: vec![0.0; n],
            g: vec![0.0; n],
            boundaries: Boundaries::default(),
            steps: 0,
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

    pub fn dims(&self) -> Dims {
        self.geometry.dims
    }

    pub fn steps(&self) -> u64 {
        self.steps
    }

    #[inline(always)]
    fn index(d: &Dims, z: usize, q: usize, y: usize, x: usize) -> usize {
        ((z * L::Q + q) * d.ny + y) * d.nx + x
    }

    /// Sets every fluid cell to the equilibrium of `state(cell) = (rho, u)` (porosity from the
    /// forcing); solid cells hold zeros.
    pub fn init(&mut self, state: impl Fn(usize) -> (f64, [f64; 3])) {
        let d = self.dims();
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
                        self.f[Self::index(&d, z, q, y, x)] = *v;
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
        let nx = d.nx;
        for q in 0..L::Q {
            let c = L::C[q];
            let ys = (y + d.ny - (c[1].rem_euclid(d.ny as i32) as usize)) % d.ny;
            let zs = (z + d.nz - (c[2].rem_euclid(d.nz as i32) as usize)) % d.nz;
            let start = Self::index(&d, zs, q, ys, 0);
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
        for l in geom.links(r) {
            let (x, q) = (l.x as usize, l.q as usize);
            buf[q * nx + x] = src[Self::index(&d, z, opposite(q), y, x)] + l.delta;
        }
    }

    /// Density, momentum and the forcing's state of the run [x0, x1) of row (y, z) from the
    /// pulled populations `buf`, into `st` (entries 0..x1 - x0).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn row_state(
        force: &F,
        d: &Dims,
        buf: &[f64],
        z: usize,
        y: usize,
        x0: usize,
        x1: usize,
        st: &mut RowState,
    ) {
        let n = x1 - x0;
        let nx = d.nx;
        let (rho, j) = (&mut st.rho[..n], &mut st.a);
        rho.fill(0.0);
        for jc in j.iter_mut() {
            jc[..n].fill(0.0);
        }
        for q in 0..L::Q {
            let c = L::C[q];
            let (cx, cy, cz) = (c[0] as f64, c[1] as f64, c[2] as f64);
            let f = &buf[q * nx + x0..q * nx + x1];
            let [jx, jy, jz] = j;
            let (jx, jy, jz) = (&mut jx[..n], &mut jy[..n], &mut jz[..n]);
            for i in 0..n {
                rho[i] += f[i];
                jx[i] += cx * f[i];
                jy[i] += cy * f[i];
                jz[i] += cz * f[i];
            }
        }
        let base = (z * d.ny + y) * nx + x0;
        for i in 0..n {
            let s = force.state(base + i, st.rho[i], [st.a[0][i], st.a[1][i], st.a[2][i]]);
            st.set(i, st.rho[i], &s);
        }
    }

    /// Stream, bounce back and collide the z-plane `z` into `out` (its Q x ny x nx chunk).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn plane_body(
        src: &[f64],
        geom: &Geometry,
        coll: &C,
        force: &F,
        z: usize,
        out: &mut [f64],
        buf: &mut [f64],
        st: &mut RowState,
        rec: &mut Option<PlaneRecord>,
    ) {
        let d = geom.dims;
        for y in 0..d.ny {
            Self::pull_row(src, geom, z, y, buf);
            for &(x0, x1) in geom.runs(z * d.ny + y) {
                let (x0, x1) = (x0 as usize, x1 as usize);
                Self::row_state(force, &d, buf, z, y, x0, x1, st);
                if let Some((rho, u, a)) = rec {
                    for i in 0..x1 - x0 {
                        let k = y * d.nx + x0 + i;
                        rho[k] = st.rho[i];
                        u[k] = [st.u[0][i], st.u[1][i], st.u[2][i]];
                        a[k] = [st.a[0][i], st.a[1][i], st.a[2][i]];
                    }
                }
                if F::ACTIVE {
                    relax_run::<L, C, true>(coll, st, buf, d.nx, (x0, x1), out, d.ny, y);
                } else {
                    relax_run::<L, C, false>(coll, st, buf, d.nx, (x0, x1), out, d.ny, y);
                }
            }
        }
    }

    /// [`Self::plane_body`] compiled for AVX2 + FMA (chosen at run time where the CPU has them).
    ///
    /// # Safety
    /// The caller must have checked that the CPU supports avx2 and fma.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    #[allow(clippy::too_many_arguments)]
    unsafe fn plane_avx2(
        src: &[f64],
        geom: &Geometry,
        coll: &C,
        force: &F,
        z: usize,
        out: &mut [f64],
        buf: &mut [f64],
        st: &mut RowState,
        rec: &mut Option<PlaneRecord>,
    ) {
        Self::plane_body(src, geom, coll, force, z, out, buf, st, rec)
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
        let plane = L::Q * d.nx * d.ny;
        let nxy = d.nx * d.ny;
        let nx = d.nx;
        #[cfg(target_arch = "x86_64")]
        let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
        let (src, geom, coll, force) = (&self.f, &self.geometry, &self.collision, &self.forcing);
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
            .for_each_init(
                || (vec![0.0; L::Q * nx], RowState::with_len(nx)),
                |(buf, st), (z, (out, rec))| {
                    #[cfg(target_arch = "x86_64")]
                    if avx2 {
                        // SAFETY: avx2 and fma were detected above.
                        unsafe { Self::plane_avx2(src, geom, coll, force, z, out, buf, st, rec) };
                        return;
                    }
                    Self::plane_body(src, geom, coll, force, z, out, buf, st, rec)
                },
            );
        if !self.boundaries.is_empty() {
            self.boundaries
                .apply::<L, C, F>(&self.f, &mut self.g, geom, coll, force);
        }
        std::mem::swap(&mut self.f, &mut self.g);
        self.steps += 1;
    }

    /// Total momentum sum f c of the post-collision populations of fluid cells (lattice
    /// units), added plane by plane in order.
    pub fn momentum(&self) -> [f64; 3] {
        let d = self.dims();
        let plane = L::Q * d.nx * d.ny;
        let sums: Vec<[f64; 3]> = self
            .f
            .par_chunks(plane)
            .enumerate()
            .map(|(z, pl)| {
                let mut s = [0.0; 3];
                for y in 0..d.ny {
                    for &(x0, x1) in self.geometry.runs(z * d.ny + y) {
                        for q in 0..L::Q {
                            let base = (q * d.ny + y) * d.nx;
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
        let plane = L::Q * d.nx * d.ny;
        let sums: Vec<f64> = self
            .f
            .par_chunks(plane)
            .enumerate()
            .map(|(z, pl)| {
                let mut s = 0.0;
                for y in 0..d.ny {
                    for &(x0, x1) in self.geometry.runs(z * d.ny + y) {
                        for q in 0..L::Q {
                            let base = (q * d.ny + y) * d.nx;
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

    /// The raw post-collision populations (layout in the module docs).
    pub fn populations(&self) -> &[f64] {
        &self.f
    }

    /// Replaces the post-collision populations and the step count by those of a saved run
    /// of the same lattice (checkpoints of runs that own a solver: bitwise continuation).
    pub fn restore_populations(&mut self, f: &[f64], steps: u64) -> Result<()> {
        if f.len() != self.f.len() {
            return invalid(format!(
                "{} populations for a lattice of {} cells x {} velocities",
                f.len(),
                self.dims().cells(),
                L::Q
            ));
        }
        self.f.copy_from_slice(f);
        self.steps = steps;
        Ok(())
    }
}

/// rho = sum f, j = sum f c (seed 002 eq. 6-7).
#[inline(always)]
pub fn density_momentum<L: Lattice>(p: &L::Pop) -> (f64, [f64; 3]) {
    let p = p.as_ref();
    let mut rho = 0.0;
    let mut j = [0.0; 3];
    for (c, &f) in L::C.iter().zip(p) {
        rho += f;
        j[0] += c[0] as f64 * f;
        j[1] += c[1] as f64 * f;
        j[2] += c[2] as f64 * f;
    }
    (rho, j)
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
