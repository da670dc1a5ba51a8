//! The run-time choice of a [`Setup`] (lattice, collision, forcing) turned into the compile-time
//! types of one monomorphised kernel, `Solver<L, C, F>`: [`build`] is the one place where the
//! choice is matched, and [`Kernel`] is what the engine asks of whichever kernel it built (one
//! call per step or per run of steps; the kernel itself has no branch on the choice).

use super::boundary::{connected, Boundaries, Plane};
use super::collision::{Bgk, Collision, Trt};
use super::fluid::{FluidSolver, AUTO_FLUID_FRACTION};
use super::forcing::{BodyForce, Forcing, Porous, Unforced};
use super::geometry::Geometry;
use super::lattice::{Lattice, D3Q15, D3Q19};
use super::setup::{
    CollisionKind, ForcingModel, Initial, LatticeKind, PlaneCondition, PlaneSpec, PlaneVelocity,
    Setup, Storage, Walls,
};
use super::solver::{Fields, Record, Solver};
use crate::error::{invalid, Result};
use std::any::Any;

/// What the engine asks of its kernel, whatever its lattice, collision and forcing.
pub(super) trait Kernel: Send + Sync {
    fn run(&mut self, steps: u64);
    fn step_recording(&mut self, rec: &mut Record) -> Result<()>;
    fn steps(&self) -> u64;
    fn geometry(&self) -> &Geometry;
    fn fields(&self) -> Fields;
    fn mass(&self) -> f64;
    fn momentum(&self) -> [f64; 3];
    fn populations(&self) -> Vec<f64>;
    fn restore_populations(&mut self, f: &[f64], steps: u64) -> Result<()>;
    fn porous(&self) -> Option<&Porous>;
    fn porous_mut(&mut self) -> Option<&mut Porous>;
    fn streaming_stores(&self) -> bool;
    fn set_streaming_stores(&mut self, on: Option<bool>);
    /// Whether boundary planes `a` and `b` are joined through fluid along the lattice's links.
    fn planes_connected(&self, a: usize, b: usize) -> bool;
    /// Bytes of the populations, tables and geometry.
    fn bytes(&self) -> usize;
}

impl<L: Lattice, C: Collision + 'static, F: Forcing + 'static> Kernel for Solver<L, C, F> {
    fn run(&mut self, steps: u64) {
        Solver::run(self, steps)
    }
    fn step_recording(&mut self, rec: &mut Record) -> Result<()> {
        Solver::step_recording(self, rec)
    }
    fn steps(&self) -> u64 {
        Solver::steps(self)
    }
    fn geometry(&self) -> &Geometry {
        Solver::geometry(self)
    }
    fn fields(&self) -> Fields {
        Solver::fields(self)
    }
    fn mass(&self) -> f64 {
        Solver::mass(self)
    }
    fn momentum(&self) -> [f64; 3] {
        Solver::momentum(self)
    }
    fn populations(&self) -> Vec<f64> {
        Solver::populations(self)
    }
    fn restore_populations(&mut self, f: &[f64], steps: u64) -> Result<()> {
        Solver::restore_populations(self, f, steps)
    }
    fn porous(&self) -> Option<&Porous> {
        (self.forcing() as &dyn Any).downcast_ref::<Porous>()
    }
    fn porous_mut(&mut self) -> Option<&mut Porous> {
        (self.forcing_mut() as &mut dyn Any).downcast_mut::<Porous>()
    }
    fn streaming_stores(&self) -> bool {
        Solver::streaming_stores(self)
    }
    fn set_streaming_stores(&mut self, on: Option<bool>) {
        Solver::set_streaming_stores(self, on)
    }
    fn bytes(&self) -> usize {
        Solver::bytes(self)
    }
    fn planes_connected(&self, a: usize, b: usize) -> bool {
        let planes = self.boundaries().planes();
        match (planes.get(a), planes.get(b)) {
            (Some(pa), Some(pb)) => connected::<L>(self.geometry(), pa, pb),
            _ => false,
        }
    }
}

impl<L: Lattice, C: Collision + 'static, F: Forcing + 'static> Kernel for FluidSolver<L, C, F> {
    fn run(&mut self, steps: u64) {
        FluidSolver::run(self, steps)
    }
    fn step_recording(&mut self, rec: &mut Record) -> Result<()> {
        FluidSolver::step_recording(self, rec)
    }
    fn steps(&self) -> u64 {
        FluidSolver::steps(self)
    }
    fn geometry(&self) -> &Geometry {
        FluidSolver::geometry(self)
    }
    fn fields(&self) -> Fields {
        FluidSolver::fields(self)
    }
    fn mass(&self) -> f64 {
        FluidSolver::mass(self)
    }
    fn momentum(&self) -> [f64; 3] {
        FluidSolver::momentum(self)
    }
    fn populations(&self) -> Vec<f64> {
        FluidSolver::populations(self)
    }
    fn restore_populations(&mut self, f: &[f64], steps: u64) -> Result<()> {
        FluidSolver::restore_populations(self, f, steps)
    }
    fn porous(&self) -> Option<&Porous> {
        (self.forcing() as &dyn Any).downcast_ref::<Porous>()
    }
    fn porous_mut(&mut self) -> Option<&mut Porous> {
        (self.forcing_mut() as &mut dyn Any).downcast_mut::<Porous>()
    }
    fn streaming_stores(&self) -> bool {
        FluidSolver::streaming_stores(self)
    }
    fn set_streaming_stores(&mut self, on: Option<bool>) {
        FluidSolver::set_streaming_stores(self, on)
    }
    fn bytes(&self) -> usize {
        FluidSolver::bytes(self)
    }
    /// The fluid list runs without boundary planes.
    fn planes_connected(&self, _a: usize, _b: usize) -> bool {
        false
    }
}

/// Whether `setup`'s kernel stores the fluid nodes only ([`Storage`]): asked for, or `Auto`
/// at a fluid fraction of at most [`AUTO_FLUID_FRACTION`]; never with boundary planes.
fn fluid_list(storage: Storage, planes: bool, geometry: &Geometry) -> Result<bool> {
    match storage {
        Storage::Box => Ok(false),
        Storage::FluidList if planes => invalid(
            "the fluid-list kernel runs periodic boxes without boundary planes: take the box \
             kernel",
        ),
        Storage::FluidList => Ok(true),
        Storage::Auto => Ok(!planes
            && geometry.fluid_cells() > 0
            && geometry.fluid_cells() as f64 <= AUTO_FLUID_FRACTION * geometry.dims.cells() as f64),
    }
}

/// Builds the kernel of `setup`: the geometry (solid mask, wall links) for its lattice, the
/// boundary planes, the collision at its relaxation time and the forcing, then the initial
/// state. Refuses what only the built lattice shows (see [`Solver::new`],
/// [`Solver::with_boundaries`], [`Plane`]).
pub(super) fn build(setup: Setup) -> Result<Box<dyn Kernel>> {
    match setup.lattice {
        LatticeKind::D3Q15 => with_lattice::<D3Q15>(setup),
        LatticeKind::D3Q19 => with_lattice::<D3Q19>(setup),
    }
}

fn with_lattice<L: Lattice>(setup: Setup) -> Result<Box<dyn Kernel>> {
    let Setup {
        collision,
        forcing,
        domain,
        boundaries,
        initial,
        storage,
        ..
    } = setup;
    initial.check(domain.dims().cells())?;
    let (dims, solid, wall_velocity, walls) = domain.into_parts();
    let fractions = match &walls {
        Walls::Halfway => None,
        Walls::Interpolated(f) => Some(f),
    };
    let geometry = Geometry::with_walls::<L>(
        dims,
        solid,
        |c| wall_velocity.as_ref().map_or([0.0; 3], |v| v[c]),
        fractions,
    )?;
    let planes = boundaries
        .iter()
        .map(|p| plane(&geometry, p))
        .collect::<Result<Vec<_>>>()?;
    let fluid_list = fluid_list(storage, !planes.is_empty(), &geometry)?;
    let planes = Boundaries::new(planes)?;
    let parts = Parts {
        fluid_list,
        geometry,
        planes,
        initial,
        nu: collision.kernel_nu(),
    };
    let tau = collision.tau.get();
    match collision.kind {
        CollisionKind::Bgk => with_collision::<L, _>(parts, Bgk::from_tau(tau), forcing),
        CollisionKind::Trt => with_collision::<L, _>(parts, Trt::magic(tau), forcing),
    }
}

/// What a kernel is built from besides its collision and forcing.
struct Parts {
    /// Whether the kernel stores the fluid nodes only.
    fluid_list: bool,
    geometry: Geometry,
    planes: Boundaries,
    initial: Initial,
    /// The kernel's viscosity (lattice units), for the Guo-Zhao drag coefficients.
    nu: f64,
}

fn with_collision<L: Lattice, C: Collision + 'static>(
    parts: Parts,
    coll: C,
    forcing: ForcingModel,
) -> Result<Box<dyn Kernel>> {
    let cells = parts.geometry.dims.cells();
    match forcing {
        ForcingModel::None => finish::<L, C, _>(parts, coll, Unforced),
        ForcingModel::Body(g) => finish::<L, C, _>(parts, coll, BodyForce { g: g.get() }),
        ForcingModel::Porous(m) => {
            let medium = m.build(cells, parts.nu)?;
            finish::<L, C, _>(parts, coll, medium)
        }
    }
}

fn finish<L: Lattice, C: Collision + 'static, F: Forcing + 'static>(
    parts: Parts,
    coll: C,
    force: F,
) -> Result<Box<dyn Kernel>> {
    if parts.fluid_list {
        let mut s = FluidSolver::<L, C, F>::new(parts.geometry, coll, force)?;
        if let Initial::State { rho, u } = &parts.initial {
            s.init(|c| (rho[c], u[c]));
        }
        return Ok(Box::new(s));
    }
    let mut s =
        Solver::<L, C, F>::new(parts.geometry, coll, force)?.with_boundaries(parts.planes)?;
    if let Initial::State { rho, u } = &parts.initial {
        s.init(|c| (rho[c], u[c]));
    }
    Ok(Box::new(s))
}

/// The boundary plane of `spec` on `geom`.
fn plane(geom: &Geometry, spec: &PlaneSpec) -> Result<Plane> {
    let face = spec.face;
    match &spec.condition {
        PlaneCondition::Density(rho) => Plane::density(geom, face, *rho),
        PlaneCondition::Velocity(PlaneVelocity::Uniform(u)) => Plane::velocity(geom, face, |_| *u),
        PlaneCondition::Velocity(PlaneVelocity::Field(v)) => {
            let d = geom.dims;
            if v.len() != face.cells_in(&d) {
                return invalid(format!(
                    "boundary plane {}: {} velocities for a face of {} cells",
                    face.name(),
                    v.len(),
                    face.cells_in(&d)
                ));
            }
            Plane::velocity(geom, face, |p| v[face.index_of(&d, p)])
        }
    }
}
