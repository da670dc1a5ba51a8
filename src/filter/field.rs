//! The fibres' field as the engine's field source: the exact periodic superposition or its
//! fast representation ([`crate::magnetics::assembly_fast`]), both wrapping the point into the
//! cell themselves.

use crate::brownian::FieldSource;
use crate::magnetics::assembly_fast::{FastAssembly, FibreAssembly, TabulatedAssembly};
use nalgebra::{Matrix3, Vector3};

impl FieldSource for FibreAssembly {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        self.exact(p)
    }
}

impl FieldSource for FastAssembly {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        FastAssembly::h_and_gradient(self, p)
    }
}

impl FieldSource for TabulatedAssembly {
    fn h_and_gradient(&self, p: &Vector3<f64>) -> (Vector3<f64>, Matrix3<f64>) {
        TabulatedAssembly::h_and_gradient(self, p)
    }
}
