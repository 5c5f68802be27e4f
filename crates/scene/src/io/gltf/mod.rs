//! glTF 2.0 binary (`.glb`) scenes for web and desktop viewers: a mesh
//! coloured by material, camera frusta as lines, flight paths as line
//! strips.
//!
//! Build a [`GltfScene`] with [`GltfScene::add_mesh`],
//! [`GltfScene::add_frusta`], [`GltfScene::add_lines`] and
//! [`GltfScene::add_line_strip`] (each one named node a viewer can list and
//! hide), then [`GltfScene::to_glb`] or [`write_glb`].
//!
//! # Frame
//! glTF is Y-up (+Y up, +Z towards the viewer, right-handed); vpctl's world
//! is local ENU, Z-up. Every position is written as
//! `(x, y, z)_glTF = (east, up, -north)` ([`enu_to_gltf`]): a proper
//! rotation (no mirror), so a viewer shows the scene upright, north away
//! from its default camera. Coordinates are written as `f32`, as glTF
//! requires: fine in a local frame (steps of 4 µm at 60 m), not for UTM-size
//! coordinates, which vpctl never uses.
//!
//! # Why gltf-json and a hand-written container
//! The JSON document uses the typed structs of `gltf-json` (the gltf-rs
//! project's, widely used), so required fields, enum values and names follow
//! the schema. The GLB container around it is a 12-byte header and two
//! padded chunks (spec section 4.4); the `gltf` crate would add image
//! decoding and more for those few lines, so they are written here.
//!
//! The output is deterministic: the same scene gives the same bytes.

use std::collections::BTreeMap;
use std::path::Path;

use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use nalgebra::Point3;

use crate::camera::Camera;
use crate::error::{Result, SceneError};
use crate::fsio;
use crate::mesh::{Material, Mesh};

#[cfg(test)]
mod tests;

/// An sRGB colour, 8 bits per channel (written as glTF's linear factors).
pub type Rgb = [u8; 3];

/// The colour of a material in [`GltfScene::add_mesh`]; faces without a
/// material are light grey.
pub fn material_colour(material: Option<Material>) -> Rgb {
    match material {
        Some(Material::Ground) => [150, 120, 85],
        Some(Material::Rock) => [160, 158, 150],
        Some(Material::Grass) => [95, 145, 60],
        Some(Material::Tree) => [45, 95, 45],
        Some(Material::Marker) => [235, 235, 235],
        None => [185, 185, 185],
    }
}

/// A point of vpctl's ENU frame (Z up) in glTF's frame (Y up): `(x, z, -y)`.
pub fn enu_to_gltf(p: &Point3<f64>) -> [f32; 3] {
    [p.x as f32, p.z as f32, -p.y as f32]
}

/// One piece of geometry with its colour.
#[derive(Debug, Clone)]
enum Part {
    /// Triangles sharing one vertex array, in groups of one colour each.
    Triangles {
        vertices: Vec<Point3<f64>>,
        groups: Vec<(Rgb, Vec<[u32; 3]>)>,
    },
    /// Separate segments (glTF mode LINES).
    Lines {
        segments: Vec<[Point3<f64>; 2]>,
        colour: Rgb,
    },
    /// One polyline (glTF mode LINE_STRIP).
    LineStrip {
        points: Vec<Point3<f64>>,
        colour: Rgb,
    },
}

/// A scene to write as glTF: named nodes, each one mesh of one part.
#[derive(Debug, Clone, Default)]
pub struct GltfScene {
    nodes: Vec<(String, Part)>,
}

impl GltfScene {
    /// An empty scene.
    pub fn new() -> Self {
        GltfScene::default()
    }

    /// Number of nodes added (empty geometry adds none).
    pub fn n_nodes(&self) -> usize {
        self.nodes.len()
    }

    /// A triangle mesh, one colour per material ([`material_colour`]).
    /// The mesh must be valid (indices in range, finite vertices).
    pub fn add_mesh(&mut self, name: &str, mesh: &Mesh) -> Result<()> {
        if mesh.faces.is_empty() {
            return Ok(());
        }
        let n = mesh.vertices.len();
        if let Some(f) = mesh
            .faces
            .iter()
            .position(|f| f.iter().any(|&i| i as usize >= n))
        {
            return Err(SceneError::InvalidMesh(format!(
                "face {f} refers to a vertex beyond the {n} vertices"
            )));
        }
        let mut groups: BTreeMap<Option<u8>, Vec<[u32; 3]>> = BTreeMap::new();
        for (f, face) in mesh.faces.iter().enumerate() {
            groups
                .entry(mesh.material(f).map(|m| m as u8))
                .or_default()
                .push(*face);
        }
        let groups = groups
            .into_iter()
            .map(|(m, faces)| (material_colour(m.and_then(Material::from_id)), faces))
            .collect();
        self.push(
            name,
            Part::Triangles {
                vertices: mesh.vertices.clone(),
                groups,
            },
        )
    }

    /// Line segments in one colour.
    pub fn add_lines(
        &mut self,
        name: &str,
        segments: Vec<[Point3<f64>; 2]>,
        colour: Rgb,
    ) -> Result<()> {
        if segments.is_empty() {
            return Ok(());
        }
        self.push(name, Part::Lines { segments, colour })
    }

    /// A polyline through `points` in order (at least two, else nothing is
    /// added), e.g. a flight path.
    pub fn add_line_strip(
        &mut self,
        name: &str,
        points: Vec<Point3<f64>>,
        colour: Rgb,
    ) -> Result<()> {
        if points.len() < 2 {
            return Ok(());
        }
        self.push(name, Part::LineStrip { points, colour })
    }

    /// Cameras as wire frusta: the four edges from the centre to the image
    /// corners at `depth` metres along the optical axis, and the image
    /// rectangle there, whose top edge is drawn twice as a tick towards the
    /// centre so that up in the image can be told.
    pub fn add_frusta(
        &mut self,
        name: &str,
        cameras: &[Camera],
        depth: f64,
        colour: Rgb,
    ) -> Result<()> {
        let mut segments = Vec::with_capacity(cameras.len() * 10);
        for cam in cameras {
            let c = cam.center();
            let k = cam.frustum_corners(depth);
            for i in 0..4 {
                segments.push([c, k[i]]);
                segments.push([k[i], k[(i + 1) % 4]]);
            }
            // The "up" mark: a small triangle on the top edge (image row 0).
            let mid = nalgebra::center(&k[0], &k[1]);
            let inward = (nalgebra::center(&k[2], &k[3]) - mid) * 0.2;
            let tip = mid - inward;
            segments.push([k[0] + (mid - k[0]) * 0.6, tip]);
            segments.push([tip, k[1] + (mid - k[1]) * 0.6]);
        }
        self.add_lines(name, segments, colour)
    }

    fn push(&mut self, name: &str, part: Part) -> Result<()> {
        let finite = |p: &Point3<f64>| p.iter().all(|c| c.is_finite());
        let ok = match &part {
            Part::Triangles { vertices, .. } => vertices.iter().all(finite),
            Part::Lines { segments, .. } => segments.iter().flatten().all(finite),
            Part::LineStrip { points, .. } => points.iter().all(finite),
        };
        if !ok {
            return Err(SceneError::InvalidArgument(format!(
                "glTF node '{name}': non-finite coordinates"
            )));
        }
        self.nodes.push((name.to_string(), part));
        Ok(())
    }

    /// The scene as a glTF 2.0 binary (GLB) file's bytes.
    pub fn to_glb(&self) -> Result<Vec<u8>> {
        let (root, bin) = Builder::default().build(self)?;
        let json = json::serialize::to_vec(&root)
            .map_err(|e| SceneError::InvalidArgument(format!("glTF JSON: {e}")))?;
        Ok(glb_container(&json, &bin))
    }
}

/// Writes `scene` to `path` (extension `.glb`, any case) atomically: no
/// partial file on failure; refuses an existing file unless `force`.
pub fn write_glb(path: &Path, scene: &GltfScene, force: bool) -> Result<()> {
    check_glb_path(path)?;
    fsio::check_overwrite(path, force)?;
    let bytes = scene.to_glb()?;
    fsio::write_file_atomic(path, &bytes)
}

/// Refuses a path whose extension is not `.glb`, naming it.
pub fn check_glb_path(path: &Path) -> Result<()> {
    let ext = path.extension().and_then(|e| e.to_str()).unwrap_or("");
    if ext.eq_ignore_ascii_case("glb") {
        Ok(())
    } else {
        Err(SceneError::InvalidArgument(format!(
            "{}: a glTF binary scene needs the extension .glb",
            path.display()
        )))
    }
}

/// The GLB container (glTF 2.0 spec, 4.4): header `glTF`, version 2, total
/// length; a JSON chunk padded with spaces and a BIN chunk padded with
/// zeros, each to 4 bytes.
fn glb_container(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.len() + pad(bin.len());
    let total = 12 + 8 + json_len + if bin.is_empty() { 0 } else { 8 + bin_len };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out.resize(out.len() + pad(json.len()), b' ');
    if !bin.is_empty() {
        out.extend_from_slice(&(bin_len as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(bin);
        out.resize(out.len() + pad(bin.len()), 0);
    }
    out
}

/// sRGB (8 bit) to glTF's linear colour factor.
fn linear(c: Rgb) -> [f32; 4] {
    let l = |v: u8| {
        let s = f64::from(v) / 255.0;
        let x = if s <= 0.04045 {
            s / 12.92
        } else {
            ((s + 0.055) / 1.055).powf(2.4)
        };
        x as f32
    };
    [l(c[0]), l(c[1]), l(c[2]), 1.0]
}

/// Assembles the document and its binary buffer.
#[derive(Default)]
struct Builder {
    root: json::Root,
    bin: Vec<u8>,
    materials: BTreeMap<Rgb, json::Index<json::Material>>,
}

impl Builder {
    fn build(mut self, scene: &GltfScene) -> Result<(json::Root, Vec<u8>)> {
        self.root.asset = json::Asset {
            generator: Some(format!("vpctl {}", env!("CARGO_PKG_VERSION"))),
            ..json::Asset::default()
        };
        let mut nodes = Vec::new();
        for (name, part) in &scene.nodes {
            let primitives = self.primitives(part)?;
            let mesh = self.root.push(json::Mesh {
                extensions: None,
                extras: json::extras::Extras::default(),
                name: Some(name.clone()),
                primitives,
                weights: None,
            });
            nodes.push(self.root.push(json::Node {
                mesh: Some(mesh),
                name: Some(name.clone()),
                ..json::Node::default()
            }));
        }
        if !self.bin.is_empty() {
            self.root.push(json::Buffer {
                byte_length: USize64::from(self.bin.len()),
                name: None,
                uri: None,
                extensions: None,
                extras: json::extras::Extras::default(),
            });
        }
        // A scene must list at least one node (schema: minItems 1).
        if !nodes.is_empty() {
            let s = self.root.push(json::Scene {
                extensions: None,
                extras: json::extras::Extras::default(),
                name: Some("vpctl (ENU z-up written as glTF y-up)".into()),
                nodes,
            });
            self.root.scene = Some(s);
        }
        Ok((self.root, self.bin))
    }

    fn primitives(&mut self, part: &Part) -> Result<Vec<json::mesh::Primitive>> {
        Ok(match part {
            Part::Triangles { vertices, groups } => {
                let pos = self.positions(vertices)?;
                let mut v = Vec::new();
                for (colour, faces) in groups {
                    let flat: Vec<u32> = faces.iter().flatten().copied().collect();
                    let idx = self.indices(&flat);
                    v.push(self.primitive(pos, Some(idx), *colour, json::mesh::Mode::Triangles));
                }
                v
            }
            Part::Lines { segments, colour } => {
                let pts: Vec<Point3<f64>> = segments.iter().flatten().copied().collect();
                let pos = self.positions(&pts)?;
                vec![self.primitive(pos, None, *colour, json::mesh::Mode::Lines)]
            }
            Part::LineStrip { points, colour } => {
                let pos = self.positions(points)?;
                vec![self.primitive(pos, None, *colour, json::mesh::Mode::LineStrip)]
            }
        })
    }

    fn primitive(
        &mut self,
        positions: json::Index<json::Accessor>,
        indices: Option<json::Index<json::Accessor>>,
        colour: Rgb,
        mode: json::mesh::Mode,
    ) -> json::mesh::Primitive {
        let material = self.material(colour);
        json::mesh::Primitive {
            attributes: BTreeMap::from([(Valid(json::mesh::Semantic::Positions), positions)]),
            extensions: None,
            extras: json::extras::Extras::default(),
            indices,
            material: Some(material),
            mode: Valid(mode),
            targets: None,
        }
    }

    /// One matte, double-sided material per colour (terrain is seen from
    /// below too; lines have no side).
    fn material(&mut self, colour: Rgb) -> json::Index<json::Material> {
        if let Some(m) = self.materials.get(&colour) {
            return *m;
        }
        let m = self.root.push(json::Material {
            double_sided: true,
            name: Some(format!(
                "#{:02x}{:02x}{:02x}",
                colour[0], colour[1], colour[2]
            )),
            pbr_metallic_roughness: json::material::PbrMetallicRoughness {
                base_color_factor: json::material::PbrBaseColorFactor(linear(colour)),
                metallic_factor: json::material::StrengthFactor(0.0),
                roughness_factor: json::material::StrengthFactor(1.0),
                ..Default::default()
            },
            ..Default::default()
        });
        self.materials.insert(colour, m);
        m
    }

    /// A buffer view over `bytes` appended to the buffer (4-byte aligned).
    fn view(
        &mut self,
        bytes: &[u8],
        target: json::buffer::Target,
    ) -> json::Index<json::buffer::View> {
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.bin.resize(self.bin.len().next_multiple_of(4), 0);
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: Some(Valid(target)),
            extensions: None,
            extras: json::extras::Extras::default(),
        })
    }

    /// A VEC3 float accessor in glTF's frame, with the min and max the
    /// spec requires for positions.
    fn positions(&mut self, points: &[Point3<f64>]) -> Result<json::Index<json::Accessor>> {
        if u32::try_from(points.len()).is_err() {
            return Err(SceneError::InvalidArgument(format!(
                "glTF: {} vertices in one node is more than 32-bit indices address",
                points.len()
            )));
        }
        let mut bytes = Vec::with_capacity(points.len() * 12);
        let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
        for p in points {
            let q = enu_to_gltf(p);
            for a in 0..3 {
                lo[a] = lo[a].min(q[a]);
                hi[a] = hi[a].max(q[a]);
                bytes.extend_from_slice(&q[a].to_le_bytes());
            }
        }
        let view = self.view(&bytes, json::buffer::Target::ArrayBuffer);
        Ok(self.accessor(
            view,
            points.len(),
            json::accessor::ComponentType::F32,
            json::accessor::Type::Vec3,
            Some((lo.to_vec(), hi.to_vec())),
        ))
    }

    /// A SCALAR unsigned-int index accessor.
    fn indices(&mut self, indices: &[u32]) -> json::Index<json::Accessor> {
        let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, json::buffer::Target::ElementArrayBuffer);
        self.accessor(
            view,
            indices.len(),
            json::accessor::ComponentType::U32,
            json::accessor::Type::Scalar,
            None,
        )
    }

    fn accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        count: usize,
        component: json::accessor::ComponentType,
        kind: json::accessor::Type,
        bounds: Option<(Vec<f32>, Vec<f32>)>,
    ) -> json::Index<json::Accessor> {
        let (min, max) = match bounds {
            Some((lo, hi)) => (Some(json::Value::from(lo)), Some(json::Value::from(hi))),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: json::extras::Extras::default(),
            type_: Valid(kind),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }
}
