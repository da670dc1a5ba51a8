//! Hard-core overlap of two posed grains through the cheapest sufficient test (seed 000
//! appendix A): bounding spheres (apart), spheres in closed form, inscribed spheres (overlap),
//! then the Perram-Wertheim contact function with its early exit on F > 1
//! ([`crate::contact::contact_ellipsoid_ellipsoid::pw_overlap`]). The substrate z = 0 is met
//! through the support function ([`super::grain::Grain::half_height`]).

use super::grain::Grain;
use crate::contact::contact_ellipsoid_ellipsoid::pw_overlap;
use crate::contact::Pose;
use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

/// How many pair tests each stage settled.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct PrefilterCounts {
    /// Apart by bounding spheres.
    pub bounding_spheres: u64,
    /// Two spheres: settled in closed form.
    pub sphere_pairs: u64,
    /// Overlapping by inscribed spheres.
    pub inscribed_spheres: u64,
    /// Settled by Perram-Wertheim.
    pub perram_wertheim: u64,
}

impl PrefilterCounts {
    pub fn add(&mut self, o: &PrefilterCounts) {
        self.bounding_spheres += o.bounding_spheres;
        self.sphere_pairs += o.sphere_pairs;
        self.inscribed_spheres += o.inscribed_spheres;
        self.perram_wertheim += o.perram_wertheim;
    }
    pub fn total(&self) -> u64 {
        self.bounding_spheres + self.sphere_pairs + self.inscribed_spheres + self.perram_wertheim
    }
}

/// Do grain `a` (orientation `qa`, shape scaled by `sa` about its centre) and grain `b`
/// (orientation `qb`, scaled by `sb`, centre at `d` from a's) overlap? Touching is not overlap.
#[allow(clippy::too_many_arguments)]
pub fn pair_overlaps(
    a: &Grain,
    qa: &UnitQuaternion<f64>,
    sa: f64,
    b: &Grain,
    qb: &UnitQuaternion<f64>,
    sb: f64,
    d: &Vector3<f64>,
    counts: &mut PrefilterCounts,
) -> bool {
    let d2 = d.norm_squared();
    let ro = sa * a.outer_radius_m + sb * b.outer_radius_m;
    if d2 >= ro * ro {
        counts.bounding_spheres += 1;
        return false;
    }
    if a.is_sphere && b.is_sphere {
        counts.sphere_pairs += 1;
        return true;
    }
    let ri = sa * a.inner_radius_m + sb * b.inner_radius_m;
    if d2 < ri * ri {
        counts.inscribed_spheres += 1;
        return true;
    }
    counts.perram_wertheim += 1;
    let ea = a.semi_axes.map(|x| x * sa);
    let eb = b.semi_axes.map(|x| x * sb);
    pw_overlap(
        &Pose::new(Vector3::zeros(), *qa),
        &ea,
        &Pose::new(*d, *qb),
        &eb,
    )
    .0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Overlap of two copies of `g` (identity orientation) scaled by `sa`, `sb`, centres `d` apart.
    fn ov(g: &Grain, sa: f64, sb: f64, d: [f64; 3], c: &mut PrefilterCounts) -> bool {
        let q = UnitQuaternion::identity();
        pair_overlaps(g, &q, sa, g, &q, sb, &Vector3::from(d), c)
    }

    #[test]
    fn spheres_touching_do_not_overlap_and_closer_ones_do() {
        let g = Grain::new([1.0; 3], 0, 2.0, 1.0, 1.0).unwrap();
        let mut c = PrefilterCounts::default();
        assert!(!ov(&g, 1.0, 1.0, [2.0, 0.0, 0.0], &mut c));
        assert!(ov(&g, 1.0, 1.0, [1.999, 0.0, 0.0], &mut c));
        assert_eq!(c.bounding_spheres, 1);
        assert_eq!(c.sphere_pairs, 1);
        // Scaled by 0.5 and 1.5 the two spheres touch at 2.
        assert!(!ov(&g, 0.5, 1.5, [2.0, 0.0, 0.0], &mut c));
        assert!(ov(&g, 0.5, 1.5, [1.99, 0.0, 0.0], &mut c));
    }

    #[test]
    fn ellipsoids_side_by_side_touch_at_the_sum_of_their_axes() {
        let g = Grain::new([2.0, 1.0, 0.5], 0, 2.0, 1.0, 1.0).unwrap();
        let mut c = PrefilterCounts::default();
        // Along y the two touch at 2 b = 2.
        assert!(!ov(&g, 1.0, 1.0, [0.0, 2.001, 0.0], &mut c));
        assert!(ov(&g, 1.0, 1.0, [0.0, 1.999, 0.0], &mut c));
        // Along z at 2 c = 1; scaled by 2 about their centres they touch at 2.
        assert!(!ov(&g, 2.0, 2.0, [0.0, 0.0, 2.001], &mut c));
        assert!(ov(&g, 2.0, 2.0, [0.0, 0.0, 1.999], &mut c));
    }
}
