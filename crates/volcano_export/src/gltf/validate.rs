//! The checks run on every mesh and line set before anything is written.

use super::{GltfError, LineData, MeshData, glb};

/// The most vertices: indices are `u32`, and the specification reserves the largest value
/// (`0xFFFF_FFFF`, primitive restart), so the last vertex is `u32::MAX - 1`.
pub(super) const MAX_VERTICES: u64 = u32::MAX as u64;
/// The most indices of one primitive (accessor counts are kept within `u32`).
pub(super) const MAX_INDICES: u64 = u32::MAX as u64;
/// How far from 1 a normal's length may be (the specification requires unit normals).
/// Stricter than the Khronos validator, which refuses a length of 1.01 and accepts 1.003:
/// data normalised in `f32` is within 1e-6 of 1, so a larger error is a normal that was
/// never normalised.
pub(super) const UNIT_TOLERANCE: f32 = 5e-4;

pub(super) fn mesh(index: usize, m: &MeshData) -> Result<(), GltfError> {
    let name = named("mesh", index, &m.name)?;
    let n = m.positions.len();
    count(name, "vertices", n, MAX_VERTICES)?;
    finite(name, "position", m.positions.iter().map(|p| p.as_slice()))?;
    if let Some(normals) = &m.normals {
        length(name, "normals", normals.len(), n)?;
        finite(name, "normal", normals.iter().map(|v| v.as_slice()))?;
        for (at, v) in normals.iter().enumerate() {
            let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if (len - 1.0).abs() > UNIT_TOLERANCE {
                return Err(GltfError::NotUnit { name: name.into(), at, length: len });
            }
        }
    }
    if let Some(colors) = &m.colors {
        length(name, "colors", colors.len(), n)?;
        for (at, c) in colors.iter().enumerate() {
            unit_range(name, "color", at, c)?;
        }
    }
    if let Some(t) = &m.temperature {
        length(name, "temperatures", t.len(), n)?;
        finite(name, "temperature", t.iter().map(std::slice::from_ref))?;
    }
    indices(name, &m.indices, 3, n)?;
    unit_range(name, "base color", 0, &m.base_color)?;
    if let Some(e) = &m.emissive {
        finite(name, "emissive", [e.as_slice()].into_iter())?;
        if e.iter().any(|c| *c < 0.0) {
            return Err(GltfError::OutOfRange {
                name: name.into(),
                attribute: "emissive",
                at: 0,
                value: e.to_vec(),
            });
        }
    }
    Ok(())
}

pub(super) fn lines(index: usize, l: &LineData) -> Result<(), GltfError> {
    let name = named("line set", index, &l.name)?;
    let n = l.positions.len();
    count(name, "vertices", n, MAX_VERTICES)?;
    finite(name, "position", l.positions.iter().map(|p| p.as_slice()))?;
    indices(name, &l.indices, 2, n)?;
    unit_range(name, "line color", 0, &l.color)
}

/// Checks that the file fits a GLB's 32-bit lengths, from the size of its binary buffer (the
/// JSON is checked once serialised). This also bounds the number of meshes, and so of every
/// array in the document, far below `u32::MAX`: each takes at least 20 bytes.
pub(super) fn size(meshes: &[MeshData], lines: &[LineData]) -> Result<(), GltfError> {
    let mut bytes: u64 = 0;
    for m in meshes {
        let per_vertex: u64 = 12
            + m.normals.as_ref().map_or(0, |_| 12)
            + m.colors.as_ref().map_or(0, |_| 16)
            + m.temperature.as_ref().map_or(0, |_| 4);
        // Counts are within `u32` (checked before), so each term fits; the sum saturates.
        bytes = bytes.saturating_add(per_vertex * m.positions.len() as u64 + 4 * m.indices.len() as u64);
    }
    for l in lines {
        bytes = bytes.saturating_add(12 * l.positions.len() as u64 + 4 * l.indices.len() as u64);
    }
    glb::length(0, bytes).map(|_| ())
}

fn named<'a>(kind: &'static str, index: usize, name: &'a str) -> Result<&'a str, GltfError> {
    if name.is_empty() { Err(GltfError::EmptyName { kind, index }) } else { Ok(name) }
}

/// At least one and at most `limit` (the specification's accessors have a count of at least 1).
pub(super) fn count(name: &str, what: &'static str, n: usize, limit: u64) -> Result<(), GltfError> {
    if n == 0 {
        Err(GltfError::Empty { name: name.into(), what })
    } else if n as u64 > limit {
        Err(GltfError::TooMany { name: name.into(), what, count: n, limit })
    } else {
        Ok(())
    }
}

fn length(name: &str, attribute: &'static str, len: usize, vertices: usize) -> Result<(), GltfError> {
    if len == vertices {
        Ok(())
    } else {
        Err(GltfError::Length { name: name.into(), attribute, len, vertices })
    }
}

fn finite<'a>(
    name: &str,
    attribute: &'static str,
    values: impl Iterator<Item = &'a [f32]>,
) -> Result<(), GltfError> {
    for (at, v) in values.enumerate() {
        if !v.iter().all(|c| c.is_finite()) {
            return Err(GltfError::NonFinite { name: name.into(), attribute, at });
        }
    }
    Ok(())
}

fn indices(name: &str, indices: &[u32], per: usize, vertices: usize) -> Result<(), GltfError> {
    count(name, "indices", indices.len(), MAX_INDICES)?;
    if !indices.len().is_multiple_of(per) {
        return Err(GltfError::IndexCount { name: name.into(), len: indices.len(), per });
    }
    match indices.iter().enumerate().find(|(_, i)| **i as usize >= vertices) {
        Some((at, &index)) => Err(GltfError::IndexOutOfRange { name: name.into(), at, index, vertices }),
        None => Ok(()),
    }
}

/// Colours are in [0, 1]: the schema's range for `baseColorFactor`, and for `COLOR_0` a rule
/// the Khronos validator reports as an error (`ACCESSOR_NON_CLAMPED`).
fn unit_range(name: &str, attribute: &'static str, at: usize, c: &[f32; 4]) -> Result<(), GltfError> {
    if !c.iter().all(|v| v.is_finite()) {
        Err(GltfError::NonFinite { name: name.into(), attribute, at })
    } else if !c.iter().all(|v| (0.0..=1.0).contains(v)) {
        Err(GltfError::OutOfRange { name: name.into(), attribute, at, value: c.to_vec() })
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The limits on counts, which real data of that size would take gigabytes to reach.
    #[test]
    fn counts_beyond_u32_are_refused() {
        assert!(count("m", "vertices", u32::MAX as usize, MAX_VERTICES).is_ok());
        let e = count("m", "vertices", u32::MAX as usize + 1, MAX_VERTICES).unwrap_err();
        assert!(matches!(e, GltfError::TooMany { count, .. } if count == u32::MAX as usize + 1), "{e}");
        assert!(matches!(
            count("m", "indices", 0, MAX_INDICES),
            Err(GltfError::Empty { what: "indices", .. })
        ));
    }

    #[test]
    fn normals_a_little_off_unit_length_pass_and_others_do_not() {
        let mut m = MeshData {
            name: "m".into(),
            positions: vec![[0.0; 3]; 2],
            normals: Some(vec![[0.0, 1.0 + UNIT_TOLERANCE / 2.0, 0.0], [0.6, 0.8, 0.0]]),
            indices: vec![0, 1, 1],
            colors: None,
            temperature: None,
            emissive: None,
            base_color: [1.0; 4],
        };
        mesh(0, &m).unwrap();
        m.normals = Some(vec![[0.0, 1.0, 0.0], [0.0, 0.99, 0.0]]);
        assert!(matches!(mesh(0, &m), Err(GltfError::NotUnit { at: 1, .. })));
        m.normals = Some(vec![[0.0; 3], [0.0, 1.0, 0.0]]);
        assert!(matches!(mesh(0, &m), Err(GltfError::NotUnit { at: 0, .. })));
    }
}
