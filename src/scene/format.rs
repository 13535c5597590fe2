//! Reading and writing the `.rss` scene format (see `docs/scene-format.md`).
//!
//! A JSON header describes the scene; bulk arrays live in a 16-byte aligned little-endian blob and are
//! copied out with `bytemuck`, so a million-triangle scene loads in well under a second.

use super::subdiv::{Boundary, FaceVaryingRule, Primvar, PrimvarMode, Scheme, Subdivision};
use super::{Camera, Instance, Light, Material, Mesh, SceneDesc, TextureDesc, Warning};
use crate::error::{Error, Result};
use glam::{Mat4, Vec2, Vec3};
use serde::{Deserialize, Serialize};
use std::path::Path;

pub const MAGIC: &[u8; 8] = b"RAYSPLAT";
pub const VERSION: u32 = 3;
/// The oldest version this build reads: files of versions 1 and 2 carry no checksum (convert the
/// stage again).
const OLDEST: u32 = 3;
const PREAMBLE: usize = 24;

/// A typed array in the blob.
#[derive(Clone, Debug, Serialize, Deserialize)]
struct ArrayRef {
    #[serde(rename = "type")]
    ty: String,
    offset: u64,
    count: u64,
}

#[derive(Serialize, Deserialize)]
struct MeshHeader {
    name: String,
    #[serde(default)]
    double_sided: bool,
    positions: ArrayRef,
    /// `null` for a subdivision surface.
    #[serde(default)]
    indices: Option<ArrayRef>,
    #[serde(default)]
    normals: Option<ArrayRef>,
    #[serde(default)]
    uvs: Option<ArrayRef>,
    #[serde(default)]
    colors: Option<ArrayRef>,
    material_ids: ArrayRef,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    subdivision: Option<SubdivisionHeader>,
}

/// A subdivision surface's cage and tags (`docs/scene-format.md`, "Subdivision surfaces").
#[derive(Serialize, Deserialize)]
struct SubdivisionHeader {
    scheme: Scheme,
    face_counts: ArrayRef,
    face_indices: ArrayRef,
    #[serde(default)]
    holes: Option<ArrayRef>,
    #[serde(default)]
    creases: Option<ArrayRef>,
    #[serde(default)]
    crease_sharpness: Option<ArrayRef>,
    #[serde(default)]
    corners: Option<ArrayRef>,
    #[serde(default)]
    corner_sharpness: Option<ArrayRef>,
    boundary: Boundary,
    face_varying: FaceVaryingRule,
    #[serde(default)]
    uvs: Option<PrimvarHeader>,
    #[serde(default)]
    colors: Option<PrimvarHeader>,
}

#[derive(Serialize, Deserialize)]
struct PrimvarHeader {
    mode: PrimvarMode,
    values: ArrayRef,
    /// Per face-vertex (`linear`, `faceVarying`); `null` for `vertex`.
    #[serde(default)]
    indices: Option<ArrayRef>,
}

#[derive(Serialize, Deserialize)]
struct InstanceHeader {
    mesh: u32,
    #[serde(default)]
    name: String,
    transform: [[f32; 4]; 4],
}

/// Scene-wide source information recorded by the converter.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct Dependency {
    pub path: String,
    /// Content hash; `None` records a file that did not exist at conversion (a missing texture):
    /// the conversion stays valid only while it still does not exist.
    pub sha256: Option<String>,
}

#[derive(Serialize, Deserialize)]
struct Header {
    format: String,
    version: u32,
    #[serde(default)]
    source: String,
    #[serde(default)]
    converter_version: String,
    #[serde(default)]
    dependencies: Vec<Dependency>,
    #[serde(default)]
    stage: serde_json::Value,
    #[serde(default)]
    resolution: Option<[u32; 2]>,
    #[serde(default)]
    camera: Option<Camera>,
    #[serde(default)]
    materials: Vec<Material>,
    #[serde(default)]
    textures: Vec<TextureDesc>,
    #[serde(default)]
    lights: Vec<Light>,
    meshes: Vec<MeshHeader>,
    #[serde(default)]
    instances: Vec<InstanceHeader>,
    #[serde(default)]
    warnings: Vec<Warning>,
}

/// What the converter recorded besides the scene itself.
#[derive(Clone, Debug, Default)]
pub struct FileInfo {
    pub converter_version: String,
    pub dependencies: Vec<Dependency>,
    /// True when the file had no camera (the loader framed the scene and added a warning).
    pub camera_missing: bool,
    /// The USD time code the stage was read at (`None`: each attribute's earliest sample, or not
    /// recorded).
    pub time: Option<f64>,
    /// Every camera of the stage (a `--camera` could pick), if the converter recorded them.
    pub cameras: Vec<String>,
    /// The stage's authored start and end time codes, if any.
    pub time_range: Option<[f64; 2]>,
}

impl FileInfo {
    fn of(header: &Header) -> FileInfo {
        FileInfo {
            converter_version: header.converter_version.clone(),
            dependencies: header.dependencies.clone(),
            camera_missing: header.camera.is_none(),
            time: header.stage.get("time").and_then(|t| t.as_f64()),
            cameras: header.stage.get("cameras").and_then(|c| c.as_array()).map_or_else(Vec::new, |c| {
                c.iter().filter_map(|p| p.as_str().map(str::to_string)).collect()
            }),
            time_range: header.stage.get("time_range").and_then(|r| Some([r.get(0)?.as_f64()?, r.get(1)?.as_f64()?])),
        }
    }
}

/// Read the header only (the checksum is checked too): used by the conversion cache to check
/// dependencies.
pub fn read_info(path: &Path) -> Result<FileInfo> {
    let bytes = crate::io::input::read_input(path)?;
    let (header, _) = parse_header(path, &bytes)?;
    Ok(FileInfo::of(&header))
}

/// Load a scene file. The result is not yet validated (see `SceneDesc::validate`).
pub fn load(path: &Path) -> Result<(SceneDesc, FileInfo)> {
    let bytes = crate::io::input::read_input(path)?;
    let file = path.display().to_string();
    let (header, blob) = parse_header(path, &bytes)?;
    let info = FileInfo::of(&header);
    let mut meshes = Vec::with_capacity(header.meshes.len());
    for m in &header.meshes {
        let ctx = |msg: String| Error::scene(&file, &m.name, msg);
        let positions: Vec<Vec3> = read_array(blob, &m.positions, "f32x3").map_err(ctx)?;
        let indices: Vec<[u32; 3]> = match (&m.indices, &m.subdivision) {
            (Some(a), None) => read_array(blob, a, "u32x3").map_err(ctx)?,
            (None, Some(_)) => Vec::new(),
            (Some(_), Some(_)) => return Err(ctx("a subdivision surface has no triangle indices (\"indices\" must be null)".into())),
            (None, None) => return Err(ctx("the mesh has no indices".into())),
        };
        let subdivision = match &m.subdivision {
            Some(sd) => Some(Box::new(read_subdivision(blob, sd).map_err(ctx)?)),
            None => None,
        };
        let normals = match &m.normals {
            Some(a) => Some(read_array::<Vec3>(blob, a, "f32x3").map_err(ctx)?),
            None => None,
        };
        let uvs = match &m.uvs {
            Some(a) => Some(read_array::<Vec2>(blob, a, "f32x2").map_err(ctx)?),
            None => None,
        };
        let colors = match &m.colors {
            Some(a) => Some(read_array::<Vec3>(blob, a, "f32x3").map_err(ctx)?),
            None => None,
        };
        let material_ids: Vec<u32> = read_array(blob, &m.material_ids, "u32").map_err(ctx)?;
        meshes.push(Mesh {
            name: m.name.clone(),
            positions,
            indices,
            normals,
            uvs,
            colors,
            material_ids,
            double_sided: m.double_sided,
            subdivision,
        });
    }
    let instances = header
        .instances
        .iter()
        .map(|i| Instance { mesh: i.mesh, transform: Mat4::from_cols_array_2d(&i.transform), name: i.name.clone() })
        .collect();
    let camera_missing = header.camera.is_none();
    let source = if header.source.is_empty() { file.clone() } else { header.source.clone() };
    let mut scene = SceneDesc {
        meshes,
        instances,
        materials: header.materials,
        textures: header.textures,
        lights: header.lights,
        camera: header.camera.unwrap_or_default(),
        resolution: header.resolution,
        warnings: header.warnings,
        source,
        ..Default::default()
    };
    if camera_missing {
        scene.frame_default_camera();
        if !scene.warnings.iter().any(|w| w.message.contains("camera")) {
            scene.warnings.push(Warning {
                prim: "/".into(),
                message: "the stage has no camera; using a default camera framing the scene".into(),
            });
        }
    }
    Ok((scene, info))
}

fn parse_header<'a>(path: &Path, bytes: &'a [u8]) -> Result<(Header, &'a [u8])> {
    let file = path.display().to_string();
    let bad = |msg: &str| Error::scene(&file, "-", msg.to_string());
    if bytes.len() < PREAMBLE || &bytes[..8] != MAGIC {
        return Err(bad("not a raysplat scene file (bad magic)"));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    if !(OLDEST..=VERSION).contains(&version) {
        return Err(bad(&format!("unsupported scene format version {version} (this build reads {OLDEST} to {VERSION})")));
    }
    // a CRC-32 of everything after it: a file changed after it was written is refused whole
    if crc32fast::hash(&bytes[16..]) != u32::from_le_bytes(bytes[12..16].try_into().unwrap()) {
        return Err(bad("the file is damaged (checksum mismatch: changed after it was written)"));
    }
    let header_len = u64::from_le_bytes(bytes[16..24].try_into().unwrap()) as usize;
    let end = PREAMBLE.checked_add(header_len).filter(|&e| e <= bytes.len()).ok_or_else(|| bad("truncated header"))?;
    let header: Header =
        serde_json::from_slice(&bytes[PREAMBLE..end]).map_err(|e| bad(&format!("malformed header: {e}")))?;
    if header.format != "raysplat-scene" {
        return Err(bad(&format!("unexpected format tag {:?}", header.format)));
    }
    let blob_start = align16(end).min(bytes.len());
    Ok((header, &bytes[blob_start..]))
}

fn align16(x: usize) -> usize {
    (x + 15) & !15
}

/// Element type name → (scalar count, element size in bytes).
fn elem_size(ty: &str) -> Option<usize> {
    match ty {
        "f32x3" | "u32x3" => Some(12),
        "f32x2" | "u32x2" => Some(8),
        "u32" | "f32" => Some(4),
        _ => None,
    }
}

fn read_array<T: bytemuck::Pod>(blob: &[u8], a: &ArrayRef, expected: &str) -> std::result::Result<Vec<T>, String> {
    if a.ty != expected {
        return Err(format!("array of type {} where {} was expected", a.ty, expected));
    }
    let size = elem_size(expected).expect("known type");
    debug_assert_eq!(size, std::mem::size_of::<T>());
    let start = a.offset as usize;
    let len = (a.count as usize).checked_mul(size).ok_or("array size overflows")?;
    let end = start.checked_add(len).filter(|&e| e <= blob.len()).ok_or_else(|| {
        format!("array at offset {} with {} elements runs past the end of the file", a.offset, a.count)
    })?;
    // Copy (the blob need not be aligned for T in memory).
    let mut out = vec![T::zeroed(); a.count as usize];
    bytemuck::cast_slice_mut::<T, u8>(&mut out).copy_from_slice(&blob[start..end]);
    Ok(out)
}

/// A subdivision header's arrays.
fn read_subdivision(blob: &[u8], h: &SubdivisionHeader) -> std::result::Result<Subdivision, String> {
    let u32s = |a: &Option<ArrayRef>| a.as_ref().map_or(Ok(Vec::new()), |a| read_array::<u32>(blob, a, "u32"));
    let f32s = |a: &Option<ArrayRef>| a.as_ref().map_or(Ok(Vec::new()), |a| read_array::<f32>(blob, a, "f32"));
    fn primvar<T: bytemuck::Pod>(blob: &[u8], p: &Option<PrimvarHeader>, ty: &str) -> std::result::Result<Option<Primvar<T>>, String> {
        let Some(p) = p else { return Ok(None) };
        let indices = match &p.indices {
            Some(a) => read_array(blob, a, "u32")?,
            None => Vec::new(),
        };
        Ok(Some(Primvar { mode: p.mode, values: read_array(blob, &p.values, ty)?, indices }))
    }
    Ok(Subdivision {
        scheme: h.scheme,
        face_counts: read_array(blob, &h.face_counts, "u32")?,
        face_indices: read_array(blob, &h.face_indices, "u32")?,
        holes: u32s(&h.holes)?,
        creases: h.creases.as_ref().map_or(Ok(Vec::new()), |a| read_array::<[u32; 2]>(blob, a, "u32x2"))?,
        crease_sharpness: f32s(&h.crease_sharpness)?,
        corners: u32s(&h.corners)?,
        corner_sharpness: f32s(&h.corner_sharpness)?,
        boundary: h.boundary,
        face_varying: h.face_varying,
        uvs: primvar(blob, &h.uvs, "f32x2")?,
        colors: primvar(blob, &h.colors, "f32x3")?,
    })
}

/// Write a scene to the `.rss` format (used by tests and the C++ API to persist built scenes).
/// The file is written to a temporary name and renamed into place.
pub fn save(scene: &SceneDesc, path: &Path) -> Result<()> {
    let mut blob: Vec<u8> = Vec::new();
    let mut push = |bytes: &[u8], ty: &str, count: usize| -> ArrayRef {
        while blob.len() % 16 != 0 {
            blob.push(0);
        }
        let offset = blob.len() as u64;
        blob.extend_from_slice(bytes);
        ArrayRef { ty: ty.into(), offset, count: count as u64 }
    };
    let mut meshes = Vec::new();
    for m in &scene.meshes {
        let positions = push(bytemuck::cast_slice(&m.positions), "f32x3", m.positions.len());
        let indices = m.subdivision.is_none().then(|| push(bytemuck::cast_slice(&m.indices), "u32x3", m.indices.len()));
        let subdivision = m.subdivision.as_deref().map(|sd| save_subdivision(sd, &mut push));
        let normals = m.normals.as_ref().map(|n| push(bytemuck::cast_slice(n), "f32x3", n.len()));
        let uvs = m.uvs.as_ref().map(|n| push(bytemuck::cast_slice(n), "f32x2", n.len()));
        let colors = m.colors.as_ref().map(|n| push(bytemuck::cast_slice(n), "f32x3", n.len()));
        let material_ids = push(bytemuck::cast_slice(&m.material_ids), "u32", m.material_ids.len());
        meshes.push(MeshHeader {
            name: m.name.clone(),
            double_sided: m.double_sided,
            positions,
            indices,
            normals,
            uvs,
            colors,
            material_ids,
            subdivision,
        });
    }
    let header = Header {
        format: "raysplat-scene".into(),
        version: VERSION,
        source: scene.source.clone(),
        converter_version: "rust".into(),
        dependencies: Vec::new(),
        stage: serde_json::json!({"meters_per_unit": 1.0, "up_axis": "Y"}),
        resolution: scene.resolution,
        camera: Some(scene.camera.clone()),
        materials: scene.materials.clone(),
        textures: scene.textures.clone(),
        lights: scene.lights.clone(),
        meshes,
        instances: scene
            .instances
            .iter()
            .map(|i| InstanceHeader { mesh: i.mesh, name: i.name.clone(), transform: i.transform.to_cols_array_2d() })
            .collect(),
        warnings: scene.warnings.clone(),
    };
    let json = serde_json::to_vec(&header).map_err(|e| Error::scene(path.display().to_string(), "-", e.to_string()))?;
    let mut out = Vec::with_capacity(PREAMBLE + json.len() + 16 + blob.len());
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes()); // the checksum, below
    out.extend_from_slice(&(json.len() as u64).to_le_bytes());
    out.extend_from_slice(&json);
    out.resize(align16(out.len()), 0);
    out.extend_from_slice(&blob);
    let crc = crc32fast::hash(&out[16..]);
    out[12..16].copy_from_slice(&crc.to_le_bytes());
    // through a temporary file and a rename, with the usual `0666 & !umask` permissions
    crate::io::write_file(path, crate::io::Format::Rss, &out)
}

/// A subdivision surface's arrays pushed into the blob; its header.
fn save_subdivision(sd: &Subdivision, push: &mut dyn FnMut(&[u8], &str, usize) -> ArrayRef) -> SubdivisionHeader {
    let mut opt = |v: &[u8], ty: &str, n: usize| (n > 0).then(|| push(v, ty, n));
    let holes = opt(bytemuck::cast_slice(&sd.holes), "u32", sd.holes.len());
    let creases = opt(bytemuck::cast_slice(&sd.creases), "u32x2", sd.creases.len());
    let crease_sharpness = opt(bytemuck::cast_slice(&sd.crease_sharpness), "f32", sd.crease_sharpness.len());
    let corners = opt(bytemuck::cast_slice(&sd.corners), "u32", sd.corners.len());
    let corner_sharpness = opt(bytemuck::cast_slice(&sd.corner_sharpness), "f32", sd.corner_sharpness.len());
    let mut primvar = |mode: PrimvarMode, values: &[u8], ty: &str, n: usize, indices: &[u32]| PrimvarHeader {
        mode,
        values: push(values, ty, n),
        indices: (mode != PrimvarMode::Vertex).then(|| push(bytemuck::cast_slice(indices), "u32", indices.len())),
    };
    let uvs = sd.uvs.as_ref().map(|p| primvar(p.mode, bytemuck::cast_slice(&p.values), "f32x2", p.values.len(), &p.indices));
    let colors = sd.colors.as_ref().map(|p| primvar(p.mode, bytemuck::cast_slice(&p.values), "f32x3", p.values.len(), &p.indices));
    SubdivisionHeader {
        scheme: sd.scheme,
        face_counts: push(bytemuck::cast_slice(&sd.face_counts), "u32", sd.face_counts.len()),
        face_indices: push(bytemuck::cast_slice(&sd.face_indices), "u32", sd.face_indices.len()),
        holes,
        creases,
        crease_sharpness,
        corners,
        corner_sharpness,
        boundary: sd.boundary,
        face_varying: sd.face_varying,
        uvs,
        colors,
    }
}
