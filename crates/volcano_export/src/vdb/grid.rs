//! A sparse float grid as OpenVDB stores one: 8³ leaves of values with an active mask, keyed
//! by their origin (the tree's internal nodes are built when the grid is written, `write.rs`).
//! A voxel is active when it holds a value other than the background, zero: a fog volume's
//! inactive voxels are empty space.

use std::collections::{BTreeMap, HashMap};

use super::{Coord, VdbError};

/// Metadata entries the writer sets on every grid (a grid's own metadata cannot replace them).
pub const RESERVED_META: [&str; 7] = [
    "class",
    "name",
    "file_bbox_min",
    "file_bbox_max",
    "file_voxel_count",
    "is_saved_as_half_float",
    "file_compression",
];

/// Voxels along each side of a leaf (OpenVDB's `LeafNode<float, 3>`).
pub const LEAF_DIM: i32 = 8;
/// Voxels in a leaf.
pub const LEAF_VOXELS: usize = 512;

/// What a grid stands for, stored as its `class` metadata; readers (Blender, Houdini) take a
/// fog volume as a density to render.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridClass {
    /// A density (or any scalar) that is zero outside its active voxels.
    FogVolume,
    /// No particular meaning (e.g. a temperature field).
    Unknown,
}

impl GridClass {
    /// The name OpenVDB writes (`gridClassToString`).
    pub fn name(self) -> &'static str {
        match self {
            GridClass::FogVolume => "fog volume",
            GridClass::Unknown => "unknown",
        }
    }
}

/// Where voxels are in the world: the centre of voxel `(i, j, k)` is at
/// `translation + voxel_size · (i, j, k)` (OpenVDB's `UniformScaleTranslateMap`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Transform {
    voxel_size: f64,
    translation: [f64; 3],
}

impl Transform {
    /// A validated transform: `voxel_size` finite and positive, `translation` finite.
    pub fn new(voxel_size: f64, translation: [f64; 3]) -> Result<Self, VdbError> {
        if !(voxel_size.is_finite() && voxel_size > 0.0) {
            return Err(VdbError::Transform(format!(
                "voxel size must be finite and positive, got {voxel_size}"
            )));
        }
        if translation.iter().any(|t| !t.is_finite()) {
            return Err(VdbError::Transform(format!("translation must be finite, got {translation:?}")));
        }
        Ok(Self { voxel_size, translation })
    }
    /// Edge of a voxel (world units).
    pub fn voxel_size(&self) -> f64 {
        self.voxel_size
    }
    /// World position of voxel (0, 0, 0)'s centre.
    pub fn translation(&self) -> [f64; 3] {
        self.translation
    }
    /// World position of voxel `ijk`'s centre.
    pub fn index_to_world(&self, ijk: Coord) -> [f64; 3] {
        std::array::from_fn(|a| self.translation[a] + self.voxel_size * ijk[a] as f64)
    }
    /// Continuous index coordinates of world point `p` (voxel centres at integers).
    pub fn world_to_index(&self, p: [f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| (p[a] - self.translation[a]) / self.voxel_size)
    }
}

/// One value of a grid's or a file's metadata, with the type name OpenVDB gives it.
#[derive(Debug, Clone, PartialEq)]
pub enum MetaValue {
    /// `string`.
    String(String),
    /// `bool`.
    Bool(bool),
    /// `float`.
    Float(f32),
    /// `double`.
    Double(f64),
    /// `int64`.
    Int64(i64),
    /// `vec3i`.
    Vec3i([i32; 3]),
    /// `vec3d`.
    Vec3d([f64; 3]),
}

/// One 8³ block of a grid.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Leaf {
    /// Values, x slowest then y then z (`((x & 7) << 6) | ((y & 7) << 3) | (z & 7)`).
    pub values: Box<[f32; LEAF_VOXELS]>,
    /// Active voxels, bit `n` of word `n >> 6`.
    pub active: [u64; 8],
}

impl Leaf {
    fn empty() -> Self {
        Self { values: Box::new([0.0; LEAF_VOXELS]), active: [0; 8] }
    }
    pub fn count_on(&self) -> u64 {
        self.active.iter().map(|w| w.count_ones() as u64).sum()
    }
    /// Sets voxel `k`: active unless the value is zero.
    fn put(&mut self, k: usize, value: f32) {
        self.values[k] = value;
        let bit = 1u64 << (k & 63);
        if value != 0.0 {
            self.active[k >> 6] |= bit;
        } else {
            self.active[k >> 6] &= !bit;
        }
    }
}

/// Offset of voxel `ijk` in its leaf.
pub(crate) fn leaf_offset(ijk: Coord) -> usize {
    (((ijk[0] & 7) << 6) | ((ijk[1] & 7) << 3) | (ijk[2] & 7)) as usize
}

/// Origin of the leaf holding `ijk`.
pub(crate) fn leaf_origin(ijk: Coord) -> Coord {
    ijk.map(|c| c & !(LEAF_DIM - 1))
}

/// A sparse grid of `f32` with a name, a class, a transform and metadata; background zero.
#[derive(Debug, Clone, PartialEq)]
pub struct FloatGrid {
    name: String,
    class: GridClass,
    transform: Transform,
    pub(crate) leaves: HashMap<Coord, Leaf>,
    metadata: BTreeMap<String, MetaValue>,
}

impl FloatGrid {
    /// An empty grid. The name must be non-empty printable text without the record separator
    /// OpenVDB puts in names it makes unique.
    pub fn new(name: &str, class: GridClass, transform: Transform) -> Result<Self, VdbError> {
        check_name(name)?;
        Ok(Self {
            name: name.to_owned(),
            class,
            transform,
            leaves: HashMap::new(),
            metadata: BTreeMap::new(),
        })
    }
    /// The grid's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// The grid's class.
    pub fn class(&self) -> GridClass {
        self.class
    }
    /// Index to world.
    pub fn transform(&self) -> &Transform {
        &self.transform
    }
    /// Metadata of the grid's own (written beside the standard entries `class`, `name` and
    /// the `file_*` statistics, which it cannot replace).
    pub fn metadata(&self) -> &BTreeMap<String, MetaValue> {
        &self.metadata
    }
    /// Adds or replaces a metadata entry; the standard names are refused.
    pub fn insert_meta(&mut self, name: &str, value: MetaValue) -> Result<(), VdbError> {
        check_name(name)?;
        if RESERVED_META.contains(&name) {
            return Err(VdbError::Metadata(format!("`{name}` is written by the writer itself")));
        }
        if let MetaValue::Float(v) = value
            && !v.is_finite()
        {
            return Err(VdbError::Metadata(format!("`{name}` is not finite")));
        }
        if let MetaValue::Double(v) = value
            && !v.is_finite()
        {
            return Err(VdbError::Metadata(format!("`{name}` is not finite")));
        }
        self.metadata.insert(name.to_owned(), value);
        Ok(())
    }

    /// Value at `ijk` (zero where nothing was set).
    pub fn get(&self, ijk: Coord) -> f32 {
        self.leaves.get(&leaf_origin(ijk)).map_or(0.0, |l| l.values[leaf_offset(ijk)])
    }

    /// Whether `ijk` is active.
    pub fn is_active(&self, ijk: Coord) -> bool {
        let n = leaf_offset(ijk);
        self.leaves.get(&leaf_origin(ijk)).is_some_and(|l| l.active[n >> 6] >> (n & 63) & 1 == 1)
    }

    /// Sets `ijk` to `value`: active unless zero. A non-finite value is refused.
    pub fn set(&mut self, ijk: Coord, value: f32) -> Result<(), VdbError> {
        self.update(ijk, |_| value)
    }

    /// Replaces the value at `ijk` by `f(old)`: active unless the result is zero. A non-finite
    /// result is refused and the voxel left as it was.
    pub fn update(&mut self, ijk: Coord, f: impl FnOnce(f32) -> f32) -> Result<(), VdbError> {
        let n = leaf_offset(ijk);
        let origin = leaf_origin(ijk);
        let old = self.get(ijk);
        let value = f(old);
        if !value.is_finite() {
            return Err(VdbError::NonFinite { grid: self.name.clone(), ijk });
        }
        if value == 0.0 && !self.leaves.contains_key(&origin) {
            return Ok(());
        }
        self.leaves.entry(origin).or_insert_with(Leaf::empty).put(n, value);
        Ok(())
    }

    /// How many of `cells` are not active yet (each leaf looked up once per run of cells in
    /// it, as a sphere's voxels come).
    pub fn count_inactive(&self, cells: &[(Coord, f32)]) -> u64 {
        let mut leaf: Option<(Coord, Option<&Leaf>)> = None;
        let mut n = 0;
        for &(ijk, _) in cells {
            let origin = leaf_origin(ijk);
            if leaf.is_none_or(|(o, _)| o != origin) {
                leaf = Some((origin, self.leaves.get(&origin)));
            }
            let k = leaf_offset(ijk);
            let on = leaf.and_then(|(_, l)| l).is_some_and(|l| l.active[k >> 6] >> (k & 63) & 1 == 1);
            n += !on as u64;
        }
        n
    }

    /// Sets each of `cells` to `combine(old, value)`, as [`FloatGrid::update`] does one voxel,
    /// looking each leaf up once per run of cells in it. Stops at the first non-finite result
    /// (the cells before it are written).
    pub fn update_cells(
        &mut self,
        cells: &[(Coord, f32)],
        combine: impl Fn(f32, f32) -> f32,
    ) -> Result<(), VdbError> {
        let mut i = 0;
        while i < cells.len() {
            let origin = leaf_origin(cells[i].0);
            let run = cells[i..].iter().take_while(|(c, _)| leaf_origin(*c) == origin).count();
            let leaf = self.leaves.entry(origin).or_insert_with(Leaf::empty);
            for &(ijk, v) in &cells[i..i + run] {
                let k = leaf_offset(ijk);
                let value = combine(leaf.values[k], v);
                if !value.is_finite() {
                    return Err(VdbError::NonFinite { grid: self.name.clone(), ijk });
                }
                leaf.put(k, value);
            }
            i += run;
        }
        Ok(())
    }

    /// Drops leaves without an active voxel (a written grid has none).
    pub fn prune(&mut self) {
        self.leaves.retain(|_, l| l.count_on() > 0);
    }

    /// Active voxels.
    pub fn active_voxel_count(&self) -> u64 {
        self.leaves.values().map(Leaf::count_on).sum()
    }

    /// Leaves allocated (2 KiB of values each).
    pub fn leaf_count(&self) -> usize {
        self.leaves.len()
    }

    /// Every active voxel and its value, in no particular order.
    pub fn iter_active(&self) -> impl Iterator<Item = (Coord, f32)> + '_ {
        self.leaves.iter().flat_map(|(o, l)| {
            (0..LEAF_VOXELS).filter(|&n| l.active[n >> 6] >> (n & 63) & 1 == 1).map(move |n| {
                let n = n as i32;
                ([o[0] + (n >> 6), o[1] + ((n >> 3) & 7), o[2] + (n & 7)], l.values[n as usize])
            })
        })
    }

    /// Inclusive index bounding box of the active voxels, `None` if there are none.
    pub fn active_bbox(&self) -> Option<(Coord, Coord)> {
        let mut bb: Option<(Coord, Coord)> = None;
        for (ijk, _) in self.iter_active() {
            let (lo, hi) = bb.get_or_insert((ijk, ijk));
            for a in 0..3 {
                lo[a] = lo[a].min(ijk[a]);
                hi[a] = hi[a].max(ijk[a]);
            }
        }
        bb
    }

    /// Sum of the active values times the voxel volume (e.g. the mass of a density grid).
    pub fn integral(&self) -> f64 {
        let v = self.transform.voxel_size.powi(3);
        self.iter_active().map(|(_, x)| x as f64).sum::<f64>() * v
    }
}

/// Names of grids and metadata: non-empty, printable, no record separator.
fn check_name(name: &str) -> Result<(), VdbError> {
    if name.is_empty() || name.len() > 256 || name.chars().any(char::is_control) {
        return Err(VdbError::Name(name.to_owned()));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> FloatGrid {
        FloatGrid::new("ash", GridClass::FogVolume, Transform::new(2.0, [1.0, 0.0, -1.0]).unwrap()).unwrap()
    }

    #[test]
    fn set_get_and_activity_across_negative_leaves() {
        let mut g = grid();
        for ijk in [[0, 0, 0], [-1, -1, -1], [7, 8, -9], [-4097, 4096, 3]] {
            g.set(ijk, 2.5).unwrap();
            assert_eq!(g.get(ijk), 2.5);
            assert!(g.is_active(ijk));
        }
        assert_eq!(g.active_voxel_count(), 4);
        assert_eq!(g.leaf_count(), 4, "{:?}", g.leaves.keys().collect::<Vec<_>>());
        assert_eq!(g.active_bbox(), Some(([-4097, -1, -9], [7, 4096, 3])));
        let mut seen: Vec<_> = g.iter_active().map(|(c, _)| c).collect();
        seen.sort();
        assert_eq!(seen, vec![[-4097, 4096, 3], [-1, -1, -1], [0, 0, 0], [7, 8, -9]]);
        g.set([0, 0, 0], 0.0).unwrap();
        assert!(!g.is_active([0, 0, 0]));
        g.prune();
        assert_eq!(g.leaf_count(), 3);
    }

    #[test]
    fn bad_input_is_refused() {
        let mut g = grid();
        assert!(matches!(g.set([1, 2, 3], f32::NAN), Err(VdbError::NonFinite { ijk: [1, 2, 3], .. })));
        assert_eq!(g.leaf_count(), 0, "a refused value allocates nothing");
        assert!(Transform::new(0.0, [0.0; 3]).is_err());
        assert!(Transform::new(1.0, [f64::INFINITY, 0.0, 0.0]).is_err());
        assert!(FloatGrid::new("", GridClass::Unknown, *g.transform()).is_err());
        assert!(FloatGrid::new("a\u{1e}b", GridClass::Unknown, *g.transform()).is_err());
        assert!(g.insert_meta("class", MetaValue::String("x".into())).is_err());
        assert!(g.insert_meta("t", MetaValue::Double(f64::NAN)).is_err());
    }

    #[test]
    fn transform_round_trips() {
        let t = Transform::new(0.5, [10.0, -3.0, 2.0]).unwrap();
        let w = t.index_to_world([4, -2, 0]);
        assert_eq!(w, [12.0, -4.0, 2.0]);
        assert_eq!(t.world_to_index(w), [4.0, -2.0, 0.0]);
    }
}
