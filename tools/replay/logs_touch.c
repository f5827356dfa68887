/* The touch log: the contact rule over the wire. Rays that slide along a crate's top, graze
 * a corner or an edge, or pass straight through, asked in the old ray_request_v1_t (which
 * means CROSSING), in ray_request_t as CROSSING, and as TOUCH at every detail; then the two
 * touch requests the daemon refuses. The golden log records that the grazing rays are clear
 * as crossings and blocked as touches. */
#include <math.h>

#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"
#include "logs_world.h"

enum { TOUCH_CLIENT = 0x70 };

#define EXACT TRIOCT_RAY_REQUEST_T_EXACT
#define WORLD_ACC TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD
#define CROSSING TRIOCT_RAY_REQUEST_T_CROSSING
#define TOUCH TRIOCT_RAY_REQUEST_T_TOUCH

int logs_write_touch(const char *dir)
{
    logs_writer w;
    lw_init(&w);
    /* Against `spare` (the crates alone, a fast world: TOUCH with the world's accuracy runs
     * exact there). The crates: [3, 5] x [-5, -3] x [0, 2], [4, 6]^2 x [0, 2.5],
     * [-6, -4]^2 x [0, 1.5], [-5, -3] x [3, 5] x [0, 1]. */
    enum { N = 5 };
    const trioct_vec3_t o[N] = {
        {0, -4, 2},       /* along the top of the first, in its plane z = 2: enters at t = 3 */
        {3.5, 4.5, 2.5},  /* diagonally across the corner (4, 4, 2.5) only, at t = 0.5 */
        {-5, -7, 0.5},    /* over the edge y = -6, z = 1.5 only, at t = 1 */
        {-7, 4, 0.5},     /* straight through the last one: the same either way */
        {0, 0, 3},        /* above everything: nothing either way */
    };
    const trioct_vec3_t d[N] = {{1, 0, 0}, {1, -1, 0}, {0, 1, 1}, {1, 0, 0}, {1, 0, 0}};
    lr_req q = {TOUCH_CLIENT, 0, "REPLAY_TOUCH", "spare", NULL, 0};
    q.id = 1; /* the old type: contact CROSSING */
    lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_ALL, EXACT, 0, INFINITY, 8, N, o, d);
    q.id = 2;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_ALL, EXACT, CROSSING, 0, INFINITY, 8, N, o, d);
    q.id = 3;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_ANY, EXACT, CROSSING, 0, INFINITY, 1, N, o, d);
    q.id = 4;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_ANY, WORLD_ACC, TOUCH, 0, INFINITY, 1, N, o, d);
    q.id = 5;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, EXACT, TOUCH, 0, INFINITY, 1, N, o, d);
    q.id = 6;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_ALL, EXACT, TOUCH, 0, INFINITY, 8, N, o, d);
    q.id = 7; /* a window that ends one ulp before the first contact of ray 0 */
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, EXACT, TOUCH, 0, nextafter(3, 0), 1, N, o, d);
    q.id = 8; /* refused: touch is exact-only */
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_ANY, TRIOCT_RAY_REQUEST_T_SEED, TOUCH, 0, INFINITY, 1, N, o, d);
    q.id = 9; /* refused: no such contact */
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_ANY, EXACT, 3, 0, INFINITY, 1, N, o, d);

    /* Touch on the yard (terrain, crates, ball) from above, the world's own exact mode. */
    rng r = rng_seeded(LOGS_SEED + 11);
    enum { M = 16 };
    trioct_vec3_t ao[M], ad[M];
    ls_rays_from_above(&r, M, ao, ad);
    q.world = "yard";
    q.id = 10;
    lr_rays_contact(&w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, TOUCH, 0, INFINITY, 1, M, ao, ad);
    return lw_save(&w, dir, "touch");
}
