//! The one-shot commands of `porelab` that evaluate a kernel on user input: `field`, `contact`,
//! `shape`, `drag`. They sit beside the kernels, which never import them.

pub mod contact;
pub mod drag;
pub mod field;
pub mod shape;
