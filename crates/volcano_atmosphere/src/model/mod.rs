//! Model layer: plain data and functions, no ECS types. Each physical law is a function with
//! a doc comment naming its thesis equation (Lastic 2023, §4.2) and the DESIGN.md erratum
//! where one applies.

pub mod advection;
pub mod fields;
pub mod multigrid;
pub mod params;
pub mod projection;
pub mod thermo;
