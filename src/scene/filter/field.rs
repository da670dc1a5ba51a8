//! The fibres' field of a filter scene as its run builds it from the plan: the exact
//! superposition or the tabulated one (the cylinder table built here), and what the summary
//! states of it.

use super::schema::FieldPlan;
use crate::brownian::FieldSource;
use crate::error::Result;
use crate::magnetics::assembly_fast::TabulatedAssembly;

/// What the summary states of the fibres' field: the method, the image cutoff and, for the
/// tabulated superposition, the table's tolerance, images listed per point and build time.
#[derive(Debug, Clone, Copy)]
pub(super) struct FieldReport {
    pub method: &'static str,
    pub cutoff_m: f64,
    pub table_tolerance: Option<f64>,
    pub images_per_bin: Option<f64>,
    pub build_seconds: f64,
}

impl FieldReport {
    pub fn describe(&self) -> String {
        match self.table_tolerance {
            None => format!("exact superposition, cutoff {:e} m", self.cutoff_m),
            Some(t) => format!(
                "tabulated superposition, table tolerance {t:e}, cutoff {:e} m, {:.0} images \
                 listed per point, built in {:.1} s",
                self.cutoff_m,
                self.images_per_bin.unwrap_or(0.0),
                self.build_seconds
            ),
        }
    }
}

/// The field source a plan asks for (the table built here, deterministically at any thread
/// count) and its report.
pub(super) fn build_field(plan: FieldPlan) -> Result<(Box<dyn FieldSource>, FieldReport)> {
    let cutoff_m = plan.model.cutoff().map_or(f64::INFINITY, |c| c.radius_m);
    Ok(match plan.table {
        None => (
            Box::new(plan.model),
            FieldReport {
                method: "exact",
                cutoff_m,
                table_tolerance: None,
                images_per_bin: None,
                build_seconds: 0.0,
            },
        ),
        Some((spec, bin_edge_m)) => {
            let tab = TabulatedAssembly::new(plan.model, spec, bin_edge_m, None)?;
            let st = *tab.stats();
            (
                Box::new(tab),
                FieldReport {
                    method: "tabulated",
                    cutoff_m,
                    table_tolerance: Some(spec.tolerance),
                    images_per_bin: Some(st.images_per_bin),
                    build_seconds: st.build_seconds,
                },
            )
        }
    })
}
