//! Outputs besides the plan JSON: a PLY of the planned cameras as small
//! pyramids for MeshLab/CloudCompare, a glTF scene (mesh, acquired and
//! planned cameras as frusta, flight paths) for any glTF viewer, and the PNG
//! top view of [`crate::top_view`] (re-exported here).

use std::path::Path;

use image::Rgb;
use nalgebra::Point3;
use vp_scene::io::gltf::{write_glb, GltfScene};
use vp_scene::io::{write_mesh, MeshFormat};
use vp_scene::plan::{Plan, Role};
use vp_scene::{fsio, Camera, Intrinsics, Material, Mesh};

use crate::error::Result;
pub use crate::top_view::{
    render_top_view, top_view, write_top_view_png, Mark, TopView, TopViewPicture, ViewKind,
};

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
pub(crate) fn role_colour(role: Role) -> Rgb<u8> {
    match role {
        Role::TripletMember => TRIPLET_COLOUR,
        Role::Bridge => BRIDGE_COLOUR,
        Role::Grid | Role::Initial => GRID_COLOUR,
    }
}

/// The acquired cameras: frusta in 3D, squares in the top view.
pub(crate) const ACQUIRED_COLOUR: Rgb<u8> = Rgb([90, 160, 255]);
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

/// Triplet members, in the top view and the 3D scene.
pub(crate) const TRIPLET_COLOUR: Rgb<u8> = Rgb([255, 150, 0]);
/// Bridging views.
pub(crate) const BRIDGE_COLOUR: Rgb<u8> = Rgb([0, 220, 220]);
/// Grid and initial views.
pub(crate) const GRID_COLOUR: Rgb<u8> = Rgb([230, 0, 230]);
