//! Cases 901, 902 and 910-914: end-to-end reproductions of the trends of seed 000 (Vidal, Zou &
//! Uesaka 2004), Figs. 3-7 and 14, as ensembles of deposition runs. Each point of a case is
//! a row of its `expected.csv` (the inputs of a scene); the trend tests are fixed in the case
//! notes before measuring and expressed as bands on z-scores, rank correlations or the location
//! of an extremum.

use super::common::required_seed;
use crate::deposition::measure::DepositMeasures;
use crate::driver::NoHooks;
use crate::validation::Table;
use crate::validation::{CaseContext, Row};
use crate::{Error, Result};

/// The mean and standard error over the runs of one point.
#[derive(Debug, Clone, Copy)]
struct PointStats {
    mean: f64,
    standard_error: f64,
}

impl PointStats {
    /// (self - other) in units of the combined standard error.
    fn z_above(&self, other: &PointStats) -> f64 {
        (self.mean - other.mean)
            / (self.standard_error.powi(2) + other.standard_error.powi(2)).sqrt()
    }
}

/// Runs the scene `text` (`runs` independent runs, in parallel) and returns the mean and
/// standard error of `measure` over the runs.
fn ensemble_point(
    id: &str,
    text: &str,
    measure: fn(&DepositMeasures) -> f64,
) -> Result<PointStats> {
    use rayon::prelude::*;
    let scene = crate::scene::deposition::parse_scene(text, id)?;
    if scene.runs < 2 {
        return Err(Error::Validation(format!(
            "case {id}: a trend point needs at least 2 runs for its standard error"
        )));
    }
    let values: Vec<f64> = (0..scene.runs)
        .into_par_iter()
        .map(|k| {
            let d = crate::deposition::driver::run_one(&scene.setup, k, &mut NoHooks)?;
            let m = crate::deposition::measure::measure(
                &d.layer,
                scene.setup.species.len(),
                &scene.measure,
            )?;
            Ok(measure(&m))
        })
        .collect::<Result<_>>()?;
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let var = values.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    Ok(PointStats {
        mean,
        standard_error: (var / n).sqrt(),
    })
}

fn layer_porosity(m: &DepositMeasures) -> f64 {
    m.layer_porosity
}

fn rms_roughness(m: &DepositMeasures) -> f64 {
    m.rms_roughness_m
}

/// A band row "at least three combined standard errors" ([3, 1003]).
fn rise_row(label: String, z: f64) -> Row {
    Row::new(label, z, 503.0, 500.0)
}

register!("901", "902" => case_901_902);
/// Cases 901 and 902: seed 000 Figs. 3 and 5, platelets of fixed diameter and needles of fixed
/// length (the table's `shape`): the layer porosity falls from aspect ratio 1 to a minimum and
/// rises again. Rows: the aspect ratio of the minimum of the mean porosity (band), and the
/// rise from the minimum to the largest aspect ratio and to aspect 1, each in units of its
/// standard error (band from 3 up).
pub fn case_901_902(ctx: &CaseContext) -> Result<Vec<Row>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, "case 901 needs a seed")?;
    let mut points = Vec::new();
    for i in 0..t.len() {
        let ar = t.f64(i, "aspect_ratio")?;
        let a = t.f64(i, "diameter_m")? / 2.0;
        let axes = match t.str(i, "shape")? {
            "platelet" => format!("[{a}, {a}, {}]", a / ar),
            "needle" => format!("[{a}, {}, {}]", a / ar, a / ar),
            o => return Err(Error::Validation(format!("unknown shape `{o}`"))),
        };
        let text = format!(
            "kind = \"deposition\"\nseed = {}\nruns = {}\n[film]\nparticles = {}\n\
             solids_percent = {}\n[[species]]\nname = \"p\"\nsemi_axes_m = {axes}\n",
            seed + i as u64,
            t.f64(i, "runs")? as usize,
            t.f64(i, "particles")? as usize,
            t.f64(i, "solids_percent")?,
        );
        points.push((ar, ensemble_point(&ctx.id, &text, layer_porosity)?));
    }
    let (ar_min, p_min) = points
        .iter()
        .copied()
        .min_by(|a, b| a.1.mean.total_cmp(&b.1.mean))
        .expect("non-empty table");
    let list: Vec<String> = points
        .iter()
        .map(|(a, p)| format!("{a}: {:.4}+-{:.4}", p.mean, p.standard_error))
        .collect();
    let mut rows = vec![Row::new(
        format!("aspect ratio of the minimum ({})", list.join(", ")),
        ar_min,
        1.65,
        0.35,
    )];
    let last = points.len() - 1;
    for k in [last, 0] {
        rows.push(rise_row(
            format!("rise from the minimum to aspect {} (z)", points[k].0),
            points[k].1.z_above(&p_min),
        ));
    }
    Ok(rows)
}

/// One row of a figure table: series label, abscissa and the scene it runs.
struct FigurePoint {
    series: String,
    x: f64,
    stats: PointStats,
}

/// The scene of row `i` of a figure table with columns `series,x,solids_percent,particles,runs,
/// species`, where `species` lists `name:a:b:c:volume_ratio` items (semi-axes in m) separated
/// by `;`. Row i draws from seed + i.
fn figure_scene(t: &Table, i: usize, seed: u64) -> Result<String> {
    let mut text = format!(
        "kind = \"deposition\"\nseed = {}\nruns = {}\n[film]\nparticles = {}\n\
         solids_percent = {}\n",
        seed + i as u64,
        t.f64(i, "runs")? as usize,
        t.f64(i, "particles")? as usize,
        t.f64(i, "solids_percent")?,
    );
    for item in t.str(i, "species")?.split(';') {
        let f: Vec<&str> = item.trim().split(':').collect();
        let bad = || {
            Error::Validation(format!(
                "row {i}: species item `{item}` is not name:a:b:c:volume_ratio"
            ))
        };
        if f.len() != 5 {
            return Err(bad());
        }
        let num = |s: &str| s.parse::<f64>().map_err(|_| bad());
        text.push_str(&format!(
            "[[species]]\nname = \"{}\"\nsemi_axes_m = [{}, {}, {}]\nvolume_ratio = {}\n",
            f[0],
            num(f[1])?,
            num(f[2])?,
            num(f[3])?,
            num(f[4])?
        ));
    }
    Ok(text)
}

/// Runs every row of a figure table and measures `measure` at each.
fn figure_points(
    ctx: &CaseContext,
    measure: fn(&DepositMeasures) -> f64,
) -> Result<Vec<FigurePoint>> {
    let t = ctx.expected_table()?;
    let seed = required_seed(ctx, &format!("case {} needs a seed", ctx.id))?;
    (0..t.len())
        .map(|i| {
            let text = figure_scene(&t, i, seed)?;
            Ok(FigurePoint {
                series: t.str(i, "series")?.to_string(),
                x: t.f64(i, "x")?,
                stats: ensemble_point(&ctx.id, &text, measure)?,
            })
        })
        .collect()
}

/// The point of `series` at abscissa `x`.
fn point<'a>(points: &'a [FigurePoint], series: &str, x: f64) -> Result<&'a FigurePoint> {
    points
        .iter()
        .find(|p| p.series == series && p.x == x)
        .ok_or_else(|| Error::Validation(format!("no point for series {series} at x = {x}")))
}

fn listing(points: &[FigurePoint], scale: f64) -> String {
    points
        .iter()
        .map(|p| {
            format!(
                "{} x={}: {:.4}+-{:.4}",
                p.series,
                p.x,
                p.stats.mean * scale,
                p.stats.standard_error * scale
            )
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Spearman's rank correlation of two equal-length samples (average ranks for ties).
pub(super) fn spearman(x: &[f64], y: &[f64]) -> f64 {
    fn ranks(v: &[f64]) -> Vec<f64> {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let mut r = vec![0.0; v.len()];
        let mut i = 0;
        while i < idx.len() {
            let mut j = i;
            while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
                j += 1;
            }
            let avg = (i + j) as f64 / 2.0 + 1.0;
            for &k in &idx[i..=j] {
                r[k] = avg;
            }
            i = j + 1;
        }
        r
    }
    let (rx, ry) = (ranks(x), ranks(y));
    let n = x.len() as f64;
    let mean = (n + 1.0) / 2.0;
    let cov: f64 = rx
        .iter()
        .zip(&ry)
        .map(|(a, b)| (a - mean) * (b - mean))
        .sum();
    let var = |r: &[f64]| r.iter().map(|a| (a - mean).powi(2)).sum::<f64>();
    cov / (var(&rx) * var(&ry)).sqrt()
}

/// One-sided 5 % critical values of Spearman's rank correlation for n = 5..10 points (Zar,
/// J. Am. Stat. Assoc. 67, 578 (1972), Table 1).
pub(super) fn spearman_critical_5_percent(n: usize) -> Result<f64> {
    const TABLE: [(usize, f64); 6] = [
        (5, 0.900),
        (6, 0.829),
        (7, 0.714),
        (8, 0.643),
        (9, 0.600),
        (10, 0.564),
    ];
    TABLE
        .iter()
        .find(|(k, _)| *k == n)
        .map(|&(_, c)| c)
        .ok_or_else(|| Error::Validation(format!("no Spearman critical value for {n} points")))
}

register!("910", "914" => case_910_914);
/// Cases 910 and 914: seed 000 Figs. 4 and 6, the RMS roughness of platelets (910) or needles
/// (914) at high solids falls with the aspect ratio. Rows: Spearman's rank correlation of the
/// mean roughness with the aspect ratio, at most minus the one-sided 5 % critical value c for
/// the number of points (since rho >= -1 the band is written [-1 - c, -c], so that rho = -1,
/// a perfectly monotone fall, lies inside it rather than on a rounded edge), and the fall
/// from the first to the last aspect ratio in combined standard errors (band from 3 up).
pub fn case_910_914(ctx: &CaseContext) -> Result<Vec<Row>> {
    let points = figure_points(ctx, rms_roughness)?;
    let x: Vec<f64> = points.iter().map(|p| p.x).collect();
    let y: Vec<f64> = points.iter().map(|p| p.stats.mean).collect();
    let rho = spearman(&x, &y);
    let c = spearman_critical_5_percent(points.len())?;
    let first = &points[0];
    let last = &points[points.len() - 1];
    Ok(vec![
        Row::new(
            format!(
                "Spearman rank correlation of roughness with aspect ratio (roughness in nm: {})",
                listing(&points, 1e9)
            ),
            rho,
            -c - 0.5,
            0.5,
        ),
        rise_row(
            format!(
                "fall of roughness from aspect {} to aspect {} (z)",
                first.x, last.x
            ),
            first.stats.z_above(&last.stats),
        ),
    ])
}

register!("911" => case_911);
/// Case 911: seed 000 Fig. 3 text, platelets of aspect ratio 5-20 deposit more porous layers
/// from a 45 % solids colour than from a 60 % one. Series = aspect ratio, x = solids content;
/// one row per aspect ratio: the porosity at 45 % above that at 60 % (z, band from 3 up).
pub fn case_911(ctx: &CaseContext) -> Result<Vec<Row>> {
    let points = figure_points(ctx, layer_porosity)?;
    let mut series: Vec<&str> = points.iter().map(|p| p.series.as_str()).collect();
    series.dedup();
    series
        .iter()
        .map(|s| {
            let (low, high) = (point(&points, s, 45.0)?, point(&points, s, 60.0)?);
            Ok(rise_row(
                format!(
                    "aspect {s}: layer porosity at 45 % ({:.4}+-{:.4}) above 60 % ({:.4}+-{:.4}) (z)",
                    low.stats.mean,
                    low.stats.standard_error,
                    high.stats.mean,
                    high.stats.standard_error
                ),
                low.stats.z_above(&high.stats),
            ))
        })
        .collect()
}

register!("912" => case_912);
/// Case 912: seed 000 Fig. 7, clay platelets of aspect 10 blended with carbonate needles: the
/// layer porosity has a maximum at a clay volume share between 30 % and 50 %. Rows: the share
/// of the maximum of the mean porosity (band [30, 50]), and the maximum above each pure
/// pigment (z, band from 3 up).
pub fn case_912(ctx: &CaseContext) -> Result<Vec<Row>> {
    let points = figure_points(ctx, layer_porosity)?;
    let best = points
        .iter()
        .max_by(|a, b| a.stats.mean.total_cmp(&b.stats.mean))
        .expect("non-empty table");
    let mut rows = vec![Row::new(
        format!(
            "clay volume % of the maximum porosity ({})",
            listing(&points, 1.0)
        ),
        best.x,
        40.0,
        10.0,
    )];
    for end in [0.0, 100.0] {
        let e = point(&points, &best.series, end)?;
        rows.push(rise_row(
            format!("maximum above the {end} % clay layer (z)"),
            best.stats.z_above(&e.stats),
        ));
    }
    Ok(rows)
}

register!("913" => case_913);
/// Case 913: seed 000 Fig. 14, clay platelets blended with spheres: a larger platelet/sphere
/// volume ratio gives a more porous layer. Series = volume ratio (`1` and `8`), x = clay volume
/// share; one row per share: porosity at ratio 8 above that at ratio 1 (z, band from 3 up).
pub fn case_913(ctx: &CaseContext) -> Result<Vec<Row>> {
    let points = figure_points(ctx, layer_porosity)?;
    let mut shares: Vec<f64> = points.iter().map(|p| p.x).collect();
    shares.sort_by(f64::total_cmp);
    shares.dedup();
    shares
        .iter()
        .map(|&x| {
            let (small, large) = (point(&points, "1", x)?, point(&points, "8", x)?);
            Ok(rise_row(
                format!(
                    "clay {x} %: porosity at volume ratio 8 ({:.4}+-{:.4}) above ratio 1 \
                     ({:.4}+-{:.4}) (z)",
                    large.stats.mean,
                    large.stats.standard_error,
                    small.stats.mean,
                    small.stats.standard_error
                ),
                large.stats.z_above(&small.stats),
            ))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::spearman;

    #[test]
    fn spearman_of_monotone_and_reversed_samples() {
        let x = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(spearman(&x, &[10.0, 20.0, 25.0, 40.0, 100.0]), 1.0);
        assert_eq!(spearman(&x, &[5.0, 4.0, 3.0, 2.0, 1.0]), -1.0);
        // Textbook example: d = (0, -1, 1, 0, 0), rho = 1 - 6 * 2 / (5 * 24) = 0.9.
        let rho = spearman(&x, &[1.0, 3.0, 2.0, 4.0, 5.0]);
        assert!((rho - 0.9).abs() < 1e-15, "{rho}");
    }
}
