//! Uniform magnetization of a cylinder in an external field (thesis 003, section 6.3; chapter 5
//! for the Stoner–Wohlfarth remark): saturated at a fixed angle alpha to the axis, or saturated
//! in the direction that minimises the Stoner–Wohlfarth energy with shape anisotropy.
//!
//! **Demagnetizing factors.** A uniformly magnetized body has magnetostatic energy
//! (mu0/2) V M . N M with N the *magnetometric* tensor (the volume average of -T, T the field
//! tensor of `porelab::magnetics::Cylinder`), so the magnetometric factors are the exact ones
//! for the uniform magnetization the thesis assumes. For a cylinder of length 2L and diameter
//! 2R, gamma = L/R (length over diameter), the axial factor is (the exact chi = 0 magnetometric
//! factor of Chen, Brug & Goldfarb, IEEE Trans. Magn. 27, 3601 (1991), who obtain it from the
//! self- and mutual inductance of the end discs; case 411 also checks it, independently of the
//! citation, against the volume average of porelab's own field tensor):
//!
//!   N_par = 1 + 4/(3 pi gamma) - 4 sqrt(1 + gamma^2)/(3 pi gamma) [gamma^2 K(m) + (1 - gamma^2) E(m)],
//!   m = k^2 = 1/(1 + gamma^2),
//!
//! with K, E the complete elliptic integrals of parameter m. It is exact (no approximation).
//! porelab evaluates gamma^2 (K - E) as (1 - m) R_D(0, 1 - m, 1)/3 (Carlson), which avoids the
//! cancellation of K - E for long rods; the remaining subtraction 1 + ... costs about
//! 1e-16/N_par relative (case 411 measures it against mpmath and against the volume average of
//! porelab's field kernel). N_perp = (1 - N_par)/2 (the trace of N is 1).
//!
//! **Stoner–Wohlfarth.** With theta the angle of M from the axis and psi that of H (both in the
//! plane of axis and field), the energy is
//!
//!   E(theta) = (mu0 Ms^2 V/2)(N_perp sin^2 theta + N_par cos^2 theta) - mu0 Ms H V cos(theta - psi).
//!
//! Up to a constant this is K sin^2 theta - mu0 Ms H V cos(theta - psi) with
//! K = mu0 Ms^2 V (N_perp - N_par)/2, i.e. uniaxial anisotropy with anisotropy field
//! H_K = Ms (N_perp - N_par) (easy axis for a long cylinder, easy plane for a flat one). In
//! reduced form e(theta) = (s/2) sin^2 theta - h cos(theta - psi), s = sign(N_perp - N_par),
//! h = H/|H_K|. Stationary points are the unit-circle roots z = exp(i theta) of the quartic
//! z^4 + (2h/s) e^{-i psi} z^3 - (2h/s) e^{i psi} z - 1 = 0 (2 i z^2 e'(theta) = 0), found by
//! Durand–Kerner iteration and polished by Newton on e'(theta); minima have e'' > 0. No grid: a
//! metastable minimum is found however narrow its basin (up to the conditioning of a near-double
//! root, about sqrt(eps) in theta).

use crate::error::{invalid, require_positive, Result};
use crate::magnetics::{Cylinder, Magnet};
use crate::special::elliptic::{carlson_rd, ellip_e};
use nalgebra::{Complex, Vector3};
use std::f64::consts::PI;

/// Saturation magnetization of the thesis' cylinder (section 6.3), A/m.
pub const THESIS_SATURATION: f64 = 985e3;

/// Magnetometric demagnetizing factors (N_par, N_perp) of a solid cylinder of radius R and
/// half-length L (m), from the exact formula in the module documentation.
pub fn cylinder_demag_factors(radius: f64, half_length: f64) -> Result<(f64, f64)> {
    require_positive(radius, || format!("cylinder radius {radius} m"))?;
    require_positive(half_length, || {
        format!("cylinder half-length {half_length} m")
    })?;
    let n_par = axial_demag_factor(half_length / radius)?;
    Ok((n_par, 0.5 * (1.0 - n_par)))
}

/// Magnetometric axial factor N_par of a cylinder with length/diameter `gamma` (> 0).
pub fn axial_demag_factor(gamma: f64) -> Result<f64> {
    require_positive(gamma, || {
        format!("cylinder aspect ratio length/diameter = {gamma}")
    })?;
    let g2 = gamma * gamma;
    let m = 1.0 / (1.0 + g2);
    // gamma^2 K + (1 - gamma^2) E = E + gamma^2 (K - E), and K - E = (m/3) R_D(0, 1 - m, 1)
    // (Carlson), so gamma^2 (K - E) = (1 - m) R_D / 3 without the cancellation of K - E for
    // long rods (which would cost gamma^2 eps).
    let e = ellip_e(m)?;
    let one_minus_m = g2 / (1.0 + g2);
    let rd = carlson_rd(0.0, one_minus_m, 1.0)?;
    let c = 4.0 / (3.0 * PI * gamma);
    Ok(1.0 + c - c * (1.0 + g2).sqrt() * (e + one_minus_m * rd / 3.0))
}

/// A saturated uniaxial (shape-anisotropy) Stoner–Wohlfarth particle: saturation Ms (A/m) and
/// magnetometric factors N_par (along the axis) and N_perp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StonerWohlfarth {
    pub saturation: f64,
    pub n_par: f64,
    pub n_perp: f64,
}

impl StonerWohlfarth {
    /// For a cylinder of the given shape; Ms > 0 and finite.
    pub fn for_cylinder(cylinder: &Cylinder, saturation: f64) -> Result<StonerWohlfarth> {
        let (n_par, n_perp) =
            cylinder_demag_factors(cylinder.radius_m(), cylinder.half_length_m())?;
        StonerWohlfarth::new(saturation, n_par, n_perp)
    }

    /// Ms > 0 finite; factors finite in [0, 1].
    pub fn new(saturation: f64, n_par: f64, n_perp: f64) -> Result<StonerWohlfarth> {
        require_positive(saturation, || {
            format!("saturation magnetization {saturation} A/m")
        })?;
        for (name, v) in [("N_par", n_par), ("N_perp", n_perp)] {
            if !(v.is_finite() && (0.0..=1.0).contains(&v)) {
                return invalid(format!(
                    "demagnetizing factor {name} = {v}: must be finite and in [0, 1]"
                ));
            }
        }
        Ok(StonerWohlfarth {
            saturation,
            n_par,
            n_perp,
        })
    }

    /// Shape-anisotropy field H_K = Ms (N_perp - N_par) (A/m): > 0 easy axis, < 0 easy plane.
    pub fn anisotropy_field(&self) -> f64 {
        self.saturation * (self.n_perp - self.n_par)
    }

    /// Energy per volume (J/m^3) at magnetization angle theta from the axis, field H (A/m) at
    /// angle psi from the axis (angles in rad, in the plane of axis and field).
    pub fn energy_density(&self, theta: f64, h: f64, psi: f64) -> f64 {
        let ms = self.saturation;
        let (s, c) = theta.sin_cos();
        crate::consts::MU0
            * (0.5 * ms * ms * (self.n_perp * s * s + self.n_par * c * c)
                - ms * h * (theta - psi).cos())
    }

    /// Reduced problem (s, h_reduced); s = 0 when there is no shape anisotropy.
    fn reduced(&self, h: f64) -> (f64, f64) {
        let hk = self.anisotropy_field();
        if hk == 0.0 {
            (0.0, f64::INFINITY)
        } else {
            (hk.signum(), h / hk.abs())
        }
    }

    /// Stationary points theta in [0, pi] (ascending) of the reduced energy, with e''(theta).
    /// Requires an anisotropy (s != 0) and h_reduced > 0.
    fn stationary(&self, s: f64, hr: f64, psi: f64) -> Vec<(f64, f64)> {
        let d1 = |t: f64| 0.5 * s * (2.0 * t).sin() + hr * (t - psi).sin();
        let d2 = |t: f64| s * (2.0 * t).cos() + hr * (t - psi).cos();
        let scale = 1.0 + hr;
        let mut out: Vec<(f64, f64)> = Vec::new();
        for z in quartic_roots(s, hr, psi) {
            // Stationary points are the roots on the unit circle; polish them in theta.
            if (z.norm() - 1.0).abs() > 1e-3 {
                continue;
            }
            let mut t = z.arg();
            let mut ok = false;
            for _ in 0..60 {
                let f = d1(t);
                if f.abs() <= 4.0 * f64::EPSILON * scale {
                    ok = true;
                    break;
                }
                let fp = d2(t);
                if fp == 0.0 {
                    break;
                }
                t -= (f / fp).clamp(-0.1, 0.1);
            }
            if !ok {
                continue;
            }
            // Fold into [0, 2 pi) and keep [0, pi]: for psi in [0, pi] the half plane
            // sin theta < 0 is never lower (cos(t - psi) >= cos(t + psi) there), and for
            // psi = 0 or pi it is the mirror image of [0, pi].
            t = t.rem_euclid(2.0 * PI);
            if t > PI + 1e-12 {
                if psi == 0.0 || psi == PI {
                    t = 2.0 * PI - t;
                } else {
                    continue;
                }
            }
            let t = t.clamp(0.0, PI);
            if !out.iter().any(|(m, _)| (m - t).abs() < 1e-9) {
                out.push((t, d2(t)));
            }
        }
        out.sort_by(|a, b| a.0.total_cmp(&b.0));
        out
    }

    /// All local minima theta in [0, pi] (strict: e'' > 0) of the energy for a field of
    /// magnitude `h` (A/m, >= 0) at angle `psi` in [0, pi] from the axis, ascending. With h = 0
    /// and an easy axis the minima are 0 and pi; with h = 0 and an easy plane, pi/2. Without
    /// anisotropy (N_par = N_perp) and h > 0 the one minimum is psi.
    pub fn local_minima(&self, h: f64, psi: f64) -> Result<Vec<f64>> {
        check_field(h, psi)?;
        let (s, hr) = self.reduced(h);
        if s == 0.0 {
            if h == 0.0 {
                return invalid(
                    "no anisotropy and no field: every direction has the same energy".to_string(),
                );
            }
            return Ok(vec![psi]);
        }
        if hr == 0.0 {
            return Ok(if s > 0.0 {
                vec![0.0, PI]
            } else {
                vec![PI / 2.0]
            });
        }
        Ok(self
            .stationary(s, hr, psi)
            .into_iter()
            .filter(|&(_, d2)| d2 > 0.0)
            .map(|(t, _)| t)
            .collect())
    }

    /// The equilibrium (global-minimum) angle theta in [0, pi] of M from the axis: the
    /// stationary point of lowest energy (a degenerate minimum with e'' = 0 included). Ties
    /// (field perpendicular to an easy axis, or none) go to the smaller theta (M . axis >= 0).
    pub fn equilibrium_angle(&self, h: f64, psi: f64) -> Result<f64> {
        check_field(h, psi)?;
        let (s, hr) = self.reduced(h);
        let cands: Vec<f64> = if s == 0.0 || hr == 0.0 {
            self.local_minima(h, psi)?
        } else {
            self.stationary(s, hr, psi)
                .into_iter()
                .map(|(t, _)| t)
                .collect()
        };
        let Some(&first) = cands.first() else {
            return invalid(format!(
                "Stoner-Wohlfarth: no stationary point found for h = {h} A/m, psi = {psi} rad \
                 (root finding failed)"
            ));
        };
        let mut best = first;
        let mut eb = self.energy_density(best, h, psi);
        for &t in &cands[1..] {
            let e = self.energy_density(t, h, psi);
            if e < eb - 1e-14 * eb.abs().max(f64::MIN_POSITIVE) {
                best = t;
                eb = e;
            }
        }
        Ok(best)
    }

    /// Equilibrium magnetization (A/m, world frame) of a cylinder with the given axis in the
    /// external field `h_ext` (A/m, world frame): saturated, at the global-minimum angle.
    pub fn magnetization(&self, axis: &Vector3<f64>, h_ext: &Vector3<f64>) -> Result<Vector3<f64>> {
        let a = unit_axis(axis)?;
        if !h_ext.iter().all(|v| v.is_finite()) {
            return invalid(format!("external field {h_ext:?} A/m: must be finite"));
        }
        let h = h_ext.norm();
        let (psi, perp) = field_frame(&a, h_ext);
        let theta = self.equilibrium_angle(h, psi)?;
        Ok((a * theta.cos() + perp * theta.sin()) * self.saturation)
    }
}

/// Saturated magnetization (A/m, world frame) at angle `alpha` (rad, [0, pi]) from the axis, in
/// the plane of the axis and `toward` (the field direction; its component perpendicular to the
/// axis sets the side). `toward` parallel to the axis picks an arbitrary perpendicular.
pub fn saturated_at_angle(
    axis: &Vector3<f64>,
    toward: &Vector3<f64>,
    alpha: f64,
    saturation: f64,
) -> Result<Vector3<f64>> {
    let a = unit_axis(axis)?;
    if !(alpha.is_finite() && (0.0..=PI).contains(&alpha)) {
        return invalid(format!(
            "magnetization angle alpha = {alpha} rad: must be in [0, pi]"
        ));
    }
    require_positive(saturation, || {
        format!("saturation magnetization {saturation} A/m")
    })?;
    if !toward.iter().all(|v| v.is_finite()) {
        return invalid(format!("field direction {toward:?}: must be finite"));
    }
    let (_, perp) = field_frame(&a, toward);
    Ok((a * alpha.cos() + perp * alpha.sin()) * saturation)
}

/// A `Magnet` for `cylinder` at `centre` with `axis`, magnetized by Stoner–Wohlfarth in `h_ext`.
pub fn stoner_wohlfarth_magnet(
    cylinder: Cylinder,
    centre: Vector3<f64>,
    axis: Vector3<f64>,
    h_ext: &Vector3<f64>,
    saturation: f64,
) -> Result<Magnet> {
    let sw = StonerWohlfarth::for_cylinder(&cylinder, saturation)?;
    let m = sw.magnetization(&axis, h_ext)?;
    Magnet::new(cylinder, centre, axis, m)
}

fn unit_axis(axis: &Vector3<f64>) -> Result<Vector3<f64>> {
    let n = axis.norm();
    if !(n.is_finite() && n > 0.0) {
        return invalid(format!(
            "cylinder axis {axis:?}: must be finite and non-zero"
        ));
    }
    Ok(axis / n)
}

/// (psi, unit perpendicular) of `v` relative to unit axis `a`: psi in [0, pi] the angle of v
/// from a, perp the unit component of v perpendicular to a (an arbitrary perpendicular when v
/// is parallel to a or zero).
fn field_frame(a: &Vector3<f64>, v: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let par = v.dot(a);
    let p = v - a * par;
    let pn = p.norm();
    if pn > 1e-15 * v.norm() && pn > 0.0 {
        (pn.atan2(par), p / pn)
    } else {
        let trial = if a.x.abs() < 0.9 {
            Vector3::x()
        } else {
            Vector3::y()
        };
        let q = trial - a * trial.dot(a);
        (if par < 0.0 { PI } else { 0.0 }, q / q.norm())
    }
}

fn check_field(h: f64, psi: f64) -> Result<()> {
    if !(h.is_finite() && h >= 0.0) {
        return invalid(format!("field magnitude {h} A/m: must be finite and >= 0"));
    }
    if !(psi.is_finite() && (0.0..=PI).contains(&psi)) {
        return invalid(format!("field angle psi = {psi} rad: must be in [0, pi]"));
    }
    Ok(())
}

/// Roots of z^4 + c3 z^3 + c1 z - 1 with c3 = (2h/s) e^{-i psi}, c1 = -(2h/s) e^{i psi}
/// (Durand–Kerner; converges for any distinct starting points not on a symmetry line).
fn quartic_roots(s: f64, h: f64, psi: f64) -> [Complex<f64>; 4] {
    let q = 2.0 * h / s;
    let c3 = Complex::from_polar(q, -psi);
    let c1 = -Complex::from_polar(q, psi);
    let poly = |z: Complex<f64>| ((z + c3) * z * z + c1) * z - Complex::new(1.0, 0.0);
    // Cauchy bound on the root moduli for the starting circle.
    let r = 1.0 + q.max(1.0);
    let seed = Complex::from_polar(1.0, 0.4);
    let mut z: [Complex<f64>; 4] = [
        seed * r,
        seed.powu(2) * r * 0.9,
        seed.powu(3) * r * 0.8,
        seed.powu(4) * r * 0.7,
    ];
    for _ in 0..2000 {
        let mut moved = 0.0f64;
        for i in 0..4 {
            let mut den = Complex::new(1.0, 0.0);
            for j in 0..4 {
                if j != i {
                    den *= z[i] - z[j];
                }
            }
            if den.norm() == 0.0 {
                den = Complex::new(1e-300, 0.0);
            }
            let dz = poly(z[i]) / den;
            z[i] -= dz;
            moved = moved.max(dz.norm() / z[i].norm().max(1.0));
        }
        if moved < 1e-15 {
            break;
        }
    }
    z
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_input_is_named() {
        let e = axial_demag_factor(-1.0).unwrap_err().to_string();
        assert!(e.contains("aspect ratio"), "{e}");
        let e = StonerWohlfarth::new(0.0, 0.1, 0.45)
            .unwrap_err()
            .to_string();
        assert!(e.contains("saturation"), "{e}");
        let sw = StonerWohlfarth::new(1e6, 0.1, 0.45).unwrap();
        let e = sw.local_minima(1.0, 4.0).unwrap_err().to_string();
        assert!(e.contains("psi"), "{e}");
        let e = sw.local_minima(f64::NAN, 1.0).unwrap_err().to_string();
        assert!(e.contains("field magnitude"), "{e}");
        let e = saturated_at_angle(&Vector3::zeros(), &Vector3::x(), 0.1, 1.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("axis"), "{e}");
    }

    #[test]
    fn limits_and_easy_axis() {
        assert!((axial_demag_factor(1e-6).unwrap() - 1.0).abs() < 1e-5);
        assert!(axial_demag_factor(1e4).unwrap() < 1e-3);
        // Easy axis, field along it: M along the field for any h (0 is a minimum; pi too
        // while h < 1, metastable).
        let sw = StonerWohlfarth::new(1e6, 0.1, 0.45).unwrap();
        let hk = sw.anisotropy_field();
        assert_eq!(sw.equilibrium_angle(0.5 * hk, 0.0).unwrap(), 0.0);
        let m = sw.local_minima(0.5 * hk, 0.0).unwrap();
        assert_eq!(m.len(), 2, "{m:?}");
        assert_eq!(sw.local_minima(1.5 * hk, 0.0).unwrap().len(), 1);
        // Field perpendicular, h < 1: sin theta = h.
        let t = sw.equilibrium_angle(0.3 * hk, PI / 2.0).unwrap();
        assert!((t.sin() - 0.3).abs() < 1e-13, "{t}");
        // Above the anisotropy field the magnetization follows a perpendicular field.
        let t = sw.equilibrium_angle(2.0 * hk, PI / 2.0).unwrap();
        assert!((t - PI / 2.0).abs() < 1e-7, "{t}");
        // Extreme fields: M follows a huge field; a tiny one barely tilts it (theta ~ h sin psi).
        let t = sw.equilibrium_angle(1e8 * hk, 1.0).unwrap();
        assert!((t - 1.0).abs() < 1e-7, "{t}");
        let t = sw.equilibrium_angle(1e-8 * hk, 1.0).unwrap();
        assert!((t / (1e-8 * 1f64.sin()) - 1.0).abs() < 1e-6, "{t}");
        let mv = sw
            .magnetization(&Vector3::z(), &Vector3::new(0.3 * hk, 0.0, 0.0))
            .unwrap();
        assert!((mv.x / 1e6 - 0.3).abs() < 1e-13 && mv.z > 0.0, "{mv:?}");
    }

    #[test]
    fn global_minimum_against_brute_force_grid() {
        // The returned angle's energy is never above the best of a 20001-point grid (up to
        // rounding), for easy-axis and easy-plane shapes over random fields.
        use rand::Rng;
        let mut rng = crate::brownian::run_rng(412, 1);
        for (n_par, n_perp) in [(0.1, 0.45), (0.6, 0.2), (0.02, 0.49)] {
            let sw = StonerWohlfarth::new(1e6, n_par, n_perp).unwrap();
            let hk = sw.anisotropy_field().abs();
            for _ in 0..300 {
                let h = hk * 3.0 * rng.gen::<f64>().powi(2);
                let psi = PI * rng.gen::<f64>();
                let t = sw.equilibrium_angle(h, psi).unwrap();
                assert!((0.0..=PI).contains(&t));
                let et = sw.energy_density(t, h, psi);
                let grid = (0..=20000)
                    .map(|k| sw.energy_density(PI * k as f64 / 20000.0, h, psi))
                    .fold(f64::INFINITY, f64::min);
                let scale = crate::consts::MU0 * 1e6 * (1e6 + h);
                assert!(et <= grid + 1e-13 * scale, "h {h} psi {psi}: {et} > {grid}");
            }
        }
    }
}
