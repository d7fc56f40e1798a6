//! The integration tests of `volcano_lava`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_lava --test it MODULE::`.

mod analytic;
mod conservation;
mod cooling;
mod faults;
mod flank;
mod folds;
mod fountain;
mod mobility_cap;
mod placement;
mod plugin;
mod robustness;
mod simd;
mod vents;
