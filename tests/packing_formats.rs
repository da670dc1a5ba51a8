//! Packings from other tools, and the bad input `porelab permeability` refuses.
//!
//! The fixtures in `tests/data/` were written by OVITO, LAMMPS and (by hand, in its documented
//! format) LIGGGHTS; `tests/data/README.md` gives their provenance and the values they hold,
//! which the tests below check against the generating script's inputs (lattice sites, radii,
//! shifts), not against porelab. The ASE file is written by ASE at test time (skipped, with the
//! reason printed, when python3 cannot import ase). The refusals run the built binary: exit
//! status 2 and one line on stderr naming the file and line, or the option, and the rule.

use nalgebra::{UnitQuaternion, Vector3};
use porelab::io::configuration::{self, check_overlaps, Format};
use porelab::io::xyz::{self, contact_shape, Cell, XyzParticle};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("porelab-formats-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn near(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * (1.0 + b.abs())
}

#[test]
fn ovito_extxyz_in_its_own_column_order() {
    let c = configuration::read(&data("ovito_spheres_ellipsoid.xyz"), -1, "--frame").unwrap();
    assert_eq!((c.format, c.frame, c.frames), (Format::ExtendedXyz, 0, 1));
    let f = &c.data;
    assert_eq!(
        f.cell,
        Cell {
            lengths: [4.0, 4.0, 3.0],
            origin: [-2.0, -2.0, 0.0],
            pbc: [true; 3]
        }
    );
    assert_eq!(f.particles.len(), 4);
    assert_eq!(f.lines, vec![3, 4, 5, 6]);
    let s = &f.particles[2];
    assert_eq!(s.species, "grain");
    assert_eq!(s.position, Vector3::new(-1.5, 0.5, 1.5));
    // OVITO's aspherical_shape 0 0 0: a sphere of `radius`
    assert_eq!(s.radius, 0.3);
    assert_eq!(contact_shape(s).unwrap().name(), "sphere");
    let e = &f.particles[3];
    assert_eq!(e.species, "ellipsoid");
    assert_eq!(e.aspherical_shape, [0.5, 0.3, 0.2]);
    assert_eq!(contact_shape(e).unwrap().name(), "ellipsoid");
    let want = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5);
    // OVITO keeps Orientation in single precision
    assert!(
        (e.orientation.coords - want.coords).norm() < 1e-7,
        "{:?}",
        e.orientation
    );
    let r = check_overlaps(f, "ovito", 1e-6).unwrap();
    assert_eq!(r.deepest, 0.0);
}

#[test]
fn lammps_dump_last_frame_by_default_and_any_frame_by_index() {
    let path = data("lammps_spheres.dump");
    let c = configuration::read(&path, -1, "--frame").unwrap();
    assert_eq!((c.format, c.frame, c.frames), (Format::LammpsDump, 2, 3));
    assert_eq!(c.timestep, Some(20));
    let f = &c.data;
    assert_eq!(
        f.cell,
        Cell {
            lengths: [4.0, 4.0, 3.0],
            origin: [0.0; 3],
            pbc: [true; 3]
        }
    );
    assert_eq!(f.particles.len(), 48);
    // lattice sites (i, j, k) moved by 0.01 x 0.5 x 20 = 0.1 along x; type 2 on z = 0
    // (LAMMPS's `%g`: six significant digits)
    let sites = |f: &xyz::Frame, shift: f64| {
        for p in &f.particles {
            let x = p.position - Vector3::new(shift, 0.0, 0.0);
            assert!(x.iter().all(|v| (v - v.round()).abs() < 2e-6), "{x:?}");
            let (species, r) = if x.z.round() == 0.0 {
                ("2", 0.3)
            } else {
                ("1", 0.4)
            };
            assert_eq!((p.species.as_str(), p.radius), (species, r), "{x:?}");
        }
    };
    sites(f, 0.1);
    assert_eq!(f.lines[0], 124);
    let first = configuration::read(&path, 0, "--frame").unwrap();
    assert_eq!((first.frame, first.timestep), (0, Some(0)));
    sites(&first.data, 0.0);
    let middle = configuration::read(&path, -2, "--frame").unwrap();
    sites(&middle.data, 0.05);
    for bad in [3, -4] {
        let e = configuration::read(&path, bad, "--frame")
            .unwrap_err()
            .to_string();
        assert!(
            e.contains(&format!("--frame {bad}")) && e.contains("3 frames"),
            "{e}"
        );
    }
    // the scaled dump of the same run (ITEM: UNITS and ITEM: TIME before the frame)
    let s = configuration::read(&data("lammps_scaled.dump"), -1, "--frame").unwrap();
    assert_eq!((s.frames, s.timestep), (1, Some(20)));
    sites(&s.data, 0.1);
}

#[test]
fn liggghts_dump_with_walls_in_z() {
    let c = configuration::read(&data("liggghts_spheres.dump"), -1, "--frame").unwrap();
    assert_eq!((c.frame, c.timestep), (1, Some(1000)));
    let f = &c.data;
    assert_eq!(
        f.cell,
        Cell {
            lengths: [2.0, 2.0, 3.0],
            origin: [0.0, 0.0, -0.5],
            pbc: [true, true, false]
        }
    );
    let z: Vec<f64> = f.particles.iter().map(|p| p.position.z).collect();
    assert_eq!(z, vec![0.25, 0.25, 1.25, 1.25]);
    assert!(f.particles.iter().all(|p| p.radius == 0.25));
}

/// Writes straight to the process's stderr (libtest captures `eprintln!` of passing tests).
fn say(msg: &str) {
    let _ = writeln!(std::io::stderr(), "{msg}");
}

#[test]
fn ase_extxyz_trajectory_reads_its_last_frame() {
    let ok = Command::new("python3")
        .args(["-c", "import ase"])
        .output()
        .map(|o| o.status.success())
        .unwrap_or(false);
    if !ok {
        say("ase_extxyz_trajectory_reads_its_last_frame: skipped, python3 cannot import ase (`pip install ase` enables it)");
        return;
    }
    let d = scratch("ase");
    let file = d.join("ase.xyz");
    let script = format!(
        "import numpy as np\nfrom ase import Atoms\nfrom ase.io import write\n\
         pos = np.array([[0.5, 0.5, 0.5], [2.0, 0.5, 0.5], [0.5, 2.0, 2.0], [2.0, 2.0, 2.0]])\n\
         frames = []\n\
         for dz in (0.0, 0.25):\n\
         \x20   a = Atoms('Ar2Cu2', positions=pos + [0, 0, dz], cell=[3.0, 3.0, 3.0], pbc=True)\n\
         \x20   a.new_array('radius', np.array([0.5, 0.5, 0.4, 0.4]))\n\
         \x20   a.info['packing_fraction'] = 0.1\n\
         \x20   frames.append(a)\n\
         write({:?}, frames, format='extxyz')\n",
        file.display().to_string()
    );
    let o = Command::new("python3")
        .args(["-c", &script])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("species:S:1:pos:R:3:radius:R:1"), "{text}");
    let c = configuration::read(&file, -1, "--frame").unwrap();
    assert_eq!((c.format, c.frame, c.frames), (Format::ExtendedXyz, 1, 2));
    let f = &c.data;
    assert_eq!(f.cell, Cell::cubic(3.0));
    let species: Vec<&str> = f.particles.iter().map(|p| p.species.as_str()).collect();
    assert_eq!(species, ["Ar", "Ar", "Cu", "Cu"]);
    let radii: Vec<f64> = f.particles.iter().map(|p| p.radius).collect();
    assert_eq!(radii, [0.5, 0.5, 0.4, 0.4]);
    assert!(near(f.particles[3].position.z, 2.25));
    assert!(near(f.particles[0].position.x, 0.5));
    assert_eq!(f.lines, vec![9, 10, 11, 12]);
}

/// Overlap depth against the tolerance, and the cell list against every pair on a larger
/// random configuration (polydisperse spheres in an orthorhombic box).
#[test]
fn overlaps_deeper_than_the_tolerance_are_refused() {
    let frame = |parts: Vec<XyzParticle>, l: f64| xyz::Frame {
        cell: Cell::cubic(l),
        lines: (3..3 + parts.len()).collect(),
        particles: parts,
    };
    let s = |x: f64, r: f64| XyzParticle::sphere(Vector3::new(x, 1.0, 1.0), r);
    // 0.1 of a diameter deep, across the periodic boundary
    let f = frame(vec![s(0.2, 0.5), s(3.3, 0.5)], 4.0);
    let e = check_overlaps(&f, "two", 1e-6).unwrap_err().to_string();
    assert!(
        e.contains("lines 3 and 4 overlap") && e.contains("1.000e-1"),
        "{e}"
    );
    let r = check_overlaps(&f, "two", 0.2).unwrap();
    assert!(
        (r.deepest - 0.1).abs() < 1e-12 && r.pairs_within_reach == 1,
        "{r:?}"
    );
    // touching exactly is not an overlap; coincident particles are named as such
    assert_eq!(
        check_overlaps(&frame(vec![s(0.5, 0.5), s(1.5, 0.5)], 4.0), "t", 0.0)
            .unwrap()
            .deepest,
        0.0
    );
    let e = check_overlaps(&frame(vec![s(1.0, 0.5), s(1.0, 0.5)], 4.0), "t", 0.2)
        .unwrap_err()
        .to_string();
    assert!(e.contains("same position"), "{e}");
    // a sphere wider than the box overlaps its own image
    let e = check_overlaps(&frame(vec![s(1.0, 1.2)], 2.0), "t", 0.1)
        .unwrap_err()
        .to_string();
    assert!(e.contains("own periodic image"), "{e}");
    // non-spheres through the contact kernels: two ellipsoids side by side, 0.05 deep
    let ell = |x: f64| XyzParticle {
        species: "ellipsoid".into(),
        aspherical_shape: [0.5, 0.3, 0.2],
        radius: 0.5,
        ..s(x, 0.5)
    };
    let f = frame(vec![ell(1.0), ell(1.95)], 4.0);
    let r = check_overlaps(&f, "e", 0.2).unwrap();
    assert!((r.deepest - 0.05 / 0.4).abs() < 1e-6, "{r:?}");
    assert!(check_overlaps(&f, "e", 1e-6).is_err());
    // 2000 random spheres: the cell list finds the deepest pair that brute force finds
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
    let len = [13.0, 9.0, 11.0];
    let parts: Vec<XyzParticle> = (0..2000)
        .map(|_| {
            XyzParticle::sphere(
                Vector3::from_fn(|k, _| rng.gen::<f64>() * len[k]),
                0.2 + 0.3 * rng.gen::<f64>(),
            )
        })
        .collect();
    let mut deepest = 0.0f64;
    for i in 0..parts.len() {
        for j in i + 1..parts.len() {
            let d = parts[j].position - parts[i].position;
            let d = Vector3::from_fn(|k, _| d[k] - len[k] * (d[k] / len[k]).round());
            let depth = parts[i].radius + parts[j].radius - d.norm();
            deepest = deepest.max(depth / (2.0 * parts[i].radius.min(parts[j].radius)));
        }
    }
    let f = xyz::Frame {
        cell: Cell {
            lengths: len,
            origin: [0.0; 3],
            pbc: [true; 3],
        },
        lines: (3..2003).collect(),
        particles: parts,
    };
    let r = check_overlaps(&f, "random", 10.0).unwrap_or_else(|e| panic!("{e} {deepest}"));
    assert!(
        (r.deepest - deepest).abs() < 1e-12,
        "{} {deepest}",
        r.deepest
    );
}

fn porelab(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_porelab"))
        .arg("permeability")
        .args(args)
        .output()
        .unwrap()
}

/// Exit status 2 and exactly one line on stderr, holding every needle.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(2), "{err}");
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "not one line: {err}");
    for n in needles {
        assert!(err.contains(n), "message lacks {n:?}: {err}");
    }
    err
}

/// A porelab-layout file of spheres of radius 0.5 in a periodic box of side 4, one per
/// centre, with `lines` replacing the particle lines when given.
fn spheres_file(dir: &Path, name: &str, centres: &[&str], lattice: &str) -> PathBuf {
    let mut s = format!(
        "{}\nLattice=\"{lattice}\" pbc=\"T T T\" Properties={}\n",
        centres.len(),
        xyz::PROPERTIES
    );
    for c in centres {
        s.push_str(&format!("{c} 0 0 0 1 0.5 0.5 0.5 0.5 0 1 1\n"));
    }
    let p = dir.join(name);
    std::fs::write(&p, s).unwrap();
    p
}

#[test]
fn bad_packings_and_options_are_refused_in_one_line() {
    let d = scratch("refusals");
    let lat = "4 0 0 0 4 0 0 0 4";
    let run = |p: &Path, extra: &[&str]| {
        let mut a = vec![p.to_str().unwrap()];
        a.extend_from_slice(extra);
        porelab(&a)
    };
    let overl = spheres_file(&d, "overlap.xyz", &["sphere 1 1 1", "sphere 1.9 1 1"], lat);
    refused(
        &run(&overl, &[]),
        &["overlap.xyz", "lines 3 and 4 overlap", "--max-overlap"],
    );
    let same = spheres_file(&d, "same.xyz", &["sphere 1 1 1", "sphere 1 1 1"], lat);
    refused(
        &run(&same, &["--max-overlap", "0.25"]),
        &["same.xyz", "same position"],
    );
    let nan = spheres_file(&d, "nan.xyz", &["sphere 1 1 1", "sphere 3 nan 3"], lat);
    refused(
        &run(&nan, &[]),
        &["nan.xyz", "line 4", "`pos` is NaN", "finite"],
    );
    let cube = spheres_file(&d, "cube.xyz", &["sphere 1 1 1", "cube 3 3 3"], lat);
    refused(
        &run(&cube, &[]),
        &["cube.xyz", "line 4", "type `cube`", "does not voxelise"],
    );
    let none = spheres_file(&d, "none.xyz", &[], lat);
    refused(&run(&none, &[]), &["none.xyz", "no particles"]);
    let zeros = spheres_file(&d, "zeros.xyz", &["sphere 1 1 1"], "0 0 0 0 0 0 0 0 0");
    refused(
        &run(&zeros, &[]),
        &["zeros.xyz", "line 2", "Lattice", "must be positive"],
    );
    let one = spheres_file(&d, "one.xyz", &["sphere 1 1 1"], lat);
    refused(
        &run(&one, &["--resolution", "1"]),
        &[
            "--resolution 1",
            "one.xyz",
            "line 3",
            "sqrt(3)/2 dx",
            "--resolution >= 7",
        ],
    );
    refused(
        &run(&one, &["--unit-m", "-1"]),
        &["--unit-m -1", "must be positive"],
    );
    refused(
        &run(&one, &["--max-overlap", "-0.1"]),
        &["--max-overlap -0.1"],
    );
    // negative numbers reach each option's own check, not the parser
    refused(
        &run(&one, &["--force", "-1e-6"]),
        &["--force", "-0.000001", "positive"],
    );
    refused(
        &run(&one, &["--tau", "-1"]),
        &["tau = -1", "must be >= 0.505"],
    );
    refused(&run(&one, &["--frame=-2"]), &["--frame -2", "1 frame"]);
    refused(
        &run(&data("lammps_spheres.dump"), &["--frame", "-7"]),
        &["--frame -7", "3 frames"],
    );
    // a dump without sizes, and a box with walls
    let atom = d.join("atom.dump");
    std::fs::write(
        &atom,
        "ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n1\nITEM: BOX BOUNDS pp pp pp\n0 4\n0 4\n0 4\n\
         ITEM: ATOMS id type xs ys zs\n1 1 0.5 0.5 0.5\n",
    )
    .unwrap();
    refused(
        &run(&atom, &[]),
        &["atom.dump", "line 9", "no `radius` or `diameter`"],
    );
    refused(
        &run(&data("liggghts_spheres.dump"), &["--resolution", "16"]),
        &["pbc", "periodic box"],
    );
}

/// What was read is printed before the run: format, frame, timestep and count.
#[test]
fn the_command_says_what_it_read() {
    let o = porelab(&[
        data("lammps_spheres.dump").to_str().unwrap(),
        "--resolution",
        "2",
    ]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        out.contains("LAMMPS dump, frame 3 of 3 (timestep 20), 48 particles, box 4 x 4 x 3"),
        "{out}"
    );
    // cells of 2 across: the spheres of radius 0.3 need sqrt(3)/2 x 4 / 0.3 = 11.5 -> 12
    refused(&o, &["--resolution 2", "--resolution >= 12"]);
}

/// A jammed porelab packing passes the default tolerance, and the deepest overlap the check
/// finds (cell list and contact kernels) is the one the packing's own analysis reports from
/// its separate pair search (summary.json `deepest_overlap`; rods of diameter 1, so the
/// fraction of the size is the depth).
#[test]
fn a_porelab_packing_passes_with_its_own_deepest_overlap() {
    let d = scratch("rods");
    let scene = "kind = \"packing\"\n[particles]\nshape = \"spherocylinder\"\nn = 60\n\
                 length_over_diameter = 1.0\n[mcm]\nseed = 3\nhalvings = 3\n";
    let opts = porelab::scene::RunOptions {
        out: Some(d.clone()),
        quiet: true,
        threads: Some(1),
        ..Default::default()
    };
    porelab::scene::run_text(scene, "rods", "rods", &opts).unwrap();
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("summary.json")).unwrap()).unwrap();
    let want = summary["deepest_overlap"].as_f64().unwrap();
    assert!(want > 1e-5, "a jammed packing touches: {want}");
    let c = configuration::read(&d.join("final.xyz"), -1, "--frame").unwrap();
    let r = check_overlaps(&c.data, "rods", 1e-3).unwrap();
    assert!(
        (r.deepest - want).abs() < 1e-9,
        "{} against {want}",
        r.deepest
    );
    assert_eq!(r.undecided, 0);
}
