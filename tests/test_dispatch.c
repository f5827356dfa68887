/* Dispatch tests: the daemon's protocol as a pure function from request bytes to reply
 * bytes, without a network. Worlds are built in-process from OBJ files written into a
 * temporary world directory; every answer is checked against the engine's own answer on
 * the same world, every reply chunk against the validator and the chunk cap, and every
 * wire status code is provoked. */
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmocka.h>

#include "channels.h"
#include "engine.h"
#include "service/dispatch.h"
#include "service/dispatch_internal.h"
#include "support/brute_force.h"
#include "support/daemon_proc.h"
#include "support/hostile_files.h"
#include "support/meshgen.h"
#include "trioct_limits.h"
#include "trioct_status.h"
#include "wire_check.h"
#include "world/mesh_load.h"
#include "world/object_state.h"
#include "world/registry.h"
#include "world/scene.h"
#include "world/world.h"

#define DAEMON "d1"
#define PREFIX "TRIOCT"
#define CLIENT_ID 7777
#define REPLY_CHANNEL "CLIENT_7777_REPLY"
#define NOW 1700000000000000LL /* the clock every request is handled at */

static uint64_t base_seed = 0x5eed2024ull;

/* ---------- fixture: a world directory, a scene, a registry ---------- */

static struct {
    char dir[64];
    scene sc;
    registry *reg;
    dispatch_ctx ctx;
    int64_t next_request;
    trioct_admin_key key; /* the daemon's; ask_at signs every admin and object request */
    int unsigned_changes; /* 1: ask_at sends them as they are */
} F;

static void write_obj(const char *name, const mesh_data *m)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", F.dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    for (size_t i = 0; i < m->vertex_count; i++)
        fprintf(f, "v %.17g %.17g %.17g\n", m->vertices[i].x, m->vertices[i].y, m->vertices[i].z);
    for (size_t t = 0; t < m->triangle_count; t++)
        fprintf(f, "f %u %u %u\n", m->indices[3 * t] + 1, m->indices[3 * t + 1] + 1, m->indices[3 * t + 2] + 1);
    assert_int_equal(fclose(f), 0);
}

static void write_text(const char *name, const char *text)
{
    char path[256];
    snprintf(path, sizeof path, "%s/%s", F.dir, name);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    assert_int_equal(fclose(f), 0);
}

/* LAYERS parallel squares z = 0.5, 1.5, ... over [-1, 1]^2: a vertical ray through them
 * crosses exactly LAYERS triangles, so ALL replies are large and their size is known. */
#define LAYERS 60
static mesh_data layers_mesh(int layers)
{
    mesh_data m = {0};
    m.vertex_count = 4 * (size_t)layers;
    m.triangle_count = 2 * (size_t)layers;
    m.vertices = calloc(m.vertex_count, sizeof *m.vertices);
    m.indices = calloc(3 * m.triangle_count, sizeof *m.indices);
    for (int k = 0; k < layers; k++) {
        double z = 0.5 + k;
        vec3 *v = &m.vertices[4 * k];
        v[0] = (vec3){-1, -1, z};
        v[1] = (vec3){1, -1, z};
        v[2] = (vec3){1, 1, z};
        v[3] = (vec3){-1, 1, z};
        uint32_t b = (uint32_t)(4 * k);
        uint32_t *ix = &m.indices[6 * k];
        ix[0] = b, ix[1] = b + 1, ix[2] = b + 2;
        ix[3] = b, ix[4] = b + 2, ix[5] = b + 3;
    }
    return m;
}

static void install_from_scene(const char *name)
{
    const world_spec *spec = scene_find(&F.sc, name);
    assert_non_null(spec);
    int status = -1;
    char err[512];
    world *w = world_build(spec, F.dir, NULL, &status, err, sizeof err);
    if (!w)
        fail_msg("building %s: %s", name, err);
    assert_int_equal(registry_install(F.reg, w), 0);
}

static int setup(void **state)
{
    (void)state;
    strcpy(F.dir, "/tmp/trioct-dispatch-XXXXXX");
    assert_non_null(mkdtemp(F.dir));

    mesh_data sphere = meshgen_icosphere((vec3){0, 0, 0}, 1.0, 3);
    mesh_data cube = meshgen_box((box3){{-0.2, -0.2, -0.2}, {0.2, 0.2, 0.2}});
    mesh_data box = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    /* Flat (z = 0) so a coplanar query triangle touches every terrain triangle it covers. */
    mesh_data flat = meshgen_terrain(11, (box3){{-10, -10, 0}, {10, 10, 0}}, 80, 80);
    mesh_data layers = layers_mesh(LAYERS);
    write_obj("sphere.obj", &sphere);
    write_obj("cube.obj", &cube);
    write_obj("box.obj", &box);
    write_obj("flat.obj", &flat);
    write_obj("layers.obj", &layers);
    write_text("garbage.obj", "this is not a mesh\nf 1 2\n");
    mesh_data_free(&sphere);
    mesh_data_free(&cube);
    mesh_data_free(&box);
    mesh_data_free(&flat);
    mesh_data_free(&layers);

    write_text("scene.ini", "[daemon]\nprefix = TRIOCT\n\n"
                            "[sphere]\nmesh = sphere.obj\neffects = rays triangles meshes\nshape.cube = cube.obj\n\n"
                            "[raysonly]\nmesh = sphere.obj\neffects = rays\n\n"
                            "[flat]\nmesh = flat.obj\neffects = triangles meshes\nshape.cube = cube.obj\n\n"
                            "[layers]\nmesh = layers.obj\neffects = rays\n\n"
                            "[spare]\nmesh = box.obj\naccuracy = fast\neffects = rays\n\n"
                            "[edited]\nmesh = box.obj\neffects = rays triangles meshes\nshape.cube = cube.obj\n\n"
                            "[near]\nmesh = box.obj\neffects = distance\nshape.cube = cube.obj\n\n"
                            "[pair]\nobject.a = box.obj\nobject.b = box.obj\npose.b = 5 0 0 1 0 0 0\neffects = distance\n");
    char path[256], err[512];
    snprintf(path, sizeof path, "%s/scene.ini", F.dir);
    if (scene_load(path, &F.sc, err, sizeof err) != 0)
        fail_msg("scene: %s", err);

    F.reg = registry_create();
    assert_non_null(F.reg);
    install_from_scene("sphere");
    install_from_scene("raysonly");
    install_from_scene("flat");
    install_from_scene("layers");

    F.ctx.worlds = F.reg;
    strcpy(F.ctx.prefix, PREFIX);
    strcpy(F.ctx.daemon, DAEMON);
    strcpy(F.ctx.world_dir, F.dir);
    pthread_mutex_init(&F.ctx.scene_lock, NULL);
    F.ctx.scene = &F.sc;
    F.next_request = 1;
    F.key.len = 32;
    for (size_t i = 0; i < F.key.len; i++)
        F.key.bytes[i] = (unsigned char)(7 * i + 1);
    F.ctx.auth = admin_auth_create(&F.key, 1);
    assert_non_null(F.ctx.auth);
    return 0;
}

static int teardown(void **state)
{
    (void)state;
    registry_free(F.reg);
    scene_free(&F.sc);
    pthread_mutex_destroy(&F.ctx.scene_lock);
    admin_auth_free(F.ctx.auth);
    const char *files[] = {"sphere.obj", "cube.obj", "box.obj", "flat.obj", "layers.obj", "garbage.obj", "scene.ini"};
    char path[256];
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++) {
        snprintf(path, sizeof path, "%s/%s", F.dir, files[i]);
        unlink(path);
    }
    rmdir(F.dir);
    return 0;
}

/* ---------- requests ---------- */

typedef struct msg {
    uint8_t *data;
    size_t size;
} msg;

#define DEFINE_ENCODER(type)                                      \
    static msg encode_##type(const type *p)                       \
    {                                                             \
        int n = type##_encoded_size(p);                           \
        msg m = {malloc((size_t)n), (size_t)n};                   \
        assert_int_equal(type##_encode(m.data, 0, n, p), n);      \
        return m;                                                 \
    }
DEFINE_ENCODER(trioct_ray_request_t)
DEFINE_ENCODER(trioct_ray_request_v1_t)
DEFINE_ENCODER(trioct_triangle_request_t)
DEFINE_ENCODER(trioct_mesh_request_t)
DEFINE_ENCODER(trioct_admin_request_t)
DEFINE_ENCODER(trioct_object_edit_request_t)
#define ENCODE(type, ptr) encode_##type(ptr)

static const char *channel_of(trioct_channel_kind kind, const char *name)
{
    static char buf[8][TRIOCT_MAX_CHANNEL_LEN + 1];
    static int next;
    char *out = buf[next++ % 8];
    assert_int_equal(trioct_channel_name(out, PREFIX, kind, name), 0);
    return out;
}

static trioct_request_header_t header(const char *world)
{
    return (trioct_request_header_t){
        .client_id = CLIENT_ID,
        .request_id = F.next_request++,
        .reply_channel = REPLY_CHANNEL,
        .world = (char *)world,
        .deadline_utime = 0,
    };
}

typedef struct ray_set {
    int n;
    trioct_vec3_t *origin, *direction;
} ray_set;

static trioct_ray_request_t ray_request(const char *world, const ray_set *rays, int8_t detail, int8_t accuracy,
                                        double tmin, double tmax, int32_t max_hits)
{
    return (trioct_ray_request_t){
        .header = header(world),
        .detail = detail,
        .accuracy = accuracy,
        .tmin = tmin,
        .tmax = tmax,
        .max_hits = max_hits,
        .num_rays = rays->n,
        .origin = rays->origin,
        .direction = rays->direction,
    };
}

static void ray_set_free(ray_set *r)
{
    free(r->origin);
    free(r->direction);
}

static trioct_vec3_t tv(vec3 v)
{
    return (trioct_vec3_t){v.x, v.y, v.z};
}

static vec3 vv(trioct_vec3_t v)
{
    return (vec3){v.x, v.y, v.z};
}

/* Rays from points around the unit sphere towards points near it: some hit, some miss. */
static ray_set sphere_rays(rng *r, int n)
{
    ray_set s = {n, calloc((size_t)n, sizeof(trioct_vec3_t)), calloc((size_t)n, sizeof(trioct_vec3_t))};
    for (int i = 0; i < n; i++) {
        vec3 o = vec3_scale(rng_unit_vector(r), rng_uniform(r, 2.0, 4.0));
        vec3 target = vec3_scale(rng_unit_vector(r), rng_uniform(r, 0.0, 1.5));
        s.origin[i] = tv(o);
        s.direction[i] = tv(vec3_sub(target, o));
    }
    return s;
}

/* Vertical rays, each from its own point (a scattered batch): every `every`-th goes through
 * all the layers, the others pass beside them. Uneven batches make a few rays need more
 * room than their share of the reply, which the dispatcher must give them. */
static ray_set layer_rays(rng *r, int n, int every)
{
    ray_set s = {n, calloc((size_t)n, sizeof(trioct_vec3_t)), calloc((size_t)n, sizeof(trioct_vec3_t))};
    for (int i = 0; i < n; i++) {
        double x = i % every == 0 ? rng_uniform(r, -0.9, 0.9) : rng_uniform(r, 1.5, 2.0);
        s.origin[i] = (trioct_vec3_t){x, rng_uniform(r, -0.9, 0.9), -1.0};
        s.direction[i] = (trioct_vec3_t){0, 0, 1};
    }
    return s;
}

/* ---------- replies ---------- */

/* A whole reply, reassembled from its chunks after each passed the validator and the cap. */
typedef struct answer {
    int status;
    request_type type;
    size_t chunks;
    int worlds_changed;
    char message[TRIOCT_MAX_MESSAGE_LEN + 1];
    char world[TRIOCT_MAX_NAME_LEN + 1];
    int64_t version;
    int8_t detail;
    int32_t num_found;
    int32_t *found;
    size_t records;
    trioct_ray_hit_t *hits;
    trioct_contact_t *contacts;
    trioct_segment_t *segments;
    trioct_mesh_pair_t *pairs;
    size_t num_worlds;
    trioct_world_info_t *worlds; /* deep copies */
    int32_t num_names;           /* query replies: chunk 0's object names */
    char names[64][TRIOCT_MAX_NAME_LEN + 1];
    int32_t failed_edit;         /* object replies */
    int64_t objects;
    trioct_object_info_t *listed; /* deep copies */
} answer;

static void answer_free(answer *a)
{
    free(a->found);
    free(a->hits);
    free(a->contacts);
    free(a->segments);
    free(a->pairs);
    if (a->worlds)
        __trioct_world_info_t_decode_array_cleanup(a->worlds, (int)a->num_worlds);
    free(a->worlds);
    if (a->listed)
        __trioct_object_info_t_decode_array_cleanup(a->listed, (int)a->num_worlds);
    free(a->listed);
    memset(a, 0, sizeof *a);
}

static void grow(void **p, size_t *have, size_t add, size_t elem, const void *src)
{
    if (add == 0)
        return;
    *p = realloc(*p, (*have + add) * elem + 1);
    assert_non_null(*p);
    memcpy((char *)*p + *have * elem, src, add * elem);
    *have += add;
}

/* Checks one chunk's header against the request and the chunk before it. */
static void check_head(const trioct_reply_header_t *h, answer *a, int64_t request_id, size_t index, size_t count)
{
    assert_int_equal(h->client_id, CLIENT_ID);
    assert_int_equal(h->request_id, request_id);
    assert_string_equal(h->daemon, DAEMON);
    assert_int_equal(h->chunk_index, (int32_t)index);
    assert_int_equal(h->chunk_count, (int32_t)count);
    assert_int_equal(h->status, a->status);
    assert_true(strlen(h->message) > 0 && strlen(h->message) <= TRIOCT_MAX_MESSAGE_LEN);
    if (index == 0) {
        strcpy(a->message, h->message);
        assert_true(strlen(h->world) <= TRIOCT_MAX_NAME_LEN);
        strcpy(a->world, h->world);
        a->version = h->world_version;
    } else {
        assert_string_equal(h->message, a->message);
        assert_string_equal(h->world, a->world);
        assert_int_equal(h->world_version, a->version);
    }
    if (a->status == TRIOCT_OK)
        assert_string_equal(h->message, "ok");
    else
        assert_int_equal(count, 1); /* error replies are one chunk */
}

static const wire_type reply_wire[REQUEST_TYPE_COUNT] = {
    [REQUEST_RAY] = WIRE_RAY_REPLY,
    [REQUEST_TRIANGLE] = WIRE_TRIANGLE_REPLY,
    [REQUEST_MESH] = WIRE_MESH_REPLY,
    [REQUEST_ADMIN] = WIRE_ADMIN_REPLY,
    [REQUEST_OBJECTS] = WIRE_OBJECT_REPLY,
    [REQUEST_STATE] = WIRE_STATE_REPLY,
    [REQUEST_DISTANCE] = WIRE_DISTANCE_REPLY,
};

static void keep_names(answer *a, int32_t count, char **names)
{
    assert_true(count >= 0 && count <= 64);
    a->num_names = count;
    for (int32_t k = 0; k < count; k++)
        snprintf(a->names[k], sizeof a->names[k], "%s", names[k]);
}

static void collect_chunk(answer *a, const dispatch_chunk *c, int64_t request_id, size_t index, size_t count)
{
    int len = (int)c->size;
    switch (a->type) {
    case REQUEST_RAY: {
        trioct_ray_reply_t m;
        assert_int_equal(trioct_ray_reply_t_decode(c->data, 0, len, &m), len);
        check_head(&m.header, a, request_id, index, count);
        if (index == 0) {
            a->detail = m.detail;
            a->num_found = m.num_rays;
            keep_names(a, m.num_objects, m.objects);
            a->found = calloc((size_t)m.num_rays + 1, sizeof *a->found);
            if (m.num_rays > 0)
                memcpy(a->found, m.found, (size_t)m.num_rays * sizeof *a->found);
        } else {
            assert_int_equal(m.num_rays, 0);
            assert_int_equal(m.detail, a->detail);
        }
        size_t have = a->records;
        grow((void **)&a->hits, &have, (size_t)m.num_hits, sizeof *a->hits, m.hits);
        a->records = have;
        trioct_ray_reply_t_decode_cleanup(&m);
        break;
    }
    case REQUEST_TRIANGLE: {
        trioct_triangle_reply_t m;
        assert_int_equal(trioct_triangle_reply_t_decode(c->data, 0, len, &m), len);
        check_head(&m.header, a, request_id, index, count);
        if (index == 0) {
            a->detail = m.detail;
            a->num_found = m.num_triangles;
            keep_names(a, m.num_objects, m.objects);
            a->found = calloc((size_t)m.num_triangles + 1, sizeof *a->found);
            if (m.num_triangles > 0)
                memcpy(a->found, m.found, (size_t)m.num_triangles * sizeof *a->found);
        } else {
            assert_int_equal(m.num_triangles, 0);
        }
        /* SEGMENTS: one segment per contact in every chunk; otherwise none. */
        if (m.detail == TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS)
            assert_int_equal(m.num_segments, m.num_contacts);
        else
            assert_int_equal(m.num_segments, 0);
        size_t have = a->records, have2 = a->records;
        grow((void **)&a->contacts, &have, (size_t)m.num_contacts, sizeof *a->contacts, m.contacts);
        grow((void **)&a->segments, &have2, (size_t)m.num_segments, sizeof *a->segments, m.segments);
        a->records = have;
        trioct_triangle_reply_t_decode_cleanup(&m);
        break;
    }
    case REQUEST_MESH: {
        trioct_mesh_reply_t m;
        assert_int_equal(trioct_mesh_reply_t_decode(c->data, 0, len, &m), len);
        check_head(&m.header, a, request_id, index, count);
        if (index == 0) {
            a->detail = m.detail;
            a->num_found = m.num_poses;
            keep_names(a, m.num_objects, m.objects);
            a->found = calloc((size_t)m.num_poses + 1, sizeof *a->found);
            if (m.num_poses > 0)
                memcpy(a->found, m.found, (size_t)m.num_poses * sizeof *a->found);
        } else {
            assert_int_equal(m.num_poses, 0);
        }
        size_t have = a->records;
        grow((void **)&a->pairs, &have, (size_t)m.num_pairs, sizeof *a->pairs, m.pairs);
        a->records = have;
        trioct_mesh_reply_t_decode_cleanup(&m);
        break;
    }
    case REQUEST_OBJECTS: {
        trioct_object_reply_t m;
        assert_int_equal(trioct_object_reply_t_decode(c->data, 0, len, &m), len);
        check_head(&m.header, a, request_id, index, count);
        a->failed_edit = m.failed_edit;
        a->objects = m.objects;
        /* The listing is kept in num_worlds' count: both are "records of their own size". */
        a->listed = realloc(a->listed, (a->num_worlds + (size_t)m.num_objects + 1) * sizeof *a->listed);
        assert_non_null(a->listed);
        assert_int_equal(__trioct_object_info_t_clone_array(m.list, &a->listed[a->num_worlds], m.num_objects), 0);
        a->num_worlds += (size_t)m.num_objects;
        trioct_object_reply_t_decode_cleanup(&m);
        break;
    }
    default: {
        trioct_admin_reply_t m;
        assert_int_equal(trioct_admin_reply_t_decode(c->data, 0, len, &m), len);
        check_head(&m.header, a, request_id, index, count);
        if (index == 0)
            a->detail = m.op;
        else
            assert_int_equal(m.op, a->detail);
        a->worlds = realloc(a->worlds, (a->num_worlds + (size_t)m.num_worlds + 1) * sizeof *a->worlds);
        assert_non_null(a->worlds);
        /* Deep copies, so the chunk's decoded struct can go. */
        assert_int_equal(__trioct_world_info_t_clone_array(m.worlds, &a->worlds[a->num_worlds], m.num_worlds), 0);
        a->num_worlds += (size_t)m.num_worlds;
        trioct_admin_reply_t_decode_cleanup(&m);
        break;
    }
    }
}

/* Every chunk: under the cap, accepted by the validator of its reply type, decoded. */
static answer read_reply(dispatch_reply *rep, request_type type, int64_t request_id)
{
    answer a = {0};
    a.status = rep->status;
    a.type = type;
    a.chunks = rep->chunk_count;
    a.worlds_changed = rep->worlds_changed;
    assert_int_equal(rep->type, type);
    assert_string_equal(rep->channel, REPLY_CHANNEL);
    assert_true(rep->chunk_count >= 1);
    for (size_t i = 0; i < rep->chunk_count; i++) {
        const dispatch_chunk *c = &rep->chunks[i];
        assert_true(c->size <= TRIOCT_MAX_CHUNK_BYTES);
        wire_error err;
        if (wire_check(reply_wire[type], c->data, c->size, &err) != 0)
            fail_msg("chunk %zu of %zu: %s", i, rep->chunk_count, err.what);
        collect_chunk(&a, c, request_id, i, rep->chunk_count);
    }
    if (a.status != TRIOCT_OK)
        assert_int_equal(a.records + a.num_found + a.num_worlds, 0);
    return a;
}

/* The request id of an encoded request, read back with the generated decoder (the tests'
 * own bytes are trusted). */
static int64_t request_id_of(const msg *m)
{
    trioct_request_header_t h;
    assert_true(__trioct_request_header_t_decode_array(m->data, 8, (int)m->size - 8, &h, 1) > 0);
    int64_t id = h.request_id;
    __trioct_request_header_t_decode_array_cleanup(&h, 1);
    return id;
}

static answer ask_at(const char *channel, msg m, request_type type, int64_t now)
{
    if ((type == REQUEST_ADMIN || type == REQUEST_OBJECTS) && !F.unsigned_changes)
        trioct_admin_sign(&F.key, channel, m.data, m.size, now);
    dispatch_reply rep;
    assert_int_equal(dispatch_handle(&F.ctx, channel, m.data, m.size, now, &rep), 0);
    answer a = read_reply(&rep, type, request_id_of(&m));
    dispatch_reply_free(&rep);
    free(m.data);
    return a;
}

static answer ask(const char *channel, msg m, request_type type)
{
    return ask_at(channel, m, type, NOW);
}

static answer ask_ray(const char *world, const trioct_ray_request_t *r)
{
    return ask(channel_of(TRIOCT_CHANNEL_RAY, world), ENCODE(trioct_ray_request_t, r), REQUEST_RAY);
}

static answer ask_triangle(const char *world, const trioct_triangle_request_t *r)
{
    return ask(channel_of(TRIOCT_CHANNEL_TRI, world), ENCODE(trioct_triangle_request_t, r), REQUEST_TRIANGLE);
}

static answer ask_mesh(const char *world, const trioct_mesh_request_t *r)
{
    return ask(channel_of(TRIOCT_CHANNEL_MESH, world), ENCODE(trioct_mesh_request_t, r), REQUEST_MESH);
}

static answer ask_objects(const char *world, int list, int n, const trioct_object_edit_t *edits)
{
    trioct_object_edit_request_t r = {header(world), (int8_t)list, n, (trioct_object_edit_t *)edits, {0}};
    return ask(channel_of(TRIOCT_CHANNEL_OBJECTS, world), ENCODE(trioct_object_edit_request_t, &r), REQUEST_OBJECTS);
}

static trioct_object_edit_t wire_edit(int8_t op, const char *name, const char *mesh, trioct_pose_t at)
{
    return (trioct_object_edit_t){op, (char *)name, (char *)(mesh ? mesh : ""), at, TRIOCT_OBJECT_EDIT_T_MATRIX, {0},
                                  0, NULL};
}

static trioct_admin_request_t admin_request(const char *world, int8_t op)
{
    return (trioct_admin_request_t){
        .header = header(world),
        .op = op,
        .mesh_path = "",
        .resolution = 0,
        .accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD,
        .seed_epsilon = 0,
        .effects = 0,
        .auth = {0},
    };
}

static answer ask_admin(trioct_channel_kind kind, const char *name, const trioct_admin_request_t *r)
{
    return ask(channel_of(kind, name), ENCODE(trioct_admin_request_t, r), REQUEST_ADMIN);
}

static answer admin_op(const char *world, int8_t op)
{
    trioct_admin_request_t r = admin_request(world, op);
    trioct_channel_kind kind = op == TRIOCT_ADMIN_REQUEST_T_LIST   ? TRIOCT_CHANNEL_LIST
                               : op == TRIOCT_ADMIN_REQUEST_T_LOAD ? TRIOCT_CHANNEL_LOAD
                                                                   : TRIOCT_CHANNEL_ADMIN;
    return ask_admin(kind, kind == TRIOCT_CHANNEL_LOAD ? DAEMON : world, &r);
}

static answer load_path(const char *world, const char *path, double resolution, int8_t accuracy, int32_t effects)
{
    trioct_admin_request_t r = admin_request(world, TRIOCT_ADMIN_REQUEST_T_LOAD);
    r.mesh_path = (char *)path;
    r.resolution = resolution;
    r.accuracy = accuracy;
    r.effects = effects;
    return ask_admin(TRIOCT_CHANNEL_LOAD, DAEMON, &r);
}

static void expect_error(const answer *a, int status, const char *needle)
{
    if (a->status != status)
        fail_msg("status %d (%s) \"%s\", expected %d (%s)", a->status, trioct_status_name(a->status), a->message,
                 status, trioct_status_name(status));
    assert_int_equal(a->chunks, 1);
    if (needle && !strstr(a->message, needle))
        fail_msg("message \"%s\" does not say \"%s\"", a->message, needle);
}

static world *held(const char *name)
{
    world *w = registry_acquire(F.reg, name);
    assert_non_null(w);
    return w;
}

/* ---------- the engine's own answers ---------- */

/* The reply must be the engine's answer for every ray, in order, bit for bit. Returns how
 * many rays hit, so callers can insist the case was not trivial. */
static size_t expect_rays(const answer *a, const char *world_name, const ray_set *rays, ray_detail detail,
                          accuracy_mode mode, double tmin, double tmax, size_t max_hits)
{
    if (a->status != TRIOCT_OK)
        fail_msg("status %s: %s", trioct_status_name(a->status), a->message);
    world *w = held(world_name);
    assert_int_equal(a->version, (int64_t)w->version);
    assert_int_equal(a->num_found, rays->n);
    size_t cap = detail == RAY_ALL ? max_hits : 1;
    ray_hit *buf = calloc(cap, sizeof *buf);
    size_t r = 0, hitting = 0;
    for (int i = 0; i < rays->n; i++) {
        ray_input in = {vv(rays->origin[i]), vv(rays->direction[i]), tmin, tmax, RAY_CROSSING};
        ray_output out = {.hits = buf, .max_hits = cap};
        assert_int_equal(octree_ray(w->tree, &in, detail, mode, &out, NULL), OCTREE_OK);
        assert_int_equal(a->found[i], (int32_t)out.hit_count);
        hitting += out.hit_count > 0;
        size_t keep = out.hit_count < cap ? out.hit_count : cap;
        for (size_t k = 0; k < keep; k++, r++) {
            assert_true(r < a->records);
            const trioct_ray_hit_t *h = &a->hits[r];
            assert_int_equal(h->ray, i);
            assert_int_equal(h->triangle, (int32_t)buf[k].triangle);
            assert_true(h->t == buf[k].t && h->u == buf[k].u && h->v == buf[k].v);
            assert_true(h->normal.x == buf[k].normal.x && h->normal.y == buf[k].normal.y &&
                        h->normal.z == buf[k].normal.z);
        }
    }
    assert_int_equal(r, a->records);
    free(buf);
    world_release(w);
    return hitting;
}

static size_t expect_triangles(const answer *a, const char *world_name, const trioct_triangle_t *tris, int n,
                               tri_detail detail, accuracy_mode mode)
{
    if (a->status != TRIOCT_OK)
        fail_msg("status %s: %s", trioct_status_name(a->status), a->message);
    world *w = held(world_name);
    assert_int_equal(a->num_found, n);
    size_t cap = 20000;
    tri_contact *buf = calloc(cap, sizeof *buf);
    size_t r = 0, touching = 0;
    for (int i = 0; i < n; i++) {
        vec3 q[3] = {vv(tris[i].a), vv(tris[i].b), vv(tris[i].c)};
        tri_output out = {.contacts = buf, .capacity = cap};
        assert_int_equal(octree_triangle(w->tree, q, detail, mode, &out, NULL), OCTREE_OK);
        assert_false(out.truncated);
        touching += out.hit != 0;
        if (detail == TRI_YESNO) {
            assert_int_equal(a->found[i], out.hit != 0);
            continue;
        }
        assert_int_equal(a->found[i], (int32_t)out.count);
        for (size_t k = 0; k < out.count; k++, r++) {
            assert_true(r < a->records);
            assert_int_equal(a->contacts[r].query, i);
            assert_int_equal(a->contacts[r].triangle, (int32_t)buf[k].triangle);
            if (detail == TRI_SEGMENTS) {
                const trioct_segment_t *s = &a->segments[r];
                assert_true(s->p.x == buf[k].p.x && s->p.y == buf[k].p.y && s->p.z == buf[k].p.z);
                assert_true(s->q.x == buf[k].q.x && s->q.y == buf[k].q.y && s->q.z == buf[k].q.z);
            }
        }
    }
    assert_int_equal(r, a->records);
    free(buf);
    world_release(w);
    return touching;
}

static size_t expect_mesh(const answer *a, const char *world_name, const mesh_view *shape, const trioct_pose_t *poses,
                          int n, int all_pairs, accuracy_mode mode)
{
    if (a->status != TRIOCT_OK)
        fail_msg("status %s: %s", trioct_status_name(a->status), a->message);
    world *w = held(world_name);
    assert_int_equal(a->num_found, n);
    size_t cap = 70000;
    mesh_pair *buf = calloc(cap, sizeof *buf);
    size_t r = 0, touching = 0;
    for (int i = 0; i < n; i++) {
        pose p;
        memcpy(p.r, poses[i].r, sizeof p.r);
        p.t = vv(poses[i].t);
        mesh_output out = {.pairs = buf, .capacity = cap};
        assert_int_equal(octree_mesh(w->tree, shape, &p, all_pairs, mode, &out, NULL), OCTREE_OK);
        assert_false(out.truncated);
        touching += out.hit != 0;
        if (!all_pairs) {
            assert_int_equal(a->found[i], out.hit != 0);
            continue;
        }
        assert_int_equal(a->found[i], (int32_t)out.count);
        for (size_t k = 0; k < out.count; k++, r++) {
            assert_true(r < a->records);
            assert_int_equal(a->pairs[r].pose, i);
            assert_int_equal(a->pairs[r].shape_triangle, (int32_t)buf[k].query_triangle);
            assert_int_equal(a->pairs[r].world_triangle, (int32_t)buf[k].world_triangle);
        }
    }
    assert_int_equal(r, a->records);
    free(buf);
    world_release(w);
    return touching;
}

static trioct_pose_t pose_at(double angle, vec3 t)
{
    double c = cos(angle), s = sin(angle);
    return (trioct_pose_t){{c, -s, 0, s, c, 0, 0, 0, 1}, tv(t)};
}

/* ---------- peek and hostile bytes ---------- */

static void expect_dropped(const char *channel, const void *bytes, size_t size, dispatch_peek_result want)
{
    dispatch_request req;
    assert_int_equal(dispatch_peek(&F.ctx, channel, bytes, size, &req), want);
    dispatch_reply rep;
    assert_int_equal(dispatch_handle(&F.ctx, channel, bytes, size, NOW, &rep), -1);
    assert_int_equal(rep.chunk_count, 0);
    assert_null(rep.chunks);
}

static void test_peek_reads_the_header(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed);
    ray_set rays = sphere_rays(&r, 3);
    trioct_ray_request_t q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    q.header.deadline_utime = NOW + 5;
    msg m = ENCODE(trioct_ray_request_t, &q);
    dispatch_request req;
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_RAY, "sphere"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_int_equal(req.type, REQUEST_RAY);
    assert_int_equal(req.channel_kind, TRIOCT_CHANNEL_RAY);
    assert_string_equal(req.channel_name, "sphere");
    assert_int_equal(req.client_id, CLIENT_ID);
    assert_int_equal(req.request_id, q.header.request_id);
    assert_string_equal(req.reply_channel, REPLY_CHANNEL);
    assert_string_equal(req.world, "sphere");
    assert_int_equal(req.deadline_utime, NOW + 5);
    assert_int_equal(req.detail, TRIOCT_RAY_REQUEST_T_CLOSEST);
    free(m.data);

    /* LOAD on this daemon's channel and LIST are admin requests with their op. */
    trioct_admin_request_t a = admin_request("newworld", TRIOCT_ADMIN_REQUEST_T_LOAD);
    m = ENCODE(trioct_admin_request_t, &a);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_LOAD, DAEMON), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_int_equal(req.type, REQUEST_ADMIN);
    assert_int_equal(req.admin_op, TRIOCT_ADMIN_REQUEST_T_LOAD);
    assert_string_equal(req.channel_name, DAEMON);
    /* ... but not on another daemon's, nor on a status or unknown channel. */
    expect_dropped(channel_of(TRIOCT_CHANNEL_LOAD, "d2"), m.data, m.size, PEEK_NOT_MINE);
    expect_dropped(channel_of(TRIOCT_CHANNEL_STATUS, NULL), m.data, m.size, PEEK_NOT_MINE);
    expect_dropped("TRIOCT_FOO_sphere", m.data, m.size, PEEK_NOT_MINE);
    expect_dropped("OTHER_LOAD_d1", m.data, m.size, PEEK_NOT_MINE);
    free(m.data);
    ray_set_free(&rays);
}

static void test_hostile_bytes_are_dropped(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 1);
    ray_set rays = sphere_rays(&r, 4);
    trioct_ray_request_t q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    msg m = ENCODE(trioct_ray_request_t, &q);
    const char *ray_channel = channel_of(TRIOCT_CHANNEL_RAY, "sphere");

    /* Every truncation. */
    for (size_t len = 0; len < m.size; len++)
        expect_dropped(ray_channel, m.data, len, PEEK_MALFORMED);
    /* A byte too many. */
    uint8_t *longer = calloc(m.size + 1, 1);
    memcpy(longer, m.data, m.size);
    expect_dropped(ray_channel, longer, m.size + 1, PEEK_MALFORMED);
    free(longer);
    /* Wrong fingerprint. */
    m.data[3] ^= 0x40;
    expect_dropped(ray_channel, m.data, m.size, PEEK_MALFORMED);
    m.data[3] ^= 0x40;
    /* Negative and huge counts: num_rays sits just before the two arrays. */
    size_t count_at = m.size - 2 * 24 * (size_t)rays.n - 4;
    const uint8_t negative[4] = {0xff, 0xff, 0xff, 0xfb}, huge[4] = {0x7f, 0xff, 0xff, 0xff};
    uint8_t saved[4];
    memcpy(saved, &m.data[count_at], 4);
    memcpy(&m.data[count_at], negative, 4);
    expect_dropped(ray_channel, m.data, m.size, PEEK_MALFORMED);
    memcpy(&m.data[count_at], huge, 4);
    expect_dropped(ray_channel, m.data, m.size, PEEK_MALFORMED);
    memcpy(&m.data[count_at], saved, 4);
    /* The untouched message is fine, so the cases above failed for their one change. */
    dispatch_request req;
    assert_int_equal(dispatch_peek(&F.ctx, ray_channel, m.data, m.size, &req), PEEK_REQUEST);

    /* Garbage after a valid fingerprint. */
    uint8_t garbage[300];
    memcpy(garbage, m.data, 8);
    for (size_t i = 8; i < sizeof garbage; i++)
        garbage[i] = (uint8_t)rng_next(&r);
    expect_dropped(ray_channel, garbage, sizeof garbage, PEEK_MALFORMED);
    expect_dropped(ray_channel, NULL, 0, PEEK_MALFORMED);

    /* The right bytes on the wrong channel: a ray request is not a triangle or admin one. */
    expect_dropped(channel_of(TRIOCT_CHANNEL_TRI, "sphere"), m.data, m.size, PEEK_MALFORMED);
    expect_dropped(channel_of(TRIOCT_CHANNEL_ADMIN, "sphere"), m.data, m.size, PEEK_MALFORMED);
    expect_dropped(channel_of(TRIOCT_CHANNEL_LIST, NULL), m.data, m.size, PEEK_MALFORMED);
    free(m.data);

    /* Reply channels that cannot be answered. */
    const char *bad_replies[] = {"", "has space", "semi;colon", "TRIOCT_RAY_sphere", "TRIOCT_LIST",
                                 "A234567890123456789012345678901234567890123456789012345678901234"};
    for (size_t i = 0; i < sizeof bad_replies / sizeof bad_replies[0]; i++) {
        q.header.reply_channel = (char *)bad_replies[i];
        m = ENCODE(trioct_ray_request_t, &q);
        expect_dropped(ray_channel, m.data, m.size, PEEK_MALFORMED);
        free(m.data);
    }
    /* 63 characters is still a channel. */
    q.header.reply_channel = "A23456789012345678901234567890123456789012345678901234567890123";
    m = ENCODE(trioct_ray_request_t, &q);
    assert_int_equal(dispatch_peek(&F.ctx, ray_channel, m.data, m.size, &req), PEEK_REQUEST);
    free(m.data);
    ray_set_free(&rays);
}

/* ---------- rays ---------- */

/* ---------- the contact rule over the wire ---------- */

/* Over `spare` (the unit box, a fast world): a ray sliding along the top, one grazing the
 * corner (0, 1, 1) and one straight through. The old request type and CROSSING see the
 * first two clear; TOUCH sees all three blocked, at the engine's touch answer; touch with
 * seed accuracy and an unknown contact are refused. */
static void test_touch_requests_get_touch_answers(void **state)
{
    (void)state;
    install_from_scene("spare");
    trioct_vec3_t o[3] = {{-1, 0.5, 1}, {-0.5, 0.5, 1}, {-1, 0.375, 0.625}};
    trioct_vec3_t d[3] = {{1, 0, 0}, {1, 1, 0}, {1, 0, 0}};
    ray_set rays = {3, o, d};
    trioct_ray_request_t q = ray_request("spare", &rays, TRIOCT_RAY_REQUEST_T_ANY, TRIOCT_RAY_REQUEST_T_EXACT, 0,
                                         INFINITY, 0);
    trioct_ray_request_v1_t old = {
        .header = q.header,
        .detail = q.detail,
        .accuracy = q.accuracy,
        .tmin = q.tmin,
        .tmax = q.tmax,
        .num_rays = 3,
        .origin = o,
        .direction = d,
    };
    answer a = ask(channel_of(TRIOCT_CHANNEL_RAY, "spare"), ENCODE(trioct_ray_request_v1_t, &old), REQUEST_RAY);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.num_found, 3);
    const int32_t crossing_any[3] = {0, 0, 1};
    assert_memory_equal(a.found, crossing_any, sizeof crossing_any);
    answer_free(&a);

    q.contact = TRIOCT_RAY_REQUEST_T_CROSSING;
    a = ask_ray("spare", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_memory_equal(a.found, crossing_any, sizeof crossing_any);
    answer_free(&a);

    q.contact = TRIOCT_RAY_REQUEST_T_TOUCH;
    q.accuracy = TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD; /* a fast world: touch runs exact */
    a = ask_ray("spare", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    const int32_t touch_any[3] = {1, 1, 1};
    assert_memory_equal(a.found, touch_any, sizeof touch_any);
    answer_free(&a);

    /* CLOSEST: the engine's touch answers on the same mesh, t = 1, 0.5 and 1. */
    q.detail = TRIOCT_RAY_REQUEST_T_CLOSEST;
    a = ask_ray("spare", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.records, 3);
    char path[512], err[256];
    snprintf(path, sizeof path, "%s/box.obj", F.dir);
    mesh_data mesh;
    assert_int_equal(mesh_load_file(path, &mesh, NULL, err, sizeof err), 0);
    mesh_view view = mesh_data_view(&mesh);
    const double first_t[3] = {1, 0.5, 1};
    for (int i = 0; i < 3; i++) {
        ray_input in = {vv(o[i]), vv(d[i]), 0, INFINITY, RAY_TOUCH};
        ray_hit h;
        assert_int_equal(brute_ray(&view, &in, RAY_CLOSEST, ACCURACY_EXACT, 0, &h, 1), 1);
        assert_int_equal(a.hits[i].ray, i);
        assert_int_equal(a.hits[i].triangle, (int32_t)h.triangle);
        assert_true(a.hits[i].t == first_t[i] && h.t == first_t[i]);
    }
    mesh_data_free(&mesh);
    answer_free(&a);

    q.accuracy = TRIOCT_RAY_REQUEST_T_SEED;
    a = ask_ray("spare", &q);
    assert_int_equal(a.status, TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(a.message, "contact TOUCH is decided exactly only: send accuracy EXACT (0) or "
                                   "ACCURACY_WORLD (-1), not SEED (1)");
    answer_free(&a);
    q.accuracy = TRIOCT_RAY_REQUEST_T_EXACT;
    q.contact = 7;
    a = ask_ray("spare", &q);
    assert_int_equal(a.status, TRIOCT_ERR_BAD_REQUEST);
    assert_string_equal(a.message, "contact 7 is not CROSSING (0) or TOUCH (1)");
    answer_free(&a);
    assert_int_equal(registry_remove(F.reg, "spare"), 0);
}

static void test_rays_equal_the_engine(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 2);
    ray_set rays = sphere_rays(&r, 300);
    const struct {
        int8_t detail;
        int8_t accuracy;
        accuracy_mode mode;
        double tmin, tmax;
    } cases[] = {
        {TRIOCT_RAY_REQUEST_T_ANY, TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD, ACCURACY_EXACT, 0, INFINITY},
        {TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD, ACCURACY_EXACT, 0, INFINITY},
        {TRIOCT_RAY_REQUEST_T_ALL, TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD, ACCURACY_EXACT, 0, INFINITY},
        {TRIOCT_RAY_REQUEST_T_CLOSEST, TRIOCT_RAY_REQUEST_T_FAST, ACCURACY_FAST, 0, INFINITY},
        {TRIOCT_RAY_REQUEST_T_ALL, TRIOCT_RAY_REQUEST_T_SEED, ACCURACY_SEED, 0, INFINITY},
        /* A t range that cuts some rays short. */
        {TRIOCT_RAY_REQUEST_T_ALL, TRIOCT_RAY_REQUEST_T_EXACT, ACCURACY_EXACT, 0.1, 0.6},
    };
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        trioct_ray_request_t q =
            ray_request("sphere", &rays, cases[c].detail, cases[c].accuracy, cases[c].tmin, cases[c].tmax, 8);
        answer a = ask_ray("sphere", &q);
        assert_int_equal(a.chunks, 1);
        assert_int_equal(a.detail, cases[c].detail);
        assert_string_equal(a.world, "sphere");
        size_t hitting = expect_rays(&a, "sphere", &rays, (ray_detail)cases[c].detail, cases[c].mode,
                                     cases[c].tmin, cases[c].tmax, 8);
        assert_true(hitting > 10 && hitting < 290); /* the batch has both hits and misses */
        answer_free(&a);
    }
    /* The same answer as brute force over every triangle, for the closest hits. */
    trioct_ray_request_t q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    answer a = ask_ray("sphere", &q);
    char path[256];
    snprintf(path, sizeof path, "%s/sphere.obj", F.dir);
    mesh_data mesh;
    char err[256];
    assert_int_equal(mesh_load_file(path, &mesh, NULL, err, sizeof err), 0);
    mesh_view view = mesh_data_view(&mesh);
    size_t rec = 0;
    for (int i = 0; i < rays.n; i++) {
        ray_input in = {vv(rays.origin[i]), vv(rays.direction[i]), 0, INFINITY, RAY_CROSSING};
        ray_hit h;
        size_t n = brute_ray(&view, &in, RAY_CLOSEST, ACCURACY_EXACT, 0, &h, 1);
        assert_int_equal(a.found[i], (int32_t)n);
        if (n) {
            assert_int_equal(a.hits[rec].triangle, (int32_t)h.triangle);
            assert_true(a.hits[rec].t == h.t);
            rec++;
        }
    }
    assert_int_equal(rec, a.records);
    mesh_data_free(&mesh);
    answer_free(&a);
    ray_set_free(&rays);
}

/* ALL keeps max_hits per ray but says how many crossings there were: nothing cut silently. */
static void test_all_hits_report_more_than_stored(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 3);
    ray_set rays = layer_rays(&r, 20, 1);
    trioct_ray_request_t q = ray_request("layers", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 7);
    answer a = ask_ray("layers", &q);
    expect_rays(&a, "layers", &rays, RAY_ALL, ACCURACY_EXACT, 0, INFINITY, 7);
    for (int i = 0; i < rays.n; i++)
        assert_int_equal(a.found[i], LAYERS);
    assert_int_equal(a.records, 20 * 7);
    answer_free(&a);
    ray_set_free(&rays);
}

static void test_ray_results_come_in_chunks(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 4);
    /* Half the rays cross 60 layers, more than their share (65536 / 1280 = 51) of the reply:
     * 38,400 hits of 56 bytes, about 36 chunks, each under the cap (read_reply checked). */
    ray_set rays = layer_rays(&r, TRIOCT_MAX_RAYS, 2);
    trioct_ray_request_t q =
        ray_request("layers", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, TRIOCT_MAX_HITS_PER_RAY);
    answer a = ask_ray("layers", &q);
    assert_true(a.chunks >= 35);
    assert_int_equal(a.records, (size_t)TRIOCT_MAX_RAYS / 2 * LAYERS);
    expect_rays(&a, "layers", &rays, RAY_ALL, ACCURACY_EXACT, 0, INFINITY, TRIOCT_MAX_HITS_PER_RAY);
    answer_free(&a);
    ray_set_free(&rays);
}

/* ---------- triangles ---------- */

static trioct_triangle_t tri_of(vec3 a, vec3 b, vec3 c)
{
    return (trioct_triangle_t){tv(a), tv(b), tv(c)};
}

/* Small random triangles around the unit sphere's surface. */
static trioct_triangle_t *sphere_triangles(rng *r, int n)
{
    trioct_triangle_t *t = calloc((size_t)n, sizeof *t);
    for (int i = 0; i < n; i++) {
        vec3 c = vec3_scale(rng_unit_vector(r), rng_uniform(r, 0.8, 1.2));
        t[i] = tri_of(vec3_add(c, vec3_scale(rng_unit_vector(r), 0.15)),
                      vec3_add(c, vec3_scale(rng_unit_vector(r), 0.15)),
                      vec3_add(c, vec3_scale(rng_unit_vector(r), 0.15)));
    }
    return t;
}

/* The peek reads what the inline estimate weighs: how many items, and for a few triangles
 * the longest side of their bounding boxes. */
static void test_peek_measures_the_request_for_the_estimate(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 21);
    dispatch_request req;
    for (int n = 0; n <= 12; n += 3) {
        ray_set rays = sphere_rays(&r, n);
        trioct_ray_request_t q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 5);
        msg m = ENCODE(trioct_ray_request_t, &q);
        assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_RAY, "sphere"), m.data, m.size, &req),
                         PEEK_REQUEST);
        assert_int_equal(req.items, n);
        free(m.data);
        /* The layout before contact counts its rays at the same place. */
        trioct_ray_request_v1_t old = {q.header, q.detail, q.accuracy, q.tmin, q.tmax, q.max_hits, q.num_rays,
                                       q.origin, q.direction};
        m = ENCODE(trioct_ray_request_v1_t, &old);
        assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_RAY, "sphere"), m.data, m.size, &req),
                         PEEK_REQUEST);
        assert_int_equal(req.items, n);
        free(m.data);
        ray_set_free(&rays);
    }

    /* Bounding boxes 0.5 x 0.25 x 0.125 and 0.1 x 3 x 0.2: the longest side is 3. */
    trioct_triangle_t tris[3] = {
        tri_of((vec3){0, 0, 0}, (vec3){0.5, 0.25, 0}, (vec3){0.25, 0, 0.125}),
        tri_of((vec3){1, -1, 2}, (vec3){1.1, 2, 2.2}, (vec3){1, 0, 2}),
        tri_of((vec3){-50, -50, 0}, (vec3){50, -50, 0}, (vec3){0, 50, 0}),
    };
    trioct_triangle_request_t t = {header("sphere"), TRIOCT_TRIANGLE_REQUEST_T_IDS, -1, 1, tris};
    msg m = ENCODE(trioct_triangle_request_t, &t);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_TRI, "sphere"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_int_equal(req.items, 1);
    assert_true(req.extent == 0.5);
    free(m.data);
    t.num_triangles = 2;
    m = ENCODE(trioct_triangle_request_t, &t);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_TRI, "sphere"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_int_equal(req.items, 2);
    assert_true(req.extent == 3.0);
    free(m.data);
    /* Past DISPATCH_INLINE_MAX_TRIANGLES the triangles are not read: they go to the pool. */
    t.num_triangles = 3;
    m = ENCODE(trioct_triangle_request_t, &t);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_TRI, "sphere"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_int_equal(req.items, 3);
    assert_true(isinf(req.extent));
    free(m.data);
    /* A coordinate that is not finite gives no size. */
    trioct_triangle_t bad = tris[0];
    bad.b.y = NAN;
    t.num_triangles = 1;
    t.triangles = &bad;
    m = ENCODE(trioct_triangle_request_t, &t);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_TRI, "sphere"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_true(isnan(req.extent));
    free(m.data);

    /* Meshes and admin requests carry no count the estimate reads. */
    trioct_admin_request_t a = admin_request("sphere", TRIOCT_ADMIN_REQUEST_T_INFO);
    m = ENCODE(trioct_admin_request_t, &a);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_ADMIN, "sphere"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_int_equal(req.items, 0);
    free(m.data);
}

/* Peeks a triangle request of n copies of tri on world's channel. */
static dispatch_request peek_triangles(const char *world_name, const trioct_triangle_t *tri, int n, int8_t detail)
{
    trioct_triangle_t copies[4];
    assert_true(n <= 4);
    for (int i = 0; i < n; i++)
        copies[i] = *tri;
    trioct_triangle_request_t t = {header(world_name), detail, -1, n, copies};
    msg m = ENCODE(trioct_triangle_request_t, &t);
    dispatch_request req;
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_TRI, world_name), m.data, m.size, &req),
                     PEEK_REQUEST);
    free(m.data);
    return req;
}

/* A triangle in the plane z = 0.1 whose bounding box's longest side is side. */
static trioct_triangle_t triangle_of_side(double side)
{
    return tri_of((vec3){0, 0, 0.1}, (vec3){side, 0, 0.1}, (vec3){0, side / 2, 0.1});
}

/* What the daemon answers on its loop thread: at most DISPATCH_INLINE_MAX_RAYS rays, at
 * most DISPATCH_INLINE_MAX_TRIANGLES triangles each within DISPATCH_INLINE_MAX_TRIANGLE_LEAVES
 * leaves of the world's resolution; never a mesh or an admin request. */
static void test_small_requests_follow_the_threshold(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 22);
    const int ray_counts[] = {0, 1, DISPATCH_INLINE_MAX_RAYS, DISPATCH_INLINE_MAX_RAYS + 1, 100};
    const int ray_small[] = {1, 1, 1, 0, 0};
    for (size_t i = 0; i < sizeof ray_counts / sizeof ray_counts[0]; i++) {
        ray_set rays = sphere_rays(&r, ray_counts[i]);
        trioct_ray_request_t q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
        msg m = ENCODE(trioct_ray_request_t, &q);
        dispatch_request req;
        assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_RAY, "sphere"), m.data, m.size, &req),
                         PEEK_REQUEST);
        assert_int_equal(dispatch_is_small(&F.ctx, &req), ray_small[i]);
        free(m.data);
        ray_set_free(&rays);
    }

    /* The flat terrain's leaves: a triangle is small up to 16 of them, whatever its detail. */
    world *w = held("flat");
    octree_info info;
    octree_get_info(w->tree, &info);
    world_release(w);
    double limit = DISPATCH_INLINE_MAX_TRIANGLE_LEAVES * info.resolution;
    assert_true(limit > 1.0 && limit < 20.0); /* the terrain is 20 wide: big triangles exist */
    const int8_t details[] = {TRIOCT_TRIANGLE_REQUEST_T_YESNO, TRIOCT_TRIANGLE_REQUEST_T_IDS,
                              TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS};
    for (size_t d = 0; d < 3; d++) {
        trioct_triangle_t at = triangle_of_side(limit), over = triangle_of_side(nextafter(limit, INFINITY));
        trioct_triangle_t tiny = triangle_of_side(0.01);
        dispatch_request req = peek_triangles("flat", &at, 1, details[d]);
        assert_true(dispatch_is_small(&F.ctx, &req));
        req = peek_triangles("flat", &at, DISPATCH_INLINE_MAX_TRIANGLES, details[d]);
        assert_true(dispatch_is_small(&F.ctx, &req));
        req = peek_triangles("flat", &tiny, DISPATCH_INLINE_MAX_TRIANGLES + 1, details[d]);
        assert_false(dispatch_is_small(&F.ctx, &req));
        req = peek_triangles("flat", &over, 1, details[d]);
        assert_false(dispatch_is_small(&F.ctx, &req));
        req = peek_triangles("flat", &tiny, 0, details[d]);
        assert_true(dispatch_is_small(&F.ctx, &req));
        /* Not finite: the workers answer it (with ERR_NONFINITE). */
        trioct_triangle_t bad = tiny;
        bad.c.x = INFINITY;
        req = peek_triangles("flat", &bad, 1, details[d]);
        assert_false(dispatch_is_small(&F.ctx, &req));
    }
    /* The limit is the world's: the same triangle is large on a finer world. */
    w = held("sphere");
    octree_get_info(w->tree, &info);
    world_release(w);
    assert_true(DISPATCH_INLINE_MAX_TRIANGLE_LEAVES * info.resolution < limit);
    trioct_triangle_t at = triangle_of_side(limit);
    dispatch_request req = peek_triangles("sphere", &at, 1, TRIOCT_TRIANGLE_REQUEST_T_YESNO);
    assert_false(dispatch_is_small(&F.ctx, &req));
    /* A world not held: its answer is ERR_UNKNOWN_WORLD, cheap wherever it is made. */
    req = peek_triangles("nowhere", &at, 1, TRIOCT_TRIANGLE_REQUEST_T_YESNO);
    assert_true(dispatch_is_small(&F.ctx, &req));

    /* A mesh query of one pose and one inline triangle, and an INFO: never small. */
    trioct_triangle_t shape = triangle_of_side(0.01);
    trioct_pose_t pose = pose_at(0, (vec3){0, 0, 0});
    trioct_mesh_request_t mq = {.header = header("flat"), .detail = TRIOCT_MESH_REQUEST_T_YESNO, .accuracy = -1,
                                .shape = "", .num_shape_triangles = 1, .shape_triangles = &shape,
                                .num_poses = 1, .poses = &pose};
    msg m = ENCODE(trioct_mesh_request_t, &mq);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_MESH, "flat"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_false(dispatch_is_small(&F.ctx, &req));
    free(m.data);
    trioct_admin_request_t a = admin_request("flat", TRIOCT_ADMIN_REQUEST_T_INFO);
    m = ENCODE(trioct_admin_request_t, &a);
    assert_int_equal(dispatch_peek(&F.ctx, channel_of(TRIOCT_CHANNEL_ADMIN, "flat"), m.data, m.size, &req),
                     PEEK_REQUEST);
    assert_false(dispatch_is_small(&F.ctx, &req));
    free(m.data);
}

static void test_triangles_equal_the_engine(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 5);
    int n = 200;
    trioct_triangle_t *tris = sphere_triangles(&r, n);
    const int8_t details[] = {TRIOCT_TRIANGLE_REQUEST_T_YESNO, TRIOCT_TRIANGLE_REQUEST_T_IDS,
                              TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS};
    for (size_t d = 0; d < 3; d++) {
        for (int8_t acc = -1; acc <= TRIOCT_RAY_REQUEST_T_FAST; acc++) {
            trioct_triangle_request_t q = {header("sphere"), details[d], acc, n, tris};
            answer a = ask_triangle("sphere", &q);
            assert_int_equal(a.chunks, 1);
            size_t touching = expect_triangles(&a, "sphere", tris, n, (tri_detail)details[d],
                                               acc < 0 ? ACCURACY_EXACT : (accuracy_mode)acc);
            assert_true(touching > 10 && touching < (size_t)n - 10);
            answer_free(&a);
        }
    }
    /* IDS equal brute force over every triangle. */
    trioct_triangle_request_t q = {header("sphere"), TRIOCT_TRIANGLE_REQUEST_T_IDS, -1, n, tris};
    answer a = ask_triangle("sphere", &q);
    char path[256], err[256];
    snprintf(path, sizeof path, "%s/sphere.obj", F.dir);
    mesh_data mesh;
    assert_int_equal(mesh_load_file(path, &mesh, NULL, err, sizeof err), 0);
    mesh_view view = mesh_data_view(&mesh);
    uint32_t ids[2000];
    size_t rec = 0;
    for (int i = 0; i < n; i++) {
        vec3 t[3] = {vv(tris[i].a), vv(tris[i].b), vv(tris[i].c)};
        size_t k = brute_triangle(&view, t, ACCURACY_EXACT, 0, ids, 2000);
        assert_int_equal(a.found[i], (int32_t)k);
        for (size_t j = 0; j < k; j++, rec++)
            assert_int_equal(a.contacts[rec].triangle, (int32_t)ids[j]);
    }
    assert_int_equal(rec, a.records);
    mesh_data_free(&mesh);
    answer_free(&a);
    free(tris);
}

static void test_triangle_results_come_in_chunks(void **state)
{
    (void)state;
    /* Coplanar triangles over halves and eighths of the flat terrain (about 6,400 and 1,600
     * contacts), among 60 small ones that touch a few: the big ones need more than their
     * share (65536 / 64 = 1024) of the reply. */
    enum { N = 64 };
    trioct_triangle_t tris[N];
    tris[0] = tri_of((vec3){-10, -10, 0}, (vec3){10, -10, 0}, (vec3){-10, 10, 0});
    tris[1] = tri_of((vec3){10, -10, 0}, (vec3){10, 10, 0}, (vec3){-10, 10, 0});
    tris[2] = tri_of((vec3){-10, 0, 0}, (vec3){0, 0, 0}, (vec3){-10, 10, 0});
    tris[3] = tri_of((vec3){10, -10, 0}, (vec3){10, 0, 0}, (vec3){0, -10, 0});
    rng r = rng_seeded(base_seed + 13);
    for (int i = 4; i < N; i++) {
        vec3 c = {rng_uniform(&r, -9, 9), rng_uniform(&r, -9, 9), 0};
        tris[i] = tri_of(vec3_add(c, (vec3){-0.3, 0, -0.1}), vec3_add(c, (vec3){0.3, 0, -0.1}),
                         vec3_add(c, (vec3){0, 0.2, 0.1}));
    }
    trioct_triangle_request_t q = {header("flat"), TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, -1, N, tris};
    answer a = ask_triangle("flat", &q);
    assert_true(a.records > 16000);
    assert_true(a.chunks >= 15); /* 56 bytes per contact and segment */
    assert_true(expect_triangles(&a, "flat", tris, N, TRI_SEGMENTS, ACCURACY_EXACT) == N);
    assert_true(a.found[0] > 1024 && a.found[5] < 100);
    answer_free(&a);

    q.detail = TRIOCT_TRIANGLE_REQUEST_T_IDS;
    q.header = header("flat");
    a = ask_triangle("flat", &q);
    assert_true(a.chunks >= 2); /* 8 bytes per contact: 7,500 a chunk */
    expect_triangles(&a, "flat", tris, N, TRI_IDS, ACCURACY_EXACT);
    answer_free(&a);
}

/* ---------- meshes ---------- */

static void test_mesh_queries_equal_the_engine(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 6);
    int n = 60;
    trioct_pose_t *poses = calloc((size_t)n, sizeof *poses);
    for (int i = 0; i < n; i++)
        poses[i] = pose_at(rng_uniform(&r, 0, 6.28), vec3_scale(rng_unit_vector(&r), rng_uniform(&r, 0.5, 1.5)));
    world *w = held("sphere");
    const world_shape *cube = world_find_shape(w, "cube");
    assert_non_null(cube);
    mesh_view cube_view = mesh_data_view(&cube->model->mesh);
    for (int8_t detail = 0; detail <= 1; detail++) {
        trioct_mesh_request_t q = {.header = header("sphere"), .detail = detail, .accuracy = -1, .shape = "cube",
                                   .num_poses = n, .poses = poses};
        answer a = ask_mesh("sphere", &q);
        size_t touching = expect_mesh(&a, "sphere", &cube_view, poses, n, detail, ACCURACY_EXACT);
        assert_true(touching > 5 && touching < (size_t)n - 5);
        answer_free(&a);
    }
    /* The same shape sent inline gives the same answers. */
    trioct_triangle_t *inline_tris = calloc(cube_view.triangle_count, sizeof *inline_tris);
    for (size_t t = 0; t < cube_view.triangle_count; t++)
        inline_tris[t] = tri_of(cube_view.vertices[cube_view.indices[3 * t]],
                                cube_view.vertices[cube_view.indices[3 * t + 1]],
                                cube_view.vertices[cube_view.indices[3 * t + 2]]);
    trioct_mesh_request_t q = {.header = header("sphere"), .detail = TRIOCT_MESH_REQUEST_T_PAIRS, .accuracy = -1,
                               .shape = "", .num_shape_triangles = (int32_t)cube_view.triangle_count,
                               .shape_triangles = inline_tris, .num_poses = n, .poses = poses};
    answer a = ask_mesh("sphere", &q);
    expect_mesh(&a, "sphere", &cube_view, poses, n, 1, ACCURACY_EXACT);
    answer_free(&a);
    free(inline_tris);
    world_release(w);
    free(poses);
}

static void test_mesh_pairs_come_in_chunks(void **state)
{
    (void)state;
    /* A shape of two coplanar triangles covering half the flat terrain each, at four
     * positions: tens of thousands of pairs. */
    trioct_triangle_t shape[2] = {
        tri_of((vec3){-10, -10, 0}, (vec3){10, -10, 0}, (vec3){-10, 10, 0}),
        tri_of((vec3){10, -10, 0}, (vec3){10, 10, 0}, (vec3){-10, 10, 0}),
    };
    /* Twenty more poses lifted off the terrain: the touching ones need more than their
     * share (65536 / 24 = 2730). */
    enum { N = 24 };
    trioct_pose_t poses[N] = {pose_at(0, (vec3){0, 0, 0}), pose_at(0, (vec3){5, 0, 0}),
                              pose_at(0, (vec3){0, 0, 3}), pose_at(0, (vec3){-4, -4, 0})};
    for (int i = 4; i < N; i++)
        poses[i] = pose_at(0.1 * i, (vec3){0, 0, 1 + i});
    trioct_mesh_request_t q = {.header = header("flat"), .detail = TRIOCT_MESH_REQUEST_T_PAIRS, .accuracy = -1,
                               .shape = "", .num_shape_triangles = 2, .shape_triangles = shape,
                               .num_poses = N, .poses = poses};
    answer a = ask_mesh("flat", &q);
    assert_true(a.records > 30000);
    assert_true(a.chunks >= 6); /* 12 bytes per pair: 5,000 a chunk */
    assert_true(a.found[0] > 2730);
    assert_int_equal(a.found[2], 0); /* lifted off the terrain */
    vec3 v[6];
    uint32_t ix[6] = {0, 1, 2, 3, 4, 5};
    for (int t = 0; t < 2; t++) {
        v[3 * t] = vv(shape[t].a);
        v[3 * t + 1] = vv(shape[t].b);
        v[3 * t + 2] = vv(shape[t].c);
    }
    mesh_view view = {v, 6, ix, 2};
    expect_mesh(&a, "flat", &view, poses, N, 1, ACCURACY_EXACT);
    answer_free(&a);
}

/* ---------- caps on results ---------- */

static void test_result_caps_are_errors_not_cuts(void **state)
{
    (void)state;
    /* One triangle over the whole terrain touches 12,800: over the per-triangle cap. */
    trioct_triangle_t whole = tri_of((vec3){-30, -30, 0}, (vec3){30, -30, 0}, (vec3){0, 40, 0});
    trioct_triangle_request_t q = {header("flat"), TRIOCT_TRIANGLE_REQUEST_T_IDS, -1, 1, &whole};
    answer a = ask_triangle("flat", &q);
    expect_error(&a, TRIOCT_ERR_OVER_CAP, "TRIOCT_MAX_CONTACTS_PER_TRIANGLE=10000");
    assert_non_null(strstr(a.message, "triangle 0 touches 12800"));
    answer_free(&a);
    /* YESNO of the same triangle is fine: one bit. */
    q.detail = TRIOCT_TRIANGLE_REQUEST_T_YESNO;
    q.header = header("flat");
    a = ask_triangle("flat", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.found[0], 1);
    answer_free(&a);

    /* Eleven triangles over half the terrain: each under its cap, together over
     * TRIOCT_MAX_RESULTS. */
    trioct_triangle_t quarters[11];
    for (int i = 0; i < 11; i++)
        quarters[i] = tri_of((vec3){-10, -10, 0}, (vec3){10, -10, 0}, (vec3){-10, 10, 0});
    q = (trioct_triangle_request_t){header("flat"), TRIOCT_TRIANGLE_REQUEST_T_IDS, -1, 11, quarters};
    a = ask_triangle("flat", &q);
    expect_error(&a, TRIOCT_ERR_OVER_CAP, "over TRIOCT_MAX_RESULTS=65536; send fewer triangles");
    answer_free(&a);

    /* Mesh pairs over the reply cap: eleven poses of a shape over half the terrain. */
    trioct_pose_t poses[11];
    for (int i = 0; i < 11; i++)
        poses[i] = pose_at(0, (vec3){0, 0, 0});
    trioct_mesh_request_t mq = {.header = header("flat"), .detail = TRIOCT_MESH_REQUEST_T_PAIRS, .accuracy = -1,
                                .shape = "", .num_shape_triangles = 1, .shape_triangles = &quarters[0],
                                .num_poses = 11, .poses = poses};
    a = ask_mesh("flat", &mq);
    expect_error(&a, TRIOCT_ERR_OVER_CAP, "TRIOCT_MAX_RESULTS=65536");
    answer_free(&a);

    /* Rays: 1,280 rays through 60 layers store 76,800 hits, over the cap; storing 51 each
     * makes 65,280, just under it, and is answered in full. */
    rng r = rng_seeded(base_seed + 7);
    ray_set rays = layer_rays(&r, TRIOCT_MAX_RAYS, 1);
    trioct_ray_request_t rq = ray_request("layers", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 1000);
    a = ask_ray("layers", &rq);
    expect_error(&a, TRIOCT_ERR_OVER_CAP,
                 "produced 76800 results, over TRIOCT_MAX_RESULTS=65536; send fewer rays or a smaller max_hits");
    answer_free(&a);
    rq = ray_request("layers", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 51);
    a = ask_ray("layers", &rq);
    assert_int_equal(a.records, (size_t)TRIOCT_MAX_RAYS * 51);
    expect_rays(&a, "layers", &rays, RAY_ALL, ACCURACY_EXACT, 0, INFINITY, 51);
    answer_free(&a);
    ray_set_free(&rays);
}

/* ---------- object edits ---------- */

static const trioct_pose_t identity_pose = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};

/* The tree of box.obj with every vertex placed by at, in the engine's one posing
 * expression: what the answers about an object at that pose must equal. */
static octree *posed_box_tree(const pose *at, mesh_data *posed)
{
    char path[256], err[256];
    snprintf(path, sizeof path, "%s/box.obj", F.dir);
    assert_int_equal(mesh_load_file(path, posed, NULL, err, sizeof err), 0);
    for (size_t v = 0; v < posed->vertex_count; v++)
        posed->vertices[v] = octree_pose_point(at, posed->vertices[v]);
    mesh_view view = mesh_data_view(posed);
    octree_def def = octree_default_def();
    def.node_bounds = 1;
    octree_error e;
    octree *t = octree_build(&view, &def, &e);
    assert_non_null(t);
    return t;
}

/* ADD_SOLID checks the mesh closed and makes the object's inside count: a triangle wholly
 * inside it is reported as a contact with the object through triangle -1; an open inline
 * mesh is refused naming its open edge. */
static void test_solid_objects_over_the_wire(void **state)
{
    (void)state;
    install_from_scene("edited");
    trioct_pose_t at = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {5, 0, 0}};
    trioct_object_edit_t add = wire_edit(TRIOCT_OBJECT_EDIT_T_ADD_SOLID, "solid_box", "box.obj", at);
    answer a = ask_objects("edited", 0, 1, &add);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);

    /* Inside the solid box, and inside the section's box, which is a surface only. */
    trioct_triangle_t tris[2] = {{{5.2, 0.2, 0.2}, {5.8, 0.3, 0.4}, {5.5, 0.7, 0.6}},
                                 {{0.2, 0.2, 0.2}, {0.8, 0.3, 0.4}, {0.5, 0.7, 0.6}}};
    for (int8_t detail = TRIOCT_TRIANGLE_REQUEST_T_YESNO; detail <= TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS; detail++) {
        trioct_triangle_request_t q = {header("edited"), detail, -1, 2, tris};
        a = ask_triangle("edited", &q);
        assert_int_equal(a.status, TRIOCT_OK);
        assert_int_equal(a.found[0], 1);
        assert_int_equal(a.found[1], 0);
        if (detail != TRIOCT_TRIANGLE_REQUEST_T_YESNO) {
            assert_int_equal(a.records, 1);
            assert_int_equal(a.contacts[0].query, 0);
            assert_int_equal(a.contacts[0].triangle, -1);
            assert_string_equal(a.names[a.contacts[0].object], "solid_box");
        }
        answer_free(&a);
    }
    /* The same for a shape: the cube inside the solid box collides through no triangle of
     * it; inside the section's box it does not. */
    trioct_pose_t in_solid[2] = {{{1, 0, 0, 0, 1, 0, 0, 0, 1}, {5.5, 0.5, 0.5}},
                                 {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0.5, 0.5, 0.5}}};
    for (int8_t detail = TRIOCT_MESH_REQUEST_T_YESNO; detail <= TRIOCT_MESH_REQUEST_T_PAIRS; detail++) {
        trioct_mesh_request_t mq = {.header = header("edited"), .detail = detail, .accuracy = -1, .shape = "cube",
                                    .num_poses = 2, .poses = in_solid};
        a = ask_mesh("edited", &mq);
        assert_int_equal(a.status, TRIOCT_OK);
        assert_int_equal(a.found[0], 1);
        assert_int_equal(a.found[1], 0);
        if (detail == TRIOCT_MESH_REQUEST_T_PAIRS) {
            assert_int_equal(a.records, 1);
            assert_int_equal(a.pairs[0].world_triangle, -1);
            assert_string_equal(a.names[a.pairs[0].object], "solid_box");
        }
        answer_free(&a);
    }

    trioct_triangle_t open_box[11];
    mesh_data box = meshgen_box((box3){{0, 0, 0}, {1, 1, 1}});
    for (int t = 0; t < 11; t++) {
        vec3 c[3] = {mesh_data_corner(&box, (size_t)t, 0), mesh_data_corner(&box, (size_t)t, 1),
                     mesh_data_corner(&box, (size_t)t, 2)};
        open_box[t] = (trioct_triangle_t){{c[0].x, c[0].y, c[0].z}, {c[1].x, c[1].y, c[1].z}, {c[2].x, c[2].y, c[2].z}};
    }
    mesh_data_free(&box);
    trioct_object_edit_t edits[2] = {wire_edit(TRIOCT_OBJECT_EDIT_T_REMOVE, "solid_box", NULL, at),
                                     wire_edit(TRIOCT_OBJECT_EDIT_T_ADD_SOLID, "leaky", NULL, at)};
    edits[1].num_triangles = 11;
    edits[1].triangles = open_box;
    a = ask_objects("edited", 0, 2, edits);
    assert_int_equal(a.status, TRIOCT_ERR_LOAD_FAILED);
    assert_int_equal(a.failed_edit, 1);
    if (!strstr(a.message, "inline: declared solid but not a closed surface: edge (") ||
        !strstr(a.message, "is open: only inline triangle"))
        fail_msg("%s", a.message);
    answer_free(&a);
    a = ask_objects("edited", 0, 1, edits); /* all or none: solid_box was still there */
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
}

/* Edits make versions; answers about a moved object equal those of a tree built from its
 * posed vertices, and name it; a world back to one object at the identity is one tree. */
static void test_object_edits_answer_as_posed_trees(void **state)
{
    (void)state;
    install_from_scene("edited");
    answer a = ask_objects("edited", 1, 0, NULL);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.objects, 1);
    assert_int_equal(a.num_worlds, 1);
    assert_string_equal(a.listed[0].name, "edited");
    int64_t v0 = a.version;
    answer_free(&a);

    /* b: box.obj a quarter turn about z, at (3, 0.5, 0.25): x in [2, 3], y in [0.5, 1.5]. */
    trioct_pose_t at_b = {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {3, 0.5, 0.25}};
    trioct_object_edit_t add = wire_edit(TRIOCT_OBJECT_EDIT_T_ADD, "b", "box.obj", at_b);
    a = ask_objects("edited", 1, 1, &add);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.version, v0 + 1);
    assert_int_equal(a.objects, 2);
    assert_string_equal(a.listed[0].name, "b");
    assert_true(a.listed[0].bbox_min.x == 2 && a.listed[0].bbox_max.y == 1.5);
    answer_free(&a);

    pose pb;
    memcpy(pb.r, at_b.r, sizeof pb.r);
    pb.t = (vec3){at_b.t.x, at_b.t.y, at_b.t.z};
    mesh_data posed;
    octree *expect = posed_box_tree(&pb, &posed);
    rng r = rng_seeded(base_seed + 40);
    enum { N = 40 };
    ray_set rays = {N, calloc(N, sizeof(trioct_vec3_t)), calloc(N, sizeof(trioct_vec3_t))};
    for (int i = 0; i < N; i++) {
        rays.origin[i] = (trioct_vec3_t){rng_uniform(&r, 1.9, 3.1), rng_uniform(&r, 0.4, 1.6), 5};
        rays.direction[i] = (trioct_vec3_t){rng_uniform(&r, -0.1, 0.1), rng_uniform(&r, -0.1, 0.1), -1};
    }
    trioct_ray_request_t q = ray_request("edited", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("edited", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    size_t hits = 0;
    for (int i = 0; i < N; i++) {
        ray_input in = {{rays.origin[i].x, rays.origin[i].y, rays.origin[i].z},
                        {rays.direction[i].x, rays.direction[i].y, rays.direction[i].z}, 0, INFINITY, RAY_CROSSING};
        ray_hit h;
        ray_output out = {.hits = &h, .max_hits = 1};
        assert_int_equal(octree_ray(expect, &in, RAY_CLOSEST, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        assert_int_equal(a.found[i], (int)out.hit_count);
        for (size_t k = 0; k < a.records; k++)
            if (a.hits[k].ray == i) {
                assert_string_equal(a.names[a.hits[k].object], "b");
                assert_true(a.hits[k].t == h.t);
                assert_int_equal(a.hits[k].triangle, (int)h.triangle);
                hits++;
            }
    }
    assert_true(hits > N / 2);
    answer_free(&a);

    /* ALL along x through both: the section's box first, then b, names in name order. */
    ray_set along = {1, calloc(1, sizeof(trioct_vec3_t)), calloc(1, sizeof(trioct_vec3_t))};
    along.origin[0] = (trioct_vec3_t){-1, 0.75, 0.75};
    along.direction[0] = (trioct_vec3_t){1, 0, 0};
    q = ray_request("edited", &along, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 8);
    a = ask_ray("edited", &q);
    assert_int_equal(a.records, 4);
    assert_int_equal(a.num_names, 2);
    assert_string_equal(a.names[0], "b");
    assert_string_equal(a.names[1], "edited");
    static const double t_all[4] = {1, 2, 3, 4};
    for (size_t k = 0; k < 4; k++) {
        assert_true(a.hits[k].t == t_all[k]);
        assert_string_equal(a.names[a.hits[k].object], k < 2 ? "edited" : "b");
    }
    answer_free(&a);

    /* The shape at poses over b's top: the pairs of the posed tree, naming b. */
    world *w = registry_acquire(F.reg, "edited");
    const world_shape *cube = world_find_shape(w, "cube");
    mesh_view cube_view = mesh_data_view(&cube->model->mesh);
    trioct_pose_t poses[6];
    for (int i = 0; i < 6; i++)
        poses[i] = (trioct_pose_t){{1, 0, 0, 0, 1, 0, 0, 0, 1}, {2.2 + 0.12 * i, 1.0, 1.25 + 0.1 * (i % 3)}};
    trioct_mesh_request_t mq = {.header = header("edited"), .detail = TRIOCT_MESH_REQUEST_T_PAIRS, .accuracy = -1,
                                .shape = "cube", .num_poses = 6, .poses = poses};
    a = ask_mesh("edited", &mq);
    assert_int_equal(a.status, TRIOCT_OK);
    size_t pairs = 0;
    for (int i = 0; i < 6; i++) {
        pose at;
        memcpy(at.r, poses[i].r, sizeof at.r);
        at.t = (vec3){poses[i].t.x, poses[i].t.y, poses[i].t.z};
        mesh_pair buf[256];
        mesh_output out = {.pairs = buf, .capacity = 256};
        assert_int_equal(octree_mesh(expect, &cube_view, &at, 1, ACCURACY_EXACT, &out, NULL), OCTREE_OK);
        assert_int_equal(a.found[i], (int)out.count);
        pairs += out.count;
    }
    assert_int_equal(a.records, pairs);
    assert_true(pairs > 0);
    for (size_t k = 0; k < a.records; k++)
        assert_string_equal(a.names[a.pairs[k].object], "b");
    answer_free(&a);
    world_release(w);

    /* Moved away and removed: the old footprint is clear, and one object at the identity
     * is one tree again. */
    trioct_object_edit_t edits[2] = {wire_edit(TRIOCT_OBJECT_EDIT_T_MOVE, "b", NULL, identity_pose),
                                     wire_edit(TRIOCT_OBJECT_EDIT_T_REMOVE, "b", NULL, identity_pose)};
    edits[0].pose.t.x = 10;
    a = ask_objects("edited", 0, 2, edits);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.objects, 1);
    answer_free(&a);
    q = ray_request("edited", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("edited", &q);
    assert_int_equal(a.records, 0);
    answer_free(&a);
    w = registry_acquire(F.reg, "edited");
    assert_non_null(w->tree);
    world_release(w);
    /* One object, moved: no longer its tree as it stands. */
    trioct_object_edit_t lift = wire_edit(TRIOCT_OBJECT_EDIT_T_MOVE, "edited", NULL, identity_pose);
    lift.pose.t.z = 1;
    a = ask_objects("edited", 0, 1, &lift);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
    along.origin[0] = (trioct_vec3_t){0.5, 0.5, 5};
    along.direction[0] = (trioct_vec3_t){0, 0, -1};
    q = ray_request("edited", &along, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("edited", &q);
    assert_int_equal(a.records, 1);
    assert_true(a.hits[0].t == 3); /* the top, z = 1 + 1 */
    answer_free(&a);
    w = registry_acquire(F.reg, "edited");
    assert_null(w->tree);
    world_release(w);

    octree_free(expect);
    mesh_data_free(&posed);
    free(rays.origin);
    free(rays.direction);
    free(along.origin);
    free(along.direction);
    assert_int_equal(registry_remove(F.reg, "edited"), 0);
}

/* ---------- distances ---------- */

DEFINE_ENCODER(trioct_distance_request_t)

/* A distance reply with its chunks joined: the results in order, the names of chunk 0. */
typedef struct distance_answer {
    int status;
    char message[TRIOCT_MAX_MESSAGE_LEN + 1];
    size_t chunks;
    int8_t kind;
    int32_t num_names;
    char names[8][TRIOCT_MAX_NAME_LEN + 1];
    size_t count;
    trioct_distance_result_t *results;
} distance_answer;

static trioct_distance_request_t points_request(const char *world, double within, int n, trioct_vec3_t *points)
{
    return (trioct_distance_request_t){.header = header(world),
                                       .kind = TRIOCT_DISTANCE_REQUEST_T_POINTS,
                                       .within = within,
                                       .num_points = n,
                                       .points = points,
                                       .shape = "",
                                       .rotation = TRIOCT_DISTANCE_REQUEST_T_MATRIX};
}

static distance_answer ask_distance(const char *world, const trioct_distance_request_t *q)
{
    msg m = ENCODE(trioct_distance_request_t, q);
    dispatch_reply rep;
    assert_int_equal(dispatch_handle(&F.ctx, channel_of(TRIOCT_CHANNEL_DISTANCE, world), m.data, m.size, NOW, &rep),
                     0);
    assert_int_equal(rep.type, REQUEST_DISTANCE);
    distance_answer a = {.status = rep.status, .chunks = rep.chunk_count};
    assert_true(rep.chunk_count >= 1);
    for (size_t c = 0; c < rep.chunk_count; c++) {
        assert_true(rep.chunks[c].size <= TRIOCT_MAX_CHUNK_BYTES);
        wire_error err;
        if (wire_check(WIRE_DISTANCE_REPLY, rep.chunks[c].data, rep.chunks[c].size, &err) != 0)
            fail_msg("distance reply chunk %zu: %s", c, err.what);
        trioct_distance_reply_t r;
        int len = (int)rep.chunks[c].size;
        assert_int_equal(trioct_distance_reply_t_decode(rep.chunks[c].data, 0, len, &r), len);
        assert_int_equal(r.header.chunk_index, (int32_t)c);
        assert_int_equal(r.header.chunk_count, (int32_t)rep.chunk_count);
        assert_int_equal(r.header.request_id, q->header.request_id);
        assert_int_equal(r.header.status, rep.status);
        if (c == 0) {
            snprintf(a.message, sizeof a.message, "%s", r.header.message);
            a.kind = r.kind;
            assert_true(r.num_objects <= 8);
            a.num_names = r.num_objects;
            for (int32_t k = 0; k < r.num_objects; k++)
                snprintf(a.names[k], sizeof a.names[k], "%s", r.objects[k]);
        } else {
            assert_int_equal(r.num_objects, 0); /* names travel in chunk 0 only */
        }
        a.results = realloc(a.results, (a.count + (size_t)r.num_results + 1) * sizeof *a.results);
        assert_non_null(a.results);
        if (r.num_results > 0)
            memcpy(a.results + a.count, r.results, (size_t)r.num_results * sizeof *r.results);
        a.count += (size_t)r.num_results;
        trioct_distance_reply_t_decode_cleanup(&r);
    }
    dispatch_reply_free(&rep);
    free(m.data);
    return a;
}

static void expect_distance_error(const distance_answer *a, int status, const char *needle)
{
    if (a->status != status)
        fail_msg("status %d (%s) \"%s\", expected %d (%s)", a->status, trioct_status_name(a->status), a->message,
                 status, trioct_status_name(status));
    assert_int_equal(a->chunks, 1);
    assert_int_equal(a->count, 0);
    if (needle && !strstr(a->message, needle))
        fail_msg("message \"%s\" does not say \"%s\"", a->message, needle);
}

/* The result must be the engine's answer, bit for bit. */
static void expect_engine_distance(const trioct_distance_result_t *got, const distance_output *want, const char *name,
                                   const distance_answer *a, trioct_vec3_t p)
{
    assert_int_equal(got->found, want->found);
    assert_true(got->shape_point.x == p.x && got->shape_point.y == p.y && got->shape_point.z == p.z);
    assert_int_equal(got->shape_triangle, -1);
    assert_int_equal(got->inside, 0);
    if (!want->found) {
        assert_int_equal(got->object, -1);
        assert_int_equal(got->triangle, -1);
        return;
    }
    assert_true(got->distance == want->distance && got->bound == want->bound);
    assert_true(got->lower == want->lower && got->upper == want->upper);
    assert_true(got->point.x == want->point.x && got->point.y == want->point.y && got->point.z == want->point.z);
    assert_int_equal(got->triangle, (int32_t)want->triangle);
    assert_int_equal(got->feature, (int8_t)want->feature);
    assert_int_equal(got->feature_index, want->feature_index);
    assert_true(got->object >= 0 && got->object < a->num_names);
    assert_string_equal(a->names[got->object], name);
}

/* Points about the unit cube [0, 1]^3, whose distances are known exactly: a face, an
 * edge and a vertex nearest, and a point inside (surface distance: the cube is no solid). */
static void test_point_distances_to_the_unit_cube(void **state)
{
    (void)state;
    install_from_scene("near");
    /* Off the faces' diagonals, where two triangles meet and the nearest feature is their
     * shared edge: (3, 0.5, 0.5) is 2 from the cube too, but on such an edge. */
    trioct_vec3_t pts[5] = {{3, 0.2, 0.6}, {2, 2, 0.5}, {2, 2, 2}, {0.4, 0.3, 0.1}, {3, 0.5, 0.5}};
    trioct_distance_request_t q = points_request("near", -1, 5, pts);
    distance_answer a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_string_equal(a.message, "ok");
    assert_int_equal(a.kind, TRIOCT_DISTANCE_REQUEST_T_POINTS);
    assert_int_equal(a.count, 5);
    assert_int_equal(a.num_names, 1);
    assert_string_equal(a.names[0], "near");
    const struct {
        double distance;
        int8_t feature;
        trioct_vec3_t point;
    } want[5] = {
        {2.0, TRIOCT_DISTANCE_RESULT_T_FACE, {1, 0.2, 0.6}},
        {sqrt(2.0), TRIOCT_DISTANCE_RESULT_T_EDGE, {1, 1, 0.5}},
        {sqrt(3.0), TRIOCT_DISTANCE_RESULT_T_VERTEX, {1, 1, 1}},
        {0.1, TRIOCT_DISTANCE_RESULT_T_FACE, {0.4, 0.3, 0}},
        {2.0, TRIOCT_DISTANCE_RESULT_T_EDGE, {1, 0.5, 0.5}},
    };
    for (int i = 0; i < 5; i++) {
        const trioct_distance_result_t *d = &a.results[i];
        assert_int_equal(d->item, i);
        assert_int_equal(d->found, 1);
        assert_int_equal(d->clear, 0);
        assert_int_equal(d->object, 0);
        assert_int_equal(d->feature, want[i].feature);
        /* The bound is proven and small: the exact distance lies in [lower, upper]. */
        assert_true(d->lower <= d->distance && d->distance <= d->upper);
        assert_true(d->bound >= 0 && d->bound < 1e-12);
        assert_true(fabs(d->distance - want[i].distance) <= d->bound + 1e-15);
        assert_true(fabs(d->point.x - want[i].point.x) < 1e-12 && fabs(d->point.y - want[i].point.y) < 1e-12 &&
                    fabs(d->point.z - want[i].point.z) < 1e-12);
    }
    /* The face case: 2 within the bound. */
    assert_true(a.results[0].lower <= 2.0 && a.results[0].upper >= 2.0);
    free(a.results);

    /* within bounds the search: nothing within 1.5 of (3, .5, .5), the cube within 2.5. */
    q = points_request("near", 1.5, 1, pts);
    a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.count, 1);
    assert_int_equal(a.results[0].found, 0);
    assert_int_equal(a.results[0].object, -1);
    assert_int_equal(a.results[0].triangle, -1);
    assert_true(a.results[0].distance == 0 && a.results[0].upper == 0);
    assert_int_equal(a.num_names, 0); /* no result names an object */
    free(a.results);
    q = points_request("near", 2.5, 1, pts);
    a = ask_distance("near", &q);
    assert_int_equal(a.results[0].found, 1);
    assert_true(a.results[0].lower <= 2.0 && 2.0 <= a.results[0].upper);
    free(a.results);

    /* An empty batch is an answer too. */
    q = points_request("near", -1, 0, NULL);
    a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.count, 0);
    free(a.results);
}

/* Random points: every answer is the engine's own, on a world of one object at the
 * identity (octree_point_distance) and on posed objects (object_set_point_distance), the
 * object named through the reply's table. */
static void test_point_distances_equal_the_engine(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 77);
    enum { N = 300 };
    trioct_vec3_t *pts = calloc(N, sizeof *pts);
    assert_non_null(pts);
    for (int i = 0; i < N; i++)
        pts[i] = tv(rng_point_in_box(&r, (box3){{-3, -3, -3}, {9, 4, 4}}));
    install_from_scene("pair");
    world *near = held("near"), *pair = held("pair");
    assert_non_null(near->tree);
    assert_null(pair->tree);
    const double withins[2] = {-1, 2.0};
    for (int k = 0; k < 2; k++) {
        trioct_distance_request_t q = points_request("near", withins[k], N, pts);
        distance_answer a = ask_distance("near", &q);
        assert_int_equal(a.status, TRIOCT_OK);
        assert_int_equal(a.count, N);
        for (int i = 0; i < N; i++) {
            distance_output want;
            double max = withins[k] < 0 ? INFINITY : withins[k];
            assert_int_equal(octree_point_distance(near->tree, vv(pts[i]), max, &want, NULL), OCTREE_OK);
            expect_engine_distance(&a.results[i], &want, "near", &a, pts[i]);
        }
        free(a.results);

        q = points_request("pair", withins[k], N, pts);
        a = ask_distance("pair", &q);
        assert_int_equal(a.status, TRIOCT_OK);
        assert_int_equal(a.count, N);
        size_t nearer_b = 0;
        for (int i = 0; i < N; i++) {
            object_distance_output want;
            double max = withins[k] < 0 ? INFINITY : withins[k];
            assert_int_equal(object_set_point_distance(pair->objects, vv(pts[i]), max, &want, NULL), OCTREE_OK);
            want.distance.found = want.found;
            const char *name = want.found ? pair->objects->objects[want.object].name : "";
            expect_engine_distance(&a.results[i], &want.distance, name, &a, pts[i]);
            nearer_b += want.found && strcmp(name, "b") == 0;
        }
        assert_true(nearer_b > 10); /* both objects answer some points */
        free(a.results);
    }
    /* (3.5, .5, .5): 1.5 from b (x in [5, 6]), 2.5 from a; only b is named. */
    trioct_vec3_t between = {3.5, 0.5, 0.5};
    trioct_distance_request_t q = points_request("pair", -1, 1, &between);
    distance_answer a = ask_distance("pair", &q);
    assert_int_equal(a.num_names, 1);
    assert_string_equal(a.names[0], "b");
    assert_true(fabs(a.results[0].distance - 1.5) <= a.results[0].bound);
    assert_true(a.results[0].lower <= 1.5 && 1.5 <= a.results[0].upper);
    assert_true(a.results[0].point.x == 5.0);
    free(a.results);
    world_release(near);
    world_release(pair);
    assert_int_equal(registry_remove(F.reg, "pair"), 0);
    free(pts);
}

/* TRIOCT_MAX_POINTS points answer in several chunks, every result once and in order. */
static void test_distance_results_come_in_chunks(void **state)
{
    (void)state;
    trioct_vec3_t *pts = calloc(TRIOCT_MAX_POINTS, sizeof *pts);
    assert_non_null(pts);
    for (int i = 0; i < TRIOCT_MAX_POINTS; i++)
        pts[i] = (trioct_vec3_t){2.0 + i * 0.001, 0.5, 0.5};
    trioct_distance_request_t q = points_request("near", -1, TRIOCT_MAX_POINTS, pts);
    distance_answer a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_true(a.chunks >= 3);
    assert_int_equal(a.count, TRIOCT_MAX_POINTS);
    for (int i = 0; i < TRIOCT_MAX_POINTS; i++) {
        assert_int_equal(a.results[i].item, i);
        assert_true(fabs(a.results[i].distance - (1.0 + i * 0.001)) <= a.results[i].bound + 1e-12);
    }
    free(a.results);
    free(pts);
}

/* A cube shape ([-0.2, 0.2]^3, registered as "cube", and inline) at poses about the unit
 * cube world, where the distances are known exactly: 1 face to face, 0 touching (exactly),
 * and across two objects the nearer named; clearance clear below the distance and not at
 * it. */
static trioct_distance_request_t shape_request(const char *world, int8_t kind, double within, const char *shape,
                                               int n, trioct_pose_t *poses)
{
    trioct_distance_request_t q = points_request(world, within, 0, NULL);
    q.kind = kind;
    q.shape = (char *)shape;
    q.num_poses = n;
    q.poses = poses;
    return q;
}

static void test_shape_distances_and_clearance(void **state)
{
    (void)state;
    install_from_scene("near");
    trioct_pose_t poses[3] = {
        {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {2.2, 0.5, 0.5}}, /* x in [2, 2.4]: 1 from the x = 1 face */
        {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {1.2, 0.5, 0.5}}, /* a quarter turn, x in [1, 1.4]: touching */
        {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {0.5, 0.5, 0.5}}, /* inside: 0.3 from every face */
    };
    /* The registered cube came through an OBJ file, read in floats: its corners are
     * +-(double)0.2f, posed by one rounded addition each. */
    const double h = (double)0.2f;
    const double want[3] = {(2.2 - h) - 1.0, 0.0, 0.5 - h};
    trioct_distance_request_t q = shape_request("near", TRIOCT_DISTANCE_REQUEST_T_SHAPE, -1, "cube", 3, poses);
    distance_answer a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.count, 3);
    assert_int_equal(a.num_names, 1);
    assert_string_equal(a.names[0], "near");
    for (int i = 0; i < 3; i++) {
        const trioct_distance_result_t *r = &a.results[i];
        assert_int_equal(r->item, i);
        assert_true(r->found);
        if (!(r->lower <= want[i] && want[i] <= r->upper))
            fail_msg("pose %d: [%.17g, %.17g], want %g", i, r->lower, r->upper, want[i]);
        assert_true(r->bound < 1e-12);
        assert_true(r->triangle >= 0 && r->triangle < 12 && r->shape_triangle >= 0 && r->shape_triangle < 12);
        assert_int_equal(r->object, 0);
    }
    assert_true(a.results[1].lower == 0 && a.results[1].upper == 0); /* touching, exactly */
    assert_true(a.results[0].point.x == 1 && a.results[0].shape_point.x == 2.2 - h);
    free(a.results);

    /* The same cube inline, as twelve triangles: the same answers. */
    trioct_triangle_t tris[12];
    mesh_data cube = meshgen_box((box3){{-0.2, -0.2, -0.2}, {0.2, 0.2, 0.2}});
    for (int i = 0; i < 12; i++) {
        vec3 v[3];
        for (int k = 0; k < 3; k++)
            v[k] = cube.vertices[cube.indices[3 * i + k]];
        tris[i] = (trioct_triangle_t){{v[0].x, v[0].y, v[0].z}, {v[1].x, v[1].y, v[1].z}, {v[2].x, v[2].y, v[2].z}};
    }
    mesh_data_free(&cube);
    q = shape_request("near", TRIOCT_DISTANCE_REQUEST_T_SHAPE, -1, "", 3, poses);
    q.num_shape_triangles = 12;
    q.shape_triangles = tris;
    a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    const double inline_want[3] = {1.0, 0.0, 0.5 - 0.2};
    for (int i = 0; i < 3; i++)
        assert_true(a.results[i].lower <= inline_want[i] && inline_want[i] <= a.results[i].upper);
    free(a.results);

    /* Nothing within 0.5 of the first pose: found 0, no object named for it. */
    q = shape_request("near", TRIOCT_DISTANCE_REQUEST_T_SHAPE, 0.5, "cube", 1, poses);
    a = ask_distance("near", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_false(a.results[0].found);
    assert_int_equal(a.results[0].object, -1);
    assert_int_equal(a.num_names, 0);
    free(a.results);

    /* Clearance at the first pose: clear at 0.99, not at exactly the contact distance,
     * not at 2. */
    const double radii[3] = {0.99, want[0], 2.0};
    const int clear[3] = {1, 0, 0};
    for (int k = 0; k < 3; k++) {
        q = shape_request("near", TRIOCT_DISTANCE_REQUEST_T_CLEAR, radii[k], "cube", 1, poses);
        a = ask_distance("near", &q);
        assert_int_equal(a.status, TRIOCT_OK);
        assert_int_equal(a.kind, TRIOCT_DISTANCE_REQUEST_T_CLEAR);
        assert_int_equal(a.results[0].clear, clear[k]);
        if (!clear[k]) {
            assert_int_equal(a.num_names, 1);
            assert_string_equal(a.names[a.results[0].object], "near");
        }
        free(a.results);
    }

    /* Objects: a at the origin, b at x = 5; the cube at x = 2.2 is 1.0 from a, 2.6 from b. */
    install_from_scene("pair");
    trioct_pose_t mid = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {2.2, 0.5, 0.5}};
    q = shape_request("pair", TRIOCT_DISTANCE_REQUEST_T_SHAPE, -1, "", 1, &mid);
    q.num_shape_triangles = 12;
    q.shape_triangles = tris;
    a = ask_distance("pair", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_true(a.results[0].lower <= 1.0 && 1.0 <= a.results[0].upper);
    assert_string_equal(a.names[a.results[0].object], "a");
    free(a.results);
    assert_int_equal(registry_remove(F.reg, "pair"), 0);
}

/* What a distance request may not do gets a reply naming it. */
static void test_distance_refusals_name_the_reason(void **state)
{
    (void)state;
    trioct_vec3_t pts[2] = {{3, 0.5, 0.5}, {0, NAN, 0}};
    trioct_distance_request_t q = points_request("raysonly", -1, 1, pts);
    distance_answer a = ask_distance("raysonly", &q);
    expect_distance_error(&a, TRIOCT_ERR_EFFECT, "serves rays only; distance queries need effects = distance");
    free(a.results);
    q = points_request("sphere", -1, 1, pts);
    a = ask_distance("sphere", &q);
    expect_distance_error(&a, TRIOCT_ERR_EFFECT, "serves rays, triangles and meshes only");
    free(a.results);

    q = points_request("near", -1, 2, pts);
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_NONFINITE, "points[1]");
    free(a.results);
    q = points_request("near", NAN, 1, pts);
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_NONFINITE, "within is NaN");
    free(a.results);

    q = points_request("near", -1, 1, pts);
    q.kind = 3;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "kind 3 is not POINTS (0), SHAPE (1) or CLEAR (2)");
    assert_int_equal(a.kind, 3); /* echoed */
    free(a.results);
    q = points_request("near", -1, 1, pts);
    q.rotation = 7;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "rotation 7");
    free(a.results);

    /* A point query carrying a shape mixes up kinds. */
    trioct_pose_t at = identity_pose;
    q = points_request("near", -1, 1, pts);
    q.num_poses = 1;
    q.poses = &at;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "kind POINTS takes points only");
    free(a.results);

    /* SHAPE and CLEAR: their own checks, each named. */
    q = points_request("near", 0.1, 1, pts);
    q.kind = TRIOCT_DISTANCE_REQUEST_T_SHAPE;
    q.shape = "cube";
    q.num_poses = 1;
    q.poses = &at;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "kind SHAPE (1) takes a shape and poses, but the request has 1 points");
    free(a.results);
    q.num_points = 0;
    q.kind = TRIOCT_DISTANCE_REQUEST_T_CLEAR;
    q.within = -1;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "CLEAR's radius must be >= 0");
    free(a.results);
    q.within = 0.5;
    q.shape = "gripper";
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_UNKNOWN_SHAPE, "world near has no query shape \"gripper\"");
    free(a.results);
    q.shape = "";
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "name a shape of the world's scene or send");
    free(a.results);
    q.shape = "cube";
    q.num_poses = 0;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_REQUEST, "num_poses 0: send 1..TRIOCT_MAX_POSES");
    free(a.results);
    trioct_pose_t scaled = {{2, 0, 0, 0, 1, 0, 0, 0, 1}, {0, 0, 0}};
    q.num_poses = 1;
    q.poses = &scaled;
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_BAD_POSE, "poses[0].r is not a rotation");
    free(a.results);

    /* Over the cap: an error naming it, never a cut. */
    trioct_vec3_t *many = calloc(TRIOCT_MAX_POINTS + 1, sizeof *many);
    assert_non_null(many);
    q = points_request("near", -1, TRIOCT_MAX_POINTS + 1, many);
    a = ask_distance("near", &q);
    expect_distance_error(&a, TRIOCT_ERR_OVER_CAP, "num_points 2049 is over TRIOCT_MAX_POINTS=2048");
    free(a.results);
    free(many);
    assert_int_equal(registry_remove(F.reg, "near"), 0);
}

/* ---------- robot states ---------- */

DEFINE_ENCODER(trioct_state_request_t)

/* A state request's one-chunk reply, decoded (the caller cleans it up). */
static trioct_state_reply_t ask_state(const char *world, const trioct_state_request_t *q)
{
    msg m = ENCODE(trioct_state_request_t, q);
    dispatch_reply rep;
    assert_int_equal(dispatch_handle(&F.ctx, channel_of(TRIOCT_CHANNEL_STATE, world), m.data, m.size, NOW, &rep), 0);
    assert_int_equal(rep.chunk_count, 1);
    wire_error err;
    if (wire_check(WIRE_STATE_REPLY, rep.chunks[0].data, rep.chunks[0].size, &err) != 0)
        fail_msg("state reply: %s", err.what);
    trioct_state_reply_t r;
    int len = (int)rep.chunks[0].size;
    assert_int_equal(trioct_state_reply_t_decode(rep.chunks[0].data, 0, len, &r), len);
    dispatch_reply_free(&rep);
    free(m.data);
    return r;
}

/* The state request answers what object_set_state answers on the world's objects: the
 * verdicts, every contact with its object named, allowed pairs and self-collision; a link
 * given inline is the registered shape's own triangles and answers alike. */
static void test_states_answer_as_the_object_set(void **state)
{
    (void)state;
    install_from_scene("edited");
    trioct_pose_t at_b = {{0, -1, 0, 1, 0, 0, 0, 0, 1}, {3, 0.5, 0.25}};
    /* "a_far" first in name order and never touched: the reply's names are its own table,
     * not the world's indexes. */
    trioct_object_edit_t adds[2] = {wire_edit(TRIOCT_OBJECT_EDIT_T_ADD, "b", "box.obj", at_b),
                                    wire_edit(TRIOCT_OBJECT_EDIT_T_ADD, "a_far", "box.obj", identity_pose)};
    adds[1].pose.t.x = 100;
    answer a = ask_objects("edited", 0, 2, adds);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
    world *w = registry_acquire(F.reg, "edited");
    const world_shape *cube = world_find_shape(w, "cube");

    enum { STATES = 24 };
    rng r = rng_seeded(base_seed + 41);
    trioct_pose_t poses[2 * STATES];
    for (int i = 0; i < 2 * STATES; i++) {
        vec3 t = {rng_uniform(&r, -0.5, 3.5), rng_uniform(&r, -0.5, 2), rng_uniform(&r, -0.2, 1.5)};
        poses[i] = pose_at(rng_uniform(&r, 0, 6.28), t);
    }
    const mesh_data *cm = &cube->model->mesh;
    trioct_triangle_t *tris = calloc(cm->triangle_count, sizeof *tris);
    for (size_t t = 0; t < cm->triangle_count; t++)
        tris[t] = (trioct_triangle_t){tv(mesh_data_corner(cm, t, 0)), tv(mesh_data_corner(cm, t, 1)),
                                      tv(mesh_data_corner(cm, t, 2))};
    trioct_state_link_t links[2] = {{"left", "cube", 0, NULL}, {"right", "", (int32_t)cm->triangle_count, tris}};
    char *allow_a[1] = {"b"}, *allow_b[1] = {"right"};
    for (int variant = 0; variant < 3; variant++) {
        int contacts = variant > 0, self = variant == 2, allowed = variant == 2 ? 1 : 0;
        trioct_state_request_t q = {header("edited"), (int8_t)contacts, (int8_t)self, 2, links, allowed,
                                    allow_a, allow_b, 2 * STATES, poses, 0, 0, NULL};
        trioct_state_reply_t rep = ask_state("edited", &q);
        assert_int_equal(rep.header.status, TRIOCT_OK);
        assert_int_equal(rep.num_states, STATES);
        size_t k = 0;
        int invalid = 0;
        for (int s = 0; s < STATES; s++) {
            state_link l[2] = {{"left", cube->model->tree, cube->model->bounds, {{0}, {0, 0, 0}}},
                               {"right", cube->model->tree, cube->model->bounds, {{0}, {0, 0, 0}}}};
            for (int i = 0; i < 2; i++) {
                memcpy(l[i].at.r, poses[2 * s + i].r, sizeof l[i].at.r);
                l[i].at.t = (vec3){poses[2 * s + i].t.x, poses[2 * s + i].t.y, poses[2 * s + i].t.z};
            }
            state_contact buf[512];
            state_output out = {.contacts = buf, .capacity = contacts ? 512 : 1};
            state_allowed al[1] = {{"b", "right"}};
            assert_int_equal(object_set_state(w->objects, l, 2, al, (size_t)allowed, self, contacts, &out, NULL, NULL),
                             OCTREE_OK);
            assert_int_equal(rep.found[s] == 0, out.valid);
            assert_int_equal(rep.found[s], (int)out.count);
            invalid += !out.valid;
            for (size_t c = 0; c < out.count; c++, k++) {
                const trioct_state_contact_t *g = &rep.contacts[k];
                assert_int_equal(g->state, s);
                assert_int_equal(g->link, (int)buf[c].link);
                assert_int_equal(g->with_link, buf[c].with_link);
                if (buf[c].with_link)
                    assert_int_equal(g->other, (int)buf[c].other);
                else
                    assert_string_equal(rep.objects[g->other], w->objects->objects[buf[c].other].name);
                assert_int_equal(g->link_triangle, (int)buf[c].link_triangle);
                assert_int_equal(g->other_triangle, (int)buf[c].other_triangle);
            }
        }
        assert_int_equal(rep.num_contacts, (int)k);
        assert_true(invalid > 0 && invalid < STATES);
        trioct_state_reply_t_decode_cleanup(&rep);
    }
    /* Refused before any work: duplicate link names, a pose count that is no whole state. */
    trioct_state_link_t twice[2] = {{"left", "cube", 0, NULL}, {"left", "cube", 0, NULL}};
    trioct_state_request_t q = {header("edited"), 0, 0, 2, twice, 0, NULL, NULL, 2, poses, 0, 0, NULL};
    trioct_state_reply_t rep = ask_state("edited", &q);
    assert_int_equal(rep.header.status, TRIOCT_ERR_BAD_REQUEST);
    assert_non_null(strstr(rep.header.message, "both named left"));
    trioct_state_reply_t_decode_cleanup(&rep);
    q = (trioct_state_request_t){header("edited"), 0, 0, 2, links, 0, NULL, NULL, 3, poses, 0, 0, NULL};
    rep = ask_state("edited", &q);
    assert_int_equal(rep.header.status, TRIOCT_ERR_BAD_REQUEST);
    assert_non_null(strstr(rep.header.message, "whole number of states"));
    trioct_state_reply_t_decode_cleanup(&rep);
    free(tris);
    world_release(w);
    assert_int_equal(registry_remove(F.reg, "edited"), 0);
}

/* ---------- status codes ---------- */

static int provoked[TRIOCT_WIRE_STATUS_COUNT];

static void saw(const answer *a, int status, const char *needle)
{
    expect_error(a, status, needle);
    provoked[status] = 1;
}

static void test_every_status_code(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 8);
    ray_set rays = sphere_rays(&r, 5);
    trioct_ray_request_t q;
    answer a;

    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    provoked[TRIOCT_OK] = 1;
    answer_free(&a);

    /* BAD_REQUEST: world differs from the channel's, bad detail, bad accuracy, tmin > tmax,
     * max_hits 0 for ALL. */
    q = ray_request("raysonly", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "header.world \"raysonly\" differs from world sphere");
    assert_string_equal(a.world, "raysonly"); /* the world as sent is echoed */
    answer_free(&a);
    q = ray_request("sphere", &rays, 3, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "detail 3");
    assert_int_equal(a.detail, 3);
    answer_free(&a);
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, 5, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "accuracy 5");
    answer_free(&a);
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 2, 1, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "tmin 2 is greater than tmax 1");
    answer_free(&a);
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "max_hits 0");
    answer_free(&a);

    /* UNKNOWN_WORLD. */
    q = ray_request("nope", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("nope", &q);
    saw(&a, TRIOCT_ERR_UNKNOWN_WORLD, "world nope is not held by daemon d1");
    assert_int_equal(a.version, 0);
    answer_free(&a);

    /* NONFINITE: an origin, a direction, tmin, tmax; the index is named. */
    trioct_vec3_t keep = rays.origin[3];
    rays.origin[3].y = NAN;
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_NONFINITE, "origin[3]");
    answer_free(&a);
    rays.origin[3] = keep;
    keep = rays.direction[4];
    rays.direction[4].z = -INFINITY;
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_NONFINITE, "direction[4]");
    answer_free(&a);
    rays.direction[4] = keep;
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, -INFINITY, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_NONFINITE, "tmin");
    answer_free(&a);
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, NAN, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_NONFINITE, "tmax");
    answer_free(&a);

    /* ZERO_DIRECTION, negative zeros included. */
    keep = rays.direction[2];
    rays.direction[2] = (trioct_vec3_t){0.0, -0.0, 0.0};
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_ZERO_DIRECTION, "direction[2] of ray 2 is (0, 0, 0)");
    answer_free(&a);
    rays.direction[2] = keep;

    /* OVER_CAP: too many rays (within the request byte cap), too many hits per ray, and a
     * request over the byte cap. */
    rng big = rng_seeded(base_seed + 9);
    ray_set many = sphere_rays(&big, 1300);
    q = ray_request("sphere", &many, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_OVER_CAP, "num_rays 1300 is over TRIOCT_MAX_RAYS=1280");
    answer_free(&a);
    ray_set_free(&many);
    many = sphere_rays(&big, 1400);
    q = ray_request("sphere", &many, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_OVER_CAP, "TRIOCT_MAX_REQUEST_BYTES=65000");
    answer_free(&a);
    ray_set_free(&many);
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, TRIOCT_MAX_HITS_PER_RAY + 1);
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_OVER_CAP, "max_hits 1001 is over TRIOCT_MAX_HITS_PER_RAY=1000");
    answer_free(&a);

    /* EFFECT: a triangle query on a rays-only world, a ray query on a world without rays. */
    trioct_triangle_t tri = tri_of((vec3){0, 0, 0}, (vec3){1, 0, 0}, (vec3){0, 1, 0});
    trioct_triangle_request_t tq = {header("raysonly"), TRIOCT_TRIANGLE_REQUEST_T_YESNO, -1, 1, &tri};
    a = ask_triangle("raysonly", &tq);
    saw(&a, TRIOCT_ERR_EFFECT, "world raysonly serves rays only; triangle queries need effects = triangles");
    answer_free(&a);
    q = ray_request("flat", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    a = ask_ray("flat", &q);
    saw(&a, TRIOCT_ERR_EFFECT, "world flat serves triangles and meshes only; ray queries need effects = rays");
    answer_free(&a);

    /* NONFINITE in a triangle, names the vertex. */
    tri.b.z = NAN;
    tq = (trioct_triangle_request_t){header("sphere"), TRIOCT_TRIANGLE_REQUEST_T_IDS, -1, 1, &tri};
    a = ask_triangle("sphere", &tq);
    saw(&a, TRIOCT_ERR_NONFINITE, "triangles[0].b");
    answer_free(&a);

    /* DEADLINE: passed is refused; in the future, or 0, is answered. */
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
    q.header.deadline_utime = NOW - 1;
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_DEADLINE, "deadline_utime");
    answer_free(&a);
    /* Any peer may send the most negative deadline: how late it is does not fit an int64,
     * and the message says so rather than overflow (UBSan stops on it in make asan). */
    q.header.deadline_utime = INT64_MIN;
    a = ask_ray("sphere", &q);
    saw(&a, TRIOCT_ERR_DEADLINE, "passed more than 9223372036854775807 us");
    answer_free(&a);
    q.header.deadline_utime = NOW;
    a = ask_ray("sphere", &q);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);

    /* UNKNOWN_SHAPE, and a mesh query's own checks. */
    trioct_pose_t pose = pose_at(0, (vec3){0, 0, 0});
    trioct_mesh_request_t mq = {.header = header("sphere"), .detail = 0, .accuracy = -1, .shape = "gripper",
                                .num_poses = 1, .poses = &pose};
    a = ask_mesh("sphere", &mq);
    saw(&a, TRIOCT_ERR_UNKNOWN_SHAPE, "world sphere has no query shape \"gripper\"");
    answer_free(&a);
    pose.r[4] = INFINITY;
    mq.shape = "cube";
    mq.header = header("sphere");
    a = ask_mesh("sphere", &mq);
    saw(&a, TRIOCT_ERR_NONFINITE, "poses[0].r[4]");
    answer_free(&a);
    pose.r[4] = 1;
    mq.shape = "";
    mq.header = header("sphere");
    a = ask_mesh("sphere", &mq);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "no query shape");
    answer_free(&a);
    /* A pose that is not a rotation, named: the second of two, scaled, then mirrored; a
     * matrix typed with six decimals is a rotation within the tolerance. */
    trioct_pose_t two[2] = {pose_at(0, (vec3){0, 0, 0}), pose_at(0, (vec3){0, 0, 0})};
    two[1].r[0] = two[1].r[4] = two[1].r[8] = 2;
    mq = (trioct_mesh_request_t){.header = header("sphere"), .detail = 0, .accuracy = -1, .shape = "cube",
                                 .num_poses = 2, .poses = two};
    a = ask_mesh("sphere", &mq);
    saw(&a, TRIOCT_ERR_BAD_POSE, "poses[1].r is not a rotation");
    answer_free(&a);
    two[1] = pose_at(0, (vec3){0, 0, 0});
    two[1].r[0] = -1;
    mq.header = header("sphere");
    a = ask_mesh("sphere", &mq);
    saw(&a, TRIOCT_ERR_BAD_POSE, "poses[1].r is not a rotation");
    answer_free(&a);
    two[1] = (trioct_pose_t){{0.707107, -0.707107, 0, 0.707107, 0.707107, 0, 0, 0, 1}, {0, 0, 0}};
    mq.header = header("sphere");
    a = ask_mesh("sphere", &mq);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);

    /* BAD_PATH, LOAD_FAILED and admin ops on the wrong channel. */
    a = load_path("escape", "../x.obj", 0, -1, 0);
    saw(&a, TRIOCT_ERR_BAD_PATH, "x.obj");
    answer_free(&a);
    a = load_path("broken", "garbage.obj", 0, -1, 0);
    saw(&a, TRIOCT_ERR_LOAD_FAILED, "garbage.obj");
    answer_free(&a);
    /* DENIED: a LOAD without the admin key's code. */
    F.unsigned_changes = 1;
    a = load_path("unsigned", "sphere.obj", 0, -1, 0);
    F.unsigned_changes = 0;
    saw(&a, TRIOCT_ERR_DENIED, "does not match the daemon's admin key");
    answer_free(&a);

    /* BUDGET: a LOAD past the daemon's memory budget. */
    memory_account_init(&F.ctx.memory, 1000);
    F.ctx.env.account = &F.ctx.memory;
    a = load_path("toobig", "sphere.obj", 0, -1, 0);
    saw(&a, TRIOCT_ERR_BUDGET, "the daemon's memory_budget is 1000 bytes");
    answer_free(&a);
    F.ctx.env = (world_env){0};
    trioct_admin_request_t ar = admin_request("sphere", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    a = ask_admin(TRIOCT_CHANNEL_LIST, NULL, &ar);
    saw(&a, TRIOCT_ERR_BAD_REQUEST, "admin op 3 (UNLOAD) is not served on this channel");
    answer_free(&a);

    /* NOMEM: the first allocation of an answer fails. */
    q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    dispatch_fail_allocation(1);
    a = ask_ray("sphere", &q);
    dispatch_fail_allocation(0);
    saw(&a, TRIOCT_ERR_NOMEM, "out of memory");
    answer_free(&a);

    /* BUSY and STOPPING come from the loop, through dispatch_error, for each reply type. */
    const struct {
        request_type type;
        trioct_channel_kind kind;
        const char *name;
    } kinds[] = {{REQUEST_RAY, TRIOCT_CHANNEL_RAY, "sphere"},
                 {REQUEST_TRIANGLE, TRIOCT_CHANNEL_TRI, "sphere"},
                 {REQUEST_MESH, TRIOCT_CHANNEL_MESH, "sphere"},
                 {REQUEST_ADMIN, TRIOCT_CHANNEL_LIST, NULL}};
    for (size_t k = 0; k < 4; k++) {
        msg m;
        if (kinds[k].type == REQUEST_RAY) {
            q = ray_request("sphere", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 4);
            m = ENCODE(trioct_ray_request_t, &q);
        } else if (kinds[k].type == REQUEST_TRIANGLE) {
            tq = (trioct_triangle_request_t){header("sphere"), TRIOCT_TRIANGLE_REQUEST_T_IDS, -1, 0, NULL};
            m = ENCODE(trioct_triangle_request_t, &tq);
        } else if (kinds[k].type == REQUEST_MESH) {
            mq = (trioct_mesh_request_t){.header = header("sphere"), .detail = 1, .shape = "cube"};
            m = ENCODE(trioct_mesh_request_t, &mq);
        } else {
            ar = admin_request("", TRIOCT_ADMIN_REQUEST_T_LIST);
            m = ENCODE(trioct_admin_request_t, &ar);
        }
        const char *ch = channel_of(kinds[k].kind, kinds[k].name);
        dispatch_request req;
        assert_int_equal(dispatch_peek(&F.ctx, ch, m.data, m.size, &req), PEEK_REQUEST);
        for (int s = 0; s < 2; s++) {
            int status = s ? TRIOCT_ERR_STOPPING : TRIOCT_ERR_BUSY;
            dispatch_reply rep;
            assert_int_equal(dispatch_error(&F.ctx, &req, status, s ? NULL : "queue full (64 requests)", &rep),
                             0);
            assert_int_equal(rep.status, status);
            answer e = read_reply(&rep, kinds[k].type, req.request_id);
            saw(&e, status, s ? trioct_status_text(status) : "queue full (64 requests)");
            assert_int_equal(e.detail, kinds[k].type == REQUEST_RAY      ? TRIOCT_RAY_REQUEST_T_ALL
                                       : kinds[k].type == REQUEST_ADMIN ? TRIOCT_ADMIN_REQUEST_T_LIST
                                                                        : 1);
            assert_int_equal(e.version, 0);
            answer_free(&e);
            dispatch_reply_free(&rep);
        }
        free(m.data);
    }

    /* UNKNOWN_OBJECT, OBJECT_EXISTS, BAD_POSE: object edits, each naming its edit. */
    install_from_scene("edited");
    trioct_object_edit_t oe = wire_edit(TRIOCT_OBJECT_EDIT_T_MOVE, "nothing", NULL, identity_pose);
    a = ask_objects("edited", 0, 1, &oe);
    saw(&a, TRIOCT_ERR_UNKNOWN_OBJECT, "edits[0] (move nothing)");
    assert_int_equal(a.failed_edit, 0);
    answer_free(&a);
    trioct_object_edit_t pair_edits[2] = {wire_edit(TRIOCT_OBJECT_EDIT_T_MOVE, "edited", NULL, identity_pose),
                                   wire_edit(TRIOCT_OBJECT_EDIT_T_ADD, "edited", "box.obj", identity_pose)};
    a = ask_objects("edited", 0, 2, pair_edits);
    saw(&a, TRIOCT_ERR_OBJECT_EXISTS, "edits[1] (add edited)");
    assert_int_equal(a.failed_edit, 1);
    answer_free(&a);
    oe = wire_edit(TRIOCT_OBJECT_EDIT_T_MOVE, "edited", NULL, identity_pose);
    oe.pose.r[4] = 1.5;
    a = ask_objects("edited", 0, 1, &oe);
    saw(&a, TRIOCT_ERR_BAD_POSE, "edits[0] (edited): the pose is not a rotation");
    answer_free(&a);
    assert_int_equal(registry_remove(F.reg, "edited"), 0);

    for (int s = 0; s < TRIOCT_WIRE_STATUS_COUNT; s++)
        if (!provoked[s])
            fail_msg("status %d (%s) was never provoked", s, trioct_status_name(s));
    ray_set_free(&rays);
}

/* ---------- admin ---------- */

static const trioct_world_info_t *find_info(const answer *a, const char *name)
{
    for (size_t i = 0; i < a->num_worlds; i++)
        if (strcmp(a->worlds[i].name, name) == 0)
            return &a->worlds[i];
    return NULL;
}

static void test_list_and_info_describe_the_worlds(void **state)
{
    (void)state;
    answer a = admin_op("", TRIOCT_ADMIN_REQUEST_T_LIST);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.detail, TRIOCT_ADMIN_REQUEST_T_LIST);
    assert_int_equal(a.version, 0);
    assert_int_equal(a.worlds_changed, 0);
    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t count = registry_entries(F.reg, entries, TRIOCT_MAX_WORLDS);
    assert_int_equal(a.num_worlds, count);
    assert_true(count >= 4);
    for (size_t i = 0; i < count; i++) {
        const trioct_world_info_t *info = &a.worlds[i];
        const world *w = entries[i].w;
        octree_info oi;
        octree_get_info(w->tree, &oi);
        assert_string_equal(info->name, w->spec.name); /* sorted by name, as the registry is */
        assert_string_equal(info->daemon, DAEMON);
        assert_int_equal(info->version, (int64_t)w->version);
        assert_string_equal(info->source, w->spec.source);
        assert_string_equal(info->accuracy, accuracy_mode_name(w->spec.def.mode));
        assert_int_equal(info->effects, (int32_t)w->spec.effects);
        assert_int_equal(info->triangles, (int64_t)oi.triangle_count);
        assert_int_equal(info->vertices, (int64_t)oi.vertex_count);
        assert_int_equal(info->nodes, (int64_t)oi.node_count);
        assert_int_equal(info->leaves, (int64_t)oi.leaf_count);
        assert_int_equal(info->max_level, oi.max_level);
        assert_true(info->resolution == oi.resolution && info->world_size == oi.world_size);
        assert_true(info->world_min.x == oi.world_min.x && info->world_min.z == oi.world_min.z);
        assert_true(info->bbox_min.x == w->report.bbox_lo.x && info->bbox_max.y == w->report.bbox_hi.y);
        assert_int_equal(info->bytes_nodes, (int64_t)oi.bytes_nodes);
        assert_int_equal(info->bytes_leaf_lists, (int64_t)oi.bytes_leaf_lists);
        assert_int_equal(info->bytes_triangles, (int64_t)oi.bytes_triangles);
        assert_int_equal(info->bytes_effects, (int64_t)(w->bytes_shapes + oi.bytes_triangle_boxes));
        assert_int_equal(info->bytes_total, (int64_t)(oi.bytes_total + w->bytes_shapes));
        assert_int_equal(info->num_shapes, (int32_t)w->shape_count);
        for (size_t s = 0; s < w->shape_count; s++)
            assert_string_equal(info->shapes[s], w->shapes[s].name);
        assert_string_equal(info->last_error, entries[i].last_error);
    }
    registry_entries_free(entries, count);
    /* Only the effects a world serves cost memory: a rays-only sphere has no triangle
     * boxes and no shapes; the full one has both. */
    const trioct_world_info_t *full = find_info(&a, "sphere"), *rays = find_info(&a, "raysonly");
    assert_non_null(full);
    assert_non_null(rays);
    assert_int_equal(rays->bytes_effects, 0);
    assert_true(full->bytes_effects > 0);
    assert_int_equal(full->num_shapes, 1);
    assert_string_equal(full->shapes[0], "cube");
    assert_true(full->bytes_total > rays->bytes_total);
    answer_free(&a);

    /* INFO answers for one world, and counts the queries answered on it. */
    a = admin_op("layers", TRIOCT_ADMIN_REQUEST_T_INFO);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.num_worlds, 1);
    assert_string_equal(a.worlds[0].name, "layers");
    int64_t before = a.worlds[0].queries;
    assert_int_equal(a.version, a.worlds[0].version);
    answer_free(&a);
    rng r = rng_seeded(base_seed + 10);
    ray_set rays3 = layer_rays(&r, 3, 1);
    for (int i = 0; i < 3; i++) {
        trioct_ray_request_t q = ray_request("layers", &rays3, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
        answer x = ask_ray("layers", &q);
        assert_int_equal(x.status, TRIOCT_OK);
        answer_free(&x);
    }
    trioct_ray_request_t bad = ray_request("layers", &rays3, 9, -1, 0, INFINITY, 0);
    answer x = ask_ray("layers", &bad);
    assert_int_equal(x.status, TRIOCT_ERR_BAD_REQUEST);
    answer_free(&x);
    a = admin_op("layers", TRIOCT_ADMIN_REQUEST_T_INFO);
    assert_int_equal(a.worlds[0].queries, before + 3); /* answered ones only */
    answer_free(&a);
    ray_set_free(&rays3);
}

static void test_load_and_unload(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 11);
    ray_set rays = sphere_rays(&r, 50);
    for (int i = 0; i < rays.n; i++) /* aim them at the unit box */
        rays.direction[i] = tv(vec3_sub(rng_point_in_box(&r, (box3){{0, 0, 0}, {1, 1, 1}}), vv(rays.origin[i])));

    /* From a mesh path, with options. */
    answer a = load_path("loaded", "box.obj", 0.25, TRIOCT_RAY_REQUEST_T_FAST, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.worlds_changed, 1);
    assert_int_equal(a.detail, TRIOCT_ADMIN_REQUEST_T_LOAD);
    assert_int_equal(a.num_worlds, 1);
    assert_int_equal(a.version, 1);
    assert_string_equal(a.world, "loaded");
    const trioct_world_info_t *info = &a.worlds[0];
    assert_string_equal(info->name, "loaded");
    assert_string_equal(info->source, "box.obj");
    assert_string_equal(info->accuracy, "fast");
    assert_int_equal(info->effects, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    assert_int_equal(info->triangles, 12);
    assert_true(info->resolution == 0.25);
    assert_int_equal(info->version, 1);
    answer_free(&a);
    trioct_ray_request_t q = ray_request("loaded", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("loaded", &q);
    assert_true(expect_rays(&a, "loaded", &rays, RAY_CLOSEST, ACCURACY_FAST, 0, INFINITY, 1) > 10);
    answer_free(&a);
    trioct_triangle_t tri = tri_of((vec3){0, 0, 0}, (vec3){1, 0, 0}, (vec3){0, 1, 0});
    trioct_triangle_request_t tq = {header("loaded"), TRIOCT_TRIANGLE_REQUEST_T_YESNO, -1, 1, &tri};
    a = ask_triangle("loaded", &tq);
    expect_error(&a, TRIOCT_ERR_EFFECT, "serves rays only");
    answer_free(&a);

    /* LOAD of a held world rebuilds it: a new version. Without options it is exact. */
    a = load_path("loaded", "box.obj", 0, TRIOCT_RAY_REQUEST_T_ACCURACY_WORLD, 0);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.version, 2);
    assert_string_equal(a.worlds[0].accuracy, "exact");
    assert_int_equal(a.worlds[0].effects, 15); /* all effects, distance among them */
    answer_free(&a);
    q = ray_request("loaded", &rays, TRIOCT_RAY_REQUEST_T_CLOSEST, -1, 0, INFINITY, 0);
    a = ask_ray("loaded", &q);
    assert_int_equal(a.version, 2);
    expect_rays(&a, "loaded", &rays, RAY_CLOSEST, ACCURACY_EXACT, 0, INFINITY, 1);
    answer_free(&a);

    /* A failed rebuild keeps the old version serving and says why in INFO. */
    a = load_path("loaded", "garbage.obj", 0, -1, 0);
    expect_error(&a, TRIOCT_ERR_LOAD_FAILED, "garbage.obj");
    assert_int_equal(a.worlds_changed, 0);
    answer_free(&a);
    a = admin_op("loaded", TRIOCT_ADMIN_REQUEST_T_INFO);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.worlds[0].version, 2);
    assert_non_null(strstr(a.worlds[0].last_error, "garbage.obj"));
    answer_free(&a);

    /* Bad LOAD options. */
    a = load_path("loaded2", "box.obj", 0, -1, 16); /* 8 is EFFECT_DISTANCE */
    expect_error(&a, TRIOCT_ERR_BAD_REQUEST, "effects 0x10");
    answer_free(&a);
    a = load_path("loaded2", "box.obj", NAN, -1, 0);
    expect_error(&a, TRIOCT_ERR_NONFINITE, "resolution");
    answer_free(&a);
    a = load_path("bad-name", "box.obj", 0, -1, 0);
    expect_error(&a, TRIOCT_ERR_BAD_REQUEST, "LOAD needs header.world");
    answer_free(&a);
    a = load_path("loaded2", "/etc/passwd", 0, -1, 0);
    expect_error(&a, TRIOCT_ERR_BAD_PATH, "absolute");
    answer_free(&a);
    a = load_path("loaded2", "sub/../../box.obj", 0, -1, 0);
    expect_error(&a, TRIOCT_ERR_BAD_PATH, NULL);
    answer_free(&a);

    /* From the scene: the section's own options (accuracy = fast, rays only). */
    a = admin_op("spare", TRIOCT_ADMIN_REQUEST_T_LOAD);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_int_equal(a.worlds_changed, 1);
    assert_string_equal(a.worlds[0].accuracy, "fast");
    assert_int_equal(a.worlds[0].effects, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    assert_non_null(strstr(a.worlds[0].source, "[spare]"));
    answer_free(&a);
    a = admin_op("missing", TRIOCT_ADMIN_REQUEST_T_LOAD);
    expect_error(&a, TRIOCT_ERR_BAD_REQUEST, "scene has no section [missing]");
    answer_free(&a);
    /* Options with a section load are refused, each one alone: the section sets them. */
    for (int which = 0; which < 4; which++) {
        trioct_admin_request_t with = admin_request("spare", TRIOCT_ADMIN_REQUEST_T_LOAD);
        if (which == 0)
            with.resolution = 0.5;
        else if (which == 1)
            with.accuracy = TRIOCT_RAY_REQUEST_T_EXACT;
        else if (which == 2)
            with.seed_epsilon = 1e-6;
        else
            with.effects = TRIOCT_WORLD_INFO_T_EFFECT_RAYS | TRIOCT_WORLD_INFO_T_EFFECT_TRIANGLES;
        a = ask_admin(TRIOCT_CHANNEL_LOAD, DAEMON, &with);
        expect_error(&a, TRIOCT_ERR_BAD_REQUEST, "send them only with mesh_path");
        answer_free(&a);
    }

    /* LOAD for another daemon is not ours; INFO on the LOAD channel is refused. */
    trioct_admin_request_t ar = admin_request("spare", TRIOCT_ADMIN_REQUEST_T_LOAD);
    msg m = ENCODE(trioct_admin_request_t, &ar);
    expect_dropped(channel_of(TRIOCT_CHANNEL_LOAD, "d2"), m.data, m.size, PEEK_NOT_MINE);
    free(m.data);
    ar = admin_request("spare", TRIOCT_ADMIN_REQUEST_T_INFO);
    a = ask_admin(TRIOCT_CHANNEL_LOAD, DAEMON, &ar);
    expect_error(&a, TRIOCT_ERR_BAD_REQUEST, "takes LOAD (2)");
    answer_free(&a);

    /* UNLOAD, then the world is gone for every request. */
    for (int k = 0; k < 2; k++) {
        const char *name = k ? "spare" : "loaded";
        a = admin_op(name, TRIOCT_ADMIN_REQUEST_T_UNLOAD);
        assert_int_equal(a.status, TRIOCT_OK);
        assert_int_equal(a.worlds_changed, 1);
        assert_int_equal(a.num_worlds, 0);
        answer_free(&a);
        q = ray_request(name, &rays, TRIOCT_RAY_REQUEST_T_ANY, -1, 0, INFINITY, 0);
        a = ask_ray(name, &q);
        expect_error(&a, TRIOCT_ERR_UNKNOWN_WORLD, "is not held by daemon d1");
        answer_free(&a);
        a = admin_op(name, TRIOCT_ADMIN_REQUEST_T_INFO);
        expect_error(&a, TRIOCT_ERR_UNKNOWN_WORLD, NULL);
        answer_free(&a);
        a = admin_op(name, TRIOCT_ADMIN_REQUEST_T_UNLOAD);
        expect_error(&a, TRIOCT_ERR_UNKNOWN_WORLD, NULL);
        assert_int_equal(a.worlds_changed, 0);
        answer_free(&a);
    }
    a = admin_op("", TRIOCT_ADMIN_REQUEST_T_LIST);
    assert_null(find_info(&a, "loaded"));
    assert_null(find_info(&a, "spare"));
    assert_non_null(find_info(&a, "sphere"));
    answer_free(&a);
    ray_set_free(&rays);
}

/* Worlds with long sources fill more than one chunk; the daemon's world cap is an error. */
static void test_list_comes_in_chunks(void **state)
{
    (void)state;
    /* "./" repeated: a long path that still resolves inside the world directory. */
    char path[1000];
    size_t n = 0;
    while (n + 2 < 960)
        path[n++] = '.', path[n++] = '/';
    strcpy(&path[n], "box.obj");

    registry_entry entries[TRIOCT_MAX_WORLDS];
    size_t before = registry_entries(F.reg, entries, TRIOCT_MAX_WORLDS);
    registry_entries_free(entries, before);
    size_t added = 0;
    char name[16];
    for (; before + added < TRIOCT_MAX_WORLDS; added++) {
        snprintf(name, sizeof name, "w%02zu", added);
        answer a = load_path(name, path, 0.5, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
        assert_int_equal(a.status, TRIOCT_OK);
        answer_free(&a);
    }
    answer a = load_path("onemore", "box.obj", 0, -1, 0);
    expect_error(&a, TRIOCT_ERR_OVER_CAP, "TRIOCT_MAX_WORLDS=64");
    answer_free(&a);

    a = admin_op("", TRIOCT_ADMIN_REQUEST_T_LIST);
    assert_int_equal(a.status, TRIOCT_OK);
    assert_true(a.chunks >= 2);
    assert_int_equal(a.num_worlds, TRIOCT_MAX_WORLDS);
    for (size_t i = 1; i < a.num_worlds; i++) /* in order over the chunks */
        assert_true(strcmp(a.worlds[i - 1].name, a.worlds[i].name) < 0);
    for (size_t i = 0; i < added; i++) {
        snprintf(name, sizeof name, "w%02zu", i);
        const trioct_world_info_t *info = find_info(&a, name);
        assert_non_null(info);
        assert_string_equal(info->source, path);
    }
    answer_free(&a);
    for (size_t i = 0; i < added; i++) {
        snprintf(name, sizeof name, "w%02zu", i);
        a = admin_op(name, TRIOCT_ADMIN_REQUEST_T_UNLOAD);
        assert_int_equal(a.status, TRIOCT_OK);
        answer_free(&a);
    }
}

/* ---------- out of memory ---------- */

typedef struct saved_reply {
    size_t count;
    uint8_t **data;
    size_t *size;
} saved_reply;

/* Each allocation dispatch makes, failed in turn: a NOMEM reply every time, never a crash or
 * a leak, and once there is nothing left to fail, the very bytes of the normal answer. */
/* A change sent again needs a new nonce: the guard refuses the same one twice. */
static void sign_afresh(const char *channel, const msg *m, request_type type)
{
    if (type == REQUEST_ADMIN || type == REQUEST_OBJECTS)
        trioct_admin_sign(&F.key, channel, m->data, m->size, NOW);
}

static void fail_every_allocation(const char *channel, const msg *m, request_type type, int same_bytes)
{
    dispatch_reply base;
    sign_afresh(channel, m, type);
    assert_int_equal(dispatch_handle(&F.ctx, channel, m->data, m->size, NOW, &base), 0);
    assert_int_equal(base.status, TRIOCT_OK);
    for (long nth = 1;; nth++) {
        sign_afresh(channel, m, type);
        dispatch_fail_allocation(nth);
        dispatch_reply rep;
        assert_int_equal(dispatch_handle(&F.ctx, channel, m->data, m->size, NOW, &rep), 0);
        int failed = atomic_load(&dispatch_alloc_countdown) == 0;
        dispatch_fail_allocation(0);
        if (!failed) {
            assert_int_equal(rep.status, TRIOCT_OK);
            assert_int_equal(rep.chunk_count, base.chunk_count);
            for (size_t c = 0; same_bytes && c < rep.chunk_count; c++) {
                assert_int_equal(rep.chunks[c].size, base.chunks[c].size);
                assert_memory_equal(rep.chunks[c].data, base.chunks[c].data, base.chunks[c].size);
            }
            dispatch_reply_free(&rep);
            assert_true(nth > 2);
            break;
        }
        answer a = read_reply(&rep, type, request_id_of(m));
        if (a.status != TRIOCT_ERR_NOMEM)
            fail_msg("allocation %ld failed: status %s \"%s\"", nth, trioct_status_name(a.status), a.message);
        answer_free(&a);
        dispatch_reply_free(&rep);
    }
    dispatch_reply_free(&base);
}

static void test_out_of_memory_is_a_reply(void **state)
{
    (void)state;
    rng r = rng_seeded(base_seed + 12);
    /* Each request below needs the second pass (items with more results than their share)
     * and several chunks, so every allocation path is failed at least once. */
    ray_set rays = layer_rays(&r, 1100, 11);
    trioct_ray_request_t q = ray_request("layers", &rays, TRIOCT_RAY_REQUEST_T_ALL, -1, 0, INFINITY, 500);
    msg m = ENCODE(trioct_ray_request_t, &q);
    fail_every_allocation(channel_of(TRIOCT_CHANNEL_RAY, "layers"), &m, REQUEST_RAY, 1);
    free(m.data);
    ray_set_free(&rays);

    trioct_triangle_t big[40] = {
        tri_of((vec3){-10, -10, 0}, (vec3){10, -10, 0}, (vec3){-10, 10, 0}),
        tri_of((vec3){10, -10, 0}, (vec3){10, 10, 0}, (vec3){-10, 10, 0}),
    };
    for (int i = 2; i < 40; i++) /* beside the terrain */
        big[i] = tri_of((vec3){20, i, 0}, (vec3){21, i, 0}, (vec3){20, i + 1, 0});
    trioct_triangle_request_t tq = {header("flat"), TRIOCT_TRIANGLE_REQUEST_T_SEGMENTS, -1, 40, big};
    m = ENCODE(trioct_triangle_request_t, &tq);
    fail_every_allocation(channel_of(TRIOCT_CHANNEL_TRI, "flat"), &m, REQUEST_TRIANGLE, 1);
    free(m.data);

    trioct_pose_t poses[30] = {pose_at(0, (vec3){0, 0, 0}), pose_at(0.3, (vec3){1, 0, 0})};
    for (int i = 2; i < 30; i++)
        poses[i] = pose_at(0, (vec3){0, 0, i});
    trioct_mesh_request_t mq = {.header = header("flat"), .detail = TRIOCT_MESH_REQUEST_T_PAIRS, .accuracy = -1,
                                .shape = "", .num_shape_triangles = 2, .shape_triangles = big,
                                .num_poses = 30, .poses = poses};
    m = ENCODE(trioct_mesh_request_t, &mq);
    fail_every_allocation(channel_of(TRIOCT_CHANNEL_MESH, "flat"), &m, REQUEST_MESH, 1);
    free(m.data);

    trioct_admin_request_t ar = admin_request("", TRIOCT_ADMIN_REQUEST_T_LIST);
    m = ENCODE(trioct_admin_request_t, &ar);
    fail_every_allocation(channel_of(TRIOCT_CHANNEL_LIST, NULL), &m, REQUEST_ADMIN, 1);
    free(m.data);

    /* A LOAD rebuilds each time, so only the status is compared. */
    ar = admin_request("oom", TRIOCT_ADMIN_REQUEST_T_LOAD);
    ar.mesh_path = "box.obj";
    m = ENCODE(trioct_admin_request_t, &ar);
    fail_every_allocation(channel_of(TRIOCT_CHANNEL_LOAD, DAEMON), &m, REQUEST_ADMIN, 0);
    free(m.data);
    assert_int_equal(registry_remove(F.reg, "oom"), 0);
}

/* Issue 20's guard: what changes the worlds needs the key's code, a fresh timestamp and an
 * unseen nonce; reading needs nothing. */
static void test_changes_need_the_admin_key(void **state)
{
    (void)state;
    install_from_scene("edited");
    world *before = held("edited");
    uint64_t version = before->version;
    world_release(before);

    /* Unsigned, and signed with another key: refused, nothing changed. */
    F.unsigned_changes = 1;
    answer a = admin_op("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    expect_error(&a, TRIOCT_ERR_DENIED, "does not match the daemon's admin key");
    answer_free(&a);
    trioct_admin_request_t r = admin_request("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    msg m = ENCODE(trioct_admin_request_t, &r);
    const char *ch = channel_of(TRIOCT_CHANNEL_ADMIN, "edited");
    trioct_admin_key other = F.key;
    other.bytes[5] ^= 1;
    trioct_admin_sign(&other, ch, m.data, m.size, NOW);
    a = ask(ch, m, REQUEST_ADMIN);
    expect_error(&a, TRIOCT_ERR_DENIED, "does not match");
    answer_free(&a);
    /* Signed for another channel (the code covers the channel's name). */
    r = admin_request("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    m = ENCODE(trioct_admin_request_t, &r);
    trioct_admin_sign(&F.key, channel_of(TRIOCT_CHANNEL_ADMIN, "sphere"), m.data, m.size, NOW);
    a = ask(ch, m, REQUEST_ADMIN);
    expect_error(&a, TRIOCT_ERR_DENIED, "does not match");
    answer_free(&a);
    /* One flipped bit after signing: refused. */
    r = admin_request("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    m = ENCODE(trioct_admin_request_t, &r);
    trioct_admin_sign(&F.key, ch, m.data, m.size, NOW);
    ((uint8_t *)m.data)[20] ^= 0x10;
    a = ask(ch, m, REQUEST_ADMIN);
    assert_int_equal(a.status == TRIOCT_ERR_DENIED || a.status == TRIOCT_ERR_BAD_REQUEST, 1);
    answer_free(&a);
    /* Stale and future timestamps, by more than the window. */
    for (int sign = -1; sign <= 1; sign += 2) {
        r = admin_request("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
        m = ENCODE(trioct_admin_request_t, &r);
        trioct_admin_sign(&F.key, ch, m.data, m.size, NOW + sign * (TRIOCT_ADMIN_WINDOW_US + 1000000));
        a = ask(ch, m, REQUEST_ADMIN);
        expect_error(&a, TRIOCT_ERR_DENIED, sign < 0 ? "31 s from the daemon's clock" : "-31 s from the daemon's clock");
        answer_free(&a);
    }
    /* Reading stays open: INFO and a list without edits, unsigned. */
    a = admin_op("edited", TRIOCT_ADMIN_REQUEST_T_INFO);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
    a = ask_objects("edited", 1, 0, NULL);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
    /* An unsigned edit is refused too. */
    trioct_object_edit_t oe = wire_edit(TRIOCT_OBJECT_EDIT_T_MOVE, "edited", NULL, identity_pose);
    a = ask_objects("edited", 0, 1, &oe);
    expect_error(&a, TRIOCT_ERR_DENIED, "admin key");
    answer_free(&a);
    F.unsigned_changes = 0;
    world *still = held("edited");
    assert_int_equal(still->version, version);
    world_release(still);

    /* Signed, within the window: the edit applies. The same bytes again: a replay, refused. */
    ch = channel_of(TRIOCT_CHANNEL_OBJECTS, "edited");
    trioct_object_edit_request_t er = {header("edited"), 0, 1, &oe, {0}};
    m = ENCODE(trioct_object_edit_request_t, &er);
    trioct_admin_sign(&F.key, ch, m.data, m.size, NOW - TRIOCT_ADMIN_WINDOW_US + 1000);
    msg again = {malloc(m.size), m.size};
    assert_non_null(again.data);
    memcpy(again.data, m.data, m.size);
    F.unsigned_changes = 1; /* keep the signature made above */
    a = ask(ch, m, REQUEST_OBJECTS);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
    a = ask(ch, again, REQUEST_OBJECTS);
    expect_error(&a, TRIOCT_ERR_DENIED, "nonce was seen before");
    answer_free(&a);
    F.unsigned_changes = 0;
    still = held("edited");
    assert_int_equal(still->version, version + 1);
    world_release(still);

    /* A daemon without a key refuses every change, and says how to change worlds. */
    admin_auth *keyed = F.ctx.auth;
    F.ctx.auth = NULL;
    a = admin_op("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    expect_error(&a, TRIOCT_ERR_DENIED, "no admin key (admin_key_file in [daemon])");
    answer_free(&a);
    F.ctx.auth = keyed;
    a = admin_op("edited", TRIOCT_ADMIN_REQUEST_T_UNLOAD);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
}

/* The loader of this build (daemon_proc_loader). */
static void use_the_loader(void)
{
    F.ctx.loader = (mesh_loader){.memory_bytes = (size_t)512 << 20, .cpu_seconds = 30, .wall_seconds = 60};
    snprintf(F.ctx.loader.program, sizeof F.ctx.loader.program, "%s", daemon_proc_loader());
    assert_int_equal(access(F.ctx.loader.program, X_OK), 0);
    F.ctx.env.loader = &F.ctx.loader;
}

/* Issue 20's hostile files, each a LOAD under the name of a world that serves: each gets an
 * error reply naming the file, the world keeps its version and answers as before, and the
 * daemon's account holds what its worlds hold, no more. */
static void test_hostile_loads_leave_the_world_serving(void **state)
{
    (void)state;
    use_the_loader();
    memory_account_init(&F.ctx.memory, (size_t)1 << 30);
    F.ctx.env.account = &F.ctx.memory;
    install_from_scene("spare");
    world *before = held("spare");
    uint64_t version = before->version;

    /* 100,000 nested COLLADA nodes: assimp's recursion overflows the child's stack. */
    char path[512];
    snprintf(path, sizeof path, "%s/deep.dae", F.dir);
    assert_int_equal(hostile_write_deep_collada(path, 100000), 0);
    answer a = load_path("spare", "deep.dae", 0, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    expect_error(&a, TRIOCT_ERR_LOAD_FAILED, "deep.dae");
    answer_free(&a);

    /* A 177-byte PLY header claiming 268 million vertices. */
    snprintf(path, sizeof path, "%s/lying.ply", F.dir);
    assert_int_equal(hostile_write_lying_ply(path), 0);
    a = load_path("spare", "lying.ply", 0, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    expect_error(&a, TRIOCT_ERR_LOAD_FAILED, "lying.ply");
    answer_free(&a);

    /* A FIFO: refused on its type, no worker blocked on it. */
    snprintf(path, sizeof path, "%s/pipe.obj", F.dir);
    assert_int_equal(mkfifo(path, 0600), 0);
    a = load_path("spare", "pipe.obj", 0, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    expect_error(&a, TRIOCT_ERR_LOAD_FAILED, "FIFO");
    answer_free(&a);

    /* A real mesh at a resolution whose tree passes the daemon's budget: ERR_BUDGET naming
     * the budget, and the account back where it was. */
    size_t used = memory_account_used(&F.ctx.memory);
    F.ctx.memory.limit = used + ((size_t)4 << 20);
    a = load_path("spare", "sphere.obj", 0.0005, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    expect_error(&a, TRIOCT_ERR_BUDGET, "memory_budget is 4 MiB");
    answer_free(&a);
    assert_int_equal(memory_account_used(&F.ctx.memory), used);
    /* And one whose mesh alone passes it, refused before the tree. */
    F.ctx.memory.limit = used + 1000;
    a = load_path("spare", "sphere.obj", 0, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    expect_error(&a, TRIOCT_ERR_BUDGET, "its mesh of");
    answer_free(&a);
    assert_int_equal(memory_account_used(&F.ctx.memory), used);

    world *after = held("spare");
    assert_ptr_equal(after, before);
    assert_int_equal(after->version, version);
    world_release(after);
    world_release(before);

    /* With room, the same file loads through the loader, and the account holds exactly the
     * new world's bytes once the old version is gone. */
    F.ctx.memory.limit = (size_t)1 << 30;
    a = load_path("fresh", "sphere.obj", 0, -1, TRIOCT_WORLD_INFO_T_EFFECT_RAYS);
    assert_int_equal(a.status, TRIOCT_OK);
    answer_free(&a);
    world *fresh = held("fresh");
    assert_int_equal(memory_account_used(&F.ctx.memory), used + world_memory_bytes(fresh));
    world_release(fresh);
    assert_int_equal(registry_remove(F.reg, "fresh"), 0);
    assert_int_equal(memory_account_used(&F.ctx.memory), used);
    assert_int_equal(registry_remove(F.reg, "spare"), 0);

    F.ctx.env = (world_env){0};
    const char *made[] = {"deep.dae", "lying.ply", "pipe.obj"};
    for (size_t i = 0; i < 3; i++) {
        snprintf(path, sizeof path, "%s/%s", F.dir, made[i]);
        unlink(path);
    }
}

int main(void)
{
    const char *s = getenv("TRIOCT_SEED");
    if (s)
        base_seed = strtoull(s, NULL, 0);
    printf("test_dispatch seed %llu (set TRIOCT_SEED to rerun)\n", (unsigned long long)base_seed);
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_peek_reads_the_header),
        cmocka_unit_test(test_hostile_loads_leave_the_world_serving),
        cmocka_unit_test(test_changes_need_the_admin_key),
        cmocka_unit_test(test_hostile_bytes_are_dropped),
        cmocka_unit_test(test_peek_measures_the_request_for_the_estimate),
        cmocka_unit_test(test_small_requests_follow_the_threshold),
        cmocka_unit_test(test_rays_equal_the_engine),
        cmocka_unit_test(test_touch_requests_get_touch_answers),
        cmocka_unit_test(test_all_hits_report_more_than_stored),
        cmocka_unit_test(test_ray_results_come_in_chunks),
        cmocka_unit_test(test_triangles_equal_the_engine),
        cmocka_unit_test(test_triangle_results_come_in_chunks),
        cmocka_unit_test(test_mesh_queries_equal_the_engine),
        cmocka_unit_test(test_mesh_pairs_come_in_chunks),
        cmocka_unit_test(test_result_caps_are_errors_not_cuts),
        cmocka_unit_test(test_every_status_code),
        cmocka_unit_test(test_object_edits_answer_as_posed_trees),
        cmocka_unit_test(test_solid_objects_over_the_wire),
        cmocka_unit_test(test_states_answer_as_the_object_set),
        cmocka_unit_test(test_point_distances_to_the_unit_cube),
        cmocka_unit_test(test_point_distances_equal_the_engine),
        cmocka_unit_test(test_distance_results_come_in_chunks),
        cmocka_unit_test(test_shape_distances_and_clearance),
        cmocka_unit_test(test_distance_refusals_name_the_reason),
        cmocka_unit_test(test_list_and_info_describe_the_worlds),
        cmocka_unit_test(test_load_and_unload),
        cmocka_unit_test(test_list_comes_in_chunks),
        cmocka_unit_test(test_out_of_memory_is_a_reply),
    };
    return cmocka_run_group_tests_name("dispatch", tests, setup, teardown);
}
