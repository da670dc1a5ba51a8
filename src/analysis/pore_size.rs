//! Pore size distribution by local thickness (maximal inscribed spheres) on a voxel grid
//! (seed 002 Fig. 11 shows a pore size distribution of the beds; the seed's erosion–dilation
//! tool is not specified in enough detail to reproduce, so porelab uses the standard local
//! thickness of Hildebrand & Rüegsegger, J. Microsc. 185, 67, 1997, the measure of PoreSpy's
//! `local_thickness`).
//!
//! Definitions (voxel centres are the sample points; distances in metres):
//! * dt(y): distance from pore voxel y to the nearest solid voxel centre (exact Euclidean
//!   distance transform, Felzenszwalb & Huttenlocher, Theory Comput. 8, 415, 2012, separable
//!   in x, y, z, with periodic axes handled on the tripled line).
//! * local thickness LT(x) = max { dt(y) : y pore, |x - y| <= dt(y) }: the radius of the
//!   largest inscribed ball of the pore space (centred on a voxel) that covers x. It is found
//!   by taking every distinct value r of dt in decreasing order, the seeds {dt >= r}, and
//!   giving r to the not yet sized pore voxels within r of a seed (a second distance
//!   transform); with every distinct dt value as a size this is LT exactly, with no binning.
//! * the distribution: for each distinct LT value, the fraction of the pore voxels that carry
//!   it (a volume fraction of the pore space). Pore diameter = 2 LT.
//!
//! Distances that are equal in exact arithmetic can differ in the last bits after the three
//! passes, so values within a relative 1e-9 are one size and comparisons allow that slack.

use super::rdf::Bed;
use crate::error::invalid;
use crate::Result;

/// Relative slack of distance comparisons (see the module note).
const REL_SLACK: f64 = 1e-9;

/// A box of voxels, index (k ny + j) nx + i; voxel (i, j, k) has its centre at
/// origin + ((i + 1/2) hx, (j + 1/2) hy, (k + 1/2) hz).
#[derive(Debug, Clone, PartialEq)]
pub struct VoxelGrid {
    pub n: [usize; 3],
    pub spacing_m: [f64; 3],
    pub origin_m: [f64; 3],
    pub periodic: [bool; 3],
    /// true: pore (void) voxel.
    pub pore: Vec<bool>,
}

impl VoxelGrid {
    pub fn new(
        n: [usize; 3],
        spacing_m: [f64; 3],
        origin_m: [f64; 3],
        periodic: [bool; 3],
        pore: Vec<bool>,
    ) -> Result<VoxelGrid> {
        if n.iter().any(|&m| m == 0) {
            return invalid(format!(
                "voxel grid {n:?}: every axis needs at least one voxel"
            ));
        }
        if let Some(h) = spacing_m.iter().find(|h| !(h.is_finite() && **h > 0.0)) {
            return invalid(format!("voxel spacing {h} m: must be positive and finite"));
        }
        if pore.len() != n[0] * n[1] * n[2] {
            return invalid(format!(
                "voxel grid {n:?}: {} values given, {} needed",
                pore.len(),
                n[0] * n[1] * n[2]
            ));
        }
        Ok(VoxelGrid {
            n,
            spacing_m,
            origin_m,
            periodic,
            pore,
        })
    }

    pub fn len(&self) -> usize {
        self.pore.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pore.is_empty()
    }

    /// Fraction of pore voxels.
    pub fn porosity(&self) -> f64 {
        self.pore.iter().filter(|&&p| p).count() as f64 / self.len() as f64
    }
}

/// The voxel grid of a bed between heights z_lo and z_hi (the seed's choice: the lowest and
/// highest particle centres), periodic in x and y. The lateral voxel edge is lx / round(lx /
/// `voxel_m`) (so that the period holds a whole number of voxels), the same in y when ly is a
/// whole number of those voxels (else ly / round(ly / edge)), and in z the x edge, over
/// round((z_hi - z_lo) / edge) (at least 1) layers from z_lo. A voxel is solid when its
/// centre lies strictly inside a sphere.
pub fn voxelize_bed(bed: &Bed, z_lo_m: f64, z_hi_m: f64, voxel_m: f64) -> Result<VoxelGrid> {
    if !(voxel_m.is_finite() && voxel_m > 0.0) {
        return invalid(format!(
            "voxel edge {voxel_m} m: must be positive and finite"
        ));
    }
    if !(z_lo_m.is_finite() && z_hi_m.is_finite() && z_hi_m > z_lo_m) {
        return invalid(format!(
            "pore-size region [{z_lo_m}, {z_hi_m}] m: needs z_hi > z_lo (at least two particle \
             heights)"
        ));
    }
    let whole = |l: f64, h: f64| ((l / h).round() as usize).max(1);
    let nx = whole(bed.lx_m, voxel_m);
    let hx = bed.lx_m / nx as f64;
    let ny = whole(bed.ly_m, hx);
    let hy = bed.ly_m / ny as f64;
    let nz = whole(z_hi_m - z_lo_m, hx);
    let hz = hx;
    let cells = nx as f64 * ny as f64 * nz as f64;
    if cells > 4e8 {
        return invalid(format!(
            "voxel edge {voxel_m} m: {cells:e} voxels; choose a coarser grid (at most 4e8)"
        ));
    }
    let mut pore = vec![true; nx * ny * nz];
    for (c, &r) in bed.pos.iter().zip(bed.radius) {
        let kz0 = (((c.z - r - z_lo_m) / hz - 0.5).floor().max(0.0)) as usize;
        let kz1 = ((((c.z + r - z_lo_m) / hz - 0.5).ceil()).min(nz as f64 - 1.0)).max(-1.0);
        if kz1 < 0.0 || kz0 >= nz {
            continue;
        }
        let kz1 = kz1 as usize;
        let span = |x: f64, h: f64| {
            (
                ((x - r) / h - 0.5).floor() as isize,
                ((x + r) / h - 0.5).ceil() as isize,
            )
        };
        let (i0, i1) = span(c.x, hx);
        let (j0, j1) = span(c.y, hy);
        for k in kz0..=kz1 {
            let dz = z_lo_m + (k as f64 + 0.5) * hz - c.z;
            for j in j0..=j1 {
                let dy = (j as f64 + 0.5) * hy - c.y;
                let jj = j.rem_euclid(ny as isize) as usize;
                for i in i0..=i1 {
                    let dx = (i as f64 + 0.5) * hx - c.x;
                    if dx * dx + dy * dy + dz * dz < r * r {
                        let ii = i.rem_euclid(nx as isize) as usize;
                        pore[(k * ny + jj) * nx + ii] = false;
                    }
                }
            }
        }
    }
    VoxelGrid::new(
        [nx, ny, nz],
        [hx, hy, hz],
        [0.0, 0.0, z_lo_m],
        [true, true, false],
        pore,
    )
}

/// 1-D squared distance transform (lower envelope of parabolas) of `f` with sample spacing
/// `w`: out[q] = min_p f[p] + (w (q - p))^2; infinite f values are no sites.
fn edt_line(f: &[f64], w: f64, out: &mut [f64], v: &mut [usize], z: &mut [f64]) {
    let n = f.len();
    let w2 = w * w;
    let mut k: isize = -1;
    for q in 0..n {
        if !f[q].is_finite() {
            continue;
        }
        let fq = f[q] + w2 * (q * q) as f64;
        let mut s = f64::NEG_INFINITY;
        while k >= 0 {
            let p = v[k as usize];
            s = (fq - (f[p] + w2 * (p * p) as f64)) / (2.0 * w2 * (q - p) as f64);
            if s <= z[k as usize] {
                k -= 1;
            } else {
                break;
            }
        }
        if k < 0 {
            k = 0;
            v[0] = q;
            z[0] = f64::NEG_INFINITY;
        } else {
            k += 1;
            v[k as usize] = q;
            z[k as usize] = s;
        }
        z[k as usize + 1] = f64::INFINITY;
    }
    if k < 0 {
        out.fill(f64::INFINITY);
        return;
    }
    let mut k = 0usize;
    for (q, o) in out.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let d = q as f64 - v[k] as f64;
        *o = f[v[k]] + w2 * d * d;
    }
}

/// Squared Euclidean distance (m^2) from every voxel centre to the nearest `site` voxel
/// centre (0 on sites, +inf when there is none), periodic along the grid's periodic axes.
pub fn squared_distance_to(grid: &VoxelGrid, site: &[bool]) -> Vec<f64> {
    let [nx, ny, nz] = grid.n;
    let mut d: Vec<f64> = site
        .iter()
        .map(|&s| if s { 0.0 } else { f64::INFINITY })
        .collect();
    let nmax = nx.max(ny).max(nz);
    let mut line = vec![0.0; 3 * nmax];
    let mut out = vec![0.0; 3 * nmax];
    let mut v = vec![0usize; 3 * nmax];
    let mut z = vec![0.0; 3 * nmax + 1];
    let strides = [1, nx, nx * ny];
    for axis in 0..3 {
        let m = grid.n[axis];
        let stride = strides[axis];
        let reps = if grid.periodic[axis] { 3 } else { 1 };
        let len = reps * m;
        let w = grid.spacing_m[axis];
        // every line along `axis`: its first voxel has coordinate 0 on that axis
        let starts: Vec<usize> = (0..d.len())
            .filter(|&idx| (idx / stride) % m == 0)
            .collect();
        for s in starts {
            for rep in 0..reps {
                for q in 0..m {
                    line[rep * m + q] = d[s + q * stride];
                }
            }
            edt_line(
                &line[..len],
                w,
                &mut out[..len],
                &mut v[..len],
                &mut z[..len + 1],
            );
            let off = if reps == 3 { m } else { 0 };
            for q in 0..m {
                d[s + q * stride] = out[off + q];
            }
        }
    }
    d
}

/// Local thickness (m) of every voxel: LT of the module note for pore voxels, 0 for solid
/// ones. Errors when the grid has no solid voxel (every distance would be infinite).
pub fn local_thickness(grid: &VoxelGrid) -> Result<Vec<f64>> {
    let solid: Vec<bool> = grid.pore.iter().map(|p| !p).collect();
    if !solid.iter().any(|&s| s) {
        return invalid("local thickness: the grid has no solid voxel");
    }
    let dt2 = squared_distance_to(grid, &solid);
    let mut sizes: Vec<f64> = dt2
        .iter()
        .zip(&grid.pore)
        .filter(|(_, &p)| p)
        .map(|(d, _)| *d)
        .collect();
    sizes.sort_by(|a, b| b.total_cmp(a));
    sizes.dedup_by(|a, b| *a >= *b * (1.0 - REL_SLACK));
    let mut lt2 = vec![0.0; grid.len()];
    let mut unsized_left = grid.pore.iter().filter(|&&p| p).count();
    for &r2 in &sizes {
        if unsized_left == 0 {
            break;
        }
        let seeds: Vec<bool> = dt2
            .iter()
            .zip(&grid.pore)
            .map(|(d, &p)| p && *d >= r2 * (1.0 - REL_SLACK))
            .collect();
        let ds2 = squared_distance_to(grid, &seeds);
        for ((l, d), &p) in lt2.iter_mut().zip(&ds2).zip(&grid.pore) {
            if p && *l == 0.0 && *d <= r2 * (1.0 + REL_SLACK) {
                *l = r2;
                unsized_left -= 1;
            }
        }
    }
    Ok(lt2.iter().map(|x| x.sqrt()).collect())
}

/// The pore size distribution: rows (local-thickness radius in m, fraction of the pore voxels
/// with it), radii increasing, one row per distinct value (values within the relative slack
/// merged). Errors without pore or solid voxels.
pub fn pore_size_distribution(grid: &VoxelGrid) -> Result<Vec<(f64, f64)>> {
    let lt = local_thickness(grid)?;
    let mut radii: Vec<f64> = lt
        .iter()
        .zip(&grid.pore)
        .filter(|(_, &p)| p)
        .map(|(l, _)| *l)
        .collect();
    if radii.is_empty() {
        return invalid("pore size distribution: the grid has no pore voxel");
    }
    let total = radii.len() as f64;
    radii.sort_by(f64::total_cmp);
    let mut rows: Vec<(f64, f64)> = Vec::new();
    for r in radii {
        match rows.last_mut() {
            Some((r0, c)) if r <= *r0 * (1.0 + REL_SLACK) => *c += 1.0,
            _ => rows.push((r, 1.0)),
        }
    }
    Ok(rows.into_iter().map(|(r, c)| (r, c / total)).collect())
}

/// The `q` quantile (0 < q <= 1) of a distribution given as rows (value, fraction), values
/// increasing: the first value at which the cumulative fraction reaches `q` (NaN for no rows).
pub fn distribution_quantile(rows: &[(f64, f64)], q: f64) -> f64 {
    let mut acc = 0.0;
    rows.iter()
        .find(|(_, f)| {
            acc += f;
            acc >= q
        })
        .map_or(f64::NAN, |(v, _)| *v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    #[test]
    fn quantile_is_the_first_value_reaching_the_fraction() {
        let rows = [(1.0, 0.25), (2.0, 0.25), (3.0, 0.5)];
        assert_eq!(distribution_quantile(&rows, 0.25), 1.0);
        assert_eq!(distribution_quantile(&rows, 0.5), 2.0);
        assert_eq!(distribution_quantile(&rows, 0.75), 3.0);
        assert!(distribution_quantile(&[], 0.5).is_nan());
    }

    fn grid(
        n: [usize; 3],
        periodic: [bool; 3],
        pore: impl Fn(usize, usize, usize) -> bool,
    ) -> VoxelGrid {
        let mut v = Vec::new();
        for k in 0..n[2] {
            for j in 0..n[1] {
                for i in 0..n[0] {
                    v.push(pore(i, j, k));
                }
            }
        }
        VoxelGrid::new(n, [1.0; 3], [0.0; 3], periodic, v).unwrap()
    }

    /// The transform equals the brute-force minimum over all sites and periodic images.
    #[test]
    fn distance_transform_matches_brute_force() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        let n = [7usize, 5, 6];
        for periodic in [
            [true, true, false],
            [false, false, false],
            [true, false, true],
        ] {
            let mut g = grid(n, periodic, |_, _, _| true);
            g.spacing_m = [0.7, 1.3, 1.0];
            let site: Vec<bool> = (0..g.len()).map(|_| rng.gen::<f64>() < 0.08).collect();
            let d = squared_distance_to(&g, &site);
            let coord = |idx: usize| [idx % n[0], (idx / n[0]) % n[1], idx / (n[0] * n[1])];
            for a in 0..g.len() {
                let ca = coord(a);
                let mut best = f64::INFINITY;
                for b in (0..g.len()).filter(|&b| site[b]) {
                    let cb = coord(b);
                    let mut s = 0.0;
                    for ax in 0..3 {
                        let mut t = ca[ax] as f64 - cb[ax] as f64;
                        if periodic[ax] {
                            let m = n[ax] as f64;
                            t -= m * (t / m).round();
                        }
                        s += (t * g.spacing_m[ax]).powi(2);
                    }
                    best = best.min(s);
                }
                assert!(
                    (d[a] - best).abs() <= 1e-12 * best.max(1.0),
                    "{a}: {} {best}",
                    d[a]
                );
            }
        }
    }

    /// A slab of P pore layers between solid layers (periodic in x and y): every pore voxel
    /// has local thickness floor((P + 1) / 2) h, the largest distance to a solid layer's
    /// centre ((P + 1) h / 2, half the distance between the solid layers, for odd P).
    #[test]
    fn slab_pore_has_one_thickness() {
        for p in [1usize, 4, 7] {
            let g = grid([6, 6, p + 2], [true, true, false], |_, _, k| {
                k >= 1 && k <= p
            });
            let psd = pore_size_distribution(&g).unwrap();
            assert_eq!(psd.len(), 1, "{psd:?}");
            let want = ((p as f64 + 1.0) / 2.0).floor();
            assert!(
                (psd[0].0 - want).abs() < 1e-12 && psd[0].1 == 1.0,
                "P = {p}: {psd:?}"
            );
        }
    }

    /// One spherical pore of radius R (voxel units, centred on a voxel) in solid: every pore
    /// voxel has the thickness of the centre, the smallest lattice distance sqrt(i^2+j^2+k^2)
    /// that is >= R (enumerated here).
    #[test]
    fn spherical_pore_has_the_centre_thickness() {
        for r in [2.5f64, 4.2, 6.0] {
            let m = 2 * (r.ceil() as usize) + 5;
            let c = (m / 2) as f64;
            let g = grid([m, m, m], [false; 3], |i, j, k| {
                let d2 = (i as f64 - c).powi(2) + (j as f64 - c).powi(2) + (k as f64 - c).powi(2);
                d2 < r * r
            });
            let mut want = f64::INFINITY;
            let b = r.ceil() as i64 + 1;
            for i in -b..=b {
                for j in -b..=b {
                    for k in -b..=b {
                        let d = ((i * i + j * j + k * k) as f64).sqrt();
                        if d >= r {
                            want = want.min(d);
                        }
                    }
                }
            }
            let psd = pore_size_distribution(&g).unwrap();
            assert_eq!(psd.len(), 1, "R = {r}: {psd:?}");
            assert!(
                (psd[0].0 - want).abs() < 1e-12,
                "R = {r}: {psd:?} want {want}"
            );
        }
    }

    #[test]
    fn bed_voxels_cover_the_spheres() {
        // one sphere of radius 0.3 at the centre of a unit periodic column: solid fraction of
        // the grid -> sphere volume / box volume as the voxels shrink
        let pos = [Vector3::new(0.5, 0.5, 0.5)];
        let radius = [0.3];
        let bed = Bed {
            pos: &pos,
            radius: &radius,
            lx_m: 1.0,
            ly_m: 1.0,
        };
        let h = 1.0 / 64.0;
        let g = voxelize_bed(&bed, 0.0, 1.0, h).unwrap();
        assert_eq!(g.n, [64, 64, 64]);
        let want = 4.0 / 3.0 * std::f64::consts::PI * 0.027;
        assert!(
            ((1.0 - g.porosity()) - want).abs() < 3e-3,
            "{}",
            g.porosity()
        );
        // wrapped across the periodic faces: the same count after a shift by whole voxels
        let shifted = [Vector3::new(0.5 - 20.0 * h, 0.5 + 30.0 * h, 0.5)];
        let g2 = voxelize_bed(
            &Bed {
                pos: &shifted,
                ..bed
            },
            0.0,
            1.0,
            h,
        )
        .unwrap();
        assert_eq!(
            g.pore.iter().filter(|p| !**p).count(),
            g2.pore.iter().filter(|p| !**p).count()
        );
    }

    #[test]
    fn bad_input_is_named() {
        assert!(
            VoxelGrid::new([0, 1, 1], [1.0; 3], [0.0; 3], [false; 3], vec![])
                .unwrap_err()
                .to_string()
                .contains("at least one voxel")
        );
        let g = grid([3, 3, 3], [false; 3], |_, _, _| true);
        assert!(local_thickness(&g)
            .unwrap_err()
            .to_string()
            .contains("no solid"));
    }
}
