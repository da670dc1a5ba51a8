//! Volume observables: the packing fraction of a configuration in its container.

use super::Configuration;
use crate::Result;

/// Packing fraction: total particle volume over container volume (thesis eq. 3.1).
pub fn packing_fraction(c: &Configuration) -> Result<f64> {
    let v = match (c.wall_diameter, c.wedge) {
        (Some(d), _) => 0.25 * std::f64::consts::PI * d * d * c.box_length,
        (None, Some((l, a))) => 0.5 * l * l * a.tan() * c.box_length,
        (None, None) => c.box_length.powi(3),
    };
    Ok(c.total_volume()? / v)
}
