//! `vpctl sim render`: one image of a procedural site from a look-at camera,
//! with its exact depth and the share of each material.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Result;
use nalgebra::Point3;
use vp_scene::colmap::write_depth_map;
use vp_scene::procedural::{generate_site, SiteParams};
use vp_scene::raster::save_rgb;
use vp_scene::raycast::RayCaster;
use vp_scene::{fsio, Intrinsics, Material};
use vp_sim::{look_at_camera, material_shares, render, RenderParams};

use super::parse_point;

/// Arguments of `vpctl sim render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Seed of the site (and of its textures).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Approximate number of faces of the site.
    #[arg(long, default_value_t = 200_000)]
    pub faces: usize,
    /// Camera centre x,y,z in metres (local ENU; the site is centred on the origin).
    #[arg(long, value_parser = parse_point, default_value = "-30,-25,30", allow_hyphen_values = true)]
    pub from: [f64; 3],
    /// Point the camera looks at, x,y,z in metres.
    #[arg(long, value_parser = parse_point, default_value = "0,0,0", allow_hyphen_values = true)]
    pub at: [f64; 3],
    /// Image width in pixels.
    #[arg(long, default_value_t = 1024)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 768)]
    pub height: u32,
    /// Horizontal field of view in degrees.
    #[arg(long, allow_negative_numbers = true, default_value_t = 60.0)]
    pub hfov: f64,
    /// Turn sun shadows off (faster).
    #[arg(long)]
    pub no_shadows: bool,
    /// Output image (.png, .jpg, .tif).
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the depth along the optical axis as a COLMAP depth map (.bin).
    #[arg(long)]
    pub depth: Option<PathBuf>,
    /// Overwrite output files that exist.
    #[arg(long)]
    pub force: bool,
}

/// `vpctl sim render`.
pub(super) fn render_site(a: &RenderArgs, out: &mut dyn Write) -> Result<()> {
    let RenderArgs {
        seed,
        faces,
        from,
        at,
        width,
        height,
        hfov,
        no_shadows,
        out: ref path,
        ref depth,
        force,
    } = *a;
    fsio::check_output_file(path, force)?;
    if let Some(d) = &depth {
        fsio::check_output_file(d, force)?;
    }
    let k = Intrinsics::from_hfov(width, height, hfov)?;
    let cam = look_at_camera(k, Point3::from(from), Point3::from(at))?;
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
    save_rgb(&r.rgb, path)?;
    writeln!(out, "wrote {} ({width}x{height})", path.display())?;
    if let Some(d) = &depth {
        write_depth_map(d, &r.depth)?;
        writeln!(out, "wrote {}", d.display())?;
    }
    let shares = material_shares(&site.mesh, &r.face_id);
    writeln!(
        out,
        "surface: {:.1} % of pixels",
        100.0 * shares.iter().sum::<f64>()
    )?;
    for (m, share) in Material::ALL.iter().zip(shares) {
        writeln!(out, "  {}: {:.1} %", m.name(), 100.0 * share)?;
    }
    Ok(())
}
