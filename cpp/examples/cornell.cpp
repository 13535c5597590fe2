// Build a Cornell box from C++ arrays, render it with raysplat and write an OpenEXR file.
//
//   cornell [output.exr [spp [method]]]
//
// Build: see docs/cpp.md (cmake -S cpp -B build/cpp && cmake --build build/cpp).
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <iostream>
#include <string>

#include <raysplat/raysplat.hpp>

#include "cornell_box.hpp"

int main(int argc, char **argv) {
  const std::string output = argc > 1 ? argv[1] : "cornell.exr";
  try {
    rust::Box<raysplat::Scene> scene = cornell::make_scene("cornell.cpp");
    std::cerr << "scene: " << scene->mesh_count() << " meshes, " << scene->triangle_count() << " triangles, "
              << scene->lights().size() << " light\n";

    raysplat::RenderOptions options = raysplat::default_options();
    options.spp = argc > 2 ? static_cast<std::uint32_t>(std::strtoul(argv[2], nullptr, 10)) : 64;
    if (argc > 3) options.method = argv[3];
    options.seed = 1;

    // Print progress in steps of 10 %.
    int last = -1;
    raysplat::FunctionProgress progress([&last](const std::string &stage, std::uint64_t done, std::uint64_t total) {
      const int pct = total ? static_cast<int>(100 * done / total) : 0;
      if (done == 0) last = -1;
      if (pct / 10 != last / 10) {
        last = pct;
        std::cerr << "  " << stage << ": " << pct << " %\n";
      }
    });
    rust::Box<raysplat::RenderResult> image = raysplat::render(*scene, options, progress);
    image->write_exr(output);

    // Mean of the beauty layer, as a sanity figure.
    const rust::Slice<const float> rgba = image->rgba();
    double sum[3] = {0, 0, 0};
    for (std::size_t i = 0; i < rgba.size(); i += 4) {
      for (int c = 0; c < 3; ++c) sum[c] += rgba[i + c];
    }
    const double n = static_cast<double>(rgba.size() / 4);
    std::cerr << image->stats().summary;
    std::cerr << "wrote " << output << " (" << image->width() << "x" << image->height() << ", method "
              << image->choice().method << "), mean RGB " << sum[0] / n << " " << sum[1] / n << " " << sum[2] / n << "\n";
    return 0;
  } catch (const std::exception &e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
}
