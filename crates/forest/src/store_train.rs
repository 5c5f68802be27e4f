//! Training from a [`PatchStore`] in bounded memory: the tree
//! [`crate::train_tree`] grows from the training set, bit for bit, with
//! patches read from the store's chunk files.
//!
//! The tree grows depth first as in memory (its node ids seed its random
//! draws, so the order is part of the model). A node larger than the
//! budget streams its samples' patches from the store, one chunk at a
//! time, for each of its two passes (the evaluation samples' patches; the
//! chosen test's response at every sample, from two rows of each chunk's
//! position-major copy). The first node on the way down
//! that fits the budget loads its samples' patches once and its whole
//! subtree grows from memory: PLANET's split between nodes that need a
//! pass over the data and subtrees that fit one machine (Panda et al.,
//! VLDB 2009). Memory is therefore bounded by the budget, one chunk and
//! five bytes of label and angle per sample, whatever the store's size.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};

use crate::error::{ForestError, Result};
use crate::grow::{grow_tree, SampleSource};
use crate::params::TrainParams;
use crate::patch::{SplitTest, PATCH_LEN};
use crate::patch_store::{PatchStore, WRITE_HINT};
use crate::train::{assemble, check_index, mix, PlanHeader, TrainedTree};
use crate::Forest;
use vp_scene::error::SceneError;

/// Patches held in memory at most while training one tree from a store
/// (beyond one chunk and the per-sample labels and angles).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoreBudget {
    /// Bytes of patches a subtree may load; 0 streams every node.
    pub resident_bytes: usize,
}

impl Default for StoreBudget {
    /// 4 GiB: with a chunk and the labels, a worker stays well under 8 GiB.
    fn default() -> Self {
        StoreBudget {
            resident_bytes: 4 << 30,
        }
    }
}

/// What training one tree read from the store.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct StoreReads {
    /// Reads of (part of) a chunk file: one per chunk a pass touched.
    pub chunk_reads: u64,
    /// Patch bytes read.
    pub bytes_read: u64,
    /// Subtrees loaded into memory whole.
    pub subtrees_loaded: u64,
    /// Largest patch buffer held at once (the read buffer plus the loaded
    /// subtree plus the evaluation samples), in bytes.
    pub peak_patch_bytes: u64,
}

/// Read over gaps of up to this many patches rather than seek past them.
const GAP: u32 = 16;

struct StoreSource<'a> {
    store: &'a PatchStore,
    files: Vec<Option<File>>,
    column_files: Vec<Option<File>>,
    cap: usize,
    resident_range: Option<(usize, usize)>,
    resident_ids: Vec<u32>,
    resident: Vec<u8>,
    buf: Vec<u8>,
    patches: Vec<u8>,
    reads: StoreReads,
}

impl<'a> StoreSource<'a> {
    fn new(store: &'a PatchStore, budget: StoreBudget) -> Self {
        StoreSource {
            store,
            files: (0..store.manifest().chunks.len()).map(|_| None).collect(),
            column_files: (0..store.manifest().chunks.len()).map(|_| None).collect(),
            cap: budget.resident_bytes / PATCH_LEN,
            resident_range: None,
            resident_ids: Vec::new(),
            resident: Vec::new(),
            buf: Vec::new(),
            patches: Vec::new(),
            reads: StoreReads::default(),
        }
    }

    fn note_peak(&mut self) {
        let held = self.buf.capacity() + self.resident.capacity() + self.patches.capacity();
        self.reads.peak_patch_bytes = self.reads.peak_patch_bytes.max(held as u64);
    }

    /// Calls `f(k, patch)` for each `ids[k]` in order (`ids` sorted, repeats
    /// allowed), reading chunk by chunk: runs of nearby ids in one read,
    /// never more than one chunk's bytes at once.
    fn for_each_patch(&mut self, ids: &[u32], mut f: impl FnMut(usize, &[u8])) -> Result<()> {
        let chunk_len = self.store.manifest().chunk_len;
        let mut k = 0;
        while k < ids.len() {
            let chunk = (u64::from(ids[k]) / chunk_len) as usize;
            let first = chunk as u64 * chunk_len;
            let mut end_chunk = k;
            while end_chunk < ids.len() && u64::from(ids[end_chunk]) / chunk_len == chunk as u64 {
                end_chunk += 1;
            }
            self.reads.chunk_reads += 1;
            let path = self.store.chunk_path(chunk);
            if self.files[chunk].is_none() {
                let file = File::open(&path).map_err(|e| SceneError::io(&path, e))?;
                self.files[chunk] = Some(file);
            }
            while k < end_chunk {
                let (a, mut last) = (ids[k], ids[k]);
                let mut r = k;
                while r < end_chunk && ids[r] - last <= GAP {
                    last = ids[r];
                    r += 1;
                }
                let n = (last - a + 1) as usize;
                // Exact sizes: the capacity is the largest read, at most a chunk.
                self.buf.clear();
                self.buf.reserve_exact(n * PATCH_LEN);
                self.buf.resize(n * PATCH_LEN, 0);
                let at = (u64::from(a) - first) * PATCH_LEN as u64;
                if let Some(file) = self.files[chunk].as_mut() {
                    file.seek(SeekFrom::Start(at))
                        .and_then(|_| file.read_exact(&mut self.buf))
                        .map_err(|e| SceneError::io(&path, e))?;
                }
                self.reads.bytes_read += self.buf.len() as u64;
                for (j, &id) in ids.iter().enumerate().take(r).skip(k) {
                    let o = (id - a) as usize * PATCH_LEN;
                    f(j, &self.buf[o..o + PATCH_LEN]);
                }
                k = r;
            }
        }
        self.note_peak();
        Ok(())
    }

    /// The responses of `test` at `ids` (sorted) from the position-major
    /// chunk files: two rows of a chunk per chunk the ids touch.
    fn stream_responses(&mut self, ids: &[u32], test: SplitTest, out: &mut Vec<i32>) -> Result<()> {
        let (p1, p2) = test.patch_indices();
        let chunk_len = self.store.manifest().chunk_len;
        let mut k = 0;
        while k < ids.len() {
            let chunk = (u64::from(ids[k]) / chunk_len) as usize;
            let first = chunk as u64 * chunk_len;
            let n = self.store.manifest().chunks[chunk].n_samples as usize;
            let path = self.store.columns_path(chunk);
            if self.column_files[chunk].is_none() {
                let file = File::open(&path).map_err(|e| SceneError::io(&path, e))?;
                self.column_files[chunk] = Some(file);
            }
            self.buf.clear();
            self.buf.reserve_exact(2 * n);
            self.buf.resize(2 * n, 0);
            if let Some(file) = self.column_files[chunk].as_mut() {
                let (row1, row2) = self.buf.split_at_mut(n);
                for (p, row) in [(p1, row1), (p2, row2)] {
                    file.seek(SeekFrom::Start((p * n) as u64))
                        .and_then(|_| file.read_exact(row))
                        .map_err(|e| SceneError::io(&path, e))?;
                }
            }
            self.reads.chunk_reads += 1;
            self.reads.bytes_read += 2 * n as u64;
            while k < ids.len() && u64::from(ids[k]) / chunk_len == chunk as u64 {
                let s = (u64::from(ids[k]) - first) as usize;
                out.push(test.op.apply(self.buf[s], self.buf[n + s]));
                k += 1;
            }
        }
        self.note_peak();
        Ok(())
    }

    fn resident_patch(&self, id: u32) -> Option<&[u8]> {
        self.resident_range?;
        let s = self.resident_ids.binary_search(&id).ok()?;
        Some(&self.resident[s * PATCH_LEN..(s + 1) * PATCH_LEN])
    }
}

impl SampleSource for StoreSource<'_> {
    fn positive(&self, i: u32) -> bool {
        self.store.positive[i as usize]
    }

    fn angle(&self, i: u32) -> f32 {
        self.store.angles[i as usize]
    }

    fn enter(&mut self, range: (usize, usize), ids: &[u32]) -> Result<()> {
        if let Some((s, e)) = self.resident_range {
            if s <= range.0 && range.1 <= e {
                return Ok(());
            }
        }
        self.resident_range = None;
        self.resident_ids.clear();
        self.resident.clear();
        if range.1 - range.0 > self.cap {
            return Ok(());
        }
        let mut unique = ids.to_vec();
        unique.dedup();
        let mut resident = std::mem::take(&mut self.resident);
        resident.reserve_exact(unique.len() * PATCH_LEN);
        resident.resize(unique.len() * PATCH_LEN, 0);
        self.for_each_patch(&unique, |k, p| {
            resident[k * PATCH_LEN..(k + 1) * PATCH_LEN].copy_from_slice(p);
        })?;
        self.resident = resident;
        self.resident_ids = unique;
        self.resident_range = Some(range);
        self.reads.subtrees_loaded += 1;
        self.note_peak();
        Ok(())
    }

    fn gather(
        &mut self,
        ids: &[u32],
        positions: Option<&[usize]>,
        out: &mut Vec<u8>,
    ) -> Result<()> {
        let mut patches = std::mem::take(&mut self.patches);
        patches.clear();
        patches.reserve_exact(ids.len() * PATCH_LEN);
        if self.resident_range.is_some() {
            for &id in ids {
                patches.extend_from_slice(self.resident_patch(id).ok_or_else(not_loaded)?);
            }
        } else {
            patches.resize(ids.len() * PATCH_LEN, 0);
            self.for_each_patch(ids, |k, p| {
                patches[k * PATCH_LEN..(k + 1) * PATCH_LEN].copy_from_slice(p);
            })?;
        }
        // The layouts of gather_columns / gather_rows: byte p (or
        // positions[r]) of sample s at out[p * m + s].
        let m = ids.len();
        let all: Vec<usize> = if positions.is_some() {
            Vec::new()
        } else {
            (0..PATCH_LEN).collect()
        };
        let positions = positions.unwrap_or(&all);
        out.clear();
        out.resize(positions.len() * m, 0);
        for (s, patch) in patches.chunks_exact(PATCH_LEN).enumerate() {
            for (r, &p) in positions.iter().enumerate() {
                out[r * m + s] = patch[p];
            }
        }
        self.patches = patches;
        self.note_peak();
        Ok(())
    }

    fn responses(&mut self, ids: &[u32], test: SplitTest, out: &mut Vec<i32>) -> Result<()> {
        let (p1, p2) = test.patch_indices();
        if self.resident_range.is_some() {
            for &id in ids {
                let p = self.resident_patch(id).ok_or_else(not_loaded)?;
                out.push(test.op.apply(p[p1], p[p2]));
            }
            return Ok(());
        }
        self.stream_responses(ids, test, out)
    }
}

fn not_loaded() -> ForestError {
    ForestError::InvalidInput("internal: a node's sample is outside its loaded subtree".into())
}

impl PatchStore {
    /// The plan header every tree trained from this store with `params`
    /// carries: the header [`crate::TrainingPlan::new`] makes from the set
    /// the store was drawn from. Refuses parameters of another draw.
    fn plan_header(&self, params: &TrainParams) -> Result<PlanHeader> {
        params.validate()?;
        let m = self.manifest();
        if params.samples_per_class != m.samples_per_class
            || params.balance_classes != m.balance_classes
        {
            return Err(ForestError::InvalidInput(format!(
                "{}: the store was drawn with samples_per_class = {}, balance_classes = {}; \
                 training with {} and {} needs a store of that draw ({WRITE_HINT})",
                self.dir().display(),
                m.samples_per_class,
                m.balance_classes,
                params.samples_per_class,
                params.balance_classes
            )));
        }
        let n_beyond = self
            .angles
            .iter()
            .filter(|&&a| params.bins.bin_of(a).is_none())
            .count() as u64;
        Ok(PlanHeader::new(
            params,
            m.seed,
            m.drawn_from(),
            [m.n_negative, m.n_positive],
            n_beyond,
        ))
    }

    /// Trains tree `index` of the forest `train(set, params, seed)` makes
    /// from the set and seed this store was written from: the same tree,
    /// bit for bit, holding at most `budget` of patches (plus one chunk).
    pub fn train_tree(
        &self,
        params: &TrainParams,
        index: usize,
        budget: StoreBudget,
    ) -> Result<TrainedTree> {
        self.train_tree_counted(params, index, budget)
            .map(|(t, _)| t)
    }

    /// [`PatchStore::train_tree`], with what it read.
    pub fn train_tree_counted(
        &self,
        params: &TrainParams,
        index: usize,
        budget: StoreBudget,
    ) -> Result<(TrainedTree, StoreReads)> {
        check_index(params, index)?;
        let header = self.plan_header(params)?;
        let selected: Vec<u32> = (0..self.len() as u32).collect();
        let mut source = StoreSource::new(self, budget);
        let (tree, stats) = grow_tree(
            &mut source,
            &selected,
            params,
            header.class_weights,
            mix(header.seed, index as u64),
        )?;
        let reads = source.reads;
        Ok((
            TrainedTree {
                index,
                tree,
                stats,
                plan: header,
            },
            reads,
        ))
    }

    /// Every tree of the forest, one after another (memory of one tree),
    /// assembled: the model bytes of [`crate::train`] on the set the store
    /// was drawn from.
    pub fn train(&self, params: &TrainParams, budget: StoreBudget) -> Result<Forest> {
        let trees = (0..params.n_trees)
            .map(|t| self.train_tree(params, t, budget))
            .collect::<Result<Vec<_>>>()?;
        assemble(trees)
    }
}
