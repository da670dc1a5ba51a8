//! Case discovery, running a case, the comparison statistics and the snapshot summary.

use super::case::{CaseContext, Row, Runner};
use super::spec::{CaseSpec, Oracle, Tier, Tolerance};
use super::table::{resolve_table_path, Table};
use crate::Result;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// One folder `validation/NNN-slug/` holding a case.toml.
#[derive(Debug, Clone)]
pub struct Case {
    /// Folder name, e.g. "104-oracle-table" (also the test name).
    pub folder: String,
    /// The folder's number, e.g. "104".
    pub id: String,
    pub dir: PathBuf,
    /// The parsed case.toml, or why it could not be used (the case then fails).
    pub spec: std::result::Result<CaseSpec, String>,
}

impl Case {
    /// The tier; a case whose case.toml is broken counts as fast so that it fails visibly.
    pub fn tier(&self) -> Tier {
        self.spec.as_ref().map_or(Tier::Fast, |s| s.tier)
    }

    pub fn title(&self) -> &str {
        self.spec
            .as_ref()
            .map_or("(invalid case.toml)", |s| s.title.as_str())
    }
}

/// The folder number of a case folder name "NNN-slug", if it is one.
pub fn folder_id(name: &str) -> Option<&str> {
    let b = name.as_bytes();
    if b.len() >= 5 && b[..3].iter().all(u8::is_ascii_digit) && b[3] == b'-' {
        Some(&name[..3])
    } else {
        None
    }
}

/// All cases under `<root>/validation/`, sorted by folder name. A missing validation folder
/// means no cases. Folders named NNN-slug without a case.toml are skipped; a broken case.toml
/// or a duplicated number gives a case that fails with the reason.
pub fn discover(root: &Path) -> Result<Vec<Case>> {
    let vdir = root.join("validation");
    if !vdir.is_dir() {
        return Ok(Vec::new());
    }
    let mut cases = Vec::new();
    for entry in std::fs::read_dir(&vdir)? {
        let entry = entry?;
        if !entry.file_type()?.is_dir() {
            continue;
        }
        let folder = entry.file_name().to_string_lossy().into_owned();
        let Some(id) = folder_id(&folder) else {
            continue;
        };
        let dir = entry.path();
        let toml = dir.join("case.toml");
        if !toml.is_file() {
            continue;
        }
        let spec = CaseSpec::read(&toml, id);
        cases.push(Case {
            id: id.to_string(),
            folder: folder.clone(),
            dir,
            spec,
        });
    }
    cases.sort_by(|a, b| a.folder.cmp(&b.folder));
    for i in 0..cases.len() {
        let dups: Vec<String> = cases
            .iter()
            .enumerate()
            .filter(|(j, c)| *j != i && c.id == cases[i].id)
            .map(|(_, c)| c.folder.clone())
            .collect();
        if !dups.is_empty() && cases[i].spec.is_ok() {
            cases[i].spec = Err(format!(
                "case number {} is also used by validation/{}",
                cases[i].id,
                dups.join(", validation/")
            ));
        }
    }
    Ok(cases)
}

/// The comparison of a runner's rows against the tolerance.
#[derive(Debug, Clone)]
pub struct Stats {
    /// Rows checked.
    pub rows: usize,
    /// Rows outside the tolerance (non-finite rows included).
    pub failing: usize,
    /// Rows whose got, expected or scale is not finite (or scale < 0).
    pub non_finite: usize,
    /// max |got - expected| / scale, and the label of that row.
    pub worst_rel: f64,
    pub worst_rel_label: String,
    /// max |got - expected| / (atol + rtol * scale); the case passes iff this is <= 1.
    pub worst_norm: f64,
    /// The row with the largest normalized error.
    pub worst_row: Option<Row>,
    pub mean_rel: f64,
}

impl Stats {
    /// True iff there is at least one row and every row is finite and within tolerance.
    pub fn passed(&self) -> bool {
        self.rows > 0 && self.failing == 0
    }
}

fn ratio(num: f64, den: f64) -> f64 {
    if num == 0.0 {
        0.0
    } else if den == 0.0 {
        f64::INFINITY
    } else {
        num / den
    }
}

/// Compares `rows` against `tol`: a row passes iff got, expected and scale are finite,
/// scale >= 0 and |got - expected| <= atol + rtol * scale.
pub fn evaluate(rows: &[Row], tol: &Tolerance) -> Stats {
    let mut s = Stats {
        rows: rows.len(),
        failing: 0,
        non_finite: 0,
        worst_rel: 0.0,
        worst_rel_label: String::new(),
        worst_norm: 0.0,
        worst_row: None,
        mean_rel: 0.0,
    };
    let mut sum_rel = 0.0;
    for r in rows {
        let finite =
            r.got.is_finite() && r.expected.is_finite() && r.scale.is_finite() && r.scale >= 0.0;
        let (rel, norm, ok) = if finite {
            let diff = (r.got - r.expected).abs();
            let allowed = tol.allowed(r.scale);
            (ratio(diff, r.scale), ratio(diff, allowed), diff <= allowed)
        } else {
            s.non_finite += 1;
            (f64::INFINITY, f64::INFINITY, false)
        };
        if !ok {
            s.failing += 1;
        }
        sum_rel += rel;
        let first = s.worst_row.is_none();
        if first || rel > s.worst_rel {
            s.worst_rel = rel;
            s.worst_rel_label = r.label.clone();
        }
        if first || norm > s.worst_norm {
            s.worst_norm = norm;
            s.worst_row = Some(r.clone());
        }
    }
    if !rows.is_empty() {
        s.mean_rel = sum_rel / rows.len() as f64;
    }
    s
}

/// `10^ceil(log10(err))` printed as "1e-15" (meaning err <= 1e-15); "0" for exact zero.
pub fn decade(err: f64) -> String {
    if err == 0.0 {
        return "0".into();
    }
    if err.is_nan() {
        return "NaN".into();
    }
    if err.is_infinite() {
        return "inf".into();
    }
    let mut k = err.log10().ceil() as i32;
    // Guard against log10 rounding at exact powers of ten.
    if 10f64.powi(k - 1) >= err {
        k -= 1;
    }
    if 10f64.powi(k) < err {
        k += 1;
    }
    format!("1e{k}")
}

/// What a case's run amounts to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    Pass,
    Fail,
    /// Failed, and the case is a documented known deviation (case.toml `deviation`).
    Deviation,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Pass => "PASS",
            Verdict::Fail => "FAIL",
            Verdict::Deviation => "DEVIATION",
        }
    }
}

/// The result of running one case.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub id: String,
    pub folder: String,
    pub title: String,
    pub tier: Tier,
    /// The tolerance as written in case.toml ("rtol=1e-12 atol=0e0"), empty if unknown.
    pub tolerance: String,
    /// Present when the runner returned rows.
    pub stats: Option<Stats>,
    pub seconds: f64,
    pub passed: bool,
    /// Why the case failed (None when it passed).
    pub message: Option<String>,
    /// Every checked number the runner returned (empty when it returned none).
    pub rows: Vec<Row>,
    /// The case's oracle and tolerance (None when its case.toml is broken).
    pub oracle: Option<Oracle>,
    pub policy: Option<Tolerance>,
    /// The documented reason when the case is a known deviation (None when the run gave no
    /// rows: a documented deviation covers numbers that miss, not a run that gave none).
    pub deviation: Option<String>,
}

impl Outcome {
    fn fail(case: &Case, tolerance: String, seconds: f64, msg: String) -> Outcome {
        Outcome {
            id: case.id.clone(),
            folder: case.folder.clone(),
            title: case.title().to_string(),
            tier: case.tier(),
            tolerance,
            stats: None,
            seconds,
            passed: false,
            message: Some(msg),
            rows: Vec::new(),
            oracle: case.spec.as_ref().ok().map(|s| s.oracle),
            policy: case.spec.as_ref().ok().map(|s| s.tolerance()),
            // a documented deviation says how far the case's numbers miss; a case that gave
            // no numbers (broken case.toml, missing reference, runner error or panic, no rows)
            // fails whatever its case.toml documents
            deviation: None,
        }
    }

    /// PASS, FAIL, or DEVIATION for a failing case documented as a known deviation.
    pub fn verdict(&self) -> Verdict {
        match (self.passed, &self.deviation) {
            (true, _) => Verdict::Pass,
            (false, Some(_)) => Verdict::Deviation,
            (false, None) => Verdict::Fail,
        }
    }

    /// True for outcomes that make a validation run fail (DEVIATION does not).
    pub fn fails_run(&self) -> bool {
        self.verdict() == Verdict::Fail
    }

    /// The compact summary stored as an insta snapshot: rounded so that it only changes when
    /// something a reviewer should see changes. The tolerance is not in here.
    ///
    /// Band (`literature`) and `statistical` cases also list the measured value of each row
    /// ([`measured_lines`]): their worst relative error is the position in a band or a
    /// z-score, whose decade hardly ever moves, so without the values a changed result would
    /// not show in review.
    pub fn snapshot_summary(&self) -> String {
        let (rows, worst, label) = match &self.stats {
            Some(s) => (
                s.rows.to_string(),
                decade(s.worst_rel),
                s.worst_rel_label.clone(),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        let measured = match (self.oracle, &self.policy) {
            (Some(Oracle::Literature | Oracle::Statistical), Some(tol))
                if !self.rows.is_empty() =>
            {
                measured_lines(&self.rows, tol)
            }
            _ => String::new(),
        };
        format!(
            "id: {}\nrows checked: {rows}\nworst relative error <= {worst}\nworst row: {label}\n{measured}result: {}\n",
            self.id,
            self.verdict().as_str()
        )
    }
}

/// Rows listed one by one in a snapshot; a case with more lists the ones with the largest
/// normalised errors (in table order) and says how many it left out.
pub const MEASURED_ROWS: usize = 40;

/// `got` rounded to the digit a tenth of the allowed deviation reaches, or a tenth of `got`
/// itself where that is finer: a value that moves by a tenth of its tolerance changes its
/// snapshot, noise far below it does not, and a value in a one-sided band (an upper bound of
/// 1e9) still shows two significant digits; below a billionth of the tolerance a value counts
/// as zero. With no allowed deviation (a zero tolerance), four significant digits.
pub fn rounded_to_tolerance(got: f64, allowed: f64) -> String {
    if !got.is_finite() {
        return format!("{got}");
    }
    let step = if allowed.is_finite() && allowed > 0.0 {
        // (a value below a billionth of its tolerance is round-off, not a size)
        let size = if got.abs() > 1e-9 * allowed {
            got.abs()
        } else {
            allowed
        };
        allowed.min(size) / 10.0
    } else {
        got.abs() * 1e-3
    };
    if step == 0.0 {
        return format!("{got}");
    }
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    let text = format!("{got:.decimals$}");
    // "-0.00" reads as a sign that is not there
    if text
        .trim_start_matches('-')
        .chars()
        .all(|c| c == '0' || c == '.')
    {
        text.trim_start_matches('-').to_string()
    } else {
        text
    }
}

/// The "measured" block of a band or statistical case's snapshot: each row's label and its
/// measured value rounded by [`rounded_to_tolerance`].
fn measured_lines(rows: &[Row], tol: &Tolerance) -> String {
    let norm = |r: &Row| {
        let allowed = tol.allowed(r.scale);
        let diff = (r.got - r.expected).abs();
        if diff.is_nan() {
            f64::INFINITY
        } else {
            ratio(diff, allowed)
        }
    };
    let mut keep: Vec<usize> = (0..rows.len()).collect();
    if rows.len() > MEASURED_ROWS {
        keep.sort_by(|&a, &b| norm(&rows[b]).total_cmp(&norm(&rows[a])).then(a.cmp(&b)));
        keep.truncate(MEASURED_ROWS);
        keep.sort_unstable();
    }
    let mut out = String::from("measured (to a tenth of the tolerance or of the value):\n");
    for &k in &keep {
        let r = &rows[k];
        out += &format!(
            "  {}: {}\n",
            r.label,
            rounded_to_tolerance(r.got, tol.allowed(r.scale))
        );
    }
    if keep.len() < rows.len() {
        out += &format!(
            "  ({} more rows, nearer their expected values, not listed)\n",
            rows.len() - keep.len()
        );
    }
    out
}

fn panic_message(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "(non-string panic payload)".into()
    }
}

/// Runs `case` with the registered runner (`case::runner_for`).
pub fn run_case(root: &Path, case: &Case) -> Outcome {
    run_case_with(root, case, super::case::runner_for)
}

/// Runs `case` with the runner that `lookup` finds for its id.
pub fn run_case_with(root: &Path, case: &Case, lookup: impl Fn(&str) -> Option<Runner>) -> Outcome {
    let start = Instant::now();
    let spec = match &case.spec {
        Ok(s) => s,
        Err(e) => {
            return Outcome::fail(case, String::new(), 0.0, format!("invalid case.toml: {e}"))
        }
    };
    let tol = spec.tolerance();
    let tol_s = tol.to_string();
    let elapsed = |start: Instant| start.elapsed().as_secs_f64();
    let Some(runner) = lookup(&spec.id) else {
        return Outcome::fail(
            case,
            tol_s,
            elapsed(start),
            format!(
                "no runner registered for case {} (register a runner next to its function in src/validation/cases/, see mod.rs there)",
                spec.id
            ),
        );
    };
    let ctx = CaseContext {
        id: spec.id.clone(),
        case_dir: case.dir.clone(),
        repo_root: root.to_path_buf(),
        expected: spec.expected.clone(),
        seed: spec.seed,
    };
    let path = resolve_table_path(&case.dir, root, &spec.expected);
    match Table::read(&path) {
        Ok(t) if !t.is_empty() => {}
        Ok(_) => {
            return Outcome::fail(
                case,
                tol_s,
                elapsed(start),
                format!(
                    "missing or empty reference file: {} has a header but no data rows",
                    path.display()
                ),
            )
        }
        Err(e) => {
            return Outcome::fail(
                case,
                tol_s,
                elapsed(start),
                format!("missing or empty reference file: {e}"),
            )
        }
    }
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| runner(&ctx)));
    let seconds = elapsed(start);
    let rows = match result {
        Ok(Ok(rows)) => rows,
        Ok(Err(e)) => {
            return Outcome::fail(
                case,
                tol_s,
                seconds,
                format!("runner returned an error: {e}"),
            )
        }
        Err(p) => {
            return Outcome::fail(
                case,
                tol_s,
                seconds,
                format!("runner panicked: {}", panic_message(&*p)),
            )
        }
    };
    if rows.is_empty() {
        return Outcome::fail(
            case,
            tol_s,
            seconds,
            "runner returned no rows (every case must assert)".into(),
        );
    }
    let stats = evaluate(&rows, &tol);
    let passed = stats.passed();
    let message = (!passed).then(|| failure_message(&stats, &tol));
    Outcome {
        id: spec.id.clone(),
        folder: case.folder.clone(),
        title: spec.title.clone(),
        tier: spec.tier,
        tolerance: tol_s,
        stats: Some(stats),
        seconds,
        passed,
        message,
        rows,
        oracle: Some(spec.oracle),
        policy: Some(tol),
        deviation: spec.deviation.clone(),
    }
}

/// The worst row and the error statistics.
pub fn failure_message(s: &Stats, tol: &Tolerance) -> String {
    let mut m = format!("{} of {} rows outside tolerance ({tol})", s.failing, s.rows);
    if s.non_finite > 0 {
        m += &format!("; {} rows not finite", s.non_finite);
    }
    if let Some(r) = &s.worst_row {
        m += &format!(
            "\n  worst row: {}\n    got      = {:e}\n    expected = {:e}\n    scale    = {:e}\n    |got-expected| = {:e}, allowed = {:e}",
            r.label,
            r.got,
            r.expected,
            r.scale,
            (r.got - r.expected).abs(),
            tol.allowed(r.scale)
        );
    }
    m += &format!(
        "\n  error statistics: worst normalized error {:.3e}; worst relative error {:.3e} at '{}'; mean relative error {:.3e}",
        s.worst_norm, s.worst_rel, s.worst_rel_label, s.mean_rel
    );
    m
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validation::spec::Tolerance;

    fn tol(r: Option<f64>, a: Option<f64>) -> Tolerance {
        Tolerance::new(r, a, None)
    }

    #[test]
    fn tolerance_boundary() {
        let rows = vec![Row::new("a", 1.001, 1.0, 1.0), Row::new("b", 2.0, 2.0, 2.0)];
        let s = evaluate(&rows, &tol(Some(1e-3 + 1e-15), None));
        assert!(s.passed(), "{s:?}");
        let s = evaluate(&rows, &tol(Some(0.9e-3), None));
        assert!(!s.passed());
        assert_eq!(s.failing, 1);
        assert_eq!(s.worst_rel_label, "a");
        assert_eq!(s.worst_row.as_ref().unwrap().label, "a");
        // atol + rtol * scale
        let rows = vec![Row::new("c", 1.5, 1.0, 10.0)];
        assert!(evaluate(&rows, &tol(Some(0.04), Some(0.1))).passed());
        assert!(!evaluate(&rows, &tol(Some(0.03), Some(0.1))).passed());
        // z acts as atol
        assert!(evaluate(
            &[Row::new("z", 2.9, 0.0, 1.0)],
            &Tolerance::new(None, None, Some(3.0))
        )
        .passed());
        assert!(!evaluate(
            &[Row::new("z", 3.1, 0.0, 1.0)],
            &Tolerance::new(None, None, Some(3.0))
        )
        .passed());
    }

    #[test]
    fn non_finite_and_empty_fail() {
        let rows = vec![
            Row::new("ok", 1.0, 1.0, 1.0),
            Row::new("nan", f64::NAN, 1.0, 1.0),
        ];
        let s = evaluate(&rows, &tol(Some(1.0), Some(1.0)));
        assert!(!s.passed());
        assert_eq!(s.non_finite, 1);
        assert_eq!(s.worst_row.unwrap().label, "nan");
        assert!(!evaluate(&[], &tol(Some(1.0), None)).passed());
        assert!(!evaluate(
            &[Row::new("inf", f64::INFINITY, 1.0, 1.0)],
            &tol(Some(1.0), None)
        )
        .passed());
    }

    #[test]
    fn stats() {
        let rows = vec![
            Row::new("a", 1.1, 1.0, 1.0),
            Row::new("b", 2.0, 2.0, 2.0),
            Row::new("c", 0.0, 0.0, 0.0),
        ];
        let s = evaluate(&rows, &tol(Some(1.0), None));
        assert!(s.passed());
        assert!((s.worst_rel - 0.1).abs() < 1e-12);
        assert!((s.mean_rel - 0.1 / 3.0).abs() < 1e-12);
        assert!((s.worst_norm - 0.1).abs() < 1e-12);
    }

    #[test]
    fn decades() {
        assert_eq!(decade(0.0), "0");
        assert_eq!(decade(3e-16), "1e-15");
        assert_eq!(decade(1e-15), "1e-15");
        assert_eq!(decade(1.0000001e-15), "1e-14");
        assert_eq!(decade(0.5), "1e0");
        assert_eq!(decade(1.0), "1e0");
        assert_eq!(decade(20.0), "1e2");
        assert_eq!(decade(f64::INFINITY), "inf");
    }

    #[test]
    fn folder_ids() {
        assert_eq!(folder_id("104-oracle-table"), Some("104"));
        assert_eq!(folder_id("104"), None);
        assert_eq!(folder_id("10-x"), None);
        assert_eq!(folder_id("abc-x"), None);
    }

    // ---- end-to-end on a temporary validation tree ------------------------------------

    struct TempRoot(PathBuf);
    impl TempRoot {
        fn new(tag: &str) -> TempRoot {
            let p = std::env::temp_dir().join(format!(
                "porelab-harness-{tag}-{}-{:?}",
                std::process::id(),
                std::thread::current().id()
            ));
            let _ = std::fs::remove_dir_all(&p);
            std::fs::create_dir_all(&p).unwrap();
            TempRoot(p)
        }
        fn case(&self, folder: &str, toml: &str, expected: Option<&str>) -> PathBuf {
            let d = self.0.join("validation").join(folder);
            std::fs::create_dir_all(&d).unwrap();
            std::fs::write(d.join("case.toml"), toml).unwrap();
            if let Some(e) = expected {
                std::fs::write(d.join("expected.csv"), e).unwrap();
            }
            d
        }
    }
    impl Drop for TempRoot {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    fn toml(id: &str, tier: &str) -> String {
        format!(
            "id = \"{id}\"\ntitle = \"dummy\"\nseed_doc = \"003 thesis\"\nequation = \"eq. 0\"\noracle = \"analytic\"\nrtol = 1e-9\ntier = \"{tier}\"\nexpected = \"expected.csv\"\n"
        )
    }

    fn runner_table(ctx: &CaseContext) -> Result<Vec<Row>> {
        let t = ctx.expected_table()?;
        (0..t.len())
            .map(|i| {
                let x = t.f64(i, "x")?;
                let y = t.f64(i, "y")?;
                Ok(Row::new(format!("x={x}"), x * x, y, y.abs()))
            })
            .collect()
    }
    fn runner_nan(_: &CaseContext) -> Result<Vec<Row>> {
        Ok(vec![
            Row::new("one", 1.0, 1.0, 1.0),
            Row::new("bad", f64::NAN, 1.0, 1.0),
        ])
    }
    fn runner_err(_: &CaseContext) -> Result<Vec<Row>> {
        Err(crate::Error::InvalidInput("radius = -1 must be > 0".into()))
    }
    fn runner_panic(_: &CaseContext) -> Result<Vec<Row>> {
        panic!("boom in runner")
    }
    fn runner_empty(_: &CaseContext) -> Result<Vec<Row>> {
        Ok(vec![])
    }

    fn lookup(id: &str) -> Option<Runner> {
        match id {
            "901" => Some(runner_table),
            "902" => Some(runner_nan),
            "903" | "911" => Some(runner_err),
            "904" => Some(runner_panic),
            "905" => Some(runner_empty),
            "906" | "907" | "912" => Some(runner_table),
            _ => None,
        }
    }

    fn run(root: &TempRoot, folder: &str) -> Outcome {
        let cases = discover(&root.0).unwrap();
        let c = cases.iter().find(|c| c.folder == folder).unwrap();
        run_case_with(&root.0, c, lookup)
    }

    #[test]
    fn end_to_end() {
        let r = TempRoot::new("e2e");
        r.case(
            "901-square",
            &toml("901", "fast"),
            Some("x,y\n1,1\n2,4\n3,9\n"),
        );
        r.case("902-nan", &toml("902", "fast"), Some("x,y\n1,1\n"));
        r.case("903-err", &toml("903", "fast"), Some("x,y\n1,1\n"));
        r.case("904-panic", &toml("904", "fast"), Some("x,y\n1,1\n"));
        r.case("905-empty-rows", &toml("905", "fast"), Some("x,y\n1,1\n"));
        r.case("906-header-only", &toml("906", "slow"), Some("x,y\n"));
        r.case("907-missing", &toml("907", "fast"), None);
        r.case("908-no-runner", &toml("908", "fast"), Some("x,y\n1,1\n"));
        r.case(
            "909-bad-key",
            &format!("{}colour = \"red\"\n", toml("909", "fast")),
            None,
        );
        let documented = |id| format!("{}deviation = \"a documented miss\"\n", toml(id, "fast"));
        r.case("911-deviation-err", &documented("911"), Some("x,y\n1,1\n"));
        r.case(
            "912-deviation-miss",
            &documented("912"),
            Some("x,y\n1,1\n2,4.5\n"),
        );
        std::fs::create_dir_all(r.0.join("validation/910-no-toml")).unwrap();
        std::fs::create_dir_all(r.0.join("validation/notes")).unwrap();

        let cases = discover(&r.0).unwrap();
        let names: Vec<&str> = cases.iter().map(|c| c.folder.as_str()).collect();
        assert_eq!(names.len(), 11, "{names:?}");
        assert_eq!(
            cases.iter().find(|c| c.id == "906").unwrap().tier(),
            Tier::Slow
        );

        let o = run(&r, "901-square");
        assert!(o.passed, "{:?}", o.message);
        assert_eq!(o.stats.as_ref().unwrap().rows, 3);
        assert_eq!(
            o.snapshot_summary(),
            "id: 901\nrows checked: 3\nworst relative error <= 0\nworst row: x=1\nresult: PASS\n"
        );

        let o = run(&r, "902-nan");
        assert!(!o.passed);
        let m = o.message.unwrap();
        assert!(m.contains("bad") && m.contains("not finite"), "{m}");

        let m = run(&r, "903-err").message.unwrap();
        assert!(m.contains("radius = -1"), "{m}");
        let m = run(&r, "904-panic").message.unwrap();
        assert!(
            m.contains("panicked") && m.contains("boom in runner"),
            "{m}"
        );
        let m = run(&r, "905-empty-rows").message.unwrap();
        assert!(m.contains("no rows"), "{m}");
        let m = run(&r, "906-header-only").message.unwrap();
        assert!(m.contains("missing or empty reference file"), "{m}");
        let m = run(&r, "907-missing").message.unwrap();
        assert!(m.contains("missing or empty reference file"), "{m}");
        let m = run(&r, "908-no-runner").message.unwrap();
        assert!(m.contains("no runner"), "{m}");
        let m = run(&r, "909-bad-key").message.unwrap();
        assert!(m.contains("colour") && m.contains("case.toml"), "{m}");
        // a documented deviation covers numbers that miss, not a run that gave none
        let o = run(&r, "911-deviation-err");
        assert_eq!(o.verdict(), Verdict::Fail, "{:?}", o.message);
        assert!(o.fails_run());
        let o = run(&r, "912-deviation-miss");
        assert_eq!(o.verdict(), Verdict::Deviation, "{:?}", o.message);
        assert!(!o.fails_run());
    }

    #[test]
    fn tolerance_failure_prints_worst_row() {
        let r = TempRoot::new("fail");
        r.case(
            "901-square",
            &toml("901", "fast"),
            Some("x,y\n1,1\n2,4.5\n3,9\n"),
        );
        let o = run(&r, "901-square");
        assert!(!o.passed);
        let m = o.message.unwrap();
        assert!(
            m.contains("1 of 3 rows") && m.contains("x=2") && m.contains("got      = 4e0"),
            "{m}"
        );
        assert!(
            m.contains("expected = 4.5e0") && m.contains("mean relative error"),
            "{m}"
        );
    }

    /// Band and statistical cases list each measured value, rounded to a tenth of its allowed
    /// deviation; other oracles keep the short summary.
    #[test]
    fn band_snapshots_show_rounded_measured_values() {
        assert_eq!(rounded_to_tolerance(0.643_217, 0.02), "0.643");
        assert_eq!(rounded_to_tolerance(1.278, 4.89), "1.3");
        assert_eq!(rounded_to_tolerance(972.01, 150.0), "972");
        assert_eq!(rounded_to_tolerance(-0.0004, 0.05), "-0.00040");
        assert_eq!(rounded_to_tolerance(-0.0, 0.05), "0.000");
        assert_eq!(rounded_to_tolerance(5.27, 5e8), "5.3");
        assert_eq!(rounded_to_tolerance(6.2e-16, 4.89), "0.0");
        assert_eq!(rounded_to_tolerance(2.5e-8, 0.0), "0.00000002500");
        assert_eq!(rounded_to_tolerance(f64::NAN, 1.0), "NaN");
        let rows = vec![
            Row::new("phi in [0.62, 0.66]", 0.643_217, 0.64, 0.02),
            Row::new("z of drift", -1.278, 0.0, 1.0),
        ];
        let stats = evaluate(&rows, &tol(Some(1.0), None));
        let mut o = Outcome {
            id: "555".into(),
            folder: "555-band".into(),
            title: "t".into(),
            tier: Tier::Fast,
            tolerance: String::new(),
            stats: Some(stats),
            seconds: 0.0,
            passed: true,
            message: None,
            rows,
            oracle: Some(Oracle::Literature),
            policy: Some(tol(Some(1.0), None)),
            deviation: None,
        };
        assert_eq!(
            o.snapshot_summary(),
            "id: 555\nrows checked: 2\nworst relative error <= 1e1\nworst row: z of drift\n\
             measured (to a tenth of the tolerance or of the value):\n  phi in [0.62, 0.66]: 0.643\n  \
             z of drift: -1.3\nresult: PASS\n"
        );
        o.oracle = Some(Oracle::Analytic);
        assert!(!o.snapshot_summary().contains("measured"));
        // Many rows: the worst MEASURED_ROWS, in table order, and a count of the rest.
        o.oracle = Some(Oracle::Statistical);
        o.rows = (0..MEASURED_ROWS + 3)
            .map(|k| Row::new(format!("r{k}"), k as f64 / 100.0, 0.0, 1.0))
            .collect();
        let s = o.snapshot_summary();
        assert!(!s.contains("  r2: ") && s.contains("  r3: 0.030\n"), "{s}");
        assert!(s.contains("(3 more rows"), "{s}");
    }

    #[test]
    fn duplicate_ids_fail() {
        let r = TempRoot::new("dup");
        r.case("901-a", &toml("901", "fast"), Some("x,y\n1,1\n"));
        r.case("901-b", &toml("901", "fast"), Some("x,y\n1,1\n"));
        let cases = discover(&r.0).unwrap();
        assert!(cases
            .iter()
            .all(|c| c.spec.as_ref().unwrap_err().contains("also used")));
    }
}
