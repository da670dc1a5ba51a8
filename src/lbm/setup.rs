//! What a lattice-Boltzmann run is, typed: the [`Setup`] that [`super::Lbm::new`] takes. Each
//! piece is an enum or a small type that checks itself once, in its constructor (as LAMMPS's
//! granular sub-models check their coefficients): the lattice ([`LatticeKind`]), the collision
//! with its relaxation time ([`CollisionModel`], [`Tau`]), the forcing ([`ForcingModel`]: none,
//! Guo body force, Guo-Zhao porous medium), the domain with its solid cells and the rule by
//! which fluid meets them ([`Domain`], [`Walls`]), the boundary planes ([`PlaneSpec`]) and the
//! initial state ([`Initial`]). Everything is in lattice units (dx = dt = 1); `units` converts
//! from SI. What only the built lattice can check (a boundary plane in the solid, the memory
//! the arrays need) is refused by `Lbm::new`.

use super::boundary::Face;
use super::collision::{Bgk, Collision, Trt};
use super::forcing::{check_permeability, check_porosity, BodyForce, Porous, Unforced};
use super::geometry::{percolates, Dims};
use super::lattice::{Lattice, D3Q15, D3Q19};
use super::units::{check_tau, nu_from_tau};
use super::walls::WallFractions;
use crate::error::{invalid, Error, Result};

/// The velocity set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LatticeKind {
    D3Q15,
    D3Q19,
}

impl LatticeKind {
    /// "D3Q15" or "D3Q19" (any case); `key` names the input in the message.
    pub fn parse(s: &str, key: &str) -> Result<LatticeKind> {
        match s.to_ascii_uppercase().as_str() {
            "D3Q15" => Ok(LatticeKind::D3Q15),
            "D3Q19" => Ok(LatticeKind::D3Q19),
            _ => invalid(format!("{key} = \"{s}\": must be \"D3Q15\" or \"D3Q19\"")),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            LatticeKind::D3Q15 => D3Q15::NAME,
            LatticeKind::D3Q19 => D3Q19::NAME,
        }
    }
    pub fn q(self) -> usize {
        match self {
            LatticeKind::D3Q15 => D3Q15::Q,
            LatticeKind::D3Q19 => D3Q19::Q,
        }
    }
    /// The lattice velocities c_q.
    pub fn velocities(self) -> &'static [[i32; 3]] {
        match self {
            LatticeKind::D3Q15 => D3Q15::C,
            LatticeKind::D3Q19 => D3Q19::C,
        }
    }
}

/// The collision operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CollisionKind {
    Bgk,
    /// TRT with Lambda = 3/16.
    Trt,
}

impl CollisionKind {
    /// "bgk" or "trt" (any case); `key` names the input in the message.
    pub fn parse(s: &str, key: &str) -> Result<CollisionKind> {
        match s.to_ascii_uppercase().as_str() {
            "BGK" => Ok(CollisionKind::Bgk),
            "TRT" => Ok(CollisionKind::Trt),
            _ => invalid(format!("{key} = \"{s}\": must be \"bgk\" or \"trt\"")),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            CollisionKind::Bgk => Bgk::NAME,
            CollisionKind::Trt => Trt::NAME,
        }
    }
}

/// The relaxation time of the even moments, tau >= [`super::units::TAU_MIN`] and finite
/// (seed 002 eq. 8: nu = (tau - 1/2)/3).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tau(f64);

impl Tau {
    /// Refuses tau below TAU_MIN (unstable) or not finite, with the rule.
    pub fn new(tau: f64) -> Result<Tau> {
        check_tau(tau)?;
        Ok(Tau(tau))
    }
    pub fn get(self) -> f64 {
        self.0
    }
    /// nu = (tau - 1/2)/3 (lattice units).
    pub fn nu(self) -> f64 {
        nu_from_tau(self.0)
    }
}

/// The collision and its relaxation time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CollisionModel {
    pub kind: CollisionKind,
    pub tau: Tau,
}

impl CollisionModel {
    pub fn new(kind: CollisionKind, tau: Tau) -> CollisionModel {
        CollisionModel { kind, tau }
    }

    pub fn name(&self) -> &'static str {
        self.kind.name()
    }

    /// The even rate the kernel relaxes with: omega+ = 1 / tau, as [`Bgk::from_tau`] and
    /// [`Trt::magic`] set it.
    pub fn omega_plus(&self) -> f64 {
        1.0 / self.tau.get()
    }

    /// The kinematic viscosity (lattice units) of the kernel's collision: nu = (tau' - 1/2)/3
    /// with tau' = 1 / omega+ as the kernel holds it. It is [`Tau::nu`] but for the last bit
    /// where 1 / (1 / tau) is not tau (tau = 0.9); the Guo-Zhao drag coefficients and the
    /// permeability k = nu <u> / g use this one.
    pub fn kernel_nu(&self) -> f64 {
        nu_from_tau(1.0 / self.omega_plus())
    }
}

/// A uniform acceleration (body force per unit mass, lattice units), every component finite.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Accel([f64; 3]);

impl Accel {
    pub fn new(g: [f64; 3]) -> Result<Accel> {
        if !g.iter().all(|v| v.is_finite()) {
            return invalid(format!(
                "body force {g:?} (lattice units): every component must be finite"
            ));
        }
        Ok(Accel(g))
    }
    /// `g` along x.
    pub fn along_x(g: f64) -> Result<Accel> {
        Accel::new([g, 0.0, 0.0])
    }
    pub fn get(self) -> [f64; 3] {
        self.0
    }
}

/// A Guo-Zhao porous medium (Guo & Zhao 2002; seed 002 eq. 10): the body force G, whether
/// Ergun's Forchheimer term is on, and the porosity eps and permeability K (lattice units)
/// every cell starts with: a clear fluid (eps = 1, K = infinity) unless given. Cells whose
/// medium changes while the flow runs are set through `Lbm::porous_mut`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Medium {
    g: Accel,
    forchheimer: bool,
    /// (eps, K) of every cell; None: clear fluid.
    fill: Option<(f64, f64)>,
}

impl Medium {
    /// Clear fluid everywhere (eps = 1, no drag) under the body force `g`.
    pub fn clear(g: Accel, forchheimer: bool) -> Medium {
        Medium {
            g,
            forchheimer,
            fill: None,
        }
    }

    /// Porosity `eps` in (0, 1] and permeability `k` > 0 (lattice units; infinity: no drag) in
    /// every cell.
    pub fn uniform(g: Accel, eps: f64, k: f64, forchheimer: bool) -> Result<Medium> {
        check_porosity(eps)
            .and_then(|_| check_permeability(k))
            .map_err(Error::InvalidInput)?;
        Ok(Medium {
            g,
            forchheimer,
            fill: Some((eps, k)),
        })
    }

    /// The porosity every cell starts with.
    pub fn porosity(&self) -> f64 {
        self.fill.map_or(1.0, |(eps, _)| eps)
    }

    /// The kernel's medium on `cells` cells for a fluid of viscosity `nu` (lattice units).
    pub(super) fn build(&self, cells: usize, nu: f64) -> Result<Porous> {
        let mut p = Porous::clear(cells, nu, self.g.get(), self.forchheimer);
        if let Some((eps, k)) = self.fill {
            for c in 0..cells {
                p.set(c, eps, k).map_err(Error::InvalidInput)?;
            }
        }
        Ok(p)
    }
}

/// What drives the fluid besides the boundaries.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ForcingModel {
    /// No force: u = j / rho.
    None,
    /// Uniform body force, Guo's scheme (Guo, Zheng & Shi 2002).
    Body(Accel),
    /// Guo-Zhao porous medium (Brinkman-Forchheimer) under its body force.
    Porous(Medium),
}

impl ForcingModel {
    pub fn name(&self) -> &'static str {
        use super::forcing::Forcing;
        match self {
            ForcingModel::None => Unforced::NAME,
            ForcingModel::Body(_) => BodyForce::NAME,
            ForcingModel::Porous(_) => Porous::NAME,
        }
    }
}

/// How fluid meets the solid cells of a [`Domain`].
#[derive(Debug, Clone, PartialEq)]
pub enum Walls {
    /// Halfway bounce-back: each fluid-solid link reflects midway between the two nodes (the
    /// walls are the solid cells' faces), with Ladd's (1994) term for a moving solid (seed 002
    /// ref. 12).
    Halfway,
    /// Curved walls: each link's wall at its own fraction q of the link (Ginzburg's central
    /// linear interpolation, [`super::walls`]); links without a fraction, or whose second
    /// fluid node is solid, bounce back halfway. Resting walls only.
    Interpolated(WallFractions),
}

/// Which wall rule a pore-resolving run asks for (the input's word for [`Walls`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WallRule {
    /// Halfway bounce-back on the voxels' faces.
    Staircase,
    /// Each link's wall where the particle surface cuts it (CLI).
    Interpolated,
}

impl WallRule {
    /// "staircase" or "interpolated" (any case); `key` names the input in the message.
    pub fn parse(s: &str, key: &str) -> Result<WallRule> {
        match s.to_ascii_lowercase().as_str() {
            "staircase" => Ok(WallRule::Staircase),
            "interpolated" => Ok(WallRule::Interpolated),
            _ => invalid(format!(
                "{key} = \"{s}\": must be \"staircase\" (halfway bounce-back) or \
                 \"interpolated\" (curved walls, CLI)"
            )),
        }
    }
    /// The domain's walls of this rule; `fractions` gives the wall fractions of the mask
    /// (called only for interpolated walls).
    pub fn walls(self, fractions: impl FnOnce() -> Result<WallFractions>) -> Result<Walls> {
        Ok(match self {
            WallRule::Staircase => Walls::Halfway,
            WallRule::Interpolated => Walls::Interpolated(fractions()?),
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            WallRule::Staircase => "staircase",
            WallRule::Interpolated => "interpolated",
        }
    }
}

/// The lattice's extent, its solid cells (with their velocities) and the wall rule. All
/// boundaries are periodic unless solid cells or boundary planes close them.
#[derive(Debug, Clone, PartialEq)]
pub struct Domain {
    dims: Dims,
    solid: Vec<bool>,
    /// Velocity of every cell (lattice units), read at solid cells; None: resting walls.
    wall_velocity: Option<Vec<[f64; 3]>>,
    walls: Walls,
}

impl Domain {
    /// All fluid, fully periodic.
    pub fn open(dims: Dims) -> Domain {
        Domain {
            dims,
            solid: vec![false; dims.cells()],
            wall_velocity: None,
            walls: Walls::Halfway,
        }
    }

    /// Solid where `solid` (one value per cell, index `Dims::cell`) is true; resting
    /// halfway bounce-back walls.
    pub fn with_solid(dims: Dims, solid: Vec<bool>) -> Result<Domain> {
        if solid.len() != dims.cells() {
            return invalid(format!(
                "solid mask has {} cells, the lattice {}",
                solid.len(),
                dims.cells()
            ));
        }
        Ok(Domain {
            dims,
            solid,
            wall_velocity: None,
            walls: Walls::Halfway,
        })
    }

    /// The solid cells move: `velocity(cell)` (lattice units, finite) is read at every solid
    /// cell.
    pub fn with_wall_velocity(mut self, velocity: impl Fn(usize) -> [f64; 3]) -> Result<Domain> {
        let mut v = vec![[0.0; 3]; self.dims.cells()];
        for (c, vc) in v.iter_mut().enumerate() {
            if self.solid[c] {
                *vc = velocity(c);
                if !vc.iter().all(|x| x.is_finite()) {
                    return invalid(format!(
                        "wall velocity {vc:?} of solid cell {:?} (lattice units): must be finite",
                        self.dims.coords(c)
                    ));
                }
            }
        }
        if matches!(self.walls, Walls::Interpolated(_)) {
            return invalid(
                "interpolated (curved) walls are for resting solids; moving solid cells take \
                 halfway bounce-back",
            );
        }
        self.wall_velocity = Some(v);
        Ok(self)
    }

    pub fn dims(&self) -> Dims {
        self.dims
    }
    pub fn solid(&self) -> &[bool] {
        &self.solid
    }
    pub fn walls(&self) -> &Walls {
        &self.walls
    }

    /// Sets the wall rule; refuses interpolated walls on moving solid cells (CLI is applied
    /// here to resting walls only).
    pub fn with_walls(mut self, walls: Walls) -> Result<Domain> {
        if matches!(walls, Walls::Interpolated(_)) && self.wall_velocity.is_some() {
            return invalid(
                "interpolated (curved) walls are for resting solids; moving solid cells take \
                 halfway bounce-back",
            );
        }
        self.walls = walls;
        Ok(self)
    }
    pub fn fluid_cells(&self) -> usize {
        self.solid.iter().filter(|&&s| !s).count()
    }

    /// Whether a fluid cluster joined along the links of `lattice` wraps round the periodic box
    /// along `axis` (without one a body force along it drives no steady flow).
    pub fn percolates(&self, lattice: LatticeKind, axis: usize) -> bool {
        percolates(self.dims, &self.solid, lattice.velocities(), axis)
    }

    /// The mask and the wall velocity of each cell, for the geometry.
    pub(super) fn into_parts(self) -> (Dims, Vec<bool>, Option<Vec<[f64; 3]>>, Walls) {
        (self.dims, self.solid, self.wall_velocity, self.walls)
    }
}

/// The velocity a velocity plane prescribes (lattice units).
#[derive(Debug, Clone, PartialEq)]
pub enum PlaneVelocity {
    /// The same at every node.
    Uniform([f64; 3]),
    /// One value per cell of the face, in the order of the cell index (values at solid cells
    /// are not read).
    Field(Vec<[f64; 3]>),
}

/// What a boundary plane prescribes.
#[derive(Debug, Clone, PartialEq)]
pub enum PlaneCondition {
    Velocity(PlaneVelocity),
    /// Density (pressure c_s^2 rho), uniform over the plane.
    Density(f64),
}

/// A boundary plane: a face of the box whose fluid nodes are rebuilt every step by
/// non-equilibrium extrapolation (Guo, Zheng & Shi 2002). Its values and its place in the
/// geometry (fluid nodes, two fluid nodes behind each, no node shared with another plane) are
/// checked when the lattice is built.
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneSpec {
    pub face: Face,
    pub condition: PlaneCondition,
}

/// The state the populations start from (at equilibrium).
#[derive(Debug, Clone, PartialEq)]
pub enum Initial {
    /// Density 1, at rest.
    Rest,
    /// Density and velocity of every cell (lattice units; index `Dims::cell`).
    State { rho: Vec<f64>, u: Vec<[f64; 3]> },
}

impl Initial {
    /// Refuses a state of another size than `cells`, a density that is not positive and
    /// finite, or a velocity that is not finite.
    pub(super) fn check(&self, cells: usize) -> Result<()> {
        let Initial::State { rho, u } = self else {
            return Ok(());
        };
        if rho.len() != cells || u.len() != cells {
            return invalid(format!(
                "initial state of {} densities and {} velocities for a lattice of {cells} cells",
                rho.len(),
                u.len()
            ));
        }
        if let Some(c) = (0..cells)
            .find(|&c| !(rho[c].is_finite() && rho[c] > 0.0 && u[c].iter().all(|v| v.is_finite())))
        {
            return invalid(format!(
                "initial state of cell {c}: density {} must be positive and finite, velocity \
                 {:?} finite",
                rho[c], u[c]
            ));
        }
        Ok(())
    }
}

/// Which cells the kernel stores: every cell of the box (the box kernel, [`super::solver`]),
/// or the fluid nodes only (the fluid-list kernel, [`super::fluid`]; periodic runs without
/// boundary planes). Both give the same bits; `Auto` takes the fluid list where the fluid
/// fraction is at most [`super::fluid::AUTO_FLUID_FRACTION`] and there are no planes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Storage {
    #[default]
    Auto,
    Box,
    FluidList,
}

impl Storage {
    pub fn parse(s: &str, key: &str) -> Result<Storage> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(Storage::Auto),
            "box" => Ok(Storage::Box),
            "fluid" | "fluid-list" => Ok(Storage::FluidList),
            _ => invalid(format!("{key} = {s}: must be auto, box or fluid")),
        }
    }
    pub fn name(self) -> &'static str {
        match self {
            Storage::Auto => "auto",
            Storage::Box => "box",
            Storage::FluidList => "fluid",
        }
    }
}

/// One lattice-Boltzmann run: lattice, collision, forcing, domain, boundary planes, initial
/// state and the kernel's storage.
#[derive(Debug, Clone, PartialEq)]
pub struct Setup {
    pub lattice: LatticeKind,
    pub collision: CollisionModel,
    pub forcing: ForcingModel,
    pub domain: Domain,
    pub boundaries: Vec<PlaneSpec>,
    pub initial: Initial,
    pub storage: Storage,
}

impl Setup {
    /// An unforced fluid at rest on `domain`, without boundary planes.
    pub fn new(lattice: LatticeKind, collision: CollisionModel, domain: Domain) -> Setup {
        Setup {
            lattice,
            collision,
            forcing: ForcingModel::None,
            domain,
            boundaries: Vec::new(),
            initial: Initial::Rest,
            storage: Storage::Auto,
        }
    }
    pub fn with_forcing(self, forcing: ForcingModel) -> Setup {
        Setup { forcing, ..self }
    }
    pub fn with_boundaries(self, boundaries: Vec<PlaneSpec>) -> Setup {
        Setup { boundaries, ..self }
    }
    pub fn with_initial(self, initial: Initial) -> Setup {
        Setup { initial, ..self }
    }
    pub fn with_storage(self, storage: Storage) -> Setup {
        Setup { storage, ..self }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel's collisions relax the even moments at 1 / tau, so that
    /// CollisionModel::kernel_nu is the viscosity of the built kernel to the bit.
    #[test]
    fn omega_plus_is_the_kernels() {
        for t in [0.505, 0.52, 0.6, 0.8, 0.9, 1.0, 1.5, 2.5] {
            let tau = Tau::new(t).unwrap();
            for kind in [CollisionKind::Bgk, CollisionKind::Trt] {
                let m = CollisionModel::new(kind, tau);
                let kernel = match kind {
                    CollisionKind::Bgk => Bgk::from_tau(t).omega_plus(),
                    CollisionKind::Trt => Trt::magic(t).omega_plus(),
                };
                assert_eq!(m.omega_plus().to_bits(), kernel.to_bits(), "{t}");
            }
        }
        // 1 / (1 / 0.9) is not 0.9: the two viscosities differ in the last bit there
        let m = CollisionModel::new(CollisionKind::Bgk, Tau::new(0.9).unwrap());
        assert!(m.kernel_nu() != m.tau.nu() && (m.kernel_nu() - m.tau.nu()).abs() < 1e-16);
    }

    /// Each piece refuses what it cannot be, naming the value and the rule.
    #[test]
    fn pieces_refuse_bad_values() {
        let e = Tau::new(0.5).unwrap_err().to_string();
        assert!(e.contains("tau = 0.5") && e.contains(">= 0.505"), "{e}");
        assert!(Tau::new(f64::NAN).is_err());
        let e = Accel::new([0.0, f64::INFINITY, 0.0])
            .unwrap_err()
            .to_string();
        assert!(e.contains("finite"), "{e}");
        let g = Accel::along_x(1e-6).unwrap();
        let e = Medium::uniform(g, 0.0, 1.0, true).unwrap_err().to_string();
        assert!(e.contains("eps = 0"), "{e}");
        let e = Medium::uniform(g, 0.5, -1.0, true).unwrap_err().to_string();
        assert!(e.contains("K = -1"), "{e}");
        assert!(Medium::uniform(g, 1.0, f64::INFINITY, false).is_ok());
        let d = Dims::new(2, 2, 2).unwrap();
        let e = Domain::with_solid(d, vec![false; 7])
            .unwrap_err()
            .to_string();
        assert!(e.contains("7 cells"), "{e}");
        let mut mask = vec![false; 8];
        mask[3] = true;
        let e = Domain::with_solid(d, mask)
            .unwrap()
            .with_wall_velocity(|_| [f64::NAN, 0.0, 0.0])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("wall velocity") && e.contains("[1, 1, 0]"),
            "{e}"
        );
        let bad = Initial::State {
            rho: vec![1.0; 8],
            u: vec![[0.0; 3]; 7],
        };
        assert!(bad
            .check(8)
            .unwrap_err()
            .to_string()
            .contains("7 velocities"));
    }
}
