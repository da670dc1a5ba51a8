//! The containers of an MCM packing (thesis sec. 2.2.4): all their geometry lives here, so a
//! new wall type touches only this file (and the cell grid's bounds in `neighbours.rs`).
//!
//! Hard walls act through virtual particles (Fig. 2.4): a particle that penetrates the wall
//! sees an identical particle on the other side of it, touching the wall from outside, and the
//! ordinary pair overlap removal pushes it back.

use crate::error::invalid;
use crate::Result;
use nalgebra::Vector3;

/// The simulation container.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Container {
    /// Periodic cubic box [0, L)^3 (L = `box_length`).
    Periodic,
    /// Hard cylindrical wall of fixed diameter D_cyl about the z axis through x = y = 0,
    /// periodic along z with period L = `box_length` (thesis sec. 2.2.4, Fig. 2.3 left);
    /// compression shortens L, D_cyl stays fixed. Wall overlaps are removed through virtual
    /// particles (Fig. 2.4).
    Cylinder { diameter: f64 },
}

impl Container {
    /// Checks the container's own parameters against the particle diameter `particle_d`.
    pub fn check(&self, particle_d: f64) -> Result<()> {
        if let Container::Cylinder { diameter } = self {
            if !(diameter.is_finite() && *diameter > particle_d) {
                return invalid(format!(
                    "cylinder diameter {diameter}: must be finite and larger than the particle \
                     diameter {particle_d}"
                ));
            }
        }
        Ok(())
    }

    /// Volume of the container of length (or side) `l`.
    pub fn volume(&self, l: f64) -> f64 {
        match self {
            Container::Periodic => l.powi(3),
            Container::Cylinder { diameter } => {
                0.25 * std::f64::consts::PI * diameter * diameter * l
            }
        }
    }

    /// The length (side) `l` at which the container has volume `v` (inverse of [`volume`]).
    ///
    /// [`volume`]: Container::volume
    pub fn length_for_volume(&self, v: f64) -> f64 {
        match self {
            Container::Periodic => v.cbrt(),
            Container::Cylinder { diameter } => {
                v / (0.25 * std::f64::consts::PI * diameter * diameter)
            }
        }
    }

    /// Scales a position from container length `from` to `to` (compression, sec. 2.2.1): all
    /// coordinates in the cubic box, only the periodic axis in the cylinder (its diameter is
    /// fixed).
    pub fn scale_position(&self, x: &Vector3<f64>, from: f64, to: f64) -> Vector3<f64> {
        let s = to / from;
        match self {
            Container::Periodic => self.wrap(&(x * s), to),
            Container::Cylinder { .. } => self.wrap(&Vector3::new(x.x, x.y, x.z * s), to),
        }
    }

    /// A point of the container's bounding box for `u` in [0, 1)^3 (uniform `u`: uniform
    /// point; the caller rejects points outside with [`sphere_inside`]).
    ///
    /// [`sphere_inside`]: Container::sphere_inside
    pub fn point_in_bounding_box(&self, u: &Vector3<f64>, l: f64) -> Vector3<f64> {
        match self {
            Container::Periodic => u * l,
            Container::Cylinder { diameter } => {
                Vector3::new((u.x - 0.5) * diameter, (u.y - 0.5) * diameter, u.z * l)
            }
        }
    }

    /// True when a sphere of radius `r` at `x` does not penetrate any wall.
    pub fn sphere_inside(&self, x: &Vector3<f64>, r: f64) -> bool {
        match self {
            Container::Periodic => true,
            Container::Cylinder { diameter } => {
                (x.x * x.x + x.y * x.y).sqrt() <= 0.5 * diameter - r
            }
        }
    }

    /// The lower corner, extent and periodicity of the region the particle centres occupy
    /// (for the cell grid; centres just outside a wall fall in its edge cells).
    pub fn grid_bounds(&self, l: f64) -> ([f64; 3], [f64; 3], [bool; 3]) {
        match self {
            Container::Periodic => ([0.0; 3], [l; 3], [true; 3]),
            Container::Cylinder { diameter } => {
                let r = 0.5 * diameter;
                (
                    [-r, -r, 0.0],
                    [*diameter, *diameter, l],
                    [false, false, true],
                )
            }
        }
    }

    /// Separation b - a: minimum image along the periodic directions.
    pub fn separation(&self, a: &Vector3<f64>, b: &Vector3<f64>, l: f64) -> Vector3<f64> {
        match self {
            Container::Periodic => (b - a).map(|d| min_image1(d, l)),
            Container::Cylinder { .. } => {
                let mut d = b - a;
                d.z = min_image1(d.z, l);
                d
            }
        }
    }

    /// Wraps a position into the periodic directions.
    pub fn wrap(&self, x: &Vector3<f64>, l: f64) -> Vector3<f64> {
        match self {
            Container::Periodic => x.map(|c| wrap1(c, l)),
            Container::Cylinder { .. } => Vector3::new(x.x, x.y, wrap1(x.z, l)),
        }
    }

    /// Virtual particles for the wall overlaps of a particle at `x` with unit axis `a`, half
    /// cylinder length `h` (0 for a sphere) and radius `r` (thesis sec. 2.2.4, Fig. 2.4): for
    /// each end point p (the centre for a sphere) that penetrates the wall, a particle
    /// identical to it, touching the wall from outside opposite p. Pushes (centre relative to
    /// `x`, unit axis) of each onto `out` (cleared first).
    ///
    /// Cylinder: p penetrates when p_x^2 + p_y^2 > (R_cyl - R)^2; the virtual particle is
    /// aligned with the cylinder axis at the azimuth and height of p.
    pub fn wall_virtuals(
        &self,
        x: &Vector3<f64>,
        a: &Vector3<f64>,
        h: f64,
        r: f64,
        out: &mut Vec<(Vector3<f64>, Vector3<f64>)>,
    ) {
        out.clear();
        let Container::Cylinder { diameter } = *self else {
            return;
        };
        let rcyl = 0.5 * diameter;
        let ends: &[f64] = if h == 0.0 { &[0.0] } else { &[-1.0, 1.0] };
        for &s in ends {
            let e = x + s * h * a;
            let rho = (e.x * e.x + e.y * e.y).sqrt();
            if rho > rcyl - r {
                let u = if rho > 0.0 {
                    Vector3::new(e.x / rho, e.y / rho, 0.0)
                } else {
                    Vector3::x()
                };
                let c = (rcyl + r) * u + Vector3::new(0.0, 0.0, e.z);
                out.push((c - x, Vector3::z()));
            }
        }
    }
}

/// Minimum image of one coordinate difference. Positions are kept wrapped into [0, L), so
/// |d| < L and one shift suffices; larger differences fall back to rounding. (A branch instead
/// of `f64::round`, which is a libm call and took 19% of an MCM run.)
#[inline]
pub fn min_image1(d: f64, l: f64) -> f64 {
    let h = 0.5 * l;
    if d > h {
        if d <= 3.0 * h {
            d - l
        } else {
            d - l * (d / l).round()
        }
    } else if d < -h {
        if d >= -3.0 * h {
            d + l
        } else {
            d - l * (d / l).round()
        }
    } else {
        d
    }
}

/// Wraps a coordinate into [0, L).
fn wrap1(c: f64, l: f64) -> f64 {
    let w = c - l * (c / l).floor();
    if w >= l {
        0.0
    } else {
        w
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_image_matches_rounding() {
        let l = 7.3;
        for k in -400..=400 {
            let d = k as f64 * 0.0571;
            let want = d - l * (d / l).round();
            assert!((min_image1(d, l) - want).abs() < 1e-12, "d = {d}");
        }
    }

    #[test]
    fn length_for_volume_inverts_volume() {
        for c in [Container::Periodic, Container::Cylinder { diameter: 4.0 }] {
            let l = 3.7;
            assert!((c.length_for_volume(c.volume(l)) - l).abs() < 1e-14);
        }
    }
}
