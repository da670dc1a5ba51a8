//! The energy terms of one move (seed 000, "Modelling Methodology" and eq. A2-A3).
//!
//! E = U + E_g + E_d with U the hard-core pair term (0, or infinite on overlap: handled by
//! rejecting the move), E_g = sum w_j z_j with w_j = (rho_j - rho_f) v_j g the buoyant weight,
//! and E_d = sum C_j mu V z_j (eq. A2) with C_j the zz component of the posed resistance
//! tensor (eq. A3). z_j is the centre height above the substrate. Only particle j changes in a
//! move, so
//!   dE = (w_j + mu V C_j') dz + mu V (C_j' - C_j) z_j,
//! written this way so that for a sphere (C' = C) the sign of dE is exactly the sign of dz.

/// Which energy terms a run includes, and their parameters.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EnergyTerms {
    /// Buoyant gravity on.
    pub gravity: bool,
    /// Drag potential on.
    pub drag: bool,
    /// Fluid viscosity mu, Pa s.
    pub viscosity_pa_s: f64,
}

impl EnergyTerms {
    /// dE (J) of moving a grain of buoyant weight `w` (N) by `dz` (m) from centre height `z`
    /// (m), its vertical drag coefficient per unit viscosity changing from `c_old` to `c_new`
    /// (m), at drainage speed `v` (m/s).
    #[inline]
    pub fn delta(&self, w: f64, dz: f64, z: f64, c_old: f64, c_new: f64, v: f64) -> f64 {
        let wg = if self.gravity { w } else { 0.0 };
        if self.drag {
            let f = self.viscosity_pa_s * v;
            (wg + f * c_new) * dz + f * (c_new - c_old) * z
        } else {
            wg * dz
        }
    }
}

/// The acceptance rule: T = 0 (the seed's Table B1) accepts iff dE < 0; a temperature kT > 0
/// (J) accepts by Metropolis, taking `uniform` only when dE >= 0.
#[inline]
pub fn accept(de_j: f64, kt_j: f64, uniform: impl FnOnce() -> f64) -> bool {
    if de_j < 0.0 {
        true
    } else if kt_j > 0.0 {
        uniform() < (-de_j / kt_j).exp()
    } else {
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_energy_change_has_the_sign_of_dz() {
        let e = EnergyTerms {
            gravity: true,
            drag: true,
            viscosity_pa_s: 0.01,
        };
        for &dz in &[1e-30, -1e-30, 3e-8, -3e-8] {
            let de = e.delta(1e-15, dz, 5e-6, 1e-6, 1e-6, 1e-7);
            assert_eq!(de.signum(), dz.signum());
        }
    }

    #[test]
    fn zero_temperature_rejects_no_change() {
        assert!(!accept(0.0, 0.0, || unreachable!()));
        assert!(accept(-1e-300, 0.0, || unreachable!()));
        assert!(accept(1.0, 1.0, || 0.3));
        assert!(!accept(1.0, 1.0, || 0.5));
    }
}
