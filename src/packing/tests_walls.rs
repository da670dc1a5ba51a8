//! Ellipsoids and superquadrics behind hard walls (cylinder, wedge): the support-function wall
//! depth of `Container::convex_wall_contacts` against the sphere path's virtual particles and
//! against brute-force surface samples made here from the superquadric's closed form (not by
//! the code under test), small packings checked independently, and bodies far outside.

use super::*;
use crate::analysis;
use crate::contact::pairgen::random_rotation as random_orientation;
use crate::contact::ContactShape as C;
use rand::{Rng, SeedableRng};

/// One particle of shape `s` in container `c` (period 10 along z).
fn one(c: Container, s: C, x: Vector3<f64>, q: UnitQuaternion<f64>) -> Packing {
    Packing {
        container: c,
        box_length: 10.0,
        particles: ParticleShapes::mixture(&[(s, 1)]),
        positions: vec![x],
        orientations: vec![q],
    }
}

/// All wall overlaps (tolerance 0) of the single particle of `p`.
fn wall_overlaps(p: &Packing) -> Vec<Overlap> {
    let props = species::props_of(&p.particles).unwrap();
    let mut ov = Vec::new();
    overlaps_of(p, &props, 0, &[], 0.0, &mut ov).unwrap();
    ov
}

/// Dense surface samples of the superquadric sum_k |y_k / a_k|^g = 1 (one exponent g):
/// each face of the cube [-1, 1]^3 gets an n x n grid, and a grid point w is mapped radially
/// onto the surface, y = w / (sum_k |w_k / a_k|^g)^(1/g) (the closed form, not the shape or
/// contact modules). Returns the samples and delta, the longest image of a grid cell's
/// diagonal: every surface point lies within delta of a sample (the cells are small and the
/// map smooth, so a cell's image is nearly a parallelogram).
fn cube_samples(a: [f64; 3], g: f64, n: usize) -> (Vec<Vector3<f64>>, f64) {
    let map = |w: Vector3<f64>| {
        let s: f64 = (0..3).map(|k| (w[k] / a[k]).abs().powf(g)).sum();
        w / s.powf(1.0 / g)
    };
    let mut pts = Vec::with_capacity(6 * (n + 1) * (n + 1));
    let mut delta: f64 = 0.0;
    let t = |i: usize| -1.0 + 2.0 * i as f64 / n as f64;
    for axis in 0..3 {
        for side in [-1.0, 1.0] {
            let at = |i: usize, j: usize| {
                let mut w = Vector3::zeros();
                w[axis] = side;
                w[(axis + 1) % 3] = t(i);
                w[(axis + 2) % 3] = t(j);
                map(w)
            };
            let mut prev: Vec<Vector3<f64>> = (0..=n).map(|j| at(0, j)).collect();
            pts.extend(prev.iter().copied());
            for i in 1..=n {
                let row: Vec<Vector3<f64>> = (0..=n).map(|j| at(i, j)).collect();
                for j in 0..n {
                    delta = delta
                        .max((row[j + 1] - prev[j]).norm())
                        .max((row[j] - prev[j + 1]).norm());
                }
                pts.extend(row.iter().copied());
                prev = row;
            }
        }
    }
    (pts, delta)
}

/// Upper bound of the principal curvatures of sum_k |y_k / a_k|^g = 1 (g >= 2): a normal
/// curvature is t.H t / |grad F| <= max_k H_kk / |grad F| with H_kk = g (g - 1) u_k^(g-2) / a_k^2
/// <= g (g - 1) / a_min^2 (u_k = |y_k| / a_k <= 1), and |grad F| >= (g / a_max) max_k u_k^(g-1)
/// >= (g / a_max) 3^(-(g-1)/g) (sum u_k^g = 1, so max u_k >= 3^(-1/g)).
fn curvature_bound(a: [f64; 3], g: f64) -> f64 {
    let amax = a.iter().cloned().fold(0.0, f64::max);
    let amin = a.iter().cloned().fold(f64::INFINITY, f64::min);
    (g - 1.0) * amax * 3f64.powf((g - 1.0) / g) / (amin * amin)
}

/// (1) A sphere given as a superquadric of exponent 2 sees exactly the walls the sphere path's
/// virtual particles give it: same depth, normal and contact point, in the cylinder and at the
/// three planes and two corners of the wedge, for penetrations up to 1.4 R (beyond 1.5 R the
/// sphere path caps its virtual particle on purpose, see `Container::wall_virtuals`).
#[test]
fn sphere_as_superquadric_matches_the_sphere_wall_path() {
    let r = 0.5;
    let sq = C::Superquadric {
        semi_axes: [r; 3],
        exponents: [2.0; 3],
    };
    let sphere = C::Sphere { radius: r };
    let alpha = 30f64.to_radians();
    let (sin, cos) = alpha.sin_cos();
    let cyl = Container::Cylinder { diameter: 4.0 };
    let wedge = Container::Wedge {
        length: 6.0,
        angle_rad: alpha,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let mut cases = Vec::new();
    for k in 0..24 {
        let phi = 0.37 + k as f64 * 0.71;
        // Penetration R + rho - R_cyl in [-0.2, 0.7] (the sphere path caps beyond 0.75).
        let pen = -0.2 + 0.9 * (k as f64 / 23.0);
        let rho = 2.0 - r + pen;
        cases.push((
            cyl,
            Vector3::new(rho * phi.cos(), rho * phi.sin(), 3.0 + 0.1 * k as f64),
        ));
    }
    let slope_foot = |x: f64| Vector3::new(x, x * alpha.tan(), 1.0);
    for &d in &[0.45, 0.3, 0.0, -0.2] {
        cases.push((wedge, Vector3::new(6.0 - d, 1.0, 2.0))); // back
        cases.push((wedge, Vector3::new(4.0, d, 2.0))); // bottom
        cases.push((wedge, slope_foot(4.0) + d * Vector3::new(sin, -cos, 0.0))); // slope
        cases.push((wedge, Vector3::new(6.0 - d, 0.2, 2.0))); // back-bottom corner
    }
    cases.push((wedge, Vector3::new(1.5, 0.3, 2.0))); // acute edge: bottom + slope
    let mut worst: f64 = 0.0;
    let mut count = 0;
    for (c, x) in cases {
        let q = random_orientation(&mut rng);
        let a = wall_overlaps(&one(c, sphere, x, q));
        let b = wall_overlaps(&one(c, sq, x, q));
        assert_eq!(a.len(), b.len(), "{c:?} at {x:?}: {a:?} vs {b:?}");
        for (oa, ob) in a.iter().zip(&b) {
            let e = (oa.depth - ob.depth)
                .abs()
                .max((oa.normal - ob.normal).norm())
                .max((oa.rc - ob.rc).norm());
            assert!(e < 1e-12, "{c:?} at {x:?}: {oa:?} vs {ob:?}");
            worst = worst.max(e);
            count += 1;
        }
    }
    assert!(count >= 40, "only {count} contacts compared");
    eprintln!("sphere as superquadric: {count} wall contacts, largest difference {worst:.2e}");
}

/// (2) Ellipsoid, superball and superellipsoid in random orientations at known distances from
/// each wedge plane and from the cylinder wall: the depth is the brute-force maximum over
/// dense closed-form surface samples ([`cube_samples`]) of the penetration, within the
/// sampling error derived here. The samples' maximum is a lower bound; the deepest point x*
/// lies within delta of a sample y, and the body contains the ball of radius 1/kappa tangent
/// at x* (Blaschke's rolling theorem, kappa = [`curvature_bound`]), so the penetration at y
/// falls short of the one at x* by at most kappa delta^2 / 2 (for the cylinder too: rho(y) >=
/// u*.y with u* the unit normal of the wall at x*). Contact point: on the surface, at the
/// reported depth.
#[test]
fn wall_depth_matches_dense_surface_samples() {
    let alpha = 25f64.to_radians();
    let (sin, cos) = alpha.sin_cos();
    let lw = 7.0;
    let wedge = Container::Wedge {
        length: lw,
        angle_rad: alpha,
    };
    let rcyl = 2.5;
    let cyl = Container::Cylinder {
        diameter: 2.0 * rcyl,
    };
    let shapes = [
        ([0.7, 0.4, 0.25], 2.0),
        ([0.5; 3], 3.0),
        ([0.6, 0.45, 0.3], 4.0),
    ];
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut report = Vec::new();
    for (a, g) in shapes {
        let shape = C::Superquadric {
            semi_axes: a,
            exponents: [g; 3],
        };
        let (pts, delta) = cube_samples(a, g, 700);
        let eps = 0.5 * curvature_bound(a, g) * delta * delta;
        let (mut worst, mut normal_err): (f64, f64) = (0.0, 0.0);
        let mut contacts = 0;
        for trial in 0..6 {
            let q = random_orientation(&mut rng);
            let rot = q.to_rotation_matrix();
            let d_c = 0.05 + 0.03 * trial as f64; // centre distance from the wall, inside
                                                  // Plane walls: outward normal m, centre at distance d_c inside.
            let planes = [
                (Vector3::x(), Vector3::new(lw - d_c, 1.2, 4.0)),
                (-Vector3::y(), Vector3::new(5.0, d_c, 4.0)),
                (
                    Vector3::new(-sin, cos, 0.0),
                    Vector3::new(5.0, 5.0 * alpha.tan(), 4.0) - d_c * Vector3::new(-sin, cos, 0.0),
                ),
            ];
            for (m, x) in planes {
                let ov = wall_overlaps(&one(wedge, shape, x, q));
                let mb = rot.transpose() * m;
                let brute = pts.iter().map(|y| mb.dot(y)).fold(f64::MIN, f64::max) - d_c;
                if ov.is_empty() {
                    // No contact: no sample beyond the plane either.
                    assert!(brute <= 1e-12, "{a:?} g = {g}: missed {brute}");
                    continue;
                }
                assert_eq!(ov.len(), 1, "{a:?} g = {g}: {ov:?}");
                contacts += 1;
                let o = ov[0];
                let err = o.depth - brute;
                assert!(
                    err >= -1e-12 && err <= eps + 1e-12,
                    "{a:?} g = {g}: depth {} brute {brute} (bound {eps:e})",
                    o.depth
                );
                worst = worst.max(err.abs());
                assert!((o.normal - m).norm() < 1e-15);
                let yb = rot.transpose() * o.rc;
                let f: f64 = (0..3).map(|k| (yb[k] / a[k]).abs().powf(g)).sum();
                assert!(
                    (f - 1.0).abs() < 1e-12,
                    "contact point off the surface: F = {f}"
                );
                assert!((m.dot(&o.rc) - d_c - o.depth).abs() < 1e-14);
            }
            // Cylinder: centre at distance d_c + 0.1 from the wall, random azimuth.
            let phi = rng.gen::<f64>() * std::f64::consts::TAU;
            let rho = rcyl - d_c - 0.1;
            let x = Vector3::new(rho * phi.cos(), rho * phi.sin(), 4.0);
            let ov = wall_overlaps(&one(cyl, shape, x, q));
            let brute = pts
                .iter()
                .map(|y| (x + rot * y).xy().norm())
                .fold(f64::MIN, f64::max)
                - rcyl;
            if ov.is_empty() {
                assert!(brute <= 1e-12, "{a:?} g = {g} cylinder: missed {brute}");
            } else {
                contacts += 1;
                let deepest = ov.iter().map(|o| o.depth).fold(0.0, f64::max);
                let err = deepest - brute;
                assert!(
                    err >= -1e-12 && err <= eps + 1e-12,
                    "{a:?} g = {g} cylinder: depth {deepest} brute {brute} (bound {eps:e})"
                );
                worst = worst.max(err.abs());
                for o in &ov {
                    let s = x + o.rc;
                    assert!((s.xy().norm() - rcyl - o.depth).abs() < 1e-12);
                    let e = (s.xy().normalize() - o.normal.xy()).norm();
                    normal_err = normal_err.max(e);
                    assert!(e < 1e-9, "normal off by {e:e}");
                }
            }
        }
        report.push(format!(
            "a = {a:?} g = {g}: largest |depth - brute| {worst:.2e}, bound {eps:.2e} \
             (delta {delta:.2e}, {} samples, {contacts} contacts); cylinder normal vs P s direction {normal_err:.1e}",
            pts.len()
        ));
        assert!(contacts >= 18, "only {contacts} contacts");
    }
    eprintln!("{}", report.join("\n"));
}

/// Independent wall check of a configuration: the deepest closed-form surface sample
/// ([`cube_samples`]) beyond the cylinder or wedge walls (superballs of half-width `a`,
/// exponent `g`).
fn sampled_wall_penetration(p: &Packing, a: f64, g: f64) -> f64 {
    let (pts, _) = cube_samples([a; 3], g, 150);
    let mut worst = f64::NEG_INFINITY;
    for (x, q) in p.positions.iter().zip(&p.orientations) {
        let rot = q.to_rotation_matrix();
        for y in &pts {
            let s = x + rot * y;
            let pen = match p.container {
                Container::Cylinder { diameter } => s.xy().norm() - 0.5 * diameter,
                Container::Wedge { length, angle_rad } => {
                    let (sin, cos) = angle_rad.sin_cos();
                    (s.x - length).max(-s.y).max(s.y * cos - s.x * sin)
                }
                Container::Periodic => f64::NEG_INFINITY,
            };
            worst = worst.max(pen);
        }
    }
    worst
}

/// (3) 40 superballs (gamma 3) packed in a cylinder and in a wedge, with the revised scheme
/// (and in the wedge a final relaxation stage, whose forces and torques use the same wall
/// contacts): every particle inside the walls by closed-form surface samples, overlap-free by
/// the sampled pair check (z images), deterministic, and compressed well beyond the start
/// (measured: cylinder phi 0.392 in 2-3 s, wedge 0.443 in 6-8 s).
#[test]
fn superballs_pack_inside_cylinder_and_wedge() {
    let (a, g) = (0.5, 3.0);
    let sb = C::Superquadric {
        semi_axes: [a; 3],
        exponents: [g; 3],
    };
    let n = 40;
    let relax = Stage {
        scheme: Scheme::Relax,
        delta_v_per_particle: 0.01,
        halvings: 0,
        tries_per_particle: 200.0,
        stage_budget_per_particle: None,
        beta: 0.5,
        dt: 0.1,
    };
    let wedge = Container::Wedge {
        length: 5.0,
        angle_rad: 30f64.to_radians(),
    };
    let cyl = Container::Cylinder { diameter: 4.0 };
    for (c, last) in [(cyl, None), (wedge, Some(relax))] {
        let mut prm = Setup::new(n, 0.0, 3);
        prm.scheme = Scheme::Revised;
        prm.delta_v_per_particle = 0.05;
        prm.halvings = 1;
        prm.tries_per_particle = 50.0;
        prm.dt = 0.5;
        prm.particles = Some(ParticleShapes::mixture(&[(sb, n)]));
        prm.container = c;
        prm.final_stage = last;
        let t = std::time::Instant::now();
        let r = run_to_end(prm.clone()).unwrap();
        let secs = t.elapsed().as_secs_f64();
        let p = &r.packing;
        let wall = sampled_wall_penetration(p, a, g);
        assert!(
            wall <= prm.overlap_tol,
            "{c:?}: sample {wall:e} beyond the wall"
        );
        let (deepest, _) = super::tests::assert_sampled_overlap_free(p, prm.overlap_tol);
        let phi = p.packing_fraction();
        eprintln!(
            "{n} superballs g = 3 in {c:?}: phi {phi:.4}, deepest wall sample {wall:.2e}, \
             deepest sampled pair overlap {deepest:.2e}, {} steps, {} tries, {secs:.1} s",
            r.history.len(),
            r.total_tries
        );
        assert!(phi > 0.35, "{c:?}: phi = {phi}");
        if last.is_none() {
            let again = run_to_end(prm.clone()).unwrap();
            assert_eq!(again.packing.positions, p.positions);
        }
    }
}

/// (4) A superball far outside a wall (1.5 D beyond the cylinder, 1.2 D beyond the wedge's
/// slope, and beyond its acute edge) has a wall overlap at least as deep as its centre's
/// distance outside, pushing it inward; a start with it is refused; both the revised scheme
/// and the relaxation bring it back inside.
#[test]
fn superball_far_outside_a_wall_is_pushed_back() {
    let sb = C::Superquadric {
        semi_axes: [0.5; 3],
        exponents: [3.0; 3],
    };
    let alpha = 30f64.to_radians();
    let (sin, cos) = alpha.sin_cos();
    let wedge = Container::Wedge {
        length: 6.0,
        angle_rad: alpha,
    };
    let slope_out = Vector3::new(-sin, cos, 0.0);
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    for (c, x, outside) in [
        (
            Container::Cylinder { diameter: 4.0 },
            Vector3::new(2.0 + 1.5, 0.4, 5.0),
            1.5,
        ),
        (
            wedge,
            Vector3::new(4.0, 4.0 * alpha.tan(), 5.0) + 1.2 * slope_out,
            1.2,
        ),
        (wedge, Vector3::new(-0.8, 0.1, 5.0), 0.8 * sin - 0.1 * cos),
    ] {
        let q = random_orientation(&mut rng);
        let p0 = one(c, sb, x, q);
        let ov = wall_overlaps(&p0);
        assert!(!ov.is_empty(), "{c:?} at {x:?}: no wall overlap");
        let deepest = ov.iter().map(|o| o.depth).fold(0.0, f64::max);
        assert!(deepest > outside, "{c:?}: depth {deepest} <= {outside}");
        // Every push (along -normal) moves the centre inward.
        let inward = |y: &Vector3<f64>| match c {
            Container::Cylinder { .. } => -Vector3::new(y.x, y.y, 0.0).normalize(),
            _ => Vector3::new(3.0, 1.0, y.z) - y,
        };
        for o in &ov {
            assert!((-o.normal).dot(&inward(&x)) > 0.0, "{c:?}: {o:?}");
        }
        // Never accepted outside: a start with the escaped particle (and one inside) is refused.
        let mut prm = Setup::new(2, 0.0, 1);
        prm.particles = Some(ParticleShapes::mixture(&[(sb, 2)]));
        prm.container = c;
        let mut two = p0.clone();
        two.particles = ParticleShapes::mixture(&[(sb, 2)]);
        two.positions.push(match c {
            Container::Cylinder { .. } => Vector3::new(0.3, 0.2, 1.0),
            _ => Vector3::new(3.3, 1.2, 1.0),
        });
        two.orientations.push(q);
        let e = Mcm::from_start(prm.clone(), two).unwrap_err().to_string();
        assert!(e.contains("overlaps"), "{e}");
        for scheme in [Scheme::Revised, Scheme::Relax] {
            prm.scheme = scheme;
            let mut p = p0.clone();
            let props = species::props_of(&p.particles).unwrap();
            let r = remove_overlaps_with(&mut p, &props, &prm, 100_000).unwrap();
            assert!(r.is_ok(), "{c:?} {scheme:?}: {r:?}");
            let pen = analysis::wall_penetration(&p.view())
                .unwrap()
                .map_or(0.0, |w| w.1);
            assert!(pen <= prm.overlap_tol, "{c:?} {scheme:?}: {pen:e}");
            assert!(sampled_wall_penetration(&p, 0.5, 3.0) <= prm.overlap_tol);
        }
    }
}

/// Walls with superquadrics still refuse what they cannot do: the original scheme, and a
/// container too small for the particles' bounding sphere (the random start places it inside).
#[test]
fn superquadrics_in_walls_refuse_unsupported_setups() {
    let sb = C::Superquadric {
        semi_axes: [0.5; 3],
        exponents: [3.0; 3],
    };
    let mut prm = Setup::new(10, 0.0, 1);
    prm.particles = Some(ParticleShapes::mixture(&[(sb, 10)]));
    prm.container = Container::Cylinder { diameter: 4.0 };
    prm.scheme = Scheme::Original;
    assert!(prm.validate().unwrap_err().to_string().contains("revised"));
    prm.scheme = Scheme::Revised;
    prm.validate().unwrap();
    // Bounding diameter 3^(1/6) = 1.20 > 1.15.
    prm.container = Container::Cylinder { diameter: 1.15 };
    let e = run_to_end(prm.clone()).unwrap_err().to_string();
    assert!(e.contains("cylinder diameter 1.15"), "{e}");
}

/// A long ellipsoid lying across the cylinder pokes through the wall on both sides: two
/// contacts, at the ends of its long axis, with the closed-form depths a_1 +- x_c - R_cyl and
/// opposite normals (the azimuths then span the whole circle).
#[test]
fn ellipsoid_across_the_cylinder_touches_both_sides() {
    let e = C::Ellipsoid {
        semi_axes: [1.2, 0.2, 0.3],
    };
    let q = UnitQuaternion::identity();
    let cyl = Container::Cylinder { diameter: 2.2 };
    let mut ov = wall_overlaps(&one(cyl, e, Vector3::new(0.05, 0.0, 5.0), q));
    ov.sort_by(|a, b| b.depth.total_cmp(&a.depth));
    assert_eq!(ov.len(), 2, "{ov:?}");
    for (o, (depth, side)) in ov.iter().zip([(0.15, 1.0f64), (0.05, -1.0)]) {
        assert!((o.depth - depth).abs() < 1e-12, "{o:?}");
        assert!((o.normal - side * Vector3::x()).norm() < 1e-9, "{o:?}");
        assert!((o.rc - side * 1.2 * Vector3::x()).norm() < 1e-6, "{o:?}");
    }
}
