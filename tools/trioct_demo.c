/* What `make run` starts until the daemon exists: builds octrees over a real mesh and a
 * generated terrain and answers a few queries of each kind, printing what it did. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "engine.h"
#include "support/meshgen.h"
#include "world/mesh_load.h"

static void show(const char *name, mesh_data *m)
{
    mesh_view v = mesh_data_view(m);
    octree_error err;
    octree *t = octree_build(&v, NULL, &err);
    if (!t) {
        printf("%s: %s\n", name, err.message);
        return;
    }
    octree_info info;
    octree_get_info(t, &info);
    printf("\n%s: %zu triangles, d = %.4g, L_max = %d, %zu nodes, %.1f bytes/triangle, built in %.3f s\n", name,
           info.triangle_count, info.resolution, info.max_level, info.node_count,
           (double)info.bytes_total / (double)info.triangle_count, info.build_seconds);
    box3 b = mesh_data_bounds(m);
    vec3 c = vec3_scale(vec3_add(b.lo, b.hi), 0.5), size = vec3_sub(b.hi, b.lo);
    vec3 from = vec3_make(c.x, c.y, b.hi.z + size.z + 1);
    for (int i = 0; i < 3; i++) {
        vec3 to = vec3_make(c.x + (i - 1) * size.x / 8, c.y, c.z);
        ray_input ray = {from, vec3_sub(to, from), 0, INFINITY};
        ray_hit hits[8];
        ray_output out = {.hits = hits, .max_hits = 8};
        query_stats st = {0};
        octree_ray(t, &ray, RAY_ALL, ACCURACY_EXACT, &out, &st);
        printf("  ray %d from above: %zu crossings", i, out.hit_count);
        for (size_t k = 0; k < out.hit_count && k < 3; k++)
            printf(" [t=%.5g tri %u]", hits[k].t, hits[k].triangle);
        printf("  (%llu nodes, %llu candidates)\n", (unsigned long long)st.nodes_visited,
               (unsigned long long)st.candidates_tested);
    }
    /* A vertical triangle standing in the middle of the bounds, as tall as they are. */
    vec3 q[3] = {vec3_make(c.x - size.x / 16, c.y, b.lo.z), vec3_make(c.x + size.x / 16, c.y, b.lo.z),
                 vec3_make(c.x, c.y, b.hi.z)};
    tri_contact contacts[64];
    tri_output to = {.contacts = contacts, .capacity = 64};
    query_stats st = {0};
    octree_triangle(t, q, TRI_SEGMENTS, ACCURACY_EXACT, &to, &st);
    printf("  a vertical triangle through the middle touches %zu world triangles (%llu candidates)", to.count,
           (unsigned long long)st.candidates_tested);
    if (to.count)
        printf(", first contact %u along (%.4g %.4g %.4g)-(%.4g %.4g %.4g)", contacts[0].triangle, contacts[0].p.x,
               contacts[0].p.y, contacts[0].p.z, contacts[0].q.x, contacts[0].q.y, contacts[0].q.z);
    printf("\n");
    octree_free(t);
}

int main(void)
{
    printf("trioct engine demo. The daemon trioctd is not built yet: the LCM service arrives with\n"
           "issue 4; until then this shows the engine it will serve.\n");
    mesh_data real = {0};
    char err[256];
    if (mesh_load_file("/usr/share/assimp/models/PLY/Wuson.ply", &real, NULL, err, sizeof err) == 0)
        show("Wuson.ply (assimp test model)", &real);
    else
        printf("%s\n", err);
    mesh_data_free(&real);
    mesh_data terrain = meshgen_terrain(1, (box3){{0, 0, 0}, {100, 100, 10}}, 256, 256);
    show("generated terrain", &terrain);
    mesh_data_free(&terrain);
    return 0;
}
