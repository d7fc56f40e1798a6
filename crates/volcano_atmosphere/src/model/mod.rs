//! Model layer: plain data and functions, no ECS types. Each physical law is a function with a
//! doc comment naming its thesis equation (Lastic 2023, §4.2) and the erratum of
//! docs/physics/atmosphere.md §5.3 where one applies.

pub mod advection;
pub mod amplify;
pub mod ash;
pub mod clouds;
pub mod fields;
pub mod guard;
pub mod maps;
pub mod multigrid;
pub mod paint;
pub mod params;
pub mod projection;
pub mod run;
pub mod scenario;
pub mod step;
pub mod sun;
pub mod terrain;
pub mod thermo;
pub mod vertical;
pub mod volume;
