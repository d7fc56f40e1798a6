//! AVX2 copies of the multigrid's row loops ([`super::kernels`]), chosen at run time
//! ([`available`]). They give the same bits as the scalar loops: the same operations in the
//! same order on each cell (no fused multiply-add), four cells per instruction.
//!
//! A red-black row is relaxed four neighbouring cells at a time, two of the colour and two
//! not: all four are computed from the row as it is and only the colour's lanes are stored
//! (a blend). A colour cell reads only cells of the other colour, which this pass does not
//! change, so storing the chunks in place in order gives each colour cell the inputs of the
//! scalar sweep; the other lanes' results are discarded. The west and east neighbours are
//! shuffled from the chunks as loaded, not loaded again across the last store. The residual's four running sums
//! (cells `i mod 4`) are one vector.
//!
//! Only the row's interior cells `4..n−4` are vectorised; the four cells at each end (whose
//! neighbours wrap round the torus) stay with the scalar loop.

#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

use std::sync::atomic::{AtomicBool, Ordering};

use super::{Faces, OMEGA};

/// Set by [`super::use_simd`]`(false)`: the scalar loops even on a CPU with AVX2.
static SCALAR_ONLY: AtomicBool = AtomicBool::new(false);

/// Whether the multigrid uses its AVX2 row loops where the CPU has them (the default) or
/// only the scalar loops; the results are the same bits either way.
pub(super) fn set_enabled(enabled: bool) {
    SCALAR_ONLY.store(!enabled, Ordering::Relaxed);
}

/// True if the AVX2 row loops are to be used: the CPU has AVX2 and they are not switched off.
pub(super) fn available() -> bool {
    cpu_has_avx2() && !SCALAR_ONLY.load(Ordering::Relaxed)
}

/// True if this CPU has AVX2 (checked once; the answer is cached by `std`).
pub(super) fn cpu_has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// The first cell past the vectorised interior `4..end` of a row of `n` cells.
#[inline(always)]
pub(super) fn interior_end(n: usize) -> usize {
    n.saturating_sub(4).max(4)
}

/// Pointers to one row of a level and its neighbours (`n` cells each).
#[derive(Clone, Copy)]
pub(super) struct RowPtrs {
    /// The row being relaxed (read and written).
    pub row: *mut f64,
    /// The row above (`j + 1`), read.
    pub up: *const f64,
    /// The row below (`j − 1`), read.
    pub down: *const f64,
    /// The right-hand side of the row, read.
    pub rhs: *const f64,
    /// Offset of the row in the level (`j·n`), for the face weights.
    pub row_at: usize,
    /// Offset of the row above in the level, for the face weights.
    pub up_at: usize,
}

/// Relaxes the cells `i ∈ [4, interior_end(n))` with `(i + first) mod 2 = 0` (one colour) of a
/// row, plain stencil (`first` = the colour's first column, 0 or 1).
///
/// # Safety
/// The CPU has AVX2 ([`available`]); the pointers of `p` are valid for `n` values each, and
/// no other thread reads or writes the row `p.row`, or writes `p.up`, `p.down` and `p.rhs`,
/// during the call.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn relax_row_plain(n: usize, h2: f64, first: usize, p: RowPtrs) {
    let keep = colour_mask(first);
    let (h2v, quarter, omega) = (_mm256_set1_pd(h2), _mm256_set1_pd(0.25), _mm256_set1_pd(OMEGA));
    // The row's cells i − 4 .. i + 8 as loaded before any store to them (see `neighbours`).
    // SAFETY: n ≥ 16 when the loop runs, so the first loads (cells 0..8) are inside the row.
    let (mut prev, mut c) = if interior_end(n) > 4 {
        unsafe { (_mm256_loadu_pd(p.row), _mm256_loadu_pd(p.row.add(4))) }
    } else {
        return;
    };
    let mut i = 4;
    while i < interior_end(n) {
        // SAFETY: 4 ≤ i and i + 4 ≤ n − 4, so every load and store is inside the rows
        // (caller's contract).
        unsafe {
            let next = _mm256_loadu_pd(p.row.add(i + 4));
            let (l, r) = neighbours(prev, c, next);
            let u = _mm256_loadu_pd(p.up.add(i));
            let d = _mm256_loadu_pd(p.down.add(i));
            let h2r = _mm256_mul_pd(h2v, _mm256_loadu_pd(p.rhs.add(i)));
            // 0.25 · (l + r + u + d − h²·rhs), as `Plain::relax`.
            let sum = _mm256_sub_pd(_mm256_add_pd(_mm256_add_pd(_mm256_add_pd(l, r), u), d), h2r);
            let x = _mm256_mul_pd(quarter, sum);
            let new = _mm256_add_pd(c, _mm256_mul_pd(omega, _mm256_sub_pd(x, c)));
            _mm256_storeu_pd(p.row.add(i), _mm256_blendv_pd(c, new, keep));
            (prev, c) = (c, next);
        }
        i += 4;
    }
}

/// The west and east neighbours `(l, r)` of the four cells `c`, from the four cells before
/// (`prev`) and after (`next`), all as loaded before this pass stored to them. Loading them
/// from the row again would read across the previous chunk's store (a stalled store
/// forward); and the values are the same where they matter: a colour cell's neighbours have
/// the other colour, which the pass does not change.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
fn neighbours(prev: __m256d, c: __m256d, next: __m256d) -> (__m256d, __m256d) {
    // [p2, p3, c0, c1] → [p3, c0, c1, c2]; [c2, c3, n0, n1] → [c1, c2, c3, n0].
    let l = _mm256_shuffle_pd::<0b0101>(_mm256_permute2f128_pd::<0x21>(prev, c), c);
    let r = _mm256_shuffle_pd::<0b0101>(c, _mm256_permute2f128_pd::<0x21>(c, next));
    (l, r)
}

/// [`relax_row_plain`] with face weights: each cell's update is `num / diag` (for every open
/// face, `diag = 4`, the same bits as `num · 0.25`), and a cell with every face closed
/// (`diag = 0`) keeps its value, as `<&Faces as Stencil>::relax`.
///
/// # Safety
/// As [`relax_row_plain`]; the face weights have the level's `n²` values.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn relax_row_faces(n: usize, h2: f64, first: usize, p: RowPtrs, f: &Faces) {
    assert!(f.ax.len() >= p.row_at + n && f.ay.len() >= p.row_at + n && f.ay.len() >= p.up_at + n);
    let keep = colour_mask(first);
    let (h2v, omega, zero) = (_mm256_set1_pd(h2), _mm256_set1_pd(OMEGA), _mm256_setzero_pd());
    let (four, quarter) = (_mm256_set1_pd(4.0), _mm256_set1_pd(0.25));
    let (ax, ay) = (f.ax.as_ptr(), f.ay.as_ptr());
    // SAFETY: as in `relax_row_plain`.
    let (mut prev, mut c) = if interior_end(n) > 4 {
        unsafe { (_mm256_loadu_pd(p.row), _mm256_loadu_pd(p.row.add(4))) }
    } else {
        return;
    };
    let mut i = 4;
    while i < interior_end(n) {
        // SAFETY: as in `relax_row_plain`; the face weights are read at `row_at + i .. + 5`
        // and `up_at + i .. + 4`, inside the asserted lengths.
        unsafe {
            let k = p.row_at + i;
            let next = _mm256_loadu_pd(p.row.add(i + 4));
            let (l, r) = neighbours(prev, c, next);
            let u = _mm256_loadu_pd(p.up.add(i));
            let d = _mm256_loadu_pd(p.down.add(i));
            let h2r = _mm256_mul_pd(h2v, _mm256_loadu_pd(p.rhs.add(i)));
            let aw = _mm256_loadu_pd(ax.add(k));
            let ae = _mm256_loadu_pd(ax.add(k + 1));
            let as_ = _mm256_loadu_pd(ay.add(k));
            let an = _mm256_loadu_pd(ay.add(p.up_at + i));
            let diag = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(aw, ae), as_), an);
            let num = _mm256_add_pd(
                _mm256_add_pd(
                    _mm256_add_pd(_mm256_mul_pd(aw, l), _mm256_mul_pd(ae, r)),
                    _mm256_mul_pd(as_, d),
                ),
                _mm256_mul_pd(an, u),
            );
            let num = _mm256_sub_pd(num, h2r);
            // Four open faces on all four cells (most of the grid): num · 0.25, the same bits
            // as num / 4 without the division.
            let x = if _mm256_movemask_pd(_mm256_cmp_pd::<_CMP_EQ_OQ>(diag, four)) == 0b1111 {
                _mm256_mul_pd(num, quarter)
            } else {
                _mm256_div_pd(num, diag)
            };
            let new = _mm256_add_pd(c, _mm256_mul_pd(omega, _mm256_sub_pd(x, c)));
            let open = _mm256_cmp_pd::<_CMP_GT_OQ>(diag, zero);
            _mm256_storeu_pd(p.row.add(i), _mm256_blendv_pd(c, new, _mm256_and_pd(keep, open)));
            (prev, c) = (c, next);
        }
        i += 4;
    }
}

/// Lanes of the colour whose first column is `first` (all bits set in a kept lane).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn colour_mask(first: usize) -> __m256d {
    let on = f64::from_bits(u64::MAX);
    if first & 1 == 0 { _mm256_setr_pd(on, 0.0, on, 0.0) } else { _mm256_setr_pd(0.0, on, 0.0, on) }
}

/// The residual `rhs − ∇·(a∇φ)` of the four cells `k .. k + 4` of one row (`up`, `down`: the
/// offsets of the same cells in the rows above and below), as `kernels` computes it cell by
/// cell: plain `l + r + u + d − 4c`, or `aw(l − c) + ae(r − c) + as(d − c) + an(u − c)` with
/// face weights, times `1/h²`.
///
/// # Safety
/// The CPU has AVX2; `phi`, `rhs` and the face weights hold the cells `k − 1 .. k + 5`,
/// `up .. up + 4` and `down .. down + 4`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[inline]
unsafe fn residual4(
    phi: *const f64,
    rhs: *const f64,
    faces: Option<&Faces>,
    k: usize,
    up: usize,
    down: usize,
    inv: __m256d,
) -> __m256d {
    // SAFETY: the caller's contract.
    unsafe {
        let c = _mm256_loadu_pd(phi.add(k));
        let l = _mm256_loadu_pd(phi.add(k - 1));
        let r = _mm256_loadu_pd(phi.add(k + 1));
        let u = _mm256_loadu_pd(phi.add(up));
        let d = _mm256_loadu_pd(phi.add(down));
        let lap = match faces {
            None => _mm256_sub_pd(
                _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(l, r), u), d),
                _mm256_mul_pd(_mm256_set1_pd(4.0), c),
            ),
            Some(f) => {
                let (ax, ay) = (f.ax.as_ptr(), f.ay.as_ptr());
                let w = _mm256_mul_pd(_mm256_loadu_pd(ax.add(k)), _mm256_sub_pd(l, c));
                let e = _mm256_mul_pd(_mm256_loadu_pd(ax.add(k + 1)), _mm256_sub_pd(r, c));
                let s = _mm256_mul_pd(_mm256_loadu_pd(ay.add(k)), _mm256_sub_pd(d, c));
                let nn = _mm256_mul_pd(_mm256_loadu_pd(ay.add(up)), _mm256_sub_pd(u, c));
                _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(w, e), s), nn)
            }
        };
        _mm256_sub_pd(_mm256_loadu_pd(rhs.add(k)), _mm256_mul_pd(lap, inv))
    }
}

/// Checks the sizes the residual loops rely on: `phi`, `rhs` and the face weights hold `n²`
/// values.
fn check_sizes(n: usize, faces: Option<&Faces>, phi: &[f64], rhs: &[f64]) {
    assert!(phi.len() >= n * n && rhs.len() >= n * n);
    if let Some(f) = faces {
        assert!(f.ax.len() >= n * n && f.ay.len() >= n * n);
    }
}

/// Adds the squared residual `(rhs − ∇·(a∇φ))²` of the cells `4..interior_end(n)` of row `j`
/// to the four running sums `acc` (lane = cell mod 4), in the cells' order, as the scalar
/// loop of `kernels::residual_sum_sq` does. `faces`: the level's face weights (`None`:
/// plain Laplacian).
///
/// # Safety
/// The CPU has AVX2 ([`available`]); `j < n`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn residual_row_sq(
    n: usize,
    inv_h2: f64,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    j: usize,
    acc: &mut [f64; 4],
) {
    check_sizes(n, faces, phi, rhs);
    assert!(j < n);
    let mask = n - 1;
    let (row, up, down) = (j * n, ((j + 1) & mask) * n, ((j + n - 1) & mask) * n);
    let inv = _mm256_set1_pd(inv_h2);
    // SAFETY: `acc` holds four values.
    let mut sum = unsafe { _mm256_loadu_pd(acc.as_ptr()) };
    let mut i = 4;
    while i < interior_end(n) {
        // SAFETY: 4 ≤ i and i + 4 ≤ n − 4: cells `row + i − 1 .. row + i + 5`, `up + i .. + 4`,
        // `down + i .. + 4` are inside the n² values (checked).
        let res = unsafe { residual4(phi.as_ptr(), rhs.as_ptr(), faces, row + i, up + i, down + i, inv) };
        sum = _mm256_add_pd(sum, _mm256_mul_pd(res, res));
        i += 4;
    }
    // SAFETY: `acc` holds four values.
    unsafe { _mm256_storeu_pd(acc.as_mut_ptr(), sum) };
}

/// The restricted residual of the coarse cells `2 .. m − 2` of coarse row `jc` (`m = n/2`):
/// each the mean of its four fine cells' residuals, summed in the order of
/// `kernels::restrict_residual` (`((r(i, j) + r(i+1, j)) + r(i, j+1)) + r(i+1, j+1)`) and
/// times 0.25, into `out[2 .. m − 2]` (a coarse row). Needs `n ≥ 16`.
///
/// # Safety
/// The CPU has AVX2 ([`available`]); `jc < n/2`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn restrict_row(
    n: usize,
    inv_h2: f64,
    faces: Option<&Faces>,
    phi: &[f64],
    rhs: &[f64],
    jc: usize,
    out: &mut [f64],
) {
    check_sizes(n, faces, phi, rhs);
    let m = n / 2;
    assert!(n >= 16 && jc < m && out.len() == m);
    let mask = n - 1;
    let j = 2 * jc;
    let (row0, row1) = (j * n, (j + 1) * n);
    let (down0, up1) = (((j + n - 1) & mask) * n, ((j + 2) & mask) * n);
    let (inv, quarter) = (_mm256_set1_pd(inv_h2), _mm256_set1_pd(0.25));
    let (p, q) = (phi.as_ptr(), rhs.as_ptr());
    // Fine cells i .. i + 8 (coarse i/2 .. i/2 + 4), 4 ≤ i, i + 8 ≤ n − 4.
    let mut i = 4;
    while i + 8 <= n - 4 {
        // SAFETY: the fine cells read are `i − 1 .. i + 9` of rows j − 1 .. j + 2 (wrapped),
        // inside the n² values (checked); the store writes out[i/2 .. i/2 + 4], inside the
        // coarse row (i/2 + 4 ≤ m − 2).
        unsafe {
            let a = residual4(p, q, faces, row0 + i, row1 + i, down0 + i, inv);
            let b = residual4(p, q, faces, row0 + i + 4, row1 + i + 4, down0 + i + 4, inv);
            let x = residual4(p, q, faces, row1 + i, up1 + i, row0 + i, inv);
            let y = residual4(p, q, faces, row1 + i + 4, up1 + i + 4, row0 + i + 4, inv);
            // Lanes in the order of coarse cells [0, 2, 1, 3]: hadd = even + odd of row j,
            // unpacklo / unpackhi = even / odd of row j + 1.
            let s = _mm256_add_pd(
                _mm256_add_pd(_mm256_hadd_pd(a, b), _mm256_unpacklo_pd(x, y)),
                _mm256_unpackhi_pd(x, y),
            );
            let c = _mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_mul_pd(quarter, s));
            _mm256_storeu_pd(out.as_mut_ptr().add(i / 2), c);
        }
        i += 8;
    }
}

/// Adds the bilinear prolongation of the coarse (`m × m`) correction to the fine cells
/// `4 .. 2m − 4` of a fine row whose coarse row is `jc` and whose other coarse neighbour row
/// is `jn`, as `kernels::prolong_add` does cell by cell (the same weights, sums in the same
/// order; with face weights only from live coarse cells, renormalised). Needs `m ≥ 8`.
///
/// # Safety
/// The CPU has AVX2 ([`available`]).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
pub(super) unsafe fn prolong_row(
    m: usize,
    coarse: &[f64],
    faces: Option<&Faces>,
    jc: usize,
    jn: usize,
    out: &mut [f64],
) {
    let n = 2 * m;
    assert!(m >= 8 && jc < m && jn < m && coarse.len() >= m * m && out.len() == n);
    if let Some(f) = faces {
        assert!(f.live.len() >= m * m);
    }
    let (w0, w1, w2) = (_mm256_set1_pd(0.5625), _mm256_set1_pd(0.1875), _mm256_set1_pd(0.0625));
    let zero = _mm256_setzero_pd();
    // Fine cells i .. i + 4 are coarse cells ic, ic, ic + 1, ic + 1 (ic = i/2) with the
    // neighbours ic − 1, ic + 1, ic, ic + 2 across: both from the coarse cells ic − 1 .. ic + 3.
    let own = |v: __m256d| _mm256_permute4x64_pd::<0b10_10_01_01>(v);
    let across = |v: __m256d| _mm256_permute4x64_pd::<0b11_01_10_00>(v);
    let mut i = 4;
    while i + 4 <= n - 4 {
        let ic = i / 2;
        // SAFETY: 1 ≤ ic − 1 and ic + 3 ≤ m − 1 (i + 4 ≤ n − 4), so the coarse cells read
        // are inside rows jc and jn (asserted); the fine cells i .. i + 4 inside `out`.
        unsafe {
            let (row, near) = (coarse.as_ptr().add(jc * m + ic - 1), coarse.as_ptr().add(jn * m + ic - 1));
            let (vr, vn) = (_mm256_loadu_pd(row), _mm256_loadu_pd(near));
            let (k, kx, ky, kxy) = (own(vr), across(vr), own(vn), across(vn));
            let x = _mm256_loadu_pd(out.as_ptr().add(i));
            let new = match faces {
                // 0.5625 c + 0.1875 (cx + cy) + 0.0625 cxy.
                None => _mm256_add_pd(
                    x,
                    _mm256_add_pd(
                        _mm256_add_pd(_mm256_mul_pd(w0, k), _mm256_mul_pd(w1, _mm256_add_pd(kx, ky))),
                        _mm256_mul_pd(w2, kxy),
                    ),
                ),
                Some(f) => {
                    let lr = _mm256_loadu_pd(f.live.as_ptr().add(jc * m + ic - 1));
                    let ln = _mm256_loadu_pd(f.live.as_ptr().add(jn * m + ic - 1));
                    let (w, wx) = (_mm256_mul_pd(w0, own(lr)), _mm256_mul_pd(w1, across(lr)));
                    let (wy, wxy) = (_mm256_mul_pd(w1, own(ln)), _mm256_mul_pd(w2, across(ln)));
                    let sum = _mm256_add_pd(_mm256_add_pd(_mm256_add_pd(w, wx), wy), wxy);
                    let num = _mm256_add_pd(
                        _mm256_add_pd(
                            _mm256_add_pd(_mm256_mul_pd(w, k), _mm256_mul_pd(wx, kx)),
                            _mm256_mul_pd(wy, ky),
                        ),
                        _mm256_mul_pd(wxy, kxy),
                    );
                    let added = _mm256_add_pd(x, _mm256_div_pd(num, sum));
                    _mm256_blendv_pd(x, added, _mm256_cmp_pd::<_CMP_GT_OQ>(sum, zero))
                }
            };
            _mm256_storeu_pd(out.as_mut_ptr().add(i), new);
        }
        i += 4;
    }
}
