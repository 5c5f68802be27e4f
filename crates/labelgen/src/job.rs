//! The front door of a labelling run: the one library entry `vpctl labelgen
//! run`, the Python `vpctl.labelgen.run` and the Dask workers
//! (`vpctl.distributed`) all call, so that each loads the same inputs the
//! same way (the frame check, the triplet list, the depth folder, the mesh
//! for missing parts) and writes the same label folder.
//!
//! [`load_label_run`] reads everything a run needs; [`run_labelling`] checks
//! the output folder first, loads, labels ([`crate::generate_labels`]) and
//! writes the labels and `summary.json` through a
//! [`vp_scene::outdir::OutDir`], so a failure leaves no partial folder.
//!
//! The request is `#[non_exhaustive]` with a constructor: a new option is a
//! new field with a default, and no caller breaks.

use std::path::{Path, PathBuf};

use vp_scene::io::ReadWarning;
use vp_scene::opensfm::ModelSource;
use vp_scene::outdir::OutDir;
use vp_scene::Location;

use crate::error::Result;
use crate::{generate_labels, TripletReconstruction};
use crate::{io, triplets, LabelParams, LabelSummary, MissingPartMeshes, ReconLabels};

/// A labelling run, as `vpctl labelgen run` takes it.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct LabelRunRequest {
    /// The sparse model with the poses of every image: a COLMAP model
    /// (with `frame.json`) or an OpenSfM reconstruction (georeferenced by
    /// its own reference), of the undistorted images the depth maps are of.
    pub model: ModelSource,
    /// The triplet list (`vpctl labelgen triplets`).
    pub triplets: PathBuf,
    /// The depth folder: `<triplet id>/level<L>/<image>.geometric.bin`.
    pub depth_dir: PathBuf,
    /// A surface mesh for missing-part negatives (stage 3); without it,
    /// holes stay unlabelled.
    pub mesh: Option<PathBuf>,
    /// Label parameters.
    pub params: LabelParams,
    /// Skip the frame check: the model is already metric, gravity-aligned
    /// local ENU.
    pub frame_unchecked: bool,
}

impl LabelRunRequest {
    /// Default parameters, no mesh, the frame checked.
    pub fn new(
        model: ModelSource,
        triplets: impl Into<PathBuf>,
        depth_dir: impl Into<PathBuf>,
    ) -> Self {
        LabelRunRequest {
            model,
            triplets: triplets.into(),
            depth_dir: depth_dir.into(),
            mesh: None,
            params: LabelParams::default(),
            frame_unchecked: false,
        }
    }

    /// The files and folders the run reads (which its output may not hold).
    pub fn inputs(&self) -> Vec<&Path> {
        [self.model.path(), &self.triplets, &self.depth_dir]
            .into_iter()
            .chain(self.mesh.as_deref())
            .collect()
    }
}

/// Everything a labelling run reads, loaded.
pub struct LabelRun {
    /// Every (triplet, level) reconstruction, in id order.
    pub reconstructions: Vec<TripletReconstruction>,
    /// The missing-part meshes, when a mesh was given.
    pub meshes: Option<MissingPartMeshes>,
    /// The parameters (validated).
    pub params: LabelParams,
    /// What the mesh was read with a warning, for the caller to tell.
    pub warnings: Vec<ReadWarning>,
}

/// Loads the run of `req`: the model (frame-checked unless told not to),
/// the triplet list, the depth maps and the mesh. Errors name the file.
pub fn load_label_run(req: &LabelRunRequest) -> Result<LabelRun> {
    req.params.validate()?;
    // The same reading and frame check as `vpctl plan`'s, for either kind
    // of model: an OpenSfM camera with distortion is refused there, naming
    // the undistort step (the depth maps are of undistorted images).
    let posed = req.model.read_posed(req.frame_unchecked)?;
    let mut warnings: Vec<ReadWarning> = posed
        .notes
        .into_iter()
        .map(|message| ReadWarning {
            path: req.model.path().to_path_buf(),
            location: Location::Header,
            message,
        })
        .collect();
    let list = triplets::read_triplet_list(&req.triplets)?;
    let reconstructions = io::load_reconstructions(&posed.reconstruction, &list, &req.depth_dir)?;
    let meshes = match &req.mesh {
        Some(p) => {
            let (mesh, read) = vp_scene::io::read_mesh_with_warnings(p)?;
            warnings.extend(read);
            Some(MissingPartMeshes::new(&mesh, req.params.mesh_iterations))
        }
        None => None,
    };
    Ok(LabelRun {
        reconstructions,
        meshes,
        params: req.params.clone(),
        warnings,
    })
}

impl LabelRun {
    /// Labels every view of every reconstruction (stages 1-3).
    pub fn label(&self) -> Result<Vec<ReconLabels>> {
        generate_labels(&self.reconstructions, self.meshes.as_ref(), &self.params)
    }
}

/// Where a labelling run writes.
#[derive(Debug, Clone)]
pub struct LabelOutput {
    /// The output folder: `<triplet id>/level<L>/<image>.vplabel` and
    /// `summary.json`.
    pub out: PathBuf,
    /// Other files the job read (the config), which `out` may not hold.
    pub inputs: Vec<PathBuf>,
    /// Replace an earlier `labelgen run` output in `out` (only vpctl's files).
    pub force: bool,
}

/// The labelling run of `req` into `output` (see the module doc); returns
/// the summary written to `summary.json` and what the inputs were read
/// with a warning (for the caller to tell).
pub fn run_labelling(
    req: &LabelRunRequest,
    output: &LabelOutput,
) -> Result<(LabelSummary, Vec<ReadWarning>)> {
    run_labelling_with_progress(req, output, &mut |_| {})
}

/// [`run_labelling`], naming each stage through `progress` as it starts
/// (loading, labelling, writing), so that a caller can say what runs.
pub fn run_labelling_with_progress(
    req: &LabelRunRequest,
    output: &LabelOutput,
    progress: &mut dyn FnMut(&str),
) -> Result<(LabelSummary, Vec<ReadWarning>)> {
    let mut inputs = req.inputs();
    inputs.extend(output.inputs.iter().map(PathBuf::as_path));
    let target = OutDir::check(&output.out, "labelgen run", &inputs, output.force)?;
    progress("loading the model, the triplets and the depth maps");
    let run = load_label_run(req)?;
    progress("labelling (support, voting, missing parts)");
    let labels = run.label()?;
    progress("writing the labels");
    let summary = target.write(|stage| io::write_labels(stage, &labels, false))?;
    Ok((summary, run.warnings))
}
