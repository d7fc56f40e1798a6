//! The integration tests of `volcano_plume`: one test binary (one link), a module per topic.
//! Run one module with `cargo test -p volcano_plume --test it MODULE::`.

mod caps;
mod common;
mod current_clouds;
mod domain;
mod faults;
mod flows_domain;
mod physical;
mod physical_plugin;
mod plugin;
mod pyroclastic;
mod pyroclastic_plugin;
mod robustness;
mod thesis_numbers;
mod timeline;
mod two_volcanoes;
mod umbrella_view;
