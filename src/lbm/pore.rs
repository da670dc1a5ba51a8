//! Pore-resolving mode: the solid mask of a particle configuration (porelab extended XYZ,
//! periodic box) and its permeability from Darcy's law; `porelab permeability`.
//!
//! A cell is solid when its centre lies inside a particle or one of its periodic images
//! (the shape's implicit function of `crate::shape`, evaluated in the body frame at the
//! minimum-image offset). Spheres, spherocylinders, ellipsoids and superquadrics are
//! voxelised; a superquadric's `superquadric_roundness` (e, n) is read as porelab writes it,
//! thesis eq. 4.3 with exponents (2/e, 2/e, 2/n) (OVITO's Superquadric for e = n). The Kozeny constant implied by k follows thesis 003 eq. 7.4:
//! k = (1 - phi)^3 nu^2 / (C_KC phi^2), nu = V/S (nu = D/6 for spheres: C_KC = 5 is the "180"
//! of the sphere form; nu = D/4 for long rods).

use super::choice::{dispatch, CollisionKind, Job, LatticeKind};
use super::geometry::{Dims, Geometry};
use super::problems::{permeability, Permeability};
use super::steady::{SteadyControl, SteadyProgress};
use super::units::describe;
use super::{Collision, Lattice};
use crate::error::{invalid, Result};
use crate::io::xyz::{self, Cell, XyzParticle};
use crate::shape::{ConvexShape, Ellipsoid, Sphere, Spherocylinder, Superquadric};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// One particle ready for voxelisation.
struct Placed {
    shape: Box<dyn ConvexShape>,
    centre: Vector3<f64>,
    to_body: nalgebra::UnitQuaternion<f64>,
    /// Particle surface area (None where no closed form is used).
    area: Option<f64>,
}

fn place(i: usize, p: &XyzParticle) -> Result<Placed> {
    let r = p.radius;
    let [a, b, c] = p.aspherical_shape;
    let (shape, area): (Box<dyn ConvexShape>, Option<f64>) = if p.cylinder_length > 0.0 {
        let l = p.cylinder_length;
        (
            Box::new(Spherocylinder::new(r, l)?),
            Some(4.0 * PI * r * r + 2.0 * PI * r * l),
        )
    } else if p.roundness != [1.0, 1.0] {
        // porelab's writer stores a superquadric of exponents g as (2/g_x, 2/g_z), g_y = g_x
        let [e, n] = p.roundness;
        if !(e > 0.0 && e <= 1.0 && n > 0.0 && n <= 1.0) {
            return invalid(format!(
                "particle {i} (species {}): superquadric_roundness {:?} must lie in (0, 1] \
                 (exponents 2/roundness >= 2: a convex superquadric)",
                p.species, p.roundness
            ));
        }
        let shape = Superquadric::new([a, b, c], [2.0 / e, 2.0 / e, 2.0 / n])
            .map_err(|err| crate::error::Error::InvalidInput(format!("particle {i}: {err}")))?;
        (Box::new(shape), None)
    } else if (a - r).abs() <= 1e-12 * r && (b - r).abs() <= 1e-12 * r && (c - r).abs() <= 1e-12 * r
    {
        (Box::new(Sphere::new(r)?), Some(4.0 * PI * r * r))
    } else {
        (Box::new(Ellipsoid::new([a, b, c])?), None)
    };
    Ok(Placed {
        shape,
        centre: p.position,
        to_body: p.orientation.inverse(),
        area,
    })
}

/// The particles of an MCM packing of equal spheres or spherocylinders (diameter 1, the
/// packing's length unit) in its periodic box, ready for [`voxelise`].
pub fn packing_particles(p: &crate::packing::Packing) -> Result<(Cell, Vec<XyzParticle>)> {
    let Some(length) = p.monodisperse_length() else {
        return invalid(
            "packing: only equal spheres or spherocylinders of diameter 1 are voxelised here",
        );
    };
    if p.container != crate::packing::Container::Periodic {
        return invalid("packing: permeability needs the periodic box container");
    }
    let (species, shape) = if length > 0.0 {
        ("spherocylinder", [0.5, 0.5, length])
    } else {
        ("sphere", [0.5; 3])
    };
    let parts = (0..p.n())
        .map(|i| XyzParticle {
            species: species.to_string(),
            position: p.positions[i],
            orientation: p.orientations[i],
            aspherical_shape: shape,
            radius: 0.5,
            cylinder_length: length,
            roundness: [1.0, 1.0],
        })
        .collect();
    Ok((Cell::cubic(p.box_length), parts))
}

/// The voxelised configuration.
#[derive(Debug)]
pub struct Voxels {
    pub dims: Dims,
    /// Cell edge in the configuration's length unit.
    pub dx: f64,
    pub solid: Vec<bool>,
    /// Solid volume fraction from the particle volumes (overlaps counted twice).
    pub phi_particles: f64,
    /// V / S of the particles (None if a shape has no surface formula here).
    pub v_over_s: Option<f64>,
}

/// The lattice of `n` cells along x in the periodic orthorhombic `cell` and its spacing dx
/// (the other edges get the same spacing, rounded; they must come out within 1e-6 relative).
pub fn voxel_dims(cell: &Cell, n: usize) -> Result<(Dims, f64)> {
    if cell.pbc != [true; 3] {
        return invalid(format!(
            "the configuration's cell has pbc = {:?}: permeability needs a periodic box (T T T)",
            cell.pbc
        ));
    }
    if n < 4 {
        return invalid(format!("resolution = {n}: must be >= 4 cells along x"));
    }
    let dx = cell.lengths[0] / n as f64;
    let mut ext = [n; 3];
    for (k, e) in ext.iter_mut().enumerate().skip(1) {
        let m = cell.lengths[k] / dx;
        *e = m.round() as usize;
        if *e == 0 || (m - *e as f64).abs() > 1e-6 * m {
            return invalid(format!(
                "box edge {k} = {} is {m} cells of dx = {dx}: must be a whole number of cells \
                 (choose the resolution so that the edges are commensurate)",
                cell.lengths[k]
            ));
        }
    }
    Ok((Dims::new(ext[0], ext[1], ext[2])?, dx))
}

/// Voxelises `particles` in the periodic orthorhombic `cell` with `n` cells along x
/// ([`voxel_dims`]).
pub fn voxelise(cell: &Cell, particles: &[XyzParticle], n: usize) -> Result<Voxels> {
    let (dims, dx) = voxel_dims(cell, n)?;
    let ext = [dims.nx, dims.ny, dims.nz];
    crate::lbm::solver::check_memory(dims, 19, 0)?;
    let placed: Vec<Placed> = particles
        .iter()
        .enumerate()
        .map(|(i, p)| place(i, p))
        .collect::<Result<_>>()?;
    let mut solid = vec![false; dims.cells()];
    let org = Vector3::from(cell.origin);
    let (mut vol, mut area, mut all_area) = (0.0, 0.0, true);
    for p in &placed {
        vol += p.shape.volume();
        match p.area {
            Some(a) => area += a,
            None => all_area = false,
        }
        let br = p.shape.bounding_radius();
        let rel = p.centre - org;
        // cell index range of the bounding cube, unwrapped; each index is wrapped below
        let lo: Vec<i64> = (0..3)
            .map(|k| ((rel[k] - br) / dx).floor() as i64)
            .collect();
        let hi: Vec<i64> = (0..3).map(|k| ((rel[k] + br) / dx).ceil() as i64).collect();
        for iz in lo[2]..=hi[2] {
            for iy in lo[1]..=hi[1] {
                for ix in lo[0]..=hi[0] {
                    let ii = [ix, iy, iz];
                    let centre = Vector3::new(
                        (ix as f64 + 0.5) * dx,
                        (iy as f64 + 0.5) * dx,
                        (iz as f64 + 0.5) * dx,
                    );
                    let body = p.to_body * (centre - rel);
                    if p.shape.implicit(&body) < 0.0 {
                        let w = |k: usize| ii[k].rem_euclid(ext[k] as i64) as usize;
                        solid[dims.cell(w(0), w(1), w(2))] = true;
                    }
                }
            }
        }
    }
    let box_vol = cell.lengths.iter().product::<f64>();
    Ok(Voxels {
        dims,
        dx,
        solid,
        phi_particles: vol / box_vol,
        v_over_s: all_area.then(|| vol / area),
    })
}

/// What `porelab permeability` reports for one resolution.
#[derive(Debug, Clone)]
pub struct PoreResult {
    pub n: usize,
    /// k in the configuration's length unit squared.
    pub k: f64,
    /// Fluid fraction of the voxels.
    pub porosity: f64,
    /// Re = <u> nu_len / nu, with nu_len = V/S (lattice units).
    pub re: f64,
    pub run: Permeability,
}

struct PoreJob {
    geom: Geometry,
    g: f64,
    ctl: SteadyControl,
    quiet: bool,
}

impl Job for PoreJob {
    type Out = Result<Permeability>;
    fn run<L: Lattice, C: Collision>(self, coll: C) -> Result<Permeability> {
        let mut bar = SteadyProgress::new(self.ctl.tol, self.quiet);
        let r = permeability::<L, C>(self.geom, coll, self.g, self.ctl, |s, res| {
            bar.update(s, res)
        });
        bar.finish();
        r
    }
}

/// Options of the pore-resolving permeability run.
#[derive(Debug, Clone, Copy)]
pub struct PoreOptions {
    pub lattice: LatticeKind,
    pub collision: CollisionKind,
    pub tau: f64,
    /// Body force (lattice units).
    pub g: f64,
    pub ctl: SteadyControl,
    pub quiet: bool,
}

/// Permeability of the voxelised configuration.
pub fn pore_permeability(v: &Voxels, o: &PoreOptions) -> Result<PoreResult> {
    // the bounce-back links depend on the lattice's directions
    let geom = match o.lattice {
        LatticeKind::D3Q19 => Geometry::new::<super::D3Q19>(v.dims, v.solid.clone(), |_| [0.0; 3])?,
        LatticeKind::D3Q15 => Geometry::new::<super::D3Q15>(v.dims, v.solid.clone(), |_| [0.0; 3])?,
    };
    if geom.fluid_cells() == 0 {
        return invalid("every cell is solid: permeability 0 (no flow path)");
    }
    let run = dispatch(
        o.lattice,
        o.collision,
        o.tau,
        PoreJob {
            geom,
            g: o.g,
            ctl: o.ctl,
            quiet: o.quiet,
        },
    )?;
    let nu = (o.tau - 0.5) / 3.0;
    let l = v.v_over_s.map_or(1.0, |s| s / v.dx);
    Ok(PoreResult {
        n: v.dims.nx,
        k: run.k * v.dx * v.dx,
        porosity: run.porosity,
        re: run.mean_u * l / nu,
        run,
    })
}

/// Kozeny constant implied by k (thesis 003 eq. 7.4): C = (1 - phi)^3 nu^2 / (k phi^2).
pub fn kozeny_constant(k: f64, solid_fraction: f64, v_over_s: f64) -> f64 {
    let e = 1.0 - solid_fraction;
    e * e * e * v_over_s * v_over_s / (k * solid_fraction * solid_fraction)
}

#[derive(Debug, Clone, clap::Args)]
pub struct PermeabilityArgs {
    /// Extended XYZ configuration (periodic box), e.g. a packing's final.xyz.
    pub packing: std::path::PathBuf,
    /// Cells along the box's x edge; a second run at half of it gives the convergence estimate.
    #[arg(long, default_value_t = 64)]
    pub resolution: usize,
    /// The configuration's length unit in metres (e.g. the particle diameter), for k in m^2.
    #[arg(long)]
    pub unit_m: Option<f64>,
    /// D3Q15 or D3Q19.
    #[arg(long, default_value = "D3Q19")]
    pub lattice: String,
    /// bgk or trt (TRT: k independent of the viscosity).
    #[arg(long, default_value = "trt")]
    pub collision: String,
    /// Relaxation time.
    #[arg(long, default_value_t = 1.0)]
    pub tau: f64,
    /// Body force in lattice units (small: Re << 1).
    #[arg(long, default_value_t = 1e-6)]
    pub force: f64,
    /// Stop when the mean velocity changes by less than this (relative) over 100 steps.
    #[arg(long, default_value_t = 1e-7)]
    pub tol: f64,
    #[arg(long, default_value_t = 500_000)]
    pub max_steps: u64,
    #[arg(long)]
    pub quiet: bool,
}

impl PoreOptions {
    /// Refuses a body force that is not positive and finite (`force_key` names it) and an
    /// unstable relaxation time.
    pub fn check(&self, force_key: &str) -> Result<()> {
        if !(self.g.is_finite() && self.g > 0.0) {
            return invalid(format!(
                "{force_key} = {}: must be positive and finite",
                self.g
            ));
        }
        super::units::check_tau(self.tau)
    }
}

/// The line `porelab permeability` starts with: the configuration and the run's options.
pub fn setup_line(cell: &Cell, particles: &[XyzParticle], o: &PoreOptions) -> String {
    format!(
        "{} particles in a {:?} box; {} {}, tau = {}, body force {:e} (lattice units)\n",
        particles.len(),
        cell.lengths,
        o.lattice.name(),
        o.collision.name(),
        o.tau,
        o.g
    )
}

/// What `porelab permeability` prints for one resolution (`unit_m`: the configuration's
/// length unit in metres, for k in m^2).
pub fn report(v: &Voxels, r: &PoreResult, o: &PoreOptions, unit_m: Option<f64>) -> String {
    let mut s = format!(
        "resolution {} ({} x {} x {}, dx = {:.4}): k = {:.6e} unit^2, porosity {:.4} (voxels; \
         particles {:.4}), {} steps, residual {:.1e}{}\n",
        r.n,
        v.dims.nx,
        v.dims.ny,
        v.dims.nz,
        v.dx,
        r.k,
        r.porosity,
        1.0 - v.phi_particles,
        r.run.steps,
        r.run.residual,
        if r.run.converged {
            ""
        } else {
            " (NOT converged)"
        }
    );
    s += &format!(
        "  {}\n",
        describe(o.tau, r.run.u_max, v.v_over_s.map_or(1.0, |s| s / v.dx))
    );
    s += &format!("  Re (mean velocity, length V/S) = {:.3e}\n", r.re);
    if let Some(vs) = v.v_over_s {
        s += &format!(
            "  Kozeny constant (eq. 7.4, nu = V/S = {vs:.4}): {:.3} with the particle phi, {:.3} \
             with the voxel phi\n",
            kozeny_constant(r.k, v.phi_particles, vs),
            kozeny_constant(r.k, 1.0 - r.porosity, vs)
        );
    }
    if let Some(u) = unit_m {
        s += &format!("  k = {:.6e} m^2\n", r.k * u * u);
    }
    s
}

pub fn cli_permeability(a: &PermeabilityArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.packing).map_err(|e| crate::Error::File {
        path: a.packing.display().to_string(),
        msg: e.to_string(),
    })?;
    let (cell, parts) = xyz::parse(&text, &a.packing.display().to_string())?;
    let o = PoreOptions {
        lattice: LatticeKind::parse(&a.lattice, "--lattice")?,
        collision: CollisionKind::parse(&a.collision, "--collision")?,
        tau: a.tau,
        g: a.force,
        ctl: SteadyControl {
            check_every: 100,
            tol: a.tol,
            max_steps: a.max_steps,
        },
        quiet: a.quiet,
    };
    o.check("--force")?;
    print!("{}", setup_line(&cell, &parts, &o));
    let mut results = Vec::new();
    let mut linearity = 0.0;
    for n in [a.resolution / 2, a.resolution] {
        let v = voxelise(&cell, &parts, n)?;
        let r = pore_permeability(&v, &o)?;
        print!("{}", report(&v, &r, &o, a.unit_m));
        if results.is_empty() {
            linearity = darcy_linearity(&v, &o, r.k)?;
        }
        results.push(r);
    }
    let (k1, k2) = (results[0].k, results[1].k);
    println!(
        "Darcy's law: k at half the force differs by {:+.2e} (resolution {}){}",
        linearity,
        results[0].n,
        if linearity.abs() > DARCY_LINEARITY_TOL {
            " -- NOT in the Darcy regime: lower --force"
        } else {
            ""
        }
    );
    println!(
        "convergence estimate: k changed by {:+.2} % from resolution {} to {}",
        100.0 * (k2 / k1 - 1.0),
        results[0].n,
        results[1].n
    );
    Ok(())
}

/// The relative change of k from the driving force to half of it above which a run is said
/// not to be in the Darcy regime.
pub const DARCY_LINEARITY_TOL: f64 = 1e-2;

/// Darcy's law (thesis eq. 7.3) on these voxels: k at half the body force of `o`, relative to
/// the `k` measured at the force itself, minus 1. Zero in the Stokes limit (up to the steady
/// tolerance); inertia lowers k at the stronger force, so it grows with Re.
pub fn darcy_linearity(v: &Voxels, o: &PoreOptions, k: f64) -> Result<f64> {
    let half = PoreOptions { g: 0.5 * o.g, ..*o };
    Ok(pore_permeability(v, &half)?.k / k - 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn sphere(x: [f64; 3], r: f64) -> XyzParticle {
        XyzParticle {
            species: "S".into(),
            position: Vector3::from(x),
            orientation: UnitQuaternion::identity(),
            aspherical_shape: [r; 3],
            radius: r,
            cylinder_length: 0.0,
            roundness: [1.0, 1.0],
        }
    }

    /// A sphere at the box centre voxelises to the simple cubic mask of the validated cases,
    /// and the same sphere split across the corner (periodic images) to its shifted copy.
    #[test]
    fn periodic_images_and_sc_mask() {
        let n = 16;
        let r = 0.3;
        let v = voxelise(&Cell::cubic(1.0), &[sphere([0.5; 3], r)], n).unwrap();
        assert_eq!(
            v.solid,
            super::super::flows::sphere_array_mask(n, r * n as f64)
        );
        let w = voxelise(&Cell::cubic(1.0), &[sphere([0.0; 3], r)], n).unwrap();
        let d = v.dims;
        for c in 0..d.cells() {
            let p = d.coords(c);
            let s = d.cell((p[0] + n / 2) % n, (p[1] + n / 2) % n, (p[2] + n / 2) % n);
            assert_eq!(v.solid[c], w.solid[s]);
        }
        assert!((v.v_over_s.unwrap() - r / 3.0).abs() < 1e-15);
    }

    /// A simple cubic array at Re 6e-3 obeys Darcy's law far inside the 1 % of
    /// DARCY_LINEARITY_TOL; driven 200 times harder (Re 1.2) it does not.
    #[test]
    fn darcy_linearity_separates_stokes_from_inertia() {
        let v = voxelise(&Cell::cubic(1.0), &[sphere([0.5; 3], 0.3)], 12).unwrap();
        let mut o = PoreOptions {
            lattice: LatticeKind::D3Q19,
            collision: CollisionKind::Trt,
            tau: 0.6,
            g: 1e-6,
            ctl: SteadyControl {
                check_every: 100,
                tol: 1e-10,
                max_steps: 200_000,
            },
            quiet: true,
        };
        let k = pore_permeability(&v, &o).unwrap().k;
        let slow = darcy_linearity(&v, &o, k).unwrap();
        // measured 8.0e-7: weak inertia (1.4e-2 at Re 1.23, scaled by Re^2: 3.5e-7) plus the
        // distance to steady
        assert!(slow.abs() < 1e-5, "{slow}");
        o.g = 2e-4;
        let fast = pore_permeability(&v, &o).unwrap();
        let inertial = darcy_linearity(&v, &o, fast.k).unwrap();
        assert!(
            inertial > DARCY_LINEARITY_TOL,
            "{inertial} at Re {}",
            fast.re
        );
    }

    /// A rotated superquadric with unequal semi-axes and exponents, placed across a box
    /// corner, voxelises to the mask of eq. 4.3 evaluated here directly: every cell centre
    /// against the 27 images of the particle, in the body frame of the quaternion's matrix.
    #[test]
    fn superquadric_mask_equals_direct_evaluation() {
        let (a, g_xy, g_z) = ([0.31, 0.22, 0.17], 4.0, 2.5);
        let q = UnitQuaternion::from_euler_angles(0.4, -0.7, 1.1);
        let centre = [0.93, 0.05, 0.48];
        let p = XyzParticle {
            species: "superquadric".into(),
            position: Vector3::from(centre),
            orientation: q,
            aspherical_shape: a,
            radius: 0.35,
            cylinder_length: 0.0,
            roundness: [2.0 / g_xy, 2.0 / g_z],
        };
        let n = 24;
        let v = voxelise(&Cell::cubic(1.0), &[p], n).unwrap();
        let rot = q.to_rotation_matrix().into_inner().transpose();
        let g = [g_xy, g_xy, g_z];
        let mut solid_cells = 0;
        for c in 0..v.dims.cells() {
            let ix = v.dims.coords(c);
            let x = Vector3::from_fn(|k, _| (ix[k] as f64 + 0.5) / n as f64);
            let mut inside = false;
            for s in 0..27 {
                let shift = Vector3::new(
                    (s % 3) as f64 - 1.0,
                    ((s / 3) % 3) as f64 - 1.0,
                    (s / 9) as f64 - 1.0,
                );
                let b = rot * (x - Vector3::from(centre) - shift);
                let f: f64 = (0..3).map(|k| (b[k] / a[k]).abs().powf(g[k])).sum();
                inside |= f < 1.0;
            }
            assert_eq!(v.solid[c], inside, "cell {ix:?}");
            solid_cells += inside as usize;
        }
        assert!(solid_cells > 500, "{solid_cells} solid cells");
        assert!(v.v_over_s.is_none());
        let bad = XyzParticle {
            roundness: [1.5, 0.5],
            ..sphere([0.5; 3], 0.2)
        };
        let e = voxelise(&Cell::cubic(1.0), &[bad], 8)
            .unwrap_err()
            .to_string();
        assert!(e.contains("superquadric_roundness"), "{e}");
    }

    /// All solid, and fluid only in isolated pockets (one sphere of radius 0.75 in the unit
    /// box leaves the corners' fluid enclosed): both refused as permeability 0.
    #[test]
    fn no_flow_path_is_said_plainly() {
        let pockets = voxelise(&Cell::cubic(1.0), &[sphere([0.5; 3], 0.75)], 8).unwrap();
        assert!(pockets.solid.iter().any(|s| !s));
        let v = voxelise(&Cell::cubic(1.0), &[sphere([0.5; 3], 2.0)], 8).unwrap();
        let o = PoreOptions {
            lattice: LatticeKind::D3Q15,
            collision: CollisionKind::Trt,
            tau: 1.0,
            g: 1e-6,
            ctl: SteadyControl {
                check_every: 10,
                tol: 1e-6,
                max_steps: 10,
            },
            quiet: true,
        };
        let e = pore_permeability(&v, &o).unwrap_err().to_string();
        assert!(e.contains("permeability 0"), "{e}");
        let e = pore_permeability(&pockets, &o).unwrap_err().to_string();
        assert!(
            e.contains("isolated pockets") && e.contains("permeability is 0"),
            "{e}"
        );
    }
}
