// Smallest raysplat program: one emissive triangle seen by the default camera.
#include <iostream>
#include <vector>

#include <raysplat/raysplat.hpp>

int main() {
  try {
    rust::Box<raysplat::SceneBuilder> b = raysplat::new_scene_builder("consumer");
    raysplat::MaterialDesc glow = raysplat::default_material("/Glow");
    glow.emissive_color.value = {1.0f, 1.0f, 1.0f};
    const std::uint32_t material = b->add_material(glow);
    const std::vector<float> p{-1, -1, -5, 1, -1, -5, 0, 1, -5};
    const std::vector<std::uint32_t> tri{0, 1, 2}, ids{material};
    const std::uint32_t mesh = b->add_mesh("/Tri", raysplat::slice(p), raysplat::slice(tri), {}, {},
                                           raysplat::slice(ids), true);
    b->add_instance(raysplat::InstanceDesc{mesh, raysplat::identity(), "/Tri"});
    rust::Box<raysplat::Scene> scene = b->build();
    raysplat::RenderOptions o = raysplat::default_options();
    o.width = o.height = 16;
    o.spp = 1;
    rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, o);
    float centre = r->rgba()[4 * (8 * 16 + 8)];
    std::cout << "raysplat " << raysplat::version() << ": centre pixel " << centre << "\n";
    return centre > 0.5f ? 0 : 1;
  } catch (const std::exception &e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
