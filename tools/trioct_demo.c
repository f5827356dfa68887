/* What `make run` shows once the demo daemon is up: a client asking the daemon a few
 * questions of every kind through libtrioct, and what the answers and the worlds' memory
 * look like. It talks to whatever daemon serves the demo scene on the bus it is given.
 *
 *   trioct-demo [LCM_URL] */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "trioct.h"

#define TIMEOUT_MS 5000

static void show_world(const trioct_world_info *w)
{
    /* MiB, as trioct info and the daemon's log count memory. */
    const double mib = 1024.0 * 1024.0;
    printf("  %-12s v%lld  %8lld triangles  d = %.3g  L_max = %d  %7lld nodes  memory %6.2f MiB "
           "(octree %.2f, effects %.2f)  effects:%s%s%s  meshes read in %.3f s, octrees built in %.3f s\n",
           w->name, (long long)w->version, (long long)w->triangles, w->resolution, w->max_level,
           (long long)w->nodes, w->bytes_total / mib, (w->bytes_total - w->bytes_effects) / mib,
           w->bytes_effects / mib, (w->effects & TRIOCT_EFFECT_RAYS) ? " rays" : "",
           (w->effects & TRIOCT_EFFECT_TRIANGLES) ? " triangles" : "",
           (w->effects & TRIOCT_EFFECT_MESHES) ? " meshes" : "", w->load_seconds, w->build_seconds);
}

static void show_status(const char *what, const trioct_reply *reply)
{
    printf("  %s: %s (%s)\n", what, trioct_status_name(reply->status), reply->message);
}

static int list_worlds(trioct_client *c)
{
    trioct_list_options lo = {.gather_ms = 300};
    trioct_list_result list;
    int rc = trioct_list(c, &lo, TIMEOUT_MS, &list);
    printf("\nworlds on the bus (%zu daemons answered):\n", list.num_daemons);
    for (size_t i = 0; i < list.num_worlds; i++)
        show_world(&list.worlds[i]);
    trioct_list_result_free(&list);
    return rc;
}

static void ask_rays(trioct_client *c)
{
    /* A fan of rays from 30 m above the yard, straight down and slanted. */
    trioct_vec3 o[5], d[5];
    for (int i = 0; i < 5; i++) {
        o[i] = (trioct_vec3){-20 + 10 * i, 0.5, 30};
        d[i] = (trioct_vec3){0.2 * (i - 2), 0, -1};
    }
    trioct_ray_query q = trioct_ray_query_default("yard");
    q.count = 5;
    q.origins = o;
    q.directions = d;
    trioct_ray_result res;
    trioct_rays(c, &q, TIMEOUT_MS, &res);
    printf("\nclosest hits of 5 rays from above the yard: %s\n", trioct_status_name(res.reply.status));
    for (size_t i = 0; i < res.num_hits; i++) {
        const trioct_ray_hit *h = &res.hits[i];
        printf("  ray %d hits triangle %d at t = %.4f, point (%.3f %.3f %.3f)\n", h->ray, h->triangle, h->t,
               o[h->ray].x + h->t * d[h->ray].x, o[h->ray].y + h->t * d[h->ray].y,
               o[h->ray].z + h->t * d[h->ray].z);
    }
    trioct_ray_result_free(&res);

    q.detail = TRIOCT_RAY_ALL;
    q.max_hits = 8;
    trioct_rays(c, &q, TIMEOUT_MS, &res);
    printf("all crossings of the same rays:");
    for (size_t i = 0; i < res.num_rays; i++)
        printf(" %d", res.found[i]);
    printf("\n");
    trioct_ray_result_free(&res);
}

static void ask_triangles(trioct_client *c)
{
    /* A vertical triangle standing in a crate's face, and one floating in the air. */
    trioct_triangle tris[2] = {{{-29, -9, 1}, {-29, -9.5, 2}, {-31, -9, 1.5}}, {{0, 0, 20}, {1, 0, 20}, {0, 1, 20}}};
    trioct_triangle_query q = {.world = "yard", .detail = TRIOCT_TRI_SEGMENTS, .accuracy = TRIOCT_ACCURACY_WORLD,
                               .count = 2, .triangles = tris};
    trioct_triangle_result res;
    trioct_triangles(c, &q, TIMEOUT_MS, &res);
    printf("\ntriangle contacts: %s; triangle 0 touches %d world triangles, triangle 1 touches %d\n",
           trioct_status_name(res.reply.status), res.num_triangles > 0 ? res.found[0] : -1,
           res.num_triangles > 1 ? res.found[1] : -1);
    for (size_t i = 0; i < res.num_contacts && i < 3; i++)
        printf("  world triangle %d along (%.3f %.3f %.3f)-(%.3f %.3f %.3f)\n", res.contacts[i].triangle,
               res.segments[i].p.x, res.segments[i].p.y, res.segments[i].p.z, res.segments[i].q.x,
               res.segments[i].q.y, res.segments[i].q.z);
    trioct_triangle_result_free(&res);

    q.world = "yard_lidar";
    trioct_triangles(c, &q, TIMEOUT_MS, &res);
    printf("the same question to the rays-only world:\n");
    show_status("answer", &res.reply);
    trioct_triangle_result_free(&res);
}

static void ask_mesh(trioct_client *c)
{
    /* The probe cube dropped onto a crate, and lifted 10 m above it. */
    trioct_pose poses[2] = {{{1, 0, 0, 0, 1, 0, 0, 0, 1}, {-28.5, -9, 2.6}}, {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {-28.5, -9, 12}}};
    trioct_mesh_query q = {.world = "yard", .detail = TRIOCT_MESH_PAIRS, .accuracy = TRIOCT_ACCURACY_WORLD,
                           .shape = "probe", .num_poses = 2, .poses = poses};
    trioct_mesh_result res;
    trioct_mesh(c, &q, TIMEOUT_MS, &res);
    printf("\nthe probe shape at 2 poses: %s; touching pairs per pose: %d, %d\n", trioct_status_name(res.reply.status),
           res.num_poses > 0 ? res.found[0] : -1, res.num_poses > 1 ? res.found[1] : -1);
    trioct_mesh_result_free(&res);
}

int main(int argc, char **argv)
{
    trioct_connect_options opt = {.url = argc > 1 ? argv[1] : NULL};
    char err[256];
    int status;
    trioct_client *c = trioct_connect(&opt, &status, err, sizeof err);
    if (c == NULL) {
        fprintf(stderr, "trioct-demo: %s\n", err);
        return 1;
    }
    /* The daemon may still be building the demo worlds: wait for its READY heartbeat. */
    int ready = 0;
    for (int tries = 0; tries < 60 && !ready; tries++) {
        trioct_daemon_status st;
        if (trioct_next_status(c, NULL, 1000, &st) == TRIOCT_OK)
            ready = st.state == TRIOCT_DAEMON_READY;
        trioct_daemon_status_free(&st);
    }
    int rc = ready ? list_worlds(c) : TRIOCT_ERR_NO_DAEMON;
    if (rc != TRIOCT_OK) {
        fprintf(stderr, "trioct-demo: no daemon answered on %s\n", trioct_url(c));
        trioct_disconnect(c);
        return 1;
    }
    ask_rays(c);
    ask_triangles(c);
    ask_mesh(c);

    trioct_vec3 o = {0, 0, 5}, d = {0, 0, 0};
    trioct_ray_query q = trioct_ray_query_default("yard");
    q.count = 1;
    q.origins = &o;
    q.directions = &d;
    trioct_ray_result res;
    trioct_rays(c, &q, TIMEOUT_MS, &res);
    printf("\nbad input is answered, not dropped:\n");
    show_status("a ray with a zero direction", &res.reply);
    trioct_ray_result_free(&res);
    q.world = "no_such_world";
    trioct_rays(c, &q, 500, &res);
    show_status("a world nobody holds", &res.reply);
    trioct_ray_result_free(&res);
    trioct_disconnect(c);
    return 0;
}
