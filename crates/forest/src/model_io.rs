//! The model file.
//!
//! Layout (little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `VPFOREST` |
//! | 4 | format version (u32, [`FORMAT_VERSION`]) |
//! | 4 | header length h (u32) |
//! | h | header, JSON: `{"params": TrainParams, "summary": TrainingSummary}`; the params hold the bin edges |
//! | 4 | number of trees (u32) |
//! | per tree | node count n (u32), leaf count l (u32), n nodes of 13 bytes, l x (2 + 2b) leaf counts (u32) |
//! | 8 | FNV-1a 64 ([`vp_scene::binfile::fnv1a64`]) of all preceding bytes |
//!
//! A node: kind (u8: 0 split, 1 leaf), channel (u8), op (u8), offset1 dx,
//! dy, offset2 dx, dy (i8 each), threshold (i16), child (u32: left child of
//! a split, leaf index of a leaf). Leaf counts: positive total, negative
//! total, then (positive, negative) per angle bin. Confidences are derived
//! from the counts when loading, so the file holds no redundant floats.

use std::path::Path;

use serde::{Deserialize, Serialize};
use vp_scene::binfile::{checksummed, ByteReader};
use vp_scene::fsio::{read_file, write_file_atomic};

use crate::error::{ForestError, Result};
use crate::params::{TrainParams, TrainingSummary, MAX_DEPTH_LIMIT};
use crate::patch::{SplitTest, TestOp};
use crate::train::{PlanHeader, TrainedTree, TreeStats};
use crate::tree::{Node, Tree};
use crate::Forest;

/// First bytes of every model file.
pub const MAGIC: [u8; 8] = *b"VPFOREST";
/// Version of the layout this build writes and reads.
pub const FORMAT_VERSION: u32 = 1;
const NODE_BYTES: usize = 13;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    params: TrainParams,
    summary: TrainingSummary,
}

impl Forest {
    /// Serialises the model (see the module docs for the layout).
    pub fn to_bytes(&self) -> Vec<u8> {
        let header = Header {
            params: self.params().clone(),
            summary: self.summary().clone(),
        };
        // Serialising plain numbers and strings cannot fail.
        let json = serde_json::to_vec(&header).unwrap_or_default();
        checksummed(MAGIC, FORMAT_VERSION, |out| {
            out.extend_from_slice(&(json.len() as u32).to_le_bytes());
            out.extend_from_slice(&json);
            out.extend_from_slice(&(self.trees().len() as u32).to_le_bytes());
            for tree in self.trees() {
                write_tree(out, tree);
            }
        })
    }

    /// Writes the model atomically (a failed write leaves no file). Replaces
    /// an existing file: callers check with `fsio::check_overwrite` first.
    pub fn save(&self, path: &Path) -> Result<()> {
        Ok(write_file_atomic(path, &self.to_bytes())?)
    }

    /// The model's fingerprint: the FNV-1a 64 checksum its file ends with
    /// (the last 8 bytes of [`Forest::to_bytes`], little-endian), so a
    /// forest in memory, in a file and in a campaign report can be told
    /// apart or matched. Two campaigns fly the same forest exactly when
    /// they show the same fingerprint (up to FNV's rare collisions): a
    /// forest trained on other labels, even one pixel's, is another model
    /// and plans other flights (docs/campaign-findings.md, "Why SGM's
    /// F5x4 moved").
    pub fn fingerprint(&self) -> u64 {
        self.to_bytes()
            .last_chunk::<8>()
            .map_or(0, |b| u64::from_le_bytes(*b))
    }

    /// Reads a model file.
    pub fn load(path: &Path) -> Result<Forest> {
        Self::from_bytes(&read_file(path)?, path)
    }

    /// Parses a model; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Forest> {
        let mut r = Reader(ByteReader::open_checksummed(
            path,
            bytes,
            MAGIC,
            FORMAT_VERSION,
            ("vp-forest model", "`vpctl train` (or `vpctl sim train`)"),
        )?);
        let header_len = r.u32("header length")? as usize;
        let at = r.0.pos();
        let header: Header = serde_json::from_slice(r.take(header_len, "header")?)
            .map_err(|e| r.error(at, &format!("model header: {e}")))?;
        header
            .params
            .validate()
            .map_err(|e| r.error(at, &e.to_string()))?;
        let params = header.params;
        let weights = header.summary.class_weights;
        if !weights.iter().all(|w| w.is_finite() && *w > 0.0) {
            return Err(r.error(at, "model header: class weights must be positive"));
        }
        let at = r.0.pos();
        let n_trees = r.u32("tree count")? as usize;
        if n_trees != params.n_trees {
            return Err(r.error(
                at,
                &format!("{n_trees} trees, the header says {}", params.n_trees),
            ));
        }
        let b = params.bins.len();
        let mut trees = Vec::with_capacity(n_trees);
        for t in 0..n_trees {
            trees.push(r.tree(t, b, weights, params.pseudo_count)?);
        }
        r.0.finish("the last tree")?;
        Ok(Forest::from_parts(params, header.summary, trees))
    }
}

/// Appends one tree in the model's layout (node count, leaf count, nodes, leaf counts).
fn write_tree(out: &mut Vec<u8>, tree: &Tree) {
    out.extend_from_slice(&(tree.nodes().len() as u32).to_le_bytes());
    out.extend_from_slice(&(tree.n_leaves() as u32).to_le_bytes());
    for n in tree.nodes() {
        let t = &n.test;
        out.extend_from_slice(&[
            u8::from(n.is_leaf),
            t.channel,
            t.op as u8,
            t.offset1.0 as u8,
            t.offset1.1 as u8,
            t.offset2.0 as u8,
            t.offset2.1 as u8,
        ]);
        out.extend_from_slice(&n.threshold.to_le_bytes());
        out.extend_from_slice(&n.child.to_le_bytes());
    }
    for c in tree.raw_counts() {
        out.extend_from_slice(&c.to_le_bytes());
    }
}

/// First bytes of one tree of a distributed training run ([`TrainedTree::to_bytes`]).
pub const TREE_MAGIC: [u8; 8] = *b"VPFTREE\0";
/// Version of the tree layout this build writes and reads.
pub const TREE_FORMAT_VERSION: u32 = 1;

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TreeHeader {
    index: usize,
    plan: PlanHeader,
    stats: TreeStats,
}

impl TrainedTree {
    /// Serialises the tree for transport between processes: magic
    /// [`TREE_MAGIC`], version, a JSON header (index, the shared training
    /// plan, the tree's statistics), the tree in the model file's layout,
    /// FNV-1a 64 checksum.
    pub fn to_bytes(&self) -> Vec<u8> {
        let header = TreeHeader {
            index: self.index,
            plan: self.plan.clone(),
            stats: self.stats,
        };
        // Serialising plain numbers and strings cannot fail.
        let json = serde_json::to_vec(&header).unwrap_or_default();
        checksummed(TREE_MAGIC, TREE_FORMAT_VERSION, |out| {
            out.extend_from_slice(&(json.len() as u32).to_le_bytes());
            out.extend_from_slice(&json);
            write_tree(out, &self.tree);
        })
    }

    /// Parses [`TrainedTree::to_bytes`]; `path` only names the source in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<TrainedTree> {
        let mut r = Reader(ByteReader::open_checksummed(
            path,
            bytes,
            TREE_MAGIC,
            TREE_FORMAT_VERSION,
            (
                "vp-forest tree",
                "distributed training (`vpctl.distributed`)",
            ),
        )?);
        let header_len = r.u32("header length")? as usize;
        let at = r.0.pos();
        let header: TreeHeader = serde_json::from_slice(r.take(header_len, "header")?)
            .map_err(|e| r.error(at, &format!("tree header: {e}")))?;
        let plan = header.plan;
        plan.params
            .validate()
            .map_err(|e| r.error(at, &e.to_string()))?;
        if !plan.class_weights.iter().all(|w| w.is_finite() && *w > 0.0) {
            return Err(r.error(at, "tree header: class weights must be positive"));
        }
        if header.index >= plan.params.n_trees {
            return Err(r.error(
                at,
                &format!(
                    "tree index {} of a forest of {} trees",
                    header.index, plan.params.n_trees
                ),
            ));
        }
        let tree = r.tree(
            header.index,
            plan.params.bins.len(),
            plan.class_weights,
            plan.params.pseudo_count,
        )?;
        r.0.finish("the tree")?;
        Ok(TrainedTree {
            index: header.index,
            tree,
            stats: header.stats,
            plan,
        })
    }
}

/// The model's body reader: the shared little-endian reader plus the
/// model's own element parsers.
struct Reader<'a>(ByteReader<'a>);

impl<'a> Reader<'a> {
    /// Reads tree `t` (b angle bins) and checks it.
    fn tree(&mut self, t: usize, b: usize, weights: [f64; 2], pseudo_count: f64) -> Result<Tree> {
        let at = self.0.pos();
        let n_nodes = self.u32("node count")? as usize;
        let n_leaves = self.u32("leaf count")? as usize;
        let raw = self.take(n_nodes.saturating_mul(NODE_BYTES), "nodes")?;
        let mut nodes = Vec::with_capacity(n_nodes);
        for (i, c) in raw.chunks_exact(NODE_BYTES).enumerate() {
            let node_at = at + 8 + i * NODE_BYTES;
            let op = TestOp::from_code(c[2]).ok_or_else(|| {
                self.error(
                    node_at,
                    &format!("tree {t} node {i}: unknown test type {}", c[2]),
                )
            })?;
            if c[0] > 1 {
                return Err(self.error(
                    node_at,
                    &format!("tree {t} node {i}: unknown node kind {}", c[0]),
                ));
            }
            nodes.push(Node {
                test: SplitTest {
                    channel: c[1],
                    op,
                    offset1: (c[3] as i8, c[4] as i8),
                    offset2: (c[5] as i8, c[6] as i8),
                },
                threshold: i16::from_le_bytes([c[7], c[8]]),
                child: u32::from_le_bytes([c[9], c[10], c[11], c[12]]),
                is_leaf: c[0] == 1,
            });
        }
        let raw = self.take(n_leaves.saturating_mul(4 * (2 + 2 * b)), "leaf counts")?;
        let counts = raw
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let tree = Tree::from_parts(nodes, counts, b, weights, pseudo_count)
            .map_err(|e| self.error(at, &format!("tree {t}: {e}")))?;
        let depth = tree.node_depths().into_iter().max().unwrap_or(0) as usize;
        if depth > MAX_DEPTH_LIMIT {
            return Err(self.error(
                at,
                &format!("tree {t} is {depth} levels deep (at most {MAX_DEPTH_LIMIT})"),
            ));
        }
        Ok(tree)
    }

    fn error(&self, offset: usize, message: &str) -> ForestError {
        self.0.error_at(offset, message).into()
    }

    fn take(&mut self, n: usize, what: &str) -> Result<&'a [u8]> {
        Ok(self.0.take(n, what)?)
    }

    fn u32(&mut self, what: &str) -> Result<u32> {
        Ok(self.0.u32(what)?)
    }
}
