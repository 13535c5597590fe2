// Tests of the raysplat C++ API (registered with CTest, also built with AddressSanitizer).
//
//   test_api [test-name-substring ...]
//
// RAYSPLAT_SOURCE_DIR (the repository, for scenes/cornell-box.usda) and RAYSPLAT_TEST_OUTPUT_DIR
// are compile-time definitions set by cpp/CMakeLists.txt.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <future>
#include <iostream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <raysplat/raysplat.hpp>

#if defined(__SANITIZE_ADDRESS__)
#define RAYSPLAT_TEST_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RAYSPLAT_TEST_ASAN 1
#endif
#endif

#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include "cornell_box.hpp"

#ifndef RAYSPLAT_SOURCE_DIR
#error "RAYSPLAT_SOURCE_DIR must be defined (the repository root)"
#endif
#ifndef RAYSPLAT_TEST_OUTPUT_DIR
#define RAYSPLAT_TEST_OUTPUT_DIR "."
#endif

namespace {

using Clock = std::chrono::steady_clock;

// Results so far (read by the cancellation watchdog when it has to end the process).
int passed = 0, failed = 0;

struct Failure : std::runtime_error {
  using std::runtime_error::runtime_error;
};

#define CHECK(cond)                                                                                        \
  do {                                                                                                     \
    if (!(cond)) {                                                                                         \
      std::ostringstream os_;                                                                              \
      os_ << __FILE__ << ":" << __LINE__ << ": CHECK(" #cond ") failed";                                   \
      throw Failure(os_.str());                                                                            \
    }                                                                                                      \
  } while (0)

#define CHECK_MSG(cond, msg)                                                                               \
  do {                                                                                                     \
    if (!(cond)) {                                                                                         \
      std::ostringstream os_;                                                                              \
      os_ << __FILE__ << ":" << __LINE__ << ": CHECK(" #cond ") failed: " << msg;                          \
      throw Failure(os_.str());                                                                            \
    }                                                                                                      \
  } while (0)

bool contains(const std::string &s, const std::string &part) { return s.find(part) != std::string::npos; }

// Run `f`, require that it throws a std::exception, and return what().
std::string thrown(const std::function<void()> &f) {
  try {
    f();
  } catch (const rust::Error &e) {
    return e.what();
  } catch (const std::exception &e) {
    throw Failure(std::string("threw a std::exception that is not rust::Error: ") + e.what());
  }
  throw Failure("expected an exception, none was thrown");
}

std::string usd_path() { return std::string(RAYSPLAT_SOURCE_DIR) + "/scenes/cornell-box.usda"; }
std::string out_path(const std::string &name) { return std::string(RAYSPLAT_TEST_OUTPUT_DIR) + "/" + name; }

// The path tracer (the defaults would let auto choose) at a small size.
raysplat::RenderOptions small_options(std::uint32_t size, std::uint32_t spp, std::uint64_t seed) {
  raysplat::RenderOptions o = raysplat::default_options();
  o.method = "pt";
  o.width = size;
  o.height = size;
  o.spp = spp;
  o.seed = seed;
  return o;
}

// Bit-identical pixels in every layer.
bool same_pixels(const raysplat::RenderResult &a, const raysplat::RenderResult &b, std::string *why) {
  if (a.width() != b.width() || a.height() != b.height()) {
    *why = "sizes differ";
    return false;
  }
  const rust::Vec<rust::String> names = a.layer_names(), other = b.layer_names();
  if (!std::equal(names.begin(), names.end(), other.begin(), other.end())) {
    *why = "layer names differ";
    return false;
  }
  for (const rust::String &name : names) {
    const rust::Slice<const float> pa = a.pixels(name), pb = b.pixels(name);
    if (pa.size() != pb.size() || std::memcmp(pa.data(), pb.data(), pa.size() * sizeof(float)) != 0) {
      std::size_t first = 0;
      while (first < std::min(pa.size(), pb.size()) && std::memcmp(&pa[first], &pb[first], sizeof(float)) == 0) ++first;
      std::ostringstream os;
      os << "layer \"" << name << "\" differs at value " << first;
      if (first < std::min(pa.size(), pb.size())) os << " (" << pa[first] << " vs " << pb[first] << ")";
      *why = os.str();
      return false;
    }
  }
  return true;
}

void require_same(const raysplat::RenderResult &a, const raysplat::RenderResult &b) {
  std::string why;
  CHECK_MSG(same_pixels(a, b, &why), why);
}

struct Summary {
  double mean[3] = {0, 0, 0};
  std::size_t non_finite = 0;
  std::size_t non_black = 0;
};

Summary summarize(const raysplat::RenderResult &r) {
  Summary s;
  const rust::Slice<const float> px = r.rgba();
  const std::size_t n = px.size() / 4;
  for (std::size_t i = 0; i < n; ++i) {
    bool black = true;
    for (int c = 0; c < 4; ++c) {
      const float v = px[4 * i + c];
      if (!std::isfinite(v)) ++s.non_finite;
      if (c < 3) {
        s.mean[c] += v / static_cast<double>(n);
        if (v > 0) black = false;
      }
    }
    if (!black) ++s.non_black;
  }
  return s;
}

// Export every array of `scene` through the API and build a new scene from them.
rust::Box<raysplat::Scene> rebuild_from_arrays(const raysplat::Scene &scene, const std::string &source) {
  rust::Box<raysplat::SceneBuilder> b = raysplat::new_scene_builder(source);
  for (const raysplat::TextureDesc &t : scene.textures()) b->add_texture(t);
  for (const raysplat::MaterialDesc &m : scene.materials()) b->add_material(m);
  for (std::size_t i = 0; i < scene.mesh_count(); ++i) {
    // Copy into std::vectors, as a C++ pipeline holding its own arrays would.
    const raysplat::MeshData m = scene.mesh(i);
    const std::vector<float> positions(m.positions.begin(), m.positions.end());
    const std::vector<std::uint32_t> indices(m.indices.begin(), m.indices.end());
    const std::vector<float> normals(m.normals.begin(), m.normals.end());
    const std::vector<float> uvs(m.uvs.begin(), m.uvs.end());
    const std::vector<std::uint32_t> materials(m.material_ids.begin(), m.material_ids.end());
    const std::uint32_t k = b->add_mesh(m.name, raysplat::slice(positions), raysplat::slice(indices),
                                        raysplat::slice(normals), raysplat::slice(uvs), raysplat::slice(materials),
                                        m.double_sided);
    CHECK(k == i);
    const std::vector<float> colors(m.colors.begin(), m.colors.end());
    b->set_mesh_colors(k, raysplat::slice(colors));
  }
  for (std::size_t i = 0; i < scene.instance_count(); ++i) b->add_instance(scene.instance(i));
  for (const raysplat::LightDesc &l : scene.lights()) b->add_light(l);
  b->set_camera(scene.camera());
  const std::array<std::uint32_t, 2> res = scene.resolution();
  b->set_resolution(res[0], res[1]);
  return b->build();
}

// Counts calls and checks that they never overlap.
class CountingProgress : public raysplat::ProgressCallback {
public:
  std::atomic<int> begins{0}, advances{0}, finishes{0}, in_flight{0}, overlaps{0};
  std::atomic<std::uint64_t> last_done{0}, last_total{0};
  Clock::time_point first_call{}, last_call{};
  std::mutex time_lock;

  void enter() {
    if (in_flight.fetch_add(1) != 0) overlaps++;
    std::lock_guard<std::mutex> g(time_lock);
    const auto now = Clock::now();
    if (first_call == Clock::time_point{}) first_call = now;
    last_call = now;
  }
  void leave() { in_flight.fetch_sub(1); }
  void begin(rust::Str, std::uint64_t total) override {
    enter();
    begins++;
    last_total = total;
    leave();
  }
  void advance(std::uint64_t done, std::uint64_t total) override {
    enter();
    advances++;
    last_done = done;
    last_total = total;
    leave();
  }
  void finish() override {
    enter();
    finishes++;
    leave();
  }
};

// ------------------------------------------------------------------------------------------------

void test_usd_and_arrays_render_identically() {
  rust::Box<raysplat::Scene> usd = raysplat::load_scene(usd_path());
  CHECK(usd->triangle_count() > 0);
  CHECK(std::string(usd->source()) == usd_path());
  rust::Box<raysplat::Scene> arrays = rebuild_from_arrays(*usd, "arrays exported from " + usd_path());
  CHECK(arrays->mesh_count() == usd->mesh_count());
  CHECK(arrays->triangle_count() == usd->triangle_count());
  for (std::size_t i = 0; i < usd->mesh_count(); ++i) CHECK(usd->mesh(i) == arrays->mesh(i));
  CHECK(usd->materials().size() == arrays->materials().size());

  const raysplat::RenderOptions o = small_options(64, 8, 7);
  rust::Box<raysplat::RenderResult> a = raysplat::render(*usd, o);
  rust::Box<raysplat::RenderResult> b = raysplat::render(*arrays, o);
  require_same(*a, *b);
  const Summary s = summarize(*a);
  CHECK(s.non_finite == 0);
  CHECK(s.non_black > 64 * 64 / 2);
  a->write_exr(out_path("usd_cornell.exr"));

  // A different seed gives different noise: the comparison above can fail.
  rust::Box<raysplat::RenderResult> c = raysplat::render(*usd, small_options(64, 8, 8));
  std::string why;
  CHECK(!same_pixels(*a, *c, &why));
}

void test_cornell_from_literals_is_plausible() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  CHECK(scene->mesh_count() == 6);
  CHECK(scene->instance_count() == 7);
  CHECK(scene->triangle_count() == 5 * 2 + 2 * 12);
  CHECK(scene->resolution()[0] == 256);

  const std::uint32_t size = 48;
  rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, small_options(size, 16, 3));
  CHECK(r->width() == size && r->height() == size);
  const Summary s = summarize(*r);
  CHECK_MSG(s.non_finite == 0, s.non_finite << " NaN/Inf values");
  CHECK_MSG(s.non_black > size * size * 9 / 10, s.non_black << " non-black pixels");
  for (double m : s.mean) CHECK_MSG(m > 0.01 && m < 10.0, "mean " << m);

  // Layers and channels as documented.
  const std::vector<std::string> expected{"", "albedo", "normal", "depth", "direct", "indirect"};
  for (const std::string &layer : expected) {
    const rust::Vec<rust::String> names = r->layer_names();
    CHECK_MSG(std::find(names.begin(), names.end(), rust::String(layer)) != names.end(), "layer " << layer);
    const std::size_t channels = r->channels(layer).size();
    CHECK(r->pixels(layer).size() == channels * size * size);
  }
  CHECK(r->channels("").size() == 4);
  CHECK(std::string(r->channels("")[3]) == "A");
  // Alpha is 1 everywhere (a closed view of the room).
  const rust::Slice<const float> px = r->rgba();
  for (std::size_t i = 3; i < px.size(); i += 4) CHECK(px[i] == 1.0f);

  // Left wall red, right wall green: average a column band half-way up the image.
  auto band = [&](std::uint32_t x0, std::uint32_t x1, int c) {
    double sum = 0;
    int n = 0;
    for (std::uint32_t y = size / 4; y < size / 2; ++y)
      for (std::uint32_t x = x0; x < x1; ++x, ++n) sum += px[4 * (y * size + x) + c];
    return sum / n;
  };
  CHECK_MSG(band(1, 5, 0) > 1.5 * band(1, 5, 1), "left wall red " << band(1, 5, 0) << " vs " << band(1, 5, 1));
  CHECK_MSG(band(size - 5, size - 1, 1) > 1.5 * band(size - 5, size - 1, 0), "right wall green");

  // Depth is positive where the camera sees the room.
  const rust::Slice<const float> depth = r->pixels("depth");
  CHECK(*std::min_element(depth.begin(), depth.end()) > 0.0f);

  r->write_exr(out_path("literal_cornell.exr"));
  std::ifstream f(out_path("literal_cornell.exr"), std::ios::binary);
  unsigned char magic[4] = {0, 0, 0, 0};
  f.read(reinterpret_cast<char *>(magic), 4);
  CHECK(magic[0] == 0x76 && magic[1] == 0x2f && magic[2] == 0x31 && magic[3] == 0x01);
}

void test_cancel_from_another_thread() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  raysplat::RenderOptions o = small_options(64, 1000000, 1);
  rust::Box<raysplat::CancelToken> token = raysplat::new_cancel_token();
  CountingProgress progress;
  // The render runs on its own thread; this thread cancels it after 200 ms and waits at most 5 s
  // for it to return (a render that ignores cancellation would otherwise hang the test for hours).
  std::promise<std::string> outcome;
  std::future<std::string> result = outcome.get_future();
  const Clock::time_point t0 = Clock::now();
  std::thread renderer([&] {
    try {
      raysplat::render(*scene, o, progress, *token);
      outcome.set_value("(no exception)");
    } catch (const std::exception &e) {
      outcome.set_value(e.what());
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(200));
  const Clock::time_point cancelled_at = Clock::now();
  token->cancel();
  if (result.wait_for(std::chrono::seconds(5)) != std::future_status::ready) {
    std::cerr << "test cancel_from_another_thread ... FAILED: the render did not return within 5 s of cancel()\n";
    std::cout << passed << " passed, " << failed + 1 << " failed\n" << std::flush;
    std::_Exit(1); // the render thread cannot be joined
  }
  const std::string msg = result.get();
  const Clock::time_point t1 = Clock::now();
  renderer.join();
  const double after_cancel = std::chrono::duration<double>(t1 - cancelled_at).count();
  const double total = std::chrono::duration<double>(t1 - t0).count();
  std::cerr << "    cancelled after " << total << " s, returned " << after_cancel << " s after cancel()\n";
  CHECK_MSG(contains(msg, "cancelled"), msg);
  CHECK_MSG(total >= 0.19, total);
  CHECK_MSG(after_cancel < 2.0, "render returned " << after_cancel << " s after cancel()");
  CHECK(token->is_cancelled());
  CHECK(progress.begins >= 1);
  CHECK(progress.finishes == 1);
  CHECK(progress.overlaps == 0);

  // A cancelled token cancels the next render at once; reset() makes it usable again.
  const std::string again = thrown([&] { raysplat::render(*scene, small_options(16, 1, 1), *token); });
  CHECK(contains(again, "cancelled"));
  token->reset();
  CHECK(!token->is_cancelled());
  raysplat::render(*scene, small_options(16, 1, 1), *token);
}

void test_progress_is_reported_in_order() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  CountingProgress progress;
  raysplat::render(*scene, small_options(64, 4, 1), progress);
  CHECK(progress.begins >= 1);
  CHECK(progress.advances >= 1);
  CHECK(progress.finishes == 1);
  CHECK(progress.overlaps == 0);
  CHECK_MSG(progress.last_done == progress.last_total, progress.last_done << " of " << progress.last_total);
}

void test_invalid_arguments_throw_clear_messages() {
  const std::vector<float> tri{0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::vector<std::uint32_t> one_material{0};
  auto builder = [] {
    rust::Box<raysplat::SceneBuilder> b = raysplat::new_scene_builder("bad-scene");
    b->add_material(raysplat::default_material("/Looks/Grey"));
    return b;
  };
  auto place = [](raysplat::SceneBuilder &b, std::uint32_t mesh, const char *name) {
    b.add_instance(raysplat::InstanceDesc{mesh, raysplat::identity(), name});
  };

  // Index out of range: found by build(), naming the source and the mesh.
  {
    rust::Box<raysplat::SceneBuilder> b = builder();
    const std::vector<std::uint32_t> bad{0, 1, 7};
    place(*b, b->add_mesh("/Bad/Indices", raysplat::slice(tri), raysplat::slice(bad), {}, {},
                          raysplat::slice(one_material), false), "/Bad/Indices");
    const std::string msg = thrown([&] { b->build(); });
    CHECK_MSG(msg == "bad-scene: /Bad/Indices: vertex index 7 out of range (mesh has 3 points)", msg);
  }
  // Index count not a multiple of 3: found by add_mesh.
  {
    rust::Box<raysplat::SceneBuilder> b = builder();
    const std::vector<std::uint32_t> bad{0, 1, 2, 0};
    const std::string msg = thrown([&] {
      b->add_mesh("/Bad/Count", raysplat::slice(tri), raysplat::slice(bad), {}, {}, raysplat::slice(one_material), false);
    });
    CHECK_MSG(contains(msg, "/Bad/Count") && contains(msg, "indices has 4 values"), msg);
  }
  // NaN vertex.
  {
    rust::Box<raysplat::SceneBuilder> b = builder();
    std::vector<float> nan = tri;
    nan[4] = std::nanf("");
    const std::vector<std::uint32_t> idx{0, 1, 2};
    place(*b, b->add_mesh("/Bad/NaN", raysplat::slice(nan), raysplat::slice(idx), {}, {},
                          raysplat::slice(one_material), false), "/Bad/NaN");
    const std::string msg = thrown([&] { b->build(); });
    CHECK_MSG(contains(msg, "/Bad/NaN") && contains(msg, "NaN"), msg);
  }
  // Normals for the wrong number of points; material index out of range.
  {
    rust::Box<raysplat::SceneBuilder> b = builder();
    const std::vector<std::uint32_t> idx{0, 1, 2};
    const std::vector<float> normals{0, 0, 1};
    std::string msg = thrown([&] {
      b->add_mesh("/Bad/Normals", raysplat::slice(tri), raysplat::slice(idx), raysplat::slice(normals), {},
                  raysplat::slice(one_material), false);
    });
    CHECK_MSG(contains(msg, "/Bad/Normals") && contains(msg, "1 normals for 3 points"), msg);
    const std::vector<std::uint32_t> missing{5};
    place(*b, b->add_mesh("/Bad/Material", raysplat::slice(tri), raysplat::slice(idx), {}, {}, raysplat::slice(missing),
                          false), "/Bad/Material");
    msg = thrown([&] { b->build(); });
    CHECK_MSG(contains(msg, "/Bad/Material") && contains(msg, "material index 5"), msg);
  }
  // An empty scene.
  CHECK(contains(thrown([] { raysplat::new_scene_builder("empty")->build(); }), "no geometry"));

  // Render settings: the CLI's messages.
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  raysplat::RenderOptions o = small_options(16, 1, 0);
  o.method = "nonsense";
  std::string msg = thrown([&] { raysplat::render(*scene, o); });
  CHECK_MSG(contains(msg, "invalid parameter method: unknown method \"nonsense\" (available: auto, pt"), msg);
  o = small_options(16, 1 << 25, 0);
  CHECK(contains(thrown([&] { raysplat::render(*scene, o); }), "invalid parameter spp"));
  o = small_options(16, 1, 0);
  o.quality = "final";
  CHECK(contains(thrown([&] { raysplat::render(*scene, o); }), "invalid parameter quality: quality applies to method auto only"));
  o = small_options(16, 1, 0);
  o.method = "pm-fg";
  o.gather_rays = 1 << 20;
  CHECK(contains(thrown([&] { raysplat::render(*scene, o); }), "invalid parameter gather_rays"));
  o = small_options(16, 1, 0);
  o.height = 0;
  CHECK(contains(thrown([&] { raysplat::render(*scene, o); }), "invalid parameter width/height: 16x0"));

  // Files.
  const std::string missing = std::string(RAYSPLAT_SOURCE_DIR) + "/scenes/does-not-exist.usda";
  msg = thrown([&] { raysplat::load_scene(missing); });
  CHECK_MSG(contains(msg, missing), msg);
  rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, small_options(8, 1, 0));
  msg = thrown([&] { r->write_exr("/nonexistent-directory/x.exr"); });
  CHECK_MSG(contains(msg, "/nonexistent-directory"), msg);
  CHECK(contains(thrown([&] { r->pixels("nope"); }), "no layer \"nope\""));
  CHECK(contains(thrown([&] { scene->mesh(99); }), "mesh index 99 out of range"));

  // Exceptions thrown by a progress callback stop the render and come back with their message.
  struct Throwing : raysplat::ProgressCallback {
    bool std_exception;
    explicit Throwing(bool s) : std_exception(s) {}
    void advance(std::uint64_t, std::uint64_t) override {
      if (std_exception) throw std::runtime_error("boom from the callback");
      throw 42;
    }
  };
  Throwing t1(true), t2(false);
  msg = thrown([&] { raysplat::render(*scene, small_options(32, 2, 0), t1); });
  CHECK_MSG(contains(msg, "progress callback advance threw: boom from the callback"), msg);
  msg = thrown([&] { raysplat::render(*scene, small_options(32, 2, 0), t2); });
  CHECK_MSG(contains(msg, "unknown exception"), msg);

  // rust::Error is a std::exception.
  try {
    raysplat::load_scene(missing);
    CHECK(false);
  } catch (const std::exception &e) {
    CHECK(contains(e.what(), missing));
  }
}

void test_two_threads_render_concurrently() {
  // One shared scene, two different renders; each must equal its result on a single thread.
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  const raysplat::RenderOptions oa = small_options(64, 24, 11);
  raysplat::RenderOptions ob = small_options(48, 32, 12);
  ob.threads = 1;
  rust::Box<raysplat::RenderResult> ref_a = raysplat::render(*scene, oa);
  rust::Box<raysplat::RenderResult> ref_b = raysplat::render(*scene, ob);

  const raysplat::Scene &shared = *scene;
  std::vector<rust::Box<raysplat::RenderResult>> results;
  std::mutex lock;
  Clock::time_point start[2], end[2];
  std::string errors[2];
  auto run = [&](int k, const raysplat::RenderOptions &o) {
    try {
      start[k] = Clock::now();
      rust::Box<raysplat::RenderResult> r = raysplat::render(shared, o);
      end[k] = Clock::now();
      std::lock_guard<std::mutex> g(lock);
      results.push_back(std::move(r));
    } catch (const std::exception &e) {
      errors[k] = e.what();
    }
  };
  std::thread ta(run, 0, std::cref(oa)), tb(run, 1, std::cref(ob));
  ta.join();
  tb.join();
  CHECK_MSG(errors[0].empty() && errors[1].empty(), errors[0] << errors[1]);
  CHECK(results.size() == 2);
  CHECK_MSG(start[0] < end[1] && start[1] < end[0], "the renders did not overlap in time");
  for (const auto &r : results) {
    require_same(*r, r->width() == 64 ? *ref_a : *ref_b);
  }
}

// method "auto" (the default) chooses per scene, as `raysplat render`, and says what and why; a
// method given is reported as given.
void test_auto_chooses_and_says_why() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  raysplat::RenderOptions o = raysplat::default_options();
  o.width = o.height = 32;
  rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, o);
  raysplat::MethodChoice c = r->choice();
  // a closed box whose light has bounced, but 32x32 pixels do not repay a light pass
  CHECK_MSG(c.automatic && c.method == rust::String("pt") && c.rule == rust::String("path tracer: small image"), c.rule);
  CHECK_MSG(contains(std::string(c.reason), "auto: pt for preview quality") && contains(std::string(c.reason), "32x32 pixels"), c.reason);
  CHECK_MSG(c.indirect_share > 0.2 && c.indirect_share < 0.8 && c.emitter_area_share > 0 && c.survey_seconds > 0, c.indirect_share);
  // at 128x128 and the draft preset: ray splatting with the draft's budget
  o.width = o.height = 128;
  o.quality = "draft";
  r = raysplat::render(*scene, o);
  c = r->choice();
  CHECK_MSG(c.automatic && c.method == rust::String("rs") && c.rule == rust::String("bounced light"), c.reason);
  CHECK_MSG(contains(std::string(c.reason), "25000 photons, 1 eye spp, 8 camera spp"), c.reason);
  std::uint64_t spp = 0;
  for (const raysplat::Counter &k : r->stats().counters)
    if (k.name == rust::String("eye_samples")) spp = k.value;
  CHECK_MSG(spp == 128 * 128, spp);
  o.quality = "best";
  CHECK(contains(thrown([&] { raysplat::render(*scene, o); }), "invalid parameter quality"));
  // a method given: no reason
  c = raysplat::render(*scene, small_options(16, 1, 0))->choice();
  CHECK(!c.automatic && c.method == rust::String("pt") && c.rule.empty() && c.reason.empty());
}

void test_every_method_is_reachable() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  const rust::Vec<rust::String> methods = raysplat::methods();
  CHECK(!methods.empty());
  CHECK(std::string(methods[0]) == "auto" && std::string(methods[1]) == "pt");
  for (const rust::String &m : methods) {
    raysplat::RenderOptions o = small_options(16, 2, 0);
    o.method = m;
    rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, o);
    const Summary s = summarize(*r);
    CHECK_MSG(s.non_finite == 0 && s.non_black > 0, "method " << m);
    std::cerr << "    method " << m << ": ok\n";
  }
}

void test_stats_and_time_budget() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, small_options(32, 5, 0));
  const raysplat::RenderStats st = r->stats();
  CHECK(!st.summary.empty());
  CHECK(st.json.size() > 2 && st.json.data()[0] == '{');
  CHECK(st.total_seconds > 0);
  CHECK(!st.phases.empty());
  bool spp = false;
  for (const raysplat::Counter &c : st.counters) spp = spp || (c.name == rust::String("spp") && c.value == 5);
  CHECK_MSG(spp, st.json);

  // A time budget without a sample count renders until the budget is spent (as the CLI): the path
  // tracer's passes end only once its trace phase has reached the budget.
  raysplat::RenderOptions o = small_options(32, 0, 0);
  o.time_budget = 0.3;
  r = raysplat::render(*scene, o);
  std::uint64_t passes = 0;
  for (const raysplat::Counter &c : r->stats().counters)
    if (c.name == rust::String("spp")) passes = c.value;
  double trace = 0;
  for (const raysplat::Phase &p : r->stats().phases)
    if (p.name == rust::String("trace")) trace = p.seconds;
  CHECK_MSG(passes >= 1 && trace >= 0.3, passes << " passes, trace phase " << trace << " s");
}

void test_defaults_and_accessors() {
  CHECK(!raysplat::version().empty());
  // The CLI's defaults (the Rust tests check both against the library's one set): auto at its
  // preview preset, and 0 or "" for every option left to the method or to auto.
  const raysplat::RenderOptions o = raysplat::default_options();
  CHECK(o.method == rust::String("auto") && o.quality.empty() && o.spp == 0 && o.photons == 0 && o.time_budget == 0.0);
  CHECK(o.max_depth == 1024 && o.knn == 100 && o.light_samples == 4 && o.aa_spp == 0 && o.glossy == rust::String("auto"));
  CHECK(o.smoothness == 0.3f && o.sensitivity == 0.1f && o.max_bandwidth == 0.2f && !o.direct_photons && o.filter_radius == 0);
  CHECK(o.width == 0 && o.height == 0 && o.gather_rays == 0 && o.memory_budget == 0);
  CHECK(o.gather_radius == 0.0f && o.spill_dir.empty() && !o.no_spill && o.density_limit == 0.0f && o.cache_error == 0.0f);
  const raysplat::MaterialDesc m = raysplat::default_material("/M");
  CHECK(m.diffuse_color.value[0] == 0.18f && m.diffuse_color.texture == -1 && m.roughness.value == 0.5f);
  CHECK(m.ior == 1.5f && !m.is_error);
  for (raysplat::LightKind k : {raysplat::LightKind::Rect, raysplat::LightKind::Disk, raysplat::LightKind::Sphere,
                                raysplat::LightKind::Distant, raysplat::LightKind::Dome}) {
    CHECK(raysplat::default_light(k, "/L").kind == k);
  }
  // A loaded scene can be edited through to_builder().
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  rust::Box<raysplat::SceneBuilder> b = scene->to_builder();
  raysplat::LightDesc sun = raysplat::default_light(raysplat::LightKind::Distant, "/Lights/Sun");
  sun.direction = {0.3f, -1.0f, -0.2f};
  b->add_light(sun);
  rust::Box<raysplat::Scene> edited = b->build();
  CHECK(edited->lights().size() == scene->lights().size() + 1);
  CHECK(edited->lights()[1] == sun);
  CHECK(edited->camera() == scene->camera());
}

// A stage with two cameras and a card that moves between time codes 1 and 10.
void test_stage_views_choose_camera_and_time() {
  const std::string path = out_path("views.usda");
  {
    std::ofstream f(path);
    f << "#usda 1.0\n(\n  startTimeCode = 1\n  endTimeCode = 10\n  metersPerUnit = 1\n  upAxis = \"Y\"\n)\n"
         "def Mesh \"Card\" {\n  int[] faceVertexCounts = [4]\n  int[] faceVertexIndices = [0, 1, 2, 3]\n"
         "  point3f[] points = [(-1, 0, 0), (1, 0, 0), (1, 2, 0), (-1, 2, 0)]\n"
         "  double3 xformOp:translate.timeSamples = { 1: (-1.5, 0, 0), 10: (1.5, 0, 0) }\n"
         "  uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n"
         "def Camera \"Front\" {\n  double3 xformOp:translate = (0, 1, 8)\n"
         "  uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n"
         "def Camera \"High\" {\n  double3 xformOp:translate = (0, 8, 8)\n"
         "  uniform token[] xformOpOrder = [\"xformOp:translate\"]\n}\n";
  }
  rust::Box<raysplat::Scene> plain = raysplat::load_scene(path);
  CHECK(std::string(plain->camera().name) == "/Front");
  CHECK(std::abs(plain->instance(0).transform[12] - -1.5f) < 1e-6f);
  std::string msg;
  const raysplat::StageView high{"/High", 5.5, true};
  rust::Box<raysplat::Scene> later = raysplat::load_stage(path, high);
  CHECK(std::string(later->camera().name) == "/High");
  CHECK(std::abs(later->camera().transform[13] - 8.0f) < 1e-6f);
  CHECK(std::abs(later->instance(0).transform[12] - 0.0f) < 1e-6f); // halfway from -1.5 to 1.5
  CHECK(later->camera().lens_radius == 0.0f && later->camera().aperture_offset[0] == 0.0f);
  // a lens set through the builder renders (depth of field) and comes back out unchanged
  rust::Box<raysplat::SceneBuilder> edit = later->to_builder();
  raysplat::CameraDesc lens = later->camera();
  lens.lens_radius = 0.05f;
  lens.focus_distance = 8.0f;
  edit->set_camera(lens);
  rust::Box<raysplat::Scene> focused = edit->build();
  CHECK(focused->camera().lens_radius == 0.05f && focused->camera().focus_distance == 8.0f);
  CHECK(summarize(*raysplat::render(*focused, small_options(16, 2, 1))).non_finite == 0);
  lens.focus_distance = 0.0f;
  edit->set_camera(lens);
  msg = thrown([&] { edit->build(); });
  CHECK_MSG(contains(msg, "/High: camera focus distance 0 m must be positive"), msg);
  // a NaN in the transform is reported as such (not as a focal-length problem)
  raysplat::CameraDesc lost = later->camera();
  lost.transform[13] = std::nanf("");
  edit->set_camera(lost);
  msg = thrown([&] { edit->build(); });
  CHECK_MSG(contains(msg, "/High: camera transform has a non-finite value"), msg);
  // vertex colours through the builder: a material that reads them, and a wrong count refused
  rust::Box<raysplat::SceneBuilder> painted = later->to_builder();
  raysplat::MaterialDesc paint = raysplat::default_material("/Looks/Paint");
  paint.diffuse_color.vertex = true;
  const std::uint32_t pm = painted->add_material(paint);
  raysplat::MeshData card = later->mesh(0);
  const std::vector<float> pos(card.positions.begin(), card.positions.end());
  const std::vector<std::uint32_t> idx(card.indices.begin(), card.indices.end());
  const std::vector<float> none;
  const std::vector<std::uint32_t> ids{pm};
  const std::uint32_t pk = painted->add_mesh("/Painted", raysplat::slice(pos), raysplat::slice(idx), raysplat::slice(none),
                                             raysplat::slice(none), raysplat::slice(ids), false);
  const std::vector<float> rgb(pos.size(), 0.5f);
  painted->set_mesh_colors(pk, raysplat::slice(rgb));
  CHECK(painted->build()->mesh(pk).colors.size() == pos.size());
  const std::vector<float> short_rgb(3, 0.5f);
  msg = thrown([&] { painted->set_mesh_colors(pk, raysplat::slice(short_rgb)); });
  CHECK_MSG(contains(msg, "/Painted: 3 colour values for " + std::to_string(pos.size() / 3) + " points"), msg);
  // the card is a subdivision surface (USD's default scheme): refined twice unless asked otherwise
  CHECK(plain->mesh(0).indices.size() == 16 * 2 * 3);
  const raysplat::StageView cage{"", 0.0, false, 0, true};
  CHECK(raysplat::load_stage(path, cage)->mesh(0).indices.size() == 2 * 3);
  const raysplat::StageView once{"", 0.0, false, 1, true};
  CHECK(raysplat::load_stage(path, once)->mesh(0).indices.size() == 4 * 2 * 3);
  const raysplat::StageView fallback{"", 0.0, false};
  CHECK(std::string(raysplat::load_stage(path, fallback)->camera().name) == "/Front");
  msg = thrown([&] { raysplat::load_stage(path, raysplat::StageView{"/Card", 0.0, false}); });
  CHECK_MSG(contains(msg, path) && contains(msg, "/Card: is a Mesh, not a Camera") && contains(msg, "/Front, /High"), msg);
  msg = thrown([&] { raysplat::load_stage(path, raysplat::StageView{"", std::nan(""), true}); });
  CHECK_MSG(contains(msg, "not a finite time code"), msg);
  // The converter's Python as a field: one named there is used or the load throws, saying how to
  // install usd-core (never another Python instead). A stage never converted (no cached copy).
  const std::string fresh = out_path("python-field.usda");
  std::ofstream(fresh) << "#usda 1.0\ndef Camera \"Cam\" {\n}\n";
  raysplat::StageView absent{};
  absent.python = "/nonexistent/bin/python3";
  msg = thrown([&] { raysplat::load_stage(fresh, absent); });
  CHECK_MSG(contains(msg, fresh) && contains(msg, "/nonexistent/bin/python3") && contains(msg, "cannot run it") &&
                contains(msg, "name an existing Python 3 that has usd-core"),
            msg);
  raysplat::StageView without_pxr{};
  without_pxr.python = "/bin/false"; // runs, but cannot import pxr
  msg = thrown([&] { raysplat::load_stage(fresh, without_pxr); });
  CHECK_MSG(contains(msg, "/bin/false") && contains(msg, "cannot import pxr") &&
                contains(msg, "/bin/false -m pip install 'usd-core=="),
            msg);
}

// --denoise through the options: the raw layer is the render without denoising, bit for bit; a
// library built without Open Image Denoise refuses "on" and renders "auto" as it is.
void test_denoise_keeps_the_raw_render() {
  const std::string denoiser(raysplat::denoiser());
  const bool available = denoiser.rfind("Open Image Denoise ", 0) == 0;
  CHECK_MSG(available || denoiser.rfind("unavailable: ", 0) == 0, denoiser);
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  const raysplat::RenderOptions plain_options = small_options(32, 2, 5);
  CHECK(plain_options.denoise == rust::String("off") && plain_options.denoise_quality == rust::String("high"));
  rust::Box<raysplat::RenderResult> plain = raysplat::render(*scene, plain_options);
  raysplat::RenderOptions o = plain_options;
  o.denoise = "auto";
  o.denoise_quality = "fast";
  rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, o);
  if (!available) {
    require_same(*plain, *r);
    o.denoise = "on";
    std::string msg;
    try {
      raysplat::render(*scene, o);
    } catch (const std::exception &e) {
      msg = e.what();
    }
    CHECK_MSG(contains(msg, "the denoiser is unavailable") && contains(msg, "make setup"), msg);
    return;
  }
  const rust::Vec<rust::String> names = r->layer_names();
  CHECK(std::find(names.begin(), names.end(), rust::String("raw")) != names.end());
  const rust::Slice<const float> raw = r->pixels("raw"), rendered = plain->rgba(), denoised = r->rgba();
  CHECK(raw.size() == rendered.size() && std::memcmp(raw.data(), rendered.data(), raw.size() * sizeof(float)) == 0);
  CHECK(std::memcmp(denoised.data(), rendered.data(), raw.size() * sizeof(float)) != 0);
  bool timed = false;
  for (const raysplat::Phase &p : r->stats().phases) timed = timed || p.name == rust::String("denoise");
  CHECK(timed);
  o.denoise_quality = "best";
  std::string msg;
  try {
    raysplat::render(*scene, o);
  } catch (const std::exception &e) {
    msg = e.what();
  }
  CHECK_MSG(contains(msg, "invalid parameter denoise_quality"), msg);
}

// Outputs: only a new path or an existing regular file is written (through a symbolic link, its
// target); another format's name and a FIFO are refused with the path in the message, and nothing
// changes on disk.
void test_write_exr_keeps_the_output_rule() {
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  rust::Box<raysplat::RenderResult> r = raysplat::render(*scene, small_options(8, 1, 0));
  const std::string png = out_path("rule.png");
  std::remove(png.c_str());
  std::string msg = thrown([&] { r->write_exr(png); });
  CHECK_MSG(contains(msg, "rule.png") && contains(msg, "OpenEXR"), msg);
  CHECK(access(png.c_str(), F_OK) != 0);
  const std::string fifo = out_path("rule-fifo.exr");
  std::remove(fifo.c_str());
  CHECK(mkfifo(fifo.c_str(), 0600) == 0);
  msg = thrown([&] { r->write_exr(fifo); });
  CHECK_MSG(contains(msg, "rule-fifo.exr") && contains(msg, "FIFO"), msg);
  struct stat st {};
  CHECK(lstat(fifo.c_str(), &st) == 0 && S_ISFIFO(st.st_mode));
  std::remove(fifo.c_str());
  const std::string target = out_path("rule-target.exr"), link = out_path("rule-link.exr");
  std::remove(link.c_str());
  { std::ofstream(target) << "old"; }
  CHECK(symlink("rule-target.exr", link.c_str()) == 0);
  r->write_exr(link);
  CHECK(lstat(link.c_str(), &st) == 0 && S_ISLNK(st.st_mode));
  std::ifstream written(target, std::ios::binary);
  char magic[4] = {};
  written.read(magic, 4);
  CHECK(static_cast<unsigned char>(magic[0]) == 0x76 && magic[1] == 0x2f);  // OpenEXR's magic number
}

// Run inside a child (`test_api --memory-limit-child`) under a 3 GB address-space limit: a
// 12000x12000 render does not fit, which must be an exception naming memory and the limit (the
// library honours the process's limits), not an abort of the host.
int memory_limit_child() {
  const rlim_t limit = 3000000000ULL;
  struct rlimit lim {limit, limit};
  if (setrlimit(RLIMIT_AS, &lim) != 0) return 5;
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  raysplat::RenderOptions o = small_options(12000, 1, 0);
  o.method = "pt";
  try {
    raysplat::render(*scene, o);
  } catch (const std::exception &e) {
    const std::string m = e.what();
    std::cerr << "child: " << m << "\n";
    return contains(m, "memory") && contains(m, "limit") ? 0 : 3;
  }
  std::cerr << "child: rendered\n";
  return 4;
}

void test_running_out_of_memory_is_an_exception() {
#if defined(RAYSPLAT_TEST_ASAN)
  std::cerr << "skipped: AddressSanitizer reserves more address space than the limit allows\n";
  return;
#else
  char self[4096] = {};
  const ssize_t n = readlink("/proc/self/exe", self, sizeof(self) - 1);
  CHECK(n > 0);
  const std::string cmd = std::string("'") + self + "' --memory-limit-child";
  const int status = std::system(cmd.c_str());
  CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 0,
            "the child " << (WIFSIGNALED(status) ? "died of signal " + std::to_string(WTERMSIG(status))
                                                   : "exited with " + std::to_string(WEXITSTATUS(status))));
#endif
}

// The pixel filter through the options: box by default, another filter changes the beauty but not
// the albedo AOV (pt splats radiance only), a bad name or radius throws naming the option.
void test_pixel_filter_option() {
  const raysplat::RenderOptions box = small_options(24, 2, 3);
  CHECK(box.pixel_filter == rust::String("box") && box.pixel_filter_radius == 0.0f);
  rust::Box<raysplat::Scene> scene = cornell::make_scene("test_api.cpp");
  rust::Box<raysplat::RenderResult> a = raysplat::render(*scene, box);
  raysplat::RenderOptions o = box;
  o.pixel_filter = "gaussian";
  o.pixel_filter_radius = 1.5f;
  rust::Box<raysplat::RenderResult> b = raysplat::render(*scene, o);
  const rust::Slice<const float> ra = a->rgba(), rb = b->rgba(), aa = a->pixels("albedo"), ab = b->pixels("albedo");
  CHECK(ra.size() == rb.size() && std::memcmp(ra.data(), rb.data(), ra.size() * sizeof(float)) != 0);
  CHECK(aa.size() == ab.size() && std::memcmp(aa.data(), ab.data(), aa.size() * sizeof(float)) == 0);
  struct Bad {
    const char *name;
    float radius;
    const char *what;
  };
  for (const Bad &bad : {Bad{"lanczos", 0.0f, "filter"}, Bad{"mitchell", 0.2f, "pixel-filter-radius"}}) {
    const char *what = bad.what;
    o.pixel_filter = bad.name;
    o.pixel_filter_radius = bad.radius;
    std::string msg;
    try {
      raysplat::render(*scene, o);
    } catch (const std::exception &e) {
      msg = e.what();
    }
    CHECK_MSG(contains(msg, what), msg);
  }
}

struct Test {
  const char *name;
  void (*run)();
};

const Test tests[] = {
    {"defaults_and_accessors", test_defaults_and_accessors},
    {"cornell_from_literals_is_plausible", test_cornell_from_literals_is_plausible},
    {"usd_and_arrays_render_identically", test_usd_and_arrays_render_identically},
    {"invalid_arguments_throw_clear_messages", test_invalid_arguments_throw_clear_messages},
    {"progress_is_reported_in_order", test_progress_is_reported_in_order},
    {"cancel_from_another_thread", test_cancel_from_another_thread},
    {"two_threads_render_concurrently", test_two_threads_render_concurrently},
    {"every_method_is_reachable", test_every_method_is_reachable},
    {"auto_chooses_and_says_why", test_auto_chooses_and_says_why},
    {"stats_and_time_budget", test_stats_and_time_budget},
    {"stage_views_choose_camera_and_time", test_stage_views_choose_camera_and_time},
    {"denoise_keeps_the_raw_render", test_denoise_keeps_the_raw_render},
    {"write_exr_keeps_the_output_rule", test_write_exr_keeps_the_output_rule},
    {"running_out_of_memory_is_an_exception", test_running_out_of_memory_is_an_exception},
    {"pixel_filter_option", test_pixel_filter_option},
};

} // namespace

int main(int argc, char **argv) {
  if (argc == 2 && std::string(argv[1]) == "--memory-limit-child") return memory_limit_child();
  for (const Test &t : tests) {
    bool selected = argc < 2;
    for (int i = 1; i < argc; ++i) selected = selected || contains(t.name, argv[i]);
    if (!selected) continue;
    std::cerr << "test " << t.name << " ...\n";
    const Clock::time_point t0 = Clock::now();
    try {
      t.run();
      ++passed;
      std::cerr << "test " << t.name << " ... ok ("
                << std::chrono::duration<double>(Clock::now() - t0).count() << " s)\n";
    } catch (const std::exception &e) {
      ++failed;
      std::cerr << "test " << t.name << " ... FAILED: " << e.what() << "\n";
    }
  }
  std::cout << passed << " passed, " << failed << " failed\n";
  return failed == 0 && passed > 0 ? 0 : 1;
}
