//! The particle configuration every observable takes: a species table of contact-module
//! shapes, each particle's species, position and orientation, and the container (a periodic
//! cubic box, a hard cylinder or a hard wedge). The MCM, deposition and DEM engines each
//! hand their particles over in this form.

use crate::contact::ContactShape;
use crate::error::invalid;
use crate::Result;
use nalgebra::{UnitQuaternion, Vector3};

/// Particles of per-particle shape (a species table of contact-module shapes: spheres,
/// spherocylinders, ellipsoids, superquadrics, and each particle's species) in the periodic
/// box [0, L)^3, or, with `wall_diameter`, inside a hard cylinder of that diameter about the z
/// axis (x = y = 0), periodic along z over [0, L), or, with `wedge` = (l_w, alpha in radians), inside the hard
/// wedge 0 <= y <= x tan(alpha), x <= l_w, periodic along z over [0, L) (thesis sec. 2.2.4).
#[derive(Debug, Clone, Copy)]
pub struct Configuration<'a> {
    pub box_length: f64,
    /// Diameter of the confining cylinder (None: periodic cubic box).
    pub wall_diameter: Option<f64>,
    /// Hard wedge (length l_w, angle alpha in radians); excludes `wall_diameter`.
    pub wedge: Option<(f64, f64)>,
    /// Species table (body frame; a spherocylinder's axis is the body z axis).
    pub shapes: &'a [ContactShape],
    /// Species of each particle (index into `shapes`).
    pub species: &'a [usize],
    pub positions: &'a [Vector3<f64>],
    /// Body -> world.
    pub orientations: &'a [UnitQuaternion<f64>],
}

/// The name this type had when only the MCM's rods used it; kept so existing paths work.
pub type Rods<'a> = Configuration<'a>;

/// Radius and half cylinder length of a sphere (0) or spherocylinder; None for other shapes.
pub fn rod_parameters(s: &ContactShape) -> Option<(f64, f64)> {
    match *s {
        ContactShape::Sphere { radius } => Some((radius, 0.0)),
        ContactShape::Spherocylinder { radius, length } => Some((radius, 0.5 * length)),
        _ => None,
    }
}

/// Total volume of particles with the given species: sum over species of count x volume
/// (exactly N V_p for one species).
pub fn total_volume(shapes: &[ContactShape], species: &[usize]) -> Result<f64> {
    let mut counts = vec![0usize; shapes.len()];
    for &s in species {
        if s >= shapes.len() {
            return invalid(format!(
                "species {s}: not in the table of {} shapes",
                shapes.len()
            ));
        }
        counts[s] += 1;
    }
    let mut v = 0.0;
    for (s, c) in shapes.iter().zip(counts) {
        v += c as f64 * crate::shape::volume_of(s)?;
    }
    Ok(v)
}

impl<'a> Configuration<'a> {
    /// Particles in a periodic cubic box of side `box_length` (no walls).
    pub fn periodic(
        box_length: f64,
        shapes: &'a [ContactShape],
        species: &'a [usize],
        positions: &'a [Vector3<f64>],
        orientations: &'a [UnitQuaternion<f64>],
    ) -> Configuration<'a> {
        Configuration {
            box_length,
            wall_diameter: None,
            wedge: None,
            shapes,
            species,
            positions,
            orientations,
        }
    }
    pub fn n(&self) -> usize {
        self.positions.len()
    }
    pub fn shape(&self, i: usize) -> &ContactShape {
        &self.shapes[self.species[i]]
    }
    /// Total particle volume (thesis eq. 2.2 for rods, eq. 4.26-4.28 for superquadrics).
    pub fn total_volume(&self) -> Result<f64> {
        total_volume(self.shapes, self.species)
    }
    pub(super) fn check(&self) -> Result<()> {
        if !(self.box_length.is_finite() && self.box_length > 0.0) {
            return invalid(format!(
                "box_length = {}: must be positive and finite",
                self.box_length
            ));
        }
        for (k, s) in self.shapes.iter().enumerate() {
            s.validate()
                .map_err(|e| crate::Error::InvalidInput(format!("species {k}: {e}")))?;
        }
        if self.positions.len() != self.orientations.len()
            || self.positions.len() != self.species.len()
        {
            return invalid(format!(
                "{} positions, {} orientations and {} species: must be equal",
                self.positions.len(),
                self.orientations.len(),
                self.species.len()
            ));
        }
        if let Some(i) = self.species.iter().position(|&s| s >= self.shapes.len()) {
            return invalid(format!(
                "particle {i}: species {} not in the table of {} shapes",
                self.species[i],
                self.shapes.len()
            ));
        }
        let mut dmax: f64 = 0.0;
        if self.wall_diameter.is_some() || self.wedge.is_some() {
            for s in self.shapes {
                // Configuration: their diameter; ellipsoids and superquadrics: their bounding sphere.
                let d = match rod_parameters(s) {
                    Some((r, _)) => 2.0 * r,
                    None => 2.0 * crate::shape::bounding_radius_of(s)?,
                };
                dmax = dmax.max(d);
            }
        }
        if let Some(d) = self.wall_diameter {
            if !(d.is_finite() && d > dmax) {
                return invalid(format!(
                    "wall_diameter = {d}: must be finite and larger than the particle diameter"
                ));
            }
        }
        if let Some((l, a)) = self.wedge {
            if self.wall_diameter.is_some() {
                return invalid("wedge and wall_diameter: a container has one wall type");
            }
            if !(l.is_finite() && l > 0.0 && a > 0.0 && a < 0.5 * std::f64::consts::PI) {
                return invalid(format!(
                    "wedge = ({l}, {a} rad): needs a positive finite length and 0 < alpha < pi/2"
                ));
            }
        }
        if let Some(i) = self
            .positions
            .iter()
            .position(|x| !(x.x.is_finite() && x.y.is_finite() && x.z.is_finite()))
        {
            return invalid(format!("position {i} is not finite"));
        }
        Ok(())
    }
}
