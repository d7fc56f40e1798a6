//! The integration tests of `volcano`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano --test it MODULE::`.

mod assets;
#[cfg(feature = "bsn")]
mod bsn;
mod despawns;
mod export;
mod fixed_rates;
mod fuzz;
mod headless_sim;
mod host_app;
mod module_cycles;
mod placement;
mod readme;
mod reflect;
mod reflect_fuzz;
mod save_load;
mod styles;
mod thread_counts;
mod view_boundary;
mod worlds;
