//! The solid of a filter bed: identical finite fibres (solid cylinders) posed in a cell that is
//! periodic along x, y and z, with a bin grid listing, per bin, the fibre images a particle in
//! that bin can touch. A particle of radius a touches a fibre when its centre is within a of the
//! solid cylinder (thesis 003, section 6.3).

use crate::brownian::capture::CylinderBody;
use crate::error::{invalid, require_positive, Result};
use nalgebra::Vector3;

/// Fibres of radius R and half-length L in a periodic cell [0, L_x) x [0, L_y) x [0, L_z).
#[derive(Debug, Clone)]
pub struct FibreBed {
    lengths_m: [f64; 3],
    fibres: Vec<CylinderBody>,
    /// Particle radius the bins were built for (m).
    particle_radius_m: f64,
    bins_n: [usize; 3],
    bin_size_m: [f64; 3],
    start: Vec<u32>,
    /// (fibre index, image shift in m)
    images: Vec<(u32, Vector3<f64>)>,
}

impl FibreBed {
    /// `centres` and `axes` (any length, non-zero) one per fibre; the bins are built for
    /// particles of radius `particle_radius_m`.
    pub fn new(
        lengths_m: [f64; 3],
        radius_m: f64,
        half_length_m: f64,
        centres: &[Vector3<f64>],
        axes: &[Vector3<f64>],
        particle_radius_m: f64,
    ) -> Result<FibreBed> {
        for (k, l) in lengths_m.iter().enumerate() {
            require_positive(*l, || {
                format!("filter cell edge {} = {l} m", ["x", "y", "z"][k])
            })?;
        }
        require_positive(particle_radius_m, || {
            format!("particle radius {particle_radius_m} m")
        })?;
        if centres.len() != axes.len() {
            return invalid(format!(
                "filter bed: {} fibre centres but {} axes",
                centres.len(),
                axes.len()
            ));
        }
        let fibres = centres
            .iter()
            .zip(axes)
            .enumerate()
            .map(|(i, (c, a))| {
                CylinderBody::new(*c, *a, radius_m, half_length_m)
                    .map_err(|e| crate::Error::InvalidInput(format!("fibre {i}: {e}")))
            })
            .collect::<Result<Vec<_>>>()?;
        // bins of about the fibre radius plus the particle radius, at least 2 per axis
        let reach = radius_m + particle_radius_m;
        let bins_n = lengths_m.map(|l| ((l / reach.max(l / 64.0)).floor() as usize).max(2));
        let bin_size_m: [f64; 3] = std::array::from_fn(|k| lengths_m[k] / bins_n[k] as f64);
        let bin_half_diagonal = 0.5 * bin_size_m[0].hypot(bin_size_m[1]).hypot(bin_size_m[2]);
        // images within reach of the cell: shifts up to the fibre's extent over the edge
        let extent = half_length_m + reach + bin_half_diagonal;
        let range: [i64; 3] = lengths_m.map(|l| (extent / l).ceil() as i64 + 1);
        let mut candidates = Vec::new();
        for (i, f) in fibres.iter().enumerate() {
            for sz in -range[2]..=range[2] {
                for sy in -range[1]..=range[1] {
                    for sx in -range[0]..=range[0] {
                        let shift = Vector3::new(
                            sx as f64 * lengths_m[0],
                            sy as f64 * lengths_m[1],
                            sz as f64 * lengths_m[2],
                        );
                        let c = f.centre + shift;
                        // keep images whose bounding sphere meets the cell
                        let outside = (0..3)
                            .map(|k| (-c[k]).max(c[k] - lengths_m[k]).max(0.0))
                            .fold(0.0f64, |s, d| s.hypot(d));
                        if outside <= extent {
                            candidates.push((i as u32, shift));
                        }
                    }
                }
            }
        }
        let total = bins_n[0] * bins_n[1] * bins_n[2];
        let mut start = Vec::with_capacity(total + 1);
        let mut images = Vec::new();
        start.push(0u32);
        for b in 0..total {
            let (ix, iy, iz) = (
                b % bins_n[0],
                (b / bins_n[0]) % bins_n[1],
                b / (bins_n[0] * bins_n[1]),
            );
            let centre = Vector3::new(
                (ix as f64 + 0.5) * bin_size_m[0],
                (iy as f64 + 0.5) * bin_size_m[1],
                (iz as f64 + 0.5) * bin_size_m[2],
            );
            for &(i, shift) in &candidates {
                let f = &fibres[i as usize];
                if f.signed_distance(&(centre - shift)) <= particle_radius_m + bin_half_diagonal {
                    images.push((i, shift));
                }
            }
            if images.len() > u32::MAX as usize {
                return invalid("filter bed: too many fibre images in the bins");
            }
            start.push(images.len() as u32);
        }
        Ok(FibreBed {
            lengths_m,
            fibres,
            particle_radius_m,
            bins_n,
            bin_size_m,
            start,
            images,
        })
    }

    pub fn lengths_m(&self) -> [f64; 3] {
        self.lengths_m
    }
    pub fn fibres(&self) -> &[CylinderBody] {
        &self.fibres
    }
    pub fn particle_radius_m(&self) -> f64 {
        self.particle_radius_m
    }

    /// `p` wrapped into the cell along all three axes.
    pub fn wrap(&self, p: &Vector3<f64>) -> Vector3<f64> {
        Vector3::from_fn(|k, _| p[k].rem_euclid(self.lengths_m[k]))
    }

    /// The first fibre (in bed order of the bin list) whose image the particle at `p` (any
    /// position; wrapped here) touches, or None.
    pub fn touching(&self, p: &Vector3<f64>) -> Option<usize> {
        self.within(p, self.particle_radius_m)
    }

    /// Whether `p` (any position) lies inside a fibre (some periodic image).
    pub fn inside(&self, p: &Vector3<f64>) -> bool {
        self.within(p, 0.0).is_some()
    }

    /// The first fibre whose image is within `reach` (at most the particle radius) of `p`.
    fn within(&self, p: &Vector3<f64>, reach: f64) -> Option<usize> {
        let q = self.wrap(p);
        let idx: [usize; 3] =
            std::array::from_fn(|k| ((q[k] / self.bin_size_m[k]) as usize).min(self.bins_n[k] - 1));
        let b = (idx[2] * self.bins_n[1] + idx[1]) * self.bins_n[0] + idx[0];
        self.images[self.start[b] as usize..self.start[b + 1] as usize]
            .iter()
            .find(|(i, shift)| self.fibres[*i as usize].touches(&(q - shift), reach))
            .map(|(i, _)| *i as usize)
    }
}

/// `n` fibres of radius `radius_m` across the flow at random (seed `seed`): axes in the x-y
/// plane at uniform angles, centres uniform in the cell `lengths_m` with 2R < z < L_z - 2R, so
/// that the inlet plane touches none. (centres, axes) for [`FibreBed::new`].
pub fn random_transverse_fibres(
    n: usize,
    lengths_m: [f64; 3],
    radius_m: f64,
    seed: u64,
) -> (Vec<Vector3<f64>>, Vec<Vector3<f64>>) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let centres = (0..n)
        .map(|_| {
            Vector3::new(
                rng.gen_range(0.0..lengths_m[0]),
                rng.gen_range(0.0..lengths_m[1]),
                rng.gen_range(2.0 * radius_m..lengths_m[2] - 2.0 * radius_m),
            )
        })
        .collect();
    let axes = (0..n)
        .map(|_| {
            let phi: f64 = rng.gen_range(0.0..std::f64::consts::PI);
            Vector3::new(phi.cos(), phi.sin(), 0.0)
        })
        .collect();
    (centres, axes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    /// The binned test agrees with a brute-force test over every image in a 5 x 5 x 5 block of
    /// cells, at random points, for fibres that cross the cell's faces.
    #[test]
    fn binned_contact_equals_brute_force_over_images() {
        let l = [1e-3, 1.2e-3, 0.9e-3];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let (r, hl, a) = (5e-5, 4e-4, 1e-5);
        let centres: Vec<_> = (0..8)
            .map(|_| Vector3::from_fn(|k, _| rng.gen_range(0.0..l[k])))
            .collect();
        let axes: Vec<_> = (0..8)
            .map(|_| Vector3::from_fn(|_, _| rng.gen_range(-1.0..1.0)))
            .collect();
        let bed = FibreBed::new(l, r, hl, &centres, &axes, a).unwrap();
        let (mut hits, mut n) = (0, 0);
        while n < 20000 {
            let p = Vector3::from_fn(|k, _| rng.gen_range(-l[k]..2.0 * l[k]));
            let brute = bed.fibres().iter().any(|f| {
                (-2..=2).any(|sx: i32| {
                    (-2..=2).any(|sy: i32| {
                        (-2..=2).any(|sz: i32| {
                            let s =
                                Vector3::new(sx as f64 * l[0], sy as f64 * l[1], sz as f64 * l[2]);
                            f.touches(&(p - s), a)
                        })
                    })
                })
            });
            assert_eq!(bed.touching(&p).is_some(), brute, "{p}");
            hits += usize::from(brute);
            n += 1;
        }
        assert!(hits > 500 && hits < n - 500, "{hits}");
    }
}
