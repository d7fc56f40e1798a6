//! Offline export of the volcano plugin set, engine-free: OpenVDB volumes ([`vdb`]) a
//! technical artist opens in Blender, Houdini or any OpenVDB reader, triangle meshes and line
//! sets as binary glTF ([`gltf`]) for Blender or any glTF 2.0 reader, the splatting of the
//! plume's spheres into a density volume ([`splat`]), and files written whole or not at all
//! ([`atomic`]). What a frame holds and how it is gathered from a Bevy world is the
//! `volcano::export` module; the command line is `volcano export` (docs/EXPORT.md).
#![forbid(unsafe_code)]

pub mod atomic;
pub mod gltf;
pub mod splat;
pub mod vdb;
