//! The integration tests of `volcano_cli`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_cli --test it MODULE::`.

mod cli;
