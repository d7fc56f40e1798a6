//! Copies of the atmosphere's state for a weather step in flight, into reused buffers: the
//! main thread pays one copy of the fields per step instead of fresh allocations (about 55 MB
//! at 512² × 3 layers, 21 MB at 256² × 5), and swaps the result back in without copying. The
//! copy is memory-bound and is the largest main-thread cost of a weather tick, so its pieces
//! are spread over a few tasks of the compute pool ([`Copies`]).

use volcano_core::{Grid2, parallel};

use crate::model::fields::{AtmosphereState, Ground, LayerFields};

/// Tasks the copies are cut into: enough for the memory bandwidth of two to four cores, few
/// enough that spawning them costs nothing beside megabytes of copying.
const COPY_TASKS: usize = 4;

/// Whether `dst` can take `src`'s values in place.
fn same_shape<T: Copy, U: Copy>(dst: &Grid2<T>, src: &Grid2<U>) -> bool {
    dst.nx() == src.nx() && dst.ny() == src.ny() && dst.cell() == src.cell() && dst.origin() == src.origin()
}

/// The grid copies of one snapshot, gathered first and then run together: as raw bytes, cut
/// into [`COPY_TASKS`] runs of equal length on the current pool (a plain copy is the same
/// bytes whichever task does it, so the snapshot does not depend on the threads).
#[derive(Default)]
struct Copies<'a> {
    pieces: Vec<(&'a mut [u8], &'a [u8])>,
}

impl<'a> Copies<'a> {
    /// `dst ← src`, reusing `dst`'s buffer when the shapes match (queued), else a clone (now).
    fn grid<T: bytemuck::Pod>(&mut self, dst: &'a mut Grid2<T>, src: &'a Grid2<T>) {
        if same_shape(dst, src) {
            self.pieces.push((bytemuck::cast_slice_mut(dst.data_mut()), bytemuck::cast_slice(src.data())));
        } else {
            *dst = src.clone();
        }
    }

    /// Runs every queued copy.
    fn run(self) {
        let total: usize = self.pieces.iter().map(|p| p.1.len()).sum();
        let per = total.div_ceil(COPY_TASKS).max(1);
        let mut tasks: Vec<Vec<(&mut [u8], &[u8])>> = vec![Vec::new()];
        let mut room = per;
        for (mut dst, mut src) in self.pieces {
            while !src.is_empty() {
                if room == 0 {
                    tasks.push(Vec::new());
                    room = per;
                }
                let n = room.min(src.len());
                let (d0, d1) = std::mem::take(&mut dst).split_at_mut(n);
                let (s0, s1) = src.split_at(n);
                if let Some(t) = tasks.last_mut() {
                    t.push((d0, s0));
                }
                (dst, src, room) = (d1, s1, room - n);
            }
        }
        parallel::par_map(tasks, |_, list| {
            for (d, s) in list {
                d.copy_from_slice(s);
            }
        });
    }
}

/// `dst ← src` for one layer. Destructures every field, so a new field fails to compile here
/// until it is copied.
fn copy_layer<'a>(dst: &'a mut LayerFields, src: &'a LayerFields, copies: &mut Copies<'a>) {
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
    dst.t_ref = *t_ref;
    dst.wind = *wind;
    dst.wind_relaxation_s = *wind_relaxation_s;
    dst.entraining.clone_from(entraining);
    copies.grid(&mut dst.t, t);
    copies.grid(&mut dst.h, h);
    copies.grid(&mut dst.w, w);
    copies.grid(&mut dst.ash, ash);
    copies.grid(&mut dst.u, u);
    copies.grid(&mut dst.v, v);
    copies.grid(&mut dst.p, p);
    copies.grid(&mut dst.c, c);
    copies.grid(&mut dst.up, up);
    copies.grid(&mut dst.d, d);
    copies.grid(&mut dst.sigma, sigma);
}

/// `dst ← src` for the ground, except the fallen ash, which starts at zero in the copy: the
/// components keep the ash fallen before the step (the coupling collects it), and the ash
/// fallen during the step is added back when the result is applied ([`merge_ground`]).
fn copy_ground_without_ash<'a>(dst: &'a mut Ground, src: &'a Ground, copies: &mut Copies<'a>) {
    let Ground { height, cover, t, water, sunlit, sunlit_for, lowest, ash } = src;
    dst.sunlit_for = *sunlit_for;
    dst.lowest.clone_from(lowest);
    // Land cover is an enum (not plain bytes) and one byte a cell: copied here.
    if same_shape(&dst.cover, cover) {
        dst.cover.data_mut().copy_from_slice(cover.data());
    } else {
        dst.cover = cover.clone();
    }
    if !same_shape(&dst.ash, ash) {
        dst.ash = ash.clone();
    }
    dst.ash.data_mut().fill(0.0);
    copies.grid(&mut dst.height, height);
    copies.grid(&mut dst.t, t);
    copies.grid(&mut dst.water, water);
    copies.grid(&mut dst.sunlit, sunlit);
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
    let mut copies = Copies::default();
    for (dst, src) in state.layers.iter_mut().zip(layers) {
        copy_layer(dst, src, &mut copies);
    }
    copy_ground_without_ash(&mut state.ground, ground, &mut copies);
    copies.run();
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
    fn snapshot_into_spare_buffers_of_another_grid_equals_a_clone_except_the_ash() {
        let a = Scenario::builtin("island").unwrap().build(Some(32)).unwrap();
        let b = Scenario::builtin("island").unwrap().build(Some(16)).unwrap();
        let refs: Vec<&LayerFields> = a.layers.iter().collect();
        let template = AtmosphereState { layers: Vec::new(), ground: Ground::default(), ..a.clone() };
        let snap = snapshot(Some(b), &refs, &a.ground, template);
        assert_eq!(snap.layers, a.layers);
        let mut want = a.ground.clone();
        want.ash.data_mut().fill(0.0);
        assert_eq!(snap.ground, want);
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
