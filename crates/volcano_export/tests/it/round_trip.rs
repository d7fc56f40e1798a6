//! Random grids written and read back by the crate's own reader, and damaged files refused.

use proptest::prelude::*;
use volcano_export::vdb::{FloatGrid, GridClass, MetaValue, Transform, VdbError, read_vdb, write_vdb};

fn write(grids: &[&FloatGrid]) -> Vec<u8> {
    let mut out = std::io::Cursor::new(Vec::new());
    write_vdb(&mut out, grids, &[("k", MetaValue::Int64(-3))]).unwrap();
    out.into_inner()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Every active voxel comes back with its value, nothing else is active, and the
    /// transform and metadata survive.
    #[test]
    fn written_grids_read_back_exactly(
        voxels in prop::collection::vec(((-9000i32..9000, -300i32..300, -9000i32..9000), 0.001f32..1e6), 0..400),
        h in 0.01f64..1000.0,
        t in prop::array::uniform3(-1e5f64..1e5),
    ) {
        let mut g = FloatGrid::new("g", GridClass::FogVolume, Transform::new(h, t).unwrap()).unwrap();
        for ((i, j, k), v) in &voxels {
            g.set([*i, *j, *k], *v).unwrap();
        }
        g.insert_meta("note", MetaValue::Vec3d([1.0, 2.0, 3.0])).unwrap();
        let (grids, meta) = read_vdb(&write(&[&g])).unwrap();
        prop_assert_eq!(meta.get("k"), Some(&MetaValue::Int64(-3)));
        prop_assert_eq!(grids.len(), 1);
        let r = &grids[0];
        prop_assert_eq!(r.voxel_size, h);
        prop_assert_eq!(r.translation, t);
        prop_assert_eq!(r.active.len() as u64, g.active_voxel_count());
        for (ijk, v) in g.iter_active() {
            prop_assert_eq!(r.active.get(&ijk), Some(&v));
        }
        prop_assert_eq!(r.metadata.get("note"), Some(&MetaValue::Vec3d([1.0, 2.0, 3.0])));
        prop_assert_eq!(r.metadata.get("class"), Some(&MetaValue::String("fog volume".into())));
    }

    /// Truncated or corrupted files are errors, never panics or huge allocations.
    #[test]
    fn damaged_files_are_refused_without_panicking(cut in 0usize..4000, flips in prop::collection::vec((0usize..4000, any::<u8>()), 0..8)) {
        let mut g = FloatGrid::new("g", GridClass::FogVolume, Transform::new(1.0, [0.0; 3]).unwrap()).unwrap();
        for i in 0..40 {
            g.set([i * 3, -i, i * i], i as f32 + 0.5).unwrap();
        }
        let mut bytes = write(&[&g]);
        for (at, b) in flips {
            let n = bytes.len();
            bytes[at % n] ^= b;
        }
        bytes.truncate(cut.min(bytes.len()));
        let _ = read_vdb(&bytes);
    }
}

#[test]
fn two_grids_of_one_name_are_refused() {
    let g = FloatGrid::new("g", GridClass::FogVolume, Transform::new(1.0, [0.0; 3]).unwrap()).unwrap();
    let mut out = std::io::Cursor::new(Vec::new());
    assert!(matches!(write_vdb(&mut out, &[&g, &g], &[]), Err(VdbError::Name(_))));
}

/// A sink that takes `room` bytes and then fails as a full disk does.
struct FullDisk {
    inner: std::io::Cursor<Vec<u8>>,
    room: usize,
}

impl std::io::Write for FullDisk {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let left = self.room.saturating_sub(self.inner.get_ref().len());
        if left == 0 {
            return Err(std::io::Error::new(std::io::ErrorKind::StorageFull, "no space left on device"));
        }
        self.inner.write(&buf[..buf.len().min(left)])
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl std::io::Seek for FullDisk {
    fn seek(&mut self, pos: std::io::SeekFrom) -> std::io::Result<u64> {
        self.inner.seek(pos)
    }
}

/// A disk that fills at any point of a file is an error saying so, never a panic or a file
/// that claims to be complete.
#[test]
fn a_disk_that_fills_is_an_error() {
    let mut g = FloatGrid::new("g", GridClass::FogVolume, Transform::new(1.0, [0.0; 3]).unwrap()).unwrap();
    for i in 0..500 {
        g.set([i, i % 7, -i], 1.0 + i as f32).unwrap();
    }
    let mut all = std::io::Cursor::new(Vec::new());
    write_vdb(&mut all, &[&g], &[]).unwrap();
    let whole = all.into_inner().len();
    for room in [0, 10, 100, whole / 2, whole - 1] {
        let mut disk = FullDisk { inner: std::io::Cursor::new(Vec::new()), room };
        let e = write_vdb(&mut disk, &[&g], &[]).expect_err(&format!("room {room} of {whole}"));
        assert!(e.to_string().contains("no space left"), "{room}: {e}");
    }
}
