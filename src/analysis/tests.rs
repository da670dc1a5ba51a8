//! Tests of the observables, against closed forms and brute force.

use super::cells::PeriodicCells;
use super::radial_distribution::pair_distance_histogram;
use super::*;
use crate::contact::ContactShape;
use nalgebra::{UnitQuaternion, Vector3};

fn spheres(pos: &[Vector3<f64>]) -> (Vec<Vector3<f64>>, Vec<UnitQuaternion<f64>>) {
    (pos.to_vec(), vec![UnitQuaternion::identity(); pos.len()])
}

/// `n` points uniform in the cube [0, box_length)^3 (ChaCha8 seeded with `seed`).
fn uniform_points(n: usize, box_length: f64, seed: u64) -> Vec<Vector3<f64>> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| Vector3::new(rng.gen(), rng.gen(), rng.gen()) * box_length)
        .collect()
}

/// The species table of equal rods of radius 1/2 (leaked: test data only).
fn mono_shape(length: f64) -> &'static [ContactShape] {
    let shape = if length == 0.0 {
        ContactShape::Sphere { radius: 0.5 }
    } else {
        ContactShape::Spherocylinder {
            radius: 0.5,
            length,
        }
    };
    Vec::leak(vec![shape])
}
fn zeros(n: usize) -> &'static [usize] {
    Vec::leak(vec![0; n])
}

fn sphere_rods<'a>(
    box_length: f64,
    pos: &'a [Vector3<f64>],
    ori: &'a [UnitQuaternion<f64>],
) -> Configuration<'a> {
    Configuration::periodic(box_length, mono_shape(0.0), zeros(pos.len()), pos, ori)
}

/// Volume of the spherical shell [k dr, (k + 1) dr).
fn shell_volume(k: usize, dr: f64) -> f64 {
    let (r0, r1) = (k as f64 * dr, (k + 1) as f64 * dr);
    4.0 / 3.0 * std::f64::consts::PI * (r1.powi(3) - r0.powi(3))
}

/// The m^3 sites of a simple cubic lattice of spacing 1 from the origin.
fn lattice(m: usize) -> Vec<Vector3<f64>> {
    (0..m * m * m)
        .map(|k| Vector3::new((k % m) as f64, ((k / m) % m) as f64, (k / (m * m)) as f64))
        .collect()
}

#[test]
fn simple_cubic_lattice_has_six_contacts_and_pi_over_six() {
    // Unit spheres (diameter 1) on a simple cubic lattice of spacing 1: phi = pi/6, every
    // sphere touches 6 neighbours, some through the periodic boundary.
    let m = 4;
    let p: Vec<_> = lattice(m)
        .into_iter()
        .map(|x| x + Vector3::repeat(0.5))
        .collect();
    let (pos, ori) = spheres(&p);
    let r = Configuration {
        box_length: m as f64,
        wall_diameter: None,
        wedge: None,
        shapes: mono_shape(0.0),
        species: zeros(pos.len()),
        positions: &pos,
        orientations: &ori,
    };
    assert!((packing_fraction(&r).unwrap() - std::f64::consts::PI / 6.0).abs() < 1e-15);
    let g = pair_gaps(&r, 1e-3).unwrap();
    let (c, rattlers) = mean_contacts(r.n(), &g, 1e-6, Some(4));
    assert_eq!(c, 6.0);
    assert_eq!(rattlers, 0);
    check_no_overlap(&r, 1e-12).unwrap();
    let (c0, _) = extrapolated_contacts(r.n(), &g, &[1e-8, 1e-7, 1e-6], None).unwrap();
    assert!((c0 - 6.0).abs() < 1e-12);
}

#[test]
fn overlap_through_the_boundary_is_found() {
    // Two spheres 0.9 apart across the periodic boundary (x = 0.2 and x = 9.3 in L = 10).
    let (pos, ori) = spheres(&[Vector3::new(0.2, 5.0, 5.0), Vector3::new(9.3, 5.0, 5.0)]);
    let r = Configuration {
        box_length: 10.0,
        wall_diameter: None,
        wedge: None,
        shapes: mono_shape(0.0),
        species: zeros(pos.len()),
        positions: &pos,
        orientations: &ori,
    };
    let w = worst_gap(&r).unwrap().unwrap();
    assert!((w.gap + 0.1).abs() < 1e-12);
    assert!(check_no_overlap(&r, 1e-4).is_err());
}

#[test]
fn crossed_rods_gap() {
    // Two rods L = 3, R = 0.5, axes x and y, centres 1.2 apart along z: gap 0.2.
    let pos = vec![Vector3::new(5.0, 5.0, 5.0), Vector3::new(5.0, 5.0, 6.2)];
    let ori = vec![
        UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::x()).unwrap(),
        UnitQuaternion::rotation_between(&Vector3::z(), &Vector3::y()).unwrap(),
    ];
    let r = Configuration {
        box_length: 10.0,
        wall_diameter: None,
        wedge: None,
        shapes: mono_shape(3.0),
        species: zeros(pos.len()),
        positions: &pos,
        orientations: &ori,
    };
    let g = pair_gaps(&r, 1.0).unwrap();
    assert_eq!(g.len(), 1);
    assert!((g[0].gap - 0.2).abs() < 1e-12);
}

#[test]
fn rattlers_are_removed_repeatedly() {
    // A chain 0-1-2 plus a triangle 3-4-5: with min_contacts 2 the chain ends are
    // rattlers, after which 1 has no contact and goes too; the triangle remains with 2.
    let gp = |i, j| PairGap { i, j, gap: 0.0 };
    let g = vec![gp(0, 1), gp(1, 2), gp(3, 4), gp(4, 5), gp(3, 5)];
    let (c, rat) = mean_contacts(6, &g, 1e-9, Some(2));
    assert_eq!(rat, 3);
    assert_eq!(c, 2.0);
    let (c_all, rat0) = mean_contacts(6, &g, 1e-9, None);
    assert_eq!(rat0, 0);
    assert!((c_all - 10.0 / 6.0).abs() < 1e-15);
    // Threshold 3 removes the triangle as well: no particle is left to average over, and
    // the extrapolation says so instead of returning 0.
    assert_eq!(mean_contacts(6, &g, 1e-9, Some(3)).1, 6);
    let e = extrapolated_contacts(6, &g, &[1e-9, 1e-8], Some(3)).unwrap_err();
    assert!(
        e.to_string()
            .contains("every one of the 6 particles is a rattler"),
        "{e}"
    );
    let (c0, slope) = extrapolated_contacts(6, &g, &[1e-9, 1e-8], Some(2)).unwrap();
    assert_eq!((c0, slope), (2.0, 0.0));
}

#[test]
fn nematic_order_limits() {
    let aligned = vec![Vector3::z(); 10];
    assert!((nematic_order(&aligned).unwrap() - 1.0).abs() < 1e-14);
    // Three orthogonal axes: Q = 0 exactly.
    let iso = vec![Vector3::x(), Vector3::y(), Vector3::z()];
    assert!(nematic_order(&iso).unwrap().abs() < 1e-14);
    assert!(nematic_order(&[]).is_err());
    assert!(nematic_order(&[Vector3::zeros()]).is_err());
}

/// Shoemake's uniform random rotation from three uniforms.
fn random_rotation(u1: f64, u2: f64, u3: f64) -> UnitQuaternion<f64> {
    let tau = std::f64::consts::TAU;
    UnitQuaternion::new_normalize(nalgebra::Quaternion::new(
        (1.0 - u1).sqrt() * (tau * u2).cos(),
        (1.0 - u1).sqrt() * (tau * u2).sin(),
        u1.sqrt() * (tau * u3).sin(),
        u1.sqrt() * (tau * u3).cos(),
    ))
}

#[test]
fn cubatic_order_limits() {
    use rand::{Rng, SeedableRng};
    // One common orientation (any): perfect cubatic order, S4 = 1 exactly at the optimum.
    let q = random_rotation(0.3, 0.7, 0.1);
    let s4 = cubatic_order(&vec![q; 50], 500).unwrap();
    assert!((s4 - 1.0).abs() < 1e-9, "{s4}");
    // Two populations sharing the z axis (one turned 45 deg about it): n = z still gives 1.
    let mut qs = vec![UnitQuaternion::identity(); 20];
    qs.extend(vec![
        UnitQuaternion::from_axis_angle(
            &Vector3::z_axis(),
            0.25 * std::f64::consts::PI
        );
        20
    ]);
    assert!((cubatic_order(&qs, 500).unwrap() - 1.0).abs() < 1e-9);
    // Isotropic orientations: <35 c^4 - 30 c^2 + 3> = 7 - 10 + 3 = 0 for uniform c; the
    // per-particle value has standard deviation below 1, so for N = 20000 the maximum over
    // directions of the mean stays within a few times 1/sqrt(N) = 0.007 of 0.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
    let iso: Vec<_> = (0..20000)
        .map(|_| random_rotation(rng.gen(), rng.gen(), rng.gen()))
        .collect();
    let s4 = cubatic_order(&iso, 300).unwrap();
    assert!(s4.abs() < 0.05, "{s4}");
    assert!(cubatic_order(&[], 100).is_err());
    assert!(cubatic_order(&iso[..3], 5).is_err());
}

#[test]
fn radial_distribution_of_lattice_and_ideal_gas() {
    // Simple cubic lattice, spacing 1: the first shell (r = 1) holds 6 neighbours, so
    // 4 pi r^2 rho g dr integrated over its bin is 6; no pair closer than 1.
    let m = 6;
    let p = lattice(m);
    let (pos, ori) = spheres(&p);
    let r = sphere_rods(m as f64, &pos, &ori);
    // Bins of 0.3 up to 1.2: the shell r = 1 lies inside [0.9, 1.2), the next (sqrt 2)
    // beyond.
    let g = radial_distribution(&r, 1.2, 4).unwrap();
    let dr = 0.3;
    let shell = |k: usize, v: f64| v * shell_volume(k, dr);
    let first: f64 = g
        .iter()
        .enumerate()
        .filter(|(_, (rc, _))| (rc - 1.05).abs() < 1e-9)
        .map(|(k, (_, v))| shell(k, *v))
        .sum();
    assert!((first - 6.0).abs() < 1e-9, "{first}");
    assert!(g.iter().take(3).all(|(_, v)| *v == 0.0));
    // Uniform random points: g = 1 within the Poisson error of each bin.
    let (pos, ori) = spheres(&uniform_points(3000, 10.0, 9));
    let r = sphere_rods(10.0, &pos, &ori);
    let g = radial_distribution(&r, 5.0, 10).unwrap();
    let rho = 3.0;
    for (k, (_, v)) in g.iter().enumerate() {
        let expected_pairs = 0.5 * 3000.0 * rho * shell_volume(k, 0.5);
        // 5 standard deviations of a Poisson count.
        assert!(
            (v - 1.0).abs() < 5.0 / expected_pairs.sqrt(),
            "bin {k}: {v}"
        );
    }
    assert!(radial_distribution(&r, 6.0, 10).is_err());
}

/// The cell-binned pair count of g(r) equals the all-pairs count bin for bin: uniform
/// points (pairs through every face of the box) and a simple cubic lattice of spacing 1
/// (every pair distance sqrt(integer), many on bin edges), with 3 and 4 cells along the box,
/// and a box of fewer than 3 cells.
#[test]
fn binned_pair_distances_equal_all_pairs() {
    let (pos, ori) = spheres(&uniform_points(2000, 12.0, 5));
    let gas = sphere_rods(12.0, &pos, &ori);
    let (cubic, cubic_ori) = spheres(&lattice(9));
    let mut pairs = 0;
    for (r, r_max, bins) in [(&gas, 4.0, 40), (&gas, 3.0, 7), (&gas, 5.0, 10)] {
        let all = pair_distance_histogram(r, r_max, bins, false);
        assert_eq!(pair_distance_histogram(r, r_max, bins, true), all);
        pairs += all.iter().sum::<u64>();
    }
    let v = sphere_rods(9.0, &cubic, &cubic_ori);
    let r_max = v.box_length / 3.0 * (1.0 - 1e-6);
    let all = pair_distance_histogram(&v, r_max, 30, false);
    assert_eq!(pair_distance_histogram(&v, r_max, 30, true), all);
    assert!(PeriodicCells::new(&v, r_max).is_some());
    assert!(PeriodicCells::new(&gas, 5.0).is_none());
    pairs += all.iter().sum::<u64>();
    assert!(pairs > 100_000, "{pairs}");
}

#[test]
fn orientation_histogram_of_uniform_axes() {
    use rand::{Rng, SeedableRng};
    // Uniform directions: P(theta bin) = cos(theta0) - cos(theta1) on the half sphere,
    // azimuth uniform; each count within 5 binomial standard deviations.
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
    let n = 200_000;
    let axes: Vec<_> = (0..n)
        .map(|_| random_rotation(rng.gen(), rng.gen(), rng.gen()) * Vector3::z())
        .collect();
    let (nt, np) = (6, 4);
    let h = orientation_histogram(&axes, nt, np).unwrap();
    let w = 0.5 * std::f64::consts::PI / nt as f64;
    for (kt, row) in h.iter().enumerate() {
        let p_theta = (kt as f64 * w).cos() - ((kt + 1) as f64 * w).cos();
        for &c in row {
            let p = p_theta / np as f64;
            let sd = (n as f64 * p * (1.0 - p)).sqrt();
            assert!((c as f64 - n as f64 * p).abs() < 5.0 * sd, "{kt}: {c}");
        }
    }
    // Axis along -z counts as theta = 0; along y as theta = pi/2, phi = pi/2.
    let h = orientation_histogram(&[-Vector3::z(), Vector3::y()], 2, 2).unwrap();
    assert_eq!(h, vec![vec![1, 0], vec![0, 1]]);
    assert!(orientation_histogram(&axes, 0, 1).is_err());
}

#[test]
fn wall_alignment_counts_tangential_particles_in_the_layer() {
    // Cylinder D_cyl = 10; three rods in the layer (rho > 4): one along z (tangential),
    // one along the azimuth (tangential), one radial (not); one rod near the axis (ignored).
    let pos = vec![
        Vector3::new(4.5, 0.0, 1.0),
        Vector3::new(0.0, 4.4, 3.0),
        Vector3::new(-4.2, 0.0, 5.0),
        Vector3::new(0.5, 0.5, 7.0),
    ];
    let to = |v: Vector3<f64>| UnitQuaternion::rotation_between(&Vector3::z(), &v).unwrap();
    let ori = vec![
        UnitQuaternion::identity(),
        to(Vector3::new(1.0, 0.0, 0.0)),
        to(Vector3::new(1.0, 0.0, 0.0)),
        UnitQuaternion::identity(),
    ];
    let r = Configuration {
        box_length: 20.0,
        wall_diameter: Some(10.0),
        wedge: None,
        shapes: mono_shape(1.0),
        species: zeros(pos.len()),
        positions: &pos,
        orientations: &ori,
    };
    let (f, near) = wall_aligned_fraction(&r, 1.0, 4f64.to_radians()).unwrap();
    assert_eq!(near, 3);
    assert!((f - 2.0 / 3.0).abs() < 1e-15);
    let periodic = Configuration {
        wall_diameter: None,
        wedge: None,
        ..r
    };
    assert!(wall_aligned_fraction(&periodic, 1.0, 0.1).is_err());
}

#[test]
fn wedge_alignment_uses_the_nearest_walls() {
    // Wedge l_w = 10, alpha = 30 deg. Near the back (x = 9.5): along y is tangential; near
    // the bottom (y = 0.5): along x is tangential, along y is not; near the slope: along
    // the slope direction is tangential; one rod deep inside is ignored.
    let a = 30f64.to_radians();
    let slope_dir = Vector3::new(a.cos(), a.sin(), 0.0);
    let on_slope = 6.0 * slope_dir + 0.5 * Vector3::new(a.sin(), -a.cos(), 0.0);
    let pos = vec![
        Vector3::new(9.5, 2.0, 1.0),
        Vector3::new(5.0, 0.5, 2.0),
        Vector3::new(6.0, 0.5, 3.0),
        on_slope + Vector3::new(0.0, 0.0, 4.0),
        Vector3::new(8.0, 2.0, 5.0),
    ];
    let to = |v: Vector3<f64>| UnitQuaternion::rotation_between(&Vector3::z(), &v).unwrap();
    let ori = vec![
        to(Vector3::y()),
        to(Vector3::x()),
        to(Vector3::y()),
        to(slope_dir),
        to(Vector3::x()),
    ];
    let r = Configuration {
        box_length: 20.0,
        wall_diameter: None,
        wedge: Some((10.0, a)),
        shapes: mono_shape(1.0),
        species: zeros(pos.len()),
        positions: &pos,
        orientations: &ori,
    };
    let (f, near) = wall_aligned_fraction(&r, 1.0, 4f64.to_radians()).unwrap();
    assert_eq!(near, 4);
    assert!((f - 0.75).abs() < 1e-15, "{f}");
}

#[test]
fn bad_input_is_an_error() {
    let (pos, ori) = spheres(&[Vector3::zeros()]);
    let r = Configuration {
        box_length: -1.0,
        wall_diameter: None,
        wedge: None,
        shapes: mono_shape(0.0),
        species: zeros(pos.len()),
        positions: &pos,
        orientations: &ori,
    };
    assert!(pair_gaps(&r, 0.0).is_err());
    assert!(extrapolated_contacts(1, &[], &[1e-6], None).is_err());
}
