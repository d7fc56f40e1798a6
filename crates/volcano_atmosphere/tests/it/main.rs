//! The integration tests of `volcano_atmosphere`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_atmosphere --test it MODULE::`.

mod behaviour;
mod cadence;
mod convergence;
mod departures;
mod ground;
mod pipeline;
mod plugin;
mod pool;
mod properties;
mod simd;
mod terrain_coupling;
