//! `vpctl plan ...` and `vpctl config --defaults`: view planning.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::{Args, Subcommand};
use vp_planner::PlannerConfig;
use vp_scene::datum::VerticalDatum;
use vp_scene::plan::GeodeticOrigin;

mod common;
mod grid;
mod model;
mod summary;

/// Plan the next camera triplets (the paper's M1-M4) from a mesh and the
/// acquired cameras, or a grid flight (`vpctl plan grid`).
///
/// Progress and per-module timings go to stderr; a summary to stdout.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct PlanArgs {
    #[command(subcommand)]
    sub: Option<PlanCommand>,
    /// Scene mesh (.ply or .obj), in the frame of the COLMAP model.
    #[arg(long, required = true)]
    mesh: Option<PathBuf>,
    /// The acquired cameras: `--colmap DIR` or `--opensfm DIR`.
    #[command(flatten)]
    model: super::sparse_model::SparseModelArgs,
    /// Directory of confidence images: `<image name>.vpconf` (extension
    /// replaced) per image of the model. Without it: no prediction (NP).
    #[arg(long)]
    confidence_dir: Option<PathBuf>,
    #[command(flatten)]
    common: Common,
    /// Leave wall-clock timings out of the plan file, so that the same
    /// inputs and seed give the same bytes.
    #[arg(long)]
    no_timings: bool,
    /// Plan even when the model has no `frame.json` from `vpctl colmap
    /// align` or its scale or gravity look implausible: only for a model
    /// already in metric, gravity-aligned local ENU.
    #[arg(long)]
    frame_unchecked: bool,
    /// The take-off point is on the ground straight below the first image
    /// (by name): its projection centre dropped along gravity onto --mesh.
    /// For a first flight launched under its first photo; otherwise --home.
    #[arg(long, conflicts_with = "home")]
    home_from_first_image: bool,
}

/// Options shared by `plan` and `plan grid`.
#[derive(Debug, Args)]
struct Common {
    /// Region of interest: inline JSON or a JSON file. One of
    /// {"kind": "box", "min": [x, y, z], "max": [x, y, z]},
    /// {"kind": "polygon", "polygon": [[x, y], ...], "z_min": z, "z_max": z}
    /// or {"kind": "image_polygon", "camera": {...}, "polygon": [[u, v], ...]}
    /// (metres, local ENU; pixels; docs/formats.md). Default: the whole mesh.
    #[arg(long, conflicts_with = "roi_box", value_name = "JSON|FILE")]
    roi: Option<String>,
    /// Region of interest box: xmin,ymin,zmin,xmax,ymax,zmax (metres).
    #[arg(long, allow_hyphen_values = true, value_parser = floats::<6>)]
    roi_box: Option<[f64; 6]>,
    /// Region of interest drawn on a map: a polygon in longitude/latitude
    /// (WGS84) from a .kml or .kmz (Google Earth) or .geojson/.json file
    /// (QGIS), placed through the plan's origin (the model's frame.json or
    /// --origin). Holes are cut out; faces at every height count unless
    /// --roi-heights (docs/formats.md, "ROI files").
    #[arg(long, conflicts_with_all = ["roi", "roi_box"], value_name = "FILE")]
    roi_polygon: Option<PathBuf>,
    /// Which polygon of a --roi-polygon file holding several: its
    /// Placemark name (KML) or feature property "name" (GeoJSON).
    #[arg(long, requires = "roi_polygon", value_name = "NAME")]
    roi_name: Option<String>,
    /// Height range of the --roi-polygon area: MIN,MAX (metres in the
    /// plan's local frame, as --roi-box). Default: every height.
    #[arg(long, requires = "roi_polygon", allow_hyphen_values = true, value_parser = floats::<2>, value_name = "MIN,MAX")]
    roi_heights: Option<[f64; 2]>,
    /// Planner configuration (TOML; `vpctl config --defaults` prints one),
    /// or a campaign config (`vpctl sim config`), whose `[planner]` section is used;
    /// missing keys take the planner's defaults.
    #[arg(long)]
    config: Option<PathBuf>,
    /// WGS84 position of the local origin: lat,lon,alt (degrees, metres).
    #[arg(long, allow_hyphen_values = true, value_parser = floats::<3>)]
    origin: Option<[f64; 3]>,
    /// What --origin's altitude is measured from: egm96 (above mean sea
    /// level), ellipsoid (WGS84) or takeoff. A model's frame.json says it
    /// for its own origin.
    #[arg(long, value_name = "DATUM", requires = "origin")]
    datum: Option<VerticalDatum>,
    /// Where the vehicle takes off: LAT,LON,ALT[,DATUM] (degrees, metres on
    /// the ground; DATUM egm96, ellipsoid or takeoff, default the plan's).
    /// Mission altitudes are heights above it; a mission cannot be exported
    /// from a plan without a home.
    #[arg(long, value_name = "LAT,LON,ALT[,DATUM]", allow_hyphen_values = true, value_parser = home_arg)]
    home: Option<HomeArg>,
    /// Output plan (JSON).
    #[arg(long, required = true)]
    out: Option<PathBuf>,
    /// Also write the planned cameras as pyramids (PLY) for MeshLab/CloudCompare.
    #[arg(long)]
    ply: Option<PathBuf>,
    /// Also write a top view (PNG): mesh shaded by f(t), ROI, acquired and
    /// planned cameras, path; title, legend and colour keys below.
    #[arg(long)]
    png: Option<PathBuf>,
    /// Also write a 3D scene (glTF 2.0 binary, .glb) for any glTF viewer:
    /// the mesh, the acquired and planned cameras as frusta, the flight
    /// path. Written Y-up as glTF wants (ENU x, z, -y).
    #[arg(long)]
    glb: Option<PathBuf>,
    /// Longest flight on one battery, seconds: splits the plan into flights
    /// that each start and end at home and take at most this less the
    /// reserve (`[mission] reserve_s`, default 120 s). Needs a home.
    #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
    max_flight_time: Option<f64>,
    /// Overwrite existing output files.
    #[arg(long)]
    force: bool,
}

/// `--home LAT,LON,ALT[,DATUM]`.
#[derive(Debug, Clone, Copy)]
pub struct HomeArg {
    /// Latitude, longitude and altitude.
    pub position: GeodeticOrigin,
    /// The altitude's datum, if given.
    pub datum: Option<VerticalDatum>,
}

/// Parses `--home LAT,LON,ALT[,DATUM]` (also used by `vpctl mission`).
pub fn home_arg(s: &str) -> std::result::Result<HomeArg, String> {
    let (nums, datum) = match s.rsplit_once(',') {
        Some((head, tail)) if tail.trim().parse::<f64>().is_err() => (
            head,
            Some(tail.parse::<VerticalDatum>().map_err(|e| e.to_string())?),
        ),
        _ => (s, None),
    };
    let [lat, lon, alt] = floats::<3>(nums)?;
    let position = GeodeticOrigin::new(lat, lon, alt).map_err(|e| e.to_string())?;
    Ok(HomeArg { position, datum })
}

/// Parses `N` comma-separated numbers (`--roi-box -5,-5,0,5,5,10`).
fn floats<const N: usize>(s: &str) -> std::result::Result<[f64; N], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| x.trim().parse::<f64>().map_err(|e| format!("{x:?}: {e}")))
        .collect::<std::result::Result<_, _>>()?;
    <[f64; N]>::try_from(v.as_slice())
        .map_err(|_| format!("expected {N} comma-separated numbers, got {}", v.len()))
        .and_then(|a| {
            if a.iter().all(|x| x.is_finite()) {
                Ok(a)
            } else {
                Err("numbers must be finite".into())
            }
        })
}

/// Plan subcommands.
#[derive(Debug, Subcommand)]
enum PlanCommand {
    /// A lawnmower grid flight over the region of interest (the paper's
    /// baseline, or an initial flight), checked against the safety distance.
    Grid(GridArgs),
}

#[derive(Debug, Args)]
struct GridArgs {
    /// Scene mesh (.ply or .obj).
    #[arg(long)]
    mesh: PathBuf,
    /// Height above the lowest point of the region of interest, metres.
    #[arg(long, allow_negative_numbers = true, default_value_t = 50.0)]
    height: f64,
    /// Ground sampling distance (m/px) instead of a height.
    #[arg(long, allow_negative_numbers = true, conflicts_with = "height")]
    gsd: Option<f64>,
    /// Front and side overlap, in [0, 1).
    #[arg(long, allow_negative_numbers = true, default_value_t = 0.8)]
    overlap: f64,
    /// Side overlap, if different from --overlap.
    #[arg(long, allow_negative_numbers = true)]
    side_overlap: Option<f64>,
    /// Camera pitch, degrees (-90 nadir).
    #[arg(long, default_value_t = -90.0, allow_negative_numbers = true)]
    pitch: f64,
    /// Direction of the flight lines, degrees counter-clockwise from east.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    yaw: f64,
    /// Mark the views as an initial flight instead of a grid baseline.
    #[arg(long)]
    initial: bool,
    #[command(flatten)]
    common: Common,
}

/// Print configuration files.
#[derive(Debug, Args)]
pub struct ConfigArgs {
    /// Print the planner configuration with every default, commented.
    #[arg(long, required = true)]
    defaults: bool,
}

/// `vpctl config --defaults`.
pub fn run_config(_args: ConfigArgs, out: &mut dyn Write) -> Result<()> {
    out.write_all(PlannerConfig::default_toml().as_bytes())?;
    Ok(())
}

/// `vpctl plan ...`.
pub fn run(args: PlanArgs, out: &mut dyn Write) -> Result<()> {
    match args.sub {
        Some(PlanCommand::Grid(g)) => grid::grid(&g, out),
        None => model::plan(&args, out),
    }
}
