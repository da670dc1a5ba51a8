//! Contact-detection validation cases (thesis 003 sec. 2.2, 3.5, 4.4; seed 000 app. A):
//!
//! * 301 aligned ellipsoids and spheres along each axis (closed forms: gap, normal, PW scale),
//! * 302 spherocylinders: crossed, parallel, nearly parallel, end-on (segment distances),
//! * 303/304 Perram-Wertheim vs common-normal Newton-Raphson on 1e4 / 1e5 near-contact
//!   ellipsoid pairs with a prescribed gap built from surface closed forms,
//! * 305 symmetry under swapping the pair and invariance under rigid motions.
//!
//! The independent oracle comparison with parry3d-f64 (GJK/EPA, segment closest points) is in
//! tests/contact_oracle.rs, because parry is a dev-dependency.

use super::common::required_seed;
use crate::contact::pairgen::{make_pair, random_rotation, random_signed_gap};
use crate::contact::{contact, pw_overlap, ContactShape, NrOptions, Pose, SqBody, SqShape};
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};
use nalgebra::{UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;

fn shape_of(kind: &str, ax: [f64; 3]) -> Result<ContactShape> {
    match kind {
        "sphere" => Ok(ContactShape::Sphere { radius: ax[0] }),
        "ellipsoid" => Ok(ContactShape::Ellipsoid { semi_axes: ax }),
        other => Err(Error::Validation(format!(
            "unknown shape '{other}' in the table"
        ))),
    }
}

register!("301" => case_301);
/// Case 301.
pub fn case_301(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let a = [t.f64(i, "a1_m")?, t.f64(i, "a2_m")?, t.f64(i, "a3_m")?];
        let b = [t.f64(i, "b1_m")?, t.f64(i, "b2_m")?, t.f64(i, "b3_m")?];
        let (ka, kb) = (t.str(i, "shape_a")?, t.str(i, "shape_b")?);
        let k = match t.str(i, "axis")? {
            "x" => 0,
            "y" => 1,
            _ => 2,
        };
        let d = t.f64(i, "d_m")?;
        let gap = t.f64(i, "gap_m")?;
        let mut e = Vector3::zeros();
        e[k] = 1.0;
        let c = contact(
            &shape_of(ka, a)?,
            &Pose::at(Vector3::zeros()),
            &shape_of(kb, b)?,
            &Pose::at(d * e),
        )?;
        let s = a[k] + b[k];
        let lab = format!(
            "{ka}-{kb} a={a:?} b={b:?} axis={} d/s-1={:.1e}",
            t.str(i, "axis")?,
            gap / s
        );
        rows.push(Row::new(format!("gap {lab}"), c.gap, gap, s));
        rows.push(Row::new(
            format!("normal {lab}"),
            c.normal.dot(&e),
            1.0,
            1.0,
        ));
        rows.push(Row::new(
            format!("sign {lab}"),
            ((c.gap < 0.0) == (gap < 0.0)) as u8 as f64,
            1.0,
            1.0,
        ));
        if ka == "ellipsoid" && kb == "ellipsoid" {
            let pw = c
                .pw_scale
                .ok_or_else(|| Error::Validation("ellipsoid pair without pw_scale".into()))?;
            rows.push(Row::new(
                format!("pw_scale {lab}"),
                pw,
                t.f64(i, "pw_scale")?,
                1.0,
            ));
        }
    }
    Ok(rows)
}

register!("302" => case_302);
/// Case 302.
pub fn case_302(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let v = |p: &str| -> Result<Vector3<f64>> {
            Ok(Vector3::new(
                t.f64(i, &format!("{p}x"))?,
                t.f64(i, &format!("{p}y"))?,
                t.f64(i, &format!("{p}z"))?,
            ))
        };
        let pa = Vector3::new(t.f64(i, "pax_m")?, t.f64(i, "pay_m")?, t.f64(i, "paz_m")?);
        let pb = Vector3::new(t.f64(i, "pbx_m")?, t.f64(i, "pby_m")?, t.f64(i, "pbz_m")?);
        let axa = v("axa")?;
        let axb = v("axb")?;
        let qa = UnitQuaternion::rotation_between(&Vector3::z(), &axa).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        let qb = UnitQuaternion::rotation_between(&Vector3::z(), &axb).unwrap_or_else(|| {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI)
        });
        let (ra, la, rb, lb) = (
            t.f64(i, "ra_m")?,
            t.f64(i, "la_m")?,
            t.f64(i, "rb_m")?,
            t.f64(i, "lb_m")?,
        );
        let c = contact(
            &ContactShape::Spherocylinder {
                radius: ra,
                length: la,
            },
            &Pose::new(pa, qa),
            &ContactShape::Spherocylinder {
                radius: rb,
                length: lb,
            },
            &Pose::new(pb, qb),
        )?;
        let gap = t.f64(i, "gap_m")?;
        let lab = format!(
            "{} pb=({:.3e},{:.3e},{:.3e})",
            t.str(i, "kind")?,
            pb.x,
            pb.y,
            pb.z
        );
        rows.push(Row::new(
            format!("gap {lab}"),
            c.gap,
            gap,
            ra + rb + gap + ra + rb,
        ));
        let cons = (c.point_b - c.point_a - c.gap * c.normal).norm();
        rows.push(Row::new(format!("consistency {lab}"), cons, 0.0, 1.0));
    }
    Ok(rows)
}

/// One pair of cases 303/304: (Perram-Wertheim wrong outside the near-contact band, solver
/// wrong, solver failed, the two disagree outside the band, gap error / bounding radius).
type PairOutcome = (bool, bool, bool, bool, f64);

/// Shared by 303/304: returns the rows of the table's checks.
fn pw_vs_nr(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case.toml needs a seed")?;
    let n = t.f64(0, "n_pairs")? as u64;
    let aspect = t.f64(0, "max_aspect")?;
    let res: Vec<PairOutcome> = (0..n)
        .into_par_iter()
        .map(|i| {
            let mut rng = ChaCha8Rng::seed_from_u64(seed);
            rng.set_stream(i);
            let mut axes = || [0, 1, 2].map(|_| 10f64.powf(rng.gen_range(0.0..aspect.log10())));
            let (aa, ab) = (axes(), axes());
            let (size, mag, delta) = random_signed_gap(&mut rng, &aa, &ab, -12.0..-3.0);
            let p = make_pair(&mut rng, aa, [2.0; 3], ab, [2.0; 3], delta, 10.0);
            let in_band = mag < 1e-9 * size;
            let (pw_ov, _) = pw_overlap(&p.pose_a, &aa, &p.pose_b, &ab);
            let a = SqBody::new(SqShape::new(aa, [2.0; 3]), p.pose_a);
            let b = SqBody::new(SqShape::new(ab, [2.0; 3]), p.pose_b);
            let scale = a.shape.bounding_radius.max(b.shape.bounding_radius);
            let want = delta < 0.0;
            match crate::contact::contact_superquadric_superquadric(&a, &b, &NrOptions::default()) {
                Ok(c) => (
                    !in_band && pw_ov != want,
                    c.overlap() != want,
                    false,
                    !in_band && pw_ov != c.overlap(),
                    (c.gap - delta).abs() / scale,
                ),
                Err(_) => (!in_band && pw_ov != want, false, true, false, 0.0),
            }
        })
        .collect();
    let count = |f: &dyn Fn(&PairOutcome) -> bool| res.iter().filter(|r| f(r)).count() as f64;
    let worst = res.iter().map(|r| r.4).fold(0.0, f64::max);
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let check = t.str(i, "check")?;
        let got = match check {
            "pw_disagrees_with_prescribed_sign_outside_band" => count(&|r| r.0),
            "nr_disagrees_with_prescribed_sign" => count(&|r| r.1),
            "nr_not_converged" => count(&|r| r.2),
            "pw_disagrees_with_nr_outside_band" => count(&|r| r.3),
            "worst_gap_error" => worst,
            other => return Err(Error::Validation(format!("unknown check '{other}'"))),
        };
        rows.push(Row::new(
            format!("{check} (n={n})"),
            got,
            t.f64(i, "expected")?,
            1.0,
        ));
    }
    Ok(rows)
}

register!("303" => case_303);
/// Case 303 (1e4 pairs, fast).
pub fn case_303(ctx: &CaseContext) -> Result<Vec<Row>> {
    pw_vs_nr(ctx)
}

register!("304" => case_304);
/// Case 304 (1e5 pairs, slow).
pub fn case_304(ctx: &CaseContext) -> Result<Vec<Row>> {
    pw_vs_nr(ctx)
}

fn random_shape(kind: &str, rng: &mut ChaCha8Rng) -> ContactShape {
    let mut s = || rng.gen_range(0.5..2.0);
    match kind {
        "sphere" => ContactShape::Sphere { radius: s() },
        "spherocylinder" => ContactShape::Spherocylinder {
            radius: 0.5 * s(),
            length: s(),
        },
        "ellipsoid" => ContactShape::Ellipsoid {
            semi_axes: [s(), s(), s()],
        },
        _ => ContactShape::Superquadric {
            semi_axes: [s(), s(), s()],
            exponents: [0, 1, 2].map(|_| rng.gen_range(2.0..4.0)),
        },
    }
}

fn size_of(s: &ContactShape) -> f64 {
    match *s {
        ContactShape::Sphere { radius } => radius,
        ContactShape::Spherocylinder { radius, length } => radius + 0.5 * length,
        ContactShape::Ellipsoid { semi_axes } | ContactShape::Superquadric { semi_axes, .. } => {
            semi_axes.iter().cloned().fold(0.0, f64::max)
        }
    }
}

register!("305" => case_305);
/// Case 305.
pub fn case_305(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case.toml needs a seed")?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let pair = t.str(i, "pair")?;
        let law = t.str(i, "law")?;
        let n = t.f64(i, "n_pairs")? as u64;
        let (ka, kb) = pair
            .split_once('-')
            .ok_or_else(|| Error::Validation(format!("bad pair '{pair}'")))?;
        let mut worst: f64 = 0.0;
        let mut where_ = String::new();
        let mut done = 0;
        let mut rng = ChaCha8Rng::seed_from_u64(seed + 1000 * i as u64);
        while done < n {
            let sa = random_shape(ka, &mut rng);
            let sb = random_shape(kb, &mut rng);
            let scale = size_of(&sa).max(size_of(&sb));
            let dir = random_rotation(&mut rng) * Vector3::z();
            let dist = (size_of(&sa) + size_of(&sb)) * rng.gen_range(0.6..1.3);
            let pa = Pose::new(Vector3::zeros(), random_rotation(&mut rng));
            let pb = Pose::new(dist * dir, random_rotation(&mut rng));
            let c = match contact(&sa, &pa, &sb, &pb) {
                Ok(c) => c,
                Err(e) => return Err(Error::Validation(format!("{pair}: {e}"))),
            };
            done += 1;
            let dev = if law == "swap" {
                let s = contact(&sb, &pb, &sa, &pa)?;
                (s.gap - c.gap)
                    .abs()
                    .max((s.normal + c.normal).norm() * scale)
                    .max((s.point_a - c.point_b).norm())
                    .max((s.point_b - c.point_a).norm())
            } else {
                let r = random_rotation(&mut rng);
                let tr = Vector3::new(
                    rng.gen_range(-10.0..10.0),
                    rng.gen_range(-10.0..10.0),
                    rng.gen_range(-10.0..10.0),
                );
                let mv = |p: &Pose| Pose::new(r * p.position + tr, r * p.orientation);
                let m = contact(&sa, &mv(&pa), &sb, &mv(&pb))?;
                (m.gap - c.gap)
                    .abs()
                    .max((m.normal - r * c.normal).norm() * scale)
                    .max((m.point_a - (r * c.point_a + tr)).norm())
                    .max((m.point_b - (r * c.point_b + tr)).norm())
            } / scale;
            if dev > worst {
                worst = dev;
                where_ = format!("gap={:.3e}", c.gap);
            }
        }
        rows.push(Row::new(
            format!("{pair} {law} worst at {where_}"),
            worst,
            t.f64(i, "expected")?,
            1.0,
        ));
    }
    Ok(rows)
}
