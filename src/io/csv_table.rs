//! The one CSV writer of porelab's outputs: a header whose column names carry their units
//! (`time_s`, `floor_force_N`, `porosity` for a ratio), then rows printed with Rust's shortest
//! round-trip formatting (`{}`: every f64 reads back to the same bits), written atomically.

use crate::Result;
use std::fmt::{Display, Write as _};
use std::path::Path;

/// A CSV table built in memory.
#[derive(Debug, Clone)]
pub struct CsvTable {
    text: String,
    columns: usize,
}

impl CsvTable {
    /// A table with these column names (units in the names: `z_m`, `k_m2`).
    pub fn new<S: AsRef<str>>(header: &[S]) -> Self {
        let mut t = CsvTable {
            text: String::new(),
            columns: header.len(),
        };
        t.push(header.iter().map(AsRef::as_ref));
        t
    }

    /// Appends one row; each cell is printed with `{}`. A row whose length differs from the
    /// header's is a programming error (checked in debug builds).
    pub fn row<I, T>(&mut self, cells: I)
    where
        I: IntoIterator<Item = T>,
        T: Display,
    {
        let n = self.push(cells);
        debug_assert_eq!(
            n, self.columns,
            "a CSV row of {n} cells under {} columns",
            self.columns
        );
    }

    fn push<I, T>(&mut self, cells: I) -> usize
    where
        I: IntoIterator<Item = T>,
        T: Display,
    {
        let mut n = 0;
        for c in cells {
            if n > 0 {
                self.text.push(',');
            }
            let _ = write!(self.text, "{c}");
            n += 1;
        }
        self.text.push('\n');
        n
    }

    /// The table's text.
    pub fn as_str(&self) -> &str {
        &self.text
    }

    /// Writes the table to `path` atomically (temporary file and rename).
    pub fn write(&self, path: &Path) -> Result<()> {
        super::write_atomic(path, self.text.as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_and_rows_print_shortest_round_trip_numbers() {
        let mut t = CsvTable::new(&["z_m", "porosity"]);
        t.row([0.1, 1.0 / 3.0]);
        t.row([&"5e-4" as &dyn Display, &0.25]);
        assert_eq!(
            t.as_str(),
            "z_m,porosity\n0.1,0.3333333333333333\n5e-4,0.25\n"
        );
        let back: f64 = "0.3333333333333333".parse().unwrap();
        assert_eq!(back, 1.0 / 3.0);
    }
}
