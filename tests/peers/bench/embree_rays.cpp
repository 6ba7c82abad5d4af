// Embree 3's rays through the dense cluster: a peer for how fast a BVH tracer finds the
// nearest sphere of each pixel, and whether anything blocks its light, on this machine.
//
//     apt-get install libembree-dev
//     g++ -O2 -std=c++17 tests/peers/bench/embree_rays.cpp -o embree_rays -lembree3 -lpthread
//     ./embree_rays out/bench/dense10000000-ply.ply 640 360 1
//
// Arguments: a float PLY that `campath bench` wrote (x, y, z, radius, red, green, blue), the
// raster's width and height, and 1 for a shadow ray from every hit (0 for none). The camera,
// ground and light are those of the bench's dense scenes' first frame: the eye at
// (-20, 8, -4) looking at (0, 3, 0), up +y, 70° across, a ground sphere of radius 10⁵ under
// y = 0, the light travelling along (-0.6, -1, 0.4). One ray a pixel through its centre,
// rtcIntersect1 and rtcOccluded1 (packets of eight were no faster), on two threads taking
// bands of four rows. Prints the time to read the file and build the scene, and the median
// and least of seven frames. Only the rays: no shading, no pixels, no hashing, f32 throughout.
// `tests/peers/embree_round.py` times it beside campath's frames of the same scenes, in rounds.
#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <thread>
#include <vector>

struct V3 {
  float x, y, z;
};
static V3 sub(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
static V3 cross(V3 a, V3 b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
static V3 unit(V3 a) {
  float l = std::sqrt(a.x * a.x + a.y * a.y + a.z * a.z);
  return {a.x / l, a.y / l, a.z / l};
}
static double now() {
  using namespace std::chrono;
  return duration<double>(steady_clock::now().time_since_epoch()).count();
}

int main(int argc, char** argv) {
  if (argc != 5) {
    fprintf(stderr, "usage: embree_rays FILE.ply WIDTH HEIGHT SHADOWS\n");
    return 2;
  }
  const int width = atoi(argv[2]), height = atoi(argv[3]), shadows = atoi(argv[4]);
  FILE* file = fopen(argv[1], "rb");
  if (!file) {
    perror(argv[1]);
    return 2;
  }
  // The header `campath bench` writes, line for line but its comment and count: any other
  // layout is refused rather than read as this one.
  const char* want[] = {"ply", "format binary_little_endian 1.0", "element vertex",
                        "property float x", "property float y", "property float z",
                        "property float radius", "property uchar red", "property uchar green",
                        "property uchar blue", "end_header"};
  char line[256];
  long n = -1;
  size_t at = 0;
  while (at < sizeof want / sizeof *want && fgets(line, sizeof line, file)) {
    line[strcspn(line, "\r\n")] = 0;
    if (!strncmp(line, "comment", 7)) continue;
    if (at == 2 ? sscanf(line, "element vertex %ld", &n) != 1 : strcmp(line, want[at]) != 0) {
      fprintf(stderr, "%s: header line \"%s\", not \"%s\" (a PLY of campath bench's)\n",
              argv[1], line, want[at]);
      return 2;
    }
    at++;
  }
  if (at < sizeof want / sizeof *want || n < 0) {
    fprintf(stderr, "%s: the header ends early\n", argv[1]);
    return 2;
  }
  double t0 = now();
  // Each vertex: four floats (x, y, z, radius), Embree's own layout, and three colour bytes.
  std::vector<float> balls(4 * n);
  unsigned char vertex[19];
  for (long i = 0; i < n; i++) {
    if (fread(vertex, 1, sizeof vertex, file) != sizeof vertex) {
      fprintf(stderr, "%s: %ld vertices, the file ends at %ld\n", argv[1], n, i);
      return 2;
    }
    memcpy(&balls[4 * i], vertex, 16);
  }
  fclose(file);
  double t1 = now();
  RTCDevice device = rtcNewDevice("threads=2");
  RTCScene scene = rtcNewScene(device);
  static float ground[4] = {0.f, -100000.f, 0.f, 100000.f};
  const std::pair<float*, long> parts[] = {{balls.data(), n}, {ground, 1}};
  for (auto [data, count] : parts) {
    RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_SPHERE_POINT);
    rtcSetSharedGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, data, 0, 16,
                               count);
    rtcCommitGeometry(g);
    rtcAttachGeometry(scene, g);
    rtcReleaseGeometry(g);
  }
  rtcCommitScene(scene);
  double t2 = now();

  const V3 eye = {-20, 8, -4}, target = {0, 3, 0};
  const V3 forward = unit(sub(target, eye));
  const V3 right = unit(cross({0, 1, 0}, forward));
  const V3 up = cross(forward, right);
  const float half = std::tan(35.0f * 3.14159265f / 180.f);
  const float aspect = float(height) / width;
  const V3 to_light = unit({0.6f, 1.0f, -0.4f});

  std::vector<double> times;
  long hits = 0;
  for (int frame = 0; frame < 7; frame++) {
    double start = now();
    std::atomic<long> met{0};
    std::atomic<int> next{0};
    auto work = [&]() {
      RTCIntersectContext context;
      rtcInitIntersectContext(&context);
      long mine = 0;
      for (int band; (band = next.fetch_add(1)) * 4 < height;) {
        for (int y = band * 4; y < std::min(height, band * 4 + 4); y++) {
          for (int x = 0; x < width; x++) {
            float u = ((x + 0.5f) / width * 2 - 1) * half;
            float v = (1 - (y + 0.5f) / height * 2) * half * aspect;
            V3 d = unit({forward.x + u * right.x + v * up.x, forward.y + u * right.y + v * up.y,
                         forward.z + u * right.z + v * up.z});
            RTCRayHit ray = {};
            ray.ray.org_x = eye.x, ray.ray.org_y = eye.y, ray.ray.org_z = eye.z;
            ray.ray.dir_x = d.x, ray.ray.dir_y = d.y, ray.ray.dir_z = d.z;
            ray.ray.tfar = INFINITY;
            ray.ray.mask = ~0u;
            ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(scene, &context, &ray);
            if (ray.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
            mine++;
            if (!shadows) continue;
            // From the hit, a little off the surface along its normal, towards the light.
            float t = ray.ray.tfar;
            V3 ng = unit({ray.hit.Ng_x, ray.hit.Ng_y, ray.hit.Ng_z});
            RTCRay shadow = {};
            shadow.org_x = eye.x + d.x * t + ng.x * 1e-4f;
            shadow.org_y = eye.y + d.y * t + ng.y * 1e-4f;
            shadow.org_z = eye.z + d.z * t + ng.z * 1e-4f;
            shadow.dir_x = to_light.x, shadow.dir_y = to_light.y, shadow.dir_z = to_light.z;
            shadow.tfar = INFINITY;
            shadow.mask = ~0u;
            rtcOccluded1(scene, &context, &shadow);
          }
        }
      }
      met += mine;
    };
    std::thread a(work), b(work);
    a.join();
    b.join();
    times.push_back(now() - start);
    hits = met;
  }
  std::sort(times.begin(), times.end());
  printf("embree %s: %ld spheres, %dx%d, shadow rays %s: read %.0f ms, scene built %.0f ms, "
         "frame median %.1f ms, least %.1f ms, %ld pixels hit\n",
         RTC_VERSION_STRING, n, width, height, shadows ? "yes" : "no", (t1 - t0) * 1e3,
         (t2 - t1) * 1e3, times[times.size() / 2] * 1e3, times[0] * 1e3, hits);
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
}
