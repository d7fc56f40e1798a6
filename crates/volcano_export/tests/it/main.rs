//! The exporter's integration tests: its files read back by OpenVDB itself (`openvdb`), by its
//! own reader over random grids (`round_trip`), and bad bytes refused without a panic; its
//! glTF files read back by the `gltf` crate (`gltf`).

mod gltf;
mod openvdb;
mod round_trip;
