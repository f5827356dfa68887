/* The logs of refused requests: every error status a query can provoke without timing
 * (errors), the count caps (overcap), and bytes that are no request at all (hostile). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "channels.h"
#include "logs_cases.h"
#include "logs_requests.h"
#include "logs_shapes.h"
#include "trioct_limits.h"
#include "trioct_ray_reply_t.h"
#include "wire_check.h"

#define WORLD_ACC TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD
#define CLOSEST TRIOCT_RAY_REQUEST_T_CLOSEST

int logs_write_errors(const char *dir)
{
    enum { C = 0xe1 };
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 6);
    trioct_vec3_t o[6], d[6];
    ls_rays_from_above(&r, 6, o, d);
    trioct_triangle_t t[4];
    ls_triangles_at_ground(&r, 4, 0.5, t);
    trioct_pose_t p[4];
    ls_poses(&r, 4, ls_vec(-5, -5, 0), ls_vec(5, 5, 2), p);
    trioct_triangle_t tet[4];
    ls_tetrahedron(0.5, tet);
    lr_req q = {C, 0, "REPLAY_ERRORS", "yard", NULL, 0};
    int64_t id = 0;
#define NEXT(...) (q.id = ++id, __VA_ARGS__)

    /* ERR_BAD_REQUEST */
    NEXT(lr_rays(&w, &q, 3, WORLD_ACC, 0, INFINITY, 1, 6, o, d));                 /* detail */
    NEXT(lr_rays(&w, &q, CLOSEST, 5, 0, INFINITY, 1, 6, o, d));                   /* accuracy */
    NEXT(lr_rays(&w, &q, CLOSEST, WORLD_ACC, 5, 1, 1, 6, o, d));                  /* tmin > tmax */
    NEXT(lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, 0, 6, o, d)); /* max_hits */
    NEXT(lr_triangles(&w, &q, 3, WORLD_ACC, 4, t));
    NEXT(lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_IDS, -2, 4, t));
    NEXT(lr_mesh(&w, &q, 2, WORLD_ACC, "probe", 0, NULL, 4, p));
    NEXT(lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "probe", 4, tet, 4, p)); /* both shapes */
    NEXT(lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, NULL, 0, NULL, 4, p));   /* no shape */
    {
        lr_req other = q; /* header.world differs from the channel's */
        other.id = ++id;
        other.channel = lw_channel(TRIOCT_CHANNEL_RAY, "yard");
        other.world = "cell";
        lr_rays(&w, &other, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, d);
    }

    /* ERR_NONFINITE, each naming the item */
    trioct_vec3_t bo[6], bd[6];
    memcpy(bo, o, sizeof bo);
    memcpy(bd, d, sizeof bd);
    bo[4].y = NAN;
    NEXT(lr_rays(&w, &q, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, bo, d));
    bd[2].z = -INFINITY;
    NEXT(lr_rays(&w, &q, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, bd));
    NEXT(lr_rays(&w, &q, CLOSEST, WORLD_ACC, NAN, INFINITY, 1, 6, o, d));
    trioct_triangle_t bt[4];
    memcpy(bt, t, sizeof bt);
    bt[3].b.x = INFINITY;
    NEXT(lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, 4, bt));
    trioct_pose_t bp[4];
    memcpy(bp, p, sizeof bp);
    bp[1].r[5] = NAN;
    NEXT(lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "probe", 0, NULL, 4, bp));
    trioct_triangle_t btet[4];
    memcpy(btet, tet, sizeof btet);
    btet[2].c.z = NAN;
    NEXT(lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, NULL, 4, btet, 4, p));

    /* ERR_ZERO_DIRECTION */
    memcpy(bd, d, sizeof bd);
    bd[3] = ls_vec(0, 0, 0);
    NEXT(lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_ANY, WORLD_ACC, 0, INFINITY, 1, 6, o, bd));
    bd[3] = ls_vec(-0.0, 0, -0.0);
    NEXT(lr_rays(&w, &q, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, bd));

    /* ERR_OVER_CAP, the small ones (overcap.lcmlog holds the counts) */
    NEXT(lr_rays(&w, &q, TRIOCT_RAY_REQUEST_T_ALL, WORLD_ACC, 0, INFINITY, TRIOCT_MAX_HITS_PER_RAY + 1, 6, o, d));
    {
        enum { BIG = TRIOCT_MAX_INLINE_SHAPE_TRIANGLES + 1 };
        static trioct_triangle_t shape[BIG];
        ls_triangles_at_ground(&r, BIG, 0.2, shape);
        NEXT(lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, NULL, BIG, shape, 1, p));
    }

    /* ERR_EFFECT: each query on a world that does not serve it */
    lr_req rays_only = q, cell = q;
    rays_only.world = "yard_rays";
    cell.world = "cell";
    rays_only.id = ++id;
    lr_triangles(&w, &rays_only, TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, 4, t);
    rays_only.id = ++id;
    lr_mesh(&w, &rays_only, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "probe", 0, NULL, 4, p);
    cell.id = ++id;
    lr_rays(&w, &cell, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, d);

    /* ERR_DEADLINE: one microsecond after 1970 began */
    lr_req late = q;
    late.deadline = 1;
    late.id = ++id;
    lr_rays(&w, &late, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, d);
    late.id = ++id;
    lr_triangles(&w, &late, TRIOCT_TRIANGLE_REQUEST_T_IDS, WORLD_ACC, 4, t);
    late.id = ++id;
    lr_mesh(&w, &late, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "probe", 0, NULL, 4, p);

    /* ERR_UNKNOWN_SHAPE: a name yard lacks, and one only yard has */
    NEXT(lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "nosuch", 0, NULL, 4, p));
    cell.id = ++id;
    lr_mesh(&w, &cell, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "ring", 0, NULL, 4, p);

    /* And one that is fine, last: the daemon still answers. */
    NEXT(lr_rays(&w, &q, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 6, o, d));
#undef NEXT
    return lw_save(&w, dir, "errors");
}

int logs_write_overcap(const char *dir)
{
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 7);
    lr_req q = {0x0c, 1, "REPLAY_OVERCAP", "yard", NULL, 0};
    /* Each one item over its cap, and still one datagram; the log stays under 200 KB. */
    static trioct_vec3_t o[TRIOCT_MAX_RAYS + 1], d[TRIOCT_MAX_RAYS + 1];
    ls_rays_from_above(&r, TRIOCT_MAX_RAYS + 1, o, d);
    lr_rays(&w, &q, CLOSEST, WORLD_ACC, 0, INFINITY, 1, TRIOCT_MAX_RAYS + 1, o, d);
    static trioct_triangle_t t[TRIOCT_MAX_TRIANGLES + 1];
    ls_triangles_at_ground(&r, TRIOCT_MAX_TRIANGLES + 1, 0.3, t);
    q.id = 2;
    lr_triangles(&w, &q, TRIOCT_TRIANGLE_REQUEST_T_YESNO, WORLD_ACC, TRIOCT_MAX_TRIANGLES + 1, t);
    static trioct_pose_t p[TRIOCT_MAX_POSES + 1];
    ls_poses(&r, TRIOCT_MAX_POSES + 1, ls_vec(-6, -6, 0), ls_vec(6, 6, 2), p);
    q.id = 3;
    lr_mesh(&w, &q, TRIOCT_MESH_REQUEST_T_YESNO, WORLD_ACC, "probe", 0, NULL, TRIOCT_MAX_POSES + 1, p);
    return lw_save(&w, dir, "overcap");
}

/* ---------- hostile ---------- */

static void put_be32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)(v >> 24);
    p[1] = (uint8_t)(v >> 16);
    p[2] = (uint8_t)(v >> 8);
    p[3] = (uint8_t)v;
}

/* Offsets in an encoded ray request: fingerprint, client, request, then the reply
 * channel's length and bytes. */
enum { REPLY_LEN_AT = 8 + 8 + 8 };

int logs_write_hostile(const char *dir)
{
    enum { C = 0xbad };
    logs_writer w;
    lw_init(&w);
    rng r = rng_seeded(LOGS_SEED + 8);
    trioct_vec3_t o[3], d[3];
    ls_rays_from_above(&r, 3, o, d);
    trioct_triangle_t t[2];
    ls_triangles_at_ground(&r, 2, 0.5, t);
    trioct_pose_t p[2];
    ls_poses(&r, 2, ls_vec(-5, -5, 0), ls_vec(5, 5, 2), p);
    const char *ray_ch = lw_channel(TRIOCT_CHANNEL_RAY, "yard");
    lr_req good = {C, 1, "REPLAY_HOSTILE", "yard", NULL, 0};
    int64_t good_id = 0;
#define GOOD()                                                                                  \
    do {                                                                                        \
        good.id = ++good_id;                                                                    \
        switch (good_id % 4) {                                                                  \
        case 0:                                                                                 \
            lr_rays(&w, &good, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 3, o, d);                    \
            break;                                                                              \
        case 1:                                                                                 \
            lr_triangles(&w, &good, TRIOCT_TRIANGLE_REQUEST_T_IDS, WORLD_ACC, 2, t);            \
            break;                                                                              \
        case 2:                                                                                 \
            lr_mesh(&w, &good, TRIOCT_MESH_REQUEST_T_PAIRS, WORLD_ACC, "probe", 0, NULL, 2, p); \
            break;                                                                              \
        default:                                                                                \
            lr_admin(&w, &good, TRIOCT_ADMIN_REQUEST_T_INFO, NULL);                             \
            break;                                                                              \
        }                                                                                       \
    } while (0)

    /* Requests 900 and up are hostile variations: none may be answered. */
    lr_req bad = {C, 900, "REPLAY_HOSTILE", "yard", NULL, 0};
    size_t n;
    uint8_t *b;

    GOOD();
    lw_raw(&w, ray_ch, "hello", 5);
    lw_raw(&w, lw_channel(TRIOCT_CHANNEL_TRI, "yard"), "", 0);
    GOOD();
    bad.id = 901; /* cut short */
    b = lr_encode_rays(&bad, 3, o, d, &n);
    lw_raw(&w, ray_ch, b, n - 5);
    free(b);
    bad.id = 902; /* a byte too many */
    b = lr_encode_rays(&bad, 3, o, d, &n);
    uint8_t *longer = calloc(1, n + 1);
    if (longer != NULL && b != NULL)
        memcpy(longer, b, n);
    lw_raw(&w, ray_ch, longer, n + 1);
    free(longer);
    free(b);
    GOOD();
    bad.id = 903; /* a ray request on the triangle channel: wrong fingerprint */
    b = lr_encode_rays(&bad, 3, o, d, &n);
    lw_raw(&w, lw_channel(TRIOCT_CHANNEL_TRI, "yard"), b, n);
    free(b);
    GOOD();
    /* Counts that the bytes cannot back: the number of rays sits 8 bytes before the
     * origins, which end 2 * 3 * 24 bytes before the message does. */
    bad.id = 904;
    b = lr_encode_rays(&bad, 3, o, d, &n);
    if (b != NULL) {
        size_t count_at = n - 2 * 3 * 24 - 4;
        put_be32(b + count_at, 0x7fffffff);
        lw_raw(&w, ray_ch, b, n);
        put_be32(b + count_at, 0xffffffff); /* -1 */
        lw_raw(&w, ray_ch, b, n);
        put_be32(b + count_at, 4); /* one more than there are */
        lw_raw(&w, ray_ch, b, n);
        free(b);
    }
    GOOD();
    bad.id = 905; /* a string whose length runs past the end, and one without its NUL */
    b = lr_encode_rays(&bad, 3, o, d, &n);
    if (b != NULL) {
        put_be32(b + REPLY_LEN_AT, 0x40000000);
        lw_raw(&w, ray_ch, b, n);
        put_be32(b + REPLY_LEN_AT, (uint32_t)strlen(bad.reply) + 1);
        b[REPLY_LEN_AT + 4 + strlen(bad.reply)] = 'X';
        lw_raw(&w, ray_ch, b, n);
        free(b);
    }
    GOOD();
    /* Well-formed bytes with reply channels nobody can be answered on. */
    static const char *const unanswerable[] = {"bad channel", "", "TRIOCT_STATUS", "TRIOCT_RAY_yard"};
    for (size_t k = 0; k < sizeof unanswerable / sizeof unanswerable[0]; k++) {
        lr_req u = bad;
        u.id = 906 + (int64_t)k;
        u.reply = unanswerable[k];
        lr_rays(&w, &u, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 3, o, d);
        GOOD();
    }
    /* A reply where a request belongs. */
    {
        trioct_ray_reply_t m;
        memset(&m, 0, sizeof m);
        m.header.client_id = C;
        m.header.request_id = 910;
        m.header.daemon = "replayd";
        m.header.world = "yard";
        m.header.message = "ok";
        m.header.chunk_count = 1;
        int len = trioct_ray_reply_t_encoded_size(&m);
        uint8_t *rb = malloc((size_t)len);
        if (rb != NULL && trioct_ray_reply_t_encode(rb, 0, len, &m) == len)
            lw_raw(&w, ray_ch, rb, (size_t)len);
        free(rb);
    }
    /* A well-formed request for a world nobody holds: unheard. */
    bad.id = 911;
    bad.world = "nosuch";
    lr_rays(&w, &bad, CLOSEST, WORLD_ACC, 0, INFINITY, 1, 3, o, d);
    GOOD();

    /* Random bytes on every request channel, some behind the right fingerprint. */
    static const int kinds[] = {TRIOCT_CHANNEL_RAY, TRIOCT_CHANNEL_TRI, TRIOCT_CHANNEL_MESH,
                                TRIOCT_CHANNEL_ADMIN, TRIOCT_CHANNEL_LOAD, TRIOCT_CHANNEL_LIST};
    static const wire_type types[] = {WIRE_RAY_REQUEST_V1, WIRE_TRIANGLE_REQUEST, WIRE_MESH_REQUEST,
                                      WIRE_ADMIN_REQUEST, WIRE_ADMIN_REQUEST, WIRE_ADMIN_REQUEST};
    for (int k = 0; k < 18; k++) {
        int kind = k % 6;
        size_t len = 1 + (size_t)(rng_next(&r) % 300);
        uint8_t junk[304];
        for (size_t i = 0; i < len; i++)
            junk[i] = (uint8_t)rng_next(&r);
        if (k >= 6 && len >= 8) {
            uint64_t fp = (uint64_t)wire_fingerprint(types[kind]);
            for (int i = 0; i < 8; i++)
                junk[i] = (uint8_t)(fp >> (56 - 8 * i));
        }
        const char *name = kinds[kind] == TRIOCT_CHANNEL_LOAD ? LOGS_DAEMON : "yard";
        lw_raw(&w, lw_channel(kinds[kind], name), junk, len);
        if (k % 3 == 2)
            GOOD();
    }
    /* Still here, and still right. */
    good.id = ++good_id;
    lr_admin(&w, &good, TRIOCT_ADMIN_REQUEST_T_LIST, NULL);
#undef GOOD
    return lw_save(&w, dir, "hostile");
}
