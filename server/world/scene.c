/* Scene files: inih splits the text into sections and keys; this file checks every key of
 * every world section and keeps the [daemon] section raw for server/service/options.c.
 *
 * inih is fed through our own line reader (ini_parse_stream), for three reasons:
 * - line numbers: the packaged inih does not pass them to the handler, but it asks the
 *   reader for exactly one line per line number, so counting calls gives them;
 * - section headers: inih only calls the handler for keys, so an empty or repeated
 *   section would be invisible; the reader sees every header line;
 * - indentation: the reader strips leading blanks, so an indented key is a key and never
 *   inih's continuation of the previous value (a scene value always fits one line). */
#include "scene.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <ini.h>

#include "../../common/channels.h"
#include "error_text.h"
#include "object_set.h"

#define DAEMON_SECTION "daemon"
#define SHAPE_KEY_PREFIX "shape."
#define OBJECT_KEY_PREFIX "object."
#define POSE_KEY_PREFIX "pose."
#define SOLID_KEY_PREFIX "solid."

typedef enum section_kind {
    SECTION_NONE,   /* before the first header */
    SECTION_DAEMON,
    SECTION_WORLD,  /* the last entry of parser.worlds */
} section_kind;

/* What the parser remembers of a world beyond its spec: where it began (for "no mesh")
 * and which single-valued keys it has set (to refuse a second value). */
typedef struct world_lines {
    int header_line;
    unsigned keys_seen;
    uint64_t poses_seen; /* bit i: objects[i] had its pose.NAME line (SCENE_MAX_OBJECTS <= 64) */
    uint64_t solids_seen; /* bit i: objects[i] had its solid.NAME line */
} world_lines;
_Static_assert(SCENE_MAX_OBJECTS <= 64, "one bit an object in poses_seen");

typedef struct scene_parser {
    const char *path;
    FILE *file;
    char *line_buf;
    size_t line_cap;
    int line;           /* the line the reader handed out last: inih's line number too */
    int read_errno;     /* errno of a failed read, 0 at a clean end of file */
    section_kind section;
    int daemon_line;    /* header line of [daemon], 0 before it */
    scene_option *options;
    size_t option_count, option_cap;
    world_spec *worlds;
    world_lines *lines; /* parallel to worlds */
    size_t world_count, world_cap;
    char *err;
    size_t err_len;
    int error_line;     /* 0 until the first error */
} scene_parser;

static int parser_fail(scene_parser *p, int line, const char *format, ...)
    __attribute__((format(printf, 3, 4)));

/* Records the first error only: later ones are usually its consequences. */
static int parser_fail(scene_parser *p, int line, const char *format, ...)
{
    if (p->error_line != 0)
        return -1;
    p->error_line = line > 0 ? line : 1;
    if (p->err && p->err_len) {
        char what[512];
        va_list args;
        va_start(args, format);
        vsnprintf(what, sizeof what, format, args);
        va_end(args);
        snprintf(p->err, p->err_len, "%s:%d: %s", p->path, line, what);
    }
    return -1;
}

/* ---------- effects and accuracy words ---------- */

static const struct {
    const char *word;
    unsigned bit;
} effect_words[] = {
    {"rays", EFFECT_RAYS},
    {"triangles", EFFECT_TRIANGLES},
    {"meshes", EFFECT_MESHES},
    {"distance", EFFECT_DISTANCE},
};
#define EFFECT_WORD_COUNT (sizeof effect_words / sizeof effect_words[0])

const char *effects_text(unsigned effects, char *buf, size_t len)
{
    if (!buf || len == 0)
        return "";
    buf[0] = '\0';
    size_t used = 0;
    for (size_t i = 0; i < EFFECT_WORD_COUNT; i++) {
        if (!(effects & effect_words[i].bit))
            continue;
        int n = snprintf(buf + used, len - used, "%s%s", used ? " " : "", effect_words[i].word);
        if (n < 0 || (size_t)n >= len - used)
            return buf; /* cut at the buffer's end, still terminated */
        used += (size_t)n;
    }
    if (used == 0)
        snprintf(buf, len, "none");
    return buf;
}

static int is_effect_separator(char c) { return c == ' ' || c == '\t' || c == ','; }

int effects_parse(const char *text, unsigned *effects, char *err, size_t err_len)
{
    unsigned mask = 0;
    const char *at = text ? text : "";
    for (;;) {
        while (is_effect_separator(*at))
            at++;
        if (*at == '\0')
            break;
        size_t n = 0;
        while (at[n] != '\0' && !is_effect_separator(at[n]))
            n++;
        unsigned bit = 0;
        for (size_t i = 0; i < EFFECT_WORD_COUNT && !bit; i++)
            if (strlen(effect_words[i].word) == n && memcmp(effect_words[i].word, at, n) == 0)
                bit = effect_words[i].bit;
        if (!bit) {
            if (err && err_len)
                snprintf(err, err_len, "unknown effect '%.*s' (rays, triangles, meshes or distance)",
                         n > 64 ? 64 : (int)n, at);
            return -1;
        }
        mask |= bit;
        at += n;
    }
    if (mask == 0) {
        if (err && err_len)
            snprintf(err, err_len, "no effect given (any of rays, triangles, meshes, distance)");
        return -1;
    }
    *effects = mask;
    return 0;
}

int accuracy_parse(const char *text, accuracy_mode *mode)
{
    static const struct {
        const char *word;
        accuracy_mode mode;
    } words[] = {{"exact", ACCURACY_EXACT}, {"seed", ACCURACY_SEED}, {"fast", ACCURACY_FAST}};
    for (size_t i = 0; text && i < sizeof words / sizeof words[0]; i++) {
        if (strcmp(text, words[i].word) == 0) {
            *mode = words[i].mode;
            return 0;
        }
    }
    return -1;
}

/* ---------- specs ---------- */

static const double identity3[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};

static int transform_is_identity(const world_transform *t)
{
    for (int i = 0; i < 9; i++)
        if (t->r[i] != identity3[i])
            return 0;
    return t->scale == 1.0 && t->t.x == 0.0 && t->t.y == 0.0 && t->t.z == 0.0;
}

void world_spec_init(world_spec *spec, const char *name)
{
    memset(spec, 0, sizeof *spec);
    if (name)
        snprintf(spec->name, sizeof spec->name, "%s", name);
    spec->transform.scale = 1.0;
    memcpy(spec->transform.r, identity3, sizeof identity3);
    spec->transform.identity = 1;
    spec->def = octree_default_def();
    spec->effects = EFFECT_ALL;
}

/* Doubles compare with ==, not memcmp: -0 and +0 build the same world, and structs hold
 * padding whose bytes mean nothing. */
static int transform_equal(const world_transform *a, const world_transform *b)
{
    for (int i = 0; i < 9; i++)
        if (a->r[i] != b->r[i])
            return 0;
    return a->scale == b->scale && a->t.x == b->t.x && a->t.y == b->t.y && a->t.z == b->t.z &&
           a->identity == b->identity;
}

/* triangle_boxes is left out: world_build derives it from the effects, whatever the spec
 * holds. */
static int def_equal(const octree_def *a, const octree_def *b)
{
    return a->resolution == b->resolution && a->max_depth == b->max_depth && a->mode == b->mode &&
           a->seed_epsilon == b->seed_epsilon && a->budget_bytes == b->budget_bytes;
}

int world_spec_equal(const world_spec *a, const world_spec *b)
{
    if (strcmp(a->name, b->name) != 0 || a->mesh_count != b->mesh_count || a->up_y != b->up_y || a->solid != b->solid ||
        a->shape_count != b->shape_count || a->effects != b->effects || a->memory_budget != b->memory_budget)
        return 0;
    for (size_t i = 0; i < a->mesh_count; i++)
        if (strcmp(a->meshes[i], b->meshes[i]) != 0)
            return 0;
    for (size_t i = 0; i < a->shape_count; i++)
        if (strcmp(a->shapes[i].name, b->shapes[i].name) != 0 ||
            strcmp(a->shapes[i].path, b->shapes[i].path) != 0)
            return 0;
    if (a->object_count != b->object_count)
        return 0;
    for (size_t i = 0; i < a->object_count; i++) {
        const world_object_spec *x = &a->objects[i], *y = &b->objects[i];
        if (strcmp(x->name, y->name) != 0 || x->mesh != y->mesh || x->solid != y->solid || x->at.t.x != y->at.t.x ||
            x->at.t.y != y->at.t.y || x->at.t.z != y->at.t.z)
            return 0;
        for (int k = 0; k < 9; k++)
            if (x->at.r[k] != y->at.r[k])
                return 0;
    }
    return transform_equal(&a->transform, &b->transform) && def_equal(&a->def, &b->def);
}

/* ---------- numbers ---------- */

/* One finite number filling the whole text (blanks around it allowed). */
static int parse_number(const char *text, double *out)
{
    char *end;
    errno = 0;
    double value = strtod(text, &end);
    if (end == text)
        return -1;
    while (*end == ' ' || *end == '\t')
        end++;
    if (*end != '\0' || !isfinite(value))
        return -1;
    *out = value;
    return 0;
}

/* Exactly n finite numbers separated by blanks or commas; why says what was wrong. */
static int parse_numbers_exactly(const char *text, double *out, int n, char *why, size_t why_len)
{
    const char *at = text;
    for (int i = 0; i < n; i++) {
        while (*at == ' ' || *at == '\t' || (i > 0 && *at == ','))
            at++;
        char *end;
        out[i] = strtod(at, &end);
        if (end == at) {
            snprintf(why, why_len, "found %d", i);
            return -1;
        }
        if (!isfinite(out[i])) {
            snprintf(why, why_len, "number %d is not finite", i + 1);
            return -1;
        }
        at = end;
    }
    while (*at == ' ' || *at == '\t')
        at++;
    if (*at != '\0') {
        snprintf(why, why_len, "more than %d, or not numbers", n);
        return -1;
    }
    return 0;
}

/* Exactly three finite numbers separated by blanks or commas. */
static int parse_three(const char *text, double out[3])
{
    char why[64];
    return parse_numbers_exactly(text, out, 3, why, sizeof why);
}

/* cos and sin of an angle in degrees, exact at every multiple of 90: the angle is split
 * into quarter turns and a rest in [-45, 45], and only the rest goes through cos and sin.
 * cos(pi / 2) in double is 6.1e-17, not 0, and a scene saying "rotate = 0 0 90" means a
 * rotation that maps the axes onto each other exactly. The rest is exact too: fmod is,
 * and the subtraction is of two doubles within a factor of two of each other. */
static void cos_sin_degrees(double degrees, double *c, double *s)
{
    static const double radians_per_degree = 3.14159265358979323846 / 180.0;
    double turn = fmod(degrees, 360.0);
    double quarters = nearbyint(turn / 90.0);
    double rest = (turn - 90.0 * quarters) * radians_per_degree;
    double cr = cos(rest), sr = sin(rest);
    switch (((int)quarters % 4 + 4) % 4) {
    case 0: *c = cr;  *s = sr;  break;
    case 1: *c = -sr; *s = cr;  break;
    case 2: *c = -cr; *s = -sr; break;
    default: *c = sr; *s = -cr; break;
    }
}

/* R = Rz Ry Rx: rotate about the fixed x axis first, then y, then z. Adding +0.0 turns the
 * -0 that products of exact zeros leave into +0. */
static void rotation_from_degrees(const double degrees[3], double r[9])
{
    double cx, sx, cy, sy, cz, sz;
    cos_sin_degrees(degrees[0], &cx, &sx);
    cos_sin_degrees(degrees[1], &cy, &sy);
    cos_sin_degrees(degrees[2], &cz, &sz);
    const double m[9] = {
        cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx,
        sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx,
        -sy,     cy * sx,                cy * cx,
    };
    for (int i = 0; i < 9; i++)
        r[i] = m[i] + 0.0;
}

/* ---------- world keys ---------- */

typedef int (*key_parser)(scene_parser *p, world_spec *spec, const char *key, const char *value);

static int copy_path(scene_parser *p, char *dst, size_t cap, const char *key, const char *value)
{
    if (value[0] == '\0')
        return parser_fail(p, p->line, "%s needs a file path", key);
    if (strlen(value) >= cap)
        return parser_fail(p, p->line, "%s path longer than %zu characters", key, cap - 1);
    memcpy(dst, value, strlen(value) + 1);
    return 0;
}

static int key_mesh(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    if (spec->mesh_count >= SCENE_MAX_MESHES)
        return parser_fail(p, p->line, "more than %d meshes in world '%s'", SCENE_MAX_MESHES, spec->name);
    if (copy_path(p, spec->meshes[spec->mesh_count], sizeof spec->meshes[0], key, value) != 0)
        return -1;
    spec->mesh_count++;
    return 0;
}

static int key_scale(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    double scale;
    if (parse_number(value, &scale) != 0 || !(scale > 0.0))
        return parser_fail(p, p->line, "%s must be a positive number, not '%s'", key, value);
    spec->transform.scale = scale;
    return 0;
}

static int key_up(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    if (strcmp(value, "z") == 0)
        spec->up_y = 0;
    else if (strcmp(value, "y") == 0)
        spec->up_y = 1;
    else
        return parser_fail(p, p->line, "%s must be z (the default) or y (for Y-up files), not '%s'", key, value);
    return 0;
}

static int key_rotate(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    double degrees[3];
    if (parse_three(value, degrees) != 0)
        return parser_fail(p, p->line, "%s must be three angles in degrees (about x, y, z), not '%s'",
                           key, value);
    rotation_from_degrees(degrees, spec->transform.r);
    return 0;
}

static int key_translate(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    double t[3];
    if (parse_three(value, t) != 0)
        return parser_fail(p, p->line, "%s must be three numbers (x y z), not '%s'", key, value);
    spec->transform.t = (vec3){t[0], t[1], t[2]};
    return 0;
}

static int key_resolution(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    if (strcmp(value, "auto") == 0) {
        spec->def.resolution = 0.0;
        return 0;
    }
    double d;
    if (parse_number(value, &d) != 0 || !(d > 0.0))
        return parser_fail(p, p->line, "%s must be 'auto' or a positive length, not '%s'", key, value);
    spec->def.resolution = d;
    return 0;
}

static int key_max_depth(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    char *end;
    errno = 0;
    long depth = strtol(value, &end, 10);
    if (end == value || *end != '\0' || errno != 0 || depth < 0 || depth > OCTREE_MAX_DEPTH_CAP)
        return parser_fail(p, p->line, "%s must be an integer from 0 to %d, not '%s'", key,
                           OCTREE_MAX_DEPTH_CAP, value);
    spec->def.max_depth = (int)depth;
    return 0;
}

int scene_parse_bytes(const char *text, size_t *out)
{
    static const struct {
        const char *unit;
        int shift;
    } units[] = {{"", 0},     {"K", 10}, {"KiB", 10}, {"M", 20}, {"MiB", 20},
                 {"G", 30},   {"GiB", 30}, {"T", 40}, {"TiB", 40}};
    if (!text || *text < '0' || *text > '9')
        return -1;
    char *end;
    errno = 0;
    unsigned long long v = strtoull(text, &end, 10);
    if (errno != 0)
        return -1;
    for (size_t i = 0; i < sizeof units / sizeof units[0]; i++) {
        if (strcmp(end, units[i].unit) != 0)
            continue;
        if (v > (unsigned long long)(SIZE_MAX >> units[i].shift))
            return -1;
        *out = (size_t)v << units[i].shift;
        return 0;
    }
    return -1;
}

static int key_memory_budget(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    size_t bytes;
    if (scene_parse_bytes(value, &bytes) != 0 || bytes == 0)
        return parser_fail(p, p->line, "%s must be a size above 0 such as 512M or 2G, not '%s'", key, value);
    spec->memory_budget = bytes;
    return 0;
}

static int key_accuracy(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    if (accuracy_parse(value, &spec->def.mode) != 0)
        return parser_fail(p, p->line, "%s must be exact, seed or fast, not '%s'", key, value);
    return 0;
}

static int key_seed_epsilon(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    double epsilon;
    if (parse_number(value, &epsilon) != 0 || epsilon < 0.0)
        return parser_fail(p, p->line, "%s must be a number >= 0, not '%s'", key, value);
    spec->def.seed_epsilon = epsilon;
    return 0;
}

static int key_effects(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    char why[160];
    if (effects_parse(value, &spec->effects, why, sizeof why) != 0)
        return parser_fail(p, p->line, "%s: %s", key, why);
    return 0;
}

static int key_shape(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    const char *name = key + strlen(SHAPE_KEY_PREFIX);
    if (!trioct_name_valid(name, TRIOCT_MAX_NAME_LEN))
        return parser_fail(p, p->line, "invalid shape name '%s': 1 to %d characters of A-Z a-z 0-9 _",
                           name, TRIOCT_MAX_NAME_LEN);
    for (size_t i = 0; i < spec->shape_count; i++)
        if (strcmp(spec->shapes[i].name, name) == 0)
            return parser_fail(p, p->line, "shape '%s' given twice", name);
    if (spec->shape_count >= TRIOCT_MAX_SHAPES)
        return parser_fail(p, p->line, "more than %d shapes in world '%s'", TRIOCT_MAX_SHAPES, spec->name);
    world_shape_spec *shape = &spec->shapes[spec->shape_count];
    if (copy_path(p, shape->path, sizeof shape->path, key, value) != 0)
        return -1;
    memcpy(shape->name, name, strlen(name) + 1);
    spec->shape_count++;
    return 0;
}

/* The object entry of that name, made (with no mesh yet, mesh -1) when it is new. NULL
 * past SCENE_MAX_OBJECTS, after saying so. */
static world_object_spec *object_entry(scene_parser *p, world_spec *spec, const char *name)
{
    for (size_t i = 0; i < spec->object_count; i++)
        if (strcmp(spec->objects[i].name, name) == 0)
            return &spec->objects[i];
    if (spec->object_count >= SCENE_MAX_OBJECTS) {
        parser_fail(p, p->line, "more than %d objects in world '%s'", SCENE_MAX_OBJECTS, spec->name);
        return NULL;
    }
    world_object_spec *o = &spec->objects[spec->object_count++];
    memset(o, 0, sizeof *o);
    memcpy(o->name, name, strlen(name) + 1);
    o->mesh = -1;
    o->solid = -1;
    memcpy(o->at.r, identity3, sizeof identity3);
    o->at.t = (vec3){0, 0, 0};
    return o;
}

/* A pose line seen (a bit of the entry is not enough: the entry is made by either key). */
static int object_pose_seen(const scene_parser *p, size_t world, size_t object)
{
    return (p->lines[world].poses_seen >> object) & 1;
}

static int key_object(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    const char *name = key + strlen(OBJECT_KEY_PREFIX);
    if (!object_name_valid(name))
        return parser_fail(p, p->line, "invalid object name '%s': 1 to %d characters of A-Z a-z 0-9 _ . -", name,
                           TRIOCT_MAX_NAME_LEN);
    world_object_spec *o = object_entry(p, spec, name);
    if (!o)
        return -1;
    if (o->mesh >= 0)
        return parser_fail(p, p->line, "object '%s' given twice", name);
    if (value[0] == '\0')
        return parser_fail(p, p->line, "%s needs a file path", key);
    /* Objects of one file share its mesh: it is loaded once. */
    for (size_t i = 0; i < spec->mesh_count; i++)
        if (strcmp(spec->meshes[i], value) == 0) {
            o->mesh = (int)i;
            return 0;
        }
    if (spec->mesh_count >= SCENE_MAX_MESHES)
        return parser_fail(p, p->line, "more than %d mesh files in world '%s'", SCENE_MAX_MESHES, spec->name);
    if (copy_path(p, spec->meshes[spec->mesh_count], sizeof spec->meshes[0], key, value) != 0)
        return -1;
    o->mesh = (int)spec->mesh_count++;
    return 0;
}

static int key_pose(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    const char *name = key + strlen(POSE_KEY_PREFIX);
    if (!object_name_valid(name))
        return parser_fail(p, p->line, "invalid object name '%s': 1 to %d characters of A-Z a-z 0-9 _ . -", name,
                           TRIOCT_MAX_NAME_LEN);
    double v[7];
    char why[160];
    if (parse_numbers_exactly(value, v, 7, why, sizeof why) != 0)
        return parser_fail(p, p->line, "%s must be seven numbers \"x y z qw qx qy qz\": %s", key, why);
    world_object_spec *o = object_entry(p, spec, name);
    if (!o)
        return -1;
    size_t index = (size_t)(o - spec->objects), world = p->world_count - 1;
    if (object_pose_seen(p, world, index))
        return parser_fail(p, p->line, "pose of object '%s' given twice", name);
    p->lines[world].poses_seen |= (uint64_t)1 << index;
    if (octree_pose_from_quaternion((vec3){v[0], v[1], v[2]}, v[3], v[4], v[5], v[6], &o->at) != OCTREE_OK)
        return parser_fail(p, p->line, "%s: the quaternion (qw qx qy qz) = (%g %g %g %g) must have length 1 within %g",
                           key, v[3], v[4], v[5], v[6], OCTREE_QUATERNION_TOLERANCE);
    return 0;
}

/* "yes" or "no", the words a scene writes for a switch; 1, 0, or -1 for anything else. */
static int parse_yes_no(const char *value)
{
    if (strcmp(value, "yes") == 0)
        return 1;
    if (strcmp(value, "no") == 0)
        return 0;
    return -1;
}

static int key_solid(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    int solid = parse_yes_no(value);
    if (solid < 0)
        return parser_fail(p, p->line, "%s must be yes or no, not '%s'", key, value);
    spec->solid = solid;
    return 0;
}

static int key_solid_object(scene_parser *p, world_spec *spec, const char *key, const char *value)
{
    const char *name = key + strlen(SOLID_KEY_PREFIX);
    if (!object_name_valid(name))
        return parser_fail(p, p->line, "invalid object name '%s': 1 to %d characters of A-Z a-z 0-9 _ . -", name,
                           TRIOCT_MAX_NAME_LEN);
    int solid = parse_yes_no(value);
    if (solid < 0)
        return parser_fail(p, p->line, "%s must be yes or no, not '%s'", key, value);
    world_object_spec *o = object_entry(p, spec, name);
    if (!o)
        return -1;
    size_t index = (size_t)(o - spec->objects), world = p->world_count - 1;
    if ((p->lines[world].solids_seen >> index) & 1)
        return parser_fail(p, p->line, "solid of object '%s' given twice", name);
    p->lines[world].solids_seen |= (uint64_t)1 << index;
    o->solid = solid;
    return 0;
}

/* repeatable: the key may appear many times (meshes); the others take one value each. */
static const struct world_key {
    const char *name;
    key_parser parse;
    int repeatable;
} world_keys[] = {
    {"mesh", key_mesh, 1},
    {"scale", key_scale, 0},
    {"rotate", key_rotate, 0},
    {"translate", key_translate, 0},
    {"up", key_up, 0},
    {"resolution", key_resolution, 0},
    {"max_depth", key_max_depth, 0},
    {"accuracy", key_accuracy, 0},
    {"seed_epsilon", key_seed_epsilon, 0},
    {"effects", key_effects, 0},
    {"memory_budget", key_memory_budget, 0},
    {"solid", key_solid, 0},
};
#define WORLD_KEY_COUNT (sizeof world_keys / sizeof world_keys[0])

static int world_key(scene_parser *p, const char *key, const char *value)
{
    world_spec *spec = &p->worlds[p->world_count - 1];
    if (strncmp(key, SHAPE_KEY_PREFIX, strlen(SHAPE_KEY_PREFIX)) == 0)
        return key_shape(p, spec, key, value);
    if (strncmp(key, OBJECT_KEY_PREFIX, strlen(OBJECT_KEY_PREFIX)) == 0)
        return key_object(p, spec, key, value);
    if (strncmp(key, POSE_KEY_PREFIX, strlen(POSE_KEY_PREFIX)) == 0)
        return key_pose(p, spec, key, value);
    if (strncmp(key, SOLID_KEY_PREFIX, strlen(SOLID_KEY_PREFIX)) == 0)
        return key_solid_object(p, spec, key, value);
    for (size_t i = 0; i < WORLD_KEY_COUNT; i++) {
        if (strcmp(key, world_keys[i].name) != 0)
            continue;
        unsigned bit = 1u << i;
        world_lines *lines = &p->lines[p->world_count - 1];
        if (!world_keys[i].repeatable && (lines->keys_seen & bit))
            return parser_fail(p, p->line, "%s given twice in world '%s'", key, spec->name);
        lines->keys_seen |= bit;
        return world_keys[i].parse(p, spec, key, value);
    }
    return parser_fail(p, p->line,
                       "unknown key '%s' in world '%s' (mesh, scale, rotate, translate, up, resolution, "
                       "max_depth, accuracy, seed_epsilon, effects, memory_budget, solid, shape.<name>, object.<name>, pose.<name>, "
                       "solid.<name>)",
                       key, spec->name);
}

/* ---------- sections ---------- */

static int daemon_option(scene_parser *p, const char *key, const char *value)
{
    scene_option option;
    if (strlen(key) >= sizeof option.key)
        return parser_fail(p, p->line, "option name '%.32s...' is too long", key);
    if (strlen(value) >= sizeof option.value)
        return parser_fail(p, p->line, "value of %s is too long", key);
    if (p->option_count == p->option_cap) {
        size_t cap = p->option_cap ? 2 * p->option_cap : 16;
        scene_option *grown = realloc(p->options, cap * sizeof *grown);
        if (!grown)
            return parser_fail(p, p->line, "out of memory");
        p->options = grown;
        p->option_cap = cap;
    }
    memset(&option, 0, sizeof option);
    memcpy(option.key, key, strlen(key) + 1);
    memcpy(option.value, value, strlen(value) + 1);
    option.line = p->line;
    p->options[p->option_count++] = option;
    return 0;
}

static int add_world(scene_parser *p, const char *name)
{
    if (p->world_count == p->world_cap) {
        size_t cap = p->world_cap ? 2 * p->world_cap : 4;
        if (cap > TRIOCT_MAX_WORLDS)
            cap = TRIOCT_MAX_WORLDS;
        world_spec *worlds = realloc(p->worlds, cap * sizeof *worlds);
        if (worlds)
            p->worlds = worlds;
        world_lines *lines = realloc(p->lines, cap * sizeof *lines);
        if (lines)
            p->lines = lines;
        if (!worlds || !lines)
            return parser_fail(p, p->line, "out of memory");
        p->world_cap = cap;
    }
    world_spec *spec = &p->worlds[p->world_count];
    world_spec_init(spec, name);
    int n = snprintf(spec->source, sizeof spec->source, "%s [%s]", p->path, name);
    if (n < 0 || (size_t)n >= sizeof spec->source)
        return parser_fail(p, p->line, "the scene path is too long");
    p->lines[p->world_count] = (world_lines){p->line, 0, 0, 0};
    p->world_count++;
    return 0;
}

static int begin_section(scene_parser *p, const char *name)
{
    if (strcmp(name, DAEMON_SECTION) == 0) {
        if (p->daemon_line)
            return parser_fail(p, p->line, "duplicate section [%s] (first at line %d)", name,
                               p->daemon_line);
        p->daemon_line = p->line;
        p->section = SECTION_DAEMON;
        return 0;
    }
    if (!trioct_name_valid(name, TRIOCT_MAX_NAME_LEN))
        return parser_fail(p, p->line, "invalid world name '%s': 1 to %d characters of A-Z a-z 0-9 _",
                           name, TRIOCT_MAX_NAME_LEN);
    for (size_t i = 0; i < p->world_count; i++)
        if (strcmp(p->worlds[i].name, name) == 0)
            return parser_fail(p, p->line, "duplicate section [%s] (first at line %d)", name,
                               p->lines[i].header_line);
    if (p->world_count >= TRIOCT_MAX_WORLDS)
        return parser_fail(p, p->line, "more than %d worlds", TRIOCT_MAX_WORLDS);
    if (add_world(p, name) != 0)
        return -1;
    p->section = SECTION_WORLD;
    return 0;
}

/* A header is '[' name ']' with anything after the ']' ignored, as inih reads it. A line
 * without ']' is left to inih, which reports it as a syntax error. */
static void maybe_begin_section(scene_parser *p, const char *text)
{
    if (text[0] != '[')
        return;
    const char *close = strchr(text, ']');
    if (!close)
        return;
    char name[256];
    size_t n = (size_t)(close - text - 1);
    if (n >= sizeof name)
        n = sizeof name - 1;
    memcpy(name, text + 1, n);
    name[n] = '\0';
    begin_section(p, name);
}

/* ---------- inih callbacks ---------- */

static int on_key(void *user, const char *section, const char *key, const char *value)
{
    (void)section; /* the reader tracks sections itself; inih's agrees with it */
    scene_parser *p = user;
    if (p->error_line)
        return 0;
    switch (p->section) {
    case SECTION_NONE:
        return parser_fail(p, p->line, "'%s' outside any section", key) == 0;
    case SECTION_DAEMON:
        return daemon_option(p, key, value) == 0;
    case SECTION_WORLD:
        return world_key(p, key, value) == 0;
    }
    return 0;
}

/* inih's fgets-like reader: one line per call, so p->line is inih's line number. Returns
 * NULL (an end of file to inih) once an error is recorded, to stop at the first one. */
static char *read_line(char *str, int num, void *stream)
{
    scene_parser *p = stream;
    if (p->error_line)
        return NULL;
    errno = 0;
    ssize_t got = getline(&p->line_buf, &p->line_cap, p->file);
    if (got < 0) {
        p->read_errno = ferror(p->file) ? (errno ? errno : EIO) : 0;
        return NULL;
    }
    p->line++;
    char *text = p->line_buf;
    size_t len = (size_t)got;
    if (strlen(text) != len) {
        parser_fail(p, p->line, "a NUL byte in the line");
        return NULL;
    }
    if (p->line == 1 && len >= 3 && memcmp(text, "\xEF\xBB\xBF", 3) == 0) {
        text += 3;
        len -= 3;
    }
    while (len > 0 && (text[len - 1] == '\n' || text[len - 1] == '\r'))
        text[--len] = '\0';
    while (*text == ' ' || *text == '\t') {
        text++;
        len--;
    }
    /* inih's line buffer is fixed (num bytes, with room for "\r\n\0"); a longer line would
     * be cut and its tail read as another line. */
    if (num < 3 || len > (size_t)num - 3) {
        parser_fail(p, p->line, "line longer than %d characters", num - 3);
        return NULL;
    }
    maybe_begin_section(p, text);
    if (p->error_line)
        return NULL;
    memcpy(str, text, len);
    str[len] = '\n';
    str[len + 1] = '\0';
    return str;
}

/* ---------- loading ---------- */

static void parser_free(scene_parser *p)
{
    free(p->line_buf);
    free(p->options);
    free(p->worlds);
    free(p->lines);
}

static int by_object_name(const void *a, const void *b)
{
    return strcmp(((const world_object_spec *)a)->name, ((const world_object_spec *)b)->name);
}

/* Objects: each pose names an object, a section with objects takes no mesh or transform
 * keys (a pose places each object), and they are kept in name order, the order their
 * triangles take in the world. */
static int check_objects(scene_parser *p, size_t i)
{
    world_spec *spec = &p->worlds[i];
    if (spec->object_count == 0)
        return 0;
    for (size_t k = 0; k < spec->object_count; k++)
        if (spec->objects[k].mesh < 0)
            return parser_fail(p, p->lines[i].header_line, "world '%s': %s.%s names no object (no object.%s line)",
                               spec->name, object_pose_seen(p, i, k) ? "pose" : "solid", spec->objects[k].name,
                               spec->objects[k].name);
    /* world_keys order: mesh, scale, rotate, translate. */
    if (p->lines[i].keys_seen & 0xfu)
        return parser_fail(p, p->lines[i].header_line,
                           "world '%s' has objects and mesh, scale, rotate or translate keys: with objects, each "
                           "object's pose places it",
                           spec->name);
    qsort(spec->objects, spec->object_count, sizeof *spec->objects, by_object_name);
    return 0;
}

static int check_every_world_has_a_mesh(scene_parser *p)
{
    for (size_t i = 0; i < p->world_count; i++) {
        if (p->worlds[i].mesh_count == 0)
            return parser_fail(p, p->lines[i].header_line, "world '%s' has no mesh",
                               p->worlds[i].name);
        if (check_objects(p, i) != 0)
            return -1;
    }
    return 0;
}

static void finish_transforms(scene_parser *p)
{
    for (size_t i = 0; i < p->world_count; i++)
        p->worlds[i].transform.identity = transform_is_identity(&p->worlds[i].transform);
}

int scene_load(const char *path, scene *out, char *err, size_t err_len)
{
    memset(out, 0, sizeof *out);
    if (err && err_len)
        err[0] = '\0';
    if (!path || !path[0])
        return error_text(err, err_len, "no scene file given");
    if (strlen(path) >= sizeof out->path)
        return error_text(err, err_len, "scene path longer than %zu characters", sizeof out->path - 1);

    scene_parser p;
    memset(&p, 0, sizeof p);
    p.path = path;
    p.err = err;
    p.err_len = err_len;
    p.file = fopen(path, "r");
    if (!p.file)
        return error_text(err, err_len, "%s: cannot open: %s", path, strerror(errno));

    int syntax_line = ini_parse_stream(read_line, &p, on_key, &p);
    fclose(p.file);
    if (p.read_errno && !p.error_line) {
        parser_free(&p);
        return error_text(err, err_len, "%s: cannot read: %s", path, strerror(p.read_errno));
    }
    /* inih's number is the first line it found wrong: a syntax error, or a key our
     * handler refused (then it is p.error_line and the message is ours). */
    if (syntax_line > 0 && (p.error_line == 0 || syntax_line < p.error_line)) {
        p.error_line = 0;
        parser_fail(&p, syntax_line, "syntax error: expected [section], key = value or a comment");
    } else if (syntax_line < 0 && !p.error_line) {
        parser_fail(&p, p.line, "out of memory");
    }
    if (!p.error_line)
        check_every_world_has_a_mesh(&p);
    if (p.error_line) {
        parser_free(&p);
        return -1;
    }
    finish_transforms(&p);
    memcpy(out->path, path, strlen(path) + 1);
    out->daemon_options = p.options;
    out->daemon_option_count = p.option_count;
    out->worlds = p.worlds;
    out->world_count = p.world_count;
    free(p.line_buf);
    free(p.lines);
    return 0;
}

void scene_free(scene *s)
{
    if (!s)
        return;
    free(s->daemon_options);
    free(s->worlds);
    memset(s, 0, sizeof *s);
}

const world_spec *scene_find(const scene *s, const char *name)
{
    for (size_t i = 0; s && name && i < s->world_count; i++)
        if (strcmp(s->worlds[i].name, name) == 0)
            return &s->worlds[i];
    return NULL;
}
