//! Frozen lava written back into the terrain under a field (docs/physics/lava.md §6.7: lava
//! colder than the solidus freezes into the ground). Inside a field the ground already
//! includes the frozen layer; this carries it into the terrain's exact added layer
//! ([`Terrain::add_thickness`]), so a field built later, the pyroclastic particles and gameplay
//! height queries see the new ground: later lava flows over earlier lava.
//!
//! The transfer is the conservative area-weighted remap of [`NodeRemap`] (each field cell
//! shares its volume among the terrain node footprints it overlaps), so the terrain gains
//! exactly the frozen volume, whatever the two cell sizes and their offset.

use bevy::math::Vec2;
use volcano_core::terrain::{NodeRegion, NodeRemap};
use volcano_core::{ConfigError, Terrain};

use super::field::FlowField;

/// The terrain nodes under one lava field and the frozen volume already written to each.
#[derive(Debug, Clone, PartialEq)]
pub struct TerrainImprint {
    remap: NodeRemap,
    /// Terrain grid the remap was built for: (nx, ny, cell, origin).
    nodes: (usize, usize, f64, Vec2),
    /// Volume (m³) written so far per node of the region, row-major.
    written: Vec<f64>,
    volumes: Vec<f64>,
    delta: Vec<f64>,
}

impl TerrainImprint {
    /// The imprint of `field` on `terrain` (the field's cells against the terrain's node
    /// footprints); nothing written yet.
    pub fn new(terrain: &Terrain, field: &FlowField) -> Self {
        let h = terrain.heights();
        let remap = NodeRemap::new(field.solid(), h);
        let n = remap.region().len();
        Self {
            remap,
            nodes: (h.nx(), h.ny(), h.cell(), h.origin()),
            written: vec![0.0; n],
            volumes: Vec::with_capacity(n),
            delta: Vec::with_capacity(n),
        }
    }

    /// The terrain nodes the field's cells overlap.
    pub fn region(&self) -> NodeRegion {
        self.remap.region()
    }

    /// Terrain nodes covered.
    pub fn len(&self) -> usize {
        self.written.len()
    }

    /// Whether no terrain node lies under the field.
    pub fn is_empty(&self) -> bool {
        self.written.is_empty()
    }

    /// Frozen volume written into the terrain so far (m³).
    pub fn written_volume(&self) -> f64 {
        self.written.iter().sum()
    }

    /// Adds to `terrain` the frozen lava of `field` not written yet: the field's frozen layer
    /// remapped onto the node footprints, minus what earlier calls wrote. Returns the nodes
    /// whose height moved (empty if none). Errors, writing nothing, if `terrain`'s grid is not
    /// the one the imprint was built for.
    pub fn apply(&mut self, terrain: &mut Terrain, field: &FlowField) -> Result<NodeRegion, ConfigError> {
        let h = terrain.heights();
        if (h.nx(), h.ny(), h.cell(), h.origin()) != self.nodes {
            return Err(ConfigError::InvalidParameter {
                name: "terrain under a lava field",
                value: h.cell(),
                reason: "its grid changed since the field was built; rebuild the field".into(),
            });
        }
        let area = h.cell() * h.cell();
        self.remap.volumes(field.solid().data(), &mut self.volumes);
        self.delta.clear();
        self.delta.extend(self.volumes.iter().zip(&self.written).map(|(v, w)| (v - w) / area));
        if self.delta.iter().all(|d| *d == 0.0) {
            return Ok(NodeRegion::default());
        }
        let moved = terrain.add_thickness(self.remap.region(), &self.delta)?;
        self.written.copy_from_slice(&self.volumes);
        Ok(moved)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::field::{Edges, FlowField};
    use volcano_core::{Grid2, LandCover};

    fn terrain(n: usize, cell: f64, height: f32) -> Terrain {
        let h = Grid2::new(n, n, cell, Vec2::ZERO, height).unwrap();
        let c = Grid2::new(n, n, cell, Vec2::ZERO, LandCover::Ground).unwrap();
        Terrain::new(h, c, f32::MIN).unwrap()
    }

    /// A 0.5 m field of 64² cells on a 2 m terrain at 2,500 m, off the node lattice.
    fn setup() -> (Terrain, FlowField) {
        let ground = Grid2::new(64, 64, 0.5, Vec2::new(10.3, 10.1), 2500.0f64).unwrap();
        (terrain(32, 2.0, 2500.0), FlowField::new(ground, Edges::default(), 300.0).unwrap())
    }

    #[test]
    fn frozen_volume_reaches_the_terrain_exactly_once() {
        let (mut t, mut field) = setup();
        let mut imprint = TerrainImprint::new(&t, &field);
        // Cells span x in [10.05, 42.05]: node footprints 5 ([9, 11]) to 21 ([41, 43]).
        assert_eq!(imprint.region(), NodeRegion { i0: 5, j0: 5, ni: 17, nj: 17 });
        for (k, v) in field.solid.data_mut().iter_mut().enumerate() {
            *v = if k % 3 == 0 { 0.3 } else { 0.0 };
        }
        let frozen = field.solid().data().iter().sum::<f64>() * 0.25;
        let moved = imprint.apply(&mut t, &field).unwrap();
        assert!(!moved.is_empty());
        let rel = (t.added_volume() - frozen).abs() / frozen;
        assert!(rel < 1e-13, "terrain gained {} m³ of {frozen} (rel {rel:e})", t.added_volume());
        assert_eq!(t.heights().get(2, 2), 2500.0, "outside the field");
        assert!(t.heights().get(12, 12) > 2500.05);
        // Nothing new: nothing written, nothing moved.
        assert!(imprint.apply(&mut t, &field).unwrap().is_empty());
        assert!((t.added_volume() - frozen).abs() < 1e-13 * frozen);
        // More freezes in one cell: only the difference is added.
        field.solid.data_mut()[1] += 0.4;
        imprint.apply(&mut t, &field).unwrap();
        let rel = (t.added_volume() - (frozen + 0.1)).abs() / frozen;
        assert!(rel < 1e-13, "{rel:e}");
    }

    #[test]
    fn a_changed_terrain_grid_is_an_error() {
        let (t, mut field) = setup();
        let mut imprint = TerrainImprint::new(&t, &field);
        field.solid.data_mut()[0] = 1.0;
        let mut other = terrain(40, 2.0, 0.0);
        assert!(imprint.apply(&mut other, &field).is_err());
        assert!(other.added().is_none(), "nothing written");
    }
}
