//! Physical constants in SI units, with their source.

/// Vacuum magnetic permeability mu0 in T m/A (CODATA 2018: 1.25663706212(19)e-6 N/A^2).
pub const MU0: f64 = 1.256_637_062_12e-6;

/// Boltzmann constant kB in J/K (exact since the 2019 SI redefinition).
pub const KB: f64 = 1.380_649e-23;

/// Standard acceleration of gravity g_n in m/s^2 (3rd CGPM, 1901; exact by definition).
pub const STANDARD_GRAVITY: f64 = 9.806_65;
