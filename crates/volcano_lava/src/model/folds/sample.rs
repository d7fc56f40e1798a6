//! Sampling the flow and surface grids at particle positions.

use bevy::math::{DVec2, Vec2};

use crate::model::field::FlowField;
use crate::model::surface::SurfaceState;

/// Continuous grid coordinates of world (x, z).
fn grid(field: &FlowField, p: DVec2) -> (f64, f64) {
    let o = field.ground().origin();
    ((p.x - o.x as f64) / field.cell(), (p.y - o.y as f64) / field.cell())
}

/// Flat index of the cell nearest to `p`, or `None` off the grid.
pub(crate) fn cell(field: &FlowField, p: DVec2) -> Option<usize> {
    if !p.is_finite() {
        return None;
    }
    field.cell_at(Vec2::new(p.x as f32, p.y as f32)).map(|(i, j)| j * field.nx() + i)
}

/// Bilinear surface velocity at `p` (zero off the grid).
pub(crate) fn surface_velocity(field: &FlowField, surface: &SurfaceState, p: DVec2) -> DVec2 {
    let (nx, ny) = (field.nx(), field.ny());
    let (gx, gy) = grid(field, p);
    if !(gx.is_finite() && gy.is_finite()) || gx < 0.0 || gy < 0.0 {
        return DVec2::ZERO;
    }
    let (gx, gy) = (gx.min((nx - 1) as f64), gy.min((ny - 1) as f64));
    let (i0, j0) = (gx.floor() as usize, gy.floor() as usize);
    let (i1, j1) = ((i0 + 1).min(nx - 1), (j0 + 1).min(ny - 1));
    let (tx, ty) = (gx - i0 as f64, gy - j0 as f64);
    let at = |i: usize, j: usize| DVec2::new(surface.vsurf[0][j * nx + i], surface.vsurf[1][j * nx + i]);
    let a = at(i0, j0).lerp(at(i1, j0), tx);
    let b = at(i0, j1).lerp(at(i1, j1), tx);
    a.lerp(b, ty)
}

/// Whether the cylinder at `p` (axis `tangent`, length `len`, diameter `dia`) lies on lava:
/// its centre, both ends and both sides are on cells holding lava.
pub(crate) fn cylinder_on_flow(field: &FlowField, p: DVec2, tangent: DVec2, len: f64, dia: f64) -> bool {
    let n = tangent.perp();
    let h = field.thickness().data();
    let min = 1e-3;
    [p, p + tangent * (0.5 * len), p - tangent * (0.5 * len), p + n * (0.5 * dia), p - n * (0.5 * dia)]
        .iter()
        .all(|&q| cell(field, q).is_some_and(|k| h[k] >= min))
}
