//! A bounded memo of the cells' samples for one worker of [`super::recover`]:
//! a cell belongs to the first ring of its 8 vertices' patches, so without it
//! every sample (an FE stress evaluation) would be computed up to 8 times per
//! recovery. Workers fit runs of consecutive nodes, whose patches overlap, so
//! a small memo catches most repeats; when it is full it starts afresh, which
//! bounds its memory whatever the grid. The samples are the caller's,
//! unchanged: fits are bit-identical with and without it.

use std::collections::HashMap;

use super::spr::PatchSamples;
use super::Sample;

/// Samples kept before the memo starts afresh (about 1 MiB for stresses).
const CAPACITY: usize = 16_384;

/// The samples of recently visited cells.
pub(super) struct SampleCache<const NC: usize> {
    /// Cell → its range in `store`.
    index: HashMap<usize, (usize, usize)>,
    store: Vec<Sample<NC>>,
}

impl<const NC: usize> SampleCache<NC> {
    pub(super) fn new() -> Self {
        SampleCache {
            index: HashMap::new(),
            store: Vec::new(),
        }
    }

    /// The samples of `cell`, from the memo or from `source`.
    pub(super) fn get<S: PatchSamples<NC>>(&mut self, source: &S, cell: usize) -> &[Sample<NC>] {
        if !self.index.contains_key(&cell) {
            if self.store.len() >= CAPACITY {
                self.index.clear();
                self.store.clear();
            }
            let start = self.store.len();
            source.samples(cell, &mut self.store);
            self.index.insert(cell, (start, self.store.len()));
        }
        let (start, end) = self.index[&cell];
        &self.store[start..end]
    }
}
