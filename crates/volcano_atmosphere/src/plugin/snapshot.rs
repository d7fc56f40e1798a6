//! Copies of the atmosphere's state for a weather step in flight, into reused buffers: the
//! main thread pays one `memcpy` of the fields per step instead of fresh allocations (about
//! 55 MB at 512² × 3 layers), and swaps the result back in without copying.

use volcano_core::Grid2;

use crate::model::fields::{AtmosphereState, Ground, LayerFields};

/// `dst ← src`, reusing `dst`'s buffer when the shapes match.
fn copy_grid<T: Copy>(dst: &mut Grid2<T>, src: &Grid2<T>) {
    let same = dst.nx() == src.nx()
        && dst.ny() == src.ny()
        && dst.cell() == src.cell()
        && dst.origin() == src.origin();
    if same {
        dst.data_mut().copy_from_slice(src.data());
    } else {
        *dst = src.clone();
    }
}

/// `dst ← src` for one layer. Destructures every field, so a new field fails to compile here
/// until it is copied.
pub(crate) fn copy_layer(dst: &mut LayerFields, src: &LayerFields) {
    let LayerFields {
        altitude,
        bottom,
        thickness,
        pi,
        t,
        t_ref,
        h,
        w,
        ash,
        u,
        v,
        p,
        c,
        up,
        d,
        sigma,
        wind,
        wind_relaxation_s,
        entraining,
    } = src;
    dst.altitude = *altitude;
    dst.bottom = *bottom;
    dst.thickness = *thickness;
    dst.pi = *pi;
    copy_grid(&mut dst.t, t);
    dst.t_ref = *t_ref;
    copy_grid(&mut dst.h, h);
    copy_grid(&mut dst.w, w);
    copy_grid(&mut dst.ash, ash);
    copy_grid(&mut dst.u, u);
    copy_grid(&mut dst.v, v);
    copy_grid(&mut dst.p, p);
    copy_grid(&mut dst.c, c);
    copy_grid(&mut dst.up, up);
    copy_grid(&mut dst.d, d);
    copy_grid(&mut dst.sigma, sigma);
    dst.wind = *wind;
    dst.wind_relaxation_s = *wind_relaxation_s;
    dst.entraining.clone_from(entraining);
}

/// `dst ← src` for the ground, except the fallen ash, which starts at zero in the copy: the
/// components keep the ash fallen before the step (the coupling collects it), and the ash
/// fallen during the step is added back when the result is applied ([`merge_ground`]).
pub(crate) fn copy_ground_without_ash(dst: &mut Ground, src: &Ground) {
    let Ground { height, cover, t, water, sunlit, sunlit_for, lowest, ash } = src;
    copy_grid(&mut dst.height, height);
    copy_grid(&mut dst.cover, cover);
    copy_grid(&mut dst.t, t);
    copy_grid(&mut dst.water, water);
    copy_grid(&mut dst.sunlit, sunlit);
    dst.sunlit_for = *sunlit_for;
    dst.lowest.clone_from(lowest);
    copy_grid(&mut dst.ash, ash);
    dst.ash.data_mut().fill(0.0);
}

/// Puts the stepped `result` ground in place of `current`, keeping `current`'s uncollected ash
/// on top of what fell during the step; `result` is left holding the old buffers.
pub(crate) fn merge_ground(current: &mut Ground, result: &mut Ground) {
    if result.ash.data().len() == current.ash.data().len() {
        for (r, c) in result.ash.data_mut().iter_mut().zip(current.ash.data()) {
            *r += *c;
        }
    }
    std::mem::swap(current, result);
}

/// A state for the next step: `spare`'s buffers (when the layer count matches) overwritten
/// with `layers` and `ground` (ash excluded, see [`copy_ground_without_ash`]) and the clock
/// fields of `template`.
pub(crate) fn snapshot(
    spare: Option<AtmosphereState>,
    layers: &[&LayerFields],
    ground: &Ground,
    template: AtmosphereState,
) -> AtmosphereState {
    let mut state = match spare {
        Some(s) if s.layers.len() == layers.len() => {
            AtmosphereState { layers: s.layers, ground: s.ground, ..template }
        }
        _ => AtmosphereState {
            layers: layers.iter().map(|l| (*l).clone()).collect(),
            ground: ground.clone(),
            ..template
        },
    };
    for (dst, src) in state.layers.iter_mut().zip(layers) {
        copy_layer(dst, src);
    }
    copy_ground_without_ash(&mut state.ground, ground);
    state
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scenario::Scenario;

    #[test]
    fn snapshot_into_spare_buffers_equals_a_clone_except_the_ash() {
        let a = Scenario::builtin("island").unwrap().build(Some(16)).unwrap();
        // Spare buffers of the same shape holding other values.
        let mut b = a.clone();
        for l in b.layers.iter_mut() {
            l.t.data_mut().fill(1.0);
            l.h.data_mut().fill(2.0);
            l.sigma.data_mut().fill(0.5);
            l.wind = bevy::math::Vec2::ONE;
            l.altitude += 1.0;
        }
        b.ground.t.data_mut().fill(1.0);
        b.ground.lowest.fill(7);
        b.ground.ash.data_mut().fill(3.0);
        let mut src = a.clone();
        src.ground.ash.data_mut()[5] = 2.0;
        let refs: Vec<&LayerFields> = src.layers.iter().collect();
        let template = AtmosphereState { layers: Vec::new(), ground: Ground::default(), ..a.clone() };
        let snap = snapshot(Some(b), &refs, &src.ground, template);
        assert_eq!(snap.layers, src.layers);
        let mut want = src.ground.clone();
        want.ash.data_mut().fill(0.0);
        assert_eq!(snap.ground, want);
        assert_eq!(snap.time_s, a.time_s);
    }

    #[test]
    fn merging_keeps_uncollected_ash_and_adds_the_fallen() {
        let s = Scenario::builtin("island").unwrap().build(Some(16)).unwrap();
        let mut current = s.ground.clone();
        current.ash.data_mut()[3] = 1.5;
        let mut result = s.ground.clone();
        result.ash.data_mut()[3] = 0.25;
        result.ash.data_mut()[4] = 2.0;
        result.t.data_mut()[0] = 300.0;
        merge_ground(&mut current, &mut result);
        assert_eq!(current.ash.data()[3], 1.75);
        assert_eq!(current.ash.data()[4], 2.0);
        assert_eq!(current.t.data()[0], 300.0);
        assert_eq!(result.ash.data()[3], 1.5, "the old buffers come back");
    }
}
