/* The logs of answered queries: every request type and detail level (queries), replies
 * cut into chunks (chunked), and a burst of interleaved clients (burst). */
#include <math.h>

#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"
#include "logs_world.h"

#define WORLD_ACC TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD

enum { QUERY_CLIENT = 0x51 };

static void query_rays(logs_writer *w, rng *r, lr_req q)
{
    enum { N = 32 };
    trioct_vec3_t o[N], d[N];
    ls_rays_from_above(r, N, o, d);
    q.id = 1;
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, N, o, d);
    q.id = 2;
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_ANY, WORLD_ACC, 0, INFINITY, 1, N, o, d);
    /* A window: only what lies between t = 10 and t = 12 (the ground band from z = 12). */
    q.id = 3;
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 10, 12, 1, N, o, d);

    trioct_vec3_t bo[24], bd[24];
    ls_rays_through_ball(r, 24, bo, bd);
    q.id = 4; /* every crossing, up to 8 a ray */
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, 8, 24, bo, bd);
    q.id = 5; /* one stored a ray: found[] says how many there were */
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, 1, 24, bo, bd);

    trioct_vec3_t ro[20], rd[20];
    ls_rays_random(r, 20, ro, rd);
    static const int8_t modes[] = {TRIOCT_RAY_REQUEST_T_EXACT, TRIOCT_RAY_REQUEST_T_SEED,
                                   TRIOCT_RAY_REQUEST_T_FAST};
    for (int k = 0; k < 3; k++) {
        q.id = 6 + k;
        lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, modes[k], 0, INFINITY, 1, 20, ro, rd);
    }

    trioct_vec3_t go[48], gd[48];
    ls_rays_on_grid(48, go, gd);
    q.id = 9; /* through vertices and edges of the terrain: each crosses it once */
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, 4, 48, go, gd);
    q.id = 10;
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, 48, go, gd);

    lr_req far = q;
    far.id = 11;
    far.deadline = LOGS_FAR_DEADLINE;
    lr_rays(w, &far, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, 8, o, d);
    q.id = 12; /* no rays at all */
    lr_rays(w, &q, TRIOCT_RAY_REQUEST_T_ANY, WORLD_ACC, 0, INFINITY, 1, 0, o, d);

    lr_req rays_only = q;
    rays_only.world = "yard_rays";
    rays_only.id = 13;
    lr_rays(w, &rays_only, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, N, o, d);
    lr_req fast = q;
    fast.world = "spare";
    fast.id = 14; /* the world's accuracy is fast */
    lr_rays(w, &fast, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, 20, ro, rd);
}

static void query_triangles(logs_writer *w, rng *r, lr_req q)
{
    enum { N = 24 };
    trioct_triangle_t t[N];
    ls_triangles_at_ground(r, N, 0.6, t);
    static const int8_t details[] = {TRIOCT_TRIANGLE_REQUEST_T_YESNO, TRIOCT_TRIANGLE_REQUEST_T_IDS,
                                     TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS};
    for (int k = 0; k < 3; k++) {
        q.id = 20 + k;
        lr_triangles(w, &q, details[k], WORLD_ACC, N, t);
    }
    q.id = 23;
    lr_triangles(w, &q, TRIOCT_TRIANGLE_REQUEST_T_IDS, TRIOCT_RAY_REQUEST_T_FAST, N, t);
    q.id = 24;
    lr_triangles(w, &q, TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, TRIOCT_RAY_REQUEST_T_SEED, N, t);

    /* On the cell: triangles in the planes of block faces, contact on contact. */
    trioct_triangle_t c[16];
    ls_triangles_on_cell(r, 16, c);
    lr_req cell = q;
    cell.world = "cell";
    cell.id = 25;
    lr_triangles(w, &cell, TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, WORLD_ACC, 16, c);
    cell.id = 26;
    lr_triangles(w, &cell, TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, 16, c);
    cell.id = 27;
    lr_triangles(w, &cell, TRIOCT_TRIANGLE_REQUEST_T_IDS, TRIOCT_RAY_REQUEST_T_FAST, 16, c);
}

static void query_meshes(logs_writer *w, rng *r, lr_req q)
{
    trioct_pose_t p[16];
    ls_poses(r, 16, ls_vec(-7, -7, -0.3), ls_vec(7, 7, 2.5), p);
    q.id = 30;
    lr_mesh(w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "probe", 0, NULL, 16, p);
    q.id = 31;
    lr_mesh(w, &q, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "probe", 0, NULL, 16, p);
    q.id = 32;
    lr_mesh(w, &q, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "ring", 0, NULL, 8, p);

    trioct_triangle_t tet[4];
    ls_tetrahedron(0.8, tet);
    q.id = 33;
    lr_mesh(w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, NULL, 4, tet, 12, p);
    q.id = 34;
    lr_mesh(w, &q, TRIOCT_MESH_REQUEST_T_PAIRS, TRIOCT_RAY_REQUEST_T_SEED, NULL, 4, tet, 12, p);

    /* The probe (a cube of 0.5) set on the cell's grid: faces flush with block faces. */
    trioct_pose_t g[18];
    ls_poses_on_grid(18, LOGS_CELL_SIZE, ls_vec(LOGS_CELL_LO_X + 0.25, LOGS_CELL_LO_Y + 0.25, 0.25), g);
    lr_req cell = q;
    cell.world = "cell";
    cell.id = 35;
    lr_mesh(w, &cell, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "probe", 0, NULL, 5, g);
    cell.id = 36;
    lr_mesh(w, &cell, TRIOCT_MESH_REQUEST_T_YESNO, TRIOCT_RAY_REQUEST_T_FAST, "probe", 0, NULL, 18, g);
}

int logs_write_queries(const char *dir)
{
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED);
    lr_req q = {QUERY_CLIENT, 0, "REPLAY_QUERIES", "yard", NULL, 0};
    query_rays(&w, &r, q);
    query_triangles(&w, &r, q);
    query_meshes(&w, &r, q);
    return lw_save(&w, dir, "queries");
}

int logs_write_chunked(const char *dir)
{
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 1);
    lr_req q = {0xc4, 1, "REPLAY_CHUNKED", "yard", NULL, 0};
    /* About 1,200 hits of 56 bytes: two chunks of at most 60,000 bytes. */
    enum { RAYS = 700 };
    static trioct_vec3_t o[RAYS], d[RAYS];
    ls_rays_through_ball(&r, RAYS, o, d);
    lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, 8, RAYS, o, d);

    /* Triangles on the cell's block faces touch dozens of coplanar triangles each: over a
     * thousand contacts with their segments, two chunks again. */
    enum { TRIS = 48 };
    trioct_triangle_t t[TRIS];
    ls_triangles_on_cell(&r, TRIS, t);
    q.world = "cell";
    q.id = 2;
    lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, WORLD_ACC, TRIS, t);
    q.id = 3;
    lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_IDS, WORLD_ACC, TRIS, t);
    return lw_save(&w, dir, "chunked");
}

int logs_write_burst(const char *dir)
{
    enum { CLIENTS = 24, EACH = 6 };
    static const char *const replies[] = {"REPLAY_BURST_A", "REPLAY_BURST_B", "REPLAY_BURST_C"};
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 2);
    /* Round k: every client sends its request k, in an order shuffled anew each round.
     * Clients share reply channels and request ids: only (client, request id) tells the
     * replies apart. */
    for (int k = 0; k < EACH; k++) {
        int order[CLIENTS];
        for (int c = 0; c < CLIENTS; c++)
            order[c] = c;
        for (int c = CLIENTS - 1; c > 0; c--) {
            int j = (int)(rng_next(&r) % (uint64_t)(c + 1)), t = order[c];
            order[c] = order[j];
            order[j] = t;
        }
        for (int i = 0; i < CLIENTS; i++) {
            int c = order[i];
            lr_req q = {0x1000 + 0x101 * c, k + 1, replies[c % 3], c % 4 == 3 ? "yard_rays" : "yard", NULL, 0};
            trioct_vec3_t o[6], d[6];
            trioct_triangle_t t[4];
            trioct_pose_t p[3];
            switch ((c + k) % 4) {
            case 0:
                ls_rays_from_above(&r, 6, o, d);
                lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, d);
                break;
            case 1:
                ls_rays_random(&r, 6, o, d);
                lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_ANY, WORLD_ACC, 0, INFINITY, 1, 6, o, d);
                break;
            case 2:
                ls_triangles_at_ground(&r, 4, 0.8, t);
                lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_IDS, WORLD_ACC, 4, t);
                break;
            default:
                ls_poses(&r, 3, ls_vec(-6, -6, 0), ls_vec(6, 6, 2), p);
                lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "probe", 0, NULL, 3, p);
                break;
            }
        }
    }
    return lw_save(&w, dir, "burst");
}
