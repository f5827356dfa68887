/* libtrioct from C: one synchronous call, then batches of rays in flight at once, completed
 * through trioct_poll. `make` builds it against the tree; the install test builds it against
 * the installed library, the way a user would:
 *
 *     cc ray_example.c $(pkg-config --cflags --libs trioct) -o ray_example
 *
 * Run: ray_example [WORLD [URL [TIMEOUT_MS]]] (defaults: yard, $LCM_DEFAULT_URL, 1000).
 * Exits 0 when every request was answered, 1 when one was not, 2 when it cannot connect. */
#include <stdio.h>
#include <stdlib.h>

#include "trioct.h"

enum { BATCHES = 4, RAYS = 16 };

typedef struct sweep {
    int answered, failed;
} sweep;

/* Runs inside trioct_poll. The library frees *res when this returns. */
static void on_rays(trioct_client *c, trioct_ray_result *res, void *user)
{
    (void)c;
    sweep *s = user;
    const trioct_reply *r = &res->reply;
    if (r->status != TRIOCT_OK) {
        s->failed++;
        fprintf(stderr, "request %lld: %s: %s\n", (long long)r->request_id,
                trioct_status_name(r->status), r->message);
        return;
    }
    s->answered++;
    size_t hit = 0;
    for (size_t i = 0; i < res->num_rays; i++)
        hit += res->found[i] > 0;
    printf("request %lld: %zu of %zu rays hit world %s (version %lld, daemon %s)\n",
           (long long)r->request_id, hit, res->num_rays, r->world, (long long)r->world_version,
           r->daemon);
    if (res->num_hits > 0)
        printf("  first hit: ray %d at t = %g on triangle %d\n", res->hits[0].ray,
               res->hits[0].t, res->hits[0].triangle);
}

int main(int argc, char **argv)
{
    const char *world = argc > 1 ? argv[1] : "yard";
    int timeout_ms = argc > 3 ? atoi(argv[3]) : 1000;
    trioct_connect_options opt = {.url = argc > 2 ? argv[2] : NULL, .send_deadlines = 1};
    int status;
    char err[256];
    trioct_client *c = trioct_connect(&opt, &status, err, sizeof err);
    if (c == NULL) {
        fprintf(stderr, "ray_example: %s\n", err);
        return 2;
    }

    /* Synchronous: the call returns with the answer (or why there is none). */
    trioct_admin_result info;
    int failed = 0;
    if (trioct_info(c, world, timeout_ms, &info) == TRIOCT_OK && info.num_worlds == 1) {
        printf("world %s: %lld triangles, held by %s\n", world,
               (long long)info.worlds[0].triangles, info.worlds[0].daemon);
    } else {
        fprintf(stderr, "info: %s\n", info.reply.message);
        failed = 1;
    }
    trioct_admin_result_free(&info);

    /* Asynchronous: every batch in flight at once. The query is sent before the call
     * returns, so one array serves every batch. */
    trioct_vec3 origins[RAYS], directions[RAYS];
    sweep s = {0};
    for (int b = 0; b < BATCHES; b++) {
        for (int i = 0; i < RAYS; i++) {
            origins[i] = (trioct_vec3){0.0, 0.0, 10.0};
            directions[i] = (trioct_vec3){i - RAYS / 2, b - BATCHES / 2, -8.0};
        }
        trioct_ray_query q = trioct_ray_query_default(world);
        q.count = RAYS;
        q.origins = origins;
        q.directions = directions;
        if (trioct_rays_async(c, &q, timeout_ms, on_rays, &s, NULL) != TRIOCT_OK) {
            fprintf(stderr, "rays: %s\n", trioct_last_error(c));
            s.failed++;
        }
    }
    while (trioct_in_flight(c) > 0)
        if (trioct_poll(c, -1) < 0) {
            fprintf(stderr, "poll: %s\n", trioct_last_error(c));
            break;
        }
    trioct_disconnect(c);
    return failed || s.failed > 0 || s.answered < BATCHES ? 1 : 0;
}
