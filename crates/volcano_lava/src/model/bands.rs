//! Row bands of the grid passes of the flow and the surface: a pass hands each band of
//! [`BAND_ROWS`] rows its own output slices (and per-band scratch) and runs the bands with
//! [`volcano_core::parallel::par_map`], the helper every domain shares, on Bevy's compute task
//! pool. The bands are fixed (not a function of the thread count) and their results come back
//! in band order, so reductions (sums, maxima) and therefore the simulation are bit-identical
//! on any machine. The row loops run in the copy that [`simd`] picks.

use std::sync::atomic::{AtomicU8, Ordering};

use volcano_core::parallel::Bands;

/// Rows per band: 512 rows → 16 bands, enough to balance two to eight cores (the default bands
/// of [`volcano_core::parallel`]).
pub const BAND_ROWS: usize = volcano_core::parallel::BAND_ROWS;

/// The row range of band `b` in a grid of `ny` rows.
pub fn band_range(b: usize, ny: usize) -> std::ops::Range<usize> {
    Bands::of(BAND_ROWS).range(b, ny)
}

/// Which compiled copy of the row loops (`flow_rows`, `surface_rows`) runs; all give the
/// same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
#[repr(u8)]
pub enum Simd {
    /// The baseline copy (SSE2 on x86-64).
    Baseline,
    /// The copy compiled for AVX2 (4 f64 per instruction).
    Avx2,
    /// The copy compiled for AVX-512F (8 f64 per instruction; 20–26 % faster than AVX2 at
    /// 256² on one thread of an AMD EPYC with AVX-512).
    Avx512,
}

/// The best copy of the row loops this CPU runs (checked at run time), at most the
/// [`limit_simd`] set.
pub fn simd() -> Simd {
    let detected = detected();
    match SIMD_LIMIT.load(Ordering::Relaxed) {
        0 => Simd::Baseline,
        1 => detected.min(Simd::Avx2),
        _ => detected,
    }
}

/// The best copy this CPU can run.
fn detected() -> Simd {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            return Simd::Avx512;
        }
        if std::arch::is_x86_feature_detected!("avx2") {
            return Simd::Avx2;
        }
    }
    Simd::Baseline
}

/// The highest copy [`simd`] may pick, process-wide (0 baseline, 1 AVX2, 2 AVX-512F).
static SIMD_LIMIT: AtomicU8 = AtomicU8::new(2);

/// Limits the row loops of every lava field in the process to `limit` or below (the CPU's own
/// support still applies: a limit above it changes nothing). All copies give the same bits, so
/// this only changes the speed; it lets a test or a benchmark run the baseline on a CPU with
/// AVX2 or AVX-512.
pub fn limit_simd(limit: Simd) {
    SIMD_LIMIT.store(limit as u8, Ordering::Relaxed);
}

/// Defines a row-loop entry point `$name` with the given arguments and a trailing
/// `simd: Simd` (from [`simd`]) that runs `$imp` (an `#[inline(always)]` function of the
/// same arguments) in the copy compiled for that instruction set. All copies evaluate the
/// same IEEE operations in the same order (Rust never fuses or reassociates floating-point
/// operations), so they give the same bits.
macro_rules! simd_dispatch {
    (
        $(#[$meta:meta])*
        $vis:vis fn $name:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)? => $imp:path
    ) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty,)* simd: $crate::model::bands::Simd) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                fn avx2_copy($($arg: $ty),*) $(-> $ret)? {
                    $imp($($arg),*)
                }
                #[target_feature(enable = "avx512f")]
                fn avx512_copy($($arg: $ty),*) $(-> $ret)? {
                    $imp($($arg),*)
                }
                match simd {
                    // SAFETY: `Simd::Avx512` comes from `simd`, which checked that this CPU
                    // has AVX-512F, the feature `avx512_copy` is compiled for.
                    $crate::model::bands::Simd::Avx512 => return unsafe { avx512_copy($($arg),*) },
                    // SAFETY: `Simd::Avx2` comes from `simd`, which checked that this CPU has
                    // AVX2, the only feature `avx2_copy` is compiled for.
                    $crate::model::bands::Simd::Avx2 => return unsafe { avx2_copy($($arg),*) },
                    $crate::model::bands::Simd::Baseline => {}
                }
            }
            let _ = simd;
            $imp($($arg),*)
        }
    };
}
pub(crate) use simd_dispatch;

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
