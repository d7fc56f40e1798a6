//! Ash from the column into the layers: each slice and umbrella sphere hands the solid mass it
//! shed to the air layer it is in (thesis §4.3.3 makes the plume a source of the layers' ash).

use volcano_atmosphere::model::fields::{GridSpec, LayerFields};

/// Where a parcel of ash went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Delivered {
    /// Into layer `layer`'s cell `cell`.
    Air {
        /// Layer index.
        layer: usize,
        /// Cell index.
        cell: usize,
    },
    /// Onto the ground at cell `cell` (every layer of that column is rock at that altitude).
    Ground {
        /// Cell index.
        cell: usize,
    },
    /// Outside the grid (booked as outflow by the caller).
    Outside,
}

/// Cell of the grid containing world point `(x, z)`, `None` outside.
pub fn cell_at(grid: GridSpec, x: f64, z: f64) -> Option<usize> {
    let half = 0.5 * grid.extent();
    if !(x.abs() < half && z.abs() < half) {
        return None;
    }
    let i = (((x + half) / grid.dx) as usize).min(grid.n - 1);
    let j = (((z + half) / grid.dx) as usize).min(grid.n - 1);
    Some(j * grid.n + i)
}

/// The layer whose slab contains `altitude` (the top layer above the stack, the bottom one
/// below it).
pub fn layer_at(layers: &[LayerFields], altitude: f64) -> usize {
    layers.iter().position(|l| altitude < l.bottom + l.thickness).unwrap_or(layers.len().saturating_sub(1))
}

/// Adds `grams` of ash at world `(x, altitude, z)`: into the cell of the layer containing that
/// altitude, or of the first free layer above it where terrain fills that layer's slab; onto
/// `ground` (g/m², cell area `dx²`) if the whole column is rock. Amount-exact: the layer gains
/// `grams / (σ h dx²)` g/m³ over its free volume.
pub fn inject_ash(
    layers: &mut [LayerFields],
    ground: &mut [f64],
    grid: GridSpec,
    (x, altitude, z): (f64, f64, f64),
    grams: f64,
) -> Delivered {
    if grams.is_nan() || grams <= 0.0 || layers.is_empty() {
        return Delivered::Outside;
    }
    let Some(cell) = cell_at(grid, x, z) else { return Delivered::Outside };
    let area = grid.dx * grid.dx;
    let start = layer_at(layers, altitude);
    for (i, layer) in layers.iter_mut().enumerate().skip(start) {
        let sigma = layer.sigma.data()[cell] as f64;
        if sigma > 0.0 {
            layer.ash.data_mut()[cell] += grams / (sigma * layer.thickness * area);
            return Delivered::Air { layer: i, cell };
        }
    }
    ground[cell] += grams / area;
    Delivered::Ground { cell }
}

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_atmosphere::model::ash::airborne;
    use volcano_atmosphere::model::fields::layer_geometry;

    #[test]
    fn ash_lands_in_the_layer_it_is_in_and_amounts_are_exact() {
        let g = GridSpec::new(16, 100.0).unwrap();
        let alts = [500.0, 1500.0, 3000.0];
        let geo = layer_geometry(&alts).unwrap();
        let mut l: Vec<LayerFields> =
            alts.iter().zip(geo).map(|(&a, (b, h))| LayerFields::new(g, a, b, h, 280.0)).collect();
        let mut ground = vec![0.0; 256];
        let k = cell_at(g, 120.0, -260.0).unwrap();
        assert_eq!(k, (5 * 16) + 9);
        assert_eq!(
            inject_ash(&mut l, &mut ground, g, (120.0, 1600.0, -260.0), 5e3),
            Delivered::Air { layer: 1, cell: k }
        );
        // Terrain fills layer 0 here: ash at 300 m goes into layer 1.
        l[0].sigma.data_mut()[3] = 0.0;
        let (cx, cz) = g.centre(3);
        assert_eq!(
            inject_ash(&mut l, &mut ground, g, (cx, 300.0, cz), 2e3),
            Delivered::Air { layer: 1, cell: 3 }
        );
        assert!((airborne(&l, 100.0) - 7e3).abs() < 1e-9);
        assert_eq!(inject_ash(&mut l, &mut ground, g, (1e5, 300.0, 0.0), 1.0), Delivered::Outside);
        for layer in l.iter_mut() {
            layer.sigma.data_mut()[4] = 0.0;
        }
        let (cx, cz) = g.centre(4);
        assert_eq!(inject_ash(&mut l, &mut ground, g, (cx, 300.0, cz), 1e4), Delivered::Ground { cell: 4 });
        assert!((ground[4] - 1.0).abs() < 1e-15);
    }
}
