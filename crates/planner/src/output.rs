//! Outputs besides the plan JSON: a PLY of the planned cameras as small
//! pyramids for MeshLab/CloudCompare, a glTF scene (mesh, acquired and
//! planned cameras as frusta, flight paths) for any glTF viewer, and a PNG
//! top view.

use std::fmt::Write as _;
use std::io::Write;
use std::path::Path;

use image::{Rgb, RgbImage};
use nalgebra::Point3;
use vp_scene::io::gltf::{write_glb, GltfScene};
use vp_scene::io::{write_mesh, MeshFormat};
use vp_scene::plan::{Plan, Role};
use vp_scene::raster::{draw_text, text_width};
use vp_scene::{fsio, Camera, Intrinsics, Material, Mesh};

use crate::error::{PlannerError, Result};

/// Material marking each role in the camera PLY (read as a face property):
/// triplet members `Rock`, bridging views `Marker`, grid views `Grass`,
/// initial views `Ground`.
pub fn role_material(role: Role) -> Material {
    match role {
        Role::TripletMember => Material::Rock,
        Role::Bridge => Material::Marker,
        Role::Grid => Material::Grass,
        Role::Initial => Material::Ground,
    }
}

/// The plan's views as pyramids (apex at the camera centre, base `depth`
/// metres along the optical axis spanning the image).
pub fn frusta_mesh(plan: &Plan, k: Intrinsics, depth: f64) -> Mesh {
    let mut mesh = Mesh {
        vertices: Vec::new(),
        faces: Vec::new(),
        materials: Some(Vec::new()),
    };
    for v in &plan.waypoints {
        let cam = v.to_camera(k);
        let base = mesh.vertices.len() as u32;
        mesh.vertices.push(cam.center());
        mesh.vertices.extend(cam.frustum_corners(depth));
        let faces = [
            [0, 1, 2],
            [0, 2, 3],
            [0, 3, 4],
            [0, 4, 1],
            [1, 3, 2],
            [1, 4, 3],
        ];
        for f in faces {
            mesh.faces.push(f.map(|i| base + i));
        }
        if let Some(m) = mesh.materials.as_mut() {
            m.extend([role_material(v.role); 6]);
        }
    }
    mesh
}

/// Writes the camera pyramids as a binary PLY; refuses to overwrite unless `force`.
pub fn write_frusta_ply(
    path: &Path,
    plan: &Plan,
    k: Intrinsics,
    depth: f64,
    force: bool,
) -> Result<()> {
    fsio::check_overwrite(path, force)?;
    write_mesh(
        path,
        &frusta_mesh(plan, k, depth),
        MeshFormat::PlyBinaryLittleEndian,
    )?;
    Ok(())
}

/// What the 3D scene of a plan shows ([`plan_scene`]).
pub struct SceneView<'a> {
    /// The scene mesh (coloured by material).
    pub mesh: &'a Mesh,
    /// The cameras already acquired (e.g. the COLMAP model's images).
    pub acquired: &'a [Camera],
    /// Plans to show, each under a name (its nodes are prefixed with it).
    pub plans: &'a [(&'a str, &'a Plan)],
    /// The planned camera, for the frusta of the plans' views.
    pub intrinsics: Intrinsics,
    /// Depth of the frusta along the optical axis, metres.
    pub frustum_depth: f64,
}

/// The colour of a planned view in the top view and the 3D scene.
fn role_colour(role: Role) -> Rgb<u8> {
    match role {
        Role::TripletMember => TRIPLET_COLOUR,
        Role::Bridge => BRIDGE_COLOUR,
        Role::Grid | Role::Initial => GRID_COLOUR,
    }
}

/// The acquired cameras: frusta in 3D, squares in the top view.
const ACQUIRED_COLOUR: Rgb<u8> = Rgb([90, 160, 255]);
/// The flight path in 3D (white would vanish on a viewer's light background).
const PATH_3D_COLOUR: Rgb<u8> = Rgb([255, 230, 0]);

/// The plan scene as glTF nodes: `mesh`; `acquired cameras` (blue frusta);
/// per plan, `<name>: triplet views` (orange), `<name>: bridging views`
/// (cyan), `<name>: grid views` (magenta) as frusta, and `<name>: flight
/// path` (yellow line strip through the views in flight order). The colours
/// are the top view's. Empty groups are left out.
pub fn plan_scene(view: &SceneView) -> Result<GltfScene> {
    let mut scene = GltfScene::new();
    scene.add_mesh("mesh", view.mesh)?;
    scene.add_frusta(
        "acquired cameras",
        view.acquired,
        view.frustum_depth,
        ACQUIRED_COLOUR.0,
    )?;
    for (name, plan) in view.plans {
        for (roles, label) in [
            (&[Role::TripletMember][..], "triplet views"),
            (&[Role::Bridge][..], "bridging views"),
            (&[Role::Grid, Role::Initial][..], "grid views"),
        ] {
            let cams: Vec<Camera> = plan
                .waypoints
                .iter()
                .filter(|w| roles.contains(&w.role))
                .map(|w| w.to_camera(view.intrinsics))
                .collect();
            scene.add_frusta(
                &format!("{name}: {label}"),
                &cams,
                view.frustum_depth,
                role_colour(roles[0]).0,
            )?;
        }
        let path = plan
            .waypoints
            .iter()
            .map(|w| Point3::from(w.position))
            .collect();
        scene.add_line_strip(&format!("{name}: flight path"), path, PATH_3D_COLOUR.0)?;
    }
    Ok(scene)
}

/// Writes [`plan_scene`] as a glTF binary (`.glb`), atomically; refuses to
/// overwrite unless `force`, and a path without the `.glb` extension.
pub fn write_plan_glb(path: &Path, view: &SceneView, force: bool) -> Result<()> {
    write_glb(path, &plan_scene(view)?, force)?;
    Ok(())
}

/// What the top view shows.
pub struct TopView<'a> {
    /// The scene mesh.
    pub mesh: &'a Mesh,
    /// Sampled triangles' centroids with their f(t), drawn over the mesh.
    pub fulfillment: &'a [(Point3<f64>, f64)],
    /// ROI outline corners (x, y), closed implicitly.
    pub roi_outline: &'a [[f64; 2]],
    /// The plan.
    pub plan: &'a Plan,
    /// The acquired cameras (the COLMAP model planned from), drawn as
    /// blue squares under the plan.
    pub acquired: &'a [Camera],
    /// Longest image side, pixels.
    pub size: u32,
}

struct Canvas {
    img: RgbImage,
    x0: f64,
    y1: f64,
    scale: f64,
}

impl Canvas {
    fn px(&self, x: f64, y: f64) -> (f64, f64) {
        ((x - self.x0) * self.scale, (self.y1 - y) * self.scale)
    }

    fn put(&mut self, x: i64, y: i64, c: Rgb<u8>) {
        if x >= 0 && y >= 0 && x < i64::from(self.img.width()) && y < i64::from(self.img.height()) {
            self.img.put_pixel(x as u32, y as u32, c);
        }
    }

    fn line(&mut self, a: (f64, f64), b: (f64, f64), c: Rgb<u8>) {
        let n = (b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil().max(1.0) as usize;
        for i in 0..=n {
            let s = i as f64 / n as f64;
            self.put(
                (a.0 + (b.0 - a.0) * s) as i64,
                (a.1 + (b.1 - a.1) * s) as i64,
                c,
            );
        }
    }

    fn dot(&mut self, p: (f64, f64), r: i64, c: Rgb<u8>) {
        for dy in -r..=r {
            for dx in -r..=r {
                if dx * dx + dy * dy <= r * r {
                    self.put(p.0 as i64 + dx, p.1 as i64 + dy, c);
                }
            }
        }
    }

    fn triangle(&mut self, t: [(f64, f64); 3], c: Rgb<u8>) {
        let (xmin, xmax) = (
            t.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
            t.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max),
        );
        let (ymin, ymax) = (
            t.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
            t.iter().map(|p| p.1).fold(f64::NEG_INFINITY, f64::max),
        );
        let edge = |a: (f64, f64), b: (f64, f64), p: (f64, f64)| {
            (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0)
        };
        let area = edge(t[0], t[1], t[2]);
        if area == 0.0 {
            return;
        }
        for y in (ymin.floor() as i64)..=(ymax.ceil() as i64) {
            for x in (xmin.floor() as i64)..=(xmax.ceil() as i64) {
                let p = (x as f64 + 0.5, y as f64 + 0.5);
                let w = [
                    edge(t[1], t[2], p),
                    edge(t[2], t[0], p),
                    edge(t[0], t[1], p),
                ];
                if w.iter().all(|v| v * area >= 0.0) {
                    self.put(x, y, c);
                }
            }
        }
    }
}

/// Per mesh face, the f(t) of the nearest sampled triangle (3D distance
/// between centroids) within 1.5 sample spacings, else `None` (not
/// sampled: outside the ROI, or too far from any sample). The spacing is
/// that of the samples spread evenly over their x/y bounding box (padded).
///
/// # Performance
/// Samples are bucketed in an x/y grid of that radius; each face looks at
/// its 3 x 3 cells only.
fn face_fulfillment(mesh: &Mesh, samples: &[(Point3<f64>, f64)]) -> Vec<Option<f64>> {
    if samples.is_empty() {
        return vec![None; mesh.n_faces()];
    }
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for (p, _) in samples {
        lo = [lo[0].min(p.x), lo[1].min(p.y)];
        hi = [hi[0].max(p.x), hi[1].max(p.y)];
    }
    // Padded by one spacing of the longer side, so that samples along a
    // line still get a spacing.
    let (w, h) = (hi[0] - lo[0], hi[1] - lo[1]);
    let pad = w.max(h) / (samples.len() as f64).sqrt();
    let area = ((w + pad) * (h + pad)).max(1e-12);
    let radius = (1.5 * (area / samples.len() as f64).sqrt()).max(1e-6);
    let cell = |x: f64, y: f64| {
        (
            ((x - lo[0]) / radius).floor() as i64,
            ((y - lo[1]) / radius).floor() as i64,
        )
    };
    let mut grid: std::collections::HashMap<(i64, i64), Vec<usize>> =
        std::collections::HashMap::new();
    for (i, (p, _)) in samples.iter().enumerate() {
        grid.entry(cell(p.x, p.y)).or_default().push(i);
    }
    (0..mesh.n_faces())
        .map(|f| {
            let c = mesh.face_centroid(f);
            let (cx, cy) = cell(c.x, c.y);
            let mut best: Option<(f64, f64)> = None;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for &i in grid.get(&(cx + dx, cy + dy)).map_or(&[][..], Vec::as_slice) {
                        let d = (samples[i].0 - c).norm();
                        if d <= radius && best.is_none_or(|(bd, _)| d < bd) {
                            best = Some((d, samples[i].1));
                        }
                    }
                }
            }
            best.map(|(_, v)| v)
        })
        .collect()
}

/// Red (0) through yellow to green (1).
fn ramp(f: f64) -> Rgb<u8> {
    let f = f.clamp(0.0, 1.0);
    let r = (255.0 * (2.0 - 2.0 * f).min(1.0)) as u8;
    let g = (255.0 * (2.0 * f).min(1.0)) as u8;
    Rgb([r, g, 40])
}

/// Renders the top view: mesh faces from below to above, each coloured by
/// the f(t) of the nearest sampled triangle (red 0 to green 1, brighter
/// higher up) or, where nothing was sampled, grey by height; the ROI outline in
/// blue, the acquired cameras as blue squares (as their frusta in 3D), the path in white, the
/// planned cameras as dots (triplet members orange, bridges cyan, grid and
/// initial views magenta) with heading ticks; below
/// the map a panel with a title, the legend, the colour keys and the scale.
pub fn render_top_view(view: &TopView) -> RgbImage {
    let b = view.mesh.bounds();
    let mut ext = b.extent();
    let acquired: Vec<[f64; 3]> = view.acquired.iter().map(|c| c.center().into()).collect();
    for p in view
        .plan
        .waypoints
        .iter()
        .map(|w| &w.position)
        .chain(&acquired)
    {
        ext.x = ext
            .x
            .max((p[0] - b.min.x).abs())
            .max((p[0] - b.max.x).abs());
        ext.y = ext
            .y
            .max((p[1] - b.min.y).abs())
            .max((p[1] - b.max.y).abs());
    }
    let side = ext.x.max(ext.y).max(1e-6);
    let scale = f64::from(view.size.max(16)) / side;
    let (w, h) = (
        ((b.extent().x * scale).ceil() as u32).max(16),
        ((b.extent().y * scale).ceil() as u32).max(16),
    );
    let mut cv = Canvas {
        img: RgbImage::from_pixel(w, h, Rgb([20, 20, 30])),
        x0: b.min.x,
        y1: b.max.y,
        scale,
    };
    let mut order: Vec<usize> = (0..view.mesh.n_faces()).collect();
    let cz: Vec<f64> = (0..view.mesh.n_faces())
        .map(|f| view.mesh.face_centroid(f).z)
        .collect();
    order.sort_by(|&a, &b| cz[a].total_cmp(&cz[b]));
    let dz = (b.max.z - b.min.z).max(1e-9);
    let shaded = face_fulfillment(view.mesh, view.fulfillment);
    for f in order {
        let t = view.mesh.triangle(f).map(|p| cv.px(p.x, p.y));
        let height = (cz[f] - b.min.z) / dz;
        let g = (60.0 + 170.0 * height) as u8;
        let colour = match shaded[f] {
            // f(t) colour, darker low and brighter high so relief still shows.
            Some(v) => {
                let k = 0.6 + 0.4 * height;
                Rgb(ramp(v).0.map(|c| (f64::from(c) * k) as u8))
            }
            None => Rgb([g, g, g]),
        };
        cv.triangle(t, colour);
    }
    let r = (0.004 * f64::from(w.max(h))).ceil().max(1.0) as i64;
    let n = view.roi_outline.len();
    for i in 0..n {
        let (a, c) = (view.roi_outline[i], view.roi_outline[(i + 1) % n]);
        let (pa, pc) = (cv.px(a[0], a[1]), cv.px(c[0], c[1]));
        cv.line(pa, pc, ROI_COLOUR);
    }
    // Squares, no heading: acquired images are mostly nadir, where a
    // heading says nothing.
    for p in &acquired {
        let p = cv.px(p[0], p[1]);
        for dy in -r..=r {
            for dx in -r..=r {
                cv.put(p.0 as i64 + dx, p.1 as i64 + dy, ACQUIRED_COLOUR);
            }
        }
    }
    let wps = &view.plan.waypoints;
    for pair in wps.windows(2) {
        let (a, c) = (
            cv.px(pair[0].position[0], pair[0].position[1]),
            cv.px(pair[1].position[0], pair[1].position[1]),
        );
        cv.line(a, c, Rgb([255, 255, 255]));
    }
    for v in wps {
        let colour = role_colour(v.role);
        let p = cv.px(v.position[0], v.position[1]);
        let yaw = v.yaw_deg.to_radians();
        let tick = 4.0 * r as f64;
        cv.line(p, (p.0 + tick * yaw.cos(), p.1 - tick * yaw.sin()), colour);
        cv.dot(p, r + 1, colour);
    }
    with_legend(&cv.img, view, w as f64 / scale)
}

const TRIPLET_COLOUR: Rgb<u8> = Rgb([255, 150, 0]);
const BRIDGE_COLOUR: Rgb<u8> = Rgb([0, 220, 220]);
const GRID_COLOUR: Rgb<u8> = Rgb([230, 0, 230]);
const ROI_COLOUR: Rgb<u8> = Rgb([60, 120, 255]);
const TEXT_COLOUR: Rgb<u8> = Rgb([235, 235, 235]);
/// Height of one legend line, pixels.
const LINE_PX: u32 = 14;

/// The map with a panel below it: a title (waypoints by role), the legend
/// of the marks, the colour key of f(t) and of the mesh's height shading,
/// and the map's scale.
fn with_legend(map: &RgbImage, view: &TopView, width_m: f64) -> RgbImage {
    let wps = &view.plan.waypoints;
    let count = |f: &dyn Fn(Role) -> bool| wps.iter().filter(|v| f(v.role)).count();
    let members = count(&|r| r == Role::TripletMember);
    let bridges = count(&|r| r == Role::Bridge);
    let grid = count(&|r| matches!(r, Role::Grid | Role::Initial));
    let mut title = format!(
        "vpctl plan: {} waypoints ({members} triplet, {bridges} bridge, {grid} grid)",
        wps.len()
    );
    if !view.acquired.is_empty() {
        let _ = write!(title, " from {} acquired", view.acquired.len());
    }
    if view.plan.cut_short {
        title.push_str(", cut short");
    }
    let note = if view.fulfillment.is_empty() {
        format!("north up, {width_m:.0} m across; no f(t): a grid plan")
    } else {
        format!("north up, {width_m:.0} m across; faces: f(t) of the nearest sample, grey: none")
    };
    let lines = 4;
    let panel = 6 + lines * LINE_PX;
    let w = map
        .width()
        .max(text_width(&title) as u32 + 12)
        .max(text_width(&note) as u32 + 12)
        .max(420);
    let mut img = RgbImage::from_pixel(w, map.height() + panel, Rgb([20, 20, 30]));
    image::imageops::overlay(&mut img, map, 0, 0);
    let y0 = i64::from(map.height()) + 4;
    let row = |k: i64| y0 + k * i64::from(LINE_PX);
    draw_text(&mut img, 6, row(0), &title, TEXT_COLOUR);
    let mut x = 6;
    for (c, label) in [
        (TRIPLET_COLOUR, "triplet"),
        (BRIDGE_COLOUR, "bridge"),
        (GRID_COLOUR, "grid"),
        (ACQUIRED_COLOUR, "acquired"),
        (Rgb([255, 255, 255]), "path"),
        (ROI_COLOUR, "ROI"),
    ] {
        fill(&mut img, x, row(1), 8, 8, c);
        draw_text(&mut img, x + 11, row(1), label, TEXT_COLOUR);
        x += 11 + text_width(label) + 12;
    }
    // Colour keys: f(t) of the sampled triangles, the mesh by height.
    let label = "f(t) 0";
    draw_text(&mut img, 6, row(2), label, TEXT_COLOUR);
    let bar_x = 6 + text_width(label) + 4;
    for i in 0..100 {
        fill(&mut img, bar_x + i, row(2), 1, 8, ramp(i as f64 / 99.0));
    }
    draw_text(&mut img, bar_x + 104, row(2), "1", TEXT_COLOUR);
    let label = "mesh: low";
    let mx = bar_x + 124;
    draw_text(&mut img, mx, row(2), label, TEXT_COLOUR);
    let gx = mx + text_width(label) + 4;
    for i in 0..60 {
        let g = (60.0 + 170.0 * i as f64 / 59.0) as u8;
        fill(&mut img, gx + i, row(2), 1, 8, Rgb([g, g, g]));
    }
    draw_text(&mut img, gx + 64, row(2), "high", TEXT_COLOUR);
    draw_text(&mut img, 6, row(3), &note, TEXT_COLOUR);
    img
}

fn fill(img: &mut RgbImage, x: i64, y: i64, w: i64, h: i64, c: Rgb<u8>) {
    for yy in y.max(0)..(y + h).min(i64::from(img.height())) {
        for xx in x.max(0)..(x + w).min(i64::from(img.width())) {
            img.put_pixel(xx as u32, yy as u32, c);
        }
    }
}

/// Writes the top view as PNG, atomically; refuses to overwrite unless `force`.
pub fn write_top_view_png(path: &Path, view: &TopView, force: bool) -> Result<()> {
    fsio::check_overwrite(path, force)?;
    let img = render_top_view(view);
    let mut buf = std::io::Cursor::new(Vec::new());
    img.write_to(&mut buf, image::ImageFormat::Png)
        .map_err(|e| PlannerError::Output {
            path: path.to_path_buf(),
            message: format!("PNG encoding failed: {e}"),
        })?;
    fsio::write_atomic(path, |w| w.write_all(buf.get_ref()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn faces_take_the_f_of_the_nearest_sample_and_far_faces_stay_unshaded() {
        // A strip of 10 unit squares along x; samples on the first two only.
        let mut vertices = Vec::new();
        let mut faces = Vec::new();
        for i in 0..=10 {
            vertices.push(Point3::new(f64::from(i), 0.0, 0.0));
            vertices.push(Point3::new(f64::from(i), 1.0, 0.0));
        }
        for i in 0..10u32 {
            let (a, b, c, d) = (2 * i, 2 * i + 2, 2 * i + 3, 2 * i + 1);
            faces.push([a, b, c]);
            faces.push([a, c, d]);
        }
        let mesh = Mesh::new(vertices, faces, None).unwrap();
        let samples = [
            (Point3::new(0.5, 0.5, 0.0), 0.2),
            (Point3::new(1.5, 0.5, 0.0), 0.9),
        ];
        let f = face_fulfillment(&mesh, &samples);
        assert_eq!(f[0], Some(0.2));
        assert_eq!(f[2], Some(0.9));
        assert_eq!(f[19], None, "9 m from any sample");
        assert!(face_fulfillment(&mesh, &[]).iter().all(Option::is_none));
    }
}
