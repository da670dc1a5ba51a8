//! `porelab bench brownian`, and the harmonic-trap driver shared with validation case 413.
//!
//! Harmonic trap: an isotropic external force F = -k r about the origin, put into the engine
//! through its position-dependent external-force hook, the field source of
//! [`Magnetic`](super::integrator::Magnetic): a closure returning a uniform H0 (so that a
//! [`LangevinMoment::Fixed`] moment m0 points along x) together with the "gradient"
//! G(r) = -(k / (mu0 m0)) r e_x^T, so that the force of eq. 6.20 as implemented,
//! mu0 G m = -k r. This is not a Maxwell field (a moment along H cannot be trapped by a real
//! field: |H| has no maximum in free space), it is only the engine's generic hook for an
//! external force; the whole force path (field source -> moment law -> mu0 G m -> update
//! eq. 6.11) is exercised.

use super::forces::{FieldFn, LangevinMoment};
use super::integrator::Magnetic;
use crate::consts::MU0;
use crate::error::{require_positive, Result};
use nalgebra::{Matrix3, Vector3};

/// Moment (A m^2) and field (A/m) used by [`harmonic_trap`]; any non-zero values give the
/// same force.
const TRAP_MOMENT: f64 = 1e-16;
const TRAP_FIELD: f64 = 1e5;

/// The magnetic terms that make the force on every particle F = -k r (N), r its position (m),
/// `stiffness` k in N/m (no dipole pairs).
pub fn harmonic_trap(stiffness: f64) -> Result<Magnetic> {
    require_positive(stiffness, || format!("trap stiffness k = {stiffness} N/m"))?;
    let c = -stiffness / (MU0 * TRAP_MOMENT);
    let source = FieldFn(move |p: &Vector3<f64>| {
        let mut g = Matrix3::zeros();
        g.set_column(0, &(p * c));
        (Vector3::new(TRAP_FIELD, 0.0, 0.0), g)
    });
    Ok(Magnetic {
        source: Box::new(source),
        moment: LangevinMoment::fixed(TRAP_MOMENT)?,
        dipole_pairs: false,
        cutoff: 0.0,
    })
}
