//! The standard problems, each a small description that builds its [`Setup`] and runs the
//! driver, for any lattice and collision: steady channel flows (plain, porous, with a moving
//! wall; driven through inlet and outlet planes; between velocity planes on the nodes), the
//! square duct, the permeability of a periodic solid mask under a small body force, and the
//! Taylor-Green vortex decay.

use super::boundary::Face;
use super::driver::{run_steady, Steady, SteadyControl};
use super::engine::Lbm;
use super::flows::{channel_coordinate, channel_mask, duct_mask};
use super::geometry::Dims;
use super::setup::{
    Accel, CollisionModel, Domain, ForcingModel, Initial, LatticeKind, Medium, PlaneCondition,
    PlaneSpec, PlaneVelocity, Setup,
};
use crate::driver::{Hooks, NoHooks};
use crate::error::{invalid, Result};
use std::ops::RangeInclusive;

/// A flow uniform along x and z between two walls normal to y, whose answer is its steady x
/// velocity across the channel.
pub trait ChannelFlow {
    fn setup(&self, lattice: LatticeKind, collision: CollisionModel) -> Result<Setup>;

    /// The rows y of the profile.
    fn rows(&self) -> RangeInclusive<usize>;

    /// Runs to the steady state; the x velocity of the cells (0, y, 0), y in [`Self::rows`]
    /// (index y - first row), and the run.
    fn steady(
        &self,
        lattice: LatticeKind,
        collision: CollisionModel,
        ctl: SteadyControl,
        hooks: &mut dyn Hooks<Lbm>,
    ) -> Result<(Vec<f64>, Steady)> {
        let st = run_steady(&mut Lbm::new(self.setup(lattice, collision)?)?, ctl, hooks)?;
        let prof = self.rows().map(|y| st.fields.u[y][0]).collect();
        Ok((prof, st))
    }
}

/// A plane channel of width h cells (walls: rows 0 and h + 1), uniform along x and z.
#[derive(Debug, Clone, Copy)]
pub struct Channel {
    pub h: usize,
    /// Body force per unit mass along x (lattice units).
    pub g: f64,
    /// Velocity of the upper wall along x (lattice units; 0: resting).
    pub wall_u: f64,
    /// Uniform porous medium (eps, K in lattice units, Forchheimer on) or None for clear fluid.
    pub porous: Option<(f64, f64, bool)>,
}

impl Channel {
    /// The lattice: 1 x (h + 2) x 1.
    pub fn dims(&self) -> Result<Dims> {
        Dims::new(1, self.h + 2, 1)
    }
}

impl ChannelFlow for Channel {
    fn setup(&self, lattice: LatticeKind, collision: CollisionModel) -> Result<Setup> {
        let d = self.dims()?;
        let top = self.h + 1;
        let u = self.wall_u;
        let domain = Domain::with_solid(d, channel_mask(d))?.with_wall_velocity(|c| {
            if d.coords(c)[1] == top {
                [u, 0.0, 0.0]
            } else {
                [0.0; 3]
            }
        })?;
        let g = Accel::along_x(self.g)?;
        let forcing = match self.porous {
            None => ForcingModel::Body(g),
            Some((eps, k, forch)) => ForcingModel::Porous(Medium::uniform(g, eps, k, forch)?),
        };
        Ok(Setup::new(lattice, collision, domain).with_forcing(forcing))
    }

    /// The fluid rows y = 1..=h.
    fn rows(&self) -> RangeInclusive<usize> {
        1..=self.h
    }
}

/// Permeability of a periodic medium from Darcy's law under body force g along x.
#[derive(Debug, Clone)]
pub struct Permeability {
    /// k = nu <u> / g (lattice units, cells^2), <u> the superficial mean velocity.
    pub k: f64,
    /// The kinematic viscosity nu of the collision (lattice units).
    pub nu: f64,
    /// Fluid cells / all cells.
    pub porosity: f64,
    pub mean_u: f64,
    pub u_max: f64,
    pub steps: u64,
    pub residual: f64,
    pub converged: bool,
    pub steady: Steady,
    /// Relative change of the total mass over the run (rounding only for halfway
    /// bounce-back; curved walls, CLI, do not conserve mass exactly).
    pub mass_change: f64,
}

/// Runs `domain` under body force `g` (lattice units) along x to steady state. Refuses a
/// domain without fluid, or whose fluid does not wrap round the box along x, as permeability
/// 0, before the lattice is built.
pub fn permeability(
    lattice: LatticeKind,
    collision: CollisionModel,
    domain: Domain,
    g: f64,
    ctl: SteadyControl,
    hooks: &mut dyn Hooks<Lbm>,
) -> Result<Permeability> {
    let fluid = domain.fluid_cells();
    if fluid == 0 {
        return invalid("the solid mask has no fluid cell: permeability is 0 (no flow path)");
    }
    if !domain.percolates(lattice, 0) {
        return invalid(
            "no fluid path wraps round the periodic box along x (the pores are isolated \
             pockets): permeability is 0 (no flow path)",
        );
    }
    let porosity = fluid as f64 / domain.dims().cells() as f64;
    let body = ForcingModel::Body(Accel::along_x(g)?);
    let mut lbm = Lbm::new(Setup::new(lattice, collision, domain).with_forcing(body))?;
    let nu = lbm.nu();
    let mass0 = lbm.mass();
    let st = run_steady(&mut lbm, ctl, hooks)?;
    let mass_change = lbm.mass() / mass0 - 1.0;
    Ok(Permeability {
        k: nu * st.mean_u[0] / g,
        nu,
        porosity,
        mean_u: st.mean_u[0],
        u_max: st.u_max,
        steps: st.steps,
        residual: st.residual,
        converged: st.converged,
        steady: st,
        mass_change,
    })
}

/// Viscosity recovered from the decay of a Taylor-Green vortex in the periodic n x n x 1 box:
/// u = U0 (-cos kx sin ky, sin kx cos ky), k = 2 pi / n, whose kinetic energy decays as
/// exp(-4 nu k^2 t); nu = ln(E(t1)/E(t2)) / (4 k^2 (t2 - t1)).
pub fn taylor_green_viscosity(
    lattice: LatticeKind,
    collision: CollisionModel,
    n: usize,
    u0: f64,
    (t1, t2): (u64, u64),
) -> Result<f64> {
    let d = Dims::new(n, n, 1)?;
    let k = 2.0 * std::f64::consts::PI / n as f64;
    let (rho, u) = (0..d.cells())
        .map(|c| {
            let p = d.coords(c);
            let (x, y) = (k * p[0] as f64, k * p[1] as f64);
            // pressure -U0^2/4 (cos 2kx + cos 2ky), rho = 1 + 3 p
            let rho = 1.0 - 0.75 * u0 * u0 * ((2.0 * x).cos() + (2.0 * y).cos());
            (rho, [-u0 * x.cos() * y.sin(), u0 * x.sin() * y.cos(), 0.0])
        })
        .unzip();
    let vortex =
        Setup::new(lattice, collision, Domain::open(d)).with_initial(Initial::State { rho, u });
    let mut lbm = Lbm::new(vortex)?;
    let energy = |s: &Lbm| -> f64 {
        s.fields()
            .u
            .iter()
            .map(|u| u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
            .sum()
    };
    lbm.run(t1)?;
    let e1 = energy(&lbm);
    lbm.run(t2 - t1)?;
    let e2 = energy(&lbm);
    Ok((e1 / e2).ln() / (4.0 * k * k * (t2 - t1) as f64))
}

/// What drives a [`DrivenChannel`] at its inlet plane x = 0.
#[derive(Debug, Clone, Copy)]
pub enum Inlet {
    /// Inlet density (lattice units): the pressure drop is c_s^2 (rho_in - rho_out).
    Density(f64),
    /// Plane Poiseuille profile with this peak velocity (lattice units) at the inlet.
    Parabola(f64),
}

/// A plane channel of width h cells between halfway bounce-back walls (rows y = 0 and h + 1)
/// whose flow is driven through its ends: boundary planes (non-equilibrium extrapolation) at
/// x = 0 (the inlet) and x = length (the outlet, density `rho_out`); one cell along z.
#[derive(Debug, Clone, Copy)]
pub struct DrivenChannel {
    pub h: usize,
    /// Distance between the inlet and outlet planes (cells).
    pub length: usize,
    pub inlet: Inlet,
    pub rho_out: f64,
}

impl DrivenChannel {
    /// The lattice: (length + 1) x (h + 2) x 1.
    pub fn dims(&self) -> Result<Dims> {
        Dims::new(self.length + 1, self.h + 2, 1)
    }

    pub fn setup(&self, lattice: LatticeKind, collision: CollisionModel) -> Result<Setup> {
        if self.length < 2 {
            return invalid(format!(
                "channel length {} cells: must be at least 2 (inlet, outlet and one node between)",
                self.length
            ));
        }
        let d = self.dims()?;
        let h = self.h as f64;
        let inlet = match self.inlet {
            Inlet::Density(rho) => PlaneCondition::Density(rho),
            Inlet::Parabola(u_max) => {
                // one value per cell of the face x = 0, z-major
                let profile = (0..d.nz)
                    .flat_map(|_| 0..d.ny)
                    .map(|y| {
                        let y = channel_coordinate(y);
                        [4.0 * u_max * y * (h - y) / (h * h), 0.0, 0.0]
                    })
                    .collect();
                PlaneCondition::Velocity(PlaneVelocity::Field(profile))
            }
        };
        let end = |high: bool, condition: PlaneCondition| PlaneSpec {
            face: Face { axis: 0, high },
            condition,
        };
        let planes = vec![
            end(false, inlet),
            end(true, PlaneCondition::Density(self.rho_out)),
        ];
        let domain = Domain::with_solid(d, channel_mask(d))?;
        Ok(Setup::new(lattice, collision, domain).with_boundaries(planes))
    }

    /// Runs to steady state; returns the run (fields over the whole lattice). Refuses a
    /// channel with no fluid path from the inlet to the outlet.
    pub fn steady(
        &self,
        lattice: LatticeKind,
        collision: CollisionModel,
        ctl: SteadyControl,
        hooks: &mut dyn Hooks<Lbm>,
    ) -> Result<Steady> {
        let mut lbm = Lbm::new(self.setup(lattice, collision)?)?;
        if !lbm.planes_connected(0, 1) {
            return invalid(
                "no fluid path joins the inlet plane to the outlet plane: the flow rate is 0 \
                 (permeability 0)",
            );
        }
        run_steady(&mut lbm, ctl, hooks)
    }
}

/// Fully developed flow in a square duct of h x h fluid cells (walls: rows y, z = 0 and h + 1,
/// halfway bounce-back) under body force g along x, one cell along x. Returns the steady x
/// velocity of fluid cell (y, z), y, z = 1..=h, at index (z - 1) h + (y - 1), and the run.
pub fn square_duct(
    lattice: LatticeKind,
    collision: CollisionModel,
    (h, g): (usize, f64),
    ctl: SteadyControl,
) -> Result<(Vec<f64>, Steady)> {
    let d = Dims::new(1, h + 2, h + 2)?;
    let duct = Setup::new(lattice, collision, Domain::with_solid(d, duct_mask(d))?)
        .with_forcing(ForcingModel::Body(Accel::along_x(g)?));
    let st = run_steady(&mut Lbm::new(duct)?, ctl, &mut NoHooks)?;
    let mut u = Vec::with_capacity(h * h);
    for z in 1..=h {
        for y in 1..=h {
            u.push(st.fields.u[d.cell(0, y, z)][0]);
        }
    }
    Ok((u, st))
}

/// Plane Couette flow with its walls on the lattice nodes y = 0 (at rest) and y = h (sliding
/// at `u_wall` along x, lattice units), both velocity planes (non-equilibrium extrapolation),
/// filled with a uniform medium `porous` = (eps, K in lattice units, Forchheimer on); one cell
/// along x and z.
#[derive(Debug, Clone, Copy)]
pub struct NodeCouette {
    pub h: usize,
    pub u_wall: f64,
    pub porous: (f64, f64, bool),
}

impl NodeCouette {
    /// The lattice: 1 x (h + 1) x 1.
    pub fn dims(&self) -> Result<Dims> {
        Dims::new(1, self.h + 1, 1)
    }
}

impl ChannelFlow for NodeCouette {
    fn setup(&self, lattice: LatticeKind, collision: CollisionModel) -> Result<Setup> {
        let (eps, k, forch) = self.porous;
        let medium = Medium::uniform(Accel::new([0.0; 3])?, eps, k, forch)?;
        let wall = |high: bool, u: [f64; 3]| PlaneSpec {
            face: Face { axis: 1, high },
            condition: PlaneCondition::Velocity(PlaneVelocity::Uniform(u)),
        };
        let planes = vec![wall(false, [0.0; 3]), wall(true, [self.u_wall, 0.0, 0.0])];
        Ok(Setup::new(lattice, collision, Domain::open(self.dims()?))
            .with_forcing(ForcingModel::Porous(medium))
            .with_boundaries(planes))
    }

    /// The nodes y = 0..=h.
    fn rows(&self) -> RangeInclusive<usize> {
        0..=self.h
    }
}
