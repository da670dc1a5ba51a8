//! The wet film at the start of a deposition (seed 000, "Modelling Methodology" and Table B1).
//!
//! Pigment volume fraction from the solids content. Per unit mass of pigment the colour holds
//! p = pph/100 of soluble binder and water making the solids a mass fraction s of the whole;
//! with volumes additive,
//!   phi = (1/rho_p) / (1/rho_p + p/rho_b + (1 + p)(1/s - 1)/rho_w).
//! (Table B1: rho_p = 2500, rho_b = 1500 kg/m^3, p = 0.07; rho_w = 1000 kg/m^3 is not in the
//! table.) The binder is dissolved: the fluid phase is the binder solution, of density
//! (p + (1 + p)(1/s - 1)) / (p/rho_b + (1 + p)(1/s - 1)/rho_w).
//!
//! Placement: every particle lies with its longest semi-axis horizontal at a random azimuth
//! and its shortest vertical (the shear in the application nip, seed 000). Random sequential
//! addition (RSA) places them without overlap in the film [0, H] of height
//! H = (total particle volume) / (phi L^2). RSA jams near 0.38 in 3-D; above a set fraction
//! (default 0.30) the particles are placed shrunk by s = (0.30 / phi)^(1/3) and then grown
//! back without gravity: in rounds, each particle not yet at full size tries to grow by its
//! own step (accepted when it then overlaps nothing and stays inside [0, H]), and every
//! particle makes one hard-core Monte-Carlo move (any move that creates no overlap and stays
//! inside [0, H] is accepted); the idea of Lubachevsky & Stillinger (J. Stat. Phys. 60, 561,
//! 1990) with Monte-Carlo moves in place of molecular dynamics. A particle that has not grown
//! for 100 rounds is moved to a random free place at its current size (also a hard-core move).

use super::grain::{Grain, GrainPose};
use super::moves;
use super::overlap::PrefilterCounts;
use super::Layer;
use crate::error::{invalid, Result};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::Rng;

/// The composition of the coating colour (Table B1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Colour {
    /// Solids content as a mass fraction (0.65 for 65 %).
    pub solids_mass_fraction: f64,
    pub pigment_density_kg_m3: f64,
    pub binder_density_kg_m3: f64,
    /// Soluble binder, parts per hundred parts of pigment.
    pub binder_pph: f64,
    pub water_density_kg_m3: f64,
}

impl Colour {
    /// Table B1's colour at the given solids content.
    pub fn table_b1(solids_mass_fraction: f64) -> Colour {
        Colour {
            solids_mass_fraction,
            pigment_density_kg_m3: 2500.0,
            binder_density_kg_m3: 1500.0,
            binder_pph: 7.0,
            water_density_kg_m3: 1000.0,
        }
    }

    fn check(&self) -> Result<()> {
        let s = self.solids_mass_fraction;
        if !(s > 0.0 && s < 1.0) {
            return invalid(format!(
                "solids content {} %: must be between 0 and 100 % (exclusive)",
                s * 100.0
            ));
        }
        for (name, v) in [
            ("pigment density", self.pigment_density_kg_m3),
            ("binder density", self.binder_density_kg_m3),
            ("water density", self.water_density_kg_m3),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return invalid(format!("{name} {v} kg/m^3: must be positive and finite"));
            }
        }
        if !(self.binder_pph.is_finite() && self.binder_pph >= 0.0) {
            return invalid(format!(
                "binder {} pph: must be >= 0 and finite",
                self.binder_pph
            ));
        }
        Ok(())
    }

    /// Water mass per unit pigment mass.
    fn water_per_pigment(&self) -> f64 {
        let p = self.binder_pph / 100.0;
        (1.0 + p) * (1.0 / self.solids_mass_fraction - 1.0)
    }

    /// Pigment volume fraction of the wet film.
    pub fn pigment_volume_fraction(&self) -> Result<f64> {
        self.check()?;
        let p = self.binder_pph / 100.0;
        let vp = 1.0 / self.pigment_density_kg_m3;
        Ok(vp
            / (vp
                + p / self.binder_density_kg_m3
                + self.water_per_pigment() / self.water_density_kg_m3))
    }

    /// Density of the fluid phase (the binder solution), kg/m^3.
    pub fn fluid_density_kg_m3(&self) -> Result<f64> {
        self.check()?;
        let p = self.binder_pph / 100.0;
        let w = self.water_per_pigment();
        Ok((p + w) / (p / self.binder_density_kg_m3 + w / self.water_density_kg_m3))
    }
}

/// How the start is built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilmOptions {
    /// Largest fraction placed by plain random sequential addition.
    pub rsa_limit: f64,
    /// Random placements tried per particle before giving up.
    pub tries_per_particle: usize,
    /// Growth rounds before giving up.
    pub max_growth_rounds: usize,
    /// Budget of the hard-core moves during growth, m^2.
    pub k_max_m2: f64,
}

/// The start orientation: shortest semi-axis vertical, longest horizontal at azimuth `psi`.
pub fn lying_flat(semi_axes: &[f64; 3], psi: f64) -> UnitQuaternion<f64> {
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| semi_axes[j].partial_cmp(&semi_axes[i]).unwrap());
    // Body axis order[0] (longest) -> world x, order[1] -> y, order[2] (shortest) -> z.
    let mut m = Matrix3::zeros();
    for (world, &body) in order.iter().enumerate() {
        m[(world, body)] = 1.0;
    }
    if m.determinant() < 0.0 {
        // A reflection: flip the middle axis (its sign is arbitrary for an ellipsoid).
        for c in 0..3 {
            m[(1, c)] = -m[(1, c)];
        }
    }
    let base = UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(m));
    UnitQuaternion::from_axis_angle(&Vector3::z_axis(), psi) * base
}

/// Places `grains` into a film of side `box_side_m` at pigment volume fraction `phi`.
pub fn build<R: Rng>(
    grains: Vec<Grain>,
    box_side_m: f64,
    phi: f64,
    opts: &FilmOptions,
    rng: &mut R,
) -> Result<Layer> {
    if !(phi > 0.0 && phi < 0.74) {
        return invalid(format!(
            "pigment volume fraction {phi}: must be in (0, 0.74) (no denser packing exists)"
        ));
    }
    if grains.is_empty() {
        return invalid("the film holds no particles: give at least one");
    }
    let solid: f64 = grains.iter().map(|g| g.volume_m3).sum();
    let height = solid / (phi * box_side_m * box_side_m);
    // Larger particles first: random addition jams later that way.
    let mut order: Vec<usize> = (0..grains.len()).collect();
    order.sort_by(|&i, &j| {
        grains[j]
            .volume_m3
            .partial_cmp(&grains[i].volume_m3)
            .unwrap()
    });
    let mut layer = Layer {
        grains,
        poses: Vec::new(),
        box_side_m,
        film_height_m: height,
    };
    // Random addition at the limit; if it jams first (blends, flat particles in thin films),
    // again at 0.8 times the fraction, down to 0.05.
    let mut fraction = phi.min(opts.rsa_limit);
    loop {
        let scale0 = (fraction / phi).cbrt();
        if let Some((mut cells, mut positions)) = place_rsa(&mut layer, &order, scale0, opts, rng)?
        {
            if scale0 < 1.0 {
                grow(&mut layer, &mut cells, &mut positions, scale0, opts, rng)?;
            }
            return Ok(layer);
        }
        fraction *= 0.8;
        if fraction < 0.05 {
            return invalid(format!(
                "random sequential addition could not place the {} particles even at a \
                 fraction of 0.05 of the film ({height:.4e} m high): the film is too thin for \
                 these particles; use more particles or a smaller box",
                layer.grains.len()
            ));
        }
    }
}

/// Puts grain `i` (scaled by `scales[i]`) at `pose` if it then overlaps nothing and stays in
/// the film [0, lid]; true if it did.
#[allow(clippy::too_many_arguments)]
fn try_pose(
    layer: &mut Layer,
    cells: &mut super::cells::Cells,
    positions: &mut [Vector3<f64>],
    i: usize,
    pose: GrainPose,
    scales: &[f64],
    lid: f64,
    counts: &mut PrefilterCounts,
) -> bool {
    if !layer.fits(
        cells,
        positions,
        i,
        &pose,
        scales[i],
        Some(scales),
        Some(lid),
        counts,
    ) {
        return false;
    }
    layer.poses[i] = pose;
    positions[i] = pose.position;
    cells.moved(i, &pose.position);
    true
}

/// A random pose of `g` scaled by `scale` lying flat inside the film [0, lid] of the box of
/// side `box_side_m`; None when the film is thinner than the particle lying flat.
fn random_flat_pose<R: Rng>(
    g: &Grain,
    scale: f64,
    box_side_m: f64,
    lid: f64,
    rng: &mut R,
) -> Option<GrainPose> {
    let q = if g.is_sphere {
        UnitQuaternion::identity()
    } else {
        lying_flat(&g.semi_axes, rng.gen::<f64>() * std::f64::consts::TAU)
    };
    let hh = scale * g.half_height(&q);
    if 2.0 * hh > lid {
        return None;
    }
    let p = Vector3::new(
        rng.gen::<f64>() * box_side_m,
        rng.gen::<f64>() * box_side_m,
        hh + rng.gen::<f64>() * (lid - 2.0 * hh),
    );
    Some(GrainPose {
        position: p,
        orientation: q,
    })
}

/// Random sequential addition of every grain, shrunk by `scale0`, in the film [0, H]: the cell
/// list and positions, or None when some grain found no room in its tries.
fn place_rsa<R: Rng>(
    layer: &mut Layer,
    order: &[usize],
    scale0: f64,
    opts: &FilmOptions,
    rng: &mut R,
) -> Result<Option<(super::cells::Cells, Vec<Vector3<f64>>)>> {
    let n = layer.grains.len();
    let height = layer.film_height_m;
    let box_side_m = layer.box_side_m;
    // Provisional poses far above: a particle not yet placed is nobody's neighbour.
    let far = Vector3::new(0.0, 0.0, f64::MAX / 4.0);
    layer.poses = vec![
        GrainPose {
            position: far,
            orientation: UnitQuaternion::identity()
        };
        n
    ];
    let mut positions: Vec<Vector3<f64>> = vec![far; n];
    let mut cells = super::cells::Cells::new(box_side_m, layer.reach_m(), height, &positions);
    let mut counts = PrefilterCounts::default();
    let scales = vec![scale0; n];
    for &i in order {
        let g = layer.grains[i];
        let mut ok = false;
        for _ in 0..opts.tries_per_particle {
            let Some(pose) = random_flat_pose(&g, scale0, box_side_m, height, rng) else {
                return invalid(format!(
                    "the wet film ({height:.4e} m = particle volume / (phi L^2)) is thinner than \
                     particle {i} lying flat: use more particles or a smaller box"
                ));
            };
            let p = pose.position;
            if layer.fits(
                &cells,
                &positions,
                i,
                &pose,
                scale0,
                Some(&scales),
                Some(height),
                &mut counts,
            ) {
                layer.poses[i] = pose;
                positions[i] = p;
                cells.moved(i, &p);
                ok = true;
                break;
            }
        }
        if !ok {
            return Ok(None);
        }
    }
    Ok(Some((cells, positions)))
}

/// Grows the shrunk particles back to full size by hard-core Monte Carlo inside [0, H]: each
/// round every particle not yet full size tries to grow by its own step (which grows by half
/// after a success and halves after a failure), then every particle makes one hard-core move.
fn grow<R: Rng>(
    layer: &mut Layer,
    cells: &mut super::cells::Cells,
    positions: &mut [Vector3<f64>],
    scale0: f64,
    opts: &FilmOptions,
    rng: &mut R,
) -> Result<()> {
    let n = layer.grains.len();
    let lid = layer.film_height_m;
    let mut counts = PrefilterCounts::default();
    let mut scales = vec![scale0; n];
    let mut steps = vec![0.02f64; n];
    let mut since_growth = 0usize;
    for _round in 0..opts.max_growth_rounds {
        let mut grew = false;
        let mut all_full = true;
        for i in 0..n {
            if scales[i] >= 1.0 {
                continue;
            }
            let s_new = (scales[i] * (1.0 + steps[i])).min(1.0);
            let pose = layer.poses[i];
            if layer.fits(
                cells,
                positions,
                i,
                &pose,
                s_new,
                Some(&scales),
                Some(lid),
                &mut counts,
            ) {
                scales[i] = s_new;
                steps[i] *= 1.5;
                grew = true;
            } else {
                steps[i] = (steps[i] * 0.5).max(1e-9);
            }
            all_full &= scales[i] >= 1.0;
        }
        if all_full {
            return Ok(());
        }
        since_growth = if grew { 0 } else { since_growth + 1 };
        if since_growth > 1000 {
            break;
        }
        if since_growth > 0 && since_growth.is_multiple_of(100) {
            // A particle caged by its neighbours (or a wall) is moved to a random free place
            // at its current size: a valid hard-core move, tried before giving up.
            for i in (0..n).filter(|&i| scales[i] < 1.0) {
                let g = layer.grains[i];
                for _ in 0..opts.tries_per_particle {
                    let Some(pose) = random_flat_pose(&g, scales[i], layer.box_side_m, lid, rng)
                    else {
                        break;
                    };
                    if try_pose(layer, cells, positions, i, pose, &scales, lid, &mut counts) {
                        break;
                    }
                }
            }
        }
        for i in 0..n {
            let m = moves::draw(rng, opts.k_max_m2, &layer.grains[i].inertia_per_volume_m2);
            let mut pose = layer.poses[i];
            pose.position += Vector3::from(m.translation_m);
            super::cells::wrap_xy(&mut pose.position, layer.box_side_m);
            if !layer.grains[i].is_sphere {
                pose.orientation = m.rotate(&pose.orientation);
            }
            try_pose(layer, cells, positions, i, pose, &scales, lid, &mut counts);
        }
    }
    let solid: f64 = layer
        .grains
        .iter()
        .zip(&scales)
        .map(|(g, s)| g.volume_m3 * s.powi(3))
        .sum();
    let area_h = layer.box_side_m.powi(2) * lid;
    invalid(format!(
        "the start could not be grown to full size in {} rounds: {} of {n} particles are full \
         size, pigment fraction {:.3} of {:.3}; the solids content is too high for this shape",
        opts.max_growth_rounds,
        scales.iter().filter(|&&s| s >= 1.0).count(),
        solid / area_h,
        layer.solid_volume_m3() / area_h
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_b1_fractions() {
        // 65 % solids: 0.0004 / (0.0004 + 0.07/1500 + 1.07 (1/0.65 - 1)/1000).
        let c = Colour::table_b1(0.65);
        let w: f64 = 1.07 * (1.0 / 0.65 - 1.0);
        let want = 0.0004 / (0.0004 + 0.07 / 1500.0 + w / 1000.0);
        assert!((c.pigment_volume_fraction().unwrap() - want).abs() < 1e-15);
        let rho_f = c.fluid_density_kg_m3().unwrap();
        assert!(rho_f > 1000.0 && rho_f < 1500.0);
        assert!(Colour::table_b1(1.2).pigment_volume_fraction().is_err());
    }

    #[test]
    fn lying_flat_puts_the_shortest_axis_vertical() {
        for axes in [
            [1.0, 2.0, 3.0],
            [3.0, 3.0, 0.3],
            [0.2, 0.2, 2.0],
            [2.0, 0.5, 1.0],
        ] {
            let q = lying_flat(&axes, 0.7);
            let r = q.to_rotation_matrix().into_inner();
            // The body axis now vertical is a shortest one; a longest one is horizontal.
            let vertical = (0..3)
                .find(|&k| (r[(2, k)].abs() - 1.0).abs() < 1e-12)
                .unwrap();
            let min = axes.iter().cloned().fold(f64::INFINITY, f64::min);
            assert_eq!(axes[vertical], min, "{axes:?}");
            let longest = (0..3)
                .max_by(|&i, &j| axes[i].partial_cmp(&axes[j]).unwrap())
                .unwrap();
            assert!(r[(2, longest)].abs() < 1e-12);
        }
    }
}
