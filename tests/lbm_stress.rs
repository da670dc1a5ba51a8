//! Bad and extreme input for the lattice-Boltzmann engine: a clear message, never NaN fields.

use porelab::lbm::flows::{brinkman_poiseuille, channel_coordinate};
use porelab::lbm::geometry::{Dims, Geometry};
use porelab::lbm::problems::Channel;
use porelab::lbm::solver::check_memory;
use porelab::lbm::steady::SteadyControl;
use porelab::lbm::units::{check_mach, Units};
use porelab::lbm::{Porous, Trt, D3Q19};

const CTL: SteadyControl = SteadyControl {
    check_every: 500,
    tol: 1e-10,
    max_steps: 200_000,
};

#[test]
fn tau_near_half_is_refused() {
    let e = Units::from_tau(1e-5, 1e-6, 1000.0, 0.501)
        .unwrap_err()
        .to_string();
    assert!(e.contains("tau = 0.501") && e.contains("unstable"), "{e}");
    assert!(Units::from_tau(1e-5, 1e-6, 1000.0, 0.6).is_ok());
}

#[test]
fn high_mach_is_refused_before_and_during_a_run() {
    let e = check_mach(0.3, "peak").unwrap_err().to_string();
    assert!(e.contains("Mach 0.520"), "{e}");
    // a channel driven so hard that the flow passes Mach 0.3: the run stops with the reason
    let ch = Channel {
        h: 16,
        g: 1e-2,
        wall_u: 0.0,
        porous: None,
    };
    let e = ch
        .steady::<D3Q19, _>(Trt::magic(1.0), CTL, |_, _| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("Mach") || e.contains("non-finite"), "{e}");
}

#[test]
fn porosity_outside_its_range_is_refused() {
    let mut p = Porous::clear(4, 0.1, [0.0; 3], true);
    assert!(p.set(0, 0.0, 1.0).unwrap_err().contains("eps = 0"));
    assert!(p.set(0, 1.2, 1.0).unwrap_err().contains("(0, 1]"));
    assert!(p.set(0, 0.5, -1.0).unwrap_err().contains("K = -1"));
    assert!(p.set(0, 1.0, f64::INFINITY).is_ok());
}

/// eps near 0 and near 1 and Da = 1e-6 give finite steady fields (Forchheimer on), and with
/// the Forchheimer term off the mid-channel velocity of the Brinkman closed form.
#[test]
fn extreme_porous_media_stay_finite() {
    for (eps, da) in [(1e-3, 1e-2), (0.999, 1e-2), (0.5, 1e-6)] {
        let h = 16;
        let k = da * (h * h) as f64;
        let nu = 1.0 / 6.0;
        let g = 1e-4 * nu / k;
        for forch in [true, false] {
            let ch = Channel {
                h,
                g,
                wall_u: 0.0,
                porous: Some((eps, k, forch)),
            };
            let (prof, st) = ch
                .steady::<D3Q19, _>(Trt::magic(1.0), CTL, |_, _| {})
                .unwrap();
            assert!(st.fields.u.iter().flatten().all(|v| v.is_finite()));
            assert!(st.fields.rho.iter().all(|v| v.is_finite()));
            if !forch {
                let y = channel_coordinate(h / 2 + 1);
                let want = brinkman_poiseuille(y, h as f64, g, nu, eps, k);
                let got = prof[h / 2];
                assert!(
                    (got / want - 1.0).abs() < 0.05,
                    "eps {eps} Da {da}: {got} vs {want}"
                );
            }
        }
    }
}

#[test]
fn lattice_too_large_is_refused_naming_the_size() {
    let d = Dims::new(20000, 20000, 20000);
    let e = match d {
        Err(e) => e.to_string(),
        Ok(d) => check_memory(d, 19, 0).unwrap_err().to_string(),
    };
    assert!(e.contains("20000 x 20000 x 20000"), "{e}");
    let d = Dims::new(1500, 1500, 1500).unwrap();
    let e = check_memory(d, 19, 0).unwrap_err().to_string();
    assert!(e.contains("GiB") && e.contains("1500 x 1500 x 1500"), "{e}");
}

#[test]
fn all_solid_mask_has_no_flow_path() {
    let d = Dims::new(4, 4, 4).unwrap();
    let g = Geometry::new::<D3Q19>(d, vec![true; 64], |_| [0.0; 3]).unwrap();
    let e =
        porelab::lbm::problems::permeability::<D3Q19, _>(g, Trt::magic(1.0), 1e-6, CTL, |_, _| {})
            .unwrap_err()
            .to_string();
    assert!(e.contains("permeability is 0"), "{e}");
}

/// Boundary planes (non-equilibrium extrapolation): a plane in the solid, a plane too thin for
/// the extrapolation, a mask with no path from inlet to outlet (flow rate 0, said plainly) and
/// a pressure drop too large for the lattice (stopped with the Mach number, never NaN).
#[test]
fn boundary_planes_refuse_what_they_cannot_do() {
    use porelab::lbm::boundary::{connected, Face, Plane};
    use porelab::lbm::flows::channel_mask;
    use porelab::lbm::problems::{DrivenChannel, Inlet};
    let d = Dims::new(8, 6, 1).unwrap();
    let geom = Geometry::new::<D3Q19>(d, channel_mask(d), |_| [0.0; 3]).unwrap();
    let e = Plane::density(
        &geom,
        Face {
            axis: 1,
            high: false,
        },
        1.0,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("y-") && e.contains("no fluid node"), "{e}");
    let e = Plane::density(
        &geom,
        Face {
            axis: 0,
            high: true,
        },
        f64::NAN,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("density NaN"), "{e}");
    let thin = Dims::new(2, 6, 1).unwrap();
    let g2 = Geometry::new::<D3Q19>(thin, channel_mask(thin), |_| [0.0; 3]).unwrap();
    let e = Plane::density(
        &g2,
        Face {
            axis: 0,
            high: false,
        },
        1.0,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("at least 3"), "{e}");
    assert!(Face::parse("w+", "inlet")
        .unwrap_err()
        .to_string()
        .contains("inlet = \"w+\""));
    // a solid wall across the channel at x = 4: no path between the end planes
    let mut mask = channel_mask(d);
    for y in 0..6 {
        mask[d.cell(4, y, 0)] = true;
    }
    let blocked = Geometry::new::<D3Q19>(d, mask, |_| [0.0; 3]).unwrap();
    // the inlet (x-) and outlet (x+) planes of a geometry, joined or not
    let joined = |g: &Geometry| {
        let end = |high: bool, rho: f64| Plane::density(g, Face { axis: 0, high }, rho).unwrap();
        connected::<D3Q19>(g, &end(false, 1.001), &end(true, 0.999))
    };
    assert!(!joined(&blocked));
    assert!(joined(&geom));
    // a pressure drop far beyond the lattice's range: stopped, with the reason
    let ch = DrivenChannel {
        h: 16,
        length: 32,
        inlet: Inlet::Density(1.4),
        rho_out: 0.6,
    };
    let e = ch
        .steady::<D3Q19, _>(Trt::magic(1.0), CTL, |_, _| {})
        .unwrap_err()
        .to_string();
    assert!(e.contains("Mach") || e.contains("non-finite"), "{e}");
}
