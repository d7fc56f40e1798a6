//! Copies of the atmosphere's state for a weather step in flight, into reused buffers: one copy
//! of the fields per step instead of fresh allocations (about 55 MB at 512² × 3 layers, 21 MB
//! at 256² × 5), and the result swapped back in without copying. The layers, nearly all of the
//! bytes, are copied by the worker from the shared fields ([`super::shared`]), off the main
//! thread; the ground (under 10 %) on the main thread as the step starts.

use volcano_core::Grid2;

use crate::model::fields::{Ground, LayerFields};

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
fn copy_layer(dst: &mut LayerFields, src: &LayerFields) {
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

/// Copies of `layers`, in `spare`'s buffers when the layer count matches.
pub(crate) fn snapshot_layers(spare: Option<Vec<LayerFields>>, layers: &[&LayerFields]) -> Vec<LayerFields> {
    match spare {
        Some(mut s) if s.len() == layers.len() => {
            for (dst, src) in s.iter_mut().zip(layers) {
                copy_layer(dst, src);
            }
            s
        }
        _ => layers.iter().map(|l| (*l).clone()).collect(),
    }
}

/// A copy of `ground` in `spare`'s buffers, except the fallen ash, which starts at zero in the
/// copy: the components keep the ash fallen before the step (the coupling collects it), and
/// the ash fallen during the step is added back when the result is applied ([`merge_ground`]).
pub(crate) fn snapshot_ground(spare: Option<Ground>, src: &Ground) -> Ground {
    let Some(mut dst) = spare else {
        let mut g = src.clone();
        g.ash.data_mut().fill(0.0);
        return g;
    };
    let Ground { height, cover, t, water, sunlit, sunlit_for, lowest, ash } = src;
    copy_grid(&mut dst.height, height);
    copy_grid(&mut dst.cover, cover);
    copy_grid(&mut dst.t, t);
    copy_grid(&mut dst.water, water);
    copy_grid(&mut dst.sunlit, sunlit);
    dst.sunlit_for = *sunlit_for;
    dst.lowest.clone_from(lowest);
    if dst.ash.data().len() != ash.data().len() {
        dst.ash = ash.clone();
    }
    dst.ash.data_mut().fill(0.0);
    dst
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::scenario::WeatherScenario;

    #[test]
    fn snapshot_into_spare_buffers_equals_a_clone_except_the_ash() {
        let a = WeatherScenario::builtin("island").unwrap().build(Some(16)).unwrap();
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
        assert_eq!(snapshot_layers(Some(b.layers), &refs), src.layers);
        let mut want = src.ground.clone();
        want.ash.data_mut().fill(0.0);
        assert_eq!(snapshot_ground(Some(b.ground), &src.ground), want);
    }

    #[test]
    fn snapshot_into_spare_buffers_of_another_grid_equals_a_clone_except_the_ash() {
        let a = WeatherScenario::builtin("island").unwrap().build(Some(32)).unwrap();
        let b = WeatherScenario::builtin("island").unwrap().build(Some(16)).unwrap();
        let refs: Vec<&LayerFields> = a.layers.iter().collect();
        assert_eq!(snapshot_layers(Some(b.layers), &refs), a.layers);
        assert_eq!(snapshot_layers(Some(Vec::new()), &refs), a.layers);
        let mut want = a.ground.clone();
        want.ash.data_mut().fill(0.0);
        assert_eq!(snapshot_ground(Some(b.ground), &a.ground), want);
        assert_eq!(snapshot_ground(None, &a.ground), want);
    }

    #[test]
    fn merging_keeps_uncollected_ash_and_adds_the_fallen() {
        let s = WeatherScenario::builtin("island").unwrap().build(Some(16)).unwrap();
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
