//! Bad and extreme input for the lattice-Boltzmann engine: a clear message, never NaN fields.

use porelab::driver::NoHooks;
use porelab::lbm::flows::{brinkman_poiseuille, channel_coordinate};
use porelab::lbm::memory::check_memory;
use porelab::lbm::problems::{Channel, ChannelFlow};
use porelab::lbm::units::{check_mach, Units};
use porelab::lbm::{
    CollisionKind, CollisionModel, Dims, Domain, LatticeKind, Lbm, Porous, Setup, SteadyControl,
    Tau,
};

const D3Q19: LatticeKind = LatticeKind::D3Q19;

/// TRT at tau = 1.
fn trt() -> CollisionModel {
    CollisionModel::new(CollisionKind::Trt, Tau::new(1.0).unwrap())
}

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
        .steady(D3Q19, trt(), CTL, &mut NoHooks)
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
            let (prof, st) = ch.steady(D3Q19, trt(), CTL, &mut NoHooks).unwrap();
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
    let solid = Domain::with_solid(d, vec![true; 64]).unwrap();
    let e = porelab::lbm::problems::permeability(D3Q19, trt(), solid, 1e-6, CTL, &mut NoHooks)
        .unwrap_err()
        .to_string();
    assert!(e.contains("permeability is 0"), "{e}");
}

/// Boundary planes (non-equilibrium extrapolation): a plane in the solid, a plane too thin for
/// the extrapolation, a density that is not a number, a velocity field of the wrong size, a
/// mask with no path from inlet to outlet (flow rate 0, said plainly) and a pressure drop too
/// large for the lattice (stopped with the Mach number, never NaN).
#[test]
fn boundary_planes_refuse_what_they_cannot_do() {
    use porelab::lbm::boundary::Face;
    use porelab::lbm::flows::channel_mask;
    use porelab::lbm::problems::{DrivenChannel, Inlet};
    use porelab::lbm::{PlaneCondition, PlaneSpec, PlaneVelocity};
    let plane = |axis: usize, high: bool, condition: PlaneCondition| PlaneSpec {
        face: Face { axis, high },
        condition,
    };
    // the flow of `mask` on `d` between the planes `planes`, or why it cannot be built
    let flow = |d: Dims, mask: Vec<bool>, planes: Vec<PlaneSpec>| {
        let domain = Domain::with_solid(d, mask).unwrap();
        Lbm::new(Setup::new(D3Q19, trt(), domain).with_boundaries(planes))
    };
    let refused = |d: Dims, planes: Vec<PlaneSpec>| match flow(d, channel_mask(d), planes) {
        Ok(_) => panic!("built"),
        Err(e) => e.to_string(),
    };
    let d = Dims::new(8, 6, 1).unwrap();
    let e = refused(d, vec![plane(1, false, PlaneCondition::Density(1.0))]);
    assert!(e.contains("y-") && e.contains("no fluid node"), "{e}");
    let e = refused(d, vec![plane(0, true, PlaneCondition::Density(f64::NAN))]);
    assert!(e.contains("density NaN"), "{e}");
    let thin = Dims::new(2, 6, 1).unwrap();
    let e = refused(thin, vec![plane(0, false, PlaneCondition::Density(1.0))]);
    assert!(e.contains("at least 3"), "{e}");
    let short = PlaneVelocity::Field(vec![[0.0; 3]; 5]);
    let e = refused(d, vec![plane(0, false, PlaneCondition::Velocity(short))]);
    assert!(e.contains("5 velocities for a face of 6 cells"), "{e}");
    assert!(Face::parse("w+", "inlet")
        .unwrap_err()
        .to_string()
        .contains("inlet = \"w+\""));
    // the inlet (x-) and outlet (x+) planes, joined or not: a solid wall across the channel
    // at x = 4 leaves no path between them
    let ends = || {
        vec![
            plane(0, false, PlaneCondition::Density(1.001)),
            plane(0, true, PlaneCondition::Density(0.999)),
        ]
    };
    let mut mask = channel_mask(d);
    for y in 0..6 {
        mask[d.cell(4, y, 0)] = true;
    }
    assert!(!flow(d, mask, ends()).unwrap().planes_connected(0, 1));
    assert!(flow(d, channel_mask(d), ends())
        .unwrap()
        .planes_connected(0, 1));
    // a pressure drop far beyond the lattice's range: stopped, with the reason
    let ch = DrivenChannel {
        h: 16,
        length: 32,
        inlet: Inlet::Density(1.4),
        rho_out: 0.6,
    };
    let e = ch
        .steady(D3Q19, trt(), CTL, &mut NoHooks)
        .unwrap_err()
        .to_string();
    assert!(e.contains("Mach") || e.contains("non-finite"), "{e}");
}
