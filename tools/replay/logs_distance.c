/* The distance log: point distances on a world of one object at the identity (yard) and
 * on posed objects (shop), with and without a limit, an empty batch and a batch large
 * enough for several chunks; the probe's shape distance and clearance at poses over both,
 * with a limit and at several radii; then what is refused: a world without the effect, a
 * NaN point, a CLEAR without a radius. */
#include <math.h>
#include <stdlib.h>

#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"
#include "logs_world.h"

enum { DISTANCE_CLIENT = 0xd1 };

/* Points over and around the yard's box, some above the ground, some below it. */
static void points_around(rng *r, int n, trioct_vec3_t *out)
{
    for (int i = 0; i < n; i++)
        out[i] = ls_vec(rng_uniform(r, -14, 14), rng_uniform(r, -14, 14), rng_uniform(r, -4, 10));
}

int logs_write_distance(const char *dir)
{
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 22);
    enum { N = 48, MANY = 1500 };
    trioct_vec3_t pts[N];
    points_around(&r, N, pts);
    lr_req q = {DISTANCE_CLIENT, 0, "REPLAY_DISTANCE", "yard", NULL, 0};

    q.id++;
    lr_distance_points(&w, &q, -1, N, pts);
    q.id++; /* a limit: the far points find nothing */
    lr_distance_points(&w, &q, 2.0, N, pts);
    q.id++;
    lr_distance_points(&w, &q, -1, 0, NULL);

    trioct_vec3_t *many = malloc(MANY * sizeof *many);
    if (many == NULL)
        return -1;
    points_around(&r, MANY, many);
    q.id++; /* 1,500 results: three chunks */
    lr_distance_points(&w, &q, -1, MANY, many);

    lr_req shop = q;
    shop.world = "shop";
    shop.id++;
    lr_distance_points(&w, &shop, -1, N, pts);
    shop.id++;
    lr_distance_points(&w, &shop, 1.0, N, pts);

    /* Refused. */
    lr_req rays_only = q;
    rays_only.world = "yard_rays";
    rays_only.id = 20;
    lr_distance_points(&w, &rays_only, -1, N, pts);
    trioct_vec3_t bad[2] = {ls_vec(0, 0, 1), ls_vec(0, NAN, 1)};
    q.id = 21;
    lr_distance_points(&w, &q, -1, 2, bad);
    q.id = 22;
    lr_distance_points(&w, &q, NAN, 1, bad);
    q.id = 23; /* CLEAR needs a radius >= 0 */
    trioct_pose_t one[1];
    ls_poses(&r, 1, ls_vec(-6, -6, 1), ls_vec(6, 6, 4), one);
    lr_distance_shape(&w, &q, TRIOCT_DISTANCE_REQUEST_T_CLEAR, -1, "probe", 1, one);

    /* The probe at poses over the ground and among the crates: distances (some touching),
     * within a limit, and clearance at three radii. */
    enum { POSES = 12 };
    trioct_pose_t at[POSES];
    ls_poses(&r, POSES, ls_vec(-6, -6, -0.5), ls_vec(6, 6, 4), at);
    lr_req shapes[2] = {q, shop};
    for (int k = 0; k < 2; k++) {
        shapes[k].id = 30 + 10 * k;
        lr_distance_shape(&w, &shapes[k], TRIOCT_DISTANCE_REQUEST_T_SHAPE, -1, "probe", POSES, at);
        shapes[k].id++;
        lr_distance_shape(&w, &shapes[k], TRIOCT_DISTANCE_REQUEST_T_SHAPE, 1.0, "probe", POSES, at);
        const double radii[3] = {0.05, 0.5, 2.0};
        for (int i = 0; i < 3; i++) {
            shapes[k].id++;
            lr_distance_shape(&w, &shapes[k], TRIOCT_DISTANCE_REQUEST_T_CLEAR, radii[i], "probe", POSES, at);
        }
    }
    free(many);
    return lw_save(&w, dir, "distance");
}
