// A Cornell box built from plain C++ arrays with raysplat::SceneBuilder (used by cornell.cpp and
// the API tests). Units: metres, Y up. The room is x ∈ [-1, 1], y ∈ [0, 2], z ∈ [-1, 1], open
// towards +Z where the camera stands; a rect light hangs under the ceiling; two blocks are
// instances of one unit cube.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <raysplat/raysplat.hpp>

namespace cornell {

// Object-to-world transform T · R_y(angle) · S, column-major.
inline raysplat::Matrix trs(float tx, float ty, float tz, float angle_y_deg, float sx, float sy, float sz) {
  const float a = angle_y_deg * 3.14159265358979f / 180.0f;
  const float c = std::cos(a), s = std::sin(a);
  return raysplat::Matrix{c * sx, 0, -s * sx, 0,  //
                          0, sy, 0, 0,            //
                          s * sz, 0, c * sz, 0,   //
                          tx, ty, tz, 1};
}

inline raysplat::MaterialDesc diffuse(const char *name, float r, float g, float b) {
  raysplat::MaterialDesc m = raysplat::default_material(name);
  m.diffuse_color.value = {r, g, b};
  m.use_specular_workflow = true; // no specular lobe: a Lambertian surface
  m.specular_color.value = {0, 0, 0};
  m.roughness.value = 1.0f;
  return m;
}

// One quad (4 points, counter-clockwise seen from the side it faces) as a mesh of two triangles.
inline std::uint32_t add_quad(raysplat::SceneBuilder &b, const char *name, const std::vector<float> &p,
                              std::uint32_t material) {
  const std::vector<std::uint32_t> indices{0, 1, 2, 0, 2, 3};
  const std::vector<std::uint32_t> materials{material};
  const std::uint32_t mesh = b.add_mesh(name, raysplat::slice(p), raysplat::slice(indices), {}, {},
                                        raysplat::slice(materials), false);
  b.add_instance(raysplat::InstanceDesc{mesh, raysplat::identity(), name});
  return mesh;
}

inline rust::Box<raysplat::SceneBuilder> make_builder(const std::string &source = "cornell_box.hpp") {
  rust::Box<raysplat::SceneBuilder> b = raysplat::new_scene_builder(source);
  const std::uint32_t white = b->add_material(diffuse("/Looks/White", 0.73f, 0.73f, 0.73f));
  const std::uint32_t red = b->add_material(diffuse("/Looks/Red", 0.63f, 0.065f, 0.05f));
  const std::uint32_t green = b->add_material(diffuse("/Looks/Green", 0.14f, 0.45f, 0.091f));

  add_quad(*b, "/Room/Floor", {-1, 0, 1, 1, 0, 1, 1, 0, -1, -1, 0, -1}, white);
  add_quad(*b, "/Room/Ceiling", {-1, 2, -1, 1, 2, -1, 1, 2, 1, -1, 2, 1}, white);
  add_quad(*b, "/Room/Back", {-1, 0, -1, 1, 0, -1, 1, 2, -1, -1, 2, -1}, white);
  add_quad(*b, "/Room/Left", {-1, 0, 1, -1, 0, -1, -1, 2, -1, -1, 2, 1}, red);
  add_quad(*b, "/Room/Right", {1, 0, -1, 1, 0, 1, 1, 2, 1, 1, 2, -1}, green);

  // A unit cube centred on the origin (outward faces), placed twice.
  const std::vector<float> cube{-0.5f, -0.5f, -0.5f, 0.5f, -0.5f, -0.5f, 0.5f, 0.5f, -0.5f, -0.5f, 0.5f, -0.5f,
                                -0.5f, -0.5f, 0.5f,  0.5f, -0.5f, 0.5f,  0.5f, 0.5f, 0.5f,  -0.5f, 0.5f, 0.5f};
  const std::uint32_t quads[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 4, 7, 3}, {1, 2, 6, 5}};
  std::vector<std::uint32_t> cube_indices;
  for (const auto &q : quads) {
    cube_indices.insert(cube_indices.end(), {q[0], q[1], q[2], q[0], q[2], q[3]});
  }
  const std::vector<std::uint32_t> cube_materials{white};
  const std::uint32_t block = b->add_mesh("/Blocks/Cube", raysplat::slice(cube), raysplat::slice(cube_indices), {},
                                          {}, raysplat::slice(cube_materials), false);
  b->add_instance(raysplat::InstanceDesc{block, trs(0.35f, 0.3f, 0.35f, -17.0f, 0.6f, 0.6f, 0.6f), "/Blocks/Short"});
  b->add_instance(raysplat::InstanceDesc{block, trs(-0.35f, 0.6f, -0.3f, 17.0f, 0.6f, 1.2f, 0.6f), "/Blocks/Tall"});

  // Rect light under the ceiling, emitting down (local −Z turned to world −Y: rotation of −90° about X).
  raysplat::LightDesc light = raysplat::default_light(raysplat::LightKind::Rect, "/Lights/Ceiling");
  light.transform = raysplat::Matrix{1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 1.98f, 0, 1};
  light.width = 0.5f;
  light.height = 0.4f;
  light.radiance = {17.0f, 12.0f, 4.0f};
  b->add_light(light);

  // Pinhole camera at z = 3.75 looking down −Z with a 39.3° field of view: the open front of the
  // box fills the view.
  raysplat::CameraDesc camera = raysplat::default_camera();
  camera.name = "/Camera";
  camera.transform = raysplat::translation(0.0f, 1.0f, 3.75f);
  camera.focal_length = 50.0f;
  camera.horizontal_aperture = camera.vertical_aperture = 2.0f * 50.0f * std::tan(0.5f * 39.3f * 3.14159265358979f / 180.0f);
  camera.clipping = {0.01f, 100.0f};
  b->set_camera(camera);
  b->set_resolution(256, 256);
  return b;
}

// The validated scene.
inline rust::Box<raysplat::Scene> make_scene(const std::string &source = "cornell_box.hpp") {
  return make_builder(source)->build();
}

} // namespace cornell
