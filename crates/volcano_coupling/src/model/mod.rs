//! Model layer of the coupling: plain functions over the layers' fields and a list of column
//! slices; no ECS types.

pub mod column;
pub mod inject;
