//! `porelab permeability` climbing its resolution ladder: the files it writes, what they hold,
//! and its exit status when the ladder does not converge (`--strict`) or cannot start.

use std::path::Path;
use std::process::Command;

/// One sphere of radius 0.31 in the unit periodic box (a simple cubic array, phi 0.125).
const SIMPLE_CUBIC: &str = "1\nLattice=\"1 0 0 0 1 0 0 0 1\" Origin=\"0 0 0\" pbc=\"T T T\" \
Properties=type:S:1:pos:R:3:orientation:R:4:aspherical_shape:R:3:radius:R:1:cylinder_length:R:1:\
superquadric_roundness:R:2\nsphere 0.5 0.5 0.5 0 0 0 1 0.31 0.31 0.31 0.31 0 1 1\n";

fn permeability(dir: &Path, extra: &[&str]) -> std::process::Output {
    let xyz = dir.join("sc.xyz");
    std::fs::write(&xyz, SIMPLE_CUBIC).unwrap();
    Command::new(env!("CARGO_BIN_EXE_porelab"))
        .arg("permeability")
        .arg(&xyz)
        .args(["--quiet", "--start", "8", "--out"])
        .arg(dir.join("out"))
        .args(extra)
        .output()
        .unwrap()
}

fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("porelab-ladder-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Rungs 8, 12, 18, 27: every rung printed and tabled, the answer in the JSON with its error,
/// the plot and the finest field written; a ladder short of its tolerance says so and exits 0,
/// or 3 under --strict.
#[test]
fn the_ladder_writes_its_answer_and_says_when_it_did_not_converge() {
    let dir = scratch("files");
    let o = permeability(&dir, &["--max-resolution", "27", "--rtol", "1e-6"]);
    let (stdout, stderr) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    assert!(o.status.success(), "{stdout}\n{stderr}");
    for n in [8, 12, 18, 27] {
        assert!(stdout.contains(&format!("rung {n:>4} cells")), "{stdout}");
    }
    assert!(stderr.contains("did NOT converge"), "{stderr}");
    let out = dir.join("out");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("permeability.json")).unwrap())
            .unwrap();
    assert_eq!(json["rungs"].as_array().unwrap().len(), 4);
    assert_eq!(json["converged"], false);
    let k = json["k_unit2"].as_f64().unwrap();
    let err = json["k_error_unit2"].as_f64().unwrap();
    assert!(k > 0.0 && err > 0.0 && err.is_finite(), "{json}");
    let csv = std::fs::read_to_string(out.join("ladder.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(csv.starts_with("cells,dx_unit,"), "{csv}");
    let svg = std::fs::read_to_string(out.join("convergence.svg")).unwrap();
    assert!(svg.contains("<svg"));
    let vtk = std::fs::read_to_string(out.join("fields.vtk")).unwrap();
    assert!(
        vtk.contains(&format!("CELL_DATA {}", 27 * 27 * 27)),
        "the finest rung's cells"
    );
    let strict = permeability(
        &dir,
        &["--max-resolution", "27", "--rtol", "1e-6", "--strict"],
    );
    assert_eq!(strict.status.code(), Some(3));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Fewer than four rungs between --start and --max-resolution: refused before any flow runs.
#[test]
fn a_ladder_too_short_is_refused() {
    let dir = scratch("short");
    let o = permeability(&dir, &["--max-resolution", "12"]);
    assert_eq!(o.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("four rungs"), "{stderr}");
    let _ = std::fs::remove_dir_all(&dir);
}
