//! The plots of `porelab sweep collect`: one SVG per collected quantity against the first
//! varied key, one series per combination of the other varied keys, error bars of one
//! standard error. Axis labels carry the unit that the key's name ends in (`radius_m` ->
//! "radius (m)", the project's convention of units in names); the legend gives the number of
//! runs per point.

use super::collect::Collected;
use crate::error::Result;
use crate::io::plot::{write_svg, Plot, Series};
use std::path::Path;

/// A file name for quantity `q` (dots and other punctuation as `_`).
fn file_stem(q: &str) -> String {
    q.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Unit suffixes of key names, longest first, and the unit they name.
const UNITS: [(&str, &str); 24] = [
    ("_a_per_m", "A/m"),
    ("_m_per_s", "m/s"),
    ("_m_s2", "m/s^2"),
    ("_m2_s", "m^2/s"),
    ("_kg_m3", "kg/m^3"),
    ("_pa_m", "Pa/m"),
    ("_pa_s", "Pa s"),
    ("_n_per_m", "N/m"),
    ("_m_s", "m/s"),
    ("_a_m2", "A m^2"),
    ("_m2", "m^2"),
    ("_m3", "m^3"),
    ("_deg", "degree"),
    ("_rad", "rad"),
    ("_pa", "Pa"),
    ("_kg", "kg"),
    ("_j", "J"),
    ("_n", "N"),
    ("_t", "T"),
    ("_k", "K"),
    ("_s", "s"),
    ("_m", "m"),
    ("_um", "um"),
    ("_d", "particle diameters"),
];

/// An axis label for a dotted key: its segments joined by spaces, the unit in parentheses
/// when the last segment ends in one (case-insensitive), else "(1)" for a count or ratio.
pub fn axis_label(key: &str) -> String {
    let last = key.rsplit('.').next().unwrap_or(key);
    let lower = last.to_ascii_lowercase();
    let (name, unit) = UNITS
        .iter()
        .find(|(suffix, _)| lower.len() > suffix.len() && lower.ends_with(suffix))
        .map(|(suffix, unit)| (&last[..last.len() - suffix.len()], *unit))
        .unwrap_or((last, "1"));
    let mut words: Vec<&str> = key.split('.').collect();
    words.pop();
    words.push(name);
    format!("{} ({unit})", words.join(" ").replace('_', " "))
}

/// "n = 3 runs per point" or "n = 2 to 3 runs per point" over `counts`.
fn runs_note(counts: &[usize]) -> String {
    let lo = counts.iter().copied().min().unwrap_or(0);
    let hi = counts.iter().copied().max().unwrap_or(0);
    if lo == hi {
        format!("n = {lo} runs per point")
    } else {
        format!("n = {lo} to {hi} runs per point")
    }
}

/// Writes `DIR/plots/<quantity>.svg` for every quantity with at least one mean; returns how
/// many. No plot when nothing is varied, or when the first varied key is not a number.
pub fn write_plots(dir: &Path, c: &Collected) -> Result<usize> {
    let Some(x_key) = c.keys.first() else {
        return Ok(0);
    };
    let xs: Option<Vec<f64>> = c.rows.iter().map(|r| r.values[0].parse().ok()).collect();
    let Some(xs) = xs else {
        eprintln!("  no plots: the first varied key {x_key} is not numeric");
        return Ok(0);
    };
    // The series: rows that share the values of every other varied key, in point order.
    let mut groups: Vec<(String, Vec<usize>)> = Vec::new();
    for (i, r) in c.rows.iter().enumerate() {
        let label = c.keys[1..]
            .iter()
            .zip(&r.values[1..])
            .map(|(k, v)| format!("{k} = {v}"))
            .collect::<Vec<_>>()
            .join(", ");
        match groups.iter_mut().find(|(l, _)| *l == label) {
            Some((_, rows)) => rows.push(i),
            None => groups.push((label, vec![i])),
        }
    }
    let mut written = 0;
    for q in &c.quantities {
        let series: Vec<Series> = groups
            .iter()
            .map(|(label, rows)| {
                let with: Vec<(f64, f64, f64, usize)> = rows
                    .iter()
                    .filter_map(|&i| {
                        let (m, s, n) = c.rows[i].stats.get(q)?;
                        Some((xs[i], *m, s.unwrap_or(0.0), *n))
                    })
                    .collect();
                let n: Vec<usize> = with.iter().map(|p| p.3).collect();
                Series {
                    label: if label.is_empty() {
                        format!("mean, bars: one standard error; {}", runs_note(&n))
                    } else {
                        format!("{label}; {}", runs_note(&n))
                    },
                    points: with.iter().map(|&(x, y, _, _)| (x, y)).collect(),
                    y_err: Some(with.iter().map(|p| p.2).collect()),
                }
            })
            .filter(|s| !s.points.is_empty())
            .collect();
        if series.is_empty() {
            continue;
        }
        let plot = Plot {
            title: format!("{q} against {x_key}"),
            x_label: axis_label(x_key),
            y_label: axis_label(q),
            log_x: false,
            log_y: false,
            series,
        };
        write_svg(
            &dir.join("plots").join(format!("{}.svg", file_stem(q))),
            &plot,
        )?;
        written += 1;
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn axis_labels_carry_the_unit_of_the_key_name() {
        assert_eq!(axis_label("particles.radius_m"), "particles radius (m)");
        assert_eq!(axis_label("fluid.viscosity_pa_s"), "fluid viscosity (Pa s)");
        assert_eq!(
            axis_label("drivers.gravity_m_s2"),
            "drivers gravity (m/s^2)"
        );
        assert_eq!(axis_label("seconds"), "seconds (1)");
        assert_eq!(axis_label("particles.n"), "particles n (1)");
        assert_eq!(axis_label("packing_fraction"), "packing fraction (1)");
        assert_eq!(axis_label("bed_top_m"), "bed top (m)");
        assert_eq!(axis_label("temperature_K"), "temperature (K)");
        assert_eq!(runs_note(&[3, 3]), "n = 3 runs per point");
        assert_eq!(runs_note(&[2, 3]), "n = 2 to 3 runs per point");
    }
}
