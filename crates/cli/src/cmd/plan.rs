//! `vpctl plan ...` and `vpctl config --defaults`: view planning.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::{bail, Result};
use clap::{Args, Subcommand};
use nalgebra::Point3;
use vp_planner::grid::GridParams;
use vp_planner::{
    GridRequest, HomeSpec, ModelPlanRequest, PlanContext, PlanOutputs, PlannerConfig, RoiSpec,
};
use vp_scene::datum::VerticalDatum;
use vp_scene::opensfm::ModelSource;
use vp_scene::plan::{GeodeticOrigin, Plan, Role};
use vp_scene::roi::Roi;
use vp_scene::{fsio, Camera, Mesh};

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
    /// COLMAP sparse model directory (text or binary): the acquired cameras.
    #[arg(
        long = "colmap",
        alias = "cameras",
        required_unless_present = "opensfm",
        value_name = "DIR"
    )]
    cameras: Option<PathBuf>,
    /// Or an OpenSfM reconstruction: an OpenDroneMap project folder, its
    /// `opensfm` folder or `reconstruction.json`; georeferenced by its
    /// `reference_lla`, so no `colmap align` (docs/formats.md).
    #[arg(long, value_name = "DIR", conflicts_with = "cameras")]
    opensfm: Option<PathBuf>,
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
    /// or a campaign config (`vpctl sim config`), whose `[planner]` section is used.
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
        Some(PlanCommand::Grid(g)) => grid(&g, out),
        None => plan(&args, out),
    }
}

fn required<'a>(v: Option<&'a PathBuf>, flag: &str) -> Result<&'a Path> {
    match v {
        Some(p) => Ok(p),
        None => bail!("{flag} is required"),
    }
}

impl Common {
    fn config(&self) -> Result<PlannerConfig> {
        let mut cfg = match &self.config {
            Some(p) => load_planner_config(p)?,
            None => PlannerConfig::default(),
        };
        if let Some(t) = self.max_flight_time {
            cfg.mission.max_flight_time_s = Some(t);
        }
        cfg.validate()?;
        Ok(cfg)
    }

    fn roi(&self) -> Result<RoiSpec> {
        if let Some(b) = &self.roi_box {
            return Ok(RoiSpec::Region(Roi::from_box(*b)?));
        }
        if let Some(p) = &self.roi_polygon {
            return Ok(RoiSpec::from_area_file(
                p,
                self.roi_name.as_deref(),
                self.roi_heights.map(|[lo, hi]| (lo, hi)),
            )?);
        }
        Ok(match &self.roi {
            Some(arg) => RoiSpec::Region(parse_roi(arg)?),
            None => RoiSpec::All,
        })
    }

    fn origin(&self) -> Result<Option<GeodeticOrigin>> {
        self.origin
            .as_ref()
            .map(|o| Ok(GeodeticOrigin::new(o[0], o[1], o[2])?))
            .transpose()
    }

    fn home(&self, from_first_image: bool) -> HomeSpec {
        match (self.home, from_first_image) {
            (Some(h), _) => HomeSpec::At {
                position: h.position,
                datum: h.datum,
            },
            (None, true) => HomeSpec::FirstImage,
            (None, false) => HomeSpec::Unset,
        }
    }

    /// Refuses early, before any work, when an output exists.
    fn check_outputs(&self) -> Result<PlanOutputs> {
        let out = required(self.out.as_ref(), "--out")?;
        super::check_extension(out, "--out", &["json"])?;
        if let Some(p) = &self.ply {
            super::check_extension(p, "--ply", &["ply"])?;
        }
        if let Some(p) = &self.png {
            super::check_extension(p, "--png", &["png"])?;
        }
        if let Some(p) = &self.glb {
            super::check_extension(p, "--glb", &["glb"])?;
        }
        for (p, flag) in [
            (Some(out), "--out"),
            (self.ply.as_deref(), "--ply"),
            (self.png.as_deref(), "--png"),
            (self.glb.as_deref(), "--glb"),
        ] {
            if let Some(p) = p {
                // The flag-naming check first: it names which option the
                // missing folder belongs to.
                super::check_output_writable(p, flag)?;
                fsio::check_output_file(p, self.force)?;
            }
        }
        Ok(PlanOutputs {
            plan: out.to_path_buf(),
            ply: self.ply.clone(),
            png: self.png.clone(),
            glb: self.glb.clone(),
            force: self.force,
        })
    }
}

/// `--roi`: inline JSON (starting with `{`) or the path of a JSON file.
fn parse_roi(arg: &str) -> Result<Roi> {
    if arg.trim_start().starts_with('{') {
        return serde_json::from_str(arg).map_err(|e| {
            super::UsageError(format!(
                "--roi: column {}: not a region of interest ({{\"kind\": \"box\" | \
                 \"polygon\" | \"image_polygon\", ...}}, see docs/formats.md): {e}",
                e.column()
            ))
            .into()
        });
    }
    Ok(Roi::load(Path::new(arg))?)
}

/// A planner config, or a campaign config's `[planner]` section (a file
/// with a `[site]` or `[planner]` table), so that the config `sim fly
/// --site` flies with plans with the same camera.
pub fn load_planner_config(path: &Path) -> Result<PlannerConfig> {
    let text = fsio::read_text(path)?;
    let table: toml::Table = vp_scene::config_file::parse_toml(&text, path)?;
    if table.contains_key("planner") || table.contains_key("site") {
        let mut planner = vp_sim::campaign::CampaignConfig::from_toml(&text, path)?.planner;
        // The campaign presets' simulated drone flies RTK; a real mission
        // planned with such a file takes its GNSS class from the file itself
        // or from the model's frame.json, never from the simulator's preset.
        let stated = table
            .get("planner")
            .and_then(|p| p.get("safety"))
            .and_then(|s| s.get("gnss"))
            .is_some();
        if !stated {
            planner.safety.gnss = None;
        }
        return Ok(planner);
    }
    Ok(PlannerConfig::from_toml(&text, path)?)
}

/// ROI outline for the top view: the box or polygon, else the x/y bounds of `pts`.
fn outline(roi: &RoiSpec, pts: impl Iterator<Item = Point3<f64>>) -> Vec<[f64; 2]> {
    match roi {
        RoiSpec::Region(Roi::Box { min, max }) => {
            vec![
                [min[0], min[1]],
                [max[0], min[1]],
                [max[0], max[1]],
                [min[0], max[1]],
            ]
        }
        RoiSpec::Region(Roi::Polygon { polygon, .. }) => polygon.clone(),
        _ => {
            let mut b = vp_scene::Aabb::empty();
            pts.for_each(|p| b.grow(&p));
            if b.min.x > b.max.x {
                return Vec::new();
            }
            vec![
                [b.min.x, b.min.y],
                [b.max.x, b.min.y],
                [b.max.x, b.max.y],
                [b.min.x, b.max.y],
            ]
        }
    }
}

impl PlanArgs {
    /// `--colmap DIR` or `--opensfm DIR`.
    fn model(&self) -> Result<ModelSource> {
        Ok(match (&self.cameras, &self.opensfm) {
            (_, Some(dir)) => ModelSource::OpenSfm(dir.clone()),
            (dir, None) => ModelSource::Colmap(required(dir.as_ref(), "--colmap")?.to_path_buf()),
        })
    }
}

fn plan(args: &PlanArgs, out: &mut dyn Write) -> Result<()> {
    let c = &args.common;
    let outputs = c.check_outputs()?;
    let cfg = c.config()?;
    let mesh = super::read_mesh(required(args.mesh.as_ref(), "--mesh")?)?;
    let model = args.model()?;
    let roi = c.roi()?;
    let job = vp_planner::plan_from_model(&ModelPlanRequest {
        mesh: &mesh,
        model: &model,
        confidence_dir: args.confidence_dir.as_deref(),
        config: &cfg,
        roi: roi.clone(),
        // --origin wins over the model's frame.json.
        origin: c.origin()?.map(|o| (o, c.datum)),
        home: c.home(args.home_from_first_image),
        frame_unchecked: args.frame_unchecked,
    })?;
    for note in &job.notes {
        eprintln!("note: {note}");
    }
    if let Some(check) = &job.frame {
        eprintln!(
            "frame: {} (origin {:.7},{:.7},{:.2}; cameras {:.2} m apart, median)",
            job.frame_file.display(),
            check.frame.origin.lat_deg,
            check.frame.origin.lon_deg,
            check.frame.origin.alt_m,
            check.median_spacing_m
        );
    }
    let r = &job.result;
    for it in &r.iterations {
        let times: Vec<String> = it
            .time_s
            .iter()
            .map(|(m, s)| format!("{m} {s:.3} s"))
            .collect();
        eprintln!(
            "triplet {}: mean f {:.4} -> {:.4}, coverage {:.3} ({})",
            it.iteration,
            it.f_before,
            it.f_after,
            it.coverage,
            times.join(", ")
        );
    }
    let mut plan = r.plan.clone();
    if args.no_timings {
        vp_planner::strip_timings(&mut plan);
    }
    let f: Vec<(Point3<f64>, f64)> = r.sampled.iter().map(|s| (s.centroid, s.f)).collect();
    let roi_outline = outline(
        &roi.resolve(&mesh, plan.origin)?,
        r.sampled.iter().map(|s| s.centroid),
    );
    let acquired: Vec<Camera> = job.acquired.iter().map(|v| v.camera).collect();
    write_outputs(&outputs, &plan, &mesh, &cfg, &f, &roi_outline, &acquired)?;
    let members = plan
        .waypoints
        .iter()
        .filter(|w| w.role == Role::TripletMember)
        .count();
    writeln!(out, "plan: {}", outputs.plan.display())?;
    writeln!(out, "{}", job.clearance)?;
    writeln!(
        out,
        "waypoints: {} ({members} triplet members, {} bridging)",
        plan.waypoints.len(),
        plan.waypoints.len() - members
    )?;
    summary::print_home(&plan, out)?;
    summary::print_flights(&plan, &cfg.mission, out)?;
    if let (Some(a), Some(b)) = (r.iterations.first(), r.iterations.last()) {
        writeln!(out, "mean f: {:.4} -> {:.4}", a.f_before, b.f_after)?;
    }
    if !r.dropped_triplets.is_empty() {
        writeln!(
            out,
            "dropped triplets (unsafe or unreachable): {:?}",
            r.dropped_triplets
        )?;
        for (t, why) in r.dropped_triplets.iter().zip(&r.dropped_reasons) {
            writeln!(out, "  triplet {t}: {why}")?;
        }
    }
    if plan.unbridged.is_empty() {
        writeln!(out, "unbridged views: none")?;
    } else {
        writeln!(
            out,
            "unbridged views: {:?} (waypoint indices: no bridge from the previous view keeps the \
             image overlap; listed in the plan as \"unbridged\")",
            plan.unbridged
        )?;
    }
    match &r.cut_short_reason {
        Some(why) => writeln!(out, "cut short: {why}")?,
        None => writeln!(out, "cut short: no")?,
    }
    Ok(())
}

/// The plan's views and the plan itself (`vp_planner::PlanOutputs`, which
/// removes what it wrote when a later file fails).
fn write_outputs(
    outputs: &PlanOutputs,
    plan: &Plan,
    mesh: &Mesh,
    cfg: &PlannerConfig,
    f: &[(Point3<f64>, f64)],
    roi_outline: &[[f64; 2]],
    acquired: &[Camera],
) -> Result<()> {
    outputs.write(
        plan,
        &PlanContext {
            mesh,
            config: cfg,
            fulfillment: f,
            roi_outline,
            acquired,
        },
    )?;
    Ok(())
}

fn grid(g: &GridArgs, out: &mut dyn Write) -> Result<()> {
    let c = &g.common;
    let outputs = c.check_outputs()?;
    let cfg = c.config()?;
    let mesh = super::read_mesh(&g.mesh)?;
    let roi = c.roi()?;
    let params = GridParams {
        height_m: g.height,
        gsd_m: g.gsd,
        front_overlap: g.overlap,
        side_overlap: g.side_overlap.unwrap_or(g.overlap),
        pitch_deg: g.pitch,
        yaw_deg: g.yaw,
        role: if g.initial { Role::Initial } else { Role::Grid },
    };
    let plan = vp_planner::plan_grid_job(&GridRequest {
        mesh: &mesh,
        roi: &roi,
        params: &params,
        config: &cfg,
        origin: c.origin()?.map(|o| (o, c.datum)),
        home: c.home(false),
    })?;
    let roi_outline = outline(
        &roi.resolve(&mesh, plan.origin)?,
        mesh.vertices.iter().copied(),
    );
    write_outputs(&outputs, &plan, &mesh, &cfg, &[], &roi_outline, &[])?;
    writeln!(out, "plan: {}", outputs.plan.display())?;
    writeln!(out, "waypoints: {}", plan.waypoints.len())?;
    writeln!(out, "{}", cfg.clearance_line())?;
    summary::print_grid_figures(&params.figures(cfg.camera.intrinsics()), out)?;
    summary::print_home(&plan, out)?;
    summary::print_flights(&plan, &cfg.mission, out)?;
    Ok(())
}
