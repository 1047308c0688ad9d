//! Parallel sums that give the same bits on every run and on any number of threads.
//!
//! rayon's `fold` then `reduce` adds partial sums in the order the threads happen to steal the work, so the last
//! bits of an Allan deviation changed from one run of `octavar analyze` on the same file to the next. Here the
//! items are folded in fixed runs of [`RUN`] consecutive items (each run in order, on one thread), and the runs'
//! partial sums are added in order on the calling thread.

use rayon::prelude::*;

/// Consecutive items one task folds.
pub(crate) const RUN: usize = 4;

/// The element-wise sum of `width`-long partial sums: for each item, `add(acc, scratch, item)` adds its terms to
/// `acc`, with `scratch` a work buffer made once per run of `run` items by `scratch()`.
pub(crate) fn ordered_sums_with<I, S, F>(
    items: I,
    run: usize,
    width: usize,
    scratch: impl Fn() -> S + Sync + Send,
    add: F,
) -> Vec<f64>
where
    I: IndexedParallelIterator,
    S: Send,
    F: Fn(&mut [f64], &mut S, I::Item) + Sync + Send,
{
    let parts: Vec<Vec<f64>> = items
        .fold_chunks(
            run.max(1),
            || (vec![0.0f64; width], scratch()),
            |(mut acc, mut s), item| {
                add(&mut acc, &mut s, item);
                (acc, s)
            },
        )
        .map(|(acc, _)| acc)
        .collect();
    parts.into_iter().fold(vec![0.0f64; width], |mut total, part| {
        total.iter_mut().zip(&part).for_each(|(t, p)| *t += p);
        total
    })
}

/// [`ordered_sums_with`] without a work buffer.
pub(crate) fn ordered_sums<I, F>(items: I, width: usize, add: F) -> Vec<f64>
where
    I: IndexedParallelIterator,
    F: Fn(&mut [f64], I::Item) + Sync + Send,
{
    ordered_sums_with(items, RUN, width, || (), |acc, _, item| add(acc, item))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Terms of very different sizes, whose sum depends on the order of the additions: the same bits on one
    /// thread and on several, run after run, and the plain sequential sum of the runs in order.
    #[test]
    fn the_same_bits_on_any_number_of_threads() {
        let terms: Vec<f64> = (0..10_000u32).map(|i| f64::from(i).sin() * 10f64.powi((i % 17) as i32 - 8)).collect();
        let sum = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                ordered_sums(terms.par_chunks(7), 2, |acc, c| {
                    acc[0] += c.iter().sum::<f64>();
                    acc[1] += c.len() as f64;
                })
            })
        };
        let one = sum(1);
        let mut want = 0.0;
        for run in terms.chunks(7 * RUN) {
            want += run.chunks(7).fold(0.0, |a, c| a + c.iter().sum::<f64>());
        }
        assert_eq!(one, vec![want, 10_000.0]);
        for threads in [2, 3, 8, 8, 8] {
            assert_eq!(
                sum(threads).iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
                [want.to_bits(), 10_000f64.to_bits()]
            );
        }
    }
}
