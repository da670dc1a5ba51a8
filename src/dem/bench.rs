//! `porelab bench dem` (see [`run`]).
