//! Hydrodynamic resistance: Stokes sphere and Happel-Brenner ellipsoids (seed 000 appendix A).

pub mod happel_brenner;
pub mod stokes;

pub use happel_brenner::{
    mobility_averaged_resistance, principal_resistances, resistance_tensor, EllipsoidDrag,
};
pub use stokes::stokes_resistance;

use crate::error::{invalid, Result};

/// Checks a dynamic viscosity (Pa s): positive and finite.
pub(crate) fn check_viscosity(mu: f64) -> Result<()> {
    if !(mu.is_finite() && mu > 0.0) {
        return invalid(format!(
            "viscosity = {mu} Pa s: must be positive and finite"
        ));
    }
    Ok(())
}
