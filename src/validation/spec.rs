//! The schema of `validation/NNN-slug/case.toml`.
//!
//! ```toml
//! id = "104"                      # must equal the folder's NNN
//! title = "Transverse field of a finite cylinder against the reference table"
//! seed_doc = "003 thesis"
//! equation = "eq. 5.3-5.6"
//! oracle = "reference"            # analytic | reference | statistical | convergence | literature
//! citation = "..."                # optional; required when oracle = "literature"
//! rtol = 1e-12                    # at least one of rtol, atol, z
//! atol = 0.0
//! z = 3.0                         # statistical cases: acts as atol on z-scores
//! tier = "fast"                   # fast | slow
//! seed = 42                       # optional fixed seed
//! expected = "expected.csv"       # relative to the case folder, or "reference/..." (repo root)
//! notes = "..."                   # optional
//! deviation = "..."               # optional: a documented known deviation (see below)
//! ```
//!
//! `deviation` marks a seed finding that does not reproduce under the protocol the case fixes:
//! the case still runs and checks every row, and when it fails its result is DEVIATION, shown
//! with the measured figures and this one-line reason; it is never counted as a pass (nor as a
//! failure of the run). When such a case passes, the report says the mark can go.
//!
//! Unknown keys are rejected by name (serde `deny_unknown_fields`).

use serde::Deserialize;
use std::fmt;
use std::path::Path;

/// What the expected values are (DESIGN.md, "Validation tree").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Oracle {
    /// Closed form or limit.
    Analytic,
    /// A table in `reference/` produced by an independent oracle.
    Reference,
    /// A statistical test at a confidence level (`z`).
    Statistical,
    /// An observed convergence order against the expected one.
    Convergence,
    /// A literature band, with its citation.
    Literature,
}

impl fmt::Display for Oracle {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Oracle::Analytic => "analytic",
            Oracle::Reference => "reference",
            Oracle::Statistical => "statistical",
            Oracle::Convergence => "convergence",
            Oracle::Literature => "literature",
        })
    }
}

/// `fast` runs in `cargo test` and `porelab validate`; `slow` is `--ignored` / `--all`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Tier {
    Fast,
    Slow,
}

impl fmt::Display for Tier {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Tier::Fast => "fast",
            Tier::Slow => "slow",
        })
    }
}

/// The contents of one `case.toml`.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CaseSpec {
    pub id: String,
    pub title: String,
    pub seed_doc: String,
    pub equation: String,
    pub oracle: Oracle,
    #[serde(default)]
    pub citation: Option<String>,
    #[serde(default)]
    pub rtol: Option<f64>,
    #[serde(default)]
    pub atol: Option<f64>,
    #[serde(default)]
    pub z: Option<f64>,
    pub tier: Tier,
    #[serde(default)]
    pub seed: Option<u64>,
    pub expected: String,
    #[serde(default)]
    pub notes: Option<String>,
    /// Why this case is a documented known deviation (one line), if it is one.
    #[serde(default)]
    pub deviation: Option<String>,
}

impl CaseSpec {
    /// Parses and checks the text of a case.toml that lives in a folder whose number is
    /// `folder_id`. The error message names the offending key and the rule it breaks.
    pub fn parse(text: &str, folder_id: &str) -> Result<CaseSpec, String> {
        let spec: CaseSpec =
            toml::from_str(text).map_err(|e| e.to_string().trim_end().to_string())?;
        spec.check(folder_id)?;
        Ok(spec)
    }

    /// Reads, parses and checks `path` (a case.toml in folder number `folder_id`).
    pub fn read(path: &Path, folder_id: &str) -> Result<CaseSpec, String> {
        let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
        CaseSpec::parse(&text, folder_id).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// The rules serde cannot express.
    pub fn check(&self, folder_id: &str) -> Result<(), String> {
        if self.id != folder_id {
            return Err(format!(
                "id = \"{}\" must equal the folder number \"{folder_id}\"",
                self.id
            ));
        }
        if self.title.trim().is_empty() {
            return Err("title must not be empty".into());
        }
        if self.oracle == Oracle::Literature
            && self.citation.as_deref().is_none_or(|c| c.trim().is_empty())
        {
            return Err("oracle = \"literature\" requires a citation".into());
        }
        if self.rtol.is_none() && self.atol.is_none() && self.z.is_none() {
            return Err("at least one of rtol, atol, z must be set".into());
        }
        for (key, v) in [("rtol", self.rtol), ("atol", self.atol), ("z", self.z)] {
            if let Some(v) = v {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!("{key} = {v} must be finite and >= 0"));
                }
            }
        }
        if self
            .deviation
            .as_deref()
            .is_some_and(|d| d.trim().is_empty())
        {
            return Err("deviation must give the reason (one line), or be left out".into());
        }
        if self.expected.trim().is_empty() {
            return Err("expected must name a table (e.g. \"expected.csv\")".into());
        }
        if Path::new(&self.expected).is_absolute() {
            return Err(format!(
                "expected = \"{}\" must be relative (to the case folder, or \"reference/...\")",
                self.expected
            ));
        }
        Ok(())
    }

    /// The pass/fail tolerance of this case.
    pub fn tolerance(&self) -> Tolerance {
        Tolerance::new(self.rtol, self.atol, self.z)
    }
}

/// The tolerance policy: a row passes when `|got - expected| <= atol + rtol * scale`.
/// Missing values count as 0; `z` acts as an absolute tolerance (on z-scores); when both
/// `atol` and `z` are given the larger one applies.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Tolerance {
    pub rtol: Option<f64>,
    pub atol: Option<f64>,
    pub z: Option<f64>,
}

impl Tolerance {
    pub fn new(rtol: Option<f64>, atol: Option<f64>, z: Option<f64>) -> Tolerance {
        Tolerance { rtol, atol, z }
    }

    /// The absolute part: max(atol, z), missing = 0.
    pub fn abs_part(&self) -> f64 {
        self.atol.unwrap_or(0.0).max(self.z.unwrap_or(0.0))
    }

    /// The allowed |got - expected| for a row of this scale.
    pub fn allowed(&self, scale: f64) -> f64 {
        self.abs_part() + self.rtol.unwrap_or(0.0) * scale
    }
}

impl fmt::Display for Tolerance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut parts = Vec::new();
        if let Some(v) = self.rtol {
            parts.push(format!("rtol={v:e}"));
        }
        if let Some(v) = self.atol {
            parts.push(format!("atol={v:e}"));
        }
        if let Some(v) = self.z {
            parts.push(format!("z={v}"));
        }
        if parts.is_empty() {
            f.write_str("none")
        } else {
            f.write_str(&parts.join(" "))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"
id = "104"
title = "Field on the axis"
seed_doc = "003 thesis"
equation = "eq. 5.3"
oracle = "analytic"
rtol = 1e-12
tier = "fast"
expected = "expected.csv"
"#;

    #[test]
    fn parses_a_good_case() {
        let s = CaseSpec::parse(GOOD, "104").unwrap();
        assert_eq!(s.oracle, Oracle::Analytic);
        assert_eq!(s.tier, Tier::Fast);
        assert_eq!(s.rtol, Some(1e-12));
        assert_eq!(s.seed, None);
    }

    #[test]
    fn rejects_unknown_key_by_name() {
        let text = format!("{GOOD}tolerance = 3\n");
        let e = CaseSpec::parse(&text, "104").unwrap_err();
        assert!(e.contains("tolerance"), "{e}");
        assert!(e.contains("unknown field"), "{e}");
    }

    #[test]
    fn rejects_bad_oracle_and_tier() {
        let e = CaseSpec::parse(&GOOD.replace("\"analytic\"", "\"guess\""), "104").unwrap_err();
        assert!(e.contains("guess"), "{e}");
        let e = CaseSpec::parse(&GOOD.replace("\"fast\"", "\"quick\""), "104").unwrap_err();
        assert!(e.contains("quick"), "{e}");
    }

    #[test]
    fn id_must_match_folder() {
        let e = CaseSpec::parse(GOOD, "105").unwrap_err();
        assert!(e.contains("105") && e.contains("104"), "{e}");
    }

    #[test]
    fn needs_a_tolerance() {
        let e = CaseSpec::parse(&GOOD.replace("rtol = 1e-12\n", ""), "104").unwrap_err();
        assert!(e.contains("rtol, atol, z"), "{e}");
        let e = CaseSpec::parse(&GOOD.replace("rtol = 1e-12", "rtol = -1.0"), "104").unwrap_err();
        assert!(e.contains("rtol"), "{e}");
    }

    #[test]
    fn literature_needs_citation() {
        let text = GOOD.replace("\"analytic\"", "\"literature\"");
        let e = CaseSpec::parse(&text, "104").unwrap_err();
        assert!(e.contains("citation"), "{e}");
        let ok = format!("{text}citation = \"Happel & Brenner 1983, table 4.2\"\n");
        CaseSpec::parse(&ok, "104").unwrap();
    }

    #[test]
    fn tolerance_policy() {
        let t = Tolerance::new(Some(1e-3), None, None);
        assert_eq!(t.allowed(2.0), 2e-3);
        let t = Tolerance::new(None, Some(1e-9), Some(3.0));
        assert_eq!(t.allowed(100.0), 3.0);
        let t = Tolerance::new(Some(0.5), Some(1.0), None);
        assert_eq!(t.allowed(4.0), 3.0);
        assert_eq!(t.to_string(), "rtol=5e-1 atol=1e0");
    }
}
