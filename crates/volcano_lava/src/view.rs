//! What renderers and panels read of a lava field (docs/ARCHITECTURE.md §2.3), beyond the
//! field itself (`LavaState` holds the [`FlowField`](crate::FlowField), the
//! [`SurfaceState`](crate::SurfaceState) and the folds) and the probes
//! ([`LavaQuery`](crate::LavaQuery), [`LavaProbe`](crate::LavaProbe)): the temperature of the
//! top of the crust (and, for vent lava, the crust a cell's age gives), the side of a vent
//! lava tile, the fold particles, the crust's debug colour, and PNG maps of a field
//! ([`write_maps`], for the CLI and the scenario example). Read-only; the functions are the
//! model's own, re-exported, so the display shows what the simulation holds.

mod maps;

pub use crate::model::crust::crust_from_contact;
pub use crate::model::folds::{Fold, FoldParticle};
pub use crate::model::runout::tiles::TILE as RUNOUT_TILE;
pub use crate::model::thermal::surface_temperature;
pub use maps::write_maps;

/// Crust debug colour (thesis Figs 5.11–5.13): red below 8 mm, green 8 mm–2 cm, blue above
/// 2 cm (sRGB). The renderer's crust view and the headless scenario's `crust.png`
/// ([`write_maps`], written by the CLI) both use it, so it
/// lives here rather than in the render crate.
pub fn crust_colour(crust: f64) -> [u8; 3] {
    if crust < 0.008 {
        [220, 40, 30]
    } else if crust <= 0.02 {
        [40, 190, 60]
    } else {
        [40, 80, 220]
    }
}
