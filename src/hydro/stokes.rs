//! Stokes drag of a sphere: F = 6 pi mu a U (Stokes 1851; Happel & Brenner 1965, eq. 2-6.7).

use super::check_viscosity;
use crate::error::{invalid, Result};

/// Translational resistance 6 pi mu a (N s/m) of a sphere of radius a (m) in a fluid of
/// viscosity mu (Pa s).
pub fn stokes_resistance(viscosity: f64, radius: f64) -> Result<f64> {
    check_viscosity(viscosity)?;
    if !(radius.is_finite() && radius > 0.0) {
        return invalid(format!("radius = {radius} m: must be positive and finite"));
    }
    Ok(6.0 * std::f64::consts::PI * viscosity * radius)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_and_errors() {
        let f = stokes_resistance(1e-3, 1e-6).unwrap();
        let want = 6.0 * std::f64::consts::PI * 1e-9;
        assert!((f - want).abs() < 4e-16 * want);
        assert!(stokes_resistance(0.0, 1.0)
            .unwrap_err()
            .to_string()
            .contains("viscosity = 0"));
        assert!(stokes_resistance(1.0, -2.0)
            .unwrap_err()
            .to_string()
            .contains("radius = -2"));
    }
}
