//! Generators of the independent reference tables in `reference/`. Nothing here calls the
//! code under test (`magnetics`, ...): each oracle is written from a different formulation.

use crate::Result;

/// `porelab reference regen [NAME]`.
pub fn cli_regen(_name: Option<&str>) -> Result<()> {
    Err(crate::Error::Validation("reference regen: not built yet".into()))
}

/// `porelab reference list`.
pub fn cli_list() -> Result<()> {
    Ok(())
}
