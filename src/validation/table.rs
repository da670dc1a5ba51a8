//! CSV tables for case runners: a header row (units in the column names) and string cells.
//!
//! Lines starting with `#` are comments (provenance notes in `reference/` tables); cells and
//! headers are trimmed. Every error names the file, the line and the column.
//!
//! ```no_run
//! # use porelab::validation::{CaseContext, Row};
//! # fn run(ctx: &CaseContext) -> porelab::Result<Vec<Row>> {
//! let t = ctx.expected_table()?;
//! let mut rows = Vec::new();
//! for i in 0..t.len() {
//!     let x = t.f64(i, "x_m")?;
//!     let hz = t.f64(i, "Hz_A_per_m")?;
//!     rows.push(Row::new(format!("x={x}"), hz, hz, hz.abs()));
//! }
//! # Ok(rows) }
//! ```

use super::case::CaseContext;
use crate::{Error, Result};
use std::path::{Path, PathBuf};

/// A CSV table read whole into memory.
#[derive(Debug, Clone)]
pub struct Table {
    path: PathBuf,
    headers: Vec<String>,
    rows: Vec<Vec<String>>,
    /// 1-based line number in the file of every data row.
    lines: Vec<u64>,
}

fn file_err(path: &Path, msg: impl Into<String>) -> Error {
    Error::File {
        path: path.display().to_string(),
        msg: msg.into(),
    }
}

impl Table {
    /// Reads a CSV file with a header row. Comment lines start with `#`.
    pub fn read(path: impl AsRef<Path>) -> Result<Table> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|e| file_err(path, e.to_string()))?;
        Table::from_bytes(&bytes, path)
    }

    /// Parses CSV text; `path` is only used in messages.
    pub fn parse(text: &str, path: impl AsRef<Path>) -> Result<Table> {
        Table::from_bytes(text.as_bytes(), path.as_ref())
    }

    fn from_bytes(bytes: &[u8], path: &Path) -> Result<Table> {
        // 1-based line of the record starting at `byte`: the csv crate reports the start of
        // any comment or blank lines before the record, so skip those.
        let line_of = |byte: u64| -> u64 {
            let mut b = (byte as usize).min(bytes.len());
            while b < bytes.len() && matches!(bytes[b], b'#' | b'\n' | b'\r') {
                match bytes[b..].iter().position(|&c| c == b'\n') {
                    Some(k) => b += k + 1,
                    None => break,
                }
            }
            1 + bytes[..b].iter().filter(|&&c| c == b'\n').count() as u64
        };
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .comment(Some(b'#'))
            .trim(csv::Trim::All)
            .flexible(true)
            .from_reader(bytes);
        let headers: Vec<String> = rdr
            .headers()
            .map_err(|e| file_err(path, format!("header: {e}")))?
            .iter()
            .map(|h| h.to_string())
            .collect();
        if headers.is_empty() || headers.iter().all(|h| h.is_empty()) {
            return Err(file_err(path, "no header row"));
        }
        for (i, h) in headers.iter().enumerate() {
            if h.is_empty() {
                return Err(file_err(path, format!("header column {} is empty", i + 1)));
            }
            if headers[..i].contains(h) {
                return Err(file_err(path, format!("header column '{h}' appears twice")));
            }
        }
        let mut rows = Vec::new();
        let mut lines = Vec::new();
        for rec in rdr.records() {
            let rec = rec.map_err(|e| file_err(path, e.to_string()))?;
            let line = rec.position().map_or(0, |p| line_of(p.byte()));
            if rec.len() != headers.len() {
                return Err(file_err(
                    path,
                    format!(
                        "line {line}: {} cells, but the header has {} columns",
                        rec.len(),
                        headers.len()
                    ),
                ));
            }
            lines.push(line);
            rows.push(rec.iter().map(|c| c.to_string()).collect());
        }
        Ok(Table {
            path: path.to_path_buf(),
            headers,
            rows,
            lines,
        })
    }

    /// The file this table was read from.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The column names, as written in the header row.
    pub fn headers(&self) -> &[String] {
        &self.headers
    }

    /// Number of data rows (the header is not counted).
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }

    /// 1-based line number of data row `row` in the file.
    pub fn line(&self, row: usize) -> u64 {
        self.lines.get(row).copied().unwrap_or(0)
    }

    /// Index of column `name`: the exact header; else the only header equal to `name` ignoring
    /// case; else the only header whose name without a unit suffix (`"Hz [A/m]"`, `"Hz(A/m)"`)
    /// equals `name` ignoring case.
    pub fn col(&self, name: &str) -> Result<usize> {
        if let Some(i) = self.headers.iter().position(|h| h == name) {
            return Ok(i);
        }
        // Fallbacks, each used only when it identifies one column: the same name ignoring
        // case, then the name without a unit suffix (ignoring case).
        let base = |h: &str| -> String {
            h.split(['[', '('])
                .next()
                .unwrap_or(h)
                .trim()
                .to_lowercase()
        };
        let lname = name.to_lowercase();
        for key in [|h: &str| h.to_lowercase(), base] {
            let hits: Vec<usize> = (0..self.headers.len())
                .filter(|&i| key(&self.headers[i]) == lname)
                .collect();
            if hits.len() == 1 {
                return Ok(hits[0]);
            }
        }
        Err(file_err(
            &self.path,
            format!("no column '{name}' (columns: {})", self.headers.join(", ")),
        ))
    }

    /// Cell (`row`, column `name`) as text.
    pub fn str(&self, row: usize, name: &str) -> Result<&str> {
        let c = self.col(name)?;
        let r = self.rows.get(row).ok_or_else(|| {
            file_err(
                &self.path,
                format!(
                    "row {row} out of range (the table has {} data rows)",
                    self.len()
                ),
            )
        })?;
        Ok(r[c].as_str())
    }

    /// Cell (`row`, column `name`) as a number. NaN and empty cells are errors naming the
    /// file, line and column; `inf` is accepted.
    pub fn f64(&self, row: usize, name: &str) -> Result<f64> {
        let s = self.str(row, name)?;
        let line = self.line(row);
        if s.is_empty() {
            return Err(file_err(
                &self.path,
                format!("line {line}, column '{name}': empty cell"),
            ));
        }
        match s.parse::<f64>() {
            Ok(v) if v.is_nan() => Err(file_err(
                &self.path,
                format!("line {line}, column '{name}': NaN is not a value"),
            )),
            Ok(v) => Ok(v),
            Err(_) => Err(file_err(
                &self.path,
                format!("line {line}, column '{name}': cannot read '{s}' as a number"),
            )),
        }
    }

    /// A whole column as numbers.
    pub fn f64_col(&self, name: &str) -> Result<Vec<f64>> {
        (0..self.len()).map(|i| self.f64(i, name)).collect()
    }
}

impl CaseContext {
    /// Where a table named in a case lives: `reference/...` is relative to the repository
    /// root, anything else to the case folder.
    pub fn resolve(&self, rel: &str) -> PathBuf {
        resolve_table_path(&self.case_dir, &self.repo_root, rel)
    }

    /// Path of the case's expected table.
    pub fn expected_path(&self) -> PathBuf {
        self.resolve(&self.expected)
    }

    /// The case's expected table (`expected` in case.toml), refused when it has no data rows:
    /// every runner opens with it.
    pub fn expected_table(&self) -> Result<Table> {
        let t = Table::read(self.expected_path())?;
        if t.is_empty() {
            return Err(crate::Error::Validation(format!(
                "case {}: {} has a header but no data rows",
                self.id,
                t.path().display()
            )));
        }
        Ok(t)
    }

    /// Another table of the case, resolved like `expected`.
    pub fn table(&self, rel_path: &str) -> Result<Table> {
        Table::read(self.resolve(rel_path))
    }
}

/// `reference/...` (or `./reference/...`) resolves against the repository root, anything
/// else against the case folder.
pub fn resolve_table_path(case_dir: &Path, repo_root: &Path, rel: &str) -> PathBuf {
    let p = Path::new(rel);
    let p = p.strip_prefix(".").unwrap_or(p);
    if p.is_absolute() {
        p.to_path_buf()
    } else if p.starts_with("reference") {
        repo_root.join(p)
    } else {
        case_dir.join(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const CSV: &str = "# provenance: test\nx_m, Hz [A/m], note\n1.0, 2.5, a\n# comment\n2.0, bad, b\n3.0, nan, c\n";

    #[test]
    fn reads_and_indexes() {
        let t = Table::parse(CSV, "t.csv").unwrap();
        assert_eq!(t.len(), 3);
        assert_eq!(t.headers(), &["x_m", "Hz [A/m]", "note"]);
        assert_eq!(t.f64(0, "x_m").unwrap(), 1.0);
        assert_eq!(t.f64(0, "Hz").unwrap(), 2.5);
        assert_eq!(t.f64(0, "Hz [A/m]").unwrap(), 2.5);
        assert_eq!(t.f64(0, "X_M").unwrap(), 1.0);
        assert_eq!(t.f64(0, "hz").unwrap(), 2.5);
        assert_eq!(t.str(1, "note").unwrap(), "b");
        assert_eq!(t.f64_col("x_m").unwrap(), vec![1.0, 2.0, 3.0]);
    }

    #[test]
    fn errors_name_file_line_column() {
        let t = Table::parse(CSV, "t.csv").unwrap();
        let e = t.f64(1, "Hz").unwrap_err().to_string();
        assert!(
            e.contains("t.csv") && e.contains("line 5") && e.contains("Hz") && e.contains("bad"),
            "{e}"
        );
        let e = t.f64(2, "Hz").unwrap_err().to_string();
        assert!(e.contains("line 6") && e.contains("NaN"), "{e}");
        let e = t.col("Bz").unwrap_err().to_string();
        assert!(e.contains("Bz") && e.contains("x_m"), "{e}");
        assert!(t.str(9, "x_m").is_err());
    }

    #[test]
    fn ragged_rows_are_errors() {
        let e = Table::parse("a,b\n1,2\n3\n", "r.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("r.csv") && e.contains("line 3"), "{e}");
    }

    #[test]
    fn header_only_is_empty() {
        let t = Table::parse("a,b\n", "h.csv").unwrap();
        assert!(t.is_empty());
        assert!(Table::parse("", "e.csv").is_err());
    }

    #[test]
    fn resolves_paths() {
        let c = Path::new("/r/validation/104-x");
        let r = Path::new("/r");
        assert_eq!(
            resolve_table_path(c, r, "expected.csv"),
            c.join("expected.csv")
        );
        assert_eq!(
            resolve_table_path(c, r, "reference/f.csv"),
            r.join("reference/f.csv")
        );
        assert_eq!(
            resolve_table_path(c, r, "./reference/f.csv"),
            r.join("reference/f.csv")
        );
    }
}
