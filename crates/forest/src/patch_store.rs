//! A patch store: the class-balanced draw of a training set written once as
//! fixed-size chunks of patches on shared storage, so that trees train from
//! it chunk by chunk in bounded memory ([`PatchStore::train_tree`]) instead
//! of holding every Lab image of the set.
//!
//! # Format (version 1)
//! A folder with
//! - `manifest.json`: [`Manifest`] (format name and version, patch size,
//!   counts per class, the chunk list, the draw's seed and parameters, what
//!   the draw was made from, digests of the two sample files);
//! - `labels.u8`: one byte per sample, 1 positive, 0 negative;
//! - `angles.f32le`: the triangulation angle of each sample in degrees,
//!   little-endian f32;
//! - `chunk-NNNNN.bin`: the patches of `chunk_len` consecutive samples (the
//!   last chunk fewer), each [`PATCH_LEN`] bytes: the 27x27 Lab patch
//!   around the pixel, u8, channel-major (L, a, b) then rows, exactly the
//!   bytes split tests read ([`crate::patch::gather`]);
//! - `cols-NNNNN.bin`: the same bytes position-major (byte p of the
//!   chunk's sample s at `p * n + s`): a node too large for memory applies
//!   its chosen test to every sample by reading two rows of n bytes per
//!   chunk instead of the whole chunk, 2 bytes per sample instead of 2187.
//!
//! Samples are the plan's drawn samples ([`crate::TrainingPlan`]) in the
//! set's order, so a tree trained from the store is the tree
//! [`crate::train_tree`] grows from the set, bit for bit. In numpy a chunk
//! is `np.fromfile(path, np.uint8).reshape(-1, 3, 27, 27)`.
//!
//! Why not Parquet or Zarr: training reads single patches at random (a
//! node's 1000 evaluation samples) as well as whole chunks, and a
//! fixed-size record is one positioned read at `index * PATCH_LEN`, with no
//! page to decode. The patches are uncompressed u8 textures that compress
//! poorly, so a columnar container would add a dependency (arrow-rs or
//! zarrs, each larger than this crate) and a decode step for nothing; the
//! manifest and the plain arrays stay readable from any language.

use std::fs::File;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use vp_scene::error::{Location, SceneError};
use vp_scene::outdir::OutDir;

use crate::dataset::TrainingSet;
use crate::error::{ForestError, Result};
use crate::params::TrainParams;
use crate::patch::{gather, PATCH, PATCH_LEN};
use crate::train::{mix, DrawnFrom, TrainingPlan};

/// `format` of a store's manifest.
pub const STORE_FORMAT: &str = "vp-forest patch store";
/// Version of the store format this build reads and writes.
pub const STORE_VERSION: u32 = 1;
/// Samples per chunk by default: 16384 patches, 36 MB per chunk file.
pub const DEFAULT_CHUNK_LEN: usize = 16384;
const MANIFEST: &str = "manifest.json";
const LABELS: &str = "labels.u8";
const ANGLES: &str = "angles.f32le";
/// What to run when a store is missing or unreadable.
pub(crate) const WRITE_HINT: &str =
    "write it with `vpctl-dask store --images IMAGES --labels LABELS --out STORE`";

/// One chunk file of a store.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ChunkEntry {
    /// File name inside the store folder (patch-major).
    pub file: String,
    /// The same patches position-major.
    pub columns: String,
    /// Patches in the file.
    pub n_samples: u64,
}

/// `manifest.json` of a patch store.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Manifest {
    /// [`STORE_FORMAT`].
    pub format: String,
    /// [`STORE_VERSION`].
    pub version: u32,
    /// Patch side in pixels (27).
    pub patch_side: usize,
    /// Bytes per patch (3 x 27 x 27).
    pub patch_len: usize,
    /// Samples in the store.
    pub n_samples: u64,
    /// Positive samples.
    pub n_positive: u64,
    /// Negative samples.
    pub n_negative: u64,
    /// Samples per chunk (the last chunk may hold fewer).
    pub chunk_len: u64,
    /// The chunk files in sample order.
    pub chunks: Vec<ChunkEntry>,
    /// Seed of the draw, and of every tree trained from the store.
    pub seed: u64,
    /// `samples_per_class` of the draw.
    pub samples_per_class: usize,
    /// `balance_classes` of the draw.
    pub balance_classes: bool,
    /// Images of the training set drawn from.
    pub n_images: usize,
    /// Label images of the training set drawn from.
    pub n_label_images: usize,
    /// [negative, positive] samples of the training set drawn from.
    pub available: [u64; 2],
    /// [`TrainingSet::fingerprint`] of the set drawn from.
    pub set_fingerprint: u64,
    /// Digest of `labels.u8`.
    pub labels_digest: u64,
    /// Digest of `angles.f32le`.
    pub angles_digest: u64,
}

impl Manifest {
    pub(crate) fn drawn_from(&self) -> DrawnFrom {
        DrawnFrom {
            n_images: self.n_images,
            n_label_images: self.n_label_images,
            available: self.available,
            set_fingerprint: self.set_fingerprint,
        }
    }
}

fn digest(bytes: &[u8]) -> u64 {
    bytes.chunks(8).fold(bytes.len() as u64, |h, c| {
        let mut w = [0u8; 8];
        w[..c.len()].copy_from_slice(c);
        mix(h, u64::from_le_bytes(w))
    })
}

/// Writes the patch store of the draw `TrainingPlan::new(set, params,
/// seed)` makes into the folder `dir`, `chunk_len` patches per chunk,
/// through [`OutDir`], as every vpctl output folder: refused when `dir` is
/// the current folder, holds one of `inputs` (the images and labels the
/// set came from), holds other files than vpctl's, or is an earlier store
/// without `force`; with `force` only the files vpctl wrote there are
/// replaced. The store appears whole or not at all (built in a sibling
/// folder and swapped in).
///
/// # Performance
/// One pass over the drawn samples, one 2187-byte copy each; the writer
/// holds the set (as [`crate::train`] does) and one chunk.
pub fn write_patch_store(
    set: &TrainingSet,
    params: &TrainParams,
    seed: u64,
    dir: &Path,
    inputs: &[&Path],
    chunk_len: usize,
    force: bool,
) -> Result<Manifest> {
    if chunk_len == 0 {
        return Err(ForestError::InvalidInput(
            "chunk_len must be positive".into(),
        ));
    }
    let target = OutDir::check(dir, "dask store", inputs, force)?;
    let plan = TrainingPlan::new(set, params, seed)?;
    target.write(|stage| write_into(&plan, chunk_len, stage))
}

fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    (|| {
        let mut f = File::create(path)?;
        f.write_all(bytes)?;
        f.sync_all()
    })()
    .map_err(|e| SceneError::io(path, e).into())
}

/// Writes the store's files into the (new, empty) folder `staging`.
fn write_into(plan: &TrainingPlan<'_>, chunk_len: usize, staging: &Path) -> Result<Manifest> {
    let set = plan.set();
    let selected = plan.selected();
    let mut chunks = Vec::new();
    let mut buf = Vec::with_capacity(chunk_len.min(selected.len()) * PATCH_LEN);
    for (k, ids) in selected.chunks(chunk_len).enumerate() {
        buf.clear();
        buf.resize(ids.len() * PATCH_LEN, 0);
        for (&i, out) in ids.iter().zip(buf.chunks_exact_mut(PATCH_LEN)) {
            let s = &set.samples[i as usize];
            gather(&set.images[s.image as usize], s.base as usize, out);
        }
        let file = format!("chunk-{k:05}.bin");
        write_file(&staging.join(&file), &buf)?;
        let n = ids.len();
        let mut cols = vec![0u8; buf.len()];
        for (s, patch) in buf.chunks_exact(PATCH_LEN).enumerate() {
            for (p, &v) in patch.iter().enumerate() {
                cols[p * n + s] = v;
            }
        }
        let columns = format!("cols-{k:05}.bin");
        write_file(&staging.join(&columns), &cols)?;
        chunks.push(ChunkEntry {
            file,
            columns,
            n_samples: ids.len() as u64,
        });
    }
    let labels: Vec<u8> = selected
        .iter()
        .map(|&i| u8::from(set.samples[i as usize].positive))
        .collect();
    let angles: Vec<u8> = selected
        .iter()
        .flat_map(|&i| set.samples[i as usize].angle.to_le_bytes())
        .collect();
    write_file(&staging.join(LABELS), &labels)?;
    write_file(&staging.join(ANGLES), &angles)?;
    let h = plan.header();
    let manifest = Manifest {
        format: STORE_FORMAT.into(),
        version: STORE_VERSION,
        patch_side: PATCH,
        patch_len: PATCH_LEN,
        n_samples: selected.len() as u64,
        n_positive: h.drawn[1],
        n_negative: h.drawn[0],
        chunk_len: chunk_len as u64,
        chunks,
        seed: h.seed,
        samples_per_class: h.params.samples_per_class,
        balance_classes: h.params.balance_classes,
        n_images: h.n_images,
        n_label_images: h.n_label_images,
        available: h.available,
        set_fingerprint: h.set_fingerprint,
        labels_digest: digest(&labels),
        angles_digest: digest(&angles),
    };
    // Serialising plain numbers and strings cannot fail.
    let json = serde_json::to_vec_pretty(&manifest).unwrap_or_default();
    write_file(&staging.join(MANIFEST), &json)?;
    Ok(manifest)
}

/// An opened patch store: the manifest and every sample's label and angle
/// (5 bytes a sample); patches stay on disk until training reads them.
#[derive(Debug, Clone)]
pub struct PatchStore {
    dir: PathBuf,
    manifest: Manifest,
    pub(crate) positive: Vec<bool>,
    pub(crate) angles: Vec<f32>,
}

impl PatchStore {
    /// Opens the store in `dir`: reads and checks the manifest, the labels
    /// and angles (length, digest) and every chunk file's size. Errors name
    /// the file and say how to write a store.
    pub fn open(dir: &Path) -> Result<PatchStore> {
        let mpath = dir.join(MANIFEST);
        let text = std::fs::read(&mpath).map_err(|e| {
            if e.kind() == std::io::ErrorKind::NotFound {
                ForestError::InvalidInput(format!(
                    "{}: no patch store here (no {MANIFEST}); {WRITE_HINT}",
                    dir.display()
                ))
            } else {
                SceneError::io(&mpath, e).into()
            }
        })?;
        let bad = |message: String| -> ForestError {
            SceneError::parse(&mpath, Location::Header, format!("{message}; {WRITE_HINT}")).into()
        };
        let manifest: Manifest = serde_json::from_slice(&text)
            .map_err(|e| bad(format!("not a patch store manifest: {e}")))?;
        if manifest.format != STORE_FORMAT || manifest.version != STORE_VERSION {
            return Err(bad(format!(
                "format {:?} version {}, this build reads {STORE_FORMAT:?} version {STORE_VERSION}",
                manifest.format, manifest.version
            )));
        }
        if manifest.patch_len != PATCH_LEN || manifest.patch_side != PATCH {
            return Err(bad(format!(
                "patches of {} bytes ({}x{}), training reads {PATCH_LEN} ({PATCH}x{PATCH})",
                manifest.patch_len, manifest.patch_side, manifest.patch_side
            )));
        }
        let n = manifest.n_samples;
        let in_chunks: u64 = manifest.chunks.iter().map(|c| c.n_samples).sum();
        let chunk_ok = manifest.chunks.iter().enumerate().all(|(k, c)| {
            c.n_samples == manifest.chunk_len
                || (k + 1 == manifest.chunks.len() && c.n_samples <= manifest.chunk_len)
        });
        if in_chunks != n || !chunk_ok || manifest.n_positive + manifest.n_negative != n {
            return Err(bad(format!(
                "{n} samples ({} positive, {} negative) do not match the chunk list \
                 ({in_chunks} samples, chunks of {})",
                manifest.n_positive, manifest.n_negative, manifest.chunk_len
            )));
        }
        if manifest
            .chunks
            .iter()
            .flat_map(|c| [&c.file, &c.columns])
            .any(|f| f.contains(['/', '\\']) || f.starts_with('.'))
        {
            return Err(bad("a chunk file name leaves the store folder".into()));
        }
        let read = |name: &str, len: u64, want: u64| -> Result<Vec<u8>> {
            let path = dir.join(name);
            let bytes = std::fs::read(&path).map_err(|e| SceneError::io(&path, e))?;
            if bytes.len() as u64 != len || digest(&bytes) != want {
                return Err(SceneError::parse(
                    &path,
                    Location::Byte(0),
                    format!(
                        "{} bytes or their digest do not match {MANIFEST} ({len} bytes); {WRITE_HINT}",
                        bytes.len()
                    ),
                )
                .into());
            }
            Ok(bytes)
        };
        let labels = read(LABELS, n, manifest.labels_digest)?;
        let angles = read(ANGLES, 4 * n, manifest.angles_digest)?;
        let positive: Vec<bool> = labels.iter().map(|&l| l != 0).collect();
        if positive.iter().filter(|&&p| p).count() as u64 != manifest.n_positive {
            return Err(bad("the positive count does not match labels.u8".into()));
        }
        for (c, path) in manifest
            .chunks
            .iter()
            .flat_map(|c| [(c, dir.join(&c.file)), (c, dir.join(&c.columns))])
        {
            let len = std::fs::metadata(&path)
                .map_err(|e| SceneError::io(&path, e))?
                .len();
            if len != c.n_samples * PATCH_LEN as u64 {
                return Err(SceneError::parse(
                    &path,
                    Location::Byte(len),
                    format!(
                        "{len} bytes, {MANIFEST} says {} patches of {PATCH_LEN}: truncated; {WRITE_HINT}",
                        c.n_samples
                    ),
                )
                .into());
            }
        }
        Ok(PatchStore {
            dir: dir.to_path_buf(),
            manifest,
            positive,
            angles: angles
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
        })
    }

    /// The store's folder.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Its manifest.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.positive.len()
    }

    /// Whether it holds no samples.
    pub fn is_empty(&self) -> bool {
        self.positive.is_empty()
    }

    /// Path of chunk `k`, patch-major.
    pub(crate) fn chunk_path(&self, k: usize) -> PathBuf {
        self.dir.join(&self.manifest.chunks[k].file)
    }

    /// Path of chunk `k`, position-major.
    pub(crate) fn columns_path(&self, k: usize) -> PathBuf {
        self.dir.join(&self.manifest.chunks[k].columns)
    }
}

#[cfg(test)]
#[path = "patch_store_tests.rs"]
mod tests;
