//! Row bands of the grid passes of the flow and the surface: a pass hands each band of
//! [`BAND_ROWS`] rows its own output slices (and per-band scratch) and runs the bands with
//! [`volcano_core::parallel::par_map`], the helper every domain shares, on Bevy's compute task
//! pool. The bands are fixed (not a function of the thread count) and their results come back
//! in band order, so reductions (sums, maxima) and therefore the simulation are bit-identical
//! on any machine.

use volcano_core::parallel::Bands;

/// Rows per band: 512 rows → 16 bands, enough to balance two to eight cores (the default bands
/// of [`volcano_core::parallel`]).
pub const BAND_ROWS: usize = volcano_core::parallel::BAND_ROWS;

/// The row range of band `b` in a grid of `ny` rows.
pub fn band_range(b: usize, ny: usize) -> std::ops::Range<usize> {
    Bands::of(BAND_ROWS).range(b, ny)
}

/// True if this CPU runs the AVX2 copies of the row loops (`flow_rows`,
/// `surface_rows`); they give the same bits as the baseline copies.
pub fn use_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Defines a row-loop entry point `$name` with the given arguments and a trailing
/// `avx2: bool` (from [`use_avx2`]) that runs `$imp` (an `#[inline(always)]` function of the
/// same arguments): in a copy compiled for AVX2 when `avx2` is true, else in the baseline
/// copy. Both copies evaluate the same IEEE operations in the same order (Rust never fuses
/// or reassociates floating-point operations), so they give the same bits.
macro_rules! avx2_dispatch {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? => $imp:path
    ) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty,)* avx2: bool) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            #[target_feature(enable = "avx2")]
            fn avx2_copy($($arg: $ty),*) $(-> $ret)? {
                $imp($($arg),*)
            }
            #[cfg(target_arch = "x86_64")]
            if avx2 {
                // SAFETY: `avx2` comes from `use_avx2`, which checked that this CPU has AVX2,
                // the only feature `avx2_copy` is compiled for.
                return unsafe { avx2_copy($($arg),*) };
            }
            let _ = avx2;
            $imp($($arg),*)
        }
    };
}
pub(crate) use avx2_dispatch;

#[cfg(test)]
mod tests {
    use super::*;
    use volcano_core::parallel::par_map;

    #[test]
    fn bands_cover_the_rows_once_in_order() {
        let (nx, ny) = (3, 100);
        let mut out = vec![0usize; nx * ny];
        let items: Vec<&mut [usize]> = out.chunks_mut(BAND_ROWS * nx).collect();
        let firsts = par_map(items, |b, rows| {
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
