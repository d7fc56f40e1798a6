//! The integration tests of `volcano_core`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_core --test it MODULE::`.

mod clock;
