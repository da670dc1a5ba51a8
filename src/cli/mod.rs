//! The one-shot commands of `porelab` that evaluate a kernel or an engine on user input:
//! `field`, `contact`, `shape`, `drag`, `permeability`. They sit beside the kernels and
//! engines, which never import them.

pub mod contact;
pub mod drag;
pub mod field;
pub mod ladder_checkpoint;
pub mod packing_input;
pub mod permeability;
pub mod shape;
