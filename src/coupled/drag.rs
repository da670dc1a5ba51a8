//! Fluid–particle drag per lattice cell: Carman–Kozeny permeability (seed 002 eq. 11), the
//! Ergun (eps < 0.8) and Wen & Yu (eps >= 0.8) correlations the seed names (seed 002 refs. 13,
//! 14; their combination is Gidaspow's, D. Gidaspow, "Multiphase Flow and Fluidization",
//! Academic Press 1994, eq. 5.39-5.41), and the smoothing of the switch.
//!
//! The interphase drag per unit mixture volume is beta (u_f - u_s), u_f the interstitial fluid
//! velocity, u_s the solid velocity:
//! * Ergun: beta = 150 (1 - eps)^2 mu / (eps d^2) + 1.75 (1 - eps) rho |u_f - u_s| / d;
//! * Wen–Yu: beta = 3/4 C_d eps (1 - eps) rho |u_f - u_s| / d eps^-2.65, C_d = 24/Re (1 +
//!   0.15 Re^0.687) for Re < 1000 and 0.44 above, Re = eps rho |u_f - u_s| d / mu.
//!
//! On the fluid (Guo–Zhao form, per unit fluid mass, superficial u = eps u_f, matrix velocity
//! w = eps u_s) this is a = -(beta / (rho eps)) (u - w). The Ergun beta is exactly the Guo–Zhao
//! porous forcing with the Carman–Kozeny K = eps^3 d^2 / (150 (1 - eps)^2) and F_eps =
//! 1.75 / sqrt(150 eps^3): its two coefficients are written through K. Wen–Yu's Re-dependent
//! factor is evaluated with the previous step's slip (a lagged coefficient; the force stays
//! implicit in u).
//!
//! Switch: [`Switch::Sharp`] is the seed's rule; [`Switch::Blend`] (default) is the arctan blend
//! of Huilin & Gidaspow (Chem. Eng. Sci. 58, 3777, 2003, eq. 17): beta = (1 - phi) beta_Ergun +
//! phi beta_WenYu with phi = 1/2 + arctan(262.5 (eps - 0.8)) / pi (262.5 = 150 x 1.75), which
//! is continuous in eps; its weight is within 0.01 of the sharp rule's more than 0.12 away
//! from 0.8 (within 0.012 at eps = 0.7 and 0.9).

use crate::lbm::forcing::guo_zhao_coefficients;
use std::f64::consts::PI;

/// How the Ergun and Wen–Yu branches meet at eps = 0.8.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Switch {
    Sharp,
    Blend,
}

impl Switch {
    pub fn name(&self) -> &'static str {
        match self {
            Switch::Sharp => "sharp at eps = 0.8 (Gidaspow)",
            Switch::Blend => "arctan blend (Huilin & Gidaspow 2003)",
        }
    }
}

/// The porosity where Gidaspow switches from Ergun to Wen–Yu.
pub const EPS_SWITCH: f64 = 0.8;

/// Carman–Kozeny permeability, seed 002 eq. 11: K = eps^3 d^2 / (150 (1 - eps)^2) (units of d^2).
pub fn carman_kozeny(eps: f64, d: f64) -> f64 {
    eps * eps * eps * d * d / (150.0 * (1.0 - eps) * (1.0 - eps))
}

/// Weight of the Wen–Yu branch: 0 or 1 for the sharp switch, the arctan blend otherwise.
pub fn wen_yu_weight(eps: f64, switch: Switch) -> f64 {
    match switch {
        Switch::Sharp => {
            if eps < EPS_SWITCH {
                0.0
            } else {
                1.0
            }
        }
        Switch::Blend => 0.5 + (262.5 * (eps - EPS_SWITCH)).atan() / PI,
    }
}

/// Wen–Yu's correction to the Stokes drag coefficient: C_d Re / 24.
pub fn wen_yu_factor(re: f64) -> f64 {
    if re < 1000.0 {
        1.0 + 0.15 * re.powf(0.687)
    } else {
        0.44 * re / 24.0
    }
}

/// The Guo–Zhao coefficients (lin, quad) of a cell (lattice units: a = -(lin + quad |u - w|)
/// (u - w)) for porosity `eps` (< 1), mean particle diameter `d` (cells), viscosity `nu`
/// (lattice) and the lagged superficial slip `slip` = |u - w| (lattice) for Wen–Yu's Re.
pub fn cell_coefficients(eps: f64, d: f64, nu: f64, slip: f64, switch: Switch) -> (f64, f64) {
    let phi = wen_yu_weight(eps, switch);
    let (mut lin, mut quad) = (0.0, 0.0);
    if phi < 1.0 {
        // Ergun through the Carman–Kozeny permeability (Guo & Zhao's own form)
        let (l, q) = guo_zhao_coefficients(eps, carman_kozeny(eps, d), nu, true);
        lin += (1.0 - phi) * l;
        quad += (1.0 - phi) * q;
    }
    if phi > 0.0 {
        // beta_WY / (rho eps) = 18 nu (1 - eps) eps^-3.65 / d^2 * C_d Re / 24, with
        // Re = eps |u_f - u_s| d / nu = |u - w| d / nu
        let re = slip * d / nu;
        lin += phi * 18.0 * nu * (1.0 - eps) * eps.powf(-3.65) / (d * d) * wen_yu_factor(re);
    }
    (lin, quad)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Guo–Zhao coefficients reproduce Gidaspow's beta / (rho eps) written out in SI-like
    /// numbers, and the single-particle limit of Wen–Yu is Stokes: beta V / (1 - eps) -> 3 pi
    /// mu d as eps -> 1.
    #[test]
    fn coefficients_match_the_correlations() {
        let (nu, d) = (0.1, 1.7);
        for &eps in &[0.4, 0.6, 0.75] {
            let slip = 0.013;
            let (lin, quad) = cell_coefficients(eps, d, nu, slip, Switch::Sharp);
            let uf = slip / eps;
            let beta =
                150.0 * (1.0 - eps).powi(2) * nu / (eps * d * d) + 1.75 * (1.0 - eps) * uf / d;
            let got = lin + quad * slip;
            assert!((got - beta / eps).abs() < 1e-14 * beta / eps, "eps {eps}");
        }
        for &eps in &[0.85, 0.95] {
            let slip = 0.02;
            let (lin, quad) = cell_coefficients(eps, d, nu, slip, Switch::Sharp);
            assert_eq!(quad, 0.0);
            let uf = slip / eps;
            let re = eps * uf * d / nu;
            let cd = 24.0 / re * (1.0 + 0.15 * re.powf(0.687));
            let beta = 0.75 * cd * eps * (1.0 - eps) * uf / d * eps.powf(-2.65);
            assert!((lin - beta / eps).abs() < 1e-13 * beta / eps, "eps {eps}");
        }
        // Stokes limit: F = beta (V / (1 - eps)) u_rel -> 3 pi nu d u_rel (rho = 1)
        let eps: f64 = 1.0 - 1e-9;
        let (lin, _) = cell_coefficients(eps, d, nu, 0.0, Switch::Sharp);
        let beta = lin * eps;
        let v = PI * d * d * d / 6.0;
        let f = beta * v / (1.0 - eps);
        assert!((f / (3.0 * PI * nu * d) - 1.0).abs() < 1e-8);
    }

    #[test]
    fn blend_is_continuous_and_close_to_the_switch() {
        assert!((wen_yu_weight(0.8, Switch::Blend) - 0.5).abs() < 1e-15);
        assert!(wen_yu_weight(0.79, Switch::Blend) < 0.5);
        for (e, sharp) in [(0.6, 0.0), (0.7, 0.0), (0.9, 1.0), (0.99, 1.0)] {
            let w = wen_yu_weight(e, Switch::Blend);
            assert!((w - sharp).abs() < 0.02, "{e}: {w}");
        }
        // Carman–Kozeny at eps = 0.4, d = 1: 0.064 / (150 * 0.36)
        assert!((carman_kozeny(0.4, 1.0) - 0.064 / 54.0).abs() < 1e-17);
    }
}
