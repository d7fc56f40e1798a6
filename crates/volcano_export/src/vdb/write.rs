//! The OpenVDB file format (version 224, read by OpenVDB 6 to 12: Blender, Houdini,
//! `vdb_print`), written from its published description (the OpenVDB library's `io::Archive`,
//! `tree::RootNode`, `InternalNode`, `LeafNode` and `io::writeCompressedValues`). Hand-written:
//! the Rust crates for the format read it, none writes it, and the C++ library is a large
//! build dependency for a few hundred lines of little-endian records.
//!
//! Layout of a file: the header (magic, versions, a flag that grid offsets follow, a UUID),
//! the file's metadata, the grid count, then per grid its descriptor (name, tree type, the
//! offsets of its data, patched once the grid is written), its compression flags, metadata,
//! transform, the tree's topology (a `Tree_float_5_4_3`: root → 32³ internal nodes → 16³
//! internal nodes → 8³ leaves, each node's child mask then value mask) and the leaves' values.
//! Values are written with active-mask compression (OpenVDB's default for fog volumes): a leaf
//! stores only its active values, its inactive ones being the background, zero.

use std::collections::BTreeMap;
use std::io::{Seek, SeekFrom, Write};

use super::grid::{FloatGrid, Leaf, MetaValue};
use super::{Coord, VdbError};

/// `OPENVDB_MAGIC`.
pub const MAGIC: i64 = 0x5644_4220;
/// File format version: `OPENVDB_FILE_VERSION_MULTIPASS_IO`, the newest that OpenVDB 10
/// (Debian 12, Blender 3.4 to 4.x) reads without a warning.
pub const FILE_VERSION: u32 = 224;
/// The library version stamped in the header (informational to readers).
pub const LIBRARY_VERSION: (u32, u32) = (10, 0);
/// `COMPRESS_ACTIVE_MASK`.
pub const COMPRESS_ACTIVE_MASK: u32 = 0x2;
/// The tree type of a float grid with OpenVDB's standard node sizes.
pub const TREE_TYPE: &str = "Tree_float_5_4_3";
/// `NO_MASK_OR_INACTIVE_VALS`: every inactive value is the background; only the active values
/// follow.
const NO_MASK_OR_INACTIVE_VALS: u8 = 0;

/// Level-1 node (16³ children of 8³ voxels): its child leaves by offset.
type Node1 = BTreeMap<u32, Coord>;
/// Level-2 node (32³ children of 128³ voxels).
type Node2 = BTreeMap<u32, Node1>;

/// The grid's leaves arranged as OpenVDB's tree, in the order it writes and reads them:
/// root children by origin (lexicographic), then children by offset (x slowest).
fn tree(grid: &FloatGrid) -> BTreeMap<Coord, Node2> {
    let mut root: BTreeMap<Coord, Node2> = BTreeMap::new();
    for (&o, leaf) in &grid.leaves {
        if leaf.count_on() == 0 {
            continue;
        }
        let o2 = o.map(|c| c & !4095);
        let off2 = (((o[0] & 4095) >> 7) << 10) | (((o[1] & 4095) >> 7) << 5) | ((o[2] & 4095) >> 7);
        let off1 = (((o[0] & 127) >> 3) << 8) | (((o[1] & 127) >> 3) << 4) | ((o[2] & 127) >> 3);
        root.entry(o2).or_default().entry(off2 as u32).or_default().insert(off1 as u32, o);
    }
    root
}

/// A little-endian writer that counts what it wrote.
struct Out<'a, W: Write + Seek> {
    w: &'a mut W,
}

impl<W: Write + Seek> Out<'_, W> {
    fn bytes(&mut self, b: &[u8]) -> Result<(), VdbError> {
        self.w.write_all(b).map_err(VdbError::Io)
    }
    fn u8(&mut self, v: u8) -> Result<(), VdbError> {
        self.bytes(&[v])
    }
    fn u32(&mut self, v: u32) -> Result<(), VdbError> {
        self.bytes(&v.to_le_bytes())
    }
    fn i32(&mut self, v: i32) -> Result<(), VdbError> {
        self.bytes(&v.to_le_bytes())
    }
    fn i64(&mut self, v: i64) -> Result<(), VdbError> {
        self.bytes(&v.to_le_bytes())
    }
    fn f64(&mut self, v: f64) -> Result<(), VdbError> {
        self.bytes(&v.to_le_bytes())
    }
    /// `writeString`: a 32-bit length, then the bytes.
    fn string(&mut self, s: &str) -> Result<(), VdbError> {
        self.u32(s.len() as u32)?;
        self.bytes(s.as_bytes())
    }
    fn vec3d(&mut self, v: [f64; 3]) -> Result<(), VdbError> {
        v.iter().try_for_each(|&x| self.f64(x))
    }
    fn coord(&mut self, c: Coord) -> Result<(), VdbError> {
        c.iter().try_for_each(|&x| self.i32(x))
    }
    /// A node mask: its 64-bit words.
    fn mask(&mut self, words: &[u64]) -> Result<(), VdbError> {
        words.iter().try_for_each(|&w| self.bytes(&w.to_le_bytes()))
    }
    fn pos(&mut self) -> Result<i64, VdbError> {
        Ok(self.w.stream_position().map_err(VdbError::Io)? as i64)
    }

    /// `MetaMap::writeMeta`: the count, then per entry its name, type name, byte size, value.
    fn meta_map(&mut self, entries: &[(&str, &MetaValue)]) -> Result<(), VdbError> {
        self.u32(entries.len() as u32)?;
        for (name, value) in entries {
            self.string(name)?;
            let mut b = Vec::new();
            let kind = match value {
                MetaValue::String(s) => {
                    b.extend_from_slice(s.as_bytes());
                    "string"
                }
                MetaValue::Bool(v) => {
                    b.push(*v as u8);
                    "bool"
                }
                MetaValue::Float(v) => {
                    b.extend_from_slice(&v.to_le_bytes());
                    "float"
                }
                MetaValue::Double(v) => {
                    b.extend_from_slice(&v.to_le_bytes());
                    "double"
                }
                MetaValue::Int64(v) => {
                    b.extend_from_slice(&v.to_le_bytes());
                    "int64"
                }
                MetaValue::Vec3i(v) => {
                    v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
                    "vec3i"
                }
                MetaValue::Vec3d(v) => {
                    v.iter().for_each(|x| b.extend_from_slice(&x.to_le_bytes()));
                    "vec3d"
                }
            };
            self.string(kind)?;
            self.u32(b.len() as u32)?;
            self.bytes(&b)?;
        }
        Ok(())
    }
}

/// A deterministic UUID-formatted string (36 characters) from the grids' names and sizes:
/// the same export writes the same bytes.
fn uuid(grids: &[&FloatGrid]) -> String {
    // FNV-1a, 64-bit, twice with different offsets for 128 bits.
    let mut h = [0xcbf2_9ce4_8422_2325u64, 0x6c62_272e_07bb_0142u64];
    for g in grids {
        let n = g.active_voxel_count();
        for b in g.name().bytes().chain(n.to_le_bytes()) {
            for x in &mut h {
                *x = (*x ^ b as u64).wrapping_mul(0x100_0000_01b3);
            }
        }
    }
    let hex = format!("{:016x}{:016x}", h[0], h[1]);
    format!("{}-{}-4{}-8{}-{}", &hex[0..8], &hex[8..12], &hex[13..16], &hex[17..20], &hex[20..32])
}

/// Writes `grids` (unique names) and the file's `metadata` as one OpenVDB file to `w`, which
/// must be positioned at its start. Streams: each grid's leaves go out as they are visited;
/// the only seeks patch the grid offsets.
pub fn write_vdb<W: Write + Seek>(
    w: &mut W,
    grids: &[&FloatGrid],
    metadata: &[(&str, MetaValue)],
) -> Result<(), VdbError> {
    for (i, g) in grids.iter().enumerate() {
        if grids[..i].iter().any(|o| o.name() == g.name()) {
            return Err(VdbError::Name(format!("{} (two grids of that name)", g.name())));
        }
    }
    let mut o = Out { w };
    o.i64(MAGIC)?;
    o.u32(FILE_VERSION)?;
    o.u32(LIBRARY_VERSION.0)?;
    o.u32(LIBRARY_VERSION.1)?;
    o.u8(1)?; // grid offsets follow each descriptor
    o.bytes(uuid(grids).as_bytes())?;
    let file_meta: Vec<(&str, &MetaValue)> = metadata.iter().map(|(k, v)| (*k, v)).collect();
    o.meta_map(&file_meta)?;
    o.i32(grids.len() as i32)?;
    for g in grids {
        write_grid(&mut o, g)?;
    }
    o.w.flush().map_err(VdbError::Io)
}

fn write_grid<W: Write + Seek>(o: &mut Out<'_, W>, g: &FloatGrid) -> Result<(), VdbError> {
    // Descriptor: unique name, tree type, instance parent (none), then three offsets.
    o.string(g.name())?;
    o.string(TREE_TYPE)?;
    o.string("")?;
    let offsets_at = o.pos()?;
    (0..3).try_for_each(|_| o.i64(0))?;
    let grid_pos = o.pos()?;
    o.u32(COMPRESS_ACTIVE_MASK)?;

    let tree = tree(g);
    let (bbox, count) = match g.active_bbox() {
        Some((lo, hi)) => ((lo, hi), g.active_voxel_count()),
        None => (([0; 3], [0; 3]), 0),
    };
    let standard = [
        ("class", MetaValue::String(g.class().name().into())),
        ("file_bbox_max", MetaValue::Vec3i(bbox.1)),
        ("file_bbox_min", MetaValue::Vec3i(bbox.0)),
        ("file_compression", MetaValue::String("active values".into())),
        ("file_voxel_count", MetaValue::Int64(count as i64)),
        ("is_saved_as_half_float", MetaValue::Bool(false)),
        ("name", MetaValue::String(g.name().into())),
    ];
    let mut meta: Vec<(&str, &MetaValue)> = standard.iter().map(|(k, v)| (*k, v)).collect();
    meta.extend(g.metadata().iter().map(|(k, v)| (k.as_str(), v)));
    o.meta_map(&meta)?;

    // Transform: `UniformScaleTranslateMap` = translation, scale, voxel size, 1/scale,
    // 1/scale², 1/(2 scale), each a Vec3d.
    let t = g.transform();
    let s = t.voxel_size();
    o.string("UniformScaleTranslateMap")?;
    o.vec3d(t.translation())?;
    for v in [s, s, 1.0 / s, 1.0 / (s * s), 0.5 / s] {
        o.vec3d([v; 3])?;
    }

    // Topology: buffer count, root (background, tiles, children), internal nodes, leaf masks.
    o.i32(1)?;
    o.bytes(&0f32.to_le_bytes())?;
    o.u32(0)?;
    o.u32(tree.len() as u32)?;
    for (origin, node2) in &tree {
        o.coord(*origin)?;
        internal_topology(o, node2.keys().copied(), 5)?;
        for node1 in node2.values() {
            internal_topology(o, node1.keys().copied(), 4)?;
            for leaf in node1.values() {
                o.mask(&g.leaves[leaf].active)?;
            }
        }
    }
    let block_pos = o.pos()?;
    for node2 in tree.values() {
        for node1 in node2.values() {
            for origin in node1.values() {
                leaf_buffers(o, &g.leaves[origin])?;
            }
        }
    }
    let end_pos = o.pos()?;
    o.w.seek(SeekFrom::Start(offsets_at as u64)).map_err(VdbError::Io)?;
    for p in [grid_pos, block_pos, end_pos] {
        o.i64(p)?;
    }
    o.w.seek(SeekFrom::Start(end_pos as u64)).map_err(VdbError::Io)?;
    Ok(())
}

/// An internal node of `2^log2` children per axis: its child mask, an empty value mask and
/// its (all background, so none written) tile values.
fn internal_topology<W: Write + Seek>(
    o: &mut Out<'_, W>,
    children: impl Iterator<Item = u32>,
    log2: u32,
) -> Result<(), VdbError> {
    let words = (1usize << (3 * log2)) / 64;
    let mut child = vec![0u64; words];
    for c in children {
        child[c as usize >> 6] |= 1 << (c & 63);
    }
    o.mask(&child)?;
    o.mask(&vec![0u64; words])?;
    // No active tiles and every inactive value the background: the metadata byte and nothing.
    o.u8(NO_MASK_OR_INACTIVE_VALS)
}

/// A leaf's buffer: its value mask again, the metadata byte, its active values in order.
fn leaf_buffers<W: Write + Seek>(o: &mut Out<'_, W>, leaf: &Leaf) -> Result<(), VdbError> {
    o.mask(&leaf.active)?;
    o.u8(NO_MASK_OR_INACTIVE_VALS)?;
    let mut b = Vec::with_capacity(4 * leaf.count_on() as usize);
    for (n, v) in leaf.values.iter().enumerate() {
        if leaf.active[n >> 6] >> (n & 63) & 1 == 1 {
            b.extend_from_slice(&v.to_le_bytes());
        }
    }
    o.bytes(&b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uuid_has_the_shape_readers_expect_and_is_deterministic() {
        let g = FloatGrid::new(
            "a",
            super::super::GridClass::FogVolume,
            super::super::Transform::new(1.0, [0.0; 3]).unwrap(),
        )
        .unwrap();
        let u = uuid(&[&g]);
        assert_eq!(u.len(), 36);
        assert_eq!(u.matches('-').count(), 4);
        assert_eq!(u, uuid(&[&g]));
    }
}
