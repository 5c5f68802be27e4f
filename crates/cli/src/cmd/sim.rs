//! `vpctl sim ...`: the simulated world (rendering of procedural sites;
//! `run` and `config` of closed-loop campaigns live in [`super::demo`]).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use clap::Subcommand;
use nalgebra::Point3;
use vp_scene::colmap::write_depth_map;
use vp_scene::procedural::{generate_site, SiteParams};
use vp_scene::raster::save_rgb;
use vp_scene::raycast::RayCaster;
use vp_scene::{fsio, Camera, Intrinsics, Material};
use vp_sim::{render, RenderParams, SimError};

/// Simulation subcommands.
#[derive(Debug, Subcommand)]
pub enum SimCommand {
    /// Render an image of a procedural site (textured per material, sun-lit)
    /// from a pinhole camera; optionally write its exact depth as a COLMAP
    /// depth map. The same arguments give a byte-identical image.
    Render {
        /// Seed of the site (and of its textures).
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Approximate number of faces of the site.
        #[arg(long, default_value_t = 200_000)]
        faces: usize,
        /// Camera centre x,y,z in metres (local ENU; the site is centred on the origin).
        #[arg(long, value_parser = parse_point, default_value = "-30,-25,30", allow_hyphen_values = true)]
        from: [f64; 3],
        /// Point the camera looks at, x,y,z in metres.
        #[arg(long, value_parser = parse_point, default_value = "0,0,0", allow_hyphen_values = true)]
        at: [f64; 3],
        /// Image width in pixels.
        #[arg(long, default_value_t = 1024)]
        width: u32,
        /// Image height in pixels.
        #[arg(long, default_value_t = 768)]
        height: u32,
        /// Horizontal field of view in degrees.
        #[arg(long, default_value_t = 60.0)]
        hfov: f64,
        /// Turn sun shadows off (faster).
        #[arg(long)]
        no_shadows: bool,
        /// Output image (.png, .jpg, .tif).
        #[arg(long)]
        out: PathBuf,
        /// Also write the depth along the optical axis as a COLMAP depth map (.bin).
        #[arg(long)]
        depth: Option<PathBuf>,
        /// Overwrite output files that exist.
        #[arg(long)]
        force: bool,
    },
    /// Run a full closed-loop campaign from a TOML config (training sites,
    /// held-out sites, strategies, evaluation): prints the paper's Table 1
    /// and writes the report directory. `sim config --defaults` prints a
    /// complete config to start from.
    Run {
        /// Campaign configuration (TOML); missing keys take the demo's values.
        #[arg(long)]
        config: PathBuf,
        #[command(flatten)]
        common: super::demo::CampaignArgs,
    },
    /// Print a complete campaign configuration (TOML, every key written out).
    Config {
        /// Which preset: demo (what `vpctl demo` runs), quick (seconds) or
        /// paper (three held-out sites, F5x4, F1x20, NP5x4).
        #[arg(long, default_value = "demo")]
        preset: String,
        /// The paper preset (same as `--preset paper`).
        #[arg(long, conflicts_with = "preset")]
        paper: bool,
    },
}

/// Parses "x,y,z" into three finite numbers.
fn parse_point(s: &str) -> Result<[f64; 3], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!(
            "'{s}' is not x,y,z (three comma-separated numbers)"
        ));
    };
    let num = |t: &str| {
        t.parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("'{t}' in '{s}' is not a finite number"))
    };
    Ok([num(x)?, num(y)?, num(z)?])
}

/// A camera at `from` looking at `at`; straight down or up it uses heading
/// east (roll is undefined there).
fn camera(k: Intrinsics, from: [f64; 3], at: [f64; 3]) -> Result<Camera> {
    let (c, t) = (Point3::from(from), Point3::from(at));
    let d = t - c;
    if !(d.norm() > 0.0) {
        return Err(SimError::InvalidArgument("--from and --at are the same point".into()).into());
    }
    let horizontal = d.x.hypot(d.y);
    if horizontal < 1e-6 * d.norm() {
        let pitch = std::f64::consts::FRAC_PI_2.copysign(d.z);
        return Ok(Camera::from_yaw_pitch(k, c, 0.0, pitch));
    }
    Ok(Camera::look_at(k, c, t)?)
}

pub fn run(cmd: SimCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        SimCommand::Run { config, common } => {
            let cfg = vp_sim::campaign::CampaignConfig::load(&config)?;
            super::demo::run_config(&cfg, &common, out)
        }
        SimCommand::Config { preset, paper } => {
            let name = if paper { "paper" } else { preset.as_str() };
            let cfg = vp_sim::campaign::CampaignConfig::preset(name)?;
            write!(out, "{}", cfg.to_toml()?)?;
            Ok(())
        }
        SimCommand::Render {
            seed,
            faces,
            from,
            at,
            width,
            height,
            hfov,
            no_shadows,
            out: path,
            depth,
            force,
        } => {
            fsio::check_overwrite(&path, force)?;
            if let Some(d) = &depth {
                fsio::check_overwrite(d, force)?;
            }
            let k = Intrinsics::from_hfov(width, height, hfov)?;
            let cam = camera(k, from, at)?;
            let site = generate_site(&SiteParams {
                seed,
                target_faces: faces,
                ..SiteParams::default()
            })?;
            let caster = RayCaster::new(&site.mesh);
            let params = RenderParams {
                shadows: !no_shadows,
                texture_seed: seed,
                ..RenderParams::default()
            };
            let r = render(&site.mesh, &caster, &cam, &params)?;
            save_rgb(&r.rgb, &path)?;
            writeln!(out, "wrote {} ({width}x{height})", path.display())?;
            if let Some(d) = &depth {
                write_depth_map(d, &r.depth)?;
                writeln!(out, "wrote {}", d.display())?;
            }
            let total = r.face_id.len().max(1) as f64;
            let mut counts = [0usize; Material::ALL.len()];
            for &f in r.face_id.iter().filter(|&&f| f != u32::MAX) {
                counts[site.mesh.material(f as usize).unwrap_or(Material::Ground) as usize] += 1;
            }
            let hit: usize = counts.iter().sum();
            writeln!(
                out,
                "surface: {:.1} % of pixels",
                100.0 * hit as f64 / total
            )?;
            for (m, n) in Material::ALL.iter().zip(counts) {
                writeln!(out, "  {}: {:.1} %", m.name(), 100.0 * n as f64 / total)?;
            }
            Ok(())
        }
    }
}
