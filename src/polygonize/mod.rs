//! Polygonisation of dual cells (temporary mod file; replaced by the mesh branch).
pub mod extract;
pub mod mc33;
