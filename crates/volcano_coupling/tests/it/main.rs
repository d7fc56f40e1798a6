//! The integration tests of `volcano_coupling`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_coupling --test it MODULE::`.

mod column_heat;
mod coupled;
mod ground_heat;
