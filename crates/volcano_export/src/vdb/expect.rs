//! What a written file must hold, as the JSON `tools/check_vdb.py` checks with OpenVDB itself:
//! per grid its name, class, transform, active voxel count and box, the sum of its active
//! values, and sampled voxels (active ones and inactive ones around the box).

use serde_json::{Value, json};

use super::FloatGrid;

/// The expectation for `grids`, with at most `samples` active voxels of each (evenly spread
/// over the voxels in index order) and the eight corners just outside its active box.
pub fn expectation(grids: &[&FloatGrid], samples: usize) -> Value {
    let grids: Vec<Value> = grids
        .iter()
        .map(|g| {
            let mut active: Vec<_> = g.iter_active().collect();
            active.sort_by_key(|(c, _)| *c);
            let step = active.len().div_ceil(samples.max(1)).max(1);
            let mut picked: Vec<Value> =
                active.iter().step_by(step).map(|(c, v)| json!([c[0], c[1], c[2], *v as f64])).collect();
            let bbox = g.active_bbox();
            if let Some((lo, hi)) = bbox {
                for n in 0..8 {
                    let c: [i32; 3] =
                        std::array::from_fn(|a| if n >> a & 1 == 0 { lo[a] - 1 } else { hi[a] + 1 });
                    picked.push(json!([c[0], c[1], c[2], 0.0]));
                }
            }
            json!({
                "name": g.name(),
                "class": g.class().name(),
                "voxel_size": g.transform().voxel_size(),
                "translation": g.transform().translation(),
                "active_voxels": active.len(),
                "bbox": bbox.map(|(lo, hi)| json!([lo, hi])),
                "sum": active.iter().map(|(_, v)| *v as f64).sum::<f64>(),
                "samples": picked,
            })
        })
        .collect();
    json!({ "grids": grids })
}
