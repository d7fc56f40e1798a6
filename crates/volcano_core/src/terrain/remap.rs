//! Conservative transfer of a cell-centred thickness field (a lava patch's frozen layer, on its
//! own grid) onto terrain nodes (docs/physics/lava.md §6.7).
//!
//! Each value of the source grid covers the square of side `c` centred on its sample; each
//! terrain node owns the square of side `C` centred on it (its *footprint*), and the outermost
//! nodes' footprints extend outward without end, so every bit of source area belongs to
//! exactly one node. A node receives `Σ v · c² · fx · fy` over the source cells, where `fx`
//! and `fy` are the fractions of the cell's width and depth inside its footprint (the exact
//! overlap of two axis-aligned squares is the product of the two 1D overlaps). The fractions
//! of one cell sum to 1 up to rounding, so the total volume is kept to ~1e-15 relative for any
//! ratio of the cell sizes and any offset between the grids (first-order conservative
//! remapping, as in Jones 1999, *Mon. Wea. Rev.* 127, for regular grids).

use bevy::reflect::Reflect;

use crate::grid::Grid2;

/// A rectangle of terrain nodes: columns `i0..i0 + ni`, rows `j0..j0 + nj`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash, Reflect)]
pub struct NodeRegion {
    /// First column.
    pub i0: usize,
    /// First row.
    pub j0: usize,
    /// Columns.
    pub ni: usize,
    /// Rows.
    pub nj: usize,
}

impl NodeRegion {
    /// Nodes in the region.
    pub fn len(&self) -> usize {
        self.ni * self.nj
    }
    /// Whether the region holds no node.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Whether node `(i, j)` lies in the region.
    pub fn contains(&self, i: usize, j: usize) -> bool {
        (self.i0..self.i0 + self.ni).contains(&i) && (self.j0..self.j0 + self.nj).contains(&j)
    }
    /// The smallest region holding both (an empty region adds nothing).
    pub fn union(self, other: NodeRegion) -> NodeRegion {
        if self.is_empty() {
            return other;
        }
        if other.is_empty() {
            return self;
        }
        let (i0, j0) = (self.i0.min(other.i0), self.j0.min(other.j0));
        let i1 = (self.i0 + self.ni).max(other.i0 + other.ni);
        let j1 = (self.j0 + self.nj).max(other.j0 + other.nj);
        NodeRegion { i0, j0, ni: i1 - i0, nj: j1 - j0 }
    }
    /// The region grown by `by` nodes on every side, clipped to an `nx × ny` grid.
    pub fn grown(self, by: usize, nx: usize, ny: usize) -> NodeRegion {
        if self.is_empty() {
            return self;
        }
        let (i0, j0) = (self.i0.saturating_sub(by), self.j0.saturating_sub(by));
        let i1 = (self.i0 + self.ni + by).min(nx);
        let j1 = (self.j0 + self.nj + by).min(ny);
        NodeRegion { i0, j0, ni: i1.saturating_sub(i0), nj: j1.saturating_sub(j0) }
    }
}

/// Overlap fractions of source cells with node footprints along one axis: for each cell, the
/// first node it touches and the fraction of its width in each following node.
#[derive(Debug, Clone, PartialEq)]
struct AxisWeights {
    first: Vec<usize>,
    start: Vec<usize>,
    weights: Vec<f64>,
}

impl AxisWeights {
    /// Cells `[o + (i − ½)c, o + (i + ½)c]`, `i < n`, against nodes `k < m` with footprints
    /// `[O + (k − ½)C, O + (k + ½)C]`, the first and last open outward.
    fn new((o, c, n): (f64, f64, usize), (big_o, big_c, m): (f64, f64, usize)) -> Self {
        let mut first = Vec::with_capacity(n);
        let mut start = Vec::with_capacity(n + 1);
        let mut weights = Vec::new();
        // Boundary between node k − 1 and node k (k in 1..m).
        let edge = |k: usize| big_o + (k as f64 - 0.5) * big_c;
        let node_of = |x: f64| ((x - big_o) / big_c + 0.5).floor().clamp(0.0, (m - 1) as f64) as usize;
        for i in 0..n {
            let a = o + (i as f64 - 0.5) * c;
            let b = a + c;
            let (ka, kb) = (node_of(a), node_of(b));
            first.push(ka);
            start.push(weights.len());
            for k in ka..=kb {
                let lo = if k == ka { a } else { edge(k) };
                let hi = if k == kb { b } else { edge(k + 1) };
                weights.push(((hi - lo) / c).max(0.0));
            }
        }
        start.push(weights.len());
        Self { first, start, weights }
    }

    /// `(node, fraction)` of cell `i`.
    fn of(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        let w = &self.weights[self.start[i]..self.start[i + 1]];
        w.iter().enumerate().map(move |(d, &f)| (self.first[i] + d, f))
    }

    /// First and one-past-last node touched by any cell.
    fn span(&self) -> (usize, usize) {
        let n = self.first.len();
        let lo = self.first.iter().copied().min().unwrap_or(0);
        let hi = (0..n).map(|i| self.first[i] + self.start[i + 1] - self.start[i]).max().unwrap_or(0);
        (lo, hi)
    }
}

/// Precomputed overlap of a source grid with the nodes of a terrain grid. Depends only on the
/// two grids' geometry, so one patch builds it once.
#[derive(Debug, Clone, PartialEq)]
pub struct NodeRemap {
    x: AxisWeights,
    y: AxisWeights,
    region: NodeRegion,
    cell_area: f64,
    /// Row sums along x, per source row (scratch).
    rows: Vec<f64>,
}

impl NodeRemap {
    /// The overlap of `cells`' squares with the footprints of `nodes`.
    pub fn new<A: Copy, B: Copy>(cells: &Grid2<A>, nodes: &Grid2<B>) -> Self {
        let (o, on) = (cells.origin().as_dvec2(), nodes.origin().as_dvec2());
        let x = AxisWeights::new((o.x, cells.cell(), cells.nx()), (on.x, nodes.cell(), nodes.nx()));
        let y = AxisWeights::new((o.y, cells.cell(), cells.ny()), (on.y, nodes.cell(), nodes.ny()));
        let ((i0, i1), (j0, j1)) = (x.span(), y.span());
        let region = NodeRegion { i0, j0, ni: i1 - i0, nj: j1 - j0 };
        Self { x, y, region, cell_area: cells.cell() * cells.cell(), rows: Vec::new() }
    }

    /// The nodes any source cell touches.
    pub fn region(&self) -> NodeRegion {
        self.region
    }

    /// Volume (m³) each node of [`Self::region`] receives from the thicknesses `values` (m,
    /// row-major over the source grid this remap was built for), into `out` (resized to the
    /// region, row-major). The sum of `out` equals `Σ values · c²` to rounding. Non-finite
    /// values count as 0.
    pub fn volumes(&mut self, values: &[f64], out: &mut Vec<f64>) {
        let (n_cx, n_cy) = (self.x.first.len(), self.y.first.len());
        let r = self.region;
        out.clear();
        out.resize(r.len(), 0.0);
        if values.len() != n_cx * n_cy {
            return;
        }
        self.rows.resize(r.ni, 0.0);
        for (j, row) in values.chunks(n_cx).enumerate() {
            self.rows.fill(0.0);
            let mut any = false;
            for (i, &v) in row.iter().enumerate() {
                if v == 0.0 || !v.is_finite() {
                    continue;
                }
                any = true;
                for (k, f) in self.x.of(i) {
                    self.rows[k - r.i0] += v * f;
                }
            }
            if !any {
                continue;
            }
            for (l, g) in self.y.of(j) {
                let dst = &mut out[(l - r.j0) * r.ni..(l - r.j0 + 1) * r.ni];
                for (d, s) in dst.iter_mut().zip(&self.rows) {
                    *d += s * g * self.cell_area;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Vec2;

    fn grid(n: usize, cell: f64, origin: Vec2) -> Grid2<f64> {
        Grid2::new(n, n, cell, origin, 0.0).unwrap()
    }

    #[test]
    fn a_cell_inside_one_footprint_goes_to_that_node() {
        // Nodes every 2 m from 0; a 0.5 m cell centred at 4.1 lies in node 2's [3, 5].
        let nodes = grid(8, 2.0, Vec2::ZERO);
        let cells = Grid2::new(1, 1, 0.5, Vec2::new(4.1, 6.2), 0.0f64).unwrap();
        let mut remap = NodeRemap::new(&cells, &nodes);
        assert_eq!(remap.region(), NodeRegion { i0: 2, j0: 3, ni: 1, nj: 1 });
        let mut out = Vec::new();
        remap.volumes(&[2.0], &mut out);
        assert_eq!(out, vec![0.5]);
    }

    #[test]
    fn a_cell_across_a_footprint_edge_splits_by_area() {
        // A 1 m cell centred at (5.25, 4): x spans [4.75, 5.75], of which 0.25 m lies in
        // node 2 (ends at 5) and 0.75 m in node 3.
        let nodes = grid(8, 2.0, Vec2::ZERO);
        let cells = Grid2::new(1, 1, 1.0, Vec2::new(5.25, 4.0), 0.0f64).unwrap();
        let mut remap = NodeRemap::new(&cells, &nodes);
        assert_eq!(remap.region(), NodeRegion { i0: 2, j0: 2, ni: 2, nj: 1 });
        let mut out = Vec::new();
        remap.volumes(&[1.0], &mut out);
        assert_eq!(out, vec![0.25, 0.75]);
    }

    #[test]
    fn coarse_cells_over_fine_nodes_and_the_edge_nodes_take_the_overhang() {
        // One 10 m cell centred at the first node of a 1 m grid: 5 m of it hangs off the
        // grid's side and goes to node 0, which also owns [−0.5, 0.5].
        let nodes = grid(20, 1.0, Vec2::ZERO);
        let cells = Grid2::new(1, 1, 10.0, Vec2::new(0.0, 10.0), 0.0f64).unwrap();
        let mut remap = NodeRemap::new(&cells, &nodes);
        let r = remap.region();
        assert_eq!((r.i0, r.ni, r.j0, r.nj), (0, 6, 5, 11));
        let mut out = Vec::new();
        remap.volumes(&[0.01], &mut out);
        // Row 5 takes 0.5 m of the cell's depth, rows 6..15 one metre each.
        let at = |i: usize, j: usize| out[(j - 5) * 6 + i];
        assert!((at(0, 10) - 0.01 * 5.5).abs() < 1e-15, "{}", at(0, 10));
        assert!((at(3, 10) - 0.01).abs() < 1e-15);
        assert!((at(3, 5) - 0.005).abs() < 1e-15);
        assert!((out.iter().sum::<f64>() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn total_volume_is_kept_for_any_offset_and_ratio() {
        let nodes = grid(64, 3.0, Vec2::new(-90.0, -90.0));
        for (cell, origin) in
            [(1.0, Vec2::new(-20.3, 7.7)), (4.7, Vec2::new(-61.1, -33.9)), (3.0, Vec2::ZERO)]
        {
            let mut cells = grid(17, cell, origin);
            for (k, v) in cells.data_mut().iter_mut().enumerate() {
                *v = ((k * 7919) % 101) as f64 * 1e-3;
            }
            let mut remap = NodeRemap::new(&cells, &nodes);
            let mut out = Vec::new();
            remap.volumes(cells.data(), &mut out);
            let want = cells.data().iter().sum::<f64>() * cell * cell;
            let got = out.iter().sum::<f64>();
            assert!((got - want).abs() < 1e-13 * want, "cell {cell}: {got} vs {want}");
            assert!(out.iter().all(|v| *v >= 0.0));
        }
    }
}
