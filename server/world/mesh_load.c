/* Reads any mesh file assimp understands into one welded triangle mesh in double, with node
 * transforms applied, and counts what a user should know about it (degenerate, duplicate). */
#include "mesh_load.h"

#include <errno.h>
#include <pthread.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include "../../common/array_reserve.h"
#include "geom/vec3.h"
#include "error_text.h"

static pthread_mutex_t import_lock = PTHREAD_MUTEX_INITIALIZER;

/* Triangulate: the engine only knows triangles. SortByPType: points and lines end up in
 * meshes of their own, so they are skipped (and counted) without touching triangle order.
 * ValidateDataStructure: assimp rejects out-of-range indices and broken scenes before we
 * read them.
 * Deliberately absent: JoinIdenticalVertices (it matches positions in float with a ULP
 * tolerance that a NaN defeats: a vertex (1, nan, 1) gets merged into a finite one and the
 * NaN vanishes unreported; the exact weld below joins identical positions instead),
 * FindDegenerates (degenerate triangles are kept and counted), FindInvalidData (it drops
 * position arrays holding NaN instead of letting us refuse them), PreTransformVertices (it
 * applies node transforms in float; we do it in double). */
#define MESH_LOAD_FLAGS \
    (aiProcess_Triangulate | aiProcess_SortByPType | aiProcess_ValidateDataStructure)

/* Vertex and triangle ids are uint32 in the engine; UINT32_MAX marks an empty hash slot. */
#define MESH_LOAD_MAX_COUNT ((size_t)UINT32_MAX - 1)
#define EMPTY_SLOT UINT32_MAX

/* An affine map in double: p' = m[.][0..2] p + m[.][3]. */
typedef struct affine {
    double m[3][4];
} affine;

typedef struct node_visit {
    const struct aiNode *node;
    affine parent_world;
} node_visit;

typedef struct loader {
    const char *path;
    char *err;
    size_t err_len;
    mesh_data out;
    size_t vertex_capacity, triangle_capacity;
    uint32_t *weld;    /* open addressing: output vertex ids, keyed by exact position */
    size_t weld_mask;
    uint32_t *seen;    /* open addressing: output triangle ids, keyed by sorted vertex ids */
    size_t seen_mask;
    uint32_t *remap;   /* per assimp mesh: its vertex -> output vertex, EMPTY_SLOT if unseen */
    size_t remap_capacity;
    mesh_load_report report;
} loader;

static int fail(loader *ld, const char *format, ...) __attribute__((format(printf, 2, 3)));
static int fail(loader *ld, const char *format, ...)
{
    va_list args;
    va_start(args, format);
    error_vtext(ld->err, ld->err_len, format, args);
    va_end(args);
    return -1;
}

static int fail_nomem(loader *ld) { return fail(ld, "%s: out of memory while loading", ld->path); }

/* ---------- hashing ---------- */

static uint64_t mix64(uint64_t x)
{
    x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
    x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
    return x ^ (x >> 31);
}

static uint64_t double_bits(double x)
{
    uint64_t bits;
    memcpy(&bits, &x, sizeof bits);
    return bits;
}

static uint64_t position_hash(vec3 p)
{
    return mix64(double_bits(p.x) ^ mix64(double_bits(p.y) ^ mix64(double_bits(p.z))));
}

static void sort3(uint32_t v[3])
{
    uint32_t t;
    if (v[0] > v[1]) { t = v[0]; v[0] = v[1]; v[1] = t; }
    if (v[1] > v[2]) { t = v[1]; v[1] = v[2]; v[2] = t; }
    if (v[0] > v[1]) { t = v[0]; v[0] = v[1]; v[1] = t; }
}

static uint64_t triple_hash(const uint32_t v[3])
{
    return mix64(((uint64_t)v[0] << 32 | v[1]) ^ mix64(v[2]));
}

static uint32_t *new_table(size_t capacity)
{
    uint32_t *table = malloc(capacity * sizeof *table);
    if (table)
        memset(table, 0xff, capacity * sizeof *table);
    return table;
}

/* Keeps both tables at most half full. The weld table holds vertices, the other triangles. */
static int grow_weld(loader *ld)
{
    size_t needed = 2 * (ld->out.vertex_count + 1);
    if (ld->weld && ld->weld_mask + 1 >= needed)
        return 0;
    size_t capacity = ld->weld ? 2 * (ld->weld_mask + 1) : 1024;
    while (capacity < needed)
        capacity *= 2;
    uint32_t *table = new_table(capacity);
    if (!table)
        return -1;
    for (size_t v = 0; v < ld->out.vertex_count; v++) {
        size_t slot = (size_t)position_hash(ld->out.vertices[v]) & (capacity - 1);
        while (table[slot] != EMPTY_SLOT)
            slot = (slot + 1) & (capacity - 1);
        table[slot] = (uint32_t)v;
    }
    free(ld->weld);
    ld->weld = table;
    ld->weld_mask = capacity - 1;
    return 0;
}

static int grow_seen(loader *ld)
{
    size_t needed = 2 * (ld->out.triangle_count + 1);
    if (ld->seen && ld->seen_mask + 1 >= needed)
        return 0;
    size_t capacity = ld->seen ? 2 * (ld->seen_mask + 1) : 1024;
    while (capacity < needed)
        capacity *= 2;
    uint32_t *table = new_table(capacity);
    if (!table)
        return -1;
    for (size_t t = 0; t < ld->out.triangle_count; t++) {
        uint32_t key[3];
        memcpy(key, ld->out.indices + 3 * t, sizeof key);
        sort3(key);
        size_t slot = (size_t)triple_hash(key) & (capacity - 1);
        while (table[slot] != EMPTY_SLOT)
            slot = (slot + 1) & (capacity - 1);
        table[slot] = (uint32_t)t;
    }
    free(ld->seen);
    ld->seen = table;
    ld->seen_mask = capacity - 1;
    return 0;
}

/* ---------- building the output ---------- */

/* The output vertex at exactly position p, added if new; p must be finite. */
static int weld_vertex(loader *ld, vec3 p, uint32_t *id)
{
    /* Adding +0.0 turns -0.0 into +0.0, so the two zeros (equal as numbers) hash alike. */
    p = vec3_make(p.x + 0.0, p.y + 0.0, p.z + 0.0);
    if (grow_weld(ld) != 0)
        return fail_nomem(ld);
    size_t slot = (size_t)position_hash(p) & ld->weld_mask;
    while (ld->weld[slot] != EMPTY_SLOT) {
        if (vec3_equal(ld->out.vertices[ld->weld[slot]], p)) {
            *id = ld->weld[slot];
            return 0;
        }
        slot = (slot + 1) & ld->weld_mask;
    }
    if (ld->out.vertex_count >= MESH_LOAD_MAX_COUNT)
        return fail(ld, "%s: more than %zu distinct vertices", ld->path, MESH_LOAD_MAX_COUNT);
    if (ld->out.vertex_count == ld->vertex_capacity) {
        size_t capacity = ld->vertex_capacity ? 2 * ld->vertex_capacity : 1024;
        vec3 *grown = realloc(ld->out.vertices, capacity * sizeof *grown);
        if (!grown)
            return fail_nomem(ld);
        ld->out.vertices = grown;
        ld->vertex_capacity = capacity;
    }
    *id = (uint32_t)ld->out.vertex_count;
    ld->out.vertices[ld->out.vertex_count++] = p;
    ld->weld[slot] = *id;
    return 0;
}

/* A triangle counts as degenerate when its cross product, evaluated in double, is exactly
 * zero: every triangle with a repeated vertex, and collinear ones whose differences round
 * cleanly. It is the figure a user sees about the file; the engine decides near-degenerate
 * triangles with exact predicates on its own and needs nothing from this count. */
static int looks_degenerate(vec3 a, vec3 b, vec3 c)
{
    vec3 n = vec3_cross(vec3_sub(b, a), vec3_sub(c, a));
    return n.x == 0.0 && n.y == 0.0 && n.z == 0.0;
}

static int add_triangle(loader *ld, const uint32_t v[3])
{
    if (ld->out.triangle_count >= MESH_LOAD_MAX_COUNT)
        return fail(ld, "%s: more than %zu triangles", ld->path, MESH_LOAD_MAX_COUNT);
    if (grow_seen(ld) != 0)
        return fail_nomem(ld);
    if (ld->out.triangle_count == ld->triangle_capacity) {
        size_t capacity = ld->triangle_capacity ? 2 * ld->triangle_capacity : 1024;
        uint32_t *grown = realloc(ld->out.indices, 3 * capacity * sizeof *grown);
        if (!grown)
            return fail_nomem(ld);
        ld->out.indices = grown;
        ld->triangle_capacity = capacity;
    }
    const vec3 *p = ld->out.vertices;
    if (looks_degenerate(p[v[0]], p[v[1]], p[v[2]]))
        ld->report.degenerate++;

    /* Positions are welded exactly, so equal positions are equal ids. */
    uint32_t key[3] = {v[0], v[1], v[2]};
    sort3(key);
    size_t slot = (size_t)triple_hash(key) & ld->seen_mask;
    int duplicate = 0;
    while (ld->seen[slot] != EMPTY_SLOT) {
        uint32_t other[3];
        memcpy(other, ld->out.indices + 3 * (size_t)ld->seen[slot], sizeof other);
        sort3(other);
        if (memcmp(key, other, sizeof key) == 0) {
            duplicate = 1;
            break;
        }
        slot = (slot + 1) & ld->seen_mask;
    }
    size_t t = ld->out.triangle_count++;
    memcpy(ld->out.indices + 3 * t, v, 3 * sizeof *v);
    if (duplicate)
        ld->report.duplicates++;
    else
        ld->seen[slot] = (uint32_t)t;
    ld->report.triangles = ld->out.triangle_count;
    return 0;
}

/* ---------- transforms ---------- */

static affine affine_identity(void)
{
    return (affine){{{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}}};
}

/* parent * local, with local's bottom row taken as (0 0 0 1): node transforms are affine. */
static affine affine_compose(const affine *parent, const struct aiMatrix4x4 *local)
{
    const double l[3][4] = {
        {local->a1, local->a2, local->a3, local->a4},
        {local->b1, local->b2, local->b3, local->b4},
        {local->c1, local->c2, local->c3, local->c4},
    };
    affine r;
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 4; j++) {
            double sum = parent->m[i][0] * l[0][j] + parent->m[i][1] * l[1][j] +
                         parent->m[i][2] * l[2][j];
            r.m[i][j] = j == 3 ? sum + parent->m[i][3] : sum;
        }
    }
    return r;
}

static vec3 affine_apply(const affine *a, const struct aiVector3D *p)
{
    double x = p->x, y = p->y, z = p->z;
    return vec3_make(a->m[0][0] * x + a->m[0][1] * y + a->m[0][2] * z + a->m[0][3],
                     a->m[1][0] * x + a->m[1][1] * y + a->m[1][2] * z + a->m[1][3],
                     a->m[2][0] * x + a->m[2][1] * y + a->m[2][2] * z + a->m[2][3]);
}

/* ---------- scene walk ---------- */

static int add_mesh_instance(loader *ld, const struct aiMesh *mesh, const affine *world)
{
    if (!mesh->mVertices || !mesh->mFaces || mesh->mNumFaces == 0)
        return 0;
    if (mesh->mNumVertices > ld->remap_capacity) {
        uint32_t *grown = realloc(ld->remap, mesh->mNumVertices * sizeof *grown);
        if (!grown)
            return fail_nomem(ld);
        ld->remap = grown;
        ld->remap_capacity = mesh->mNumVertices;
    }
    memset(ld->remap, 0xff, mesh->mNumVertices * sizeof *ld->remap);

    size_t before = ld->out.triangle_count;
    for (unsigned f = 0; f < mesh->mNumFaces; f++) {
        const struct aiFace *face = &mesh->mFaces[f];
        if (face->mNumIndices < 3 || !face->mIndices) {
            ld->report.skipped_primitives++;
            continue;
        }
        for (unsigned k = 0; k < face->mNumIndices; k++)
            if (face->mIndices[k] >= mesh->mNumVertices)
                return fail(ld, "%s: a face refers to vertex %u of a mesh with %u vertices",
                            ld->path, face->mIndices[k], mesh->mNumVertices);
        /* Triangulate leaves only triangles; a fan keeps any larger face usable anyway. */
        for (unsigned k = 1; k + 1 < face->mNumIndices; k++) {
            unsigned corner[3] = {face->mIndices[0], face->mIndices[k], face->mIndices[k + 1]};
            uint32_t v[3];
            for (int c = 0; c < 3; c++) {
                uint32_t *mapped = &ld->remap[corner[c]];
                if (*mapped == EMPTY_SLOT) {
                    vec3 p = affine_apply(world, &mesh->mVertices[corner[c]]);
                    if (!vec3_is_finite(p))
                        return fail(ld, "%s: triangle %zu has a NaN or infinite coordinate",
                                    ld->path, ld->out.triangle_count);
                    if (weld_vertex(ld, p, mapped) != 0)
                        return -1;
                }
                v[c] = *mapped;
            }
            if (add_triangle(ld, v) != 0)
                return -1;
        }
    }
    if (ld->out.triangle_count > before)
        ld->report.meshes++;
    return 0;
}

/* Depth first, children in file order, with an explicit stack: a deep hierarchy in a
 * hostile file cannot overflow the C stack. */
static int walk_nodes(loader *ld, const struct aiScene *scene)
{
    size_t capacity = 64, depth = 0;
    node_visit *stack = malloc(capacity * sizeof *stack);
    if (!stack)
        return fail_nomem(ld);
    stack[depth++] = (node_visit){scene->mRootNode, affine_identity()};
    int status = 0;
    while (depth > 0 && status == 0) {
        node_visit visit = stack[--depth];
        const struct aiNode *node = visit.node;
        affine world = affine_compose(&visit.parent_world, &node->mTransformation);
        for (unsigned k = 0; k < node->mNumMeshes && status == 0; k++) {
            unsigned mesh_index = node->mMeshes[k];
            if (mesh_index >= scene->mNumMeshes || !scene->mMeshes[mesh_index])
                status = fail(ld, "%s: a node refers to mesh %u of %u", ld->path, mesh_index,
                              scene->mNumMeshes);
            else
                status = add_mesh_instance(ld, scene->mMeshes[mesh_index], &world);
        }
        if (status != 0 || !node->mChildren)
            continue;
        if (array_reserve((void **)&stack, &capacity, depth + node->mNumChildren, sizeof *stack, 64) != 0) {
            status = fail_nomem(ld);
            break;
        }
        /* Pushed last-first so the first child is visited first. */
        for (unsigned c = node->mNumChildren; c-- > 0;)
            if (node->mChildren[c])
                stack[depth++] = (node_visit){node->mChildren[c], world};
    }
    free(stack);
    return status;
}

/* assimp's own "unable to open" hides the reason; errno names it. */
static const char *file_kind(mode_t mode)
{
    if (S_ISDIR(mode))
        return "a directory";
    if (S_ISFIFO(mode))
        return "a FIFO";
    if (S_ISCHR(mode) || S_ISBLK(mode))
        return "a device";
    if (S_ISSOCK(mode))
        return "a socket";
    return "not a regular file";
}

/* Only a regular file is handed to the importer. It is opened without blocking and asked
 * what it is on that descriptor: a FIFO would block an open for reading, and with it the
 * thread, until a writer came (a FIFO in the world directory hung a worker), and a device
 * could be read forever. */
static int check_readable(loader *ld)
{
    char reason[128] = "unknown error";
    int fd = open(ld->path, O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        strerror_r(errno, reason, sizeof reason);
        return fail(ld, "cannot open %s: %s", ld->path, reason);
    }
    struct stat info;
    int rc = fstat(fd, &info);
    int why = errno;
    close(fd);
    if (rc != 0) {
        strerror_r(why, reason, sizeof reason);
        return fail(ld, "cannot open %s: %s", ld->path, reason);
    }
    if (!S_ISREG(info.st_mode))
        return fail(ld, "cannot load %s: it is %s, not a regular file", ld->path, file_kind(info.st_mode));
    return 0;
}

static void compute_bbox(loader *ld)
{
    if (ld->out.vertex_count == 0)
        return;
    vec3 lo = ld->out.vertices[0], hi = lo;
    for (size_t v = 1; v < ld->out.vertex_count; v++) {
        lo = vec3_min(lo, ld->out.vertices[v]);
        hi = vec3_max(hi, ld->out.vertices[v]);
    }
    ld->report.bbox_lo = lo;
    ld->report.bbox_hi = hi;
}

int mesh_load_file(const char *path, mesh_data *out, mesh_load_report *report, char *err,
                   size_t err_len)
{
    loader ld;
    memset(&ld, 0, sizeof ld);
    ld.path = path ? path : "(null)";
    ld.err = err;
    ld.err_len = err_len;
    memset(out, 0, sizeof *out);
    if (report)
        memset(report, 0, sizeof *report);
    if (err && err_len)
        err[0] = '\0';
    if (!path)
        return fail(&ld, "no mesh file given");
    if (check_readable(&ld) != 0)
        return -1;

    /* aiGetErrorString is the importer's last error, one for the whole process: the import
     * and the reading of its error happen under one lock, so loads on several threads
     * (the daemon loads worlds off its loop) each report their own error. */
    pthread_mutex_lock(&import_lock);
    const struct aiScene *scene = aiImportFile(path, MESH_LOAD_FLAGS);
    if (!scene) {
        const char *why = aiGetErrorString();
        fail(&ld, "cannot load %s: %s", path, why && *why ? why : "assimp failed");
        pthread_mutex_unlock(&import_lock);
        return -1;
    }
    pthread_mutex_unlock(&import_lock);
    int status = scene->mRootNode ? walk_nodes(&ld, scene) : 0;
    aiReleaseImport(scene);
    free(ld.weld);
    free(ld.seen);
    free(ld.remap);

    if (status == 0 && ld.out.triangle_count == 0)
        status = fail(&ld, "no triangles in %s", path);
    if (status != 0) {
        mesh_data_free(&ld.out);
        return -1;
    }
    /* Trim the growth slack; a failed shrink keeps the larger, valid block. */
    vec3 *vertices = realloc(ld.out.vertices, ld.out.vertex_count * sizeof *vertices);
    if (vertices)
        ld.out.vertices = vertices;
    uint32_t *indices = realloc(ld.out.indices, 3 * ld.out.triangle_count * sizeof *indices);
    if (indices)
        ld.out.indices = indices;
    compute_bbox(&ld);
    *out = ld.out;
    if (report)
        *report = ld.report;
    return 0;
}
