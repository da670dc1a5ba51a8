//! Reports of a validation run: the table on stdout, `validation-report.csv` and `.md`.

use super::harness::{Outcome, Verdict};
use super::spec::Oracle;
use crate::io::plot::{render_svg, Plot, Series};
use crate::{Error, Result};
use std::path::{Path, PathBuf};

pub use crate::io::write_atomic;

fn worst(o: &Outcome) -> String {
    o.stats
        .as_ref()
        .map_or("-".into(), |s| format!("{:.2e}", s.worst_rel))
}

fn rows(o: &Outcome) -> String {
    o.stats.as_ref().map_or("-".into(), |s| s.rows.to_string())
}

fn status(o: &Outcome) -> &'static str {
    o.verdict().as_str()
}

/// `x` with `digits` significant digits, in plain decimals between 1e-3 and 1e5.
fn sig(x: f64, digits: usize) -> String {
    if x == 0.0 || !x.is_finite() {
        return format!("{x}");
    }
    let mag = x.abs().log10().floor() as i32;
    if (-3..5).contains(&mag) {
        let decimals = (digits as i32 - 1 - mag).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits.saturating_sub(1))
    }
}

/// What was checked, as a reader compares it: for literature bands the measured value against
/// the band, for statistical cases the z-score (or value) against its limit, for closed forms
/// and reference tables the worst relative error against the tolerance. Shown for the row
/// nearest to (or furthest beyond) its limit, with the count of rows outside when any are.
pub fn check_text(o: &Outcome) -> String {
    let (Some(s), Some(tol)) = (&o.stats, &o.policy) else {
        return "-".into();
    };
    let Some(r) = &s.worst_row else {
        return "-".into();
    };
    let allowed = tol.allowed(r.scale);
    let inside = (r.got - r.expected).abs() <= allowed;
    let text = match o.oracle {
        Some(Oracle::Literature) => format!(
            "{} {} [{}, {}]",
            sig(r.got, 4),
            if inside { "in" } else { "outside" },
            sig(r.expected - allowed, 4),
            sig(r.expected + allowed, 4)
        ),
        Some(Oracle::Statistical) if r.expected == 0.0 => format!(
            "z {} {} ±{}",
            sig(r.got, 3),
            if inside { "within" } else { "beyond" },
            sig(allowed, 3)
        ),
        Some(Oracle::Statistical) => format!(
            "{} vs {} ±{}",
            sig(r.got, 4),
            sig(r.expected, 4),
            sig(allowed, 3)
        ),
        _ => format!("rel {:.1e} ({})", s.worst_rel, o.tolerance),
    };
    if s.failing > 0 {
        format!("{text}; {} of {} rows out", s.failing, s.rows)
    } else {
        text
    }
}

fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(n - 1).collect();
        t.push('…');
        t
    }
}

/// The plain-text table printed by `porelab validate`, followed by the failure messages.
pub fn text_table(outcomes: &[Outcome]) -> String {
    let head = ["id", "title", "rows", "check", "seconds", "result"];
    let body: Vec<[String; 6]> = outcomes
        .iter()
        .map(|o| {
            [
                o.id.clone(),
                clip(&o.title, 44),
                rows(o),
                clip(&check_text(o), 60),
                format!("{:.2}", o.seconds),
                status(o).to_string(),
            ]
        })
        .collect();
    let mut w = head.map(|h| h.chars().count());
    for r in &body {
        for (i, c) in r.iter().enumerate() {
            w[i] = w[i].max(c.chars().count());
        }
    }
    let line = |cells: &[String]| -> String {
        let mut s = String::new();
        for (i, c) in cells.iter().enumerate() {
            let pad = w[i] - c.chars().count();
            // numbers right-aligned
            if matches!(i, 2 | 4) {
                s += &" ".repeat(pad);
                s += c;
            } else {
                s += c;
                if i + 1 < cells.len() {
                    s += &" ".repeat(pad);
                }
            }
            if i + 1 < cells.len() {
                s += "  ";
            }
        }
        s.trim_end().to_string() + "\n"
    };
    let mut out = line(&head.map(String::from));
    out += &line(&w.map(|n| "-".repeat(n)));
    for r in &body {
        out += &line(r);
    }
    for o in outcomes.iter().filter(|o| !o.passed) {
        match &o.deviation {
            None => {
                out += &format!(
                    "\n{} FAILED: {}\n",
                    o.folder,
                    o.message.as_deref().unwrap_or("")
                )
            }
            Some(why) => {
                out += &format!(
                    "\n{} DEVIATION (documented, not a pass): {}\n  measured: {}\n",
                    o.folder,
                    why,
                    check_text(o)
                )
            }
        }
    }
    for o in outcomes
        .iter()
        .filter(|o| o.passed && o.deviation.is_some())
    {
        out += &format!(
            "\n{} passes although case.toml marks it a deviation: remove the `deviation` key\n",
            o.folder
        );
    }
    out
}

/// The CSV report.
pub fn csv_report(outcomes: &[Outcome]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let err = |e: csv::Error| Error::Validation(format!("writing the CSV report: {e}"));
    w.write_record([
        "id",
        "folder",
        "title",
        "tier",
        "rows",
        "failing_rows",
        "worst_rel_error",
        "worst_rel_row",
        "worst_normalized_error",
        "mean_rel_error",
        "tolerance",
        "check",
        "seconds",
        "result",
        "message",
    ])
    .map_err(err)?;
    for o in outcomes {
        let (rows, failing, wr, wl, wn, mr) = match &o.stats {
            Some(s) => (
                s.rows.to_string(),
                s.failing.to_string(),
                format!("{:e}", s.worst_rel),
                s.worst_rel_label.clone(),
                format!("{:e}", s.worst_norm),
                format!("{:e}", s.mean_rel),
            ),
            None => Default::default(),
        };
        w.write_record([
            o.id.as_str(),
            &o.folder,
            &o.title,
            &o.tier.to_string(),
            &rows,
            &failing,
            &wr,
            &wl,
            &wn,
            &mr,
            &o.tolerance,
            &check_text(o),
            &format!("{:.3}", o.seconds),
            status(o),
            o.deviation
                .as_deref()
                .or(o.message.as_deref())
                .unwrap_or(""),
        ])
        .map_err(err)?;
    }
    w.into_inner()
        .map_err(|e| Error::Validation(format!("writing the CSV report: {e}")))
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// "N of M cases passed" with the failures and documented deviations counted apart.
fn tally(outcomes: &[Outcome]) -> String {
    let count = |v: Verdict| outcomes.iter().filter(|o| o.verdict() == v).count();
    format!(
        "{} of {} cases passed, {} failed, {} documented deviation(s) (not passes).",
        count(Verdict::Pass),
        outcomes.len(),
        count(Verdict::Fail),
        count(Verdict::Deviation)
    )
}

/// The Markdown report.
pub fn md_report(outcomes: &[Outcome]) -> String {
    let mut s = format!(
        "# porelab validation report\n\n{}\n\n| id | title | tier | rows | check | worst rel error | worst row | tolerance | seconds | result |\n|---|---|---|---:|---|---:|---|---|---:|---|\n",
        tally(outcomes)
    );
    for o in outcomes {
        let wl = o
            .stats
            .as_ref()
            .map_or(String::new(), |s| s.worst_rel_label.clone());
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.2} | {} |\n",
            o.id,
            md_cell(&o.title),
            o.tier,
            rows(o),
            md_cell(&check_text(o)),
            worst(o),
            md_cell(&wl),
            o.tolerance,
            o.seconds,
            status(o)
        );
    }
    let failed: Vec<&Outcome> = outcomes.iter().filter(|o| !o.passed).collect();
    if !failed.is_empty() {
        s += "\n## Failures and documented deviations\n";
        for o in failed {
            let why = o
                .deviation
                .as_ref()
                .map_or(String::new(), |d| format!("Documented deviation: {d}\n\n"));
            s += &format!(
                "\n### {} ({})\n\n{why}```\n{}\n```\n",
                o.folder,
                status(o),
                o.message.as_deref().unwrap_or("")
            );
        }
    }
    s
}

/// Every checked number of every case: id, row label (for a band row it names the band),
/// measured value, expected value, scale of the relative tolerance, |got - expected|.
pub fn rows_report(outcomes: &[Outcome]) -> Result<Vec<u8>> {
    let mut w = csv::Writer::from_writer(Vec::new());
    let err = |e: csv::Error| Error::Validation(format!("writing the rows report: {e}"));
    w.write_record(["id", "label", "got", "expected", "scale", "abs_error"])
        .map_err(err)?;
    for o in outcomes {
        for row in &o.rows {
            w.write_record([
                o.id.clone(),
                row.label.clone(),
                format!("{:e}", row.got),
                format!("{:e}", row.expected),
                format!("{:e}", row.scale),
                format!("{:e}", (row.got - row.expected).abs()),
            ])
            .map_err(err)?;
        }
    }
    w.into_inner()
        .map_err(|e| Error::Validation(format!("writing the rows report: {e}")))
}

fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The relative error of every row against its row number, on a log axis (exact rows drawn at
/// 1e-17), for cases whose rows are closed forms, reference tables or convergence runs.
fn error_plot(o: &Outcome) -> Option<String> {
    let exact = matches!(
        o.oracle,
        Some(Oracle::Analytic | Oracle::Reference | Oracle::Convergence)
    );
    if !exact || o.rows.len() < 2 {
        return None;
    }
    let points = o
        .rows
        .iter()
        .enumerate()
        .map(|(i, r)| ((i + 1) as f64, r.rel_error().max(1e-17)))
        .collect();
    let plot = Plot {
        title: String::new(),
        x_label: "row".into(),
        y_label: "relative error".into(),
        log_y: true,
        series: vec![Series {
            label: String::new(),
            points,
            y_err: None,
        }],
        ..Default::default()
    };
    render_svg(&plot, (420, 200)).ok()
}

/// One HTML page, one row per case (verdict coloured, the check as a reader compares it), with
/// the relative error of every row plotted for the closed-form and reference cases.
pub fn html_report(outcomes: &[Outcome]) -> String {
    let mut s = format!(
        "<!DOCTYPE html>\n<html><head><meta charset=\"utf-8\"><title>porelab validation</title>\n<style>body{{font-family:sans-serif;margin:1.5em}}table{{border-collapse:collapse}}td,th{{border:1px solid #ccc;padding:4px 8px;vertical-align:top;font-size:14px}}.PASS{{background:#d8f0d8}}.FAIL{{background:#f6d0d0}}.DEVIATION{{background:#f8ecc8}}details svg{{display:block}}</style></head><body>\n<h1>porelab validation report</h1>\n<p>porelab {} &middot; {}</p>\n<table><tr><th>id</th><th>title</th><th>tier</th><th>oracle</th><th>rows</th><th>check</th><th>seconds</th><th>result</th></tr>\n",
        env!("CARGO_PKG_VERSION"),
        html_escape(&tally(outcomes))
    );
    for o in outcomes {
        let oracle = o
            .oracle
            .map_or("-".to_string(), |x| format!("{x:?}").to_lowercase());
        let mut detail = String::new();
        if let Some(d) = &o.deviation {
            detail += &format!("<br><i>documented deviation: {}</i>", html_escape(d));
        }
        if !o.passed {
            detail += &format!(
                "<br><small>{}</small>",
                html_escape(o.message.as_deref().unwrap_or(""))
            );
        }
        if let Some(svg) = error_plot(o) {
            detail += &format!("<details><summary>error per row</summary>{svg}</details>");
        }
        s += &format!(
            "<tr class=\"{v}\"><td>{}</td><td>{}{detail}</td><td>{}</td><td>{oracle}</td><td>{}</td><td>{}</td><td>{:.2}</td><td>{v}</td></tr>\n",
            o.id,
            html_escape(&o.title),
            o.tier,
            rows(o),
            html_escape(&check_text(o)),
            o.seconds,
            v = status(o)
        );
    }
    s += "</table></body></html>\n";
    s
}

/// Writes `<dir>/validation-report.csv`, `.md`, `.html` and `validation-rows.csv` (every
/// checked number); returns their paths in that order.
pub fn write_reports(dir: &Path, outcomes: &[Outcome]) -> Result<[PathBuf; 4]> {
    let csv = dir.join("validation-report.csv");
    let md = dir.join("validation-report.md");
    let html = dir.join("validation-report.html");
    let rows = dir.join("validation-rows.csv");
    write_atomic(&csv, &csv_report(outcomes)?)?;
    write_atomic(&md, md_report(outcomes).as_bytes())?;
    write_atomic(&html, html_report(outcomes).as_bytes())?;
    write_atomic(&rows, &rows_report(outcomes)?)?;
    Ok([csv, md, html, rows])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validation::spec::Tier;

    fn outcome(passed: bool) -> Outcome {
        Outcome {
            id: "104".into(),
            folder: "104-x".into(),
            title: "a | b".into(),
            tier: Tier::Fast,
            tolerance: "rtol=1e-12".into(),
            stats: None,
            seconds: 0.5,
            passed,
            message: (!passed).then(|| "bad, \"row\"\nline2".to_string()),
            rows: vec![crate::validation::Row::new("x in [0, 1]", 0.25, 0.5, 1.0)],
            oracle: Some(Oracle::Literature),
            policy: Some(crate::validation::Tolerance::new(Some(0.5), None, None)),
            deviation: None,
        }
    }

    #[test]
    fn reports_render_and_write() {
        let os = vec![outcome(true), outcome(false)];
        let t = text_table(&os);
        assert!(
            t.contains("PASS") && t.contains("FAIL") && t.contains("104-x FAILED"),
            "{t}"
        );
        let md = md_report(&os);
        assert!(
            md.contains("1 of 2 cases passed") && md.contains("a \\| b"),
            "{md}"
        );
        let dir = std::env::temp_dir().join(format!("porelab-report-{}", std::process::id()));
        let [c, m, h, rows_path] = write_reports(&dir.join("sub"), &os).unwrap();
        assert!(std::fs::read_to_string(&h)
            .unwrap()
            .contains("<td>104</td>"));
        let t = crate::validation::Table::read(&c).unwrap();
        assert_eq!(t.len(), 2);
        assert_eq!(t.str(1, "message").unwrap(), "bad, \"row\"\nline2");
        assert!(m.is_file());
        let rows = crate::validation::Table::read(&rows_path).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows.f64(0, "got").unwrap(), 0.25);
        assert_eq!(rows.f64(1, "abs_error").unwrap(), 0.25);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn bands_show_the_measured_value_and_deviations_are_not_passes() {
        // got 0.25 against expected 0.5 with rtol 0.5 on scale 1: the band is [0, 1].
        let mut o = outcome(false);
        o.stats = Some(crate::validation::evaluate(
            &o.rows,
            o.policy.as_ref().unwrap(),
        ));
        assert_eq!(check_text(&o), "0.2500 in [0, 1.000]");
        o.policy = Some(crate::validation::Tolerance::new(Some(0.1), None, None));
        o.stats = Some(crate::validation::evaluate(
            &o.rows,
            o.policy.as_ref().unwrap(),
        ));
        assert_eq!(
            check_text(&o),
            "0.2500 outside [0.4000, 0.6000]; 1 of 1 rows out"
        );
        o.deviation = Some("ridge creep at T = 0".into());
        assert_eq!(o.verdict(), Verdict::Deviation);
        assert!(!o.fails_run());
        let t = text_table(&[o.clone()]);
        assert!(
            t.contains("DEVIATION (documented, not a pass): ridge creep"),
            "{t}"
        );
        assert!(tally(&[o]).contains("0 of 1 cases passed, 0 failed, 1 documented"));
        assert_eq!(sig(1.23456e-7, 3), "1.23e-7");
        assert_eq!(sig(0.012345, 3), "0.0123");
    }
}
