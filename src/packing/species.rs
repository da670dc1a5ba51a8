//! Per-particle shapes of an MCM packing: a species table (shapes as the contact module's plain
//! parameters, [`ContactShape`]) and each particle's species index. A monodisperse packing has
//! one species; a mixture one per component; a polydisperse packing (each particle its own
//! size) one per particle.
//!
//! Sphere and spherocylinder species pair through the closed-form segment geometry of the
//! engine (both overlap-removal schemes); ellipsoids and superquadrics (thesis ch. 4) pair
//! through the certified common-normal Newton-Raphson of `crate::contact` and only with the
//! revised scheme, which is what the thesis used for them (sec. 4.5).

use crate::contact::{ContactShape, SqShape};
use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;

/// The shapes of the particles of a packing (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct ParticleShapes {
    /// Species table.
    pub shapes: Vec<ContactShape>,
    /// Species of each particle (index into `shapes`).
    pub species: Vec<usize>,
}

impl ParticleShapes {
    /// N equal particles of radius R = 1/2: spheres (L = 0) or spherocylinders of cylinder
    /// length L (the MCM's reduced units, diameter 1).
    pub fn monodisperse(n: usize, length: f64) -> ParticleShapes {
        let shape = if length == 0.0 {
            ContactShape::Sphere {
                radius: super::RADIUS,
            }
        } else {
            ContactShape::Spherocylinder {
                radius: super::RADIUS,
                length,
            }
        };
        ParticleShapes {
            shapes: vec![shape],
            species: vec![0; n],
        }
    }

    /// A mixture: `count` particles of each shape, in the order given (particle indices in
    /// blocks).
    pub fn mixture(parts: &[(ContactShape, usize)]) -> ParticleShapes {
        let mut species = Vec::new();
        for (k, (_, c)) in parts.iter().enumerate() {
            species.extend(std::iter::repeat_n(k, *c));
        }
        ParticleShapes {
            shapes: parts.iter().map(|(s, _)| *s).collect(),
            species,
        }
    }

    /// One species per particle (polydisperse).
    pub fn per_particle(shapes: Vec<ContactShape>) -> ParticleShapes {
        let species = (0..shapes.len()).collect();
        ParticleShapes { shapes, species }
    }

    pub fn n(&self) -> usize {
        self.species.len()
    }

    pub fn shape(&self, i: usize) -> &ContactShape {
        &self.shapes[self.species[i]]
    }

    /// True when any species is an ellipsoid or superquadric (contact-solver pairs).
    pub fn has_superquadrics(&self) -> bool {
        self.shapes.iter().any(is_superquadric)
    }

    /// Checks every shape and every species index; the message names the offender.
    pub fn validate(&self) -> Result<()> {
        if self.shapes.is_empty() {
            return invalid("particles: the species table is empty");
        }
        for (k, s) in self.shapes.iter().enumerate() {
            s.validate().map_err(|e| {
                crate::Error::InvalidInput(format!("species {k} ({}): {e}", s.name()))
            })?;
        }
        if let Some(i) = self.species.iter().position(|&s| s >= self.shapes.len()) {
            return invalid(format!(
                "particle {i}: species {} is not in the table of {} shapes",
                self.species[i],
                self.shapes.len()
            ));
        }
        let rods = self
            .shapes
            .iter()
            .any(|s| matches!(s, ContactShape::Spherocylinder { .. }));
        if rods && self.has_superquadrics() {
            return invalid(
                "particles: spherocylinders cannot be mixed with ellipsoids or superquadrics (the \
                 contact module has no spherocylinder-superquadric query)",
            );
        }
        Ok(())
    }

    /// Number of particles of each species.
    pub fn counts(&self) -> Vec<usize> {
        let mut c = vec![0; self.shapes.len()];
        for &s in &self.species {
            c[s] += 1;
        }
        c
    }

    /// Total particle volume sum_species count V (thesis eq. 3.1 numerator; for one species
    /// exactly N V_p).
    pub fn total_volume(&self) -> Result<f64> {
        crate::analysis::total_volume(&self.shapes, &self.species)
    }

    /// Largest bounding radius over the species.
    pub fn max_bounding_radius(&self) -> Result<f64> {
        let mut r: f64 = 0.0;
        for s in &self.shapes {
            r = r.max(crate::shape::bounding_radius_of(s)?);
        }
        Ok(r)
    }
}

fn is_superquadric(s: &ContactShape) -> bool {
    matches!(
        s,
        ContactShape::Ellipsoid { .. } | ContactShape::Superquadric { .. }
    )
}

/// What the overlap removal needs of one species, computed once per removal pass.
#[derive(Debug, Clone)]
pub(super) struct Props {
    /// The shape itself (contact queries).
    pub shape: ContactShape,
    /// Sphere/spherocylinder radius R and half cylinder length L/2 (superquadrics: 0, 0).
    pub r: f64,
    pub h: f64,
    /// Ellipsoid or superquadric (None for spheres and rods). Without the solver's surface
    /// samples (sec. 4.4.2): with 400 samples their k-d tree searches took half the run time
    /// of 50 superballs (perf) and the solver, started from support points instead, gave
    /// bitwise the same packing in half the time.
    pub sq: Option<SqShape>,
    /// Bounding radius (L/2 + R for rods).
    pub bound: f64,
    /// Mass = volume (density 1, thesis sec. 3.6).
    pub mass: f64,
    /// Principal moments of inertia at mass = volume, body frame (revised scheme).
    pub inertia: Vector3<f64>,
    /// Original scheme: xi = I_xy / m (sec. 2.3).
    pub xi: f64,
    /// A sphere (never rotated).
    pub sphere: bool,
}

impl Props {
    pub fn new(s: &ContactShape) -> Result<Props> {
        let mass = crate::shape::volume_of(s)?;
        let bound = crate::shape::bounding_radius_of(s)?;
        let rod = |r: f64, l: f64| {
            let (ixy, iz) = super::rod_inertia(r, l, mass);
            Props {
                shape: *s,
                r,
                h: 0.5 * l,
                sq: None,
                bound,
                mass,
                inertia: Vector3::new(ixy, ixy, iz),
                xi: super::rod_inertia(r, l, 1.0).0,
                sphere: l == 0.0,
            }
        };
        Ok(match *s {
            ContactShape::Sphere { radius } => rod(radius, 0.0),
            ContactShape::Spherocylinder { radius, length } => rod(radius, length),
            ContactShape::Ellipsoid { semi_axes } => {
                let e = crate::shape::Ellipsoid::new(semi_axes)?;
                sq_props(s, &e, SqShape::new(semi_axes, [2.0; 3]), mass, bound)
            }
            ContactShape::Superquadric {
                semi_axes,
                exponents,
            } => {
                let q = crate::shape::Superquadric::new(semi_axes, exponents)?;
                sq_props(s, &q, SqShape::new(semi_axes, exponents), mass, bound)
            }
        })
    }
}

/// Props of an ellipsoid or superquadric: inertia from the shape module (thesis eq. 4.29-4.31).
fn sq_props(
    contact_shape: &ContactShape,
    shape: &dyn crate::shape::ConvexShape,
    sq: SqShape,
    mass: f64,
    bound: f64,
) -> Props {
    let inertia = shape.principal_inertia(mass);
    Props {
        shape: *contact_shape,
        r: 0.0,
        h: 0.0,
        sq: Some(sq),
        bound,
        mass,
        inertia,
        xi: inertia.x / mass,
        sphere: false,
    }
}

/// The props of every species (for a sphere among superquadrics the contact solver treats it
/// as a superquadric with exponents 2).
pub(super) fn props_of(p: &ParticleShapes) -> Result<Vec<Props>> {
    let sq = p.has_superquadrics();
    p.shapes
        .iter()
        .map(|s| {
            let mut pr = Props::new(s)?;
            if sq {
                if let (None, Some(q)) = (&pr.sq, s.as_superquadric()) {
                    pr.sq = Some(q);
                }
            }
            Ok(pr)
        })
        .collect()
}
