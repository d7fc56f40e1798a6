//! The integration tests of `volcano_render`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_render --test it MODULE::`.

mod common;
mod gpu_expansion;
mod headless_ash;
mod headless_ash_body;
mod headless_ash_fall;
mod headless_ash_light;
mod headless_ash_vent;
mod headless_cloud_over_ash;
mod headless_clouds;
mod headless_ground_detail;
mod headless_horizon;
mod headless_lava;
mod headless_lit_clouds;
mod headless_smoke;
mod headless_write_error;
mod interpolation;
mod lava_placement;
mod unrendered;
