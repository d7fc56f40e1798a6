//! A reader for the subset of the OpenVDB format that `write.rs` produces (float trees with
//! the standard node sizes, a uniform scale-and-translate map, no tiles, active-mask
//! compression), for tests and tools that want the values back without OpenVDB. Anything else
//! is a [`VdbError::Format`], never a panic: every count is checked against the bytes left.

use std::collections::{BTreeMap, HashMap};

use super::grid::MetaValue;
use super::write::{COMPRESS_ACTIVE_MASK, MAGIC, TREE_TYPE};
use super::{Coord, VdbError};

/// A grid as read back.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadGrid {
    /// Name.
    pub name: String,
    /// Metadata, the standard entries included.
    pub metadata: BTreeMap<String, MetaValue>,
    /// Voxel size.
    pub voxel_size: f64,
    /// World position of voxel (0, 0, 0)'s centre.
    pub translation: [f64; 3],
    /// Active voxels and their values.
    pub active: HashMap<Coord, f32>,
}

struct In<'a> {
    b: &'a [u8],
    at: usize,
}

fn bad(what: &str) -> VdbError {
    VdbError::Format(what.to_owned())
}

impl<'a> In<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], VdbError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.b.len()).ok_or_else(|| bad("truncated"))?;
        let s = &self.b[self.at..end];
        self.at = end;
        Ok(s)
    }
    fn arr<const N: usize>(&mut self) -> Result<[u8; N], VdbError> {
        Ok(self.take(N)?.try_into().expect("length checked"))
    }
    fn u8(&mut self) -> Result<u8, VdbError> {
        Ok(self.arr::<1>()?[0])
    }
    fn u32(&mut self) -> Result<u32, VdbError> {
        Ok(u32::from_le_bytes(self.arr()?))
    }
    fn i32(&mut self) -> Result<i32, VdbError> {
        Ok(i32::from_le_bytes(self.arr()?))
    }
    fn i64(&mut self) -> Result<i64, VdbError> {
        Ok(i64::from_le_bytes(self.arr()?))
    }
    fn f32(&mut self) -> Result<f32, VdbError> {
        Ok(f32::from_le_bytes(self.arr()?))
    }
    fn f64(&mut self) -> Result<f64, VdbError> {
        Ok(f64::from_le_bytes(self.arr()?))
    }
    fn string(&mut self) -> Result<String, VdbError> {
        let n = self.u32()? as usize;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| bad("a name that is not UTF-8"))
    }
    fn vec3d(&mut self) -> Result<[f64; 3], VdbError> {
        Ok([self.f64()?, self.f64()?, self.f64()?])
    }
    fn coord(&mut self) -> Result<Coord, VdbError> {
        Ok([self.i32()?, self.i32()?, self.i32()?])
    }
    fn mask(&mut self, words: usize) -> Result<Vec<u64>, VdbError> {
        let b = self.take(words * 8)?;
        Ok(b.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().expect("8 bytes"))).collect())
    }

    fn meta_map(&mut self) -> Result<BTreeMap<String, MetaValue>, VdbError> {
        let n = self.u32()?;
        let mut out = BTreeMap::new();
        for _ in 0..n {
            let name = self.string()?;
            let kind = self.string()?;
            let size = self.u32()? as usize;
            let mut v = In { b: self.take(size)?, at: 0 };
            let value = match kind.as_str() {
                "string" => MetaValue::String(String::from_utf8(v.b.to_vec()).map_err(|_| bad("string"))?),
                "bool" => MetaValue::Bool(v.u8()? != 0),
                "float" => MetaValue::Float(v.f32()?),
                "double" => MetaValue::Double(v.f64()?),
                "int64" => MetaValue::Int64(v.i64()?),
                "vec3i" => MetaValue::Vec3i(v.coord()?),
                "vec3d" => MetaValue::Vec3d(v.vec3d()?),
                other => return Err(bad(&format!("metadata type `{other}`"))),
            };
            out.insert(name, value);
        }
        Ok(out)
    }

    /// An internal node's masks and (empty) values; returns the child offsets.
    fn internal(&mut self, log2: u32) -> Result<Vec<u32>, VdbError> {
        let words = (1usize << (3 * log2)) / 64;
        let child = self.mask(words)?;
        let value = self.mask(words)?;
        if value.iter().any(|&w| w != 0) || self.u8()? != 0 {
            return Err(bad("internal-node tiles"));
        }
        Ok(ones(&child))
    }
}

fn ones(mask: &[u64]) -> Vec<u32> {
    (0..mask.len() as u32 * 64).filter(|&n| mask[n as usize >> 6] >> (n & 63) & 1 == 1).collect()
}

/// Reads every grid of an OpenVDB file written by [`super::write_vdb`], with the file's
/// metadata.
pub fn read_vdb(bytes: &[u8]) -> Result<(Vec<ReadGrid>, BTreeMap<String, MetaValue>), VdbError> {
    let mut r = In { b: bytes, at: 0 };
    if r.i64()? != MAGIC {
        return Err(bad("not a VDB file"));
    }
    let _version = (r.u32()?, r.u32()?, r.u32()?);
    if r.u8()? != 1 {
        return Err(bad("no grid offsets"));
    }
    r.take(36)?;
    let file_meta = r.meta_map()?;
    let count = r.i32()?;
    let mut grids = Vec::new();
    for _ in 0..count.max(0) {
        let name = r.string()?;
        if r.string()? != TREE_TYPE || !r.string()?.is_empty() {
            return Err(bad("grid type"));
        }
        let _offsets = (r.i64()?, r.i64()?, r.i64()?);
        if r.u32()? != COMPRESS_ACTIVE_MASK {
            return Err(bad("compression"));
        }
        let metadata = r.meta_map()?;
        if r.string()? != "UniformScaleTranslateMap" {
            return Err(bad("transform"));
        }
        let translation = r.vec3d()?;
        let scale = r.vec3d()?;
        (0..4).try_for_each(|_| r.vec3d().map(drop))?;
        if r.i32()? != 1 || r.f32()? != 0.0 || r.u32()? != 0 {
            return Err(bad("root"));
        }
        let roots = r.u32()?;
        let mut leaves: Vec<(Coord, Vec<u64>)> = Vec::new();
        for _ in 0..roots {
            let o2 = r.coord()?;
            for c2 in r.internal(5)? {
                let c2 = c2 as i32;
                let o1 =
                    [o2[0] + ((c2 >> 10) << 7), o2[1] + (((c2 >> 5) & 31) << 7), o2[2] + ((c2 & 31) << 7)];
                for c1 in r.internal(4)? {
                    let c1 = c1 as i32;
                    let o =
                        [o1[0] + ((c1 >> 8) << 3), o1[1] + (((c1 >> 4) & 15) << 3), o1[2] + ((c1 & 15) << 3)];
                    leaves.push((o, r.mask(8)?));
                }
            }
        }
        let mut active = HashMap::new();
        for (o, mask) in leaves {
            if r.mask(8)? != mask || r.u8()? != 0 {
                return Err(bad("leaf buffer"));
            }
            for n in ones(&mask) {
                let n = n as i32;
                active.insert([o[0] + (n >> 6), o[1] + ((n >> 3) & 7), o[2] + (n & 7)], r.f32()?);
            }
        }
        grids.push(ReadGrid { name, metadata, voxel_size: scale[0], translation, active });
    }
    Ok((grids, file_meta))
}
