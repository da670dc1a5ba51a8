//! The random displacement of one particle (seed 000 appendix A, eq. A12-A16).
//!
//! A move draws zeta in [0, 1] and six xi in [-1, 1]; the kinetic-energy budget
//! K_j = zeta K_max (eq. A13) is split between the three translations and the three rotations
//! about the body axes in proportion to |xi_i| (eq. A16), so that
//!   dx^2 + dy^2 + dz^2 + (I_a/v) da^2 + (I_b/v) db^2 + (I_c/v) dg^2 = zeta K_max   (eq. A14)
//! holds for every move. The rotations are applied about the body axes and composed with the
//! current orientation (q' = q exp(dtheta / 2)); angles are never added as Euler angles.
//! For spheres all six numbers are still drawn (the budget is split six ways, as in eq. A16),
//! but the rotation is not applied: it changes nothing.

use nalgebra::{UnitQuaternion, Vector3};
use rand::Rng;

/// One trial displacement: translation (m) and rotation angles about the body axes (rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    pub translation_m: [f64; 3],
    pub rotation_rad: [f64; 3],
    /// The budget zeta K_max of this move, m^2.
    pub budget_m2: f64,
}

impl Move {
    /// The left side of eq. A14 for a particle with these I/v ratios (m^2).
    pub fn kinetic_measure(&self, inertia_per_volume_m2: &[f64; 3]) -> f64 {
        let t = &self.translation_m;
        let r = &self.rotation_rad;
        t[0] * t[0]
            + t[1] * t[1]
            + t[2] * t[2]
            + inertia_per_volume_m2[0] * r[0] * r[0]
            + inertia_per_volume_m2[1] * r[1] * r[1]
            + inertia_per_volume_m2[2] * r[2] * r[2]
    }

    /// The orientation after the move: the body-axis rotation composed on the right.
    pub fn rotate(&self, q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
        let d = UnitQuaternion::from_scaled_axis(Vector3::from(self.rotation_rad));
        UnitQuaternion::new_normalize((q * d).into_inner())
    }
}

/// Draws one move (eq. A13, A16) for a particle with the given I/v ratios (m^2) under the
/// budget `k_max_m2` (m^2). Seven uniform numbers are drawn from `rng`, always in the same
/// order (zeta, then xi_x, xi_y, xi_z, xi_a, xi_b, xi_g).
pub fn draw<R: Rng>(rng: &mut R, k_max_m2: f64, inertia_per_volume_m2: &[f64; 3]) -> Move {
    let zeta: f64 = rng.gen::<f64>();
    let mut xi = [0.0f64; 6];
    for x in xi.iter_mut() {
        *x = rng.gen::<f64>() * 2.0 - 1.0;
    }
    let sum: f64 = xi.iter().map(|x| x.abs()).sum();
    let budget = zeta * k_max_m2;
    if sum == 0.0 {
        // Probability zero in exact arithmetic; with f64 uniforms it needs six exact zeros.
        return Move {
            translation_m: [0.0; 3],
            rotation_rad: [0.0; 3],
            budget_m2: 0.0,
        };
    }
    let share = |x: f64, scale2: f64| (x.abs() / sum * budget * scale2).sqrt().copysign(x);
    Move {
        translation_m: [share(xi[0], 1.0), share(xi[1], 1.0), share(xi[2], 1.0)],
        rotation_rad: [
            share(xi[3], 1.0 / inertia_per_volume_m2[0]),
            share(xi[4], 1.0 / inertia_per_volume_m2[1]),
            share(xi[5], 1.0 / inertia_per_volume_m2[2]),
        ],
        budget_m2: budget,
    }
}

/// The same move with its translation turned to a direction drawn uniformly on the sphere,
/// its length (eq. A16's) kept: not the seed's rule, a probe of eq. A16's direction bias.
/// The direction is drawn from `rng` after the move (three uniforms per try, rejection from
/// the cube).
pub fn isotropic<R: Rng>(rng: &mut R, m: Move) -> Move {
    let t = Vector3::from(m.translation_m);
    let dir = loop {
        let v = Vector3::from_fn(|_, _| rng.gen::<f64>() * 2.0 - 1.0);
        let n2 = v.norm_squared();
        if (1e-6..=1.0).contains(&n2) {
            break v / n2.sqrt();
        }
    };
    Move {
        translation_m: (dir * t.norm()).into(),
        ..m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    #[test]
    fn eq_a14_holds_for_every_move() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let ipv = [0.2e-12, 0.5e-12, 0.3e-12];
        for _ in 0..10_000 {
            let m = draw(&mut rng, 1e-14, &ipv);
            let k = m.kinetic_measure(&ipv);
            assert!((k - m.budget_m2).abs() <= 1e-14 * m.budget_m2.max(1e-300) + 1e-300);
            assert!(m.budget_m2 <= 1e-14);
        }
    }

    /// Isotropic directions keep eq. A16's lengths (so eq. A14), and a component is small
    /// against the others as often as isotropy says: |dz| / |t| below 0.01 in 1 % of the draws
    /// (uniform cos theta), where eq. A16's directions give it far more rarely.
    #[test]
    fn isotropic_directions_keep_lengths_and_are_uniform() {
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let ipv = [0.1e-12; 3];
        let n = 200_000;
        let (mut near_plane_iso, mut near_plane_seed) = (0u32, 0u32);
        for _ in 0..n {
            let m = draw(&mut rng, 1e-14, &ipv);
            let iso = isotropic(&mut rng, m);
            let (t, ti) = (
                Vector3::from(m.translation_m),
                Vector3::from(iso.translation_m),
            );
            assert!((t.norm() - ti.norm()).abs() <= 1e-12 * t.norm());
            assert!((iso.kinetic_measure(&ipv) - m.budget_m2).abs() <= 1e-13 * m.budget_m2);
            near_plane_iso += u32::from(ti.z.abs() < 0.01 * ti.norm());
            near_plane_seed += u32::from(t.z.abs() < 0.01 * t.norm());
        }
        // binomial(200000, 0.01): 2000 +- 45; 5 standard deviations
        assert!(
            (near_plane_iso as f64 - 2000.0).abs() < 225.0,
            "{near_plane_iso}"
        );
        assert!(10 * near_plane_seed < near_plane_iso, "{near_plane_seed}");
    }

    #[test]
    fn composed_rotation_stays_unit() {
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let ipv = [1e-14; 3];
        let mut q = UnitQuaternion::identity();
        for _ in 0..100_000 {
            q = draw(&mut rng, 1e-14, &ipv).rotate(&q);
        }
        assert!((q.into_inner().norm() - 1.0).abs() < 1e-14);
    }
}
