//! Deterministic data parallelism on Bevy's task pools, shared by every domain (the
//! weather model, the lava grid, the pyroclastic particles).
//!
//! Work is cut into **fixed bands** of rows: the bands depend on the grid and on
//! [`Bands::rows`], never on the number of threads, and the per-band results come back **in
//! band order**. A reduction folded over those results (sum, maximum, count) is therefore
//! bit-identical on a laptop, a CI runner and a 64-core workstation. One band runs inline,
//! without touching the pool.
//!
//! The bands run on one of Bevy's pools ([`Pool`]): the `ComputeTaskPool` by default, the
//! `AsyncComputeTaskPool` inside [`on_pool`]`(Pool::AsyncCompute, ..)`. In an app they are
//! the pools `TaskPoolPlugin` built (so the app's thread budget is the only one); in a bare
//! `World`, a test, a command-line tool or a bench they are created on first use. The calling
//! thread helps run the bands while it waits, so a call from inside another band (nested
//! loops) makes progress; nested calls stay on the pool of the outer call.
//!
//! **Work that a system may block on must not use the compute pool.** Bevy's multi-threaded
//! executor runs systems as tasks of the compute pool, and a thread waiting for its bands
//! runs whatever task of that pool is queued, systems included. The weather step runs as a
//! task (`AsyncComputeTaskPool`) that a system joins (`block_on`) one weather step later: had
//! its bands been on the compute pool, the task's own thread could pick up that joining
//! system while helping and wait for itself for ever. So the weather step runs its bands on
//! the async compute pool, whose tasks never wait for a system. `tests/pool.rs` in
//! `volcano_atmosphere` runs the pipeline in a
//! multi-threaded app on a two-thread compute pool.
//!
//! The helper is written by hand rather than with rayon on purpose: rayon brings a second
//! thread pool, sized to the machine, that competes with Bevy's for the same cores (on two
//! cores the two pools oversubscribe them and a step waits on both). With everything on
//! Bevy's pools the app's thread budget (`TaskPoolPlugin`) is the only one.
//!
//! ```
//! use volcano_core::parallel::{self, Bands};
//!
//! // Per row of a 4-wide grid: one slice ...
//! let mut a = vec![0.0f32; 4 * 100];
//! parallel::for_each_row(a.as_mut_slice(), 4, |j, row| row.fill(j as f32));
//! // ... or several zipped slices (a tuple of up to 8 `&mut [T]`).
//! let mut b = vec![0u32; 4 * 100];
//! parallel::for_each_row((a.as_mut_slice(), b.as_mut_slice()), 4, |j, (ra, rb)| {
//!     for (x, y) in ra.iter_mut().zip(rb) {
//!         *y = j as u32;
//!         *x += 1.0;
//!     }
//! });
//! // Per band, with a result each (band order): a deterministic sum.
//! let sums = Bands::of(16).map(a.as_mut_slice(), 4, |_first_row, band| band.iter().sum::<f32>());
//! let total: f32 = sums.iter().sum();
//! assert_eq!(total, (0..100).map(|j| 4.0 * (j as f32 + 1.0)).sum::<f32>());
//! ```
//!

use std::cell::Cell;
use std::ops::Range;

use bevy::tasks::{AsyncComputeTaskPool, ComputeTaskPool, TaskPool};

/// Rows per band of [`Bands::DEFAULT`]: a 512-row grid makes 16 bands, enough to balance two
/// to eight cores while each band is long enough that its task's cost does not show.
pub const BAND_ROWS: usize = 32;

/// Which of Bevy's task pools the helper's bands run on (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Pool {
    /// Bevy's `ComputeTaskPool`: work a system waits for while it runs (the lava grid, the
    /// pyroclastic particles).
    #[default]
    Compute,
    /// Bevy's `AsyncComputeTaskPool`: work inside a task that a system may block on (the
    /// weather step of the off-thread pipeline).
    AsyncCompute,
}

impl Pool {
    /// The pool, created with the default size if the app has not built it (bare `World`,
    /// tests, command-line tools, benches).
    pub fn task_pool(self) -> &'static TaskPool {
        match self {
            Pool::Compute => ComputeTaskPool::get_or_init(TaskPool::default),
            Pool::AsyncCompute => AsyncComputeTaskPool::get_or_init(TaskPool::default),
        }
    }

    /// The pool the helper's calls on this thread use now.
    pub fn current() -> Pool {
        POOL.get()
    }
}

thread_local! {
    /// Set by [`run_inline`]: every helper call on this thread runs its bands here, in order.
    static INLINE: Cell<bool> = const { Cell::new(false) };
    /// Set by [`on_pool`] (and inside every band): the pool of this thread's helper calls.
    static POOL: Cell<Pool> = const { Cell::new(Pool::Compute) };
}

/// Restores a thread-local flag when dropped (also when the closure panics).
struct Restore<T: Copy + 'static>(&'static std::thread::LocalKey<Cell<T>>, T);

impl<T: Copy + 'static> Drop for Restore<T> {
    fn drop(&mut self) {
        self.0.set(self.1);
    }
}

/// Runs `f` with every helper call it makes on this thread (and every call nested in their
/// bands) running its bands on `pool`.
pub fn on_pool<R>(pool: Pool, f: impl FnOnce() -> R) -> R {
    let _restore = Restore(&POOL, POOL.replace(pool));
    f()
}

/// Runs `f` with every helper call it makes (on this thread, nested ones included) executed
/// inline, band after band in band order, without the pool: the single-threaded reference
/// that tests compare a parallel run with (the bands, hence the results, are the same).
pub fn run_inline<R>(f: impl FnOnce() -> R) -> R {
    let _restore = Restore(&INLINE, INLINE.replace(true));
    f()
}

/// Runs `f(index, item)` for every item, one task per item on the [current pool](Pool::current),
/// and returns the results in item order. Runs inline when there is at most one item (or inside
/// [`run_inline`]).
///
/// The primitive under [`Bands`]: use it when a pass builds its own per-band items (slices of
/// different row lengths, optional extra rows, per-band scratch).
pub fn par_map<T: Send, R: Send + 'static>(items: Vec<T>, f: impl Fn(usize, T) -> R + Sync) -> Vec<R> {
    if items.len() <= 1 || INLINE.get() {
        return items.into_iter().enumerate().map(|(b, t)| f(b, t)).collect();
    }
    let f = &f;
    let pool = Pool::current();
    // `scope` returns the spawned tasks' results in spawn order. A band may run on any thread
    // of the pool: it carries the pool along, so its own nested calls stay there.
    pool.task_pool().scope(|scope| {
        for (b, item) in items.into_iter().enumerate() {
            scope.spawn(async move { on_pool(pool, || f(b, item)) });
        }
    })
}

/// One or several equally long mutable slices that can be cut at an element index: a
/// `&mut [T]`, or a tuple of 1 to 8 of them (tuples nest). Each slice holds the same grid of
/// rows, so a band or a row of the tuple is the same band or row of each slice.
pub trait RowSlices: Send + Sized {
    /// Number of elements (the same in every slice; panics otherwise).
    fn elem_count(&self) -> usize;
    /// Cuts every slice at element `mid`: the first `mid` elements, and the rest.
    fn split_at_elem(self, mid: usize) -> (Self, Self);
}

impl<T: Send> RowSlices for &mut [T] {
    fn elem_count(&self) -> usize {
        self.len()
    }

    fn split_at_elem(self, mid: usize) -> (Self, Self) {
        self.split_at_mut(mid)
    }
}

macro_rules! tuple_row_slices {
    ($($t:ident $v:ident $i:tt),+) => {
        impl<$($t: RowSlices),+> RowSlices for ($($t,)+) {
            fn elem_count(&self) -> usize {
                let n = self.0.elem_count();
                $(assert_eq!(self.$i.elem_count(), n, "zipped slices must have the same length");)+
                n
            }

            fn split_at_elem(self, mid: usize) -> (Self, Self) {
                $(let $v = self.$i.split_at_elem(mid);)+
                (($($v.0,)+), ($($v.1,)+))
            }
        }
    };
}

tuple_row_slices!(A a 0);
tuple_row_slices!(A a 0, B b 1);
tuple_row_slices!(A a 0, B b 1, C c 2);
tuple_row_slices!(A a 0, B b 1, C c 2, D d 3);
tuple_row_slices!(A a 0, B b 1, C c 2, D d 3, E e 4);
tuple_row_slices!(A a 0, B b 1, C c 2, D d 3, E e 4, F f 5);
tuple_row_slices!(A a 0, B b 1, C c 2, D d 3, E e 4, F f 5, G g 6);
tuple_row_slices!(A a 0, B b 1, C c 2, D d 3, E e 4, F f 5, G g 6, H h 7);

/// A fixed cut of rows into bands of [`Bands::rows`] rows (the last band may be shorter): the
/// unit of work of the helpers, independent of the thread count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bands {
    rows: usize,
}

impl Default for Bands {
    fn default() -> Self {
        Self::DEFAULT
    }
}

impl Bands {
    /// Bands of [`BAND_ROWS`] rows.
    pub const DEFAULT: Self = Self { rows: BAND_ROWS };

    /// Bands of `rows` rows (at least one).
    pub const fn of(rows: usize) -> Self {
        Self { rows: if rows == 0 { 1 } else { rows } }
    }

    /// Rows per band.
    pub const fn rows(self) -> usize {
        self.rows
    }

    /// Number of bands covering `rows` rows (0 for no rows).
    pub const fn count(self, rows: usize) -> usize {
        rows.div_ceil(self.rows)
    }

    /// Rows of band `b` in a grid of `rows` rows (empty past the end).
    pub fn range(self, b: usize, rows: usize) -> Range<usize> {
        (b * self.rows).min(rows)..((b + 1) * self.rows).min(rows)
    }

    /// Runs `f(rows)` for the row range of every band of `rows` rows, in parallel, and returns
    /// the results in band order. For passes that write through something other than slices
    /// (e.g. a red–black sweep) or that only read.
    pub fn map_ranges<R: Send + 'static>(self, rows: usize, f: impl Fn(Range<usize>) -> R + Sync) -> Vec<R> {
        let ranges: Vec<_> = (0..self.count(rows)).map(|b| self.range(b, rows)).collect();
        par_map(ranges, |_, r| f(r))
    }

    /// Runs `f(j)` for every row index `j < rows`, bands in parallel, rows in order inside a
    /// band.
    pub fn for_each_index(self, rows: usize, f: impl Fn(usize) + Sync) {
        self.map_ranges(rows, |r| r.for_each(&f));
    }

    /// Cuts `slices` (rows of `n` elements) into bands and runs `f(first_row, band)` for each,
    /// in parallel; returns the results in band order. `band` is the same kind of slice or
    /// tuple as `slices`, holding the band's rows.
    ///
    /// Panics when the length is not a multiple of `n` (or `n` is 0 with elements).
    pub fn map<S: RowSlices, R: Send + 'static>(
        self,
        slices: S,
        n: usize,
        f: impl Fn(usize, S) -> R + Sync,
    ) -> Vec<R> {
        let len = slices.elem_count();
        if len == 0 {
            return Vec::new();
        }
        assert!(n > 0 && len.is_multiple_of(n), "{len} elements are not rows of {n}");
        let rows = len / n;
        let mut items = Vec::with_capacity(self.count(rows));
        let mut rest = slices;
        let mut first = 0;
        while rows - first > self.rows {
            let (band, tail) = rest.split_at_elem(self.rows * n);
            items.push((first, band));
            rest = tail;
            first += self.rows;
        }
        items.push((first, rest));
        par_map(items, |_, (first, band)| f(first, band))
    }

    /// Runs `f(j, row)` for every row `j` of `slices` (rows of `n` elements), bands in
    /// parallel, rows in order inside a band. `row` is the same kind of slice or tuple as
    /// `slices`, holding row `j`.
    pub fn for_each_row<S: RowSlices>(self, slices: S, n: usize, f: impl Fn(usize, S) + Sync) {
        // The rows' results are `()`: the vectors collecting them never allocate.
        self.map_rows(slices, n, f);
    }

    /// Runs `f(j, row)` for every row like [`Bands::for_each_row`] and returns the rows'
    /// results in row order (fold them in that order for a deterministic reduction).
    pub fn map_rows<S: RowSlices, R: Send + 'static>(
        self,
        slices: S,
        n: usize,
        f: impl Fn(usize, S) -> R + Sync,
    ) -> Vec<R> {
        let bands = self.map(slices, n, |first, band| {
            let mut rest = band;
            let rows = rest.elem_count() / n;
            let mut out = Vec::with_capacity(rows);
            for j in first..first + rows {
                let (row, tail) = rest.split_at_elem(n);
                out.push(f(j, row));
                rest = tail;
            }
            out
        });
        bands.into_iter().flatten().collect()
    }
}

/// [`Bands::map_rows`] with the [default bands](Bands::DEFAULT).
pub fn map_rows<S: RowSlices, R: Send + 'static>(
    slices: S,
    n: usize,
    f: impl Fn(usize, S) -> R + Sync,
) -> Vec<R> {
    Bands::DEFAULT.map_rows(slices, n, f)
}

/// [`Bands::for_each_row`] with the [default bands](Bands::DEFAULT).
pub fn for_each_row<S: RowSlices>(slices: S, n: usize, f: impl Fn(usize, S) + Sync) {
    Bands::DEFAULT.for_each_row(slices, n, f);
}

/// [`Bands::map`] with the [default bands](Bands::DEFAULT).
pub fn map_bands<S: RowSlices, R: Send + 'static>(
    slices: S,
    n: usize,
    f: impl Fn(usize, S) -> R + Sync,
) -> Vec<R> {
    Bands::DEFAULT.map(slices, n, f)
}

/// [`Bands::for_each_index`] with the [default bands](Bands::DEFAULT).
pub fn for_each_index(rows: usize, f: impl Fn(usize) + Sync) {
    Bands::DEFAULT.for_each_index(rows, f);
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[test]
    fn rows_are_covered_once_with_their_index() {
        for rows in [0, 1, 31, 32, 33, 100, 512] {
            let n = 3;
            let mut a = vec![usize::MAX; n * rows];
            let mut hits = vec![0u8; n * rows];
            for_each_row((a.as_mut_slice(), hits.as_mut_slice()), n, |j, (ra, rh)| {
                for (i, (x, h)) in ra.iter_mut().zip(rh).enumerate() {
                    *x = j * n + i;
                    *h += 1;
                }
            });
            assert!(a.iter().enumerate().all(|(k, v)| *v == k), "rows = {rows}");
            assert!(hits.iter().all(|h| *h == 1), "rows = {rows}");
        }
    }

    #[test]
    fn rows_run_in_order_inside_a_band_and_bands_return_in_order() {
        let seen = Mutex::new(Vec::new());
        let (n, rows) = (2, 100);
        let mut a = vec![0u32; n * rows];
        let firsts = Bands::of(8).map(a.as_mut_slice(), n, |first, band| {
            let mut mine = Vec::new();
            for (r, row) in band.chunks_mut(n).enumerate() {
                row.fill((first + r) as u32);
                mine.push(first + r);
            }
            seen.lock().unwrap().push(mine);
            (first, band.len() / n)
        });
        let expected: Vec<_> = (0..13).map(|b| (8 * b, if b < 12 { 8 } else { 4 })).collect();
        assert_eq!(firsts, expected);
        for band in seen.into_inner().unwrap() {
            assert!(band.windows(2).all(|w| w[1] == w[0] + 1), "rows in order: {band:?}");
        }
        assert!(a.chunks(n).enumerate().all(|(j, r)| r.iter().all(|v| *v as usize == j)));
    }

    #[test]
    fn results_come_back_in_band_order_and_repeat_bit_for_bit() {
        // A float sum that depends on the order of its terms: folded over bands in order it is
        // the same on every call (and machine), whatever the threads did.
        let n = 64;
        let mut a: Vec<f32> =
            (0..n * 300).map(|k| ((k * 7919) % 1000) as f32 * 1.1e-3 + 1e4 / (k + 1) as f32).collect();
        let sum = |a: &mut [f32]| {
            let parts = Bands::of(7).map(a, n, |_, band| band.iter().map(|x| *x as f64).sum::<f64>());
            assert_eq!(parts.len(), Bands::of(7).count(300));
            parts.into_iter().fold(0.0f64, |s, p| s + p).to_bits()
        };
        let first = sum(&mut a);
        for _ in 0..20 {
            assert_eq!(sum(&mut a), first);
        }
        let serial: f64 =
            a.chunks(7 * n).map(|c| c.iter().map(|x| *x as f64).sum::<f64>()).fold(0.0, |s, p| s + p);
        assert_eq!(serial.to_bits(), first);
    }

    #[test]
    fn zero_rows_and_ragged_last_band() {
        let mut empty: Vec<f32> = Vec::new();
        assert!(map_bands(empty.as_mut_slice(), 8, |_, _| 1).is_empty());
        for_each_row(empty.as_mut_slice(), 0, |_, _| panic!("no rows"));
        assert!(Bands::DEFAULT.map_ranges(0, |_| 1).is_empty());
        assert_eq!(Bands::of(32).count(70), 3);
        assert_eq!(Bands::of(32).range(2, 70), 64..70);
        assert_eq!(Bands::of(32).range(3, 70), 70..70);
        let ranges = Bands::of(32).map_ranges(70, |r| r);
        assert_eq!(ranges, vec![0..32, 32..64, 64..70]);
        // One band runs inline.
        let here = std::thread::current().id();
        let ids = Bands::of(32).map_ranges(10, |_| std::thread::current().id());
        assert_eq!(ids, vec![here]);
    }

    #[test]
    fn eight_zipped_slices_and_indices() {
        let n = 5;
        let rows = 41;
        let mut v: Vec<Vec<u16>> = (0..8).map(|_| vec![0; n * rows]).collect();
        let [a, b, c, d, e, f, g, h] =
            v.iter_mut().map(|x| x.as_mut_slice()).collect::<Vec<_>>().try_into().unwrap();
        Bands::of(4).for_each_row((a, b, c, d, e, f, g, h), n, |j, (a, b, c, d, e, f, g, h)| {
            for (k, s) in [a, b, c, d, e, f, g, h].into_iter().enumerate() {
                s.fill((j * 8 + k) as u16);
            }
        });
        for (k, s) in v.iter().enumerate() {
            assert!(s.chunks(n).enumerate().all(|(j, r)| r.iter().all(|x| *x as usize == j * 8 + k)));
        }
        let count = std::sync::atomic::AtomicUsize::new(0);
        for_each_index(rows, |j| {
            count.fetch_add(j + 1, std::sync::atomic::Ordering::Relaxed);
        });
        assert_eq!(count.into_inner(), rows * (rows + 1) / 2);
    }

    #[test]
    fn row_results_in_row_order() {
        let n = 4;
        let mut a = vec![1u64; n * 77];
        let r = Bands::of(10).map_rows(a.as_mut_slice(), n, |j, row| {
            row.iter_mut().for_each(|x| *x = j as u64);
            j * 2
        });
        assert_eq!(r, (0..77).map(|j| j * 2).collect::<Vec<_>>());
        assert!(map_rows(Vec::<u8>::new().as_mut_slice(), n, |j, _| j).is_empty());
    }

    #[test]
    fn run_inline_stays_on_this_thread_and_matches() {
        let here = std::thread::current().id();
        let ids = run_inline(|| Bands::of(1).map_ranges(20, |_| std::thread::current().id()));
        assert!(ids.iter().all(|id| *id == here));
        let work = || Bands::of(3).map_ranges(100, |r| r.map(|j| (j as f64).sqrt()).sum::<f64>().to_bits());
        assert_eq!(run_inline(work), work());
    }

    #[test]
    #[should_panic(expected = "same length")]
    fn zipped_slices_of_different_lengths_panic() {
        let (mut a, mut b) = (vec![0u8; 8], vec![0u8; 6]);
        for_each_row((a.as_mut_slice(), b.as_mut_slice()), 2, |_, _| {});
    }

    #[test]
    fn items_map_in_order_from_inside_another_band() {
        // Nested use (a band that runs its own bands) finishes and keeps the order.
        let outer = par_map((0..4).collect(), |i, x: usize| {
            assert_eq!(i, x);
            let inner = Bands::of(1).map_ranges(50, |r| r.start * 10 + x);
            inner.iter().enumerate().all(|(j, v)| *v == j * 10 + x)
        });
        assert_eq!(outer, vec![true; 4]);
    }
}
