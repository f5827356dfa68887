/* The oracle (oracle.h) over every triangle of a mesh: the truth an octree query is checked
 * against, with no engine code on the way. Triangles are first pruned by their bounding
 * boxes: for a query triangle by plain comparisons of doubles (exact), for a ray by slabs
 * widened far past their rounding error (conservative); every triangle left goes to the
 * oracle. */
#ifndef TRIOCT_TESTS_ORACLE_MESH_H
#define TRIOCT_TESTS_ORACLE_MESH_H

#include <stddef.h>
#include <stdint.h>

#include "engine.h"

typedef struct oracle_mesh {
    mesh_view mesh; /* borrowed */
    vec3 *lo, *hi;  /* each triangle's bounding box */
} oracle_mesh;

/* 0, or -1 when out of memory. */
int oracle_mesh_init(oracle_mesh *om, const mesh_view *mesh);
void oracle_mesh_free(oracle_mesh *om);
void oracle_mesh_triangle_at(const oracle_mesh *om, uint32_t id, vec3 out[3]);

/* Ids (ascending) of the triangles the closed query triangle touches; returns how many
 * (ids holds the first cap of them). */
size_t oracle_mesh_triangle(const oracle_mesh *om, const vec3 q[3], uint32_t *ids, size_t cap);

/* Every triangle the ray (closed interval [tmin, tmax]) meets, ascending by id, with the
 * contact kind of each (ORACLE_RAY_INTERIOR, _BOUNDARY, _IN_PLANE or _ZERO_AREA). */
typedef struct oracle_ray_truth {
    size_t count;
    uint32_t *ids;
    unsigned char *kinds;
    size_t boundary; /* contacts that are not interior crossings */
    int has_closest;
    uint32_t closest; /* the nearest interior crossing by exact t, ties to the smaller id */
} oracle_ray_truth;

/* 0, or -1 when out of memory. */
int oracle_mesh_ray(const oracle_mesh *om, const ray_input *ray, oracle_ray_truth *out);
void oracle_ray_truth_free(oracle_ray_truth *t);

/* Is the engine's answer (hits[0..hit_count), for RAY_ALL the whole sorted list) to `ray`
 * at `detail` right? A ray that crosses every triangle it meets in its interior (no
 * boundary contact) has one right answer: ANY a hit exactly when the ray meets something
 * (and on a met triangle), CLOSEST the nearest crossing by exact t with ties to the
 * smaller id, ALL exactly the met triangles. With boundary contacts a crossing rule
 * (watertightness) may take or leave each boundary contact, so only this is required:
 * every reported triangle is met, every interior crossing is reported (ALL) or the
 * reported hit is not beyond any interior crossing (CLOSEST), and the ray is not reported
 * as missing while it crosses a triangle's interior. Returns 1 when right, else 0 with a
 * reason in why. */
int oracle_ray_answer_ok(const oracle_mesh *om, const ray_input *ray, const oracle_ray_truth *truth,
                         ray_detail detail, const ray_hit *hits, size_t hit_count, char *why, size_t why_len);

#endif
