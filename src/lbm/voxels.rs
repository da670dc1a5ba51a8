//! The solid mask of a particle configuration (porelab extended XYZ, periodic box): a cell is
//! solid when its centre lies inside a particle or one of its periodic images (the shape's
//! implicit function of `crate::shape`, evaluated in the body frame at the minimum-image
//! offset). Spheres, spherocylinders, ellipsoids and superquadrics are voxelised; a
//! superquadric's `superquadric_roundness` (e, n) is read as porelab writes it, thesis eq. 4.3
//! with exponents (2/e, 2/e, 2/n) (OVITO's Superquadric for e = n).

use super::geometry::Dims;
use super::memory::check_memory;
use crate::error::{invalid, Result};
use crate::io::xyz::{Cell, XyzParticle};
use crate::shape::{ConvexShape, Ellipsoid, Sphere, Spherocylinder, Superquadric};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// One particle ready for voxelisation.
struct Placed {
    shape: Box<dyn ConvexShape>,
    centre: Vector3<f64>,
    to_body: nalgebra::UnitQuaternion<f64>,
    /// Particle surface area (None where no closed form is used).
    area: Option<f64>,
}

fn place(i: usize, p: &XyzParticle) -> Result<Placed> {
    let r = p.radius;
    let [a, b, c] = p.aspherical_shape;
    let (shape, area): (Box<dyn ConvexShape>, Option<f64>) = if p.cylinder_length > 0.0 {
        let l = p.cylinder_length;
        (
            Box::new(Spherocylinder::new(r, l)?),
            Some(4.0 * PI * r * r + 2.0 * PI * r * l),
        )
    } else if p.roundness != [1.0, 1.0] {
        // porelab's writer stores a superquadric of exponents g as (2/g_x, 2/g_z), g_y = g_x
        let [e, n] = p.roundness;
        if !(e > 0.0 && e <= 1.0 && n > 0.0 && n <= 1.0) {
            return invalid(format!(
                "particle {i} (species {}): superquadric_roundness {:?} must lie in (0, 1] \
                 (exponents 2/roundness >= 2: a convex superquadric)",
                p.species, p.roundness
            ));
        }
        let shape = Superquadric::new([a, b, c], [2.0 / e, 2.0 / e, 2.0 / n])
            .map_err(|err| crate::error::Error::InvalidInput(format!("particle {i}: {err}")))?;
        (Box::new(shape), None)
    } else if (a - r).abs() <= 1e-12 * r && (b - r).abs() <= 1e-12 * r && (c - r).abs() <= 1e-12 * r
    {
        (Box::new(Sphere::new(r)?), Some(4.0 * PI * r * r))
    } else {
        (Box::new(Ellipsoid::new([a, b, c])?), None)
    };
    Ok(Placed {
        shape,
        centre: p.position,
        to_body: p.orientation.inverse(),
        area,
    })
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
    })
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
}
