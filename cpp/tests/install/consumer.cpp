// A program using an installed raysplat next to the system's own OpenEXR 3.1 and zlib
// (cpp/tests/install_test.sh builds it with find_package and with pkg-config, against the shared
// and the static library, with and without AddressSanitizer).
//
//   consumer <scene.usda> <out.exr> [python] [denoise]
//
// Loads the USD stage (with `python` as StageView::python when given, else RAYSPLAT_PYTHON),
// renders it with the default options (method "auto") at 48x48, writes the EXR, reads it back with
// the system's OpenEXR, and checks that zlib and OpenEXR are the versions this program was
// compiled against. Prints where each library was loaded from ("zlib from <file>") for the test
// script to check. Exit status 1 on any failure.
#include <dlfcn.h>
#include <openexr.h>
#include <zlib.h>

#include <cstring>
#include <iostream>
#include <string>

#include <raysplat/raysplat.hpp>

namespace {

// The file a symbol was loaded from.
std::string origin(const void *symbol) {
  Dl_info info{};
  if (dladdr(symbol, &info) == 0 || info.dli_fname == nullptr) return "?";
  return info.dli_fname;
}

bool fail(const std::string &what) {
  std::cerr << "FAIL: " << what << "\n";
  return false;
}

bool check_system_libraries() {
  bool ok = true;
  // zlib: the runtime version must be the headers' (a bundled 1.2.11 would shadow the host's).
  std::cout << "zlib " << zlibVersion() << " (compiled against " << ZLIB_VERSION << ") from "
            << origin(reinterpret_cast<const void *>(&zlibVersion)) << "\n";
  if (std::strcmp(zlibVersion(), ZLIB_VERSION) != 0) ok = fail("zlib runtime version differs from the headers'");
  int major = 0, minor = 0, patch = 0;
  const char *extra = nullptr;
  exr_get_library_version(&major, &minor, &patch, &extra);
  std::cout << "OpenEXR " << major << "." << minor << "." << patch << " (compiled against "
            << OPENEXR_VERSION_MAJOR << "." << OPENEXR_VERSION_MINOR << "." << OPENEXR_VERSION_PATCH << ") from "
            << origin(reinterpret_cast<const void *>(&exr_get_library_version)) << "\n";
  if (major != OPENEXR_VERSION_MAJOR || minor != OPENEXR_VERSION_MINOR || patch != OPENEXR_VERSION_PATCH)
    ok = fail("OpenEXR runtime version differs from the headers'");
  return ok;
}

// Read the EXR back with the system's OpenEXR (Core C API): its data window must be w x h.
bool check_exr(const std::string &path, std::uint32_t w, std::uint32_t h) {
  exr_context_t ctx = nullptr;
  if (exr_start_read(&ctx, path.c_str(), nullptr) != EXR_ERR_SUCCESS) return fail("system OpenEXR cannot read " + path);
  exr_attr_box2i_t box{};
  const bool read = exr_get_data_window(ctx, 0, &box) == EXR_ERR_SUCCESS;
  exr_finish(&ctx);
  const long width = long(box.max.x) - box.min.x + 1, height = long(box.max.y) - box.min.y + 1;
  std::cout << "read back " << path << ": " << width << "x" << height << "\n";
  if (!read || width != long(w) || height != long(h)) return fail("wrong data window in " + path);
  return true;
}

} // namespace

int main(int argc, char **argv) {
  if (argc < 3) {
    std::cerr << "usage: consumer <scene.usda> <out.exr> [python] [denoise]\n";
    return 2;
  }
  bool ok = check_system_libraries();
  try {
    std::cout << "raysplat " << raysplat::version() << " from "
              << origin(reinterpret_cast<const void *>(&raysplat::load_stage)) << "; denoiser: "
              << raysplat::denoiser() << "\n";
    raysplat::StageView view{};
    if (argc > 3) view.python = argv[3];
    rust::Box<raysplat::Scene> scene = raysplat::load_stage(argv[1], view);
    raysplat::RenderOptions options = raysplat::default_options();
    if (std::string(options.method) != "auto") ok = fail("default_options().method is not auto");
    options.width = options.height = 48;
    if (argc > 4) options.denoise = argv[4];
    rust::Box<raysplat::RenderResult> image = raysplat::render(*scene, options);
    const raysplat::MethodChoice choice = image->choice();
    std::cout << "auto chose " << choice.method << ": " << choice.reason << "\n";
    if (!choice.automatic || choice.method.empty() || choice.reason.empty()) ok = fail("no automatic choice reported");
    std::cout << "layers:";
    for (const rust::String &layer : image->layer_names()) std::cout << " " << (layer.empty() ? "beauty" : std::string(layer));
    std::cout << "\n";
    double sum = 0;
    for (float v : image->rgba()) sum += v;
    if (!(sum > 0)) ok = fail("black or non-finite image");
    image->write_exr(argv[2]);
    ok = check_exr(argv[2], image->width(), image->height()) && ok;
    // an error still arrives as an exception through the installed library
    try {
      options.method = "nonsense";
      raysplat::render(*scene, options);
      ok = fail("an unknown method was accepted");
    } catch (const rust::Error &e) {
      std::cout << "error as expected: " << e.what() << "\n";
    }
  } catch (const std::exception &e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return ok ? 0 : 1;
}
