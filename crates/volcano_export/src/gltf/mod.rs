//! Triangle meshes and line sets as binary glTF 2.0 (`.glb`): [`write_glb`] /
//! [`write_glb_file`], opened by Blender's glTF importer, Bevy's loader or any glTF 2.0
//! reader.
//!
//! The frame needs no conversion: glTF is right-handed, y-up, in metres, with
//! counter-clockwise front faces, as is Bevy's world.
//!
//! Layout of a file: one scene; per [`MeshData`] one node, one mesh of one indexed triangle
//! primitive (mode 4) and one material; per [`LineData`] the same with a line primitive (mode
//! 1). Each accessor has its own tightly packed buffer view, 4-byte aligned in the one buffer
//! that is the GLB's BIN chunk. A mesh's attributes are `POSITION` (with the `min` and `max`
//! the specification requires), optionally `NORMAL`, `COLOR_0` (float RGBA) and the custom
//! attribute `_TEMPERATURE` (float scalar, Kelvin; custom attribute names start with an
//! underscore), and `u32` indices.
//!
//! The JSON is the `gltf-json` crate's document model, the one the `gltf` crate reads (and
//! Bevy's loader with it), serialised with its field names and enum values as the
//! specification spells them. The GLB container around it (a 12-byte header, a JSON chunk and
//! a BIN chunk, [`MAGIC`] to [`CHUNK_BIN`]) is a few dozen lines and written here by hand.
//!
//! Every input is checked before a byte is written ([`GltfError`]): a refused mesh leaves the
//! writer untouched, and [`write_glb_file`] leaves no file. The binary buffer is assembled in
//! memory, so writing needs about the size of the file in memory.

mod document;
mod glb;
mod validate;

use std::io::Write;
use std::path::Path;

pub use glb::{CHUNK_BIN, CHUNK_JSON, MAGIC, VERSION};

/// `asset.generator` of every file written.
pub const GENERATOR: &str = "volcano_export";
/// The name of the custom vertex attribute holding [`MeshData::temperature`].
pub const TEMPERATURE_ATTRIBUTE: &str = "_TEMPERATURE";

/// A triangle mesh: a node, a mesh of one indexed triangle primitive and a material.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshData {
    /// The name of the node, the mesh and the material; not empty.
    pub name: String,
    /// Vertex positions in metres (`POSITION`); at least one.
    pub positions: Vec<[f32; 3]>,
    /// Unit vertex normals (`NORMAL`), one per position.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Vertex indices, three per triangle, counter-clockwise seen from the front.
    pub indices: Vec<u32>,
    /// Linear RGBA vertex colours (`COLOR_0`) in [0, 1], one per position; they multiply
    /// `base_color`.
    pub colors: Option<Vec<[f32; 4]>>,
    /// Temperature in Kelvin, one per position (the custom attribute `_TEMPERATURE`).
    pub temperature: Option<Vec<f32>>,
    /// Linear RGB emission of the material, each component at least 0. Above 1 it is written
    /// as an `emissiveFactor` scaled to 1 times a `KHR_materials_emissive_strength`.
    pub emissive: Option<[f32; 3]>,
    /// Linear RGBA base colour of the material, each component in [0, 1]; an alpha below 1
    /// makes the material blended.
    pub base_color: [f32; 4],
}

/// A set of line segments: a node, a mesh of one indexed line primitive and a material.
#[derive(Clone, Debug, PartialEq)]
pub struct LineData {
    /// The name of the node, the mesh and the material; not empty.
    pub name: String,
    /// Vertex positions in metres (`POSITION`); at least one.
    pub positions: Vec<[f32; 3]>,
    /// Vertex indices, two per segment.
    pub indices: Vec<u32>,
    /// Linear RGBA colour of the lines, each component in [0, 1].
    pub color: [f32; 4],
}

/// What can go wrong writing a glTF file. `name` is the mesh's or line set's.
#[derive(Debug, thiserror::Error)]
pub enum GltfError {
    /// A mesh or line set without a name (the `index`-th of its slice).
    #[error("{kind} {index} has an empty name")]
    EmptyName {
        /// "mesh" or "line set".
        kind: &'static str,
        /// Its position in its slice.
        index: usize,
    },
    /// No vertices or no indices.
    #[error("`{name}` has no {what}")]
    Empty {
        /// The mesh or line set.
        name: String,
        /// "vertices" or "indices".
        what: &'static str,
    },
    /// More vertices or indices than `u32` indices and counts allow.
    #[error("`{name}` has {count} {what}, more than {limit}")]
    TooMany {
        /// The mesh or line set.
        name: String,
        /// "vertices" or "indices".
        what: &'static str,
        /// How many it has.
        count: usize,
        /// The most allowed.
        limit: u64,
    },
    /// A vertex attribute whose length differs from the number of positions.
    #[error("`{name}` has {len} {attribute} for {vertices} positions")]
    Length {
        /// The mesh.
        name: String,
        /// "normals", "colors" or "temperatures".
        attribute: &'static str,
        /// Its length.
        len: usize,
        /// The number of positions.
        vertices: usize,
    },
    /// An index count that is not a whole number of triangles or segments.
    #[error("`{name}` has {len} indices, not a multiple of {per}")]
    IndexCount {
        /// The mesh or line set.
        name: String,
        /// The number of indices.
        len: usize,
        /// 3 for triangles, 2 for lines.
        per: usize,
    },
    /// An index that names no vertex.
    #[error("`{name}`: index {at} is {index}, but there are {vertices} vertices")]
    IndexOutOfRange {
        /// The mesh or line set.
        name: String,
        /// Its position among the indices.
        at: usize,
        /// Its value.
        index: u32,
        /// The number of vertices.
        vertices: usize,
    },
    /// A NaN or infinite value.
    #[error("`{name}`: non-finite {attribute} at {at}")]
    NonFinite {
        /// The mesh or line set.
        name: String,
        /// "position", "normal", "color", "temperature", "base color", "emissive" or "line color".
        attribute: &'static str,
        /// The vertex (0 for a material value).
        at: usize,
    },
    /// A normal whose length is not 1 (the specification requires unit normals).
    #[error("`{name}`: normal {at} has length {length}, not 1")]
    NotUnit {
        /// The mesh.
        name: String,
        /// The vertex.
        at: usize,
        /// Its length.
        length: f32,
    },
    /// A value outside its range: a vertex, base or line colour component outside [0, 1] (the
    /// specification's range for colours), a negative emission.
    #[error("`{name}`: {attribute} {value:?} at {at} out of range")]
    OutOfRange {
        /// The mesh or line set.
        name: String,
        /// "color", "base color", "line color" or "emissive".
        attribute: &'static str,
        /// The vertex (0 for a material value).
        at: usize,
        /// The value.
        value: Vec<f32>,
    },
    /// A file of more than the 4 GiB a GLB's 32-bit lengths can describe.
    #[error("the file would be {bytes} bytes, more than a GLB's {limit}")]
    TooLarge {
        /// Its size.
        bytes: u64,
        /// The most a GLB holds.
        limit: u64,
    },
    /// The JSON could not be serialised.
    #[error("cannot serialise the glTF JSON: {0}")]
    Json(#[from] serde_json::Error),
    /// Writing failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Creating, flushing or renaming a file failed: nothing was left at its path.
    #[error("{0}")]
    File(#[from] crate::atomic::FileError),
}

/// Writes `meshes` and `lines` as one binary glTF to `w`. Everything is checked first: on an
/// error other than [`GltfError::Io`] nothing was written.
pub fn write_glb<W: Write>(w: &mut W, meshes: &[MeshData], lines: &[LineData]) -> Result<(), GltfError> {
    for (i, m) in meshes.iter().enumerate() {
        validate::mesh(i, m)?;
    }
    for (i, l) in lines.iter().enumerate() {
        validate::lines(i, l)?;
    }
    validate::size(meshes, lines)?;
    let (root, bin) = document::build(meshes, lines);
    let json = root.to_vec()?;
    glb::write(w, &json, &bin)
}

/// Writes `meshes` and `lines` to `path` through a temporary file in the same folder, renamed
/// to `path` once complete: an error (refused data, a full disk) leaves no file at `path` and
/// no temporary one beside it.
pub fn write_glb_file(path: &Path, meshes: &[MeshData], lines: &[LineData]) -> Result<(), GltfError> {
    crate::atomic::write_atomically(path, |w| write_glb(w, meshes, lines))
}
