//! Row-band parallelism for the grid passes of the flow and the surface: a pass hands each
//! band of [`BAND_ROWS`] rows its own output slices and runs the bands on Bevy's compute task
//! pool. The bands are fixed (not a function of the thread count) and their results come back
//! in band order, so reductions (sums, maxima) and therefore the simulation are bit-identical
//! on any machine.

/// Rows per band: 512 rows → 16 bands, enough to balance two to eight cores.
pub const BAND_ROWS: usize = 32;

/// Runs `f(band_index, item)` for every per-band `item` (typically a tuple of `&mut` row
/// slices) on the compute task pool, returning the results in band order. Runs inline when
/// there is one band.
pub fn par_bands<T: Send, R: Send + 'static>(items: Vec<T>, f: impl Fn(usize, T) -> R + Sync) -> Vec<R> {
    if items.len() <= 1 {
        return items.into_iter().enumerate().map(|(b, t)| f(b, t)).collect();
    }
    let pool = bevy::tasks::ComputeTaskPool::get_or_init(bevy::tasks::TaskPool::default);
    let f = &f;
    pool.scope(|scope| {
        for (b, item) in items.into_iter().enumerate() {
            scope.spawn(async move { f(b, item) });
        }
    })
}

/// The row range of band `b` in a grid of `ny` rows.
pub fn band_range(b: usize, ny: usize) -> std::ops::Range<usize> {
    (b * BAND_ROWS).min(ny)..((b + 1) * BAND_ROWS).min(ny)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_cover_the_rows_once_in_order() {
        let (nx, ny) = (3, 100);
        let mut out = vec![0usize; nx * ny];
        let items: Vec<&mut [usize]> = out.chunks_mut(BAND_ROWS * nx).collect();
        let firsts = par_bands(items, |b, rows| {
            let r = band_range(b, ny);
            for (k, v) in rows.iter_mut().enumerate() {
                *v = r.start * nx + k;
            }
            r.start
        });
        assert_eq!(firsts, vec![0, 32, 64, 96]);
        assert!(out.iter().enumerate().all(|(k, v)| *v == k));
    }
}
