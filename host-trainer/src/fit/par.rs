//! The parallel map the selection and the sweeps share.

use rayon::prelude::*;

/// `f` over `items` in parallel (rayon), results in the order of `items`.
pub(crate) fn par_map<T: Sync, U: Send>(items: &[T], f: impl Fn(&T) -> U + Sync + Send) -> Vec<U> {
    items.par_iter().map(f).collect()
}
