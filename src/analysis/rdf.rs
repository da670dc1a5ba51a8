//! Radial distribution function and coordination of a bed of spheres between horizontal walls,
//! periodic in x and y (seed 002 Fig. 3: g against r / <D>).
//!
//! Reading of g in a bed with a floor and a free surface: the reference particles are those
//! whose centres lie in the slab [z_a + r_max, z_b - r_max] inside the bulk slab [z_a, z_b],
//! so that every shell of radius below r_max around them lies inside the bulk slab; their
//! neighbours are all particles (minimum image in x and y). The density is the number of
//! centres in the bulk slab over its volume, so g tends to 1 in a homogeneous bulk:
//! g(r_k) = N_k / (N_ref rho V_shell,k), N_k the neighbours counted in shell k.

use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Minimum-image difference of one periodic component.
fn wrap(d: f64, l: f64) -> f64 {
    d - l * (d / l).round()
}

/// A bed: centres (m), radii (m), periodic lengths lx, ly (m).
#[derive(Debug, Clone, Copy)]
pub struct Bed<'a> {
    pub pos: &'a [Vector3<f64>],
    pub radius: &'a [f64],
    pub lx_m: f64,
    pub ly_m: f64,
}

impl Bed<'_> {
    fn check(&self) -> Result<()> {
        if self.pos.len() != self.radius.len() {
            return invalid(format!(
                "bed: {} centres but {} radii",
                self.pos.len(),
                self.radius.len()
            ));
        }
        for (name, l) in [("lx_m", self.lx_m), ("ly_m", self.ly_m)] {
            if !(l.is_finite() && l > 0.0) {
                return invalid(format!("bed: {name} = {l}: must be positive and finite"));
            }
        }
        if let Some(i) = self
            .radius
            .iter()
            .position(|r| !(r.is_finite() && *r > 0.0))
        {
            return invalid(format!(
                "bed: radius of particle {i} = {}: must be positive and finite",
                self.radius[i]
            ));
        }
        Ok(())
    }

    /// Mean diameter <D> (m).
    pub fn mean_diameter(&self) -> f64 {
        2.0 * self.radius.iter().sum::<f64>() / self.radius.len().max(1) as f64
    }
}

/// The g(r) of the module note: rows (r / <D> at the bin centre, g), `bins` bins over
/// (0, r_max_over_d <D>], with the bulk slab [z_a, z_b] (m). Errors when the lateral box is
/// narrower than 2 r_max (the minimum image would miss neighbours) or when no reference
/// particle is left.
pub fn slab_rdf(
    bed: &Bed,
    z_a_m: f64,
    z_b_m: f64,
    r_max_over_d: f64,
    bins: usize,
) -> Result<Vec<(f64, f64)>> {
    bed.check()?;
    if bins == 0 {
        return invalid("g(r): bins = 0: need at least one bin");
    }
    let d = bed.mean_diameter();
    let r_max = r_max_over_d * d;
    if !(r_max.is_finite() && r_max > 0.0) {
        return invalid(format!(
            "g(r): r_max / <D> = {r_max_over_d}: must be positive and finite"
        ));
    }
    if 2.0 * r_max > bed.lx_m.min(bed.ly_m) {
        return invalid(format!(
            "g(r): r_max = {r_max} m: must be at most half the lateral box ({} m x {} m)",
            bed.lx_m, bed.ly_m
        ));
    }
    let (lo, hi) = (z_a_m + r_max, z_b_m - r_max);
    let refs: Vec<usize> = (0..bed.pos.len())
        .filter(|&i| bed.pos[i].z >= lo && bed.pos[i].z <= hi)
        .collect();
    if refs.is_empty() {
        return invalid(format!(
            "g(r): no centre in [{lo}, {hi}] m (the bulk slab [{z_a_m}, {z_b_m}] m less r_max \
             on each side)"
        ));
    }
    let in_bulk = bed
        .pos
        .iter()
        .filter(|p| p.z >= z_a_m && p.z <= z_b_m)
        .count();
    let rho = in_bulk as f64 / (bed.lx_m * bed.ly_m * (z_b_m - z_a_m));
    let dr = r_max / bins as f64;
    let mut hist = vec![0u64; bins];
    for &i in &refs {
        for (j, q) in bed.pos.iter().enumerate() {
            if j == i {
                continue;
            }
            let v = Vector3::new(
                wrap(q.x - bed.pos[i].x, bed.lx_m),
                wrap(q.y - bed.pos[i].y, bed.ly_m),
                q.z - bed.pos[i].z,
            );
            let r = v.norm();
            if r < r_max {
                hist[((r / dr) as usize).min(bins - 1)] += 1;
            }
        }
    }
    Ok(hist
        .iter()
        .enumerate()
        .map(|(k, &h)| {
            let (r0, r1) = (k as f64 * dr, (k + 1) as f64 * dr);
            let shell = 4.0 / 3.0 * PI * (r1.powi(3) - r0.powi(3));
            (
                0.5 * (r0 + r1) / d,
                h as f64 / (refs.len() as f64 * rho * shell),
            )
        })
        .collect())
}

/// Mean number of contacts (`counts`, one per particle) over the particles whose centres lie
/// in [z_a, z_b]; `None` when there are none.
pub fn mean_coordination_in(
    pos: &[Vector3<f64>],
    counts: &[usize],
    z_a_m: f64,
    z_b_m: f64,
) -> Option<f64> {
    let (sum, n) = pos
        .iter()
        .zip(counts)
        .filter(|(p, _)| p.z >= z_a_m && p.z <= z_b_m)
        .fold((0usize, 0usize), |(s, n), (_, c)| (s + c, n + 1));
    (n > 0).then(|| sum as f64 / n as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A simple cubic lattice of spacing a (= D) in a slab of m^2 x layers sites: the running
    /// coordination number 4 pi rho int g r^2 dr counts exactly 6 neighbours below sqrt(2) a,
    /// 18 below sqrt(3) a and 26 below 2 a.
    #[test]
    fn simple_cubic_shell_counts() {
        let (a, m, layers) = (1.0, 8usize, 16usize);
        let mut pos = Vec::new();
        for k in 0..layers {
            for j in 0..m {
                for i in 0..m {
                    pos.push(Vector3::new(
                        i as f64 * a,
                        j as f64 * a,
                        (k as f64 + 0.5) * a,
                    ));
                }
            }
        }
        let radius = vec![0.5 * a; pos.len()];
        let l = m as f64 * a;
        let bed = Bed {
            pos: &pos,
            radius: &radius,
            lx_m: l,
            ly_m: l,
        };
        // bulk slab [0, layers a]: exactly layers m^2 centres
        let bins = 400;
        let g = slab_rdf(&bed, 0.0, layers as f64 * a, 2.5, bins).unwrap();
        let in_bulk = pos.len() as f64 / (l * l * layers as f64 * a);
        let dr = 2.5 * a / bins as f64;
        let running = |r: f64| -> f64 {
            g.iter()
                .filter(|(x, _)| *x < r)
                .map(|(x, gg)| {
                    let (r0, r1) = (x - 0.5 * dr, x + 0.5 * dr);
                    gg * in_bulk * 4.0 / 3.0 * PI * (r1.powi(3) - r0.powi(3))
                })
                .sum()
        };
        for (r, n) in [(1.2, 6.0), (1.6, 18.0), (1.9, 26.0)] {
            assert!((running(r) - n).abs() < 1e-9, "N({r}) = {}", running(r));
        }
    }

    /// Uniform random points: g = 1 within its Poisson noise at every r.
    #[test]
    fn ideal_gas_is_flat() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (l, h) = (10.0, 30.0);
        let pos: Vec<Vector3<f64>> = (0..6000)
            .map(|_| {
                Vector3::new(
                    rng.gen::<f64>() * l,
                    rng.gen::<f64>() * l,
                    rng.gen::<f64>() * h,
                )
            })
            .collect();
        let radius = vec![0.5; pos.len()];
        let bed = Bed {
            pos: &pos,
            radius: &radius,
            lx_m: l,
            ly_m: l,
        };
        let g = slab_rdf(&bed, 0.0, h, 4.0, 8).unwrap();
        let mean: f64 = g.iter().map(|x| x.1).sum::<f64>() / g.len() as f64;
        // outer bins hold thousands of pairs: 5 % is over 3 standard deviations
        assert!((mean - 1.0).abs() < 0.05, "{g:?}");
        assert!(g[4..].iter().all(|x| (x.1 - 1.0).abs() < 0.05), "{g:?}");
    }

    #[test]
    fn bad_input_is_named() {
        let pos = vec![Vector3::new(0.0, 0.0, 0.2); 2];
        let radius = vec![0.5; 2];
        let bed = Bed {
            pos: &pos,
            radius: &radius,
            lx_m: 4.0,
            ly_m: 4.0,
        };
        let e = slab_rdf(&bed, 0.0, 2.0, 3.0, 10).unwrap_err().to_string();
        assert!(e.contains("r_max"), "{e}");
        let e = slab_rdf(&bed, 0.0, 2.0, 1.0, 10).unwrap_err().to_string();
        assert!(e.contains("no centre"), "{e}");
        let e = slab_rdf(&bed, 0.0, 2.0, 1.0, 0).unwrap_err().to_string();
        assert!(e.contains("bins"), "{e}");
    }
}
