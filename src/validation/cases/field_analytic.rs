//! stub
use crate::validation::{CaseContext, Row};
use crate::Result;
pub fn case_101(_c: &CaseContext) -> Result<Vec<Row>> { Ok(vec![]) }
pub fn case_102(_c: &CaseContext) -> Result<Vec<Row>> { Ok(vec![]) }
pub fn case_103(_c: &CaseContext) -> Result<Vec<Row>> { Ok(vec![]) }
pub fn case_105(_c: &CaseContext) -> Result<Vec<Row>> { Ok(vec![]) }
pub fn case_106(_c: &CaseContext) -> Result<Vec<Row>> { Ok(vec![]) }
