//! Local support of a sphere deposit. Under gravity and without friction a sphere is at rest
//! when its weight can be balanced by its contacts below: the vertical ez lies in the cone of
//! the contact normals, which for spheres means that the horizontal projection of its centre
//! lies in the convex hull of the projections of its contact points below the centre (or it
//! touches the substrate). By Farkas' lemma this is the same as: no displacement lowers the
//! sphere without overlapping a contact at first order, so at T = 0 a supported sphere has no
//! accepted move left (eq. A2 with gravity), and an unsupported one (on a ridge between two
//! spheres, or leaning on one) still has downhill moves, however rare.
//!
//! Contacts are read with a tolerance: a surface gap below `gap_fraction` of the smaller
//! diameter counts as a contact.

use super::Layer;
use nalgebra::Vector3;
use std::collections::HashMap;
use std::f64::consts::PI;

/// The gap, as a fraction of the smaller diameter, below which two spheres (or a sphere and
/// the substrate) are read as touching by [`supported_fraction`]'s default use.
pub const CONTACT_GAP_FRACTION: f64 = 0.01;

/// Whether each sphere of `layer` is supported (module doc); None when a grain is not a sphere.
pub fn supported(layer: &Layer, gap_fraction: f64) -> Option<Vec<bool>> {
    Some(
        contacts_below(layer, gap_fraction)?
            .into_iter()
            .map(|(s, _)| s)
            .collect(),
    )
}

/// Per sphere of `layer`: whether it is supported (module doc) and its contacts below the
/// centre (other spheres, and the substrate as one); None when a grain is not a sphere.
pub fn contacts_below(layer: &Layer, gap_fraction: f64) -> Option<Vec<(bool, usize)>> {
    if layer.grains.iter().any(|g| !g.is_sphere) {
        return None;
    }
    let n = layer.grains.len();
    let l = layer.box_side_m;
    let radius: Vec<f64> = layer.grains.iter().map(|g| g.semi_axes[0]).collect();
    let pos: Vec<Vector3<f64>> = layer.poses.iter().map(|p| p.position).collect();
    let r_max = radius.iter().copied().fold(0.0, f64::max);
    // cells at least one contact distance wide; periodic along x and y
    let per_side = ((l / (2.0 * r_max * (1.0 + gap_fraction))).floor() as i64).max(1);
    let cell = l / per_side as f64;
    let key = |p: &Vector3<f64>| {
        (
            ((p.x / cell).floor() as i64).rem_euclid(per_side),
            ((p.y / cell).floor() as i64).rem_euclid(per_side),
            (p.z / cell).floor() as i64,
        )
    };
    let mut grid: HashMap<(i64, i64, i64), Vec<usize>> = HashMap::new();
    for (i, p) in pos.iter().enumerate() {
        grid.entry(key(p)).or_default().push(i);
    }
    let wrap = |d: f64| d - l * (d / l).round();
    let mut out = Vec::with_capacity(n);
    for i in 0..n {
        let (c, ri) = (pos[i], radius[i]);
        let on_substrate = c.z - ri < gap_fraction * 2.0 * ri;
        let (kx, ky, kz) = key(&c);
        let mut angles: Vec<f64> = Vec::new();
        let mut under_centre = false;
        // the neighbouring columns, each once (fewer than three cells per side repeat)
        let mut columns: Vec<(i64, i64)> = Vec::with_capacity(9);
        for dx in -1..=1 {
            for dy in -1..=1 {
                let col = (
                    (kx + dx).rem_euclid(per_side),
                    (ky + dy).rem_euclid(per_side),
                );
                if !columns.contains(&col) {
                    columns.push(col);
                }
            }
        }
        for (cx, cy) in columns {
            for dz in -1..=1 {
                let Some(list) = grid.get(&(cx, cy, kz + dz)) else {
                    continue;
                };
                for &j in list {
                    if j == i {
                        continue;
                    }
                    let d =
                        Vector3::new(wrap(pos[j].x - c.x), wrap(pos[j].y - c.y), pos[j].z - c.z);
                    let reach = ri + radius[j] + gap_fraction * 2.0 * ri.min(radius[j]);
                    if d.z >= 0.0 || d.norm_squared() >= reach * reach {
                        continue;
                    }
                    // the contact point's horizontal offset from the centre, along d
                    let h = d.xy() * (ri / (ri + radius[j]));
                    if h.norm() <= 1e-9 * ri {
                        under_centre = true;
                    } else {
                        angles.push(h.y.atan2(h.x));
                    }
                }
            }
        }
        let below = angles.len() + usize::from(under_centre) + usize::from(on_substrate);
        out.push((
            on_substrate || under_centre || encloses_origin(&mut angles),
            below,
        ));
    }
    Some(out)
}

/// The fraction of supported spheres ([`supported`] with [`CONTACT_GAP_FRACTION`]); None when
/// a grain is not a sphere or the layer is empty.
pub fn supported_fraction(layer: &Layer) -> Option<f64> {
    let s = supported(layer, CONTACT_GAP_FRACTION)?;
    (!s.is_empty()).then(|| s.iter().filter(|&&b| b).count() as f64 / s.len() as f64)
}

/// The mean count of contacts below the centre per sphere ([`contacts_below`] with
/// [`CONTACT_GAP_FRACTION`]); None when a grain is not a sphere or the layer is empty.
pub fn mean_contacts_below(layer: &Layer) -> Option<f64> {
    let c = contacts_below(layer, CONTACT_GAP_FRACTION)?;
    (!c.is_empty()).then(|| c.iter().map(|&(_, k)| k as f64).sum::<f64>() / c.len() as f64)
}

/// Whether points at these polar angles around the origin enclose it strictly: every angular
/// gap between neighbours (cyclically) is below pi.
fn encloses_origin(angles: &mut [f64]) -> bool {
    if angles.len() < 3 {
        return false;
    }
    angles.sort_by(f64::total_cmp);
    let wrap_gap = angles[0] + 2.0 * PI - angles[angles.len() - 1];
    let widest = angles
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(wrap_gap, f64::max);
    widest < PI
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::deposition::grain::{Grain, GrainPose};
    use nalgebra::UnitQuaternion;

    fn layer(centres: &[[f64; 3]], r: f64, l: f64) -> Layer {
        let g = Grain::new([r; 3], 0, 2500.0, 1000.0, 9.8).unwrap();
        Layer {
            grains: vec![g; centres.len()],
            poses: centres
                .iter()
                .map(|c| GrainPose {
                    position: Vector3::from(*c),
                    orientation: UnitQuaternion::identity(),
                })
                .collect(),
            box_side_m: l,
            film_height_m: 4.0 * r,
        }
    }

    #[test]
    fn pocket_of_three_supports_ridge_of_two_does_not() {
        let (r, l) = (1.0, 20.0);
        // three spheres on the substrate at the corners of an equilateral triangle of side 2r
        let h3 = 3f64.sqrt();
        let base = [[5.0, 5.0, r], [7.0, 5.0, r], [6.0, 5.0 + h3, r]];
        let centroid = [6.0, 5.0 + h3 / 3.0];
        // the pocket: at distance 2r from all three
        let z = r + (4.0 * r * r - (2.0 / h3) * (2.0 / h3)).sqrt();
        let mut c = base.to_vec();
        c.push([centroid[0], centroid[1], z]);
        assert_eq!(supported(&layer(&c, r, l), 0.01).unwrap(), vec![true; 4]);
        // on the ridge of the first two only (the third moved away): not supported
        let mut c = base[..2].to_vec();
        c.push([6.0, 5.0, r + 3f64.sqrt() * r]);
        assert_eq!(
            supported(&layer(&c, r, l), 0.01).unwrap(),
            vec![true, true, false]
        );
        // contacts below: the substrate for the two below, the two of them for the ridge
        let below = contacts_below(&layer(&c, r, l), 0.01).unwrap();
        assert_eq!(below.iter().map(|b| b.1).collect::<Vec<_>>(), vec![1, 1, 2]);
        // across the periodic boundary: the same pocket shifted by -5.5 in x
        let mut c: Vec<[f64; 3]> = base
            .iter()
            .map(|p| [(p[0] - 5.5).rem_euclid(l), p[1], p[2]])
            .collect();
        c.push([(centroid[0] - 5.5).rem_euclid(l), centroid[1], z]);
        assert_eq!(supported(&layer(&c, r, l), 0.01).unwrap(), vec![true; 4]);
    }

    #[test]
    fn angular_gap_rule() {
        assert!(encloses_origin(&mut [0.0, 2.0, 4.0]));
        assert!(!encloses_origin(&mut [0.0, 1.0, 2.0]));
        assert!(!encloses_origin(&mut [0.0, PI]));
    }
}
