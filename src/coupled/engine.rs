//! The two-way coupling loop (seed 002, "Two-way coupling algorithm"): each coupling step
//!
//! 1. porosity per cell from the particles ([`super::porosity`]), the local mean diameter and
//!    the solid velocity, hence the Guo–Zhao fields of every cell: eps, the drag coefficients
//!    of [`super::drag`] (Carman–Kozeny K for the Ergun branch, seed 002 eq. 10-11) and the
//!    matrix velocity w = eps u_s (computed when the particles have moved, at the end of the
//!    step before and by [`Coupled::new`], so that between steps the porosity is that of the
//!    particles' positions, as the outputs show it);
//! 2. one LBM step, recording the density, velocity and source acceleration of each cell;
//! 3. the force the fluid of each cell lost to its solid, F_c = rho_c (eps_c G - a_c) (G the
//!    driving body force), shared among the particles in the cell by their volume in it (the
//!    weights of the porosity): particle i gets sum_c (V_ic / V_c) [F_c + D_c eps_c (v_c - v_i)],
//!    D_c = rho_c (lin_c + quad_c |u_c - w_c|) and v_c the cell's volume-weighted solid
//!    velocity, i.e. the drag on its own relative velocity; the second term sums to zero over
//!    a cell, so the particles gain exactly what the fluid lost;
//! 4. M DEM steps with that force held constant, plus the buoyant weight (the DEM's
//!    m (1 - rho_f / rho_p) g) and the mean pressure gradient on the particle volume,
//!    -V_i grad p (the solid's share of the imposed pressure drop; the fluid gets the rest as
//!    eps G, G = -grad p / rho_f).
//!
//! The local pressure variations of the LBM reach the particles through the drag: the fluid's
//! momentum equation (Guo & Zhao 2002 eq. 9) carries them to the source term the particles
//! receive, so no separate local pressure-gradient force is added (it would be counted twice).
//!
//! Refusals at run time: a particle moving more than [`Setup::max_move_cells`] of a
//! cell in one coupling step, a drag relaxation gamma_i dt_LBM / m_i above
//! [`Setup::max_relaxation`] (the force is explicit over the coupling step), and any
//! non-finite state. Lattice units inside the LBM (dx = dt = 1, rho = 1); SI everywhere else.

use super::drag::{cell_coefficients, Switch};
use super::porosity::{sphere_cells, Overlap};
use crate::dem::{Dem, TimeStep, WallLedger};
use crate::error::{invalid, Error, Result};
use crate::lbm::units::{Units, MACH_MAX};
use crate::lbm::{
    Accel, CollisionModel, Dims, Domain, ForcingModel, LatticeKind, Lbm, Medium, Porous, Record,
};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::f64::consts::PI;
use std::time::Instant;

/// Everything a coupled run is made of (SI): the DEM bed, the fluid's lattice and collision,
/// and the coupling.
#[derive(Debug, Clone)]
pub struct Setup {
    /// The particles, their box and contacts. Its time step stays automatic: the coupled run
    /// steps the DEM at dt_LBM / M ([`Setup::dem_steps`]), so a given one is refused.
    pub dem: crate::dem::Setup,
    /// Lattice spacing (m); the box must hold a whole number of cells in x and y. The lattice
    /// spans the DEM box up to its top wall's start height (and the basesheet below it).
    pub dx_m: f64,
    pub lattice: LatticeKind,
    /// Collision and relaxation time (sets dt = (tau - 1/2)/3 dx^2 / nu, `lbm::units`).
    pub collision: CollisionModel,
    pub fluid_density_kg_m3: f64,
    pub viscosity_pa_s: f64,
    pub overlap: Overlap,
    pub switch: Switch,
    /// Porosity floor of a cell (the Carman–Kozeny K stays finite and the 1/eps terms of the
    /// equilibrium bounded).
    pub eps_min: f64,
    /// Imposed mean pressure gradient (Pa/m); the fluid is driven by G = -grad p / rho_f.
    pub grad_p_pa_m: Vector3<f64>,
    /// Add to grad p the gradient that carries the particles' buoyant weight, sum m'_i g /
    /// V_box (a periodic suspension then has no net external force).
    pub balance_weight: bool,
    /// DEM steps per LBM step (M).
    pub dem_steps: u64,
    /// Largest particle displacement per coupling step, in cells.
    pub max_move_cells: f64,
    /// Largest drag relaxation gamma dt_LBM / m of a particle.
    pub max_relaxation: f64,
    /// Particles held fixed (no DEM steps): a fixed bed.
    pub frozen: bool,
    /// A permeable bottom (the basesheet) below the DEM floor.
    pub basesheet: Option<Basesheet>,
}

/// The basesheet: a Darcy layer of permeability K and thickness h below the DEM floor (z from
/// -h to 0), in whole lattice layers added under the particles' lattice. Its cells carry the
/// Darcy drag a = -(nu / K) u (Guo–Zhao with porosity 1 and no Forchheimer term): its whole
/// resistance is K, so the steady pressure drop across it is mu U h / K (Darcy) with U the
/// superficial velocity. A porosity below 1 in the Guo–Zhao equations would make the layer's
/// solid take (1 - eps) of the mean driving and the drop would no longer be Darcy's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Basesheet {
    pub thickness_m: f64,
    pub permeability_m2: f64,
}

/// Seconds spent in each part of the loop.
#[derive(Debug, Clone, Copy, Default, serde::Serialize, serde::Deserialize)]
pub struct Timing {
    pub lbm_s: f64,
    pub dem_s: f64,
    pub coupling_s: f64,
}

/// The balance of one coupling step (SI, N s): fluid and particle momentum changes, the
/// external impulse (driving, buoyant weight, pressure gradient on the particles) and the
/// impulse of the walls on the particles.
#[derive(Debug, Clone, Copy, Default)]
pub struct Balance {
    pub fluid: Vector3<f64>,
    pub particles: Vector3<f64>,
    pub external: Vector3<f64>,
    /// Impulse of the floor and top-wall contacts over the M DEM steps, as velocity Verlet
    /// applies it (dt_DEM / 2 (W_n + W_n+1) per step); for a frozen bed, the impulse of the
    /// constraint that holds it (minus every force on its particles).
    pub walls: Vector3<f64>,
    /// Magnitude the rounding scales with: the exchanged, external and wall impulses.
    pub scale: f64,
}

impl Balance {
    /// |dP_fluid + dP_particles - J_external - J_walls| / scale.
    pub fn relative_error(&self) -> f64 {
        (self.fluid + self.particles - self.external - self.walls).norm()
            / self.scale.max(f64::MIN_POSITIVE)
    }
}

/// Largest lattice density variation c_s^-2 G L across the free fluid the driving may cause:
/// the density stays within +-25 % of its mean. A stability refusal, not an accuracy bound
/// (the pressure channel of `kind = "lbm"` keeps its drop below 0.2 for accuracy; case 817
/// runs at 0.3 and meets Darcy to 1e-9).
pub const MAX_DENSITY_VARIATION: f64 = 0.5;

/// A column of lattice cells in steady flow along its axis (lattice units): `bed` cells of
/// particles spread uniformly (porosity `eps`, diameter `d_cells`) over `sheet` cells of a
/// Darcy layer of permeability `sheet_k` (dx^2).
#[derive(Debug, Clone, Copy)]
pub struct Column {
    pub bed: f64,
    pub eps: f64,
    pub d_cells: f64,
    pub sheet: f64,
    pub sheet_k: f64,
}

impl Column {
    /// The superficial velocity at which the engine's drag (Ergun / Wen–Yu of
    /// [`cell_coefficients`] in the bed, -(nu / K) u in the sheet) balances the driving `g`
    /// on the fluid, g (eps bed + sheet) = bed (lin(U) + quad U) U + sheet (nu / K) U, by
    /// bisection (the right side increases with U); infinite with nothing to resist.
    pub fn velocity(&self, nu: f64, g: f64, switch: Switch) -> f64 {
        let resist = |u: f64| {
            let bed = if self.eps < 1.0 && self.bed > 0.0 {
                let (lin, quad) = cell_coefficients(self.eps, self.d_cells, nu, u, switch);
                self.bed * (lin + quad * u) * u
            } else {
                0.0
            };
            let sheet = if self.sheet > 0.0 {
                self.sheet * nu / self.sheet_k * u
            } else {
                0.0
            };
            bed + sheet
        };
        let target = g.abs() * (self.eps * self.bed + self.sheet);
        crate::special::root::increasing_root(resist, target, 1e6)
    }
}

/// Refuses, before the run, a driving too large for the weakly compressible fluid (seed 002
/// eq. 3-9 hold for Mach << 1 and small density variations), by two estimates:
///
/// * Mach: the steady superficial velocity U through the particles spread uniformly over the
///   column (mean porosity eps, volume-weighted diameter), solved from the engine's own drag
///   closure; for a fixed total solid volume the uniform spread is the least resistant layering
///   (the Ergun and Wen–Yu resistances per unit length are convex in the solid fraction, so by
///   Jensen's inequality any layering of the same solid resists more). sqrt(3) U / eps must
///   not exceed [`MACH_MAX`] (the LBM engine's own limit);
/// * density: along z the fluid that no particle occupies (free fluid) carries the driving by
///   its own pressure gradient, so the lattice density varies by c_s^-2 G_z L_free = 3 G_z
///   L_free (lattice units) across it; L_free is the column less the solid's volume over the
///   base area (no bed is thinner), or for a fixed bed the layers no sphere reaches. It must
///   not exceed [`MAX_DENSITY_VARIATION`].
fn check_driving(
    dem: &Dem,
    setup: &Setup,
    units: &Units,
    dims: Dims,
    sheet_cells: usize,
) -> Result<()> {
    let rho = setup.fluid_density_kg_m3;
    let dx = setup.dx_m;
    let b = 1.0 - rho / dem.setup().density_kg_m3;
    let (mut v_s, mut vd, mut weight) = (0.0, 0.0, Vector3::zeros());
    for (r, m) in dem.p.radius.iter().zip(&dem.p.mass) {
        let v = 4.0 / 3.0 * PI * r * r * r;
        v_s += v;
        vd += v * 2.0 * r;
        weight += dem.setup().gravity_m_s2 * (m * b);
    }
    let v_box = dims.cells() as f64 * dx.powi(3);
    let mut grad = setup.grad_p_pa_m;
    if setup.balance_weight {
        grad += weight / v_box;
    }
    let g_l = units.accel_to_lattice(grad.norm() / rho);
    if g_l == 0.0 {
        return Ok(());
    }
    let key = "fluid.pressure_gradient_pa_m";
    let shown = format!("[{}, {}, {}]", grad.x, grad.y, grad.z);
    let area = dims.nx as f64 * dims.ny as f64 * dx * dx;
    let bed = (dims.nz - sheet_cells) as f64;
    let eps = 1.0 - v_s / (area * bed * dx);
    let column = Column {
        bed,
        eps,
        d_cells: if v_s > 0.0 { vd / v_s / dx } else { 1.0 },
        sheet: sheet_cells as f64,
        sheet_k: setup
            .basesheet
            .map_or(f64::INFINITY, |b| b.permeability_m2 / (dx * dx)),
    };
    let u = column.velocity(units.nu_lattice(), g_l, setup.switch);
    let what =
        format!("through the particles spread uniformly (porosity {eps:.3}) and the basesheet");
    let mach = 3f64.sqrt() * u / eps.clamp(setup.eps_min, 1.0);
    if !(mach.is_finite() && mach <= MACH_MAX) {
        return invalid(format!(
            "{key} = {shown} Pa/m (with the weight's share if balanced): the steady flow {what} \
             would be {:.3e} m/s, lattice Mach sqrt(3) U / eps = {mach:.3} > {MACH_MAX} (rule: \
             the weakly compressible fluid needs Mach <= {MACH_MAX}); lower the gradient or \
             fluid.tau",
            units.velocity_to_si(u)
        ));
    }
    let free = if setup.frozen {
        let mut reached = vec![false; dims.nz - sheet_cells];
        for (p, r) in dem.p.pos.iter().zip(&dem.p.radius) {
            let lo = ((p.z - r) / dx).floor().max(0.0) as usize;
            let hi = ((p.z + r) / dx).ceil().max(0.0) as usize;
            for k in lo..hi.min(reached.len()) {
                reached[k] = true;
            }
        }
        reached.iter().filter(|&&r| !r).count() as f64 * dx
    } else {
        (bed * dx - v_s / area).max(0.0)
    };
    let g_z = units.accel_to_lattice(grad.z / rho);
    let drho = 3.0 * g_z.abs() * free / dx;
    if !(drho.is_finite() && drho <= MAX_DENSITY_VARIATION) {
        return invalid(format!(
            "{key} = {shown} Pa/m: across the {free:.3e} m of free fluid in z the lattice density \
             would vary by c_s^-2 G L = {drho:.3} (rule: at most {MAX_DENSITY_VARIATION} for the \
             weakly compressible fluid); lower the gradient, fluid.tau or the column height"
        ));
    }
    Ok(())
}

/// The fluid's Guo-Zhao medium ([`Coupled::new`] builds the fluid with one).
fn medium(lbm: &Lbm) -> Result<&Porous> {
    lbm.porous()
        .ok_or_else(|| Error::InvalidInput("coupled: the fluid has no porous medium".into()))
}

fn medium_mut(lbm: &mut Lbm) -> Result<&mut Porous> {
    lbm.porous_mut()
        .ok_or_else(|| Error::InvalidInput("coupled: the fluid has no porous medium".into()))
}

/// A coupled LBM–DEM system.
pub struct Coupled {
    pub dem: Dem,
    pub lbm: Lbm,
    pub units: Units,
    pub setup: Setup,
    pub dims: Dims,
    pub dt_dem_s: f64,
    /// Coupling steps done.
    pub steps: u64,
    pub time_s: f64,
    pub timing: Timing,
    /// The last LBM step's record (lattice units).
    pub record: Record,
    /// Per cell: solid volume (m^3), porosity used, volume-weighted diameter sum and velocity.
    pub solid_volume_m3: Vec<f64>,
    pub eps: Vec<f64>,
    vd: Vec<f64>,
    vv: Vec<[f64; 3]>,
    /// Per cell: lagged superficial slip |u - w| (lattice) and D_c = lin + quad |u - w|.
    pub(crate) slip: Vec<f64>,
    /// Hydrodynamic force on each particle of the last step (N) and its drag rate (kg/s).
    pub hydro_n: Vec<Vector3<f64>>,
    pub gamma_kg_s: Vec<f64>,
    overlaps: Vec<Vec<(u32, f64)>>,
    /// Worst relative momentum imbalance over all steps, and the last step's balance.
    pub worst_balance: f64,
    pub last_balance: Balance,
    /// Largest displacement per coupling step seen (cells).
    pub max_move_seen_cells: f64,
    /// Lattice layers of the basesheet (0 without one); the DEM's z = 0 is the lattice's
    /// z = sheet_cells dx.
    pub sheet_cells: usize,
    /// The fluid's force on the basesheet in the last step (lattice units, summed over its
    /// cells).
    sheet_force: [f64; 3],
}

/// What [`Coupled::new`] settles before it allocates the lattice: the DEM bed, the lattice's
/// size, the units and the DEM step, with every check of the setup done (`porelab run --check`
/// stops here).
pub struct Plan {
    dem: Dem,
    dims: Dims,
    units: Units,
    dt_dem_s: f64,
    sheet_cells: usize,
}

/// Bytes per lattice cell the coupled engine holds beside the populations: the record (density
/// and velocity), solid volume, porosity, diameter and velocity sums, slip, and the Guo–Zhao
/// medium's porosity, inverse permeability and solid velocity.
const BYTES_PER_CELL_BESIDE_POPULATIONS: usize = 8 * (4 + 3 + 3 + 1 + 5);

impl Plan {
    /// The lattice's cells.
    pub fn dims(&self) -> Dims {
        self.dims
    }

    /// The lattice time step (s).
    pub fn dt_lbm_s(&self) -> f64 {
        self.units.dt
    }
}

impl Coupled {
    /// Builds the DEM bed and the lattice around its box, and checks the two time steps.
    pub fn new(setup: Setup) -> Result<Coupled> {
        let Plan {
            dem,
            dims,
            units,
            dt_dem_s: dt_dem,
            sheet_cells,
        } = Coupled::plan(&setup)?;
        let cells = dims.cells();
        // Guo-Zhao with the Forchheimer term; every cell's medium is set each coupling step
        let medium = Medium::clear(Accel::new([0.0; 3])?, true);
        let fluid = crate::lbm::Setup::new(setup.lattice, setup.collision, Domain::open(dims))
            .with_forcing(ForcingModel::Porous(medium));
        let lbm = Lbm::new(fluid)?;
        let n = dem.p.len();
        // the fluid at rest (rho = 1, lattice units) until the first step records its state
        let mut record = Record::zeros(cells);
        record.rho.fill(1.0);
        let mut c = Coupled {
            dem,
            lbm,
            units,
            dims,
            dt_dem_s: dt_dem,
            steps: 0,
            time_s: 0.0,
            timing: Timing::default(),
            record,
            solid_volume_m3: vec![0.0; cells],
            eps: vec![1.0; cells],
            vd: vec![0.0; cells],
            vv: vec![[0.0; 3]; cells],
            slip: vec![0.0; cells],
            hydro_n: vec![Vector3::zeros(); n],
            gamma_kg_s: vec![0.0; n],
            overlaps: vec![Vec::new(); n],
            worst_balance: 0.0,
            last_balance: Balance::default(),
            max_move_seen_cells: 0.0,
            sheet_cells,
            sheet_force: [0.0; 3],
            setup,
        };
        c.update_porosity()?;
        Ok(c)
    }

    /// Every check of [`Coupled::new`], the DEM bed built and the lattice sized (its memory
    /// checked), without allocating the lattice.
    pub fn plan(setup: &Setup) -> Result<Plan> {
        if let TimeStep::Given { dt_s } = setup.dem.time_step {
            return invalid(format!(
                "dem.run.dt_s = {dt_s} s: a coupled run steps the DEM at dt_LBM / M (M = \
                 coupling.dem_steps_per_lbm_step); remove dt_s and choose M instead"
            ));
        }
        let dem = Dem::new(setup.dem.clone())?;
        let dx = setup.dx_m;
        for (key, v) in [
            ("fluid.dx_m", dx),
            ("fluid.density_kg_m3", setup.fluid_density_kg_m3),
            ("fluid.viscosity_pa_s", setup.viscosity_pa_s),
            ("coupling.max_move_cells", setup.max_move_cells),
            ("coupling.max_relaxation", setup.max_relaxation),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return invalid(format!("{key} = {v}: must be positive and finite"));
            }
        }
        if !(setup.eps_min > 0.0 && setup.eps_min < 1.0) {
            return invalid(format!(
                "coupling.eps_min = {}: must be in (0, 1)",
                setup.eps_min
            ));
        }
        if !setup.grad_p_pa_m.iter().all(|c| c.is_finite()) {
            return invalid("fluid.pressure_gradient_pa_m: must be finite");
        }
        if setup.dem_steps == 0 {
            return invalid("coupling.dem_steps_per_lbm_step = 0: must be at least 1");
        }
        let cells_along = |l: f64, key: &str| -> Result<usize> {
            let n = (l / dx).round();
            if n < 1.0 || ((n * dx - l) / l).abs() > 1e-9 {
                return invalid(format!(
                    "{key} = {l} m is not a whole number of cells of fluid.dx_m = {dx} m \
                     ({:.6} cells)",
                    l / dx
                ));
            }
            Ok(n as usize)
        };
        let nx = cells_along(dem.setup().lx_m, "box.lx_m")?;
        let ny = cells_along(dem.setup().ly_m, "box.ly_m")?;
        // the top wall's start height in whole cells (a height of n cells gives n)
        let nz = ((dem.top_z_m / dx) * (1.0 - 1e-12)).ceil().max(1.0) as usize;
        let sheet_cells = match setup.basesheet {
            None => 0,
            Some(b) => {
                if !(b.permeability_m2.is_finite() && b.permeability_m2 > 0.0) {
                    return invalid(format!(
                        "fluid.basesheet.permeability_m2 = {}: must be positive and finite",
                        b.permeability_m2
                    ));
                }
                if !(b.thickness_m.is_finite() && b.thickness_m > 0.0) {
                    return invalid(format!(
                        "fluid.basesheet.thickness_m = {}: must be positive",
                        b.thickness_m
                    ));
                }
                cells_along(b.thickness_m, "fluid.basesheet.thickness_m")?
            }
        };
        let dims = Dims::new(nx, ny, nz + sheet_cells)?;
        let nu = setup.viscosity_pa_s / setup.fluid_density_kg_m3;
        let tau = setup.collision.tau.get();
        let units = Units::from_tau(dx, nu, setup.fluid_density_kg_m3, tau)?;
        let dt_dem = units.dt / setup.dem_steps as f64;
        if (dem.setup().fluid_density_kg_m3 - setup.fluid_density_kg_m3).abs()
            > 1e-12 * setup.fluid_density_kg_m3
        {
            return invalid(format!(
                "the DEM's buoyancy fluid density {} kg/m^3 differs from the fluid's {} kg/m^3",
                dem.setup().fluid_density_kg_m3,
                setup.fluid_density_kg_m3
            ));
        }
        if dem.setup().drag.is_some() {
            return invalid(
                "the DEM's uniform Stokes drag is on: the coupled fluid replaces it (remove \
                 drivers.viscosity_pa_s from the [dem] table)",
            );
        }
        let mut dem = dem;
        if !setup.frozen {
            // the DEM's stiffness rule at the largest impact speed the displacement refusal
            // allows, 2 max_move_cells dx / dt_LBM
            let v_max = 2.0 * setup.max_move_cells * dx / units.dt;
            let (tc, _) = crate::dem::setup::contact_times(
                dem.setup(),
                dem.p.radius.iter().cloned().fold(f64::INFINITY, f64::min),
                v_max,
            );
            let limit = crate::dem::setup::MAX_CONTACT_TIME_FRACTION * tc;
            if dt_dem > limit {
                return invalid(format!(
                    "DEM step dt_LBM / M = {:e} s / {} = {dt_dem:e} s exceeds t_contact / 10 = \
                     {limit:e} s: raise coupling.dem_steps_per_lbm_step to at least {}",
                    units.dt,
                    setup.dem_steps,
                    (units.dt / limit).ceil()
                ));
            }
            dem = dem.with_time_step(dt_dem, v_max)?;
        }
        check_driving(&dem, setup, &units, dims, sheet_cells)?;
        crate::lbm::memory::check_memory(
            dims,
            setup.lattice.q(),
            BYTES_PER_CELL_BESIDE_POPULATIONS,
        )?;
        Ok(Plan {
            dem,
            dims,
            units,
            dt_dem_s: dt_dem,
            sheet_cells,
        })
    }

    /// Cell volume (m^3).
    pub fn cell_volume_m3(&self) -> f64 {
        self.setup.dx_m.powi(3)
    }

    /// The pressure gradient in force (Pa/m): the imposed one plus, if asked, the weight's.
    pub fn grad_p(&self) -> Vector3<f64> {
        let mut g = self.setup.grad_p_pa_m;
        if self.setup.balance_weight {
            let b = 1.0 - self.setup.fluid_density_kg_m3 / self.dem.setup().density_kg_m3;
            let w: f64 = self.dem.p.mass.iter().sum::<f64>() * b;
            let v_box = self.dims.cells() as f64 * self.cell_volume_m3();
            g += self.dem.setup().gravity_m_s2 * (w / v_box);
        }
        g
    }

    /// Step 1: solid volume, porosity, diameter and velocity per cell, and the Guo–Zhao fields.
    pub fn update_porosity(&mut self) -> Result<()> {
        let dx = self.setup.dx_m;
        let n = [self.dims.nx, self.dims.ny, self.dims.nz];
        let method = self.setup.overlap;
        let p = &self.dem.p;
        let z0 = self.sheet_cells as f64 * dx;
        let first_cell = (self.sheet_cells * n[0] * n[1]) as u32;
        self.overlaps
            .par_iter_mut()
            .enumerate()
            .with_min_len(16)
            .for_each(|(i, out)| {
                out.clear();
                let c = p.pos[i];
                sphere_cells(method, [c.x, c.y, c.z + z0], p.radius[i], n, dx, out);
                // the basesheet is not the particles' (a sphere pressed into the floor)
                out.retain(|&(cell, _)| cell >= first_cell);
            });
        self.solid_volume_m3.fill(0.0);
        self.vd.fill(0.0);
        self.vv.fill([0.0; 3]);
        let to_l = self.units.dt / dx;
        for (i, ov) in self.overlaps.iter().enumerate() {
            let d = 2.0 * p.radius[i];
            let v = p.vel[i] * to_l;
            for &(c, vol) in ov {
                let c = c as usize;
                self.solid_volume_m3[c] += vol;
                self.vd[c] += vol * d;
                for k in 0..3 {
                    self.vv[c][k] += vol * v[k];
                }
            }
        }
        let vcell = self.cell_volume_m3();
        let nu = self.units.nu_lattice();
        let (eps_min, switch) = (self.setup.eps_min, self.setup.switch);
        let g = -self.grad_p() / self.setup.fluid_density_kg_m3;
        let gl = self.units.accel_to_lattice(1.0);
        let porous = medium_mut(&mut self.lbm)?;
        porous.g = [g.x * gl, g.y * gl, g.z * gl];
        for c in 0..self.dims.cells() {
            let vs = self.solid_volume_m3[c];
            let (eps, lin, quad, w) = if vs > 0.0 {
                let eps = (1.0 - vs / vcell).clamp(eps_min, 1.0);
                let d_cells = self.vd[c] / vs / dx;
                let vbar = [self.vv[c][0] / vs, self.vv[c][1] / vs, self.vv[c][2] / vs];
                if eps < 1.0 {
                    let (lin, quad) = cell_coefficients(eps, d_cells, nu, self.slip[c], switch);
                    (
                        eps,
                        lin,
                        quad,
                        [eps * vbar[0], eps * vbar[1], eps * vbar[2]],
                    )
                } else {
                    (1.0, 0.0, 0.0, [0.0; 3])
                }
            } else {
                (1.0, 0.0, 0.0, [0.0; 3])
            };
            let (eps, lin, quad, w) = match self.setup.basesheet {
                Some(b) if c < first_cell as usize => {
                    // Darcy layer: a = -(nu / K) u, seed 002 eq. 10 with eps = 1, no Forchheimer
                    (1.0, nu / (b.permeability_m2 / (dx * dx)), 0.0, [0.0; 3])
                }
                _ => (eps, lin, quad, w),
            };
            self.eps[c] = eps;
            porous
                .set_coefficients(c, eps, lin, quad)
                .and_then(|_| porous.set_matrix_velocity(c, w))
                .map_err(|e| crate::Error::InvalidInput(format!("cell {c}: {e}")))?;
        }
        Ok(())
    }

    /// Steps 2-3: one LBM step and the hydrodynamic force on every particle.
    pub fn fluid_step(&mut self) -> Result<()> {
        let t = Instant::now();
        self.lbm.step_recording(&mut self.record)?;
        self.timing.lbm_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let cells = self.dims.cells();
        let porous = medium(&self.lbm)?;
        let g = porous.g;
        // per cell: lost force F_c and D_c (lattice)
        let mut fc = vec![[0.0; 3]; cells];
        let mut dc = vec![0.0; cells];
        let sheet_end = self.sheet_cells * self.dims.nx * self.dims.ny;
        self.sheet_force = [0.0; 3];
        for c in 0..cells {
            let rho = self.record.rho[c];
            let a = self.record.a[c];
            let u = self.record.u[c];
            let eps = porous.eps(c);
            let w = porous.matrix_velocity(c);
            let r = [u[0] - w[0], u[1] - w[1], u[2] - w[2]];
            let rn = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            if !(rho.is_finite() && rn.is_finite()) {
                return invalid(format!(
                    "fluid cell {c}: non-finite state after LBM step {} (rho = {rho}, u = {u:?}): \
                     the flow is unstable (lower the driving or the Mach number)",
                    self.lbm.steps()
                ));
            }
            self.slip[c] = rn;
            if c < sheet_end {
                for k in 0..3 {
                    self.sheet_force[k] += rho * (eps * g[k] - a[k]);
                }
            } else if self.solid_volume_m3[c] > 0.0 {
                for k in 0..3 {
                    fc[c][k] = rho * (eps * g[k] - a[k]);
                }
                // D_c = rho (lin + quad |u - w|), from the acceleration's drag part
                dc[c] = if rn > 0.0 {
                    let drag: f64 = (0..3).map(|k| (eps * g[k] - a[k]) * r[k]).sum::<f64>();
                    rho * drag / (rn * rn)
                } else {
                    0.0
                };
            }
        }
        // SI: force = lattice force * rho dx^4 / dt^2, rate = lattice rate * rho dx^3 / dt
        let (dx, dt, rho_si) = (
            self.setup.dx_m,
            self.units.dt,
            self.setup.fluid_density_kg_m3,
        );
        let f_si = rho_si * dx.powi(4) / (dt * dt);
        let g_si = rho_si * dx.powi(3) / dt;
        let to_l = dt / dx;
        let (vs, vv, eps) = (&self.solid_volume_m3, &self.vv, &self.eps);
        let p = &self.dem.p;
        let ov = &self.overlaps;
        self.hydro_n
            .par_iter_mut()
            .zip(self.gamma_kg_s.par_iter_mut())
            .enumerate()
            .with_min_len(64)
            .for_each(|(i, (f, gam))| {
                let v = p.vel[i] * to_l;
                let mut s = [0.0; 3];
                let mut rate = 0.0;
                for &(c, vol) in &ov[i] {
                    let c = c as usize;
                    let share = vol / vs[c];
                    let k_c = dc[c] * eps[c];
                    for k in 0..3 {
                        let vbar = vv[c][k] / vs[c];
                        s[k] += share * (fc[c][k] + k_c * (vbar - v[k]));
                    }
                    rate += share * k_c;
                }
                *f = Vector3::new(s[0], s[1], s[2]) * f_si;
                *gam = rate * g_si;
            });
        self.timing.coupling_s += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// One coupling step: one LBM step in the porosity of the particles' positions, the forces,
    /// M DEM steps, and the porosity of the new positions. Returns its momentum balance.
    pub fn step(&mut self) -> Result<Balance> {
        let t = Instant::now();
        let p_f0 = self.lbm.momentum();
        let p_s0 = self.particle_momentum();
        self.timing.coupling_s += t.elapsed().as_secs_f64();
        self.fluid_step()?;
        let t = Instant::now();
        let dt = self.units.dt;
        let grad_p = self.grad_p();
        let mut ext = Vec::with_capacity(self.dem.p.len());
        let b = 1.0 - self.setup.fluid_density_kg_m3 / self.dem.setup().density_kg_m3;
        let mut j_ext = Vector3::zeros();
        let mut j_exchanged = 0.0;
        for i in 0..self.dem.p.len() {
            let m = self.dem.p.mass[i];
            let gamma = self.gamma_kg_s[i];
            if !self.setup.frozen && gamma * dt / m > self.setup.max_relaxation {
                return invalid(format!(
                    "coupling step {}: particle {i}'s drag relaxes its velocity at rate gamma / m \
                     = {:.3e} 1/s, so dt_LBM = {dt:.3e} s is {:.3} relaxation times (limit \
                     coupling.max_relaxation = {}): the drag, held over the coupling step, \
                     would overshoot; refine the lattice time step (lower fluid.tau) or use \
                     heavier particles",
                    self.steps,
                    gamma / m,
                    gamma * dt / m,
                    self.setup.max_relaxation
                ));
            }
            let r = self.dem.p.radius[i];
            let vol = 4.0 / 3.0 * PI * r * r * r;
            let fp = -grad_p * vol;
            ext.push(self.hydro_n[i] + fp);
            j_exchanged += self.hydro_n[i].norm() * dt;
            j_ext += (fp + self.dem.setup().gravity_m_s2 * (m * b)) * dt;
        }
        // the fluid's driving impulse: sum rho_c eps_c G over the cells (lattice -> SI)
        let porous = medium(&self.lbm)?;
        let g = porous.g;
        let mut drive = [0.0; 3];
        for c in 0..self.dims.cells() {
            let re = self.record.rho[c] * porous.eps(c);
            for k in 0..3 {
                drive[k] += re * g[k];
            }
        }
        let imp = self.setup.fluid_density_kg_m3 * self.setup.dx_m.powi(4) / dt;
        let drive = Vector3::new(drive[0], drive[1], drive[2]) * imp;
        j_ext += drive;
        self.timing.coupling_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        // the basesheet holds what the fluid lost in its cells
        let sf = self.sheet_force;
        let mut j_walls = -Vector3::new(sf[0], sf[1], sf[2]) * imp;
        let mut wall_scale = j_walls.norm();
        if self.setup.frozen {
            // the constraint holding the bed takes every force on its particles
            for (i, e) in ext.iter().enumerate() {
                let w = self.dem.setup().gravity_m_s2 * (self.dem.p.mass[i] * b);
                j_walls -= (e + w) * dt;
            }
            wall_scale += j_walls.norm();
        } else {
            self.dem.set_external_forces(&ext)?;
            let before = self.dem.p.pos.clone();
            // the walls' impulse, step by step, continues the sums (on two threads or more,
            // `run` steps a large bed as one team of threads)
            self.dem.wall_ledger = Some(WallLedger {
                impulse_ns: j_walls,
                magnitude_ns: wall_scale,
                ..WallLedger::default()
            });
            let ran = self.dem.run(self.setup.dem_steps);
            let ledger = self.dem.wall_ledger.take().expect("set above");
            ran?;
            (j_walls, wall_scale) = (ledger.impulse_ns, ledger.magnitude_ns);
            let (lx, ly) = (self.dem.setup().lx_m, self.dem.setup().ly_m);
            let mut worst: f64 = 0.0;
            for (a, b) in before.iter().zip(&self.dem.p.pos) {
                let mut d = b - a;
                d.x -= lx * (d.x / lx).round();
                d.y -= ly * (d.y / ly).round();
                worst = worst.max(d.norm());
            }
            let cells_moved = worst / self.setup.dx_m;
            self.max_move_seen_cells = self.max_move_seen_cells.max(cells_moved);
            if cells_moved > self.setup.max_move_cells {
                return invalid(format!(
                    "coupling step {}: a particle moved {cells_moved:.3} cells in one coupling \
                     step of {dt:.3e} s (limit coupling.max_move_cells = {}): the porosity the \
                     fluid saw is stale; lower fluid.tau (shorter dt_LBM) or the driving",
                    self.steps, self.setup.max_move_cells
                ));
            }
        }
        self.timing.dem_s += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let f_si = self.setup.fluid_density_kg_m3 * self.setup.dx_m.powi(4) / dt;
        let p_f1 = self.lbm.momentum();
        let dpf = Vector3::new(p_f1[0] - p_f0[0], p_f1[1] - p_f0[1], p_f1[2] - p_f0[2]) * f_si;
        let dps = self.particle_momentum() - p_s0;
        let bal = Balance {
            fluid: dpf,
            particles: dps,
            external: j_ext,
            walls: j_walls,
            scale: j_exchanged + j_ext.norm() + drive.norm() + wall_scale,
        };
        let m = self.lbm.mass();
        if !m.is_finite() {
            return invalid(format!(
                "fluid mass is {m} after coupling step {}: unstable flow",
                self.steps
            ));
        }
        self.worst_balance = self.worst_balance.max(bal.relative_error());
        self.last_balance = bal;
        self.steps += 1;
        self.time_s += dt;
        self.update_porosity()?;
        self.timing.coupling_s += t.elapsed().as_secs_f64();
        Ok(bal)
    }

    /// Total particle momentum sum m v (N s).
    pub fn particle_momentum(&self) -> Vector3<f64> {
        let mut s = Vector3::zeros();
        for (m, v) in self.dem.p.mass.iter().zip(&self.dem.p.vel) {
            s += v * *m;
        }
        s
    }

    /// Fluid velocity of every cell (m/s), superficial, from the last record.
    pub fn velocity_si(&self) -> Vec<[f64; 3]> {
        let s = self.setup.dx_m / self.units.dt;
        self.record
            .u
            .iter()
            .map(|u| [u[0] * s, u[1] * s, u[2] * s])
            .collect()
    }

    /// Pressure deviation of every cell, c_s^2 (rho - 1) in SI (Pa), from the last record.
    pub fn pressure_si(&self) -> Vec<f64> {
        let s = self.setup.fluid_density_kg_m3 * (self.setup.dx_m / self.units.dt).powi(2);
        self.record
            .rho
            .iter()
            .map(|r| (r - 1.0) / 3.0 * s)
            .collect()
    }

    /// Porosity averaged over each z-layer of cells (the profile along the flow).
    pub fn porosity_profile(&self) -> Vec<f64> {
        let nxy = self.dims.nx * self.dims.ny;
        self.eps
            .chunks(nxy)
            .map(|l| l.iter().sum::<f64>() / nxy as f64)
            .collect()
    }
}
