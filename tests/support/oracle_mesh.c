/* The oracle over a whole mesh (see oracle_mesh.h). */
#include "oracle_mesh.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "oracle.h"

int oracle_mesh_init(oracle_mesh *om, const mesh_view *mesh)
{
    om->mesh = *mesh;
    size_t n = mesh->triangle_count ? mesh->triangle_count : 1;
    om->lo = malloc(n * sizeof *om->lo);
    om->hi = malloc(n * sizeof *om->hi);
    if (!om->lo || !om->hi) {
        oracle_mesh_free(om);
        return -1;
    }
    for (size_t i = 0; i < mesh->triangle_count; i++) {
        vec3 t[3];
        oracle_mesh_triangle_at(om, (uint32_t)i, t);
        om->lo[i] = om->hi[i] = t[0];
        for (int k = 1; k < 3; k++) {
            om->lo[i].x = fmin(om->lo[i].x, t[k].x), om->hi[i].x = fmax(om->hi[i].x, t[k].x);
            om->lo[i].y = fmin(om->lo[i].y, t[k].y), om->hi[i].y = fmax(om->hi[i].y, t[k].y);
            om->lo[i].z = fmin(om->lo[i].z, t[k].z), om->hi[i].z = fmax(om->hi[i].z, t[k].z);
        }
    }
    return 0;
}

void oracle_mesh_free(oracle_mesh *om)
{
    free(om->lo);
    free(om->hi);
    om->lo = om->hi = NULL;
}

void oracle_mesh_triangle_at(const oracle_mesh *om, uint32_t id, vec3 out[3])
{
    for (int k = 0; k < 3; k++)
        out[k] = om->mesh.vertices[om->mesh.indices[3 * (size_t)id + (size_t)k]];
}

size_t oracle_mesh_triangle(const oracle_mesh *om, const vec3 q[3], uint32_t *ids, size_t cap)
{
    vec3 lo = q[0], hi = q[0];
    for (int k = 1; k < 3; k++) {
        lo.x = fmin(lo.x, q[k].x), hi.x = fmax(hi.x, q[k].x);
        lo.y = fmin(lo.y, q[k].y), hi.y = fmax(hi.y, q[k].y);
        lo.z = fmin(lo.z, q[k].z), hi.z = fmax(hi.z, q[k].z);
    }
    size_t n = 0;
    for (size_t i = 0; i < om->mesh.triangle_count; i++) {
        /* Closed boxes that do not overlap hold closed triangles that do not meet. */
        if (om->lo[i].x > hi.x || om->hi[i].x < lo.x || om->lo[i].y > hi.y || om->hi[i].y < lo.y ||
            om->lo[i].z > hi.z || om->hi[i].z < lo.z)
            continue;
        vec3 t[3];
        oracle_mesh_triangle_at(om, (uint32_t)i, t);
        if (!oracle_tri_tri(q, t))
            continue;
        if (n < cap)
            ids[n] = (uint32_t)i;
        n++;
    }
    return n;
}

/* The widening of a slab bound: (plane - o) * (1/d) is three roundings, each relative
 * 2^-53, so a relative 2^-40 and an absolute 2^-1000 (underflow) are far outside the
 * error. A bound that is not finite is left alone (an overflowed quotient rounds toward
 * its own infinity). */
static double widened(double t, double sign)
{
    if (!isfinite(t))
        return t;
    return t + sign * (fabs(t) * 0x1p-40 + 0x1p-1000);
}

/* 1 unless the ray surely misses the closed box [lo, hi]. */
static int ray_may_meet_box(const ray_input *r, const double inv[3], vec3 lo, vec3 hi)
{
    const double o[3] = {r->origin.x, r->origin.y, r->origin.z};
    const double d[3] = {r->direction.x, r->direction.y, r->direction.z};
    const double l[3] = {lo.x, lo.y, lo.z}, h[3] = {hi.x, hi.y, hi.z};
    double tn = r->tmin, tf = r->tmax;
    for (int a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < l[a] || o[a] > h[a])
                return 0;
            continue;
        }
        if (!isfinite(inv[a]) || fabs(inv[a]) < 0x1p-1000)
            continue; /* no trusted slab on this axis */
        double t0 = (l[a] - o[a]) * inv[a], t1 = (h[a] - o[a]) * inv[a];
        if (isnan(t0) || isnan(t1))
            continue;
        if (t0 > t1) {
            double s = t0;
            t0 = t1;
            t1 = s;
        }
        t0 = widened(t0, -1.0);
        t1 = widened(t1, +1.0);
        tn = t0 > tn ? t0 : tn;
        tf = t1 < tf ? t1 : tf;
    }
    return tn <= tf;
}

int oracle_mesh_ray(const oracle_mesh *om, const ray_input *ray, oracle_ray_truth *out)
{
    *out = (oracle_ray_truth){0};
    const double inv[3] = {1.0 / ray->direction.x, 1.0 / ray->direction.y, 1.0 / ray->direction.z};
    size_t cap = 0;
    for (size_t i = 0; i < om->mesh.triangle_count; i++) {
        if (!ray_may_meet_box(ray, inv, om->lo[i], om->hi[i]))
            continue;
        vec3 t[3];
        oracle_mesh_triangle_at(om, (uint32_t)i, t);
        int kind = oracle_ray_tri_contact(ray->origin, ray->direction, ray->tmin, ray->tmax, t);
        if (kind == ORACLE_RAY_MISS)
            continue;
        if (out->count == cap) {
            cap = cap ? 2 * cap : 8;
            uint32_t *ids = realloc(out->ids, cap * sizeof *ids);
            if (ids)
                out->ids = ids;
            unsigned char *kinds = realloc(out->kinds, cap);
            if (kinds)
                out->kinds = kinds;
            if (!ids || !kinds) {
                oracle_ray_truth_free(out);
                return -1;
            }
        }
        out->ids[out->count] = (uint32_t)i;
        out->kinds[out->count++] = (unsigned char)kind;
        if (kind != ORACLE_RAY_INTERIOR) {
            out->boundary++;
            continue;
        }
        if (out->has_closest) {
            vec3 c[3];
            oracle_mesh_triangle_at(om, out->closest, c);
            /* Ascending ids: a tie keeps the earlier, smaller one. */
            if (oracle_compare_plane_t(ray->origin, ray->direction, t, c) >= 0)
                continue;
        }
        out->closest = (uint32_t)i;
        out->has_closest = 1;
    }
    return 0;
}

void oracle_ray_truth_free(oracle_ray_truth *t)
{
    free(t->ids);
    free(t->kinds);
    *t = (oracle_ray_truth){0};
}

/* The contact kind of triangle id, or ORACLE_RAY_MISS when the ray does not meet it. */
static int kind_of(const oracle_ray_truth *t, uint32_t id)
{
    size_t lo = 0, hi = t->count;
    while (lo < hi) {
        size_t mid = lo + (hi - lo) / 2;
        if (t->ids[mid] < id)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo < t->count && t->ids[lo] == id ? t->kinds[lo] : ORACLE_RAY_MISS;
}

/* -1, 0, +1: the exact t of interior crossings a against b. */
static int compare_t(const oracle_mesh *om, const ray_input *ray, uint32_t a, uint32_t b)
{
    vec3 ta[3], tb[3];
    oracle_mesh_triangle_at(om, a, ta);
    oracle_mesh_triangle_at(om, b, tb);
    return oracle_compare_plane_t(ray->origin, ray->direction, ta, tb);
}

#define WHY(...) (snprintf(why, why_len, __VA_ARGS__), 0)

int oracle_ray_answer_ok(const oracle_mesh *om, const ray_input *ray, const oracle_ray_truth *truth,
                         ray_detail detail, const ray_hit *hits, size_t hit_count, char *why, size_t why_len)
{
    const int clean = truth->boundary == 0;
    const size_t interior = truth->count - truth->boundary;
    size_t stored = detail == RAY_ALL ? hit_count : (hit_count > 0);
    for (size_t k = 0; k < stored; k++)
        if (kind_of(truth, hits[k].triangle) == ORACLE_RAY_MISS)
            return WHY("reported triangle %u, which the ray does not meet (t %.17g)", hits[k].triangle, hits[k].t);
    if (hit_count == 0 && interior > 0)
        return WHY("no hit, but the ray crosses %zu triangle interiors (the nearest %u)", interior, truth->closest);
    if (clean && hit_count == 0 && truth->count > 0)
        return WHY("no hit, but the ray meets %zu triangles", truth->count);
    if (detail == RAY_ANY)
        return 1;
    if (detail == RAY_CLOSEST) {
        if (hit_count == 0 || !truth->has_closest)
            return 1;
        uint32_t got = hits[0].triangle;
        if (clean)
            return got == truth->closest ? 1
                                         : WHY("closest hit on triangle %u, the nearest crossing is triangle %u",
                                               got, truth->closest);
        /* A boundary contact may be taken or left, but never one beyond an interior
         * crossing (which always counts), nor one tied with it and of a larger id; a
         * contact in the triangle's plane or with a zero-area triangle has no plane t. */
        int kind = kind_of(truth, got);
        if (kind == ORACLE_RAY_IN_PLANE || kind == ORACLE_RAY_ZERO_AREA)
            return 1;
        int c = compare_t(om, ray, got, truth->closest);
        if (c > 0 || (c == 0 && got > truth->closest))
            return WHY("closest hit on triangle %u, beyond (or tied above) the interior crossing of triangle %u",
                       got, truth->closest);
        return 1;
    }
    /* RAY_ALL: each triangle once, every interior crossing present, and on a clean ray
     * exactly the met triangles in exact t order. */
    if (hit_count > stored)
        return WHY("%zu hits, only %zu stored: the check needs them all", hit_count, stored);
    size_t interior_found = 0;
    for (size_t k = 0; k < stored; k++) {
        for (size_t j = 0; j < k; j++)
            if (hits[j].triangle == hits[k].triangle)
                return WHY("triangle %u reported twice", hits[k].triangle);
        interior_found += kind_of(truth, hits[k].triangle) == ORACLE_RAY_INTERIOR;
    }
    if (interior_found != interior)
        return WHY("%zu of the ray's %zu interior crossings reported", interior_found, interior);
    if (!clean)
        return 1;
    if (stored != truth->count)
        return WHY("%zu hits, the ray meets %zu triangles", stored, truth->count);
    for (size_t k = 1; k < stored; k++) {
        int c = compare_t(om, ray, hits[k - 1].triangle, hits[k].triangle);
        if (c > 0 || (c == 0 && hits[k - 1].triangle > hits[k].triangle))
            return WHY("hits %zu and %zu (triangles %u, %u) out of exact t order", k - 1, k, hits[k - 1].triangle,
                       hits[k].triangle);
    }
    return 1;
}
