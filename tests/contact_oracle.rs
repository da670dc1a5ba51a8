//! porelab's pair queries against an independent oracle, parry3d-f64 (a dev-dependency):
//! GJK distance / GJK+EPA contact on support maps, capsule contact and segment closest points.
//!
//! The support maps handed to parry are written here from closed forms, not taken from
//! porelab: ellipsoid s(d) = A^2 d / |A d| (A = diag(a)); superquadric by bisection on the
//! Lagrange multiplier of max d.x s.t. sum |x_k/a_k|^g_k = 1 (the stationarity condition gives
//! |x_k/a_k| = (|d_k| a_k / (mu g_k))^(1/(g_k - 1)), and sum |x_k/a_k|^g_k is monotone in mu).
//!
//! Two kinds of check:
//! * tight, parry-independent: separated curved pairs are bracketed by duality bounds computed
//!   with the support maps written here (lb = separating-axis value along porelab's normal,
//!   ub = |point_b - point_a| with both points verified on their surfaces by implicit functions
//!   written here): lb <= distance <= ub, and ub - lb must be < 1e-12 of the size; segment
//!   distances against a brute-force golden-section minimisation to 1e-13;
//! * against parry's GJK/EPA and capsule contact: GJK on curved support maps stops at a
//!   relative tolerance, so its distances on ellipsoids/superquadrics are measured at ~1e-6
//!   of the size and its normals at ~5e-4 (parry's error: the duality bounds above prove
//!   porelab's distances to 1e-12); they are compared to 1e-5 and 2e-3 for separated pairs
//!   with gap > 1e-4 of the size, shallow overlaps (|gap| < 1e-2 size) against EPA to 1e-6.
//!
//! `cargo test --release --test contact_oracle -- --nocapture` prints the worst errors.

#[path = "common/parry_shapes.rs"]
mod parry_shapes;

use nalgebra::{Isometry3, Point3, UnitQuaternion, Vector3};
use parry3d_f64::query::details::contact_support_map_support_map;
use parry3d_f64::shape::{Capsule, SupportMap};
use parry_shapes::{iso, sq_support_point};
use porelab::contact::pairgen::{min_semi_axis, random_rotation};
use porelab::contact::{closest_points_segments, contact, ContactShape, Pose};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

struct OracleEllipsoid([f64; 3]);
impl SupportMap for OracleEllipsoid {
    fn local_support_point(&self, d: &Vector3<f64>) -> Point3<f64> {
        let a = self.0;
        let ad = Vector3::new(a[0] * d.x, a[1] * d.y, a[2] * d.z);
        let n = ad.norm();
        if n == 0.0 {
            return Point3::new(a[0], 0.0, 0.0);
        }
        Point3::new(a[0] * ad.x / n, a[1] * ad.y / n, a[2] * ad.z / n)
    }
}

struct OracleSq([f64; 3], [f64; 3]);
impl SupportMap for OracleSq {
    fn local_support_point(&self, d: &Vector3<f64>) -> Point3<f64> {
        sq_support_point(self.0, self.1, d, 200.0, 200)
    }
}

/// sum |x_k/a_k|^g_k - 1, written here (not porelab's).
fn implicit(a: &[f64; 3], g: &[f64; 3], x: &Vector3<f64>) -> f64 {
    (0..3).map(|k| (x[k] / a[k]).abs().powf(g[k])).sum::<f64>() - 1.0
}

/// parry's signed distance, normal (world, from a to b) and points (world).
fn parry_contact(
    ga: &dyn SupportMap,
    pa: &Pose,
    gb: &dyn SupportMap,
    pb: &Pose,
) -> (f64, Vector3<f64>, Vector3<f64>, Vector3<f64>) {
    let (ia, ib) = (iso(pa), iso(pb));
    let pos12 = ia.inv_mul(&ib);
    let c = contact_support_map_support_map(&pos12, ga, gb, 1e6)
        .expect("parry: no contact within prediction");
    (
        c.dist,
        ia * c.normal1.into_inner(),
        (ia * c.point1).coords,
        (ib * c.point2).coords,
    )
}

#[derive(Default)]
struct Stat {
    n: usize,
    worst_gap: f64,
    worst_normal: f64,
    where_: String,
}
impl Stat {
    fn add(&mut self, dg: f64, dn: f64, w: impl Fn() -> String) {
        self.n += 1;
        if dg > self.worst_gap {
            self.worst_gap = dg;
            self.where_ = w();
        }
        self.worst_normal = self.worst_normal.max(dn);
    }
    fn print(&self, name: &str) {
        println!("{name:<40} pairs {:>6}  worst |gap - oracle|/size {:.2e}  worst |n - n_oracle| {:.2e}  ({})", self.n, self.worst_gap, self.worst_normal, self.where_);
    }
}

#[test]
fn gjk_accuracy_on_spheres() {
    // calibrates the oracle: parry GJK on sphere support maps against the exact distance
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let mut worst: f64 = 0.0;
    for _ in 0..2000 {
        let (ra, rb) = (rng.gen_range(0.5..2.0), rng.gen_range(0.5..2.0));
        let d = (ra + rb) * (1.0 + 10f64.powf(rng.gen_range(-6.0..0.0)));
        let pa = Pose::new(Vector3::zeros(), random_rotation(&mut rng));
        let pb = Pose::new(
            random_rotation(&mut rng) * Vector3::new(0.0, 0.0, d),
            random_rotation(&mut rng),
        );
        let (g, ..) = parry_contact(
            &OracleEllipsoid([ra; 3]),
            &pa,
            &OracleEllipsoid([rb; 3]),
            &pb,
        );
        worst = worst.max((g - (d - ra - rb)).abs() / (ra + rb));
    }
    println!("parry GJK on spheres: worst |gap - exact| / size = {worst:.2e}");
    assert!(worst < 1e-7);
}

#[test]
fn spherocylinders_against_parry_capsules_and_segments() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let mut st = Stat::default();
    let mut seg = 0.0f64;
    let mut seg_where = String::new();
    let (mut seg_brute, mut parry_brute) = (0.0f64, 0.0f64);
    for i in 0..20000 {
        let (ra, la, rb, lb) = (
            rng.gen_range(0.05..0.5),
            rng.gen_range(0.1..3.0),
            rng.gen_range(0.05..0.5),
            rng.gen_range(0.1..3.0),
        );
        let pa = Pose::new(Vector3::zeros(), random_rotation(&mut rng));
        // every third pair nearly parallel
        let qb = if i % 3 == 0 {
            let tilt = 10f64.powf(rng.gen_range(-15.0..-2.0));
            pa.orientation * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), tilt)
        } else {
            random_rotation(&mut rng)
        };
        let pb = Pose::new(
            random_rotation(&mut rng) * Vector3::new(0.0, 0.0, rng.gen_range(0.0..3.0)),
            qb,
        );
        let c = contact(
            &ContactShape::Spherocylinder {
                radius: ra,
                length: la,
            },
            &pa,
            &ContactShape::Spherocylinder {
                radius: rb,
                length: lb,
            },
            &pb,
        )
        .unwrap();
        let (ia, ib) = (iso(&pa), iso(&pb));
        let ca = Capsule::new_z(0.5 * la, ra);
        let cb = Capsule::new_z(0.5 * lb, rb);
        let o = parry3d_f64::query::contact(&ia, &ca, &ib, &cb, 1e6)
            .unwrap()
            .unwrap();
        let size = ra + rb + la.max(lb);
        // deep overlaps: parry's capsule contact reports EPA's minimum translation distance,
        // which may be along the axes; the segment-distance depth is a different quantity.
        if c.gap > -0.5 * ra.min(rb) {
            let dn = if o.dist > 1e-6 {
                (c.normal - o.normal1.into_inner()).norm()
            } else {
                0.0
            };
            st.add((c.gap - o.dist).abs() / size, dn, || {
                format!("gap {:.3e}", c.gap)
            });
        }
        // segments directly
        let (u, v) = (pa.axis_z(), pb.axis_z());
        let (p0, p1, q0, q1) = (
            pa.position - 0.5 * la * u,
            pa.position + 0.5 * la * u,
            pb.position - 0.5 * lb * v,
            pb.position + 0.5 * lb * v,
        );
        let (_, _, p, q) = closest_points_segments(&p0, &p1, &q0, &q1);
        let sa = parry3d_f64::shape::Segment::new(Point3::from(p0), Point3::from(p1));
        let sb = parry3d_f64::shape::Segment::new(Point3::from(q0), Point3::from(q1));
        let (la_, lb_) = parry3d_f64::query::details::closest_points_segment_segment_with_locations(
            &Isometry3::identity(),
            &sa,
            &sb,
        );
        let (op, oq) = (sa.point_at(&la_), sb.point_at(&lb_));
        let (dm, dp) = ((q - p).norm(), (oq - op).norm());
        let db = brute_segment_distance(&p0, &p1, &q0, &q1);
        seg_brute = seg_brute.max((dm - db).abs() / size);
        parry_brute = parry_brute.max((dp - db).abs() / size);
        // both are distances between points of the segments: the smaller is the better one
        if (dm - dp).abs() / size > seg {
            seg = (dm - dp).abs() / size;
            seg_where = format!("porelab {dm:.16e} parry {dp:.16e} (i = {i})");
        }
    }
    st.print("spherocylinder vs parry capsule");
    println!(
        "{:<40} pairs {:>6}  worst |distance - oracle|/size {seg:.2e} {seg_where}",
        "segment closest points vs parry", 20000
    );
    println!("{:<40} pairs {:>6}  worst |distance - brute force|/size: porelab {seg_brute:.2e}, parry {parry_brute:.2e}", "segment distance vs brute force", 20000);
    // porelab's segment distance is checked against the brute force to 1e-13 (the golden
    // section resolves s to 1e-16, the distance to rounding); parry's own error (~1e-8 on
    // nearly parallel pairs, from its epsilon thresholds) bounds the capsule comparison.
    assert!(seg_brute < 1e-13, "segment distance error {seg_brute:.2e}");
    assert!(st.worst_gap < 1e-5 && st.worst_normal < 1e-2);
}

/// Brute-force segment distance (independent of both libraries): the distance from P(s) to
/// segment Q (closed form for a point) is convex in s; golden-section search over [0, 1]
/// after a coarse scan, to 1e-16 in s.
fn brute_segment_distance(
    p0: &Vector3<f64>,
    p1: &Vector3<f64>,
    q0: &Vector3<f64>,
    q1: &Vector3<f64>,
) -> f64 {
    let dq = q1 - q0;
    let pt_seg = |x: Vector3<f64>| {
        let t = ((x - q0).dot(&dq) / dq.norm_squared()).clamp(0.0, 1.0);
        (q0 + dq * t - x).norm()
    };
    let f = |s: f64| pt_seg(p0 + (p1 - p0) * s);
    let n = 64;
    let k = (0..=n)
        .min_by(|&i, &j| {
            f(i as f64 / n as f64)
                .partial_cmp(&f(j as f64 / n as f64))
                .unwrap()
        })
        .unwrap();
    let (mut lo, mut hi) = (
        ((k as f64) - 1.0).max(0.0) / n as f64,
        ((k as f64) + 1.0).min(n as f64) / n as f64,
    );
    let gr = 0.5 * (5f64.sqrt() - 1.0);
    for _ in 0..200 {
        let (m1, m2) = (hi - gr * (hi - lo), lo + gr * (hi - lo));
        if f(m1) < f(m2) {
            hi = m2
        } else {
            lo = m1
        }
        if hi - lo < 1e-16 {
            break;
        }
    }
    f(0.5 * (lo + hi)).min(f(0.0)).min(f(1.0))
}

fn random_axes(rng: &mut ChaCha8Rng, aspect: f64) -> [f64; 3] {
    [0, 1, 2].map(|_| 10f64.powf(rng.gen_range(0.0..aspect.log10())))
}

fn compare_curved(name: &str, n: usize, seed: u64, sq: bool) -> (Stat, Stat) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (mut sep, mut ovl) = (Stat::default(), Stat::default());
    let mut bounds = (0usize, 0.0f64, 0.0f64);
    for _ in 0..n {
        let (aa, ab) = (random_axes(&mut rng, 4.0), random_axes(&mut rng, 4.0));
        let (ga, gb) = if sq {
            (
                [0, 1, 2].map(|_| rng.gen_range(2.0..6.0)),
                [0, 1, 2].map(|_| rng.gen_range(2.0..6.0)),
            )
        } else {
            ([2.0; 3], [2.0; 3])
        };
        let (pa, pb) = if rng.gen_bool(0.5) {
            let pa = Pose::new(Vector3::zeros(), random_rotation(&mut rng));
            let dir = random_rotation(&mut rng) * Vector3::z();
            let r = aa.iter().chain(ab.iter()).cloned().fold(0.0, f64::max);
            (
                pa,
                Pose::new(dir * rng.gen_range(0.3..2.0) * r, random_rotation(&mut rng)),
            )
        } else {
            // shallow overlaps for the EPA comparison (prescribed by construction)
            let size = min_semi_axis(&aa, &ab);
            let delta = -10f64.powf(rng.gen_range(-6.0..-2.0)) * size;
            let p = porelab::contact::pairgen::make_pair(&mut rng, aa, ga, ab, gb, delta, 0.0);
            (p.pose_a, p.pose_b)
        };
        let (sa, sb) = if sq {
            (
                ContactShape::Superquadric {
                    semi_axes: aa,
                    exponents: ga,
                },
                ContactShape::Superquadric {
                    semi_axes: ab,
                    exponents: gb,
                },
            )
        } else {
            (
                ContactShape::Ellipsoid { semi_axes: aa },
                ContactShape::Ellipsoid { semi_axes: ab },
            )
        };
        let c = match contact(&sa, &pa, &sb, &pb) {
            Ok(c) => c,
            Err(_) => continue,
        };
        let (og, on, ..) = if sq {
            parry_contact(&OracleSq(aa, ga), &pa, &OracleSq(ab, gb), &pb)
        } else {
            parry_contact(&OracleEllipsoid(aa), &pa, &OracleEllipsoid(ab), &pb)
        };
        let size = min_semi_axis(&aa, &ab);
        if c.gap > 0.0 {
            // duality bounds from the oracle's support maps: lb = separating-axis value along
            // porelab's normal <= true distance <= |point_b - point_a| = ub (points must lie on
            // the surfaces, checked with the implicit functions written here)
            let (sma, smb): (Box<dyn SupportMap>, Box<dyn SupportMap>) = if sq {
                (Box::new(OracleSq(aa, ga)), Box::new(OracleSq(ab, gb)))
            } else {
                (Box::new(OracleEllipsoid(aa)), Box::new(OracleEllipsoid(ab)))
            };
            let n = c.normal;
            let lb = n.dot(&smb.support_point(&iso(&pb), &(-n)).coords)
                - n.dot(&sma.support_point(&iso(&pa), &n).coords);
            let ub = (c.point_b - c.point_a).norm();
            let fa = implicit(&aa, &ga, &pa.to_local(&c.point_a));
            let fb = implicit(&ab, &gb, &pb.to_local(&c.point_b));
            let err = (ub - lb).max(lb - c.gap).max(c.gap - ub).max(0.0) / size;
            bounds.0 += 1;
            if err > bounds.1 {
                bounds.1 = err;
            }
            bounds.2 = bounds.2.max(fa.abs()).max(fb.abs());
        }
        if c.gap > 1e-4 * size {
            sep.add((c.gap - og).abs() / size, (c.normal - on).norm(), || {
                format!("gap {:.3e}", c.gap)
            });
        } else if c.gap < 0.0 && c.gap > -1e-2 * size {
            // shallow overlaps: the common-normal depth and EPA's penetration depth agree to O(depth^2)
            ovl.add((c.gap - og).abs() / size, (c.normal - on).norm(), || {
                format!("gap {:.3e}", c.gap)
            });
        }
    }
    println!("{:<40} pairs {:>6}  distance proven within (ub - lb)/size <= {:.2e}; max |F| at the points {:.1e}", format!("{name} oracle duality bounds"), bounds.0, bounds.1, bounds.2);
    assert!(
        bounds.0 > 100 && bounds.1 < 1e-12 && bounds.2 < 1e-12,
        "duality bounds {bounds:?}"
    );
    sep.print(&format!("{name} separated (GJK)"));
    ovl.print(&format!("{name} shallow overlap (EPA)"));
    (sep, ovl)
}

#[test]
fn ellipsoids_against_parry_gjk_epa() {
    let (sep, ovl) = compare_curved("ellipsoid-ellipsoid", 4000, 3, false);
    assert!(sep.n > 500 && sep.worst_gap < 1e-5 && sep.worst_normal < 2e-3);
    assert!(ovl.n >= 5 && ovl.worst_gap < 1e-6);
}

#[test]
fn superquadrics_against_parry_gjk_epa() {
    let (sep, ovl) = compare_curved("superquadric-superquadric", 1500, 4, true);
    assert!(sep.n > 200 && sep.worst_gap < 1e-5 && sep.worst_normal < 2e-3);
    assert!(ovl.n >= 3 && ovl.worst_gap < 1e-6);
}

#[test]
fn sphere_ellipsoid_against_parry() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    let mut st = Stat::default();
    let mut bound = 0.0f64;
    for _ in 0..4000 {
        let r = rng.gen_range(0.2..2.0);
        let ab = random_axes(&mut rng, 5.0);
        let pa = Pose::new(Vector3::zeros(), random_rotation(&mut rng));
        let dir = random_rotation(&mut rng) * Vector3::z();
        let pb = Pose::new(
            dir * rng.gen_range(0.5..1.5) * (r + ab.iter().cloned().fold(0.0, f64::max)),
            random_rotation(&mut rng),
        );
        let c = contact(
            &ContactShape::Sphere { radius: r },
            &pa,
            &ContactShape::Ellipsoid { semi_axes: ab },
            &pb,
        )
        .unwrap();
        if c.gap <= 1e-4 * r {
            continue;
        }
        let (og, on, ..) = parry_contact(&OracleEllipsoid([r; 3]), &pa, &OracleEllipsoid(ab), &pb);
        st.add((c.gap - og).abs() / r, (c.normal - on).norm(), || {
            format!("gap {:.3e}", c.gap)
        });
        // duality bounds (parry-independent)
        let n = c.normal;
        let lb = n.dot(&OracleEllipsoid(ab).support_point(&iso(&pb), &(-n)).coords)
            - n.dot(&pa.position)
            - r;
        let ub = (c.point_b - c.point_a).norm();
        let fb = implicit(&ab, &[2.0; 3], &pb.to_local(&c.point_b)).abs();
        let fa = ((c.point_a - pa.position).norm() / r - 1.0).abs();
        bound = bound
            .max((ub - lb).max(lb - c.gap).max(c.gap - ub) / r)
            .max(fa)
            .max(fb);
    }
    println!("sphere-ellipsoid duality bounds: worst (ub - lb)/r or |F| = {bound:.2e}");
    assert!(bound < 1e-12);
    st.print("sphere-ellipsoid separated");
    assert!(st.n > 500 && st.worst_gap < 1e-4 && st.worst_normal < 2e-3);
}
