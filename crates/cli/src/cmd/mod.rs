//! One module per subcommand group.

pub mod colmap;
pub mod demo;
pub mod depth;
pub mod forest;
pub mod labelgen;
pub mod mesh;
pub mod mission;
pub mod mvs;
pub mod plan;
pub mod scene;
pub mod sim;
pub mod sparse_model;

use std::error::Error;

use vp_forest::ForestError;
use vp_labelgen::LabelgenError;
use vp_mission::MissionError;
use vp_mvs::MvsError;
use vp_planner::PlannerError;
use vp_scene::SceneError;
use vp_sim::SimError;

/// A wrong use of the command line that only the CLI can see (conflicting
/// or missing flags): exit code 2, like every input error.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// Exit code when a check ran and found problems (`vpctl mesh info` on a
/// mesh with defects): distinct from 2 (the input could not be read at all)
/// and from the mission codes 3-7.
pub const EXIT_PROBLEMS_FOUND: u8 = 8;

/// A check that ran to the end and found problems: exit code
/// [`EXIT_PROBLEMS_FOUND`].
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct ProblemsFound(pub String);

/// Exit code for an error: 2 when the user's input is at fault (bad file,
/// bad argument, refusing to overwrite, missing file, bad URL), 1 otherwise
/// (I/O failures). Mission failures have one code per outcome
/// ([`MissionError::exit_code`]: 3 no vehicle, 4 timeout, 5 rejected,
/// 6 verification failed, 7 protocol violation, 9 signing); a check that found
/// problems exits [`EXIT_PROBLEMS_FOUND`]. The outermost library
/// error in the chain decides.
pub fn exit_code(e: &anyhow::Error) -> u8 {
    if e.chain()
        .any(|c| c.downcast_ref::<ProblemsFound>().is_some())
    {
        return EXIT_PROBLEMS_FOUND;
    }
    if let Some(m) = e.chain().find_map(|c| c.downcast_ref::<MissionError>()) {
        return m.exit_code();
    }
    e.chain()
        .find_map(is_input_error)
        .map_or(1, |input| if input { 2 } else { 1 })
}

/// Whether `e` is an input error, if it is one of the libraries' errors.
fn is_input_error(e: &(dyn Error + 'static)) -> Option<bool> {
    (e.downcast_ref::<SceneError>()
        .map(SceneError::is_input_error))
    .or_else(|| {
        e.downcast_ref::<ForestError>()
            .map(ForestError::is_input_error)
    })
    .or_else(|| {
        e.downcast_ref::<LabelgenError>()
            .map(LabelgenError::is_input_error)
    })
    .or_else(|| {
        e.downcast_ref::<PlannerError>()
            .map(PlannerError::is_input_error)
    })
    .or_else(|| {
        e.downcast_ref::<MissionError>()
            .map(MissionError::is_input_error)
    })
    .or_else(|| e.downcast_ref::<SimError>().map(SimError::is_input_error))
    .or_else(|| e.downcast_ref::<MvsError>().map(MvsError::is_input_error))
    .or_else(|| e.downcast_ref::<UsageError>().map(|_| true))
}

/// Refuses an output path whose extension is not one of `expected`
/// (lower case, no dot), naming the extension found and the flag.
pub fn check_extension(
    path: &std::path::Path,
    flag: &str,
    expected: &[&str],
) -> anyhow::Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if expected.contains(&ext.as_str()) {
        return Ok(());
    }
    let want: Vec<String> = expected.iter().map(|e| format!(".{e}")).collect();
    let found = if ext.is_empty() {
        "no extension".to_string()
    } else {
        format!("the extension '.{ext}'")
    };
    Err(UsageError(format!(
        "{flag} {}: {found} is not a file type this output writes (expected {})",
        path.display(),
        want.join(" or ")
    ))
    .into())
}

/// Refuses, before any work, an output path whose folder does not exist or
/// cannot be written (probed with a temporary file that is removed again),
/// naming the flag and the file: exit code 2, nothing written.
pub fn check_output_writable(path: &std::path::Path, flag: &str) -> anyhow::Result<()> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => std::path::Path::new("."),
    };
    if let Err(e) = vp_scene::fsio::check_parent_exists(path) {
        return Err(UsageError(format!("{flag} {e}")).into());
    }
    let name = path
        .file_name()
        .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
    let probe = dir.join(format!(".{name}.probe-{}", std::process::id()));
    match std::fs::File::create(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(UsageError(format!(
            "{flag} {}: cannot write in {}: {e}",
            path.display(),
            dir.display()
        ))
        .into()),
    }
}

pub use crate::progress::Progress;

/// Prints what a reader accepted with a warning to standard error: the
/// library returns these, the CLI tells the user.
pub fn print_warnings(warnings: &[vp_scene::io::ReadWarning]) {
    for w in warnings {
        eprintln!("warning: {w}");
    }
}

/// [`vp_scene::io::read_mesh`], its warnings printed.
pub fn read_mesh(path: &std::path::Path) -> vp_scene::Result<vp_scene::Mesh> {
    let (mesh, warnings) = vp_scene::io::read_mesh_with_warnings(path)?;
    print_warnings(&warnings);
    Ok(mesh)
}
