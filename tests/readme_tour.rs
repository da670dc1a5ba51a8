//! The README's quick tour, executed: every `$ ` command of the README's code blocks runs, in
//! README order, in one scratch folder with `porelab` on the PATH (`sh -c`, so `printf ... >
//! points.csv` works), and must exit 0. Every output line the README shows under a command must
//! appear, in order, among the lines the command prints on stdout (the README may leave lines
//! out). Within a line:
//! - runs of white space count as one space;
//! - `...` stands for any text (an abridged line);
//! - a number matches a printed number that rounds to it at the README's own precision
//!   (`0.4045` matches 0.40449 but not 0.4035; `9.163189790830357e-7` only itself);
//! - a wall-clock time, a number with at most one decimal and no exponent followed by the unit
//!   `s` (`in 2.1 s`), matches any number: it depends on the machine.
//!
//! So a change of a printed figure fails this test until the README shows the new figure.
//!
//! A code block whose first line is `# file: NAME` is an input the tour uses: its text is
//! written to NAME in the scratch folder, in README order, before the commands that follow.

use std::path::{Path, PathBuf};
use std::process::Command;

/// One `$ ` command of the README with the output lines shown under it, or a file the tour
/// writes (`# file: NAME` blocks: `file` holds the name, `expected` the lines).
struct Example {
    line_no: usize,
    command: String,
    expected: Vec<String>,
    file: Option<String>,
}

/// The `$ ` commands of the README's fenced code blocks, with the lines that follow each.
fn examples(readme: &str) -> Vec<Example> {
    let mut out: Vec<Example> = Vec::new();
    let mut in_block = false;
    // the example whose output the block's next lines show (none before a block's first `$ `)
    let mut current: Option<usize> = None;
    // a `# file: NAME` block being read (its example's index)
    let mut file: Option<usize> = None;
    let mut block_start = false;
    for (k, line) in readme.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            in_block = !in_block;
            (current, file, block_start) = (None, None, in_block);
            continue;
        }
        if !in_block {
            continue;
        }
        let first = std::mem::replace(&mut block_start, false);
        if let Some(i) = file {
            out[i].expected.push(line.to_string());
        } else if let Some(name) = line.strip_prefix("# file: ").filter(|_| first) {
            out.push(Example {
                line_no: k + 1,
                command: String::new(),
                expected: vec![line.to_string()],
                file: Some(name.trim().to_string()),
            });
            file = Some(out.len() - 1);
        } else if let Some(cmd) = line.strip_prefix("$ ") {
            out.push(Example {
                line_no: k + 1,
                command: cmd.to_string(),
                expected: Vec::new(),
                file: None,
            });
            current = Some(out.len() - 1);
        } else if let Some(i) = current {
            if line.trim() != "..." && !line.trim().is_empty() {
                out[i].expected.push(line.to_string());
            }
        }
    }
    out
}

/// A piece of an expected line.
#[derive(Debug)]
enum Piece {
    Text(String),
    /// A number and the half-unit of its last printed digit.
    Number {
        value: f64,
        half_ulp: f64,
    },
    /// A wall-clock time: any number.
    AnyNumber,
    /// `...`: any text.
    Anything,
}

/// The number at the start of `s` (optional sign, digits, optional fraction, optional exponent),
/// with its length in bytes, its decimals and whether it has an exponent.
fn leading_number(s: &str) -> Option<(usize, f64, i32, Option<i32>)> {
    let b = s.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'-' || b[i] == b'+') {
        i += 1;
    }
    let int_start = i;
    while i < b.len() && b[i].is_ascii_digit() {
        i += 1;
    }
    if i == int_start {
        return None;
    }
    let mut decimals = 0;
    if i + 1 < b.len() && b[i] == b'.' && b[i + 1].is_ascii_digit() {
        i += 1;
        while i < b.len() && b[i].is_ascii_digit() {
            i += 1;
            decimals += 1;
        }
    }
    let mut exponent = None;
    if i < b.len() && (b[i] == b'e' || b[i] == b'E') {
        let mut j = i + 1;
        if j < b.len() && (b[j] == b'-' || b[j] == b'+') {
            j += 1;
        }
        let exp_start = j;
        while j < b.len() && b[j].is_ascii_digit() {
            j += 1;
        }
        if j > exp_start {
            exponent = s[i + 1..j].parse().ok();
            i = j;
        }
    }
    let value: f64 = s[..i].parse().ok()?;
    Some((i, value, decimals, exponent))
}

/// White space collapsed to single spaces, ends trimmed.
fn squeeze(s: &str) -> String {
    s.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// An expected line cut into pieces.
fn pieces(expected: &str) -> Vec<Piece> {
    let s = squeeze(expected);
    let mut out = Vec::new();
    let mut text = String::new();
    let mut rest = s.as_str();
    let mut prev: Option<char> = None;
    while let Some(c) = rest.chars().next() {
        if let Some(after) = rest.strip_prefix("...") {
            out.push(Piece::Text(std::mem::take(&mut text)));
            out.push(Piece::Anything);
            rest = after;
            prev = Some('.');
            continue;
        }
        // a number starts a word: `D3Q19` and `run-003` are text
        let starts_number = (c.is_ascii_digit() || c == '-')
            && !prev.is_some_and(|p| p.is_alphanumeric() || p == '_' || p == '.');
        if starts_number {
            if let Some((len, value, decimals, exponent)) = leading_number(rest) {
                let after = &rest[len..];
                let unit_s = after.trim_start().strip_prefix('s').is_some_and(|u| {
                    !u.chars()
                        .next()
                        .is_some_and(|n| n.is_alphanumeric() || n == '_')
                });
                out.push(Piece::Text(std::mem::take(&mut text)));
                if unit_s && exponent.is_none() && decimals <= 1 {
                    out.push(Piece::AnyNumber);
                } else {
                    let scale = exponent.unwrap_or(0) - decimals;
                    out.push(Piece::Number {
                        value,
                        half_ulp: 0.5 * 10f64.powi(scale),
                    });
                }
                rest = after;
                prev = Some('0');
                continue;
            }
        }
        text.push(c);
        prev = Some(c);
        rest = &rest[c.len_utf8()..];
    }
    out.push(Piece::Text(text));
    out.retain(|p| !matches!(p, Piece::Text(t) if t.is_empty()));
    out
}

/// Does the whole of `actual` (squeezed) match the pieces?
fn matches(pieces: &[Piece], actual: &str) -> bool {
    let Some((first, rest)) = pieces.split_first() else {
        return actual.is_empty();
    };
    match first {
        Piece::Text(t) => actual
            .strip_prefix(t.as_str())
            .is_some_and(|a| matches(rest, a)),
        Piece::Number { value, half_ulp } => {
            leading_number(actual).is_some_and(|(len, got, _, _)| {
                (got - value).abs() <= half_ulp * (1.0 + 1e-9) + 1e-300
                    && matches(rest, &actual[len..])
            })
        }
        Piece::AnyNumber => {
            leading_number(actual).is_some_and(|(len, _, _, _)| matches(rest, &actual[len..]))
        }
        Piece::Anything => actual
            .char_indices()
            .map(|(k, _)| k)
            .chain(std::iter::once(actual.len()))
            .any(|k| matches(rest, &actual[k..])),
    }
}

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A scratch folder holding `bin/porelab` (a link to the binary under test).
fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("porelab-readme-tour-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(d.join("bin")).unwrap();
    std::os::unix::fs::symlink(env!("CARGO_BIN_EXE_porelab"), d.join("bin/porelab")).unwrap();
    d
}

fn run(dir: &Path, command: &str) -> (bool, String, String) {
    let path = format!(
        "{}:{}",
        dir.join("bin").display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let o = Command::new("sh")
        .arg("-c")
        .arg(command)
        .current_dir(dir)
        .env("PATH", path)
        .env("PORELAB_ROOT", repo())
        .output()
        .unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn quick_tour_prints_what_the_readme_shows() {
    let readme = std::fs::read_to_string(repo().join("README.md")).unwrap();
    let examples = examples(&readme);
    assert!(
        examples.len() >= 8,
        "the README's quick tour should have its commands in code blocks: found {}",
        examples.len()
    );
    // the sweep example is executed: its file is written and planned, run and collected
    assert!(
        examples
            .iter()
            .any(|e| e.file.as_deref() == Some("sweep.toml"))
            && examples
                .iter()
                .any(|e| e.command.starts_with("porelab sweep plan sweep.toml")),
        "the README's sweep example should be a `# file: sweep.toml` block and its commands"
    );
    let dir = scratch();
    let mut failures = Vec::new();
    for ex in &examples {
        if let Some(name) = &ex.file {
            std::fs::write(dir.join(name), ex.expected.join("\n") + "\n").unwrap();
            continue;
        }
        let (ok, stdout, stderr) = run(&dir, &ex.command);
        if !ok {
            failures.push(format!(
                "README.md:{}: `{}` failed:\n{stderr}",
                ex.line_no, ex.command
            ));
            continue;
        }
        let printed: Vec<String> = stdout.lines().map(squeeze).collect();
        let mut from = 0;
        for want in &ex.expected {
            let p = pieces(want);
            match printed[from..].iter().position(|got| matches(&p, got)) {
                Some(k) => from += k + 1,
                None => {
                    failures.push(format!(
                        "README.md:{}: `{}`: no printed line (after the ones matched before) matches\n  README: {want}\n  printed:\n    {}",
                        ex.line_no,
                        ex.command,
                        printed.join("\n    ")
                    ));
                    break;
                }
            }
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

#[test]
fn the_matcher_compares_to_the_readmes_rounding() {
    let p = pieces("porosity below top 0.4263, bulk 0.4045; dt = 9.163189790830357e-7 s, 9.4 s");
    assert!(matches(
        &p,
        "porosity below top 0.42634, bulk 0.40449; dt = 9.163189790830357e-7 s, 17.0 s"
    ));
    // another figure at the README's precision, or another dt
    assert!(!matches(
        &p,
        "porosity below top 0.4233, bulk 0.4045; dt = 9.163189790830357e-7 s, 9.4 s"
    ));
    assert!(!matches(
        &p,
        "porosity below top 0.4263, bulk 0.4045; dt = 9.163189790830358e-7 s, 9.4 s"
    ));
    // `...` abridges; text is literal; `D3Q19` is text, not a number
    let q = pieces("lattice D3Q19 ... Mach = 1.127e-3, ...");
    assert!(matches(
        &q,
        "lattice D3Q19 TRT, 32 cells Mach = 1.1274e-3, Re = 0.1"
    ));
    assert!(!matches(&q, "lattice D3Q15 TRT Mach = 1.127e-3, Re"));
    assert!(!matches(&q, "lattice D3Q19 TRT Mach = 1.128e-3, Re"));
    // a line with less than the README shows does not match
    assert!(!matches(
        &pieces("8 passed, 0 failed"),
        "8 passed, 0 failed, 3 not selected"
    ));
}
