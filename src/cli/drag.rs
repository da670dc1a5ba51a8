//! `porelab drag --semi-axes A,B,C --viscosity MU`: principal translational resistances of an
//! ellipsoid (N s/m, along each semi-axis) and the orientation-averaged resistance
//! f = 3 / sum(1/C_i), printed as `{"resistance": [Ca, Cb, Cc], "mobility_averaged_resistance": f}`.

use crate::cli::shape::{json_number, parse_three};
use crate::error::{invalid, Result};
use crate::hydro::happel_brenner::EllipsoidDrag;
use std::process::ExitCode;

#[derive(Debug, clap::Args)]
pub struct DragArgs {
    /// Semi-axes A,B,C in m.
    #[arg(long = "semi-axes", allow_hyphen_values = true)]
    pub semi_axes: String,
    /// Dynamic viscosity in Pa s.
    #[arg(long, allow_hyphen_values = true)]
    pub viscosity: f64,
}

/// The JSON result of `porelab drag`, keys in the documented order.
pub fn drag_json(args: &DragArgs) -> Result<String> {
    let axes = parse_three(&args.semi_axes, "semi-axes")?;
    let d = EllipsoidDrag::new(axes, args.viscosity)?;
    let f = d.mobility_averaged();
    if !(d.principal.iter().all(|c| c.is_finite()) && f.is_finite()) {
        return invalid(format!(
            "resistance ({:e}, {:e}, {:e}) N s/m is not finite in f64 for semi-axes ({:e}, {:e}, {:e}) m and viscosity {:e} Pa s",
            d.principal[0], d.principal[1], d.principal[2], axes[0], axes[1], axes[2], args.viscosity
        ));
    }
    Ok(format!(
        "{{\"resistance\": [{}, {}, {}], \"mobility_averaged_resistance\": {}}}",
        json_number(d.principal[0]),
        json_number(d.principal[1]),
        json_number(d.principal[2]),
        json_number(f)
    ))
}

/// `porelab drag`.
pub fn run_drag(args: &DragArgs) -> Result<ExitCode> {
    println!("{}", drag_json(args)?);
    Ok(ExitCode::SUCCESS)
}
