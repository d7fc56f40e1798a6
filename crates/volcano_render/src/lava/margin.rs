//! Smooth lava margins: the outline of a flow is placed inside the cells, where a cell's
//! *coverage* crosses one half, instead of following the cell staircase.
//!
//! A heightfield cell at the front of a flow is partly covered: its thickness is the cell
//! average of a sheet that ends somewhere inside it. [`coverage`] estimates that fraction as
//! the cell's thickness over the thickest cell around it (1 away from the front, 0 on dry
//! ground), a volume-of-fluid reading of the field. [`clip_grid`] then triangulates the grid
//! of cell centres and clips it at coverage ½ (marching triangles: a quad crossed by the
//! outline is split into four triangles around its centre, so no diagonal is favoured), with
//! the outline's vertices where the linear interpolation of coverage along an edge crosses ½.
//! Neighbouring quads share those vertices, so the surface has no cracks. Pure functions, no
//! ECS.

use std::collections::HashMap;

/// Coverage at which the outline is drawn.
pub const EDGE: f32 = 0.5;

/// Coverage (0–1) of each cell of an `nx × ny` row-major grid holding `depth` (m) of lava:
/// 0 where the depth is at most `min`, 1 where no cell of the 3×3 neighbourhood (inside the
/// grid) is that thin, else the depth over the deepest cell of the neighbourhood.
pub fn coverage(depth: &[f64], nx: usize, ny: usize, min: f64) -> Vec<f32> {
    let mut out = vec![0.0; depth.len()];
    if depth.len() != nx * ny {
        return out;
    }
    for j in 0..ny {
        for i in 0..nx {
            let k = j * nx + i;
            if depth[k] <= min {
                continue;
            }
            let (mut deepest, mut front) = (depth[k], false);
            for b in j.saturating_sub(1)..(j + 2).min(ny) {
                for a in i.saturating_sub(1)..(i + 2).min(nx) {
                    let d = depth[b * nx + a];
                    front |= d <= min;
                    deepest = deepest.max(d);
                }
            }
            out[k] = if front { (depth[k] / deepest).clamp(0.0, 1.0) as f32 } else { 1.0 };
        }
    }
    out
}

/// A vertex [`clip_grid`] adds after the `nx · ny` grid vertices.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Extra {
    /// The centre of a quad: the mean of its four corner vertices.
    Centre([u32; 4]),
    /// On the outline: `(1 − t) · a + t · b` of two earlier vertices (grid or extra).
    Edge {
        /// First vertex (the lower index).
        a: u32,
        /// Second vertex.
        b: u32,
        /// Position between them, 0 at `a`.
        t: f32,
    },
}

/// The covered part of a grid: [`Extra`] vertices following the grid's, and triangles.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ClippedGrid {
    /// Vertices after the grid's, in order (each refers only to earlier ones).
    pub extra: Vec<Extra>,
    /// Triangle list (counter-clockwise seen from +y, with grid row `j` along +z and column
    /// `i` along +x).
    pub indices: Vec<u32>,
}

impl ClippedGrid {
    /// Extends per-vertex `values` of the grid (`nx · ny` of them) with those of the extra
    /// vertices: means for centres, linear interpolation on the outline.
    pub fn extend<const N: usize>(&self, values: &mut Vec<[f32; N]>) {
        for e in &self.extra {
            let v = match *e {
                Extra::Centre(q) => {
                    let mut s = [0.0; N];
                    for c in q {
                        for (s, x) in s.iter_mut().zip(values[c as usize]) {
                            *s += 0.25 * x;
                        }
                    }
                    s
                }
                Extra::Edge { a, b, t } => {
                    let (a, b) = (values[a as usize], values[b as usize]);
                    std::array::from_fn(|n| a[n] + t * (b[n] - a[n]))
                }
            };
            values.push(v);
        }
    }

    /// Every outline vertex's index (after the grid's) and its two ends.
    pub fn outline(&self, grid_vertices: usize) -> impl Iterator<Item = (usize, u32, u32, f32)> + '_ {
        self.extra.iter().enumerate().filter_map(move |(n, e)| match *e {
            Extra::Edge { a, b, t } => Some((grid_vertices + n, a, b, t)),
            Extra::Centre(_) => None,
        })
    }
}

/// Triangulates the `nx × ny` grid of vertices (row `j` at `j · nx + i`) and keeps the part
/// whose interpolated `cover` is at least [`EDGE`]: quads with all four corners covered as two
/// triangles, quads crossed by the outline as four triangles around their centre, clipped.
pub fn clip_grid(cover: &[f32], nx: usize, ny: usize) -> ClippedGrid {
    let mut out = ClippedGrid::default();
    if cover.len() != nx * ny || nx < 2 || ny < 2 {
        return out;
    }
    let mut alpha: Vec<f32> = cover.to_vec();
    let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
    let base = (nx * ny) as u32;
    for j in 0..ny - 1 {
        for i in 0..nx - 1 {
            let v00 = (j * nx + i) as u32;
            let (v01, v10, v11) = (v00 + nx as u32, v00 + 1, v00 + nx as u32 + 1);
            // Around the quad, counter-clockwise seen from +y.
            let ring = [v00, v01, v11, v10];
            let inside = ring.map(|v| alpha[v as usize] >= EDGE);
            if inside.iter().all(|&x| x) {
                out.indices.extend([v00, v01, v10, v10, v01, v11]);
                continue;
            }
            if !inside.iter().any(|&x| x) {
                continue;
            }
            let centre = base + out.extra.len() as u32;
            out.extra.push(Extra::Centre(ring));
            alpha.push(0.25 * ring.iter().map(|&v| alpha[v as usize]).sum::<f32>());
            for n in 0..4 {
                let tri = [ring[n], ring[(n + 1) % 4], centre];
                clip_triangle(tri, &mut alpha, &mut edges, base, &mut out);
            }
        }
    }
    out
}

/// Clips one triangle (counter-clockwise) at coverage [`EDGE`] and appends what is left,
/// fanned, with outline vertices shared through `edges`.
fn clip_triangle(
    tri: [u32; 3],
    alpha: &mut Vec<f32>,
    edges: &mut HashMap<(u32, u32), u32>,
    base: u32,
    out: &mut ClippedGrid,
) {
    let mut poly: [u32; 4] = [0; 4];
    let mut len = 0;
    for n in 0..3 {
        let (p, q) = (tri[n], tri[(n + 1) % 3]);
        let (ip, iq) = (alpha[p as usize] >= EDGE, alpha[q as usize] >= EDGE);
        if ip {
            poly[len] = p;
            len += 1;
        }
        if ip != iq {
            let key = (p.min(q), p.max(q));
            let v = *edges.entry(key).or_insert_with(|| {
                let (a, b) = key;
                let (fa, fb) = (alpha[a as usize], alpha[b as usize]);
                let t = ((EDGE - fa) / (fb - fa)).clamp(0.0, 1.0);
                out.extra.push(Extra::Edge { a, b, t });
                alpha.push(EDGE);
                base + out.extra.len() as u32 - 1
            });
            poly[len] = v;
            len += 1;
        }
    }
    for n in 1..len.saturating_sub(1) {
        out.indices.extend([poly[0], poly[n], poly[n + 1]]);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flat lobe of radius `r` (cells) centred at `(cx, cy)` (cells, from the grid's first
    /// cell centre): each cell's depth is 0.3 m times the fraction of its area inside the
    /// circle (16 × 16 samples), as a mass-conserving heightfield holds a steep-fronted lobe.
    fn lobe(n: usize, (cx, cy): (f64, f64), r: f64) -> Vec<f64> {
        let mut depth = vec![0.0; n * n];
        for j in 0..n {
            for i in 0..n {
                let mut inside = 0;
                for s in 0..16 {
                    for t in 0..16 {
                        let x = i as f64 - 0.5 + (s as f64 + 0.5) / 16.0;
                        let y = j as f64 - 0.5 + (t as f64 + 0.5) / 16.0;
                        inside += usize::from((x - cx).hypot(y - cy) < r);
                    }
                }
                depth[j * n + i] = 0.3 * inside as f64 / 256.0;
            }
        }
        depth
    }

    /// Distance (cells) of every outline vertex from the circle, as (max, mean).
    fn outline_error(n: usize, centre: (f64, f64), r: f64) -> (f64, f64, usize) {
        let depth = lobe(n, centre, r);
        let cover = coverage(&depth, n, n, 1e-3);
        let grid = clip_grid(&cover, n, n);
        let mut xy: Vec<[f32; 2]> = (0..n * n).map(|k| [(k % n) as f32, (k / n) as f32]).collect();
        grid.extend(&mut xy);
        let errors: Vec<f64> = grid
            .outline(n * n)
            .map(|(v, ..)| {
                let [x, y] = xy[v];
                ((x as f64 - centre.0).hypot(y as f64 - centre.1) - r).abs()
            })
            .collect();
        let max = errors.iter().copied().fold(0.0, f64::max);
        (max, errors.iter().sum::<f64>() / errors.len() as f64, errors.len())
    }

    #[test]
    fn a_round_lobe_has_a_round_outline() {
        for (centre, r) in [((15.3, 16.1), 9.4), ((20.0, 20.0), 12.0), ((16.7, 15.2), 4.3)] {
            let (max, mean, count) = outline_error(40, centre, r);
            assert!(count > 20, "{count} outline vertices");
            // The cell staircase is off by up to ~0.7 cell (half a diagonal), 0.25 on average.
            assert!(max < 0.2 && mean < 0.06, "r = {r}: max {max:.3}, mean {mean:.3} cells");
        }
    }

    #[test]
    fn the_clipped_surface_is_closed_and_counter_clockwise() {
        let n = 24;
        let depth = lobe(n, (11.2, 12.6), 7.3);
        let cover = coverage(&depth, n, n, 1e-3);
        let grid = clip_grid(&cover, n, n);
        let mut xy: Vec<[f32; 2]> = (0..n * n).map(|k| [(k % n) as f32, (k / n) as f32]).collect();
        grid.extend(&mut xy);
        // Every triangle faces +y (x along i, z along j): cross_y = dz1·dx2 − dx1·dz2 ≥ 0.
        let mut area = 0.0;
        for t in grid.indices.chunks(3) {
            let [a, b, c] = [xy[t[0] as usize], xy[t[1] as usize], xy[t[2] as usize]];
            let cross = (b[1] - a[1]) * (c[0] - a[0]) - (b[0] - a[0]) * (c[1] - a[1]);
            assert!(cross >= -1e-6, "clockwise triangle {t:?}");
            area += 0.5 * cross as f64;
        }
        // Covered area ≈ the disc's (π r²), within a fraction of a cell of perimeter.
        let disc = std::f64::consts::PI * 7.3 * 7.3;
        assert!((area - disc).abs() < 0.1 * 2.0 * std::f64::consts::PI * 7.3, "{area} vs {disc}");
        // Watertight: every edge of the outline belongs to exactly one triangle, every inner
        // edge to two with opposite directions.
        let mut count: HashMap<(u32, u32), i32> = HashMap::new();
        for t in grid.indices.chunks(3) {
            for e in 0..3 {
                let (p, q) = (t[e], t[(e + 1) % 3]);
                *count.entry((p.min(q), p.max(q))).or_default() += if p < q { 1 } else { -1 };
            }
        }
        let boundary = count.values().filter(|&&c| c != 0).count();
        assert_eq!(boundary, grid.outline(n * n).count(), "outline edges = outline vertices");
        // Interior cells are untouched; a dry grid has no triangles.
        assert_eq!(cover[12 * n + 11], 1.0);
        assert!(clip_grid(&[0.0; 16], 4, 4).indices.is_empty());
        assert_eq!(clip_grid(&[1.0; 16], 4, 4).indices.len(), 9 * 6);
    }

    #[test]
    fn coverage_is_the_depth_fraction_at_the_front() {
        // 1 × 4: thick, half, thin (below min), dry.
        let c = coverage(&[0.4, 0.2, 0.0005, 0.0], 4, 1, 1e-3);
        assert_eq!(c, vec![1.0, 0.5, 0.0, 0.0]);
        // A cell next to a dry one is a front cell, scaled by the deepest neighbour.
        let c = coverage(&[0.4, 0.4, 0.4, 0.0], 4, 1, 1e-3);
        assert_eq!(c, vec![1.0, 1.0, 1.0, 0.0]);
    }
}
