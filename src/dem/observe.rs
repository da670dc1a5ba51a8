//! Observables of a DEM bed: porosity against height from exact sphere–slab volumes, bulk
//! porosity away from the floor and the free surface (seed 002 Fig. 10), coordination number.

use std::f64::consts::PI;

/// Volume of the part of a sphere (centre height zc, radius r) between the planes z = a < b:
/// the integral of pi (r^2 - (z - zc)^2) dz over [a, b] intersected with [zc - r, zc + r].
pub fn sphere_slab_volume(zc: f64, r: f64, a: f64, b: f64) -> f64 {
    let lo = (a - zc).max(-r);
    let hi = (b - zc).min(r);
    if hi <= lo {
        return 0.0;
    }
    let prim = |u: f64| PI * (r * r * u - u * u * u / 3.0);
    prim(hi) - prim(lo)
}

/// Porosity in `bins` equal slabs between heights z0 and z1 of a box of cross-section `area`:
/// rows (z_lo, z_hi, porosity).
pub fn porosity_profile(
    z: &[f64],
    r: &[f64],
    area: f64,
    z0: f64,
    z1: f64,
    bins: usize,
) -> Vec<(f64, f64, f64)> {
    let dz = (z1 - z0) / bins as f64;
    let mut solid = vec![0.0; bins];
    for (zc, rr) in z.iter().zip(r) {
        let k0 = (((zc - rr - z0) / dz).floor().max(0.0) as usize).min(bins);
        let k1 = ((((zc + rr - z0) / dz).floor() + 1.0).max(0.0) as usize).min(bins);
        for (k, s) in solid.iter_mut().enumerate().take(k1).skip(k0) {
            let a = z0 + k as f64 * dz;
            *s += sphere_slab_volume(*zc, *rr, a, a + dz);
        }
    }
    solid
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let a = z0 + k as f64 * dz;
            (a, a + dz, 1.0 - s / (area * dz))
        })
        .collect()
}

/// Porosity of the slab [a, b] (exact sphere–slab volumes).
pub fn slab_porosity(z: &[f64], r: &[f64], area: f64, a: f64, b: f64) -> f64 {
    let s: f64 = z
        .iter()
        .zip(r)
        .map(|(zc, rr)| sphere_slab_volume(*zc, *rr, a, b))
        .sum();
    1.0 - s / (area * (b - a))
}

/// Bed top: the highest sphere top (m).
pub fn bed_top(z: &[f64], r: &[f64]) -> f64 {
    z.iter().zip(r).map(|(a, b)| a + b).fold(0.0, f64::max)
}

/// The bulk region [2 <d>, top - 2 <d>] (floor at 0) used for the bulk porosity, if not empty.
pub fn bulk_region(z: &[f64], r: &[f64], top: f64) -> Option<(f64, f64)> {
    if r.is_empty() {
        return None;
    }
    let d_mean = 2.0 * r.iter().sum::<f64>() / r.len() as f64;
    let (a, b) = (2.0 * d_mean, top - 2.0 * d_mean);
    let _ = z;
    (b > a).then_some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slab_volumes_add_up_to_the_sphere() {
        let (zc, r) = (0.37, 0.5);
        let total: f64 = (0..7)
            .map(|k| sphere_slab_volume(zc, r, -0.5 + 0.2 * k as f64, -0.3 + 0.2 * k as f64))
            .sum();
        assert!((total - 4.0 / 3.0 * PI * r.powi(3)).abs() < 1e-15);
        // a cap of height h has volume pi h^2 (3 r - h) / 3
        let h = 0.2;
        let cap = sphere_slab_volume(zc, r, zc + r - h, 10.0);
        assert!((cap - PI * h * h * (3.0 * r - h) / 3.0).abs() < 1e-15);
    }

    #[test]
    fn profile_matches_slab_porosity() {
        let z = [0.5, 1.2, 2.9];
        let r = [0.5, 0.4, 0.6];
        let prof = porosity_profile(&z, &r, 4.0, 0.0, 4.0, 8);
        for (a, b, e) in prof {
            assert!((e - slab_porosity(&z, &r, 4.0, a, b)).abs() < 1e-15);
        }
    }
}
