//! The plots of `porelab sweep collect`: one SVG per collected quantity against the first
//! varied key, one series per combination of the other varied keys, error bars of one
//! standard error.

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
                let with: Vec<(f64, f64, f64)> = rows
                    .iter()
                    .filter_map(|&i| {
                        let (m, s, _) = c.rows[i].stats.get(q)?;
                        Some((xs[i], *m, s.unwrap_or(0.0)))
                    })
                    .collect();
                Series {
                    label: if label.is_empty() {
                        "mean, bars: one standard error".into()
                    } else {
                        label.clone()
                    },
                    points: with.iter().map(|&(x, y, _)| (x, y)).collect(),
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
            x_label: x_key.clone(),
            y_label: q.clone(),
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
