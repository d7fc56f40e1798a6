//! The exporter's integration tests: its files read back by OpenVDB itself (`openvdb`), by its
//! own reader over random grids (`round_trip`), and bad bytes refused without a panic.

mod openvdb;
mod round_trip;
