//! The VTK image data written for lattice-Boltzmann fields, read back by an independent reader
//! (meshio, through python3). Without python3 or meshio the test prints why and skips.

use porelab::io::vtk::{write_image_data, CellField};
use porelab::lbm::flows::sphere_array_mask;
use porelab::lbm::{
    Accel, CollisionKind, CollisionModel, Dims, Domain, ForcingModel, LatticeKind, Lbm, Setup, Tau,
};
use std::process::Command;

#[test]
fn vtk_fields_read_by_meshio() {
    let probe = Command::new("python3")
        .args(["-c", "import meshio"])
        .output();
    match probe {
        Err(e) => {
            eprintln!("SKIPPED vtk_fields_read_by_meshio: python3 not runnable ({e})");
            return;
        }
        Ok(o) if !o.status.success() => {
            eprintln!(
                "SKIPPED vtk_fields_read_by_meshio: python3 cannot import meshio ({}); \
                 `pip install meshio` enables this test",
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            );
            return;
        }
        Ok(_) => {}
    }
    let (nx, ny, nz) = (6, 5, 4);
    let d = Dims::new(nx, ny, nz).unwrap();
    let mut mask = sphere_array_mask(6, 1.6);
    mask.truncate(d.cells());
    let domain = Domain::with_solid(d, mask.clone()).unwrap();
    let trt = CollisionModel::new(CollisionKind::Trt, Tau::new(0.9).unwrap());
    let body = ForcingModel::Body(Accel::new([1e-4, 3e-5, -2e-5]).unwrap());
    let setup = Setup::new(LatticeKind::D3Q19, trt, domain).with_forcing(body);
    let mut s = Lbm::new(setup).unwrap();
    s.run(20).unwrap();
    let f = s.fields();
    let solid: Vec<f64> = mask.iter().map(|&b| if b { 1.0 } else { 0.0 }).collect();
    // a porosity field that differs from cell to cell, as the Guo-Zhao scenes write
    let porosity: Vec<f64> = (0..d.cells())
        .map(|i| 0.3 + 0.7 * (i % 7) as f64 / 6.0)
        .collect();
    let dir = std::env::temp_dir().join(format!("porelab-vtk-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("fields.vtk");
    write_image_data(
        &path,
        "test",
        [nx, ny, nz],
        0.5,
        [0.0; 3],
        &[
            CellField::Vector("velocity", &f.u),
            CellField::Scalar("density", &f.rho),
            CellField::Scalar("porosity", &porosity),
            CellField::Scalar("solid", &solid),
        ],
    )
    .unwrap();
    let script = "import sys, meshio\n\
        m = meshio.read(sys.argv[1])\n\
        n = sum(len(c.data) for c in m.cells)\n\
        print('cells', n, 'points', len(m.points))\n\
        u = m.cell_data['velocity'][0]; r = m.cell_data['density'][0].ravel(); s = m.cell_data['solid'][0].ravel(); e = m.cell_data['porosity'][0].ravel()\n\
        for i in range(n):\n    print(repr(float(u[i][0])), repr(float(u[i][1])), repr(float(u[i][2])), repr(float(r[i])), repr(float(s[i])), repr(float(e[i])))\n";
    let out = Command::new("python3")
        .args(["-c", script, path.to_str().unwrap()])
        .output()
        .unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        out.status.success(),
        "meshio failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    let mut lines = text.lines();
    assert_eq!(
        lines.next().unwrap(),
        format!(
            "cells {} points {}",
            d.cells(),
            (nx + 1) * (ny + 1) * (nz + 1)
        )
    );
    let mut fluid_moving = 0;
    for (i, l) in lines.enumerate() {
        let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
        assert_eq!(v[..3], f.u[i], "velocity of cell {i}");
        assert_eq!(v[3], f.rho[i], "density of cell {i}");
        assert_eq!(v[4], solid[i], "solid of cell {i}");
        assert_eq!(v[5], porosity[i], "porosity of cell {i}");
        if v[4] == 0.0 && v[0] > 0.0 {
            fluid_moving += 1;
        }
    }
    assert!(fluid_moving > 0, "no moving fluid cell read back");
}
