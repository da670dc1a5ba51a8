//! The standard problems, written once generically in the lattice and collision: steady
//! channel flows (plain, porous, with a moving wall), the permeability of a periodic solid
//! mask under a small body force, and the Taylor-Green vortex decay.

use super::boundary::{connected, Boundaries, Face, Plane};
use super::flows::{channel_mask, duct_mask};
use super::geometry::{Dims, Geometry};
use super::steady::{run_steady, Steady, SteadyControl};
use super::{BodyForce, Collision, Lattice, Porous, Solver, Unforced};
use crate::error::{invalid, Result};

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
    fn geometry<L: Lattice>(&self) -> Result<Geometry> {
        let d = Dims::new(1, self.h + 2, 1)?;
        let top = self.h + 1;
        let u = self.wall_u;
        Geometry::new::<L>(d, channel_mask(d), move |c| {
            if d.coords(c)[1] == top {
                [u, 0.0, 0.0]
            } else {
                [0.0; 3]
            }
        })
    }

    /// The steady x velocity of fluid rows y = 1..=h (index y - 1), and the run's report;
    /// `progress(steps, residual)` is called after each check.
    pub fn steady<L: Lattice, C: Collision>(
        &self,
        coll: C,
        ctl: SteadyControl,
        progress: impl FnMut(u64, f64),
    ) -> Result<(Vec<f64>, Steady)> {
        let geom = self.geometry::<L>()?;
        let st = match self.porous {
            None => {
                let mut s = Solver::<L, C, BodyForce>::new(
                    geom,
                    coll,
                    BodyForce {
                        g: [self.g, 0.0, 0.0],
                    },
                )?;
                run_steady(&mut s, ctl, progress)?
            }
            Some((eps, k, forch)) => {
                let cells = geom.dims.cells();
                let nu = (1.0 / coll.omega_plus() - 0.5) / 3.0;
                let mut p = Porous::clear(cells, nu, [self.g, 0.0, 0.0], forch);
                for c in 0..cells {
                    p.set(c, eps, k).map_err(crate::Error::InvalidInput)?;
                }
                let mut s = Solver::<L, C, Porous>::new(geom, coll, p)?;
                s.init(|_| (1.0, [0.0; 3]));
                run_steady(&mut s, ctl, progress)?
            }
        };
        let prof = (1..=self.h).map(|y| st.fields.u[y][0]).collect();
        Ok((prof, st))
    }
}

/// Permeability of a periodic medium from Darcy's law under body force g along x.
#[derive(Debug, Clone)]
pub struct Permeability {
    /// k = nu <u> / g (lattice units, cells^2), <u> the superficial mean velocity.
    pub k: f64,
    /// Fluid cells / all cells.
    pub porosity: f64,
    pub mean_u: f64,
    pub u_max: f64,
    pub steps: u64,
    pub residual: f64,
    pub converged: bool,
    pub steady: Steady,
}

/// Runs `geom` under body force `g` (lattice units) along x to steady state.
pub fn permeability<L: Lattice, C: Collision>(
    geom: Geometry,
    coll: C,
    g: f64,
    ctl: SteadyControl,
    progress: impl FnMut(u64, f64),
) -> Result<Permeability> {
    if geom.fluid_cells() == 0 {
        return invalid("the solid mask has no fluid cell: permeability is 0 (no flow path)");
    }
    if !geom.percolates::<L>(0) {
        return invalid(
            "no fluid path wraps round the periodic box along x (the pores are isolated \
             pockets): permeability is 0 (no flow path)",
        );
    }
    let porosity = geom.fluid_cells() as f64 / geom.dims.cells() as f64;
    let nu = (1.0 / coll.omega_plus() - 0.5) / 3.0;
    let mut s = Solver::<L, C, BodyForce>::new(geom, coll, BodyForce { g: [g, 0.0, 0.0] })?;
    let st = run_steady(&mut s, ctl, progress)?;
    Ok(Permeability {
        k: nu * st.mean_u[0] / g,
        porosity,
        mean_u: st.mean_u[0],
        u_max: st.u_max,
        steps: st.steps,
        residual: st.residual,
        converged: st.converged,
        steady: st,
    })
}

/// Viscosity recovered from the decay of a Taylor-Green vortex in the periodic n x n x 1 box:
/// u = U0 (-cos kx sin ky, sin kx cos ky), k = 2 pi / n, whose kinetic energy decays as
/// exp(-4 nu k^2 t); nu = ln(E(t1)/E(t2)) / (4 k^2 (t2 - t1)).
pub fn taylor_green_viscosity<L: Lattice, C: Collision>(
    coll: C,
    n: usize,
    u0: f64,
    t1: u64,
    t2: u64,
) -> Result<f64> {
    let d = Dims::new(n, n, 1)?;
    let k = 2.0 * std::f64::consts::PI / n as f64;
    let mut s = Solver::<L, C, Unforced>::new(Geometry::open::<L>(d), coll, Unforced)?;
    s.init(|c| {
        let p = d.coords(c);
        let (x, y) = (k * p[0] as f64, k * p[1] as f64);
        // pressure -U0^2/4 (cos 2kx + cos 2ky), rho = 1 + 3 p
        let rho = 1.0 - 0.75 * u0 * u0 * ((2.0 * x).cos() + (2.0 * y).cos());
        (rho, [-u0 * x.cos() * y.sin(), u0 * x.sin() * y.cos(), 0.0])
    });
    let energy = |s: &Solver<L, C, Unforced>| -> f64 {
        s.fields()
            .u
            .iter()
            .map(|u| u[0] * u[0] + u[1] * u[1] + u[2] * u[2])
            .sum()
    };
    s.run(t1);
    let e1 = energy(&s);
    s.run(t2 - t1);
    let e2 = energy(&s);
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

    /// Runs to steady state; returns the run (fields over the whole lattice);
    /// `progress(steps, residual)` is called after each check.
    pub fn steady<L: Lattice, C: Collision>(
        &self,
        coll: C,
        ctl: SteadyControl,
        progress: impl FnMut(u64, f64),
    ) -> Result<Steady> {
        if self.length < 2 {
            return invalid(format!(
                "channel length {} cells: must be at least 2 (inlet, outlet and one node between)",
                self.length
            ));
        }
        let d = self.dims()?;
        let geom = Geometry::new::<L>(d, channel_mask(d), |_| [0.0; 3])?;
        let h = self.h as f64;
        let inlet = match self.inlet {
            Inlet::Density(rho) => Plane::density(
                &geom,
                Face {
                    axis: 0,
                    high: false,
                },
                rho,
            )?,
            Inlet::Parabola(u_max) => Plane::velocity(
                &geom,
                Face {
                    axis: 0,
                    high: false,
                },
                |p| {
                    let y = super::flows::channel_coordinate(p[1]);
                    [4.0 * u_max * y * (h - y) / (h * h), 0.0, 0.0]
                },
            )?,
        };
        let outlet = Plane::density(
            &geom,
            Face {
                axis: 0,
                high: true,
            },
            self.rho_out,
        )?;
        if !connected::<L>(&geom, &inlet, &outlet) {
            return invalid(
                "no fluid path joins the inlet plane to the outlet plane: the flow rate is 0 \
                 (permeability 0)",
            );
        }
        let b = Boundaries::new(vec![inlet, outlet])?;
        let mut s = Solver::<L, C, Unforced>::new(geom, coll, Unforced)?.with_boundaries(b)?;
        run_steady(&mut s, ctl, progress)
    }
}

/// Fully developed flow in a square duct of h x h fluid cells (walls: rows y, z = 0 and h + 1,
/// halfway bounce-back) under body force g along x, one cell along x. Returns the steady x
/// velocity of fluid cell (y, z), y, z = 1..=h, at index (z - 1) h + (y - 1), and the run.
pub fn square_duct<L: Lattice, C: Collision>(
    h: usize,
    g: f64,
    coll: C,
    ctl: SteadyControl,
) -> Result<(Vec<f64>, Steady)> {
    let d = Dims::new(1, h + 2, h + 2)?;
    let geom = Geometry::new::<L>(d, duct_mask(d), |_| [0.0; 3])?;
    let mut s = Solver::<L, C, BodyForce>::new(geom, coll, BodyForce { g: [g, 0.0, 0.0] })?;
    let st = run_steady(&mut s, ctl, |_, _| {})?;
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
/// along x and z. Returns the steady x velocity at the nodes y = 0..=h and the run;
/// `progress(steps, residual)` is called after each check.
pub fn node_couette<L: Lattice, C: Collision>(
    h: usize,
    u_wall: f64,
    porous: (f64, f64, bool),
    coll: C,
    ctl: SteadyControl,
    progress: impl FnMut(u64, f64),
) -> Result<(Vec<f64>, Steady)> {
    let d = Dims::new(1, h + 1, 1)?;
    let geom = Geometry::open::<L>(d);
    let nu = (1.0 / coll.omega_plus() - 0.5) / 3.0;
    let (eps, k, forch) = porous;
    let mut p = Porous::clear(d.cells(), nu, [0.0; 3], forch);
    for c in 0..d.cells() {
        p.set(c, eps, k).map_err(crate::Error::InvalidInput)?;
    }
    let lower = Plane::velocity(
        &geom,
        Face {
            axis: 1,
            high: false,
        },
        |_| [0.0; 3],
    )?;
    let upper = Plane::velocity(
        &geom,
        Face {
            axis: 1,
            high: true,
        },
        |_| [u_wall, 0.0, 0.0],
    )?;
    let b = Boundaries::new(vec![lower, upper])?;
    let mut s = Solver::<L, C, Porous>::new(geom, coll, p)?.with_boundaries(b)?;
    let st = run_steady(&mut s, ctl, progress)?;
    let prof = (0..=h).map(|y| st.fields.u[y][0]).collect();
    Ok((prof, st))
}
