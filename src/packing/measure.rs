//! Observables of a packing (thesis sec. 2.2.5, 3.3, eq. 2.11, 4.17): packing fraction,
//! deepest overlap, contact numbers at gap cut-offs and their extrapolation to contact, with
//! and without rattlers, nematic and cubatic order, wall alignment, and for ellipsoids and
//! superquadrics the solver-free sampled overlap check; all by [`crate::analysis`],
//! independently of the engine's own pair search.

use super::{Container, Packing, RADIUS};
use crate::analysis;
use crate::Result;
use serde::Serialize;

/// Observables of a final configuration (thesis sec. 2.2.5, 3.3, eq. 2.11, 4.17).
#[derive(Debug, Clone, Serialize)]
pub struct Measures {
    pub packing_fraction: f64,
    /// Deepest overlap (>= 0) by the analysis' pair search ([`analysis::pair_gaps`], independent
    /// of the engine; equal to the brute force over all pairs and images).
    pub deepest_overlap: f64,
    pub contact_cutoffs: Vec<f64>,
    /// Mean contacts at each cut-off, all particles.
    pub contacts_at_cutoffs: Vec<f64>,
    /// Linear extrapolation to zero cut-off, all particles counted (rattlers included).
    pub contacts_extrapolated: f64,
    /// The same with rattlers removed repeatedly (fewer than `rattler_min_contacts`); `None`
    /// (JSON null) when that removes every particle at some cut-off, as it does for hypostatic
    /// packings (superballs with the default threshold 5): there is no mean to report.
    pub contacts_extrapolated_no_rattlers: Option<f64>,
    pub rattler_min_contacts: usize,
    /// Rattlers at the smallest cut-off.
    pub rattlers: usize,
    pub nematic_s: f64,
    pub cubatic_s4: f64,
    /// Cylinder and wedge: fraction of the particles within D of a wall whose axis is
    /// tangential to it within 4 degrees (thesis sec. 2.2.5, Fig. 2.6, 2.14), and how many are
    /// in that layer.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_aligned_fraction: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wall_layer_particles: Option<usize>,
    /// Ellipsoids / superquadrics only: deepest penetration proven by the solver-free sampled
    /// check ([`analysis::sampled_overlap`], 0 when no sample lies inside another particle)
    /// and the sample spacing, its resolution.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sampled_deepest_overlap: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub sample_spacing: Option<f64>,
}

/// Measures a configuration with [`crate::analysis`].
pub fn measure(
    p: &Packing,
    cutoffs: &[f64],
    min_contacts: usize,
    s4_trials: usize,
) -> Result<Measures> {
    let v = p.view();
    let dmax = cutoffs.iter().cloned().fold(0.0, f64::max);
    let gaps = analysis::pair_gaps(&v, dmax)?;
    let deepest = gaps.iter().map(|g| -g.gap).fold(0.0f64, f64::max);
    let contacts_at: Vec<f64> = cutoffs
        .iter()
        .map(|&d| analysis::mean_contacts(v.n(), &gaps, d, None).0)
        .collect();
    let (c0, _) = analysis::extrapolated_contacts(v.n(), &gaps, cutoffs, None)?;
    let c0r = if analysis::cutoff_where_all_rattle(v.n(), &gaps, cutoffs, min_contacts).is_some() {
        None
    } else {
        Some(analysis::extrapolated_contacts(v.n(), &gaps, cutoffs, Some(min_contacts))?.0)
    };
    let dmin = cutoffs.iter().cloned().fold(f64::INFINITY, f64::min);
    let (_, rattlers) = analysis::mean_contacts(v.n(), &gaps, dmin, Some(min_contacts));
    let wall = match p.container {
        Container::Periodic => None,
        Container::Cylinder { .. } | Container::Wedge { .. } => Some(
            analysis::wall_aligned_fraction(&v, 2.0 * RADIUS, 4f64.to_radians())?,
        ),
    };
    let sampled = if p.particles.has_superquadrics() {
        Some(analysis::sampled_overlap(&v, analysis::OVERLAP_SAMPLES)?)
    } else {
        None
    };
    Ok(Measures {
        sampled_deepest_overlap: sampled.map(|s| s.worst.map_or(0.0, |w| w.2)),
        sample_spacing: sampled.map(|s| s.spacing),
        packing_fraction: p.packing_fraction(),
        deepest_overlap: deepest,
        contact_cutoffs: cutoffs.to_vec(),
        contacts_at_cutoffs: contacts_at,
        contacts_extrapolated: c0,
        contacts_extrapolated_no_rattlers: c0r,
        rattler_min_contacts: min_contacts,
        rattlers,
        nematic_s: analysis::nematic_order(&p.axes())?,
        cubatic_s4: analysis::cubatic_order(&p.orientations, s4_trials)?,
        wall_aligned_fraction: wall.map(|w| w.0),
        wall_layer_particles: wall.map(|w| w.1),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packing::ParticleShapes;
    use nalgebra::{UnitQuaternion, Vector3};

    /// Four touching spheres in a row have 1.5 contacts each on average. With the rattler
    /// threshold 2 the ends go, then the middle pair: nothing is left, and the rattler-free
    /// contact number is null, not 0. Threshold 1 keeps all four.
    #[test]
    fn rattler_free_contacts_are_null_when_every_particle_rattles() {
        let p = Packing {
            container: Container::Periodic,
            box_length: 10.0,
            particles: ParticleShapes::monodisperse(4, 0.0),
            positions: (0..4)
                .map(|k| Vector3::new(1.0 + k as f64, 5.0, 5.0))
                .collect(),
            orientations: vec![UnitQuaternion::identity(); 4],
        };
        let cut = [1e-6, 1e-5];
        let all = measure(&p, &cut, 2, 10).unwrap();
        assert_eq!(all.rattlers, 4);
        assert_eq!(all.contacts_extrapolated_no_rattlers, None);
        assert!((all.contacts_extrapolated - 1.5).abs() < 1e-12);
        let kept = measure(&p, &cut, 1, 10).unwrap();
        assert_eq!(kept.rattlers, 0);
        let c0 = kept.contacts_extrapolated_no_rattlers.unwrap();
        assert!((c0 - 1.5).abs() < 1e-12, "{c0}");
    }
}
