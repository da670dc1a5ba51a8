//! Reports of a validation run: the table on stdout, `validation-report.csv` and `.md`.

use super::harness::Outcome;
use crate::{Error, Result};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Writes `bytes` to `path` atomically: a temporary file in the same folder, then a rename.
/// Creates the parent folders.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| Error::File {
        path: dir.display().to_string(),
        msg: e.to_string(),
    })?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    let tmp = dir.join(format!(".{name}.tmp-{}-{k}", std::process::id()));
    let res = std::fs::write(&tmp, bytes).and_then(|_| std::fs::rename(&tmp, path));
    if let Err(e) = res {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::File {
            path: path.display().to_string(),
            msg: e.to_string(),
        });
    }
    Ok(())
}

fn worst(o: &Outcome) -> String {
    o.stats
        .as_ref()
        .map_or("-".into(), |s| format!("{:.2e}", s.worst_rel))
}

fn rows(o: &Outcome) -> String {
    o.stats.as_ref().map_or("-".into(), |s| s.rows.to_string())
}

fn status(o: &Outcome) -> &'static str {
    if o.passed {
        "PASS"
    } else {
        "FAIL"
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
    let head = [
        "id",
        "title",
        "rows",
        "worst rel",
        "tolerance",
        "seconds",
        "result",
    ];
    let body: Vec<[String; 7]> = outcomes
        .iter()
        .map(|o| {
            [
                o.id.clone(),
                clip(&o.title, 48),
                rows(o),
                worst(o),
                o.tolerance.clone(),
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
            if matches!(i, 2 | 3 | 5) {
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
        out += &format!(
            "\n{} FAILED: {}\n",
            o.folder,
            o.message.as_deref().unwrap_or("")
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
            &format!("{:.3}", o.seconds),
            status(o),
            o.message.as_deref().unwrap_or(""),
        ])
        .map_err(err)?;
    }
    w.into_inner()
        .map_err(|e| Error::Validation(format!("writing the CSV report: {e}")))
}

fn md_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// The Markdown report.
pub fn md_report(outcomes: &[Outcome]) -> String {
    let pass = outcomes.iter().filter(|o| o.passed).count();
    let mut s = format!(
        "# porelab validation report\n\n{pass} of {} cases passed.\n\n| id | title | tier | rows | worst rel error | worst row | tolerance | seconds | result |\n|---|---|---|---:|---:|---|---|---:|---|\n",
        outcomes.len()
    );
    for o in outcomes {
        let wl = o
            .stats
            .as_ref()
            .map_or(String::new(), |s| s.worst_rel_label.clone());
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} | {:.2} | {} |\n",
            o.id,
            md_cell(&o.title),
            o.tier,
            rows(o),
            worst(o),
            md_cell(&wl),
            o.tolerance,
            o.seconds,
            status(o)
        );
    }
    let failed: Vec<&Outcome> = outcomes.iter().filter(|o| !o.passed).collect();
    if !failed.is_empty() {
        s += "\n## Failures\n";
        for o in failed {
            s += &format!(
                "\n### {}\n\n```\n{}\n```\n",
                o.folder,
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

/// Writes `<dir>/validation-report.csv`, `.md` and `validation-rows.csv` (every checked
/// number); returns their paths in that order.
pub fn write_reports(dir: &Path, outcomes: &[Outcome]) -> Result<[PathBuf; 3]> {
    let csv = dir.join("validation-report.csv");
    let md = dir.join("validation-report.md");
    let rows = dir.join("validation-rows.csv");
    write_atomic(&csv, &csv_report(outcomes)?)?;
    write_atomic(&md, md_report(outcomes).as_bytes())?;
    write_atomic(&rows, &rows_report(outcomes)?)?;
    Ok([csv, md, rows])
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
        let [c, m, rows_path] = write_reports(&dir.join("sub"), &os).unwrap();
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
}
