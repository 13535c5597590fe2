//! Per-vertex tangents for normal maps: MikkTSpace (the convention of the bakers that make normal
//! maps — Blender, Substance, xNormal — and of glTF), through the `bevy_mikktspace` crate, from a
//! mesh's positions, normals (face normals where it has none) and texture coordinates (USD's: `v`
//! up, so the bitangent follows the image's up direction, as OpenGL-style maps expect).

use crate::scene::Mesh;
use glam::{Vec2, Vec3, Vec4};

/// Tangents of `mesh`, one per vertex: `xyz` the tangent (object space), `w` ±1 the bitangent's
/// sign (`B = w · N × T`). `None` without texture coordinates, or when the mesh has no triangle
/// MikkTSpace can use. A vertex shared by triangles whose tangent spaces MikkTSpace keeps apart
/// (a mirrored texture seam on shared vertices) takes the last one.
pub fn mikktspace(mesh: &Mesh) -> Option<Vec<Vec4>> {
    let uvs = mesh.uvs.as_ref()?;
    let mut g = Geometry { mesh, uvs, out: vec![Vec4::new(1.0, 0.0, 0.0, 1.0); mesh.positions.len()] };
    bevy_mikktspace::generate_tangents(&mut g).then_some(g.out)
}

struct Geometry<'a> {
    mesh: &'a Mesh,
    uvs: &'a [Vec2],
    out: Vec<Vec4>,
}

impl Geometry<'_> {
    #[inline]
    fn vertex(&self, face: usize, vert: usize) -> usize {
        self.mesh.indices[face][vert] as usize
    }
}

impl bevy_mikktspace::Geometry for Geometry<'_> {
    fn num_faces(&self) -> usize {
        self.mesh.indices.len()
    }

    fn num_vertices_of_face(&self, _face: usize) -> usize {
        3
    }

    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.mesh.positions[self.vertex(face, vert)].to_array()
    }

    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        match &self.mesh.normals {
            Some(n) => n[self.vertex(face, vert)].to_array(),
            None => {
                let p = |k: usize| self.mesh.positions[self.vertex(face, k)];
                (p(1) - p(0)).cross(p(2) - p(0)).try_normalize().unwrap_or(Vec3::Z).to_array()
            }
        }
    }

    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.uvs[self.vertex(face, vert)].to_array()
    }

    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        let v = self.vertex(face, vert);
        self.out[v] = Vec4::from(tangent);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On a flat quad whose texture coordinates turn with the geometry, the tangent is the
    /// direction of increasing `u` and the bitangent (`w · N × T`) that of increasing `v`, for
    /// either handedness of the mapping.
    #[test]
    fn tangents_follow_the_texture_axes() {
        for (flip, sign) in [(1.0f32, 1.0f32), (-1.0, -1.0)] {
            let mesh = Mesh {
                name: "/Quad".into(),
                positions: vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
                indices: vec![[0, 1, 2], [0, 2, 3]],
                normals: Some(vec![Vec3::Z; 4]),
                // u along +y, v along −x (or +x, mirrored)
                uvs: Some(vec![Vec2::new(0.0, 0.0), Vec2::new(0.0, -flip), Vec2::new(1.0, -flip), Vec2::new(1.0, 0.0)]),
                material_ids: vec![0],
                ..Default::default()
            };
            let t = mikktspace(&mesh).expect("tangents");
            for v in t {
                assert!((v.truncate() - Vec3::Y).length() < 1e-5, "{v}");
                assert_eq!(v.w, sign);
                let b = v.w * Vec3::Z.cross(v.truncate());
                assert!((b - Vec3::new(-flip, 0.0, 0.0)).length() < 1e-5, "{b}");
            }
        }
    }
}
