//! The extended XYZ files porelab writes, loaded by two independent readers: OVITO (`pip
//! install ovito`) and ASE (`pip install ase`), through python3. Each kind of file a scene
//! writes is produced by a small scene run through the library (`porelab run`'s code path):
//! packings of spheres (periodic), spherocylinders (cylinder container), ellipsoids and
//! superballs, DEM spheres with a radius per particle, and a deposition of ellipsoids. Each
//! reader must give back the count, the cell and its periodicity, and per particle the
//! position, the orientation quaternion, the shape columns and the type name that porelab's
//! own reader (`porelab::io::xyz::parse`, whose exact round trip is tested in the library)
//! finds in the file.
//!
//! OVITO maps `type`, `pos`, `orientation`, `aspherical_shape` and `radius` by name; the test
//! also applies the README's two-line OVITO setup (roundness column -> Superquadric Roundness,
//! spherocylinder type -> Spherocylinder shape) and checks its result. A reader that python3
//! cannot import makes its half of the test print why it is skipped, on stderr past the
//! test harness's capture.

use porelab::io::xyz::{self, Cell, XyzParticle};
use porelab::scene::{run_text, RunOptions};
use serde_json::Value;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

/// Writes straight to the process's stderr (libtest captures `eprintln!` of passing tests).
fn say(msg: &str) {
    let _ = writeln!(std::io::stderr(), "{msg}");
}

/// None when python3 can import `module`, else the reason it cannot.
fn unavailable(module: &str) -> Option<String> {
    match Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .output()
    {
        Err(e) => Some(format!("python3 not runnable ({e})")),
        Ok(o) if !o.status.success() => Some(format!(
            "python3 cannot import {module} ({}); `pip install {module}` enables it",
            String::from_utf8_lossy(&o.stderr)
                .lines()
                .last()
                .unwrap_or("")
        )),
        Ok(_) => None,
    }
}

const PACKING_FAST: &str = "[mcm]\nseed = 3\nphi0 = 0.05\ndelta_v_per_particle = 0.02\n\
                            halvings = 1\ntries_per_particle = 20.0\nmax_steps = 40\n";

/// The scenes, each small enough to run in well under a second: (name, TOML, file written).
fn scenes() -> Vec<(&'static str, String, &'static str)> {
    vec![
        (
            "spheres",
            format!("kind = \"packing\"\n[particles]\nshape = \"sphere\"\nn = 20\n{PACKING_FAST}"),
            "final.xyz",
        ),
        (
            "spherocylinders",
            format!(
                "kind = \"packing\"\n[particles]\nshape = \"spherocylinder\"\nn = 30\n\
                 length_over_diameter = 1.0\n[container]\nshape = \"cylinder\"\n\
                 diameter = 3.0\n{PACKING_FAST}"
            ),
            "final.xyz",
        ),
        (
            "ellipsoids",
            format!(
                "kind = \"packing\"\n[[particles.species]]\nshape = \"ellipsoid\"\nn = 8\n\
                 semi_axes = [0.5, 0.35, 0.25]\n{PACKING_FAST}scheme = \"revised\"\ndt = 0.5\n"
            ),
            "final.xyz",
        ),
        (
            "superballs",
            format!(
                "kind = \"packing\"\n[[particles.species]]\nshape = \"superball\"\nn = 8\n\
                 half_width = 0.5\nexponent = 3.0\n{PACKING_FAST}scheme = \"revised\"\n\
                 dt = 0.5\n"
            ),
            "final.xyz",
        ),
        (
            "dem-spheres",
            "kind = \"dem\"\nseed = 1\n[particles]\nn = 40\ndensity_kg_m3 = 2500.0\n\
             size = \"mono\"\ndiameter_m = 4e-4\n[box]\nlx_m = 1.59e-3\nly_m = 1.59e-3\n\
             porosity = 0.75\n[contact]\nmodel = \"hertz-mindlin\"\nyoung_pa = 1e7\n\
             poisson = 0.3\nrestitution = 0.5\nfriction = 0.3\n[drivers]\n\
             gravity_m_s2 = 9.81\n[run]\nmax_time_s = 0.002\n"
                .to_string(),
            "final.xyz",
        ),
        (
            "deposition-ellipsoids",
            "kind = \"deposition\"\nseed = 5\nruns = 1\n[film]\nparticles = 40\n\
             box_side_m = 4e-6\nsolids_percent = 40\n[[species]]\nname = \"clay\"\n\
             semi_axes_m = [0.5e-6, 0.5e-6, 0.125e-6]\n"
                .to_string(),
            "run-000/final.xyz",
        ),
    ]
}

/// Runs every scene into `dir/<name>/` and returns (name, path of its XYZ file).
fn write_files(dir: &Path) -> Vec<(&'static str, PathBuf)> {
    scenes()
        .into_iter()
        .map(|(name, toml, file)| {
            let out = dir.join(name);
            let opts = RunOptions {
                out: Some(out.clone()),
                quiet: true,
                threads: Some(1),
                ..Default::default()
            };
            run_text(&toml, name, name, &opts).unwrap_or_else(|e| panic!("scene {name}: {e}"));
            let path = out.join(file);
            assert!(path.is_file(), "scene {name} wrote no {}", path.display());
            (name, path)
        })
        .collect()
}

/// OVITO: the columns it maps by name, then the README's setup (a pipeline function).
const OVITO_SCRIPT: &str = r#"
import sys, json
from ovito.io import import_file
from ovito.vis import ParticlesVis
def porelab_shapes(frame, data):
    if 'superquadric_roundness' in data.particles:
        data.particles_.create_property('Superquadric Roundness',
            data=data.particles['superquadric_roundness'][...])
    for t in data.particles_.particle_types_.types_:
        if t.name == 'spherocylinder':
            t.shape = ParticlesVis.Shape.Spherocylinder
out = []
for path in sys.argv[1:]:
    pipeline = import_file(path)
    raw = pipeline.compute()
    pipeline.modifiers.append(porelab_shapes)
    d = pipeline.compute()
    p = d.particles
    types = p.particle_types
    out.append({
        'mapped': sorted(raw.particles.keys()),
        'count': p.count,
        'cell': [[float(x) for x in row] for row in d.cell[...]],
        'pbc': [bool(b) for b in d.cell.pbc],
        'pos': p['Position'][...].tolist(),
        'orientation': p['Orientation'][...].tolist(),
        'aspherical_shape': p['Aspherical Shape'][...].tolist(),
        'radius': p['Radius'][...].tolist(),
        'roundness': p['Superquadric Roundness'][...].tolist()
            if 'Superquadric Roundness' in p else None,
        'type': [types.type_by_id(int(t)).name for t in types[...]],
        'type_shape': {t.name: str(t.shape) for t in types.types},
    })
print(json.dumps(out))
"#;

/// ASE: everything as it reads it, symbols included.
const ASE_SCRIPT: &str = r#"
import sys, json
import ase.io
out = []
for path in sys.argv[1:]:
    a = ase.io.read(path, format='extxyz')
    out.append({
        'count': len(a),
        'symbols': sorted(set(a.get_chemical_symbols())),
        'cell': a.cell[...].tolist(),
        'pbc': [bool(b) for b in a.pbc],
        'pos': a.positions.tolist(),
        'orientation': a.arrays['orientation'].tolist(),
        'aspherical_shape': a.arrays['aspherical_shape'].tolist(),
        'radius': a.arrays['radius'].tolist(),
        'roundness': a.arrays['superquadric_roundness'].tolist(),
        'type': [str(t) for t in a.arrays['type']],
    })
print(json.dumps(out))
"#;

fn run_python(script: &str, files: &[(&str, PathBuf)]) -> Vec<Value> {
    let out = Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(files.iter().map(|(_, p)| p.as_os_str()))
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "python3 failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let json = text.lines().last().unwrap_or("");
    match serde_json::from_str::<Value>(json) {
        Ok(Value::Array(v)) => v,
        other => panic!("python3 printed no JSON list ({other:?}): {text}"),
    }
}

fn numbers(v: &Value, what: &str) -> Vec<f64> {
    fn flat(v: &Value, out: &mut Vec<f64>) {
        match v {
            Value::Array(a) => a.iter().for_each(|x| flat(x, out)),
            Value::Number(n) => out.push(n.as_f64().unwrap()),
            other => panic!("not a number: {other}"),
        }
    }
    let mut out = Vec::new();
    flat(&v[what], &mut out);
    out
}

/// Asserts |got - want| <= rtol * scale element by element.
fn close(name: &str, what: &str, got: &[f64], want: &[f64], rtol: f64, scale: f64) {
    assert_eq!(
        got.len(),
        want.len(),
        "{name}: {what}: {} values, want {}",
        got.len(),
        want.len()
    );
    for (k, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() <= rtol * scale,
            "{name}: {what}[{k}] = {g}, the file holds {w} (tolerance {:e})",
            rtol * scale
        );
    }
}

/// What the file holds, by porelab's own reader.
struct Truth {
    cell: Cell,
    parts: Vec<XyzParticle>,
}

impl Truth {
    fn read(path: &Path) -> Truth {
        let text = std::fs::read_to_string(path).unwrap();
        let (cell, parts) = xyz::parse(&text, &path.display().to_string()).unwrap();
        assert!(!parts.is_empty(), "{}: no particles", path.display());
        Truth { cell, parts }
    }
    fn scale(&self) -> f64 {
        self.cell.lengths.iter().cloned().fold(0.0, f64::max)
    }
    fn positions(&self) -> Vec<f64> {
        self.parts
            .iter()
            .flat_map(|p| p.position.iter().copied().collect::<Vec<_>>())
            .collect()
    }
    /// X, Y, Z, W.
    fn orientations(&self) -> Vec<f64> {
        self.parts
            .iter()
            .flat_map(|p| {
                let q = p.orientation.quaternion();
                [q.i, q.j, q.k, q.w]
            })
            .collect()
    }
    fn shapes(&self) -> Vec<f64> {
        self.parts.iter().flat_map(|p| p.aspherical_shape).collect()
    }
    fn radii(&self) -> Vec<f64> {
        self.parts.iter().map(|p| p.radius).collect()
    }
    fn roundness(&self) -> Vec<f64> {
        self.parts.iter().flat_map(|p| p.roundness).collect()
    }
    fn types(&self) -> Vec<String> {
        self.parts.iter().map(|p| p.species.clone()).collect()
    }
    fn pbc(&self) -> Value {
        Value::from(self.cell.pbc.to_vec())
    }
    /// The three cell vectors (rows) and, for OVITO, the origin as a fourth column.
    fn cell_rows(&self, with_origin: bool) -> Vec<f64> {
        let mut v = Vec::new();
        for r in 0..3 {
            for c in 0..3 {
                v.push(if r == c { self.cell.lengths[r] } else { 0.0 });
            }
            if with_origin {
                v.push(self.cell.origin[r]);
            }
        }
        v
    }
}

fn strings(v: &Value, what: &str) -> Vec<String> {
    v[what]
        .as_array()
        .unwrap_or_else(|| panic!("{what} is not a list: {v}"))
        .iter()
        .map(|s| s.as_str().unwrap().to_string())
        .collect()
}

/// What one reader must give back: the count, the cell (with OVITO's origin column when
/// `origin_column`), the periodicity, and per particle the position (within `pos_rtol` of the
/// largest cell edge), orientation, shape columns and roundness (within `rtol`: OVITO keeps
/// them in single precision) and the type names.
struct Reader {
    name: &'static str,
    origin_column: bool,
    pos_rtol: f64,
    rtol: f64,
}

impl Reader {
    fn check(&self, scene: &str, t: &Truth, v: &Value) {
        let what = |w: &str| format!("{} {w}", self.name);
        assert_eq!(v["count"], t.parts.len(), "{scene}: {}", what("count"));
        let cell_rows = t.cell_rows(self.origin_column);
        close(
            scene,
            &what("cell"),
            &numbers(v, "cell"),
            &cell_rows,
            1e-12,
            t.scale(),
        );
        assert_eq!(v["pbc"], t.pbc(), "{scene}: {}", what("pbc"));
        let size = t.radii().iter().cloned().fold(0.0, f64::max);
        let columns: [(&str, &str, Vec<f64>, f64, f64); 5] = [
            ("pos", "position", t.positions(), self.pos_rtol, t.scale()),
            (
                "orientation",
                "orientation",
                t.orientations(),
                self.rtol,
                1.0,
            ),
            (
                "aspherical_shape",
                "aspherical shape",
                t.shapes(),
                self.rtol,
                size,
            ),
            ("radius", "radius", t.radii(), self.rtol, size),
            (
                "roundness",
                "superquadric roundness",
                t.roundness(),
                self.rtol,
                1.0,
            ),
        ];
        for (key, label, want, rtol, scale) in &columns {
            close(scene, &what(label), &numbers(v, key), want, *rtol, *scale);
        }
        assert_eq!(strings(v, "type"), t.types(), "{scene}: {}", what("types"));
    }
}

/// OVITO: positions in double, orientation, shape, radius and roundness in single precision;
/// the cell matrix has the origin as its fourth column.
const OVITO: Reader = Reader {
    name: "OVITO",
    origin_column: true,
    pos_rtol: 1e-12,
    rtol: 1e-6,
};

/// ASE: every column in double precision, no origin in its cell.
const ASE: Reader = Reader {
    name: "ASE",
    origin_column: false,
    pos_rtol: 1e-15,
    rtol: 1e-15,
};

/// Asserts that every one of `wanted` is in `list`.
fn assert_has(list: &[String], wanted: &[&str], what: &str) {
    for w in wanted {
        assert!(list.iter().any(|x| x == w), "{what}: no {w} in {list:?}");
    }
}

fn check_ovito(name: &str, t: &Truth, o: &Value) {
    // mapped by name to OVITO's standard properties, and the roundness column kept
    let mapped = [
        "Particle Type",
        "Position",
        "Orientation",
        "Aspherical Shape",
        "Radius",
    ];
    assert_has(
        &strings(o, "mapped"),
        &mapped,
        &format!("{name}: OVITO's properties"),
    );
    let kept = ["superquadric_roundness"];
    assert_has(
        &strings(o, "mapped"),
        &kept,
        &format!("{name}: OVITO's properties"),
    );
    OVITO.check(name, t, o);
    if t.types().iter().any(|s| s == "spherocylinder") {
        assert_eq!(
            o["type_shape"]["spherocylinder"], "Shape.Spherocylinder",
            "{name}: the README's setup gives the spherocylinder type its shape"
        );
    }
}

fn check_ase(name: &str, t: &Truth, a: &Value) {
    // No shape name read as a chemical element: the dummy symbol X for every particle.
    assert_eq!(a["symbols"], Value::from(vec!["X"]), "{name}: ASE symbols");
    ASE.check(name, t, a);
}

#[test]
fn extended_xyz_read_by_ovito_and_ase() {
    let missing: Vec<(&str, Option<String>)> =
        vec![("ovito", unavailable("ovito")), ("ase", unavailable("ase"))];
    for (module, why) in &missing {
        if let Some(why) = why {
            say(&format!(
                "SKIPPED the {module} half of extended_xyz_read_by_ovito_and_ase: {why}"
            ));
        }
    }
    if missing.iter().all(|(_, why)| why.is_some()) {
        return;
    }
    let dir = std::env::temp_dir().join(format!("porelab-interop-xyz-{}", std::process::id()));
    let files = write_files(&dir);
    let truths: Vec<Truth> = files.iter().map(|(_, p)| Truth::read(p)).collect();
    // Every kind of particle porelab writes is among the files.
    let all_types: Vec<String> = truths.iter().flat_map(Truth::types).collect();
    let kinds = [
        "sphere",
        "spherocylinder",
        "ellipsoid",
        "superquadric",
        "clay",
    ];
    assert_has(&all_types, &kinds, "the types written");
    if missing[0].1.is_none() {
        let got = run_python(OVITO_SCRIPT, &files);
        for (((name, _), t), o) in files.iter().zip(&truths).zip(&got) {
            check_ovito(name, t, o);
        }
        say(&format!(
            "OVITO read {} porelab files as written",
            got.len()
        ));
    }
    if missing[1].1.is_none() {
        let got = run_python(ASE_SCRIPT, &files);
        for (((name, _), t), a) in files.iter().zip(&truths).zip(&got) {
            check_ase(name, t, a);
        }
        say(&format!("ASE read {} porelab files as written", got.len()));
    }
    let _ = std::fs::remove_dir_all(&dir);
}
