//! `vpctl colmap align`: georegister a model to known image positions (a
//! CSV or the photos' EXIF GPS tags) and write it with its `frame.json`.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Result;
use vp_scene::colmap;
use vp_scene::datum::VerticalDatum;

/// Arguments of `vpctl colmap align`.
#[derive(Debug, clap::Args)]
pub struct AlignArgs {
    /// The sparse model (text or binary).
    #[arg(long = "colmap", alias = "model", value_name = "DIR")]
    pub model: PathBuf,
    /// CSV of image positions: name,lat,lon,alt per line (WGS84 degrees,
    /// metres; an optional header line, `#` comments).
    #[arg(
        long,
        value_name = "CSV",
        required_unless_present = "exif",
        conflicts_with = "exif"
    )]
    pub positions: Option<PathBuf>,
    /// Instead of --positions: the folder of the photos, whose EXIF GPS
    /// latitude, longitude and altitude give the positions (JPEG, TIFF, PNG,
    /// WebP, HEIF; names relative to the folder, as in the model). Photos
    /// without a GPS position are listed and skipped.
    #[arg(long, value_name = "IMAGES_DIR")]
    pub exif: Option<PathBuf>,
    /// Output folder for the aligned model (same format as the input) and
    /// frame.json (a new or empty folder, or an earlier `colmap align`
    /// output with --force).
    #[arg(long)]
    pub out: PathBuf,
    /// A position farther than this from its aligned camera is an outlier (m).
    #[arg(long, allow_negative_numbers = true, default_value_t = 3.0)]
    pub max_error: f64,
    /// Replace an earlier output in --out (only the files vpctl wrote there;
    /// other files stay).
    #[arg(long)]
    pub force: bool,
    /// For a single strip (corridor) flight, whose cameras lie on a line:
    /// take the rotation about the line, which positions cannot fix, from
    /// the cameras' mean viewing direction, assuming they look down (nadir
    /// or oblique, below the horizon); the rotation chosen makes the mean
    /// viewing direction point as far down as possible. Still refused if the
    /// cameras look along the line or the positions run vertically.
    /// Ignored when the cameras do not lie on a line.
    #[arg(long)]
    pub gravity_from_views: bool,
    /// What the positions' altitudes are measured from: `egm96` (above mean
    /// sea level, as most drones write EXIF GPS altitude), `ellipsoid`
    /// (WGS84, as a GNSS receiver computes it) or `takeoff` (above the
    /// take-off point). Recorded in frame.json so that a home given later in
    /// another datum is converted, never mixed. Default: egm96 with --exif;
    /// unstated with --positions.
    #[arg(long, value_name = "DATUM")]
    pub datum: Option<vp_scene::datum::VerticalDatum>,
    /// How precise the positions are: `rtk`, `standard` (a consumer drone's
    /// GNSS without corrections) or `H,V` (horizontal RMS and vertical
    /// 1-sigma, metres). Recorded in frame.json: `vpctl plan` adds the
    /// position uncertainty of this class to its clearance. Default:
    /// unrecorded, and the planner assumes standard GNSS.
    #[arg(long, value_name = "CLASS")]
    pub gnss: Option<vp_scene::gnss::GnssClass>,
}

/// What --positions or --exif gave: the positions, the file or folder they
/// came from, their altitudes' datum and the take-off altitude if known.
struct Positions<'a> {
    geo: Vec<(String, vp_scene::plan::GeodeticOrigin)>,
    source: &'a Path,
    datum: Option<VerticalDatum>,
    takeoff_alt_m: Option<f64>,
}

/// The positions of --positions or --exif. The photos without a GPS
/// position are listed first, so that a refusal to align (too few
/// positions) shows why.
fn read_positions<'a>(a: &'a AlignArgs, out: &mut dyn Write) -> Result<Positions<'a>> {
    match (&a.positions, &a.exif) {
        (Some(csv), _) => Ok(Positions {
            geo: colmap::read_positions_csv(csv)?,
            source: csv,
            datum: a.datum,
            takeoff_alt_m: None,
        }),
        (None, Some(dir)) => {
            let found = colmap::read_positions_exif(dir)?;
            writeln!(
                out,
                "exif: {} photo(s) with a GPS position, {} skipped",
                found.positions.len(),
                found.skipped.len()
            )?;
            for (name, why) in &found.skipped {
                writeln!(out, "  skipped {name}: {why}")?;
            }
            if let Some([(low, low_m), (high, high_m)]) = &found.takeoff_spread {
                eprintln!(
                    "warning: no take-off altitude recorded: the photos' GPS altitude minus \
                     their height above take-off runs from {low_m:.2} m ({low}) to {high_m:.2} m \
                     ({high}), more than {} m apart: more than one take-off point, or a \
                     barometer that drifted. Give the next mission's home yourself: `vpctl \
                     plan --home LAT,LON,ALT,DATUM` at the point you will take off from",
                    colmap::TAKEOFF_SPREAD_M
                );
            }
            let datum = a.datum.unwrap_or(VerticalDatum::Egm96);
            // The relative altitudes say where the ground of the take-off
            // is, in the datum of the GPS altitudes; with heights that are
            // themselves relative to take-off it is 0.
            let takeoff_alt_m = match datum {
                VerticalDatum::Takeoff => Some(0.0),
                _ => found.takeoff_alt_m,
            };
            Ok(Positions {
                geo: found.positions,
                source: dir,
                datum: Some(datum),
                takeoff_alt_m,
            })
        }
        (None, None) => Err(crate::cmd::UsageError(
            "--positions CSV or --exif IMAGES_DIR is needed".into(),
        )
        .into()),
    }
}

pub(super) fn align(a: &AlignArgs, out: &mut dyn Write) -> Result<()> {
    if !(a.max_error.is_finite() && a.max_error > 0.0) {
        return Err(crate::cmd::UsageError(format!(
            "--max-error must be a positive number of metres, got {}",
            a.max_error
        ))
        .into());
    }
    let inputs: Vec<&Path> = [
        Some(a.model.as_path()),
        a.positions.as_deref(),
        a.exif.as_deref(),
    ]
    .into_iter()
    .flatten()
    .collect();
    let out_dir = vp_scene::outdir::OutDir::check(&a.out, "colmap align", &inputs, a.force)?;
    let format = colmap::detect_format(&a.model)?;
    let rec = colmap::read_model_as(&a.model, format)?;
    let Positions {
        geo,
        source,
        datum,
        takeoff_alt_m,
    } = read_positions(a, out)?;
    // The readers refuse an empty list; the origin is the first position
    // (in file order, or the first photo by name).
    let Some(&(_, origin)) = geo.first() else {
        return Err(crate::cmd::UsageError(format!("{}: no positions", source.display())).into());
    };
    let frame = vp_mission::geodesy::LocalFrame::new(origin)?;
    let enu: Vec<(String, nalgebra::Point3<f64>)> = geo
        .iter()
        .map(|(n, g)| (n.clone(), nalgebra::Point3::from(frame.to_enu(*g))))
        .collect();
    let params = colmap::AlignParams {
        max_error_m: a.max_error,
        gravity_from_views: a.gravity_from_views,
        ..colmap::AlignParams::default()
    };
    let al = colmap::align_to_positions(&rec, &enu, &params, source)?;
    let moved = colmap::transform_reconstruction(&rec, &al.sim3);
    let model_frame = colmap::ModelFrame {
        origin,
        sim3: al.sim3,
        rms_m: al.rms_m,
        residuals: al.residuals.clone(),
        strip: al.strip,
        vertical_datum: datum,
        takeoff_alt_m,
        home: None,
        gnss: a.gnss,
    };
    // Built beside --out and swapped in when complete: nothing partial.
    out_dir.write(|dir| -> vp_scene::Result<()> {
        match format {
            colmap::ModelFormat::Binary => colmap::write_binary(dir, &moved)?,
            colmap::ModelFormat::Text => colmap::write_text(dir, &moved)?,
        }
        model_frame.save(dir)
    })?;
    print_alignment(a, &al, &model_frame, out)?;
    writeln!(out, "written: {}", a.out.display())?;
    Ok(())
}

/// What `colmap align` found: the origin and its datum, the scale, the
/// positions used and their residuals.
fn print_alignment(
    a: &AlignArgs,
    al: &colmap::Alignment,
    f: &colmap::ModelFrame,
    out: &mut dyn Write,
) -> Result<()> {
    let n_in = al.residuals.iter().filter(|r| r.inlier).count();
    writeln!(
        out,
        "origin: {:.8},{:.8},{:.3} (first position: in the air, not the take-off point)",
        f.origin.lat_deg, f.origin.lon_deg, f.origin.alt_m
    )?;
    writeln!(
        out,
        "altitude datum: {}",
        f.vertical_datum.map_or(
            "unstated (pass --datum egm96|ellipsoid|takeoff)",
            VerticalDatum::name
        )
    )?;
    if let Some(t) = f.takeoff_alt_m {
        writeln!(
            out,
            "take-off altitude: {t:.2} m (the photos' GPS altitude minus their height above \
             take-off, median)"
        )?;
    }
    writeln!(out, "scale: {:.6} m per model unit", al.sim3.scale)?;
    writeln!(
        out,
        "positions: {} of {} used ({} outliers beyond {} m, {} not in the model)",
        n_in,
        al.residuals.len(),
        al.residuals.len() - n_in,
        a.max_error,
        al.unmatched.len()
    )?;
    writeln!(out, "rms residual: {:.4} m (inliers)", al.rms_m)?;
    match (&al.strip, a.gravity_from_views) {
        (Some(s), _) => writeln!(
            out,
            "strip: cameras on a line; rotation about it from the mean viewing direction \
             ({:.1} degrees from the line), now {:.1} degrees below the horizon",
            s.view_to_line_deg, s.view_tilt_deg
        )?,
        (None, true) => writeln!(
            out,
            "--gravity-from-views not used: the cameras do not lie on a line"
        )?,
        (None, false) => {}
    }
    for r in &al.residuals {
        writeln!(
            out,
            "  {}: {:.4} m{}",
            r.name,
            r.residual_m,
            if r.inlier { "" } else { " (outlier)" }
        )?;
    }
    Ok(())
}
