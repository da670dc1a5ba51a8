//! The solid mask of a particle configuration (porelab extended XYZ, periodic box): a cell is
//! solid when its centre lies inside a particle or one of its periodic images (the shape's
//! implicit function of `crate::shape`, evaluated in the body frame at the minimum-image
//! offset). Spheres, spherocylinders, ellipsoids and superquadrics are voxelised; a
//! superquadric's `superquadric_roundness` (e, n) is read as porelab writes it, thesis eq. 4.3
//! with exponents (2/e, 2/e, 2/n) (OVITO's Superquadric for e = n).

use super::geometry::Dims;
use super::memory::check_memory;
use super::walls::{
    clamp_fraction, convex_crossing, neighbour_directions, sphere_crossing, WallFractions,
};
use crate::contact::ContactShape;
use crate::error::{invalid, Result};
use crate::io::xyz::{contact_shape, Cell, XyzParticle};
use crate::shape::{ConvexShape, Ellipsoid, Sphere, Spherocylinder, Superquadric};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// One particle ready for voxelisation.
#[derive(Debug)]
struct Placed {
    /// The particle's shape by the one rule of [`contact_shape`].
    kind: ContactShape,
    shape: Box<dyn ConvexShape>,
    centre: Vector3<f64>,
    to_body: nalgebra::UnitQuaternion<f64>,
    /// Particle surface area (None where no closed form is used).
    area: Option<f64>,
}

fn place(i: usize, p: &XyzParticle) -> Result<Placed> {
    let kind = contact_shape(p).map_err(|e| {
        crate::error::Error::InvalidInput(format!("particle {i} (species {}): {e}", p.species))
    })?;
    let (shape, area): (Box<dyn ConvexShape>, Option<f64>) = match kind {
        ContactShape::Sphere { radius: r } => (Box::new(Sphere::new(r)?), Some(4.0 * PI * r * r)),
        ContactShape::Spherocylinder {
            radius: r,
            length: l,
        } => (
            Box::new(Spherocylinder::new(r, l)?),
            Some(4.0 * PI * r * r + 2.0 * PI * r * l),
        ),
        ContactShape::Ellipsoid { semi_axes } => (Box::new(Ellipsoid::new(semi_axes)?), None),
        ContactShape::Superquadric {
            semi_axes,
            exponents,
        } => (Box::new(Superquadric::new(semi_axes, exponents)?), None),
    };
    Ok(Placed {
        kind,
        shape,
        centre: p.position,
        to_body: p.orientation.inverse(),
        area,
    })
}

impl Placed {
    /// The first crossing t in [0, 1] of the segment a + t d (configuration units, in the
    /// frame where the particle sits at `rel`; `a` outside it) with the particle's surface:
    /// exact for a sphere, a root-find on the shape's implicit function otherwise.
    fn crossing(&self, rel: &Vector3<f64>, a: &Vector3<f64>, d: &Vector3<f64>) -> Option<f64> {
        if let ContactShape::Sphere { radius } = self.kind {
            return sphere_crossing((*a).into(), (*d).into(), (*rel).into(), radius);
        }
        convex_crossing(|t| self.shape.implicit(&(self.to_body * (a + t * d - rel))))
    }
}

/// The voxelised configuration.
#[derive(Debug)]
pub struct Voxels {
    pub dims: Dims,
    /// Cell edge in the configuration's length unit.
    pub dx: f64,
    pub solid: Vec<bool>,
    /// Solid volume fraction from the particle volumes (overlaps counted twice).
    pub phi_particles: f64,
    /// V / S of the particles (None if a shape has no surface formula here).
    pub v_over_s: Option<f64>,
    /// The particles and the box origin, for the walls' fractions.
    placed: Vec<Placed>,
    origin: Vector3<f64>,
}

/// The lattice of `n` cells along x in the periodic orthorhombic `cell` and its spacing dx
/// (the other edges get the same spacing, rounded; they must come out within 1e-6 relative).
pub fn voxel_dims(cell: &Cell, n: usize) -> Result<(Dims, f64)> {
    if cell.pbc != [true; 3] {
        return invalid(format!(
            "the configuration's cell has pbc = {:?}: permeability needs a periodic box (T T T)",
            cell.pbc
        ));
    }
    if n < 4 {
        return invalid(format!("resolution = {n}: must be >= 4 cells along x"));
    }
    let dx = cell.lengths[0] / n as f64;
    let mut ext = [n; 3];
    for (k, e) in ext.iter_mut().enumerate().skip(1) {
        let m = cell.lengths[k] / dx;
        *e = m.round() as usize;
        if *e == 0 || (m - *e as f64).abs() > 1e-6 * m {
            return invalid(format!(
                "box edge {k} = {} is {m} cells of dx = {dx}: must be a whole number of cells \
                 (choose the resolution so that the edges are commensurate)",
                cell.lengths[k]
            ));
        }
    }
    Ok((Dims::new(ext[0], ext[1], ext[2])?, dx))
}

/// Voxelises `particles` in the periodic orthorhombic `cell` with `n` cells along x
/// ([`voxel_dims`]).
pub fn voxelise(cell: &Cell, particles: &[XyzParticle], n: usize) -> Result<Voxels> {
    let (dims, dx) = voxel_dims(cell, n)?;
    let ext = [dims.nx, dims.ny, dims.nz];
    check_memory(dims, 19, 0)?;
    let placed: Vec<Placed> = particles
        .iter()
        .enumerate()
        .map(|(i, p)| place(i, p))
        .collect::<Result<_>>()?;
    let mut solid = vec![false; dims.cells()];
    let org = Vector3::from(cell.origin);
    let (mut vol, mut area, mut all_area) = (0.0, 0.0, true);
    for p in &placed {
        vol += p.shape.volume();
        match p.area {
            Some(a) => area += a,
            None => all_area = false,
        }
        let br = p.shape.bounding_radius();
        let rel = p.centre - org;
        // cell index range of the bounding cube, unwrapped; each index is wrapped below
        let lo: Vec<i64> = (0..3)
            .map(|k| ((rel[k] - br) / dx).floor() as i64)
            .collect();
        let hi: Vec<i64> = (0..3).map(|k| ((rel[k] + br) / dx).ceil() as i64).collect();
        for iz in lo[2]..=hi[2] {
            for iy in lo[1]..=hi[1] {
                for ix in lo[0]..=hi[0] {
                    let ii = [ix, iy, iz];
                    let centre = Vector3::new(
                        (ix as f64 + 0.5) * dx,
                        (iy as f64 + 0.5) * dx,
                        (iz as f64 + 0.5) * dx,
                    );
                    let body = p.to_body * (centre - rel);
                    if p.shape.implicit(&body) < 0.0 {
                        let w = |k: usize| ii[k].rem_euclid(ext[k] as i64) as usize;
                        solid[dims.cell(w(0), w(1), w(2))] = true;
                    }
                }
            }
        }
    }
    let box_vol = cell.lengths.iter().product::<f64>();
    Ok(Voxels {
        dims,
        dx,
        solid,
        phi_particles: vol / box_vol,
        v_over_s: all_area.then(|| vol / area),
        placed,
        origin: org,
    })
}

impl Voxels {
    /// The wall fraction of every fluid-solid link (any of the 26 neighbour directions; the
    /// lattice's own are read from these): the first crossing of the link from the fluid cell
    /// centre to its solid neighbour with the surface of any particle or periodic image near
    /// it ([`super::walls`]).
    pub fn wall_fractions(&self) -> Result<WallFractions> {
        let d = self.dims;
        let ext = [d.nx as i64, d.ny as i64, d.nz as i64];
        let dx = self.dx;
        let mut links = Vec::new();
        for p in &self.placed {
            let br = p.shape.bounding_radius();
            let rel = p.centre - self.origin;
            // every fluid cell within one cell of the particle's bounding cube, unwrapped
            let lo: Vec<i64> = (0..3)
                .map(|k| ((rel[k] - br) / dx).floor() as i64 - 1)
                .collect();
            let hi: Vec<i64> = (0..3)
                .map(|k| ((rel[k] + br) / dx).ceil() as i64 + 1)
                .collect();
            for iz in lo[2]..=hi[2] {
                for iy in lo[1]..=hi[1] {
                    for ix in lo[0]..=hi[0] {
                        let ii = [ix, iy, iz];
                        let w = |k: usize, v: i64| v.rem_euclid(ext[k]) as usize;
                        let cell = d.cell(w(0, ix), w(1, iy), w(2, iz));
                        if self.solid[cell] {
                            continue;
                        }
                        let a = Vector3::from_fn(|k, _| (ii[k] as f64 + 0.5) * dx);
                        for c in neighbour_directions() {
                            let n = d.cell(
                                w(0, ix + c[0] as i64),
                                w(1, iy + c[1] as i64),
                                w(2, iz + c[2] as i64),
                            );
                            if !self.solid[n] {
                                continue;
                            }
                            let step = Vector3::from_fn(|k, _| c[k] as f64 * dx);
                            if let Some(t) = p.crossing(&rel, &a, &step) {
                                links.push((cell, c, clamp_fraction(t)));
                            }
                        }
                    }
                }
            }
        }
        WallFractions::new(links)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn sphere(x: [f64; 3], r: f64) -> XyzParticle {
        XyzParticle::sphere(Vector3::from(x), r)
    }

    /// A sphere at the box centre voxelises to the simple cubic mask of the validated cases,
    /// and the same sphere split across the corner (periodic images) to its shifted copy.
    #[test]
    fn periodic_images_and_sc_mask() {
        let n = 16;
        let r = 0.3;
        let v = voxelise(&Cell::cubic(1.0), &[sphere([0.5; 3], r)], n).unwrap();
        assert_eq!(
            v.solid,
            crate::lbm::flows::sphere_array_mask(n, r * n as f64)
        );
        let w = voxelise(&Cell::cubic(1.0), &[sphere([0.0; 3], r)], n).unwrap();
        let d = v.dims;
        for c in 0..d.cells() {
            let p = d.coords(c);
            let s = d.cell((p[0] + n / 2) % n, (p[1] + n / 2) % n, (p[2] + n / 2) % n);
            assert_eq!(v.solid[c], w.solid[s]);
        }
        assert!((v.v_over_s.unwrap() - r / 3.0).abs() < 1e-15);
    }

    /// A rotated superquadric with unequal semi-axes and exponents, placed across a box
    /// corner, voxelises to the mask of eq. 4.3 evaluated here directly: every cell centre
    /// against the 27 images of the particle, in the body frame of the quaternion's matrix.
    #[test]
    fn superquadric_mask_equals_direct_evaluation() {
        let (a, g_xy, g_z) = ([0.31, 0.22, 0.17], 4.0, 2.5);
        let q = UnitQuaternion::from_euler_angles(0.4, -0.7, 1.1);
        let centre = [0.93, 0.05, 0.48];
        let p = XyzParticle {
            species: "superquadric".into(),
            position: Vector3::from(centre),
            orientation: q,
            aspherical_shape: a,
            radius: 0.35,
            cylinder_length: 0.0,
            roundness: [2.0 / g_xy, 2.0 / g_z],
        };
        let n = 24;
        let v = voxelise(&Cell::cubic(1.0), &[p], n).unwrap();
        let rot = q.to_rotation_matrix().into_inner().transpose();
        let g = [g_xy, g_xy, g_z];
        let mut solid_cells = 0;
        for c in 0..v.dims.cells() {
            let ix = v.dims.coords(c);
            let x = Vector3::from_fn(|k, _| (ix[k] as f64 + 0.5) / n as f64);
            let mut inside = false;
            for s in 0..27 {
                let shift = Vector3::new(
                    (s % 3) as f64 - 1.0,
                    ((s / 3) % 3) as f64 - 1.0,
                    (s / 9) as f64 - 1.0,
                );
                let b = rot * (x - Vector3::from(centre) - shift);
                let f: f64 = (0..3).map(|k| (b[k] / a[k]).abs().powf(g[k])).sum();
                inside |= f < 1.0;
            }
            assert_eq!(v.solid[c], inside, "cell {ix:?}");
            solid_cells += inside as usize;
        }
        assert!(solid_cells > 500, "{solid_cells} solid cells");
        assert!(v.v_over_s.is_none());
        let bad = XyzParticle {
            roundness: [1.5, 0.5],
            ..sphere([0.5; 3], 0.2)
        };
        let e = voxelise(&Cell::cubic(1.0), &[bad], 8)
            .unwrap_err()
            .to_string();
        assert!(e.contains("superquadric_roundness"), "{e}");
    }

    /// Every fluid-solid link of a sphere and a rotated superquadric across the box corner
    /// (periodic images) gets a wall fraction, and the point x + q c it names lies on a
    /// particle surface by eq. 4.3 evaluated here directly (27 images), with the link's
    /// start of the segment before it outside both.
    #[test]
    fn wall_fractions_lie_on_the_surfaces() {
        let (a, g_xy, g_z) = ([0.31, 0.22, 0.17], 4.0, 2.5);
        let q = UnitQuaternion::from_euler_angles(0.4, -0.7, 1.1);
        let sq_centre = [0.93, 0.05, 0.48];
        let sq = XyzParticle {
            species: "superquadric".into(),
            position: Vector3::from(sq_centre),
            orientation: q,
            aspherical_shape: a,
            radius: 0.35,
            cylinder_length: 0.0,
            roundness: [2.0 / g_xy, 2.0 / g_z],
        };
        let (s_centre, r) = ([0.45, 0.6, 0.02], 0.2);
        let n = 20;
        let v = voxelise(&Cell::cubic(1.0), &[sq, sphere(s_centre, r)], n).unwrap();
        let fr = v.wall_fractions().unwrap();
        let rot = q.to_rotation_matrix().into_inner().transpose();
        let g = [g_xy, g_xy, g_z];
        // the smallest |f| over the images of each particle at x (f: inside-outside value)
        let level = |x: Vector3<f64>| -> (f64, f64) {
            let (mut fq, mut fs) = (f64::INFINITY, f64::INFINITY);
            for s in 0..27 {
                let shift = Vector3::new(
                    (s % 3) as f64 - 1.0,
                    ((s / 3) % 3) as f64 - 1.0,
                    (s / 9) as f64 - 1.0,
                );
                let b = rot * (x - Vector3::from(sq_centre) - shift);
                let f: f64 = (0..3).map(|k| (b[k] / a[k]).abs().powf(g[k])).sum::<f64>() - 1.0;
                fq = fq.min(f);
                fs = fs.min((x - Vector3::from(s_centre) - shift).norm() - r);
            }
            (fq, fs)
        };
        let d = v.dims;
        let mut links = 0;
        for c in 0..d.cells() {
            if v.solid[c] {
                continue;
            }
            let p = d.coords(c);
            for dir in neighbour_directions() {
                let m = d.shifted(p, dir);
                if !v.solid[d.cell(m[0], m[1], m[2])] {
                    continue;
                }
                links += 1;
                let t = fr.get(c, dir).expect("every link has a fraction");
                let x = Vector3::from_fn(|k, _| (p[k] as f64 + 0.5 + t * dir[k] as f64) / n as f64);
                let (fq, fs) = level(x);
                assert!(
                    fq.abs() < 1e-9 || fs.abs() < 1e-9,
                    "{p:?} {dir:?}: {fq} {fs}"
                );
                let before = Vector3::from_fn(|k, _| {
                    (p[k] as f64 + 0.5 + 0.5 * t * dir[k] as f64) / n as f64
                });
                let (bq, bs) = level(before);
                assert!(bq > 0.0 && bs > 0.0, "{p:?} {dir:?}: {bq} {bs}");
            }
        }
        assert!(
            links > 1000 && fr.len() == links,
            "{links} links, {} fractions",
            fr.len()
        );
    }
}
