//! The integration tests of `volcano_egui`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_egui --test it MODULE::`.

mod egui_order;
mod overlay_hdr;
