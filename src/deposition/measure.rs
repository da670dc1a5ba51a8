//! The observables of a finished deposit, through `analysis`: porosity of the layer and of its
//! core, the porosity profile, the RMS roughness of the top surface, the orientation order of
//! each species, the first-layer coverage of the substrate and the supported fraction of a
//! sphere deposit.

use super::Layer;
use crate::analysis::height_map::{height_map, order_against_z};
use crate::analysis::slab::{porosity_profile, solid_fraction_between, PosedEllipsoid, ProfileBin};
use crate::Result;
use serde::Serialize;

/// How the observables are measured.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasureOptions {
    /// Height-map nodes per shortest semi-axis (at least 5 for the stated resolution).
    pub nodes_per_shortest_semi_axis: f64,
    /// Bins of the porosity profile.
    pub profile_bins: usize,
    /// A particle whose lowest point is below this fraction of its shortest semi-axis touches
    /// the substrate (first-layer coverage).
    pub touch_fraction: f64,
}

impl Default for MeasureOptions {
    fn default() -> Self {
        MeasureOptions {
            nodes_per_shortest_semi_axis: 5.0,
            profile_bins: 50,
            touch_fraction: 0.01,
        }
    }
}

/// The observables of one deposit.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct DepositMeasures {
    /// Mean height h of the top surface, m.
    pub surface_mean_height_m: f64,
    /// Porosity over [0, h].
    pub layer_porosity: f64,
    /// Porosity over [2 l, h - 2 l] (l the longest particle diameter); None when h < 5 l.
    pub core_porosity: Option<f64>,
    /// RMS of the top-surface height, m (on a box of side `box_side_m`: not intensive).
    pub rms_roughness_m: f64,
    pub box_side_m: f64,
    /// Height-map nodes per side.
    pub grid_nodes: usize,
    /// Per species: order parameter S of its symmetry axis against z (None for spheres).
    pub order_by_species: Vec<Option<f64>>,
    /// Per species: particle count.
    pub count_by_species: Vec<usize>,
    /// Fraction of the substrate under particles that touch it.
    pub first_layer_coverage: f64,
    /// Fraction of the spheres at rest on their contacts (support.rs; None unless all grains
    /// are spheres).
    pub supported_fraction: Option<f64>,
    /// Mean count per sphere of its contacts below the centre (other spheres within 1 % of d,
    /// and the substrate as one; support.rs; None unless all grains are spheres).
    pub contacts_below_per_sphere: Option<f64>,
    #[serde(skip)]
    pub profile: Vec<ProfileBin>,
}

/// The body axis of a spheroid that differs from the other two (its symmetry axis): the one
/// whose semi-axis is farthest from the middle one. None for a sphere.
pub fn symmetry_axis(semi_axes: &[f64; 3]) -> Option<usize> {
    let mut s = *semi_axes;
    s.sort_by(|a, b| a.partial_cmp(b).unwrap());
    if s[0] == s[2] {
        return None;
    }
    let mid = s[1];
    (0..3).max_by(|&i, &j| {
        (semi_axes[i] - mid)
            .abs()
            .partial_cmp(&(semi_axes[j] - mid).abs())
            .unwrap()
    })
}

/// The layer's particles as analysis ellipsoids.
pub fn posed(layer: &Layer) -> Vec<PosedEllipsoid> {
    layer
        .grains
        .iter()
        .zip(&layer.poses)
        .map(|(g, p)| PosedEllipsoid {
            semi_axes: g.semi_axes,
            position: p.position,
            orientation: p.orientation,
        })
        .collect()
}

/// Measures a deposit of `n_species` species.
pub fn measure(layer: &Layer, n_species: usize, opts: &MeasureOptions) -> Result<DepositMeasures> {
    let parts = posed(layer);
    let l = layer.box_side_m;
    let area = l * l;
    let shortest = layer
        .grains
        .iter()
        .map(|g| g.inner_radius_m)
        .fold(f64::INFINITY, f64::min);
    let longest = layer
        .grains
        .iter()
        .map(|g| g.longest_diameter())
        .fold(0.0, f64::max);
    let n = ((l / shortest * opts.nodes_per_shortest_semi_axis).ceil() as usize).max(1);
    // Touching: per particle, below touch_fraction x its own shortest semi-axis; the map takes
    // one threshold, so use the smallest (conservative for blends).
    let hm = height_map(&parts, l, n, opts.touch_fraction * shortest)?;
    let h = hm.mean_m();
    let top = parts
        .iter()
        .map(|p| p.position.z + p.half_height())
        .fold(0.0, f64::max);
    let profile = porosity_profile(&parts, area, top.max(f64::MIN_POSITIVE), opts.profile_bins)?;
    let layer_porosity = 1.0 - solid_fraction_between(&parts, area, 0.0, h);
    let core_porosity = (h >= 5.0 * longest)
        .then(|| 1.0 - solid_fraction_between(&parts, area, 2.0 * longest, h - 2.0 * longest));
    let mut order_by_species = Vec::with_capacity(n_species);
    let mut count_by_species = vec![0usize; n_species];
    for g in &layer.grains {
        count_by_species[g.species] += 1;
    }
    for s in 0..n_species {
        let axes = layer
            .grains
            .iter()
            .zip(&layer.poses)
            .filter(|(g, _)| g.species == s)
            .filter_map(|(g, p)| {
                symmetry_axis(&g.semi_axes).map(|k| super::grain::vertical_row(&p.orientation)[k])
            });
        order_by_species.push(order_against_z(axes));
    }
    Ok(DepositMeasures {
        surface_mean_height_m: h,
        layer_porosity,
        core_porosity,
        rms_roughness_m: hm.rms_roughness_m(),
        box_side_m: l,
        grid_nodes: n,
        order_by_species,
        count_by_species,
        first_layer_coverage: hm.first_layer_coverage(),
        supported_fraction: super::support::supported_fraction(layer),
        contacts_below_per_sphere: super::support::mean_contacts_below(layer),
        profile,
    })
}
