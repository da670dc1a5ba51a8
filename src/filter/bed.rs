//! The solid of a filter bed: identical finite fibres (solid cylinders) posed in a cell that is
//! periodic along x, y and z, with a bin grid listing, per bin, the fibre images a particle in
//! that bin can touch. A particle of radius a touches a fibre when its centre is within a of the
//! solid cylinder (thesis 003, section 6.3). With a wall layer (the no-slip layer of
//! [`super::wall`]) the bins also list every image within the layer, for the exact distance to
//! the nearest fibre surface and its outward normal.

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
    /// Wall layer the bins also reach (m; 0: none).
    wall_layer_m: f64,
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
        FibreBed::binned(lengths_m, fibres, particle_radius_m, 0.0)
    }

    /// The same bed with bins that also list every fibre image within `wall_layer_m` (finite,
    /// at least 0) of a point, for [`FibreBed::nearest_surface`]. The contact test is
    /// unchanged: the images it can touch keep their order in every bin.
    pub fn with_wall_layer(self, wall_layer_m: f64) -> Result<FibreBed> {
        if !(wall_layer_m.is_finite() && wall_layer_m >= 0.0) {
            return invalid(format!(
                "filter wall layer {wall_layer_m} m: must be finite and >= 0"
            ));
        }
        FibreBed::binned(
            self.lengths_m,
            self.fibres,
            self.particle_radius_m,
            wall_layer_m,
        )
    }

    /// Builds the bins for contact within `particle_radius_m` and distances within
    /// `wall_layer_m` (identical fibres, checked).
    fn binned(
        lengths_m: [f64; 3],
        fibres: Vec<CylinderBody>,
        particle_radius_m: f64,
        wall_layer_m: f64,
    ) -> Result<FibreBed> {
        let (radius_m, half_length_m) = fibres
            .first()
            .map_or((0.0, 0.0), |f| (f.radius, f.half_length));
        // what a bin must list: images within the particle radius or the wall layer
        let near = particle_radius_m.max(wall_layer_m);
        // bins of about the fibre radius plus the particle radius, at least 2 per axis
        let reach = radius_m + particle_radius_m;
        let bins_n = lengths_m.map(|l| ((l / reach.max(l / 64.0)).floor() as usize).max(2));
        let bin_size_m: [f64; 3] = std::array::from_fn(|k| lengths_m[k] / bins_n[k] as f64);
        let bin_half_diagonal = 0.5 * bin_size_m[0].hypot(bin_size_m[1]).hypot(bin_size_m[2]);
        // images within reach of the cell: shifts up to the fibre's extent over the edge
        let extent = half_length_m + radius_m + near + bin_half_diagonal;
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
                if f.signed_distance(&(centre - shift)) <= near + bin_half_diagonal {
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
            wall_layer_m,
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
        self.bin_images(&q)
            .iter()
            .find(|(i, shift)| self.fibres[*i as usize].touches(&(q - shift), reach))
            .map(|(i, _)| *i as usize)
    }

    /// The fibre images listed in the bin of `q` (wrapped into the cell).
    fn bin_images(&self, q: &Vector3<f64>) -> &[(u32, Vector3<f64>)] {
        let idx: [usize; 3] =
            std::array::from_fn(|k| ((q[k] / self.bin_size_m[k]) as usize).min(self.bins_n[k] - 1));
        let b = (idx[2] * self.bins_n[1] + idx[1]) * self.bins_n[0] + idx[0];
        &self.images[self.start[b] as usize..self.start[b + 1] as usize]
    }

    /// The wall layer the bins reach (m; 0: none, see [`FibreBed::with_wall_layer`]).
    pub fn wall_layer_m(&self) -> f64 {
        self.wall_layer_m
    }

    /// The nearest fibre surface to `p` (any position) when one lies within the wall layer:
    /// the exact signed distance to it (m; < 0 inside a fibre) and its outward unit normal at
    /// the nearest surface point (the gradient of the distance). None beyond the layer.
    pub fn nearest_surface(&self, p: &Vector3<f64>) -> Option<Surface> {
        let q = self.wrap(p);
        let (fibre, distance_m, local) = self
            .bin_images(&q)
            .iter()
            .map(|(i, shift)| {
                let local = q - shift;
                (*i, self.fibres[*i as usize].signed_distance(&local), local)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        (distance_m < self.wall_layer_m).then(|| Surface {
            fibre: fibre as usize,
            distance_m,
            normal: outward_normal(&self.fibres[fibre as usize], &local),
        })
    }
}

/// The nearest fibre surface to a point: [`FibreBed::nearest_surface`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface {
    pub fibre: usize,
    /// Signed distance from the point to the surface (m).
    pub distance_m: f64,
    /// Outward unit normal at the nearest surface point.
    pub normal: Vector3<f64>,
}

/// The outward unit normal of the solid cylinder `f` at the surface point nearest to `p`: radial
/// beside the mantle, along the axis beyond the flat ends, from the rim's nearest point beyond
/// both; inside, that of the nearer face.
fn outward_normal(f: &CylinderBody, p: &Vector3<f64>) -> Vector3<f64> {
    let d = p - f.centre;
    let a = f.axis();
    let z = d.dot(&a);
    let radial = d - a * z;
    let rho = radial.norm();
    let e_rho = if rho > 0.0 {
        radial / rho
    } else {
        // on the axis: any direction across it
        crate::contact::contact_spherocylinder_spherocylinder::any_perpendicular(&a)
    };
    let e_z = if z < 0.0 { -a } else { a };
    let (dr, dz) = (rho - f.radius, z.abs() - f.half_length);
    if dr > 0.0 && dz > 0.0 {
        (e_rho * dr + e_z * dz) / dr.hypot(dz)
    } else if dr >= dz {
        e_rho
    } else {
        e_z
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

    /// `n` fibres at uniform random centres in the cell `l`, random axes.
    fn random_bed(
        rng: &mut rand_chacha::ChaCha8Rng,
        n: usize,
        l: [f64; 3],
        r: f64,
        hl: f64,
        a: f64,
    ) -> FibreBed {
        let centres: Vec<_> = (0..n)
            .map(|_| Vector3::from_fn(|k, _| rng.gen_range(0.0..l[k])))
            .collect();
        let axes: Vec<_> = (0..n)
            .map(|_| Vector3::from_fn(|_, _| rng.gen_range(-1.0..1.0)))
            .collect();
        FibreBed::new(l, r, hl, &centres, &axes, a).unwrap()
    }

    /// The binned test agrees with a brute-force test over every image in a 5 x 5 x 5 block of
    /// cells, at random points, for fibres that cross the cell's faces.
    #[test]
    fn binned_contact_equals_brute_force_over_images() {
        let l = [1e-3, 1.2e-3, 0.9e-3];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let (r, hl, a) = (5e-5, 4e-4, 1e-5);
        let bed = random_bed(&mut rng, 8, l, r, hl, a);
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

    /// The binned nearest surface equals a brute-force minimum over every image in a 5 x 5 x 5
    /// block of cells wherever that minimum is within the wall layer (and is None beyond it);
    /// its normal is the gradient of the distance (central differences) and points from the
    /// nearest surface point, at the mantle, the flat ends and the rims alike.
    #[test]
    fn nearest_surface_equals_brute_force_and_its_normal_is_the_distance_gradient() {
        let l = [1e-3, 1.2e-3, 0.9e-3];
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let (r, hl, a, layer) = (5e-5, 2e-4, 1e-8, 4e-5);
        let bed = random_bed(&mut rng, 6, l, r, hl, a)
            .with_wall_layer(layer)
            .unwrap();
        let brute = |p: &Vector3<f64>| {
            let mut best = f64::INFINITY;
            for f in bed.fibres() {
                for sx in -2..=2 {
                    for sy in -2..=2 {
                        for sz in -2..=2 {
                            let s =
                                Vector3::new(sx as f64 * l[0], sy as f64 * l[1], sz as f64 * l[2]);
                            best = best.min(f.signed_distance(&(p - s)));
                        }
                    }
                }
            }
            best
        };
        let (mut near, mut ends, mut n) = (0, 0, 0);
        while n < 40000 {
            n += 1;
            let p = Vector3::from_fn(|k, _| rng.gen_range(-l[k]..2.0 * l[k]));
            let want = brute(&p);
            match bed.nearest_surface(&p) {
                None => assert!(want >= layer, "{p} {want}"),
                Some(s) => {
                    assert!(want < layer, "{p} {want}");
                    assert!(
                        (s.distance_m - want).abs() < 1e-15,
                        "{p} {} {want}",
                        s.distance_m
                    );
                    near += 1;
                    if s.distance_m <= 0.0 {
                        continue;
                    }
                    let e = 1e-9;
                    let grad = Vector3::from_fn(|k, _| {
                        let mut d = Vector3::zeros();
                        d[k] = e;
                        (brute(&(p + d)) - brute(&(p - d))) / (2.0 * e)
                    });
                    assert!((grad - s.normal).norm() < 1e-5, "{p} {grad} {}", s.normal);
                    assert!((s.normal.norm() - 1.0).abs() < 1e-12);
                    // the foot of the normal is on the surface
                    assert!(brute(&(p - s.normal * s.distance_m)).abs() < 1e-15);
                    // an end or a rim: the normal is not across the axis
                    let axis = bed.fibres()[s.fibre].axis();
                    ends += usize::from(s.normal.dot(&axis).abs() > 1e-6);
                }
            }
        }
        assert!(near > 2000 && ends > 100, "{near} {ends}");
    }
}
