//! Helpers shared by the case runners: table checks, the oracle-estimate guard, vector columns
//! and the log-log slope fit.

use crate::validation::{CaseContext, Table};
use crate::{Error, Result};
use nalgebra::Vector3;

/// The vector (t[i, names[0]], t[i, names[1]], t[i, names[2]]).
pub(super) fn v3(t: &Table, i: usize, names: [&str; 3]) -> Result<Vector3<f64>> {
    Ok(Vector3::new(
        t.f64(i, names[0])?,
        t.f64(i, names[1])?,
        t.f64(i, names[2])?,
    ))
}

/// The case's seed from case.toml, or a validation error with the message `missing`.
pub(super) fn required_seed(ctx: &CaseContext, missing: &str) -> Result<u64> {
    ctx.seed.ok_or_else(|| Error::Validation(missing.into()))
}

/// An error naming the table when it has no rows.
pub(super) fn non_empty(t: &Table) -> Result<()> {
    if t.is_empty() {
        return Err(no_rows(t));
    }
    Ok(())
}

/// The error for a table (or a table-derived list) without rows.
pub(super) fn no_rows(t: &Table) -> Error {
    Error::Validation(format!("{}: no rows", t.path().display()))
}

/// Refuses row `i` unless its oracle error estimate `est_rel_err` is at most `limit` (NaN is
/// refused): such a row cannot decide the case. `regen` names the `porelab reference regen`
/// target that rewrites the table.
pub(super) fn check_estimate(t: &Table, i: usize, limit: f64, regen: &str) -> Result<()> {
    let est = t.f64(i, "est_rel_err")?;
    if est.is_nan() || est > limit {
        return Err(Error::Validation(format!(
            "{} line {}: oracle error estimate {est:e} exceeds {limit:e}; the row cannot decide \
             the case (regenerate with `porelab reference regen {regen}`)",
            t.path().display(),
            t.line(i)
        )));
    }
    Ok(())
}

/// Least-squares slope of ln y against ln x.
pub(super) fn loglog_slope(pts: &[(f64, f64)]) -> f64 {
    let n = pts.len() as f64;
    let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for &(x, y) in pts {
        let (x, y) = (x.ln(), y.ln());
        sx += x;
        sy += y;
        sxx += x * x;
        sxy += x * y;
    }
    (n * sxy - sx * sy) / (n * sxx - sx * sx)
}

/// One row per Cartesian component: label "{prefix}x {suffix}" etc., common scale.
pub(super) fn push_components(
    rows: &mut Vec<crate::validation::Row>,
    prefix: &str,
    suffix: &str,
    got: &Vector3<f64>,
    expected: &Vector3<f64>,
    scale: f64,
) {
    for (k, c) in ["x", "y", "z"].iter().enumerate() {
        rows.push(crate::validation::Row::new(
            format!("{prefix}{c} {suffix}"),
            got[k],
            expected[k],
            scale,
        ));
    }
}

/// Rows from measured quantities against the bands of an expected.csv with columns
/// `quantity,lower,upper,source`: `got` is the measured value, `expected` the band centre and
/// `scale` the half-width, so with `rtol = 1`, `atol = 0` a row passes iff the value lies in
/// [lower, upper]. A quantity the table names but the case does not measure is an error.
pub(super) fn band_rows(
    ctx: &CaseContext,
    got: &std::collections::BTreeMap<&str, f64>,
) -> Result<Vec<crate::validation::Row>> {
    let t = ctx.expected_table()?;
    let mut rows = Vec::new();
    for i in 0..t.len() {
        let q = t.str(i, "quantity")?;
        let (lo, hi) = (t.f64(i, "lower")?, t.f64(i, "upper")?);
        if lo.is_nan() || hi.is_nan() || lo > hi {
            return Err(Error::Validation(format!(
                "{} line {}: lower = {lo} above upper = {hi}",
                t.path().display(),
                t.line(i)
            )));
        }
        let v = got.get(q).copied().ok_or_else(|| {
            Error::Validation(format!(
                "{} line {}: quantity `{q}` is not measured by case {} (known: {:?})",
                t.path().display(),
                t.line(i),
                ctx.id,
                got.keys().collect::<Vec<_>>()
            ))
        })?;
        rows.push(crate::validation::Row::new(
            format!("{q} in [{lo}, {hi}]"),
            v,
            0.5 * (lo + hi),
            0.5 * (hi - lo),
        ));
    }
    Ok(rows)
}
