/* Brute-force reference queries (see brute_force.h). */
#include "brute_force.h"

#include <stdlib.h>

#include "geom/ray_tri.h"
#include "geom/tri_tri.h"
#include "geom/vec3.h"

static void tri_of(const mesh_view *m, size_t i, vec3 t[3])
{
    for (int k = 0; k < 3; k++)
        t[k] = m->vertices[m->indices[3 * i + (size_t)k]];
}

static int ray_test(const ray_input *r, const vec3 t[3], accuracy_mode mode, double eps, ray_tri_hit *h)
{
    switch (mode) {
    case ACCURACY_SEED: return ray_tri_seed(r->origin, r->direction, r->tmin, r->tmax, t, eps, h);
    case ACCURACY_FAST: return ray_tri_fast(r->origin, r->direction, r->tmin, r->tmax, t, h);
    default:
        if (r->contact == RAY_TOUCH)
            return ray_tri_touch(r->origin, r->direction, r->tmin, r->tmax, t, h);
        return ray_tri_exact(r->origin, r->direction, r->tmin, r->tmax, t, h);
    }
}

/* -1 when hit a comes before hit b. */
static int before(const mesh_view *m, const ray_input *r, accuracy_mode mode, const ray_hit *a, const ray_hit *b)
{
    int c;
    if (mode == ACCURACY_EXACT) {
        vec3 ta[3], tb[3];
        tri_of(m, a->triangle, ta);
        tri_of(m, b->triangle, tb);
        c = r->contact == RAY_TOUCH ? ray_tri_touch_compare(r->origin, r->direction, r->tmin, r->tmax, ta, tb)
                                    : ray_tri_compare_t(r->origin, r->direction, ta, tb);
    } else {
        c = (a->t > b->t) - (a->t < b->t);
    }
    if (c == 0)
        c = (a->triangle > b->triangle) - (a->triangle < b->triangle);
    return c < 0;
}

size_t brute_ray(const mesh_view *m, const ray_input *r, ray_detail detail, accuracy_mode mode, double eps,
                 ray_hit *hits, size_t max_hits)
{
    size_t n = 0;
    for (size_t i = 0; i < m->triangle_count; i++) {
        vec3 t[3];
        tri_of(m, i, t);
        ray_tri_hit h;
        if (!ray_test(r, t, mode, eps, &h))
            continue;
        ray_hit hit = {h.t, (uint32_t)i, h.u, h.v, {0, 0, 0}};
        if (detail == RAY_ANY) {
            if (max_hits)
                hits[0] = hit;
            return 1;
        }
        if (detail == RAY_CLOSEST) {
            if (n == 0 || before(m, r, mode, &hit, &hits[0]))
                hits[0] = hit;
            n = 1;
            continue;
        }
        /* insertion into the sorted prefix */
        size_t j = n < max_hits ? n : max_hits - 1;
        if (n >= max_hits && !before(m, r, mode, &hit, &hits[max_hits - 1])) {
            n++;
            continue;
        }
        while (j > 0 && before(m, r, mode, &hit, &hits[j - 1])) {
            if (j < max_hits)
                hits[j] = hits[j - 1];
            j--;
        }
        hits[j] = hit;
        n++;
    }
    return n;
}

size_t brute_triangle(const mesh_view *m, const vec3 q[3], accuracy_mode mode, double eps, uint32_t *ids,
                      size_t cap)
{
    size_t n = 0;
    for (size_t i = 0; i < m->triangle_count; i++) {
        vec3 t[3];
        tri_of(m, i, t);
        int hit = mode == ACCURACY_SEED   ? tri_tri_overlap_seed(q, t, eps)
                  : mode == ACCURACY_FAST ? tri_tri_overlap_fast(q, t)
                                          : tri_tri_overlap_exact(q, t);
        if (hit) {
            if (n < cap)
                ids[n] = (uint32_t)i;
            n++;
        }
    }
    return n;
}
