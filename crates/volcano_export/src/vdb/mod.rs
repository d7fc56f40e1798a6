//! OpenVDB volumes: [`FloatGrid`] (sparse, 8³ leaves, background zero), written by
//! [`write_vdb`] / [`write_vdb_file`] and read back by [`read_vdb`] (the subset this writer
//! produces; OpenVDB itself is the reference, `tools/check_vdb.py`).

mod expect;
mod grid;
mod read;
mod write;

pub use expect::expectation;
pub use grid::{FloatGrid, GridClass, LEAF_DIM, LEAF_VOXELS, MetaValue, Transform};
pub use read::{ReadGrid, read_vdb};
pub use write::{COMPRESS_ACTIVE_MASK, FILE_VERSION, MAGIC, TREE_TYPE, write_vdb};

use std::path::Path;

/// Index of a voxel (i, j, k).
pub type Coord = [i32; 3];

/// What can go wrong building, writing or reading a volume.
#[derive(Debug, thiserror::Error)]
pub enum VdbError {
    /// A grid or metadata name that is empty, too long or holds control characters.
    #[error("invalid grid or metadata name `{0}`")]
    Name(String),
    /// An invalid transform.
    #[error("invalid transform: {0}")]
    Transform(String),
    /// An invalid metadata value.
    #[error("invalid metadata: {0}")]
    Metadata(String),
    /// A value that is NaN or infinite.
    #[error("non-finite value for voxel {ijk:?} of grid `{grid}`")]
    NonFinite {
        /// The grid.
        grid: String,
        /// The voxel.
        ijk: Coord,
    },
    /// A grid that would exceed its voxel budget.
    #[error("grid `{grid}` would need more than {limit} active voxels (use larger voxels)")]
    TooManyVoxels {
        /// The grid.
        grid: String,
        /// The limit.
        limit: u64,
    },
    /// Reading or writing failed (the path is in the message where known).
    #[error("{0}")]
    Io(#[from] std::io::Error),
    /// Creating, flushing or renaming a file failed: nothing was left at its path.
    #[error("{0}")]
    File(#[from] crate::atomic::FileError),
    /// A file this reader does not understand.
    #[error("not a volume this reader understands: {0}")]
    Format(String),
}

/// Writes `grids` to `path` through a temporary file in the same folder, renamed to `path`
/// once complete: an error (a full disk, a refused grid) leaves no file at `path` and no
/// temporary one beside it.
pub fn write_vdb_file(
    path: &Path,
    grids: &[&FloatGrid],
    metadata: &[(&str, MetaValue)],
) -> Result<(), VdbError> {
    crate::atomic::write_atomically(path, |w| write_vdb(w, grids, metadata))
}
