/* The bench's Embree harness: prices a Whitted frame of a triangle mesh at Embree 3's single-ray
 * rates. `cargo xtask bench` writes this file out and compiles it with `cc` when Debian's
 * libembree-dev is installed (nothing of Lancer's is linked in).
 *
 * usage: embree-harness MESH.obj WIDTH HEIGHT FROM_X FROM_Y FROM_Z TO_X TO_Y TO_Z FOV LIGHT_X
 *        LIGHT_Y LIGHT_Z MAX_DEPTH
 *
 * It reads the OBJ's `v` and `f` lines (a polygon as a fan of triangles; `v/vt/vn` indices and
 * negative ones accepted), builds the scene on one thread, and traces the frame Lancer traces
 * for a mirror material under one point light with hard shadows: a camera ray through every
 * pixel's centre (the camera of Lancer's scene files: vertical field of view `FOV` degrees, up
 * +y, right = forward x up), then at each hit a shadow ray to the light when the light is on the
 * side the ray came from, and a mirror ray while fewer than MAX_DEPTH reflections led to it
 * (Lancer's `max_depth`: 2 traces the camera ray and two generations of mirror rays). Every kind
 * of ray is traced in its own timed loop, one ray at a time (rtcIntersect1, rtcOccluded1), one
 * generation after the other. It prints one line:
 *
 *   embree build S triangles N camera COUNT SECONDS mirror COUNT SECONDS shadow COUNT SECONDS blocked COUNT
 *
 * (`blocked`: the shadow rays that met something before the light). Rays start 1e-4 x (1 + |p|)
 * off the surface along its normal, |p| the hit point's largest coordinate: well above the
 * rounding of a hit at that distance from the origin. It fails (exit 1, a message) on Embree's
 * errors and when no camera ray hits the mesh, so that an empty scene is never priced.
 */
#include <embree3/rtcore.h>
#include <math.h>
#include <pmmintrin.h>
#include <xmmintrin.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

typedef struct { float x, y, z; } V3;

static V3 v3(float x, float y, float z) { V3 v = { x, y, z }; return v; }
static V3 add(V3 a, V3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static V3 sub(V3 a, V3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static V3 mul(V3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static float dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static V3 cross(V3 a, V3 b) { return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x); }
static V3 unit(V3 a) {
  float l = sqrtf(dot(a, a));
  return l > 0.0f ? mul(a, 1.0f / l) : a;
}

static double now(void) {
  struct timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return t.tv_sec + t.tv_nsec * 1e-9;
}

static void fail(const char *what) {
  fprintf(stderr, "embree-harness: %s\n", what);
  exit(1);
}

static void embree_error(void *user, enum RTCError code, const char *what) {
  (void)user;
  fprintf(stderr, "embree-harness: Embree error %d: %s\n", (int)code, what ? what : "");
  exit(1);
}

/* How far off the surface at `p` a secondary ray starts. */
static float offset(V3 p) {
  float m = fmaxf(fabsf(p.x), fmaxf(fabsf(p.y), fabsf(p.z)));
  return 1e-4f * (1.0f + m);
}

/* A growable array of `size`-byte items. */
typedef struct { char *data; size_t len, cap, size; } Vec;

static void *push(Vec *v) {
  if (v->len == v->cap) {
    v->cap = v->cap ? 2 * v->cap : 1024;
    v->data = realloc(v->data, v->cap * v->size);
    if (!v->data) fail("out of memory");
  }
  return v->data + v->size * v->len++;
}

/* The vertex a face's index names (1-based, or negative: from the end), or -1. */
static long vertex_index(const char *token, size_t vertices) {
  long i = strtol(token, NULL, 10);
  if (i < 0) i += (long)vertices + 1;
  return (i >= 1 && (size_t)i <= vertices) ? i - 1 : -1;
}

static void read_obj(const char *path, Vec *vertices, Vec *triangles) {
  FILE *f = fopen(path, "r");
  if (!f) fail("cannot open the mesh");
  char line[4096];
  while (fgets(line, sizeof line, f)) {
    if (!strchr(line, '\n') && !feof(f)) fail("a line of the mesh is longer than 4095 bytes");
    if (line[0] == 'v' && (line[1] == ' ' || line[1] == '\t')) {
      float *p = push(vertices);
      if (sscanf(line + 2, "%f %f %f", &p[0], &p[1], &p[2]) != 3) fail("a `v` line without three numbers");
    } else if (line[0] == 'f' && (line[1] == ' ' || line[1] == '\t')) {
      long first = -1, prev = -1;
      for (char *t = strtok(line + 2, " \t\r\n"); t; t = strtok(NULL, " \t\r\n")) {
        long i = vertex_index(t, vertices->len);
        if (i < 0) fail("a face names a vertex that is not there");
        if (first < 0) first = i;
        else if (prev >= 0 && prev != first) {
          unsigned *tri = push(triangles);
          tri[0] = (unsigned)first; tri[1] = (unsigned)prev; tri[2] = (unsigned)i;
        }
        prev = i;
      }
    }
  }
  fclose(f);
}

/* A ray of the next generation: where it starts, where it goes and how deep it is. */
typedef struct { V3 org, dir; int depth; } Ray;

int main(int argc, char **argv) {
  if (argc != 15) fail("usage: embree-harness MESH.obj W H FROM(3) TO(3) FOV LIGHT(3) MAX_DEPTH");
  int width = atoi(argv[2]), height = atoi(argv[3]);
  V3 from = v3(atof(argv[4]), atof(argv[5]), atof(argv[6]));
  V3 to = v3(atof(argv[7]), atof(argv[8]), atof(argv[9]));
  float tan_half = tanf(atof(argv[10]) * 3.14159265358979f / 360.0f);
  V3 light = v3(atof(argv[11]), atof(argv[12]), atof(argv[13]));
  int max_depth = atoi(argv[14]);
  if (width <= 0 || height <= 0) fail("the image size must be positive");

  Vec vertices = { 0, 0, 0, 3 * sizeof(float) }, triangles = { 0, 0, 0, 3 * sizeof(unsigned) };
  read_obj(argv[1], &vertices, &triangles);
  if (!triangles.len) fail("the mesh has no triangles");

  /* As Embree asks of its users: denormals flushed to zero (its traversal's speed). */
  _MM_SET_FLUSH_ZERO_MODE(_MM_FLUSH_ZERO_ON);
  _MM_SET_DENORMALS_ZERO_MODE(_MM_DENORMALS_ZERO_ON);
  double t0 = now();
  RTCDevice device = rtcNewDevice("threads=1");
  if (!device) fail("rtcNewDevice failed");
  rtcSetDeviceErrorFunction(device, embree_error, NULL);
  RTCScene scene = rtcNewScene(device);
  RTCGeometry geom = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  /* (A buffer Embree allocates has the room its 16-byte loads need after the last vertex.) */
  float *vb = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), vertices.len);
  unsigned *ib = rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.len);
  if (!vb || !ib) fail("rtcSetNewGeometryBuffer failed");
  memcpy(vb, vertices.data, vertices.len * vertices.size);
  memcpy(ib, triangles.data, triangles.len * triangles.size);
  rtcCommitGeometry(geom);
  rtcAttachGeometry(scene, geom);
  rtcReleaseGeometry(geom);
  rtcCommitScene(scene);
  double build = now() - t0;
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) fail("Embree reported an error building the scene");

  V3 forward = unit(sub(to, from));
  V3 right = unit(cross(forward, v3(0, 1, 0)));
  V3 up = cross(right, forward);

  /* The rays of the current generation, and the hits they make (to spawn shadow and mirror rays). */
  size_t pixels = (size_t)width * height;
  Ray *rays = malloc(pixels * sizeof(Ray)), *next = malloc(pixels * sizeof(Ray));
  V3 *hit_at = malloc(pixels * sizeof(V3)), *hit_n = malloc(pixels * sizeof(V3));
  int *hit_depth = malloc(pixels * sizeof(int));
  V3 *hit_dir = malloc(pixels * sizeof(V3));
  struct RTCRay *shadow = malloc(pixels * sizeof(struct RTCRay));
  if (!rays || !next || !hit_at || !hit_n || !hit_depth || !hit_dir || !shadow) fail("out of memory");
  size_t count = 0;
  for (int y = 0; y < height; y++)
    for (int x = 0; x < width; x++) {
      float px = (2.0f * (x + 0.5f) / width - 1.0f) * tan_half * width / height;
      float py = (1.0f - 2.0f * (y + 0.5f) / height) * tan_half;
      Ray r = { from, unit(add(forward, add(mul(right, px), mul(up, py)))), 0 };
      rays[count++] = r;
    }

  struct RTCIntersectContext ctx;
  rtcInitIntersectContext(&ctx);
  double secs[2] = { 0, 0 }, shadow_secs = 0;
  size_t traced[2] = { 0, 0 }, shadows = 0;
  size_t blocked = 0;
  while (count) {
    /* Closest hits of this generation (camera rays first, then mirror rays). */
    int kind = rays[0].depth == 0 ? 0 : 1;
    size_t hits = 0;
    double start = now();
    for (size_t i = 0; i < count; i++) {
      struct RTCRayHit rh;
      rh.ray.org_x = rays[i].org.x; rh.ray.org_y = rays[i].org.y; rh.ray.org_z = rays[i].org.z;
      rh.ray.dir_x = rays[i].dir.x; rh.ray.dir_y = rays[i].dir.y; rh.ray.dir_z = rays[i].dir.z;
      rh.ray.tnear = 0.0f; rh.ray.tfar = INFINITY; rh.ray.time = 0.0f;
      rh.ray.mask = 0xFFFFFFFF; rh.ray.id = 0; rh.ray.flags = 0;
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID; rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &ctx, &rh);
      if (rh.hit.geomID != RTC_INVALID_GEOMETRY_ID) {
        hit_at[hits] = add(rays[i].org, mul(rays[i].dir, rh.ray.tfar));
        hit_n[hits] = v3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
        hit_dir[hits] = rays[i].dir;
        hit_depth[hits] = rays[i].depth;
        /* primID read so that the compiler keeps the hit record (and as a check). */
        if (rh.hit.primID >= triangles.len) fail("a hit on a triangle that is not there");
        hits++;
      }
    }
    secs[kind] += now() - start;
    traced[kind] += count;

    /* Shadow rays of this generation's hits, towards the light, from just off the surface:
     * made first, then traced in a timed loop of their own. */
    size_t made = 0;
    for (size_t i = 0; i < hits; i++) {
      V3 n = unit(hit_n[i]);
      if (dot(n, hit_dir[i]) > 0) n = mul(n, -1.0f);
      V3 to_light = sub(light, hit_at[i]);
      float dist = sqrtf(dot(to_light, to_light));
      if (!(dist > 0) || dot(n, to_light) <= 0) continue;
      V3 org = add(hit_at[i], mul(n, offset(hit_at[i])));
      V3 d = mul(to_light, 1.0f / dist);
      struct RTCRay *r = &shadow[made++];
      r->org_x = org.x; r->org_y = org.y; r->org_z = org.z;
      r->dir_x = d.x; r->dir_y = d.y; r->dir_z = d.z;
      r->tnear = 0.0f; r->tfar = dist; r->time = 0.0f; r->mask = 0xFFFFFFFF; r->id = 0; r->flags = 0;
    }
    start = now();
    for (size_t i = 0; i < made; i++) rtcOccluded1(scene, &ctx, &shadow[i]);
    shadow_secs += now() - start;
    for (size_t i = 0; i < made; i++) blocked += shadow[i].tfar < 0;
    shadows += made;
    if (kind == 0 && hits == 0) fail("no camera ray hits the mesh");

    /* Mirror rays of this generation's hits, for the next one. */
    size_t spawned = 0;
    for (size_t i = 0; i < hits; i++) {
      if (hit_depth[i] >= max_depth) continue;
      V3 n = unit(hit_n[i]);
      if (dot(n, hit_dir[i]) > 0) n = mul(n, -1.0f);
      V3 d = unit(sub(hit_dir[i], mul(n, 2.0f * dot(hit_dir[i], n))));
      V3 org = add(hit_at[i], mul(n, offset(hit_at[i])));
      Ray r = { org, d, hit_depth[i] + 1 };
      next[spawned++] = r;
    }
    Ray *t = rays; rays = next; next = t;
    count = spawned;
  }
  printf("embree build %.6f triangles %zu camera %zu %.6f mirror %zu %.6f shadow %zu %.6f blocked %zu\n", build,
         triangles.len, traced[0], secs[0], traced[1], secs[1], shadows, shadow_secs, blocked);
  if (rtcGetDeviceError(device) != RTC_ERROR_NONE) fail("Embree reported an error tracing");
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  free(rays); free(next); free(hit_at); free(hit_n); free(hit_depth); free(hit_dir); free(shadow);
  free(vertices.data); free(triangles.data);
  return 0;
}
