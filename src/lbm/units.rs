//! SI at the boundary, lattice units inside. A flow is given by the lattice spacing dx (m),
//! the kinematic viscosity nu (m^2/s) and either the time step dt (s) or the relaxation time
//! tau; then nu_lattice = nu dt / dx^2 and tau = 3 nu_lattice + 1/2 (seed 002 eq. 8-9). The
//! conversions between tau and the lattice viscosity are written here and nowhere else
//! ([`nu_from_tau`], [`tau_from_nu`]).

use crate::error::{invalid, Result};

/// Smallest tau accepted: below it BGK and TRT lose stability at any useful Mach number.
pub const TAU_MIN: f64 = 0.505;
/// Largest Mach number u / c_s accepted (compressibility error ~ Ma^2).
pub const MACH_MAX: f64 = 0.3;

/// The kinematic viscosity (lattice units) of relaxation time `tau`: nu = (tau - 1/2)/3
/// (seed 002 eq. 8).
pub fn nu_from_tau(tau: f64) -> f64 {
    (tau - 0.5) / 3.0
}

/// The relaxation time of the kinematic viscosity `nu` (lattice units): tau = 3 nu + 1/2.
pub fn tau_from_nu(nu: f64) -> f64 {
    3.0 * nu + 0.5
}

/// The SI <-> lattice conversion of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Units {
    /// Lattice spacing (m).
    pub dx: f64,
    /// Time step (s).
    pub dt: f64,
    /// Fluid density (kg/m^3): lattice density 1.
    pub rho: f64,
    /// Kinematic viscosity (m^2/s).
    pub nu: f64,
}

impl Units {
    /// From dx, nu, rho and the relaxation time tau (dt follows).
    pub fn from_tau(dx: f64, nu: f64, rho: f64, tau: f64) -> Result<Units> {
        check_tau(tau)?;
        for (name, v, unit) in [("dx", dx, "m"), ("nu", nu, "m^2/s"), ("rho", rho, "kg/m^3")] {
            if !(v.is_finite() && v > 0.0) {
                return invalid(format!("{name} = {v} {unit}: must be positive and finite"));
            }
        }
        let nu_l = nu_from_tau(tau);
        Ok(Units {
            dx,
            dt: nu_l * dx * dx / nu,
            rho,
            nu,
        })
    }
    pub fn nu_lattice(&self) -> f64 {
        self.nu * self.dt / (self.dx * self.dx)
    }
    pub fn tau(&self) -> f64 {
        tau_from_nu(self.nu_lattice())
    }
    /// Acceleration (m/s^2) -> lattice units.
    pub fn accel_to_lattice(&self, g: f64) -> f64 {
        g * self.dt * self.dt / self.dx
    }
    /// Velocity (lattice units) -> m/s.
    pub fn velocity_to_si(&self, u: f64) -> f64 {
        u * self.dx / self.dt
    }
    /// Velocity (m/s) -> lattice units.
    pub fn velocity_to_lattice(&self, u: f64) -> f64 {
        u * self.dt / self.dx
    }
    /// Permeability (lattice units, dx^2) -> m^2.
    pub fn area_to_si(&self, k: f64) -> f64 {
        k * self.dx * self.dx
    }
}

/// Refuses tau <= TAU_MIN (or not finite) with the rule.
pub fn check_tau(tau: f64) -> Result<()> {
    if !(tau.is_finite() && tau >= TAU_MIN) {
        return invalid(format!(
            "relaxation time tau = {tau}: must be >= {TAU_MIN} (nu_lattice = (tau - 1/2)/3 \
             = {:.3e}); tau this close to 1/2 is unstable: raise the viscosity or dt, or refine dx",
            nu_from_tau(tau)
        ));
    }
    Ok(())
}

/// Refuses a lattice velocity whose Mach number u sqrt(3) exceeds MACH_MAX.
pub fn check_mach(u_lattice: f64, what: &str) -> Result<f64> {
    let mach = u_lattice.abs() * 3f64.sqrt();
    if !(mach.is_finite() && mach <= MACH_MAX) {
        return invalid(format!(
            "{what}: velocity {u_lattice:.3e} lattice units is Mach {mach:.3} > {MACH_MAX}: \
             lower the driving force or refine the lattice"
        ));
    }
    Ok(mach)
}

/// One line for the run log: tau, Mach, Re.
pub fn describe(tau: f64, u_lattice: f64, length_cells: f64) -> String {
    let nu = nu_from_tau(tau);
    format!(
        "tau = {tau:.4}, nu = {nu:.4e} (lattice), Mach = {:.3e}, Re = {:.3e} (u {u_lattice:.3e}, L = {length_cells} cells)",
        u_lattice.abs() * 3f64.sqrt(),
        u_lattice.abs() * length_cells / nu
    )
}
