//! Pair contact detection (parry style: one file per pair query) and the periodic broad phase.
//!
//! Every query returns one [`Contact`]: the two contact points in world coordinates, the unit
//! normal pointing from body a to body b, and the signed gap (> 0 apart, < 0 overlapping).
//!
//! | pair | method (`Contact::method`) | file |
//! |---|---|---|
//! | sphere-sphere | closed form | `contact_sphere_sphere.rs` |
//! | spherocylinder-spherocylinder | closest points of the axis segments (Vega & Lago 1994) | `contact_spherocylinder_spherocylinder.rs` |
//! | sphere-spherocylinder | closest point of a segment | `contact_sphere_spherocylinder.rs` |
//! | sphere-ellipsoid | point-to-ellipsoid distance (monotone root in the Lagrange multiplier) | `contact_sphere_ellipsoid.rs` |
//! | ellipsoid-ellipsoid | overlap and scale factor: Perram-Wertheim + Brent (seed 000 app. A); points, gap, normal: common-normal Newton-Raphson | `contact_ellipsoid_ellipsoid.rs` |
//! | superquadric-superquadric (and ellipsoid/sphere with superquadric) | common-normal Newton-Raphson with analytic Jacobian and Householder frames (thesis 003 sec. 4.4, app. 4.B), prefiltered by bounding spheres and point samples in a k-d tree (sec. 4.4.2) | `contact_superquadric_superquadric.rs` |
//!
//! Shapes are given here by plain parameters ([`ContactShape`]) and a [`Pose`] (position and
//! orientation: body frame -> world), so the contact code depends on nothing but nalgebra.
//!
//! **Failure behaviour.** The iterative queries (superquadric Newton-Raphson) never return a
//! sign they have not certified: a separated result is certified by a separating plane
//! (support functions of both bodies along the normal), an overlapping one by a witness point
//! strictly inside both bodies. When the iteration does not converge from any of its starting
//! points, or converges to a stationary pair that fails the certificate, or the gap is below
//! what rounding can resolve, the query returns `Err(ContactError::NotConverged { .. })`.

pub mod broad_phase;
pub mod contact_ellipsoid_ellipsoid;
pub mod contact_sphere_ellipsoid;
pub mod contact_sphere_sphere;
pub mod contact_sphere_spherocylinder;
pub mod contact_spherocylinder_spherocylinder;
pub mod contact_superquadric_superquadric;
pub mod kdtree;
pub mod pairgen;
pub mod superquadric_geometry;

pub use broad_phase::CellList;
pub use contact_ellipsoid_ellipsoid::{
    contact_ellipsoid_ellipsoid, pw_contact_function, pw_max, pw_overlap, PwResult,
};
pub use contact_sphere_ellipsoid::contact_sphere_ellipsoid;
pub use contact_sphere_sphere::contact_sphere_sphere;
pub use contact_sphere_spherocylinder::contact_sphere_spherocylinder;
pub use contact_spherocylinder_spherocylinder::{
    closest_points_segments, contact_spherocylinder_spherocylinder,
};
pub use contact_superquadric_superquadric::{
    contact_superquadric_superquadric, overlap_superquadric_superquadric, NrOptions, SqBody,
    SqShape,
};

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

/// Result of a pair query.
#[derive(Debug, Clone, PartialEq)]
pub struct Contact {
    /// Contact point on the surface of body a (world).
    pub point_a: Vector3<f64>,
    /// Contact point on the surface of body b (world).
    pub point_b: Vector3<f64>,
    /// Unit normal from a to b (outward normal of a at `point_a`).
    pub normal: Vector3<f64>,
    /// Signed gap: > 0 apart (distance), < 0 overlapping (common-normal overlap depth).
    pub gap: f64,
    /// Which algorithm produced the result.
    pub method: &'static str,
    /// Perram-Wertheim contact scale factor sqrt(max F) (ellipsoid pairs only): the factor by
    /// which both ellipsoids must be scaled about their centres to touch (< 1 overlapping).
    pub pw_scale: Option<f64>,
}

impl Contact {
    /// True when the bodies overlap (gap < 0).
    pub fn overlap(&self) -> bool {
        self.gap < 0.0
    }
    /// The same contact seen from b: points exchanged, normal reversed.
    pub fn swapped(&self) -> Contact {
        Contact {
            point_a: self.point_b,
            point_b: self.point_a,
            normal: -self.normal,
            gap: self.gap,
            method: self.method,
            pw_scale: self.pw_scale,
        }
    }
}

/// Why a query failed.
#[derive(Debug, Clone, PartialEq)]
pub enum ContactError {
    /// A shape parameter or pose breaks a rule (the message names value and rule).
    Invalid(String),
    /// The iterative solver did not produce a certified answer (message says why).
    NotConverged(String),
    /// The pair of shapes has no query.
    Unsupported(String),
}

impl std::fmt::Display for ContactError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ContactError::Invalid(m) => write!(f, "{m}"),
            ContactError::NotConverged(m) => write!(f, "contact solver did not converge: {m}"),
            ContactError::Unsupported(m) => write!(f, "unsupported contact pair: {m}"),
        }
    }
}

impl std::error::Error for ContactError {}

impl From<ContactError> for crate::Error {
    fn from(e: ContactError) -> Self {
        crate::Error::InvalidInput(e.to_string())
    }
}

pub type ContactResult<T> = std::result::Result<T, ContactError>;

/// Position and orientation of a body (body frame -> world: x_world = position + R x_body).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    pub position: Vector3<f64>,
    pub orientation: UnitQuaternion<f64>,
}

impl Pose {
    pub fn new(position: Vector3<f64>, orientation: UnitQuaternion<f64>) -> Self {
        Pose {
            position,
            orientation,
        }
    }
    pub fn at(position: Vector3<f64>) -> Self {
        Pose::new(position, UnitQuaternion::identity())
    }
    pub fn rotation(&self) -> Matrix3<f64> {
        *self.orientation.to_rotation_matrix().matrix()
    }
    /// Body z axis in world coordinates.
    pub fn axis_z(&self) -> Vector3<f64> {
        self.orientation * Vector3::z()
    }
    pub fn to_world(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.position + self.orientation * p
    }
    pub fn to_local(&self, p: &Vector3<f64>) -> Vector3<f64> {
        self.orientation
            .inverse_transform_vector(&(p - self.position))
    }
}

/// A convex shape given by its plain parameters (body frame: centre at the origin, principal
/// axes along x, y, z; the spherocylinder axis is z).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ContactShape {
    Sphere {
        radius: f64,
    },
    /// Radius and length between the hemisphere centres.
    Spherocylinder {
        radius: f64,
        length: f64,
    },
    Ellipsoid {
        semi_axes: [f64; 3],
    },
    /// Thesis eq. 4.3: sum |x_k / a_k|^g_k = 1, exponents >= 2.
    Superquadric {
        semi_axes: [f64; 3],
        exponents: [f64; 3],
    },
}

/// |v| without the overflow or underflow of the squares: the plain norm (bit for bit) when it
/// is finite and not a spurious 0, else the norm of v scaled by its largest component (pairs
/// 1e160 apart still get a finite gap, normal and points).
pub fn norm_no_overflow(v: &Vector3<f64>) -> f64 {
    let n = v.norm();
    if n.is_finite() && (n > 0.0 || *v == Vector3::zeros()) {
        return n;
    }
    let m = v.amax();
    if !(m.is_finite() && m > 0.0) {
        return n;
    }
    m * (v / m).norm()
}

fn positive(v: f64, what: &str) -> ContactResult<()> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(ContactError::Invalid(format!(
            "{what} = {v}: must be positive and finite"
        )))
    }
}

impl ContactShape {
    /// Checks the parameters (lengths positive and finite; exponents >= 2 and finite).
    pub fn validate(&self) -> ContactResult<()> {
        match *self {
            ContactShape::Sphere { radius } => positive(radius, "radius"),
            ContactShape::Spherocylinder { radius, length } => {
                positive(radius, "radius")?;
                // L = 0 is a sphere, as in `shape::Spherocylinder` (the segment is a point).
                if length.is_finite() && length >= 0.0 {
                    Ok(())
                } else {
                    Err(ContactError::Invalid(format!(
                        "length = {length}: must be finite and >= 0 (0 is a sphere)"
                    )))
                }
            }
            ContactShape::Ellipsoid { semi_axes } => {
                for (k, a) in semi_axes.iter().enumerate() {
                    positive(*a, &format!("semi_axes[{k}]"))?;
                }
                Ok(())
            }
            ContactShape::Superquadric {
                semi_axes,
                exponents,
            } => {
                for (k, a) in semi_axes.iter().enumerate() {
                    positive(*a, &format!("semi_axes[{k}]"))?;
                }
                for (k, g) in exponents.iter().enumerate() {
                    if !(g.is_finite() && *g >= 2.0) {
                        return Err(ContactError::Invalid(format!(
                            "exponents[{k}] = {g}: must be finite and >= 2 (convex superquadric)"
                        )));
                    }
                }
                Ok(())
            }
        }
    }
    pub fn name(&self) -> &'static str {
        match self {
            ContactShape::Sphere { .. } => "sphere",
            ContactShape::Spherocylinder { .. } => "spherocylinder",
            ContactShape::Ellipsoid { .. } => "ellipsoid",
            ContactShape::Superquadric { .. } => "superquadric",
        }
    }
    /// The shape as a superquadric (sphere and ellipsoid: exponents 2), if it is one.
    pub fn as_superquadric(&self) -> Option<SqShape> {
        match *self {
            ContactShape::Sphere { radius } => Some(SqShape::new([radius; 3], [2.0; 3])),
            ContactShape::Ellipsoid { semi_axes } => Some(SqShape::new(semi_axes, [2.0; 3])),
            ContactShape::Superquadric {
                semi_axes,
                exponents,
            } => Some(SqShape::new(semi_axes, exponents)),
            ContactShape::Spherocylinder { .. } => None,
        }
    }
}

/// Contact between any two supported shapes (dispatch to the pair queries; a pair given in the
/// other order is computed swapped and swapped back, so the normal always points from a to b).
///
/// Ellipsoid pairs carry `pw_scale`; their overlap flag (sign of `gap`) comes from the
/// certified Newton-Raphson and is checked against Perram-Wertheim (validation 303/304).
pub fn contact(a: &ContactShape, pa: &Pose, b: &ContactShape, pb: &Pose) -> ContactResult<Contact> {
    use ContactShape::*;
    a.validate()?;
    b.validate()?;
    match (*a, *b) {
        (Sphere { radius: ra }, Sphere { radius: rb }) => {
            Ok(contact_sphere_sphere(&pa.position, ra, &pb.position, rb))
        }
        (Sphere { radius }, Spherocylinder { radius: rb, length }) => Ok(
            contact_sphere_spherocylinder(&pa.position, radius, pb, rb, length),
        ),
        (Spherocylinder { .. }, Sphere { .. }) => Ok(contact(b, pb, a, pa)?.swapped()),
        (
            Spherocylinder {
                radius: ra,
                length: la,
            },
            Spherocylinder {
                radius: rb,
                length: lb,
            },
        ) => Ok(contact_spherocylinder_spherocylinder(
            pa, ra, la, pb, rb, lb,
        )),
        (Sphere { radius }, Ellipsoid { semi_axes }) => Ok(contact_sphere_ellipsoid(
            &pa.position,
            radius,
            pb,
            semi_axes,
        )),
        (Ellipsoid { .. }, Sphere { .. }) => Ok(contact(b, pb, a, pa)?.swapped()),
        (Ellipsoid { semi_axes: sa }, Ellipsoid { semi_axes: sb }) => {
            contact_ellipsoid_ellipsoid(pa, sa, pb, sb)
        }
        (Spherocylinder { .. }, _) | (_, Spherocylinder { .. }) => {
            Err(ContactError::Unsupported(format!(
                "{} with {} (spherocylinders pair only with spheres and spherocylinders)",
                a.name(),
                b.name()
            )))
        }
        _ => {
            let sa = SqBody::new(a.as_superquadric().unwrap(), *pa);
            let sb = SqBody::new(b.as_superquadric().unwrap(), *pb);
            contact_superquadric_superquadric(&sa, &sb, &NrOptions::default())
        }
    }
}

/// [`contact`] retried from perturbed poses when the solver does not converge (nearly
/// parallel flat faces of superquadrics with large exponents make the common-normal problem
/// ill-conditioned): b is rotated about its centre by `angle` radians about each body axis
/// in turn and the query repeated; the first certified result is returned with method
/// "perturbed-pose". The rotation moves b's surface by at most bounding radius x
/// `angle`, so the gap changes by no more (callers choose `angle` well below their contact
/// tolerance). When every retry fails the original error is returned, with the retries named.
pub fn contact_perturbed(
    a: &ContactShape,
    pa: &Pose,
    b: &ContactShape,
    pb: &Pose,
    angle: f64,
) -> ContactResult<Contact> {
    retry_perturbed(pb, angle, |q| contact(a, pa, b, q))
}

/// [`contact_perturbed`] for two superquadrics given with their precomputed [`SqShape`]s (the
/// MCM's per-species shapes): the same query, retries and result as [`contact_perturbed`] on
/// the corresponding [`ContactShape`]s when either is a [`ContactShape::Superquadric`]
/// (which [`contact`] sends to the same solver), without validating the parameters and
/// recomputing both bounding radii on every call (that took 64% of the run time of 50
/// superballs, perf). Shapes are assumed valid (`ContactShape::validate`).
pub fn contact_superquadric_perturbed(
    a: &SqShape,
    pa: &Pose,
    b: &SqShape,
    pb: &Pose,
    angle: f64,
) -> ContactResult<Contact> {
    let body_a = SqBody::new(a.clone(), *pa);
    retry_perturbed(pb, angle, |q| {
        let body_b = SqBody::new(b.clone(), *q);
        contact_superquadric_superquadric(&body_a, &body_b, &NrOptions::default())
    })
}

/// Runs `query` at b's pose and, when it does not converge, at b rotated by `angle` about each
/// body axis in turn (see [`contact_perturbed`]).
fn retry_perturbed(
    pb: &Pose,
    angle: f64,
    query: impl Fn(&Pose) -> ContactResult<Contact>,
) -> ContactResult<Contact> {
    match query(pb) {
        Err(ContactError::NotConverged(first)) => {
            for axis in [Vector3::x_axis(), Vector3::y_axis(), Vector3::z_axis()] {
                let rot = UnitQuaternion::from_axis_angle(&axis, angle);
                let q = Pose::new(pb.position, pb.orientation * rot);
                if let Ok(mut c) = query(&q) {
                    c.method = "perturbed-pose";
                    return Ok(c);
                }
            }
            Err(ContactError::NotConverged(format!(
                "{first}; also after rotating b by {angle:e} rad about each body axis"
            )))
        }
        other => other,
    }
}
