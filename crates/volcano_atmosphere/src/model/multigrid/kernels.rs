//! The sweeps of the multigrid V-cycle ([`super`]): red-black Gauss–Seidel smoothing, the
//! residual, its restriction to the coarse grid and the bilinear prolongation, each
//! monomorphised for the plain and the face-weighted 5-point stencil; rows in parallel on
//! large grids (fixed bands, results independent of the thread count).

use volcano_core::parallel;

use super::avx2;
use super::{Faces, OMEGA};

/// The 5-point operator of one level: the plain Laplacian or the face-weighted one. Each
/// sweep is monomorphised for both, so the inner loops carry no per-cell branch on the kind.
pub(super) trait Stencil: Copy + Sync {
    /// `h² ∇·(a∇φ)` at cell `k` (its west/east/south/north neighbours given).
    fn apply(self, phi: &[f64], k: usize, left: usize, right: usize, down: usize, up: usize) -> f64;
    /// The Gauss–Seidel update of cell `k` (east and north neighbours `right`, `up`) from its
    /// neighbours' values `[west, east, north, south]` and `h² rhs`; `None` for a cell with
    /// every face closed (left alone).
    fn relax(self, k: usize, right: usize, up: usize, nb: [f64; 4], h2r: f64) -> Option<f64>;
}

/// All faces open: the plain 5-point Laplacian.
#[derive(Clone, Copy)]
pub(super) struct Plain;

impl Stencil for Plain {
    #[inline(always)]
    fn apply(self, phi: &[f64], k: usize, left: usize, right: usize, down: usize, up: usize) -> f64 {
        phi[left] + phi[right] + phi[up] + phi[down] - 4.0 * phi[k]
    }
    #[inline(always)]
    fn relax(self, _: usize, _: usize, _: usize, [pl, pr, pu, pd]: [f64; 4], h2r: f64) -> Option<f64> {
        Some(0.25 * (pl + pr + pu + pd - h2r))
    }
}

impl Stencil for &Faces {
    #[inline(always)]
    fn apply(self, phi: &[f64], k: usize, left: usize, right: usize, down: usize, up: usize) -> f64 {
        let c = phi[k];
        let (aw, ae, as_, an) = self.around(k, right, up);
        aw * (phi[left] - c) + ae * (phi[right] - c) + as_ * (phi[down] - c) + an * (phi[up] - c)
    }
    #[inline(always)]
    fn relax(self, k: usize, right: usize, up: usize, [pl, pr, pu, pd]: [f64; 4], h2r: f64) -> Option<f64> {
        let (aw, ae, as_, an) = self.around(k, right, up);
        let diag = aw + ae + as_ + an;
        let num = aw * pl + ae * pr + as_ * pd + an * pu - h2r;
        // Dividing by 4 and multiplying by 0.25 round the same exact value: every face open
        // (most cells) skips the division.
        if diag == 4.0 { Some(num * 0.25) } else { (diag > 0.0).then(|| num / diag) }
    }
}

/// Runs `body` with the level's stencil as a concrete type.
macro_rules! with_stencil {
    ($faces:expr, |$s:ident| $body:expr) => {
        match $faces {
            None => {
                let $s = Plain;
                $body
            }
            Some(f) => {
                let $s = f;
                $body
            }
        }
    };
}

/// Grids at least this wide run their sweeps with rows in parallel. Below, a sweep is a few
/// tens of microseconds, no more than handing its bands to the pool costs (and the layers'
/// solves already run in parallel); the bands do not change the result.
const PARALLEL_FROM: usize = 256;

/// A raw pointer that may be shared between the threads of one red-black colour pass.
#[derive(Clone, Copy)]
struct SharedRows(*mut f64);
// SAFETY: used only in `rb_gauss_seidel`, where the threads of one pass write disjoint rows
// of one colour and read only cells that no thread writes in that pass (see there).
unsafe impl Send for SharedRows {}
unsafe impl Sync for SharedRows {}

/// One red-black Gauss–Seidel sweep of `∇·(a∇φ) = rhs` (5-point stencil, toroidal; `a = 1`
/// without face weights; a cell with all faces closed is skipped): every red cell
/// (`(i + j)` even) from the old black ones, then every black cell from the new red ones.
///
/// The two colours run in one pass over the rows, black lagging one row behind red, so each
/// row is read while it is in cache: a black cell needs only the red cells of its own and the
/// two neighbouring rows, so black row `j − 1` is final once red row `j` is, while red row `j`
/// still sees the old black rows `j ± 1`. Every cell gets the same inputs as in two separate
/// colour passes (bit for bit). Large grids cut the rows into fixed bands run in parallel;
/// the black rows at the ends of the bands (whose red neighbours belong to another band) are
/// updated in a second parallel pass after every red row. The result does not depend on the
/// thread count.
/// The kernels' precondition on a level of `n × n` cells, checked in every build because the
/// unsafe loops rely on it: `n` is a power of two (the torus wraps with the mask `n − 1`), so
/// even (a cell's four neighbours have the other colour, also across the seam, which is what
/// lets the bands relax one colour concurrently) and, from 4 up, a whole number of the AVX2
/// loops' 4-wide lanes.
fn check_rows(n: usize) {
    assert!(
        n.is_power_of_two() && n >= 4,
        "multigrid rows must be a power of two of at least 4 cells, got {n}"
    );
}

pub(super) fn rb_gauss_seidel(n: usize, h2: f64, faces: Option<&Faces>, phi: &mut [f64], rhs: &[f64]) {
    rb_gauss_seidel_on(n, h2, faces, phi, rhs, avx2::available());
}

/// [`rb_gauss_seidel`] with or without the AVX2 row loops (`avx2` only if
/// [`avx2::available`]); the same bits either way.
pub(super) fn rb_gauss_seidel_on(
    n: usize,
    h2: f64,
    faces: Option<&Faces>,
    phi: &mut [f64],
    rhs: &[f64],
    avx2: bool,
) {
    assert!(!avx2 || avx2::cpu_has_avx2(), "AVX2 loops on a CPU without AVX2");
    check_rows(n);
    with_stencil!(faces, |s| rb_gauss_seidel_with(n, h2, s, faces, phi, rhs, avx2))
}

fn rb_gauss_seidel_with<S: Stencil>(
    n: usize,
    h2: f64,
    s: S,
    faces: Option<&Faces>,
    phi: &mut [f64],
    rhs: &[f64],
    avx2: bool,
) {
    assert_eq!(phi.len(), n * n);
    assert_eq!(rhs.len(), n * n);
    let mask = n - 1;
    let base = SharedRows(phi.as_mut_ptr());
    // Relaxes the cells of colour `colour` (0 red, 1 black) in row `j`; `own_rows`: rows
    // `j ± 1` belong to the calling band too (no other thread touches them in this pass),
    // so the row's interior may take the AVX2 loop.
    let row_pass = |j: usize, colour: usize, own_rows: bool| {
        let p = base;
        let row = j * n;
        let up = ((j + 1) & mask) * n;
        let down = ((j + n - 1) & mask) * n;
        let first = (colour + j) & 1;
        // Cells `skip_from..skip_to` were relaxed by the AVX2 loop.
        let (skip_from, skip_to) =
            if avx2 && own_rows && avx2::interior_end(n) > 4 { (4, avx2::interior_end(n)) } else { (n, n) };
        #[cfg(target_arch = "x86_64")]
        if skip_from < skip_to {
            // SAFETY: `avx2` is only true when the CPU has AVX2 (asserted above). The row
            // pointers are inside `phi` and `rhs` (n² values each, asserted); the row `j` and
            // the rows `j ± 1` belong to the calling band (`own_rows`), which no other thread
            // reads or writes during this pass, and `rhs` is not written.
            unsafe {
                let ptrs = avx2::RowPtrs {
                    row: p.0.add(row),
                    up: p.0.add(up),
                    down: p.0.add(down),
                    rhs: rhs.as_ptr().add(row),
                    row_at: row,
                    up_at: up,
                };
                match faces {
                    None => avx2::relax_row_plain(n, h2, first, ptrs),
                    Some(f) => avx2::relax_row_faces(n, h2, first, ptrs, f),
                }
            }
        }
        let mut i = first;
        while i < n {
            if i >= skip_from && i < skip_to {
                // Past the vectorised cells, same colour (`skip_to` is even).
                i = skip_to + (i & 1);
                continue;
            }
            let left = (i + n - 1) & mask;
            let right = (i + 1) & mask;
            // SAFETY: all indices are < n² (masked; `rhs` has n² values, asserted), so inside
            // `phi` and `rhs`. A cell's four neighbours have the other colour (the ±1 changes
            // the parity also across the torus seam because n is even). In the first pass a
            // band writes the red cells of its rows and the black cells of its inner rows
            // (not its first and last); it reads black cells of its rows and of the last row
            // of the band before and the first row of the band after — rows no band writes
            // black cells of in this pass — and red cells of its own rows only. In the second
            // pass each band writes the black cells of its first and last rows and reads only
            // red cells, which no one writes any more. So no cell is read and written
            // concurrently.
            unsafe {
                let (pl, pr) = (*p.0.add(row + left), *p.0.add(row + right));
                let (pu, pd) = (*p.0.add(up + i), *p.0.add(down + i));
                let h2r = h2 * *rhs.get_unchecked(row + i);
                if let Some(x) = s.relax(row + i, row + right, up + i, [pl, pr, pu, pd], h2r) {
                    let old = *p.0.add(row + i);
                    *p.0.add(row + i) = old + OMEGA * (x - old);
                }
            }
            i += 2;
        }
    };
    // Red rows of a band, black rows lagging one behind, except the band's first and last.
    let inner = |rows: std::ops::Range<usize>| {
        for j in rows.clone() {
            row_pass(j, 0, j > rows.start && j + 1 < rows.end);
            if j >= rows.start + 2 {
                row_pass(j - 1, 1, true);
            }
        }
    };
    // Black cells of a band's first and last rows (their neighbour rows belong to other
    // bands: the scalar loop, which reads only the red cells there).
    let ends = |rows: std::ops::Range<usize>| {
        row_pass(rows.start, 1, false);
        if rows.end - rows.start >= 2 {
            row_pass(rows.end - 1, 1, false);
        }
    };
    if n >= PARALLEL_FROM {
        parallel::Bands::DEFAULT.map_ranges(n, inner);
        parallel::Bands::DEFAULT.map_ranges(n, ends);
    } else {
        inner(0..n);
        ends(0..n);
    }
}

/// Sum of the squared residual `rhs − ∇·(a∇φ)` over the grid, never stored: each fixed band
/// of rows sums its cells in a fixed order while computing them (bands in parallel on large grids),
/// and the band sums are added in band order, so the result does not depend on the thread
/// count.
pub(super) fn residual_sum_sq(n: usize, h2: f64, faces: Option<&Faces>, phi: &[f64], rhs: &[f64]) -> f64 {
    residual_sum_sq_on(n, h2, faces, phi, rhs, avx2::available())
}

/// [`residual_sum_sq`] with or without the AVX2 row loop (`avx2` only if
/// [`avx2::available`]); the same bits either way.
pub(super) fn residual_sum_sq_on(
    n: usize,
    h2: f64,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    avx2: bool,
) -> f64 {
    assert!(!avx2 || avx2::cpu_has_avx2(), "AVX2 loops on a CPU without AVX2");
    check_rows(n);
    with_stencil!(faces, |s| residual_sum_sq_with(n, h2, s, faces, phi, rhs, avx2))
}

fn residual_sum_sq_with<S: Stencil>(
    n: usize,
    h2: f64,
    s: S,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    avx2: bool,
) -> f64 {
    assert_eq!(phi.len(), n * n);
    assert_eq!(rhs.len(), n * n);
    let mask = n - 1;
    let inv = 1.0 / h2;
    // Four running sums (cells i mod 4; n is a power of two ≥ 4, checked), so the additions
    // do not wait on each other.
    // Cells `skip_from..skip_to` of each row are summed by the AVX2 loop (the same lanes in
    // the same order).
    let (skip_from, skip_to) = if avx2 { (4, avx2::interior_end(n)) } else { (4, 4) };
    let band = |rows: std::ops::Range<usize>| {
        let mut sum = [0.0f64; 4];
        for j in rows {
            let row = j * n;
            let up = ((j + 1) & mask) * n;
            let down = ((j + n - 1) & mask) * n;
            for i0 in (0..n).step_by(4) {
                if i0 >= skip_from && i0 < skip_to {
                    if i0 == skip_from {
                        #[cfg(target_arch = "x86_64")]
                        // SAFETY: `avx2` is only true when the CPU has AVX2 (asserted above);
                        // `phi` and `rhs` have n² values (asserted), j < n.
                        unsafe {
                            avx2::residual_row_sq(n, inv, faces, phi, rhs, j, &mut sum)
                        };
                    }
                    continue;
                }
                for (lane, acc) in sum.iter_mut().enumerate() {
                    let i = i0 + lane;
                    let left = (i + n - 1) & mask;
                    let right = (i + 1) & mask;
                    let lap = s.apply(phi, row + i, row + left, row + right, down + i, up + i) * inv;
                    let r = rhs[row + i] - lap;
                    *acc += r * r;
                }
            }
        }
        (sum[0] + sum[1]) + (sum[2] + sum[3])
    };
    let bands = parallel::Bands::DEFAULT;
    if n >= PARALLEL_FROM {
        bands.map_ranges(n, band).into_iter().fold(0.0, |a, b| a + b)
    } else {
        (0..bands.count(n)).map(|b| band(bands.range(b, n))).fold(0.0, |a, b| a + b)
    }
}

/// Residual `rhs − ∇·(a∇φ)` of the fine (n × n) grid restricted to the coarse one (mean of
/// the four children), computed on the fly (coarse rows in parallel on large grids).
pub(super) fn restrict_residual(
    n: usize,
    h2: f64,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    coarse: &mut [f64],
) {
    restrict_residual_on(n, h2, faces, phi, rhs, coarse, avx2::available());
}

/// [`restrict_residual`] with or without the AVX2 row loop (`avx2` only if
/// [`avx2::available`]); the same bits either way.
pub(super) fn restrict_residual_on(
    n: usize,
    h2: f64,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    coarse: &mut [f64],
    avx2: bool,
) {
    assert!(!avx2 || avx2::cpu_has_avx2(), "AVX2 loops on a CPU without AVX2");
    check_rows(n);
    assert_eq!(phi.len(), n * n);
    assert_eq!(rhs.len(), n * n);
    assert_eq!(coarse.len(), n * n / 4);
    with_stencil!(faces, |s| restrict_residual_with(n, h2, s, faces, phi, rhs, coarse, avx2))
}

#[allow(clippy::too_many_arguments)]
fn restrict_residual_with<S: Stencil>(
    n: usize,
    h2: f64,
    s: S,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    coarse: &mut [f64],
    avx2: bool,
) {
    let m = n / 2;
    let mask = n - 1;
    let inv = 1.0 / h2;
    let r = |i: usize, j: usize| {
        let row = j * n;
        let up = ((j + 1) & mask) * n;
        let down = ((j + n - 1) & mask) * n;
        let left = (i + n - 1) & mask;
        let right = (i + 1) & mask;
        rhs[row + i] - s.apply(phi, row + i, row + left, row + right, down + i, up + i) * inv
    };
    // Coarse cells `skip_from..skip_to` of each row are computed by the AVX2 loop (the same
    // bits).
    let (skip_from, skip_to) = if avx2 && n >= 16 { (2, m - 2) } else { (m, m) };
    let row_pass = |(jc, out): (usize, &mut [f64])| {
        #[cfg(target_arch = "x86_64")]
        if skip_from < skip_to {
            // SAFETY: `avx2` is only true when the CPU has AVX2 (asserted above); jc < m.
            unsafe { avx2::restrict_row(n, inv, faces, phi, rhs, jc, out) };
        }
        for (ic, c) in out.iter_mut().enumerate() {
            if ic >= skip_from && ic < skip_to {
                continue;
            }
            let (i, j) = (2 * ic, 2 * jc);
            *c = 0.25 * (r(i, j) + r(i + 1, j) + r(i, j + 1) + r(i + 1, j + 1));
        }
    };
    if n >= PARALLEL_FROM {
        parallel::for_each_row(coarse, m, |j, row| row_pass((j, row)));
    } else {
        coarse.chunks_mut(m).enumerate().for_each(row_pass);
    }
}

/// Coarse (m × m) correction added to fine (2m × 2m) by cell-centred bilinear interpolation;
/// with face weights, only from coarse cells with an open face (weights renormalised), so a
/// coarse cell inside the terrain (whose value means nothing) does not drag its neighbours.
pub(super) fn prolong_add(m: usize, coarse: &[f64], faces: Option<&Faces>, fine: &mut [f64]) {
    prolong_add_on(m, coarse, faces, fine, avx2::available());
}

/// [`prolong_add`] with or without the AVX2 row loop (`avx2` only if [`avx2::available`]);
/// the same bits either way.
pub(super) fn prolong_add_on(m: usize, coarse: &[f64], faces: Option<&Faces>, fine: &mut [f64], avx2: bool) {
    assert!(!avx2 || avx2::cpu_has_avx2(), "AVX2 loops on a CPU without AVX2");
    check_rows(m);
    let n = 2 * m;
    let mask = m - 1;
    // Fine cells `skip_from..skip_to` of each row are computed by the AVX2 loop.
    let (skip_from, skip_to) = if avx2 && m >= 8 { (4, n - 4) } else { (n, n) };
    let row_pass = |(jf, out): (usize, &mut [f64])| {
        let jc = jf / 2;
        let jn = if jf & 1 == 0 { (jc + m - 1) & mask } else { (jc + 1) & mask };
        #[cfg(target_arch = "x86_64")]
        if skip_from < skip_to {
            // SAFETY: `avx2` is only true when the CPU has AVX2 (asserted above).
            unsafe { avx2::prolong_row(m, coarse, faces, jc, jn, out) };
        }
        for (i_f, x) in out.iter_mut().enumerate() {
            if i_f >= skip_from && i_f < skip_to {
                continue;
            }
            let ic = i_f / 2;
            let in_ = if i_f & 1 == 0 { (ic + m - 1) & mask } else { (ic + 1) & mask };
            let (k, kx, ky, kxy) = (jc * m + ic, jc * m + in_, jn * m + ic, jn * m + in_);
            match faces {
                None => {
                    *x += 0.5625 * coarse[k] + 0.1875 * (coarse[kx] + coarse[ky]) + 0.0625 * coarse[kxy];
                }
                Some(f) => {
                    let (w, wx, wy, wxy) =
                        (0.5625 * f.live[k], 0.1875 * f.live[kx], 0.1875 * f.live[ky], 0.0625 * f.live[kxy]);
                    let sum = w + wx + wy + wxy;
                    if sum > 0.0 {
                        *x += (w * coarse[k] + wx * coarse[kx] + wy * coarse[ky] + wxy * coarse[kxy]) / sum;
                    }
                }
            }
        }
    };
    if n >= PARALLEL_FROM {
        parallel::for_each_row(fine, n, |j, row| row_pass((j, row)));
    } else {
        fine.chunks_mut(n).enumerate().for_each(row_pass);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A level whose rows are not a power of two would break the red-black parity the unsafe
    /// loops' race freedom rests on: refused in every build, before any of them runs.
    #[test]
    #[should_panic(expected = "power of two of at least 4 cells, got 12")]
    fn rows_that_are_not_a_power_of_two_are_refused() {
        let (mut phi, rhs) = (vec![0.0; 144], vec![0.0; 144]);
        rb_gauss_seidel_on(12, 1.0, None, &mut phi, &rhs, false);
    }
}
