//! Model layer: plain structs and functions, each physical law beside the thesis equation it
//! implements.

pub mod ambient;
pub mod column;
pub mod deposit;
pub mod humid;
pub mod inverse;
pub mod params;
pub mod pyroclastic;
pub mod run;
pub mod slice;
pub mod spheres;
pub mod umbrella;
pub mod wind;
