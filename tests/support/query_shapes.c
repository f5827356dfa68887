#include "query_shapes.h"

void query_triangle_sample(const mesh_data *m, rng *r, double leaf, query_triangle_kind kind, vec3 out[3])
{
    size_t t = rng_next(r) % m->triangle_count;
    vec3 a = mesh_data_corner(m, t, 0);
    if (kind == QUERY_TRI_SAME) {
        out[0] = a;
        out[1] = mesh_data_corner(m, t, 1);
        out[2] = mesh_data_corner(m, t, 2);
        return;
    }
    vec3 q0 = a;
    if (kind == QUERY_TRI_NEAR)
        q0 = vec3_add(a, vec3_scale(rng_unit_vector(r), 0.5 * leaf * rng_uniform(r, 0, 1)));
    out[0] = q0;
    out[1] = vec3_add(q0, vec3_scale(rng_unit_vector(r), leaf));
    out[2] = vec3_add(q0, vec3_scale(rng_unit_vector(r), leaf));
}
