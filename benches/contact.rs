//! Contact benchmark: nanoseconds per pair query for each pair type, the hit rate of each
//! superquadric prefilter, Perram-Wertheim against Newton-Raphson for ellipsoids, and porelab
//! against parry3d-f64 (GJK/EPA on support maps, ball and capsule queries) on the same pairs.
//!
//! `cargo bench --bench contact` prints a table and writes target/porelab/bench-contact.csv
//! (query, pairs, n_pairs, ns_per_query, overlap_fraction, bounding_sphere, samples_inside,
//! samples_apart, full_solver, failures). Single thread; fixed seeds.
//!
//! Pair sets: "near" = prescribed near-contact pairs (|gap| = 1e-6..1e-2 of the size, both
//! signs, built by porelab::contact::pairgen); "mixed" = random centre distances 0.5..3 times
//! the summed bounding radii (what a neighbour list hands to the narrow phase).

#[path = "../tests/common/parry_shapes.rs"]
mod parry_shapes;

use nalgebra::{Point3, Vector3};
use parry3d_f64::query::details::contact_support_map_support_map;
use parry3d_f64::shape::{Ball, Capsule, SupportMap};
use parry_shapes::{iso, sq_support_point};
use porelab::contact::pairgen::{make_pair, random_rotation, random_signed_gap};
use porelab::contact::{
    contact_ellipsoid_ellipsoid, contact_sphere_ellipsoid, contact_sphere_sphere,
    contact_sphere_spherocylinder, contact_spherocylinder_spherocylinder,
    contact_superquadric_superquadric, overlap_superquadric_superquadric, pw_max, pw_overlap,
    NrOptions, Pose, SqBody, SqShape,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::hint::black_box;
use std::io::Write;
use std::time::Instant;

struct Ell([f64; 3]);
impl SupportMap for Ell {
    fn local_support_point(&self, d: &Vector3<f64>) -> Point3<f64> {
        let a = self.0;
        let ad = Vector3::new(a[0] * d.x, a[1] * d.y, a[2] * d.z);
        let n = ad.norm().max(1e-300);
        Point3::new(a[0] * ad.x / n, a[1] * ad.y / n, a[2] * ad.z / n)
    }
}
/// Superquadric support for parry (bisection on the multiplier, as in tests/contact_oracle.rs).
struct Sq([f64; 3], [f64; 3]);
impl SupportMap for Sq {
    fn local_support_point(&self, d: &Vector3<f64>) -> Point3<f64> {
        sq_support_point(self.0, self.1, d, 60.0, 60)
    }
}

/// Runs f over all items repeatedly for >= 0.3 s; returns ns per call.
fn time<T>(items: &[T], mut f: impl FnMut(&T)) -> f64 {
    let mut reps = 0usize;
    let t0 = Instant::now();
    loop {
        for it in items {
            f(it);
        }
        reps += 1;
        if t0.elapsed().as_secs_f64() > 0.3 {
            break;
        }
    }
    t0.elapsed().as_secs_f64() * 1e9 / (reps * items.len()) as f64
}

/// Pairs per set.
const N: usize = 2000;

#[derive(Default, Clone)]
struct Line {
    query: String,
    pairs: String,
    n: usize,
    ns: f64,
    overlap: f64,
    hits: [f64; 4],
    failures: usize,
}

impl Line {
    /// A line over the N pairs of every set.
    fn new(query: &str, pairs: &str, ns: f64, overlap: f64) -> Line {
        Line {
            query: query.into(),
            pairs: pairs.into(),
            n: N,
            ns,
            overlap,
            ..Default::default()
        }
    }
}

/// One parry GJK/EPA contact query between two support maps (result discarded).
fn parry_support_maps_once(pa: &Pose, a: &impl SupportMap, pb: &Pose, b: &impl SupportMap) {
    let (ia, ib) = (iso(pa), iso(pb));
    black_box(contact_support_map_support_map(&ia.inv_mul(&ib), a, b, 1e9));
}

/// One superquadric common-normal contact query (result discarded).
fn nr_contact_once(b: &(SqBody, SqBody)) {
    let _ = black_box(contact_superquadric_superquadric(
        &b.0,
        &b.1,
        &NrOptions::default(),
    ));
}

/// Failures of the superquadric contact solver on `bodies`, and ns per query.
fn nr_contact(bodies: &[(SqBody, SqBody)]) -> (usize, f64) {
    let fails = bodies
        .iter()
        .filter(|b| contact_superquadric_superquadric(&b.0, &b.1, &NrOptions::default()).is_err())
        .count();
    (fails, time(bodies, nr_contact_once))
}

fn main() {
    let mut lines: Vec<Line> = Vec::new();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let n = N;

    // ---- spheres
    let sph: Vec<(Pose, f64, Pose, f64)> = (0..n)
        .map(|_| {
            let (ra, rb) = (rng.gen_range(0.5..1.5), rng.gen_range(0.5..1.5));
            let d = (ra + rb) * rng.gen_range(0.8..1.2);
            (
                Pose::at(Vector3::zeros()),
                ra,
                Pose::at(random_rotation(&mut rng) * Vector3::new(0.0, 0.0, d)),
                rb,
            )
        })
        .collect();
    let ov = sph
        .iter()
        .filter(|p| contact_sphere_sphere(&p.0.position, p.1, &p.2.position, p.3).gap < 0.0)
        .count() as f64
        / n as f64;
    let ns = time(&sph, |p| {
        black_box(contact_sphere_sphere(
            &p.0.position,
            p.1,
            &p.2.position,
            p.3,
        ));
    });
    lines.push(Line::new("sphere-sphere porelab", "near", ns, ov));
    let ns = time(&sph, |p| {
        black_box(
            parry3d_f64::query::contact(
                &iso(&p.0),
                &Ball::new(p.1),
                &iso(&p.2),
                &Ball::new(p.3),
                1e9,
            )
            .unwrap(),
        );
    });
    lines.push(Line::new("sphere-sphere parry", "near", ns, ov));

    // ---- spherocylinders
    let sc: Vec<(Pose, f64, f64, Pose, f64, f64)> = (0..n)
        .map(|_| {
            let (ra, la, rb, lb) = (
                rng.gen_range(0.1..0.5),
                rng.gen_range(0.5..3.0),
                rng.gen_range(0.1..0.5),
                rng.gen_range(0.5..3.0),
            );
            let d = rng.gen_range(0.2..2.0);
            (
                Pose::new(Vector3::zeros(), random_rotation(&mut rng)),
                ra,
                la,
                Pose::new(
                    random_rotation(&mut rng) * Vector3::new(0.0, 0.0, d),
                    random_rotation(&mut rng),
                ),
                rb,
                lb,
            )
        })
        .collect();
    let ov = sc
        .iter()
        .filter(|p| contact_spherocylinder_spherocylinder(&p.0, p.1, p.2, &p.3, p.4, p.5).gap < 0.0)
        .count() as f64
        / n as f64;
    let ns = time(&sc, |p| {
        black_box(contact_spherocylinder_spherocylinder(
            &p.0, p.1, p.2, &p.3, p.4, p.5,
        ));
    });
    lines.push(Line::new(
        "spherocylinder-spherocylinder porelab",
        "mixed",
        ns,
        ov,
    ));
    let ns = time(&sc, |p| {
        black_box(
            parry3d_f64::query::contact(
                &iso(&p.0),
                &Capsule::new_z(0.5 * p.2, p.1),
                &iso(&p.3),
                &Capsule::new_z(0.5 * p.5, p.4),
                1e9,
            )
            .unwrap(),
        );
    });
    lines.push(Line::new(
        "spherocylinder-spherocylinder parry",
        "mixed",
        ns,
        ov,
    ));
    let ns = time(&sc, |p| {
        black_box(contact_sphere_spherocylinder(
            &p.0.position,
            p.1,
            &p.3,
            p.4,
            p.5,
        ));
    });
    lines.push(Line::new("sphere-spherocylinder porelab", "mixed", ns, 0.0));

    // ---- ellipsoids (near-contact pairs)
    let ell: Vec<_> = (0..n)
        .map(|_| {
            let aa = [0, 1, 2].map(|_| rng.gen_range(0.3..3.0));
            let ab = [0, 1, 2].map(|_| rng.gen_range(0.3..3.0));
            let (_, _, delta) = random_signed_gap(&mut rng, &aa, &ab, -6.0..-2.0);
            make_pair(&mut rng, aa, [2.0; 3], ab, [2.0; 3], delta, 1.0)
        })
        .collect();
    let ov = ell.iter().filter(|p| p.gap < 0.0).count() as f64 / n as f64;
    let ns = time(&ell, |p| {
        black_box(pw_overlap(&p.pose_a, &p.axes_a, &p.pose_b, &p.axes_b));
    });
    lines.push(Line::new(
        "ellipsoid PW overlap (early exit)",
        "near",
        ns,
        ov,
    ));
    let ns = time(&ell, |p| {
        black_box(pw_max(&p.pose_a, &p.axes_a, &p.pose_b, &p.axes_b));
    });
    lines.push(Line::new(
        "ellipsoid PW max F (scale factor)",
        "near",
        ns,
        ov,
    ));
    let bodies: Vec<(SqBody, SqBody)> = ell
        .iter()
        .map(|p| {
            (
                SqBody::new(SqShape::new(p.axes_a, [2.0; 3]), p.pose_a),
                SqBody::new(SqShape::new(p.axes_b, [2.0; 3]), p.pose_b),
            )
        })
        .collect();
    let (fails, ns) = nr_contact(&bodies);
    lines.push(Line {
        failures: fails,
        ..Line::new("ellipsoid NR common normal (contact)", "near", ns, ov)
    });
    let ns = time(&ell, |p| {
        let _ = black_box(contact_ellipsoid_ellipsoid(
            &p.pose_a, p.axes_a, &p.pose_b, p.axes_b,
        ));
    });
    lines.push(Line::new(
        "ellipsoid NR + PW scale (contact())",
        "near",
        ns,
        ov,
    ));
    let ns = time(&ell, |p| {
        parry_support_maps_once(&p.pose_a, &Ell(p.axes_a), &p.pose_b, &Ell(p.axes_b))
    });
    lines.push(Line::new(
        "ellipsoid parry GJK/EPA (contact)",
        "near",
        ns,
        ov,
    ));
    let ns = time(&ell, |p| {
        black_box(contact_sphere_ellipsoid(
            &p.pose_a.position,
            p.axes_a[0],
            &p.pose_b,
            p.axes_b,
        ));
    });
    lines.push(Line::new("sphere-ellipsoid porelab", "near-ish", ns, 0.0));

    // ---- superquadrics: near pairs (full contact) and mixed pairs (overlap with prefilters)
    let sqp: Vec<_> = (0..n)
        .map(|_| {
            let aa = [0, 1, 2].map(|_| rng.gen_range(0.5..2.0));
            let ab = [0, 1, 2].map(|_| rng.gen_range(0.5..2.0));
            let ga = [0, 1, 2].map(|_| rng.gen_range(2.0..6.0));
            let gb = [0, 1, 2].map(|_| rng.gen_range(2.0..6.0));
            let (_, _, delta) = random_signed_gap(&mut rng, &aa, &ab, -6.0..-2.0);
            make_pair(&mut rng, aa, ga, ab, gb, delta, 1.0)
        })
        .collect();
    let sqb: Vec<(SqBody, SqBody)> = sqp
        .iter()
        .map(|p| {
            (
                SqBody::new(SqShape::new(p.axes_a, p.exps_a).with_samples(256), p.pose_a),
                SqBody::new(SqShape::new(p.axes_b, p.exps_b).with_samples(256), p.pose_b),
            )
        })
        .collect();
    let sqb_nosamples: Vec<(SqBody, SqBody)> = sqp
        .iter()
        .map(|p| {
            (
                SqBody::new(SqShape::new(p.axes_a, p.exps_a), p.pose_a),
                SqBody::new(SqShape::new(p.axes_b, p.exps_b), p.pose_b),
            )
        })
        .collect();
    let ov = sqp.iter().filter(|p| p.gap < 0.0).count() as f64 / n as f64;
    let (fails, ns) = nr_contact(&sqb);
    lines.push(Line {
        failures: fails,
        ..Line::new("superquadric NR contact (k-d start)", "near", ns, ov)
    });
    let (fails, ns) = nr_contact(&sqb_nosamples);
    lines.push(Line {
        failures: fails,
        ..Line::new("superquadric NR contact (no samples)", "near", ns, ov)
    });
    let ns = time(&sqp, |p| {
        parry_support_maps_once(
            &p.pose_a,
            &Sq(p.axes_a, p.exps_a),
            &p.pose_b,
            &Sq(p.axes_b, p.exps_b),
        )
    });
    lines.push(Line::new(
        "superquadric parry GJK/EPA (contact)",
        "near",
        ns,
        ov,
    ));

    // mixed: random distances, overlap test with prefilters
    let mixed: Vec<(SqBody, SqBody)> = sqb
        .iter()
        .map(|(a, b)| {
            let d = (a.shape.bounding_radius + b.shape.bounding_radius) * rng.gen_range(0.5..1.5);
            let a2 = SqBody::new(
                a.shape.clone(),
                Pose::new(Vector3::zeros(), random_rotation(&mut rng)),
            );
            let b2 = SqBody::new(
                b.shape.clone(),
                Pose::new(
                    random_rotation(&mut rng) * Vector3::new(0.0, 0.0, d),
                    random_rotation(&mut rng),
                ),
            );
            (a2, b2)
        })
        .collect();
    let mut hits = [0usize; 4];
    let mut fails = 0;
    let mut nov = 0;
    for (a, b) in &mixed {
        match overlap_superquadric_superquadric(a, b, &NrOptions::default()) {
            Ok((o, m)) => {
                nov += o as usize;
                let k = match m {
                    "bounding-sphere" => 0,
                    "point-samples-inside" => 1,
                    "point-samples-apart" => 2,
                    _ => 3,
                };
                hits[k] += 1;
            }
            Err(_) => fails += 1,
        }
    }
    let ns = time(&mixed, |b| {
        let _ = black_box(overlap_superquadric_superquadric(
            &b.0,
            &b.1,
            &NrOptions::default(),
        ));
    });
    lines.push(Line {
        query: "superquadric overlap (prefilters + NR)".into(),
        pairs: "mixed".into(),
        n,
        ns,
        overlap: nov as f64 / n as f64,
        hits: hits.map(|h| h as f64 / n as f64),
        failures: fails,
    });
    let ns = time(&mixed, nr_contact_once);
    lines.push(Line::new(
        "superquadric NR contact, no prefilter",
        "mixed",
        ns,
        nov as f64 / n as f64,
    ));
    let ns = time(&mixed, |b| {
        parry_support_maps_once(
            &b.0.pose,
            &Sq(b.0.shape.semi_axes, b.0.shape.exponents),
            &b.1.pose,
            &Sq(b.1.shape.semi_axes, b.1.shape.exponents),
        )
    });
    lines.push(Line::new(
        "superquadric parry GJK/EPA (contact)",
        "mixed",
        ns,
        nov as f64 / n as f64,
    ));

    println!(
        "{:<42} {:<8} {:>6} {:>12} {:>8} {:>8} {:>8} {:>8} {:>8} {:>6}",
        "query", "pairs", "n", "ns/query", "overlap", "bsphere", "s-in", "s-apart", "full", "fail"
    );
    for l in &lines {
        println!(
            "{:<42} {:<8} {:>6} {:>12.1} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>8.3} {:>6}",
            l.query,
            l.pairs,
            l.n,
            l.ns,
            l.overlap,
            l.hits[0],
            l.hits[1],
            l.hits[2],
            l.hits[3],
            l.failures
        );
    }
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("target/porelab");
    std::fs::create_dir_all(&dir).unwrap();
    let tmp = dir.join("bench-contact.csv.tmp");
    let mut f = std::fs::File::create(&tmp).unwrap();
    writeln!(f, "query,pairs,n_pairs,ns_per_query,overlap_fraction,bounding_sphere,samples_inside,samples_apart,full_solver,failures").unwrap();
    for l in &lines {
        writeln!(
            f,
            "{},{},{},{:.1},{:.4},{:.4},{:.4},{:.4},{:.4},{}",
            l.query,
            l.pairs,
            l.n,
            l.ns,
            l.overlap,
            l.hits[0],
            l.hits[1],
            l.hits[2],
            l.hits[3],
            l.failures
        )
        .unwrap();
    }
    drop(f);
    std::fs::rename(&tmp, dir.join("bench-contact.csv")).unwrap();
    println!("wrote {}", dir.join("bench-contact.csv").display());
}
