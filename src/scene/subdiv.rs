//! Subdivision surfaces in the scene description: a mesh's control cage and its tags
//! ([`super::Mesh::subdivision`]), and how the renderer turns them into surfaces
//! ([`SubdivisionMode`]).

use glam::{Vec2, Vec3};
use serde::{Deserialize, Serialize};

/// The subdivision rules (USD `subdivisionScheme`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Scheme {
    #[serde(rename = "catmullClark")]
    CatmullClark,
    #[serde(rename = "loop")]
    Loop,
    #[serde(rename = "bilinear")]
    Bilinear,
}

/// How the boundary is refined (USD `interpolateBoundary`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Boundary {
    /// Boundary faces are not part of the surface (they only shape their neighbours).
    #[serde(rename = "none")]
    None,
    /// Boundary edges are infinitely sharp creases.
    #[serde(rename = "edgeOnly")]
    EdgeOnly,
    /// As `EdgeOnly`, and a boundary point of a single face is an infinitely sharp corner.
    #[serde(rename = "edgeAndCorner")]
    EdgeAndCorner,
}

/// How face-varying data is refined (USD `faceVaryingLinearInterpolation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum FaceVaryingRule {
    #[serde(rename = "none")]
    None,
    #[serde(rename = "cornersOnly")]
    CornersOnly,
    #[serde(rename = "cornersPlus1")]
    CornersPlus1,
    #[serde(rename = "cornersPlus2")]
    CornersPlus2,
    #[serde(rename = "boundaries")]
    Boundaries,
    #[serde(rename = "all")]
    All,
}

/// How a primvar's values spread over a subdivision surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum PrimvarMode {
    /// One value per point, refined by the surface's own rules (USD `vertex`).
    #[serde(rename = "vertex")]
    Vertex,
    /// Values per face-vertex interpolated linearly within each face (USD `varying`, `uniform`,
    /// `constant`, and face-varying data under `faceVaryingLinearInterpolation = all`).
    #[serde(rename = "linear")]
    Linear,
    /// Values per face-vertex refined by the scheme over their own topology, with the mesh's
    /// [`FaceVaryingRule`] (USD `faceVarying`).
    #[serde(rename = "faceVarying")]
    FaceVarying,
}

/// A primvar on a subdivision surface.
#[derive(Clone, Debug, PartialEq)]
pub struct Primvar<T> {
    pub mode: PrimvarMode,
    pub values: Vec<T>,
    /// Per face-vertex of the cage, the index of its value (`Linear`, `FaceVarying`); empty for
    /// `Vertex` (one value per point).
    pub indices: Vec<u32>,
}

/// A subdivision surface's control cage: its faces and tags. The cage's points are the mesh's
/// `positions`; its `material_ids` are per face (or one for all).
#[derive(Clone, Debug, PartialEq)]
pub struct Subdivision {
    pub scheme: Scheme,
    /// Vertices of each face.
    pub face_counts: Vec<u32>,
    /// The faces' vertices, face after face (counter-clockwise seen from the front).
    pub face_indices: Vec<u32>,
    /// Faces that are not part of the surface (they shape their neighbours).
    pub holes: Vec<u32>,
    /// Creased edges (pairs of points) and their sharpness (≥ 0; 10 and more: infinitely sharp).
    pub creases: Vec<[u32; 2]>,
    pub crease_sharpness: Vec<f32>,
    /// Sharp points (corners) and their sharpness.
    pub corners: Vec<u32>,
    pub corner_sharpness: Vec<f32>,
    pub boundary: Boundary,
    pub face_varying: FaceVaryingRule,
    pub uvs: Option<Primvar<Vec2>>,
    pub colors: Option<Primvar<Vec3>>,
}

impl Subdivision {
    /// The first face-vertex of each face.
    pub fn offsets(&self) -> Vec<u32> {
        let mut off = 0u32;
        self.face_counts
            .iter()
            .map(|&n| {
                let o = off;
                off += n;
                o
            })
            .collect()
    }
}

/// What the renderer makes of subdivision surfaces (`--subdivision`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SubdivisionMode {
    /// Catmull–Clark surfaces tessellated by Embree at edge rates that follow the camera (a target
    /// edge length in pixels); Loop and bilinear ones refined to a level that follows it too.
    #[default]
    Auto,
    /// The control cages, as polygon meshes.
    Cage,
    /// A fixed level: Catmull–Clark surfaces tessellated at 2^N segments per cage edge, Loop and
    /// bilinear ones refined N times (N ≥ 1).
    Level(u32),
}

/// The most levels `SubdivisionMode::Level` accepts (each has four times the faces).
pub const MAX_SUBDIVISION_LEVEL: u32 = 6;

impl std::str::FromStr for SubdivisionMode {
    type Err = String;

    /// `auto`, `cage` or a level `1`…`6` (`0` is the cage).
    fn from_str(s: &str) -> Result<SubdivisionMode, String> {
        match s {
            "auto" => Ok(SubdivisionMode::Auto),
            "cage" => Ok(SubdivisionMode::Cage),
            _ => match s.parse::<u32>() {
                Ok(0) => Ok(SubdivisionMode::Cage),
                Ok(n) if n <= MAX_SUBDIVISION_LEVEL => Ok(SubdivisionMode::Level(n)),
                Ok(n) => Err(format!("{n} is more than {MAX_SUBDIVISION_LEVEL} (each level has four times the faces)")),
                Err(_) => Err(format!("{s:?} is not auto, cage or a level 0…{MAX_SUBDIVISION_LEVEL}")),
            },
        }
    }
}

impl std::fmt::Display for SubdivisionMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SubdivisionMode::Auto => write!(f, "auto"),
            SubdivisionMode::Cage => write!(f, "cage"),
            SubdivisionMode::Level(n) => write!(f, "{n}"),
        }
    }
}

impl Subdivision {
    /// Check the cage of a mesh of `npts` points: counts that fit together, indices in range,
    /// finite non-negative sharpness, primvars of the right sizes with finite values.
    pub fn validate(&self, npts: usize, material_ids: &[u32], n_materials: u32) -> Result<(), String> {
        let (nf, nfv) = (self.face_counts.len(), self.face_indices.len());
        let sum: u64 = self.face_counts.iter().map(|&c| c as u64).sum();
        if sum != nfv as u64 {
            return Err(format!("subdivision surface: face vertex counts sum to {sum} where there are {nfv} face vertex indices"));
        }
        if let Some(&bad) = self.face_indices.iter().find(|&&i| i as usize >= npts) {
            return Err(format!("subdivision surface: vertex index {bad} out of range (mesh has {npts} points)"));
        }
        if let Some(&bad) = self.holes.iter().find(|&&f| f as usize >= nf) {
            return Err(format!("subdivision surface: hole {bad} out of range ({nf} faces)"));
        }
        if self.creases.len() != self.crease_sharpness.len() || self.corners.len() != self.corner_sharpness.len() {
            return Err("subdivision surface: creases or corners without one sharpness each".into());
        }
        if self.creases.iter().flatten().chain(&self.corners).any(|&v| v as usize >= npts) {
            return Err(format!("subdivision surface: a crease or corner names a point out of range (mesh has {npts} points)"));
        }
        if let Some(s) = self.crease_sharpness.iter().chain(&self.corner_sharpness).find(|s| !(s.is_finite() && **s >= 0.0)) {
            return Err(format!("subdivision surface: sharpness {s} must be finite and at least 0"));
        }
        if !(material_ids.len() == 1 || material_ids.len() == nf) {
            return Err(format!("{} material ids for {nf} faces of a subdivision surface", material_ids.len()));
        }
        if let Some(bad) = material_ids.iter().find(|&&m| m >= n_materials) {
            return Err(format!("material index {bad} out of range ({n_materials} materials)"));
        }
        fn primvar<T>(what: &str, p: &Option<Primvar<T>>, finite: fn(&T) -> bool, npts: usize, nfv: usize) -> Result<(), String> {
            let Some(p) = p else { return Ok(()) };
            if !p.values.iter().all(finite) {
                return Err(format!("{what} contain NaN or infinite values"));
            }
            match p.mode {
                PrimvarMode::Vertex if p.values.len() != npts || !p.indices.is_empty() => {
                    Err(format!("{} vertex {what} for {npts} points", p.values.len()))
                }
                PrimvarMode::Linear | PrimvarMode::FaceVarying if p.indices.len() != nfv => {
                    Err(format!("{} {what} indices for {nfv} face vertices", p.indices.len()))
                }
                _ => match p.indices.iter().find(|&&i| i as usize >= p.values.len()) {
                    Some(bad) => Err(format!("{what} index {bad} out of range ({} values)", p.values.len())),
                    None => Ok(()),
                },
            }
        }
        primvar("texture coordinates", &self.uvs, |v| v.is_finite(), npts, nfv)?;
        primvar("vertex colours", &self.colors, |v| v.is_finite(), npts, nfv)
    }
}
