//! The case runners. Each registers itself next to its function with `register!`, naming the
//! case numbers it answers; [`super::case::runner_for`] finds it. A new case is its folder
//! under `validation/` plus one registered function here.

/// Registers `run` as the runner of the listed case numbers (`register!("801" => case_801);`,
/// written just above the function).
macro_rules! register {
    ($($id:literal),+ => $run:path) => {
        const _: () = {
            #[linkme::distributed_slice(crate::validation::case::RUNNERS)]
            static REGISTRATION: crate::validation::case::Registration =
                crate::validation::case::Registration {
                    ids: &[$($id),+],
                    run: $run,
                };
        };
    };
}

mod brownian;
mod brownian_capture;
mod brownian_chains;
mod brownian_equilibrium;
mod brownian_scenes;
mod common;
mod contact;
mod coupled;
mod dem;
mod dem_figures;
mod dem_packing;
mod dem_zhou;
mod deposition;
mod deposition_figures;
mod drag;
mod elliptic_cases;
mod field_analytic;
mod field_oracle;
mod filter;
mod filter_thesis;
mod lbm;
mod lbm_boundaries;
mod lbm_packings;
mod packing;
mod packing_confined;
mod shapes;

#[cfg(test)]
mod tests {
    use crate::validation::case::{registered_twice, runner_for, RUNNERS};
    use crate::validation::{discover, repo_root};

    #[test]
    fn every_case_folder_has_one_runner_and_every_runner_a_folder() {
        let cases = discover(&repo_root()).unwrap();
        assert!(cases.len() > 100, "{} cases found", cases.len());
        let missing: Vec<_> = cases
            .iter()
            .filter(|c| runner_for(&c.id).is_none())
            .map(|c| c.folder.as_str())
            .collect();
        assert!(missing.is_empty(), "no runner registered for {missing:?}");
        assert!(registered_twice().is_empty(), "{:?}", registered_twice());
        let orphans: Vec<_> = RUNNERS
            .iter()
            .flat_map(|r| r.ids.iter())
            .filter(|id| !cases.iter().any(|c| c.id == **id))
            .collect();
        assert!(
            orphans.is_empty(),
            "runners without a case folder: {orphans:?}"
        );
    }
}
