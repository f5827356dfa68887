/* World info records for people and for --json (see cli_world_info.h). */
#include "cli_world_info.h"

#include <inttypes.h>
#include <string.h>

#include "cli_text.h"

static const struct {
    int bit;
    const char *name;
} effect_names[] = {
    {TRIOCT_EFFECT_RAYS, "rays"},
    {TRIOCT_EFFECT_TRIANGLES, "triangles"},
    {TRIOCT_EFFECT_MESHES, "meshes"},
    {TRIOCT_EFFECT_DISTANCE, "distance"},
};
#define NUM_EFFECTS (sizeof effect_names / sizeof effect_names[0])

const char *cli_effects_text(int effects, char buf[40])
{
    buf[0] = '\0';
    for (size_t i = 0; i < NUM_EFFECTS; i++)
        if (effects & effect_names[i].bit) {
            if (buf[0] != '\0')
                strcat(buf, " ");
            strcat(buf, effect_names[i].name);
        }
    if (buf[0] == '\0')
        strcpy(buf, "none");
    return buf;
}

const char *cli_daemon_state_name(int state)
{
    switch (state) {
    case TRIOCT_DAEMON_STARTING:
        return "starting";
    case TRIOCT_DAEMON_READY:
        return "ready";
    case TRIOCT_DAEMON_RELOADING:
        return "reloading";
    case TRIOCT_DAEMON_STOPPING:
        return "stopping";
    }
    return "unknown";
}

void cli_world_info_json(cli_json *j, const trioct_world_info *w)
{
    cli_json_object_begin(j);
    cli_json_key_string(j, "name", w->name);
    cli_json_key_string(j, "daemon", w->daemon);
    cli_json_key_int(j, "version", w->version);
    cli_json_key_string(j, "source", w->source);
    cli_json_key_string(j, "accuracy", w->accuracy);
    cli_json_key_double(j, "seed_epsilon", w->seed_epsilon);
    cli_json_key(j, "effects");
    cli_json_array_begin(j);
    for (size_t i = 0; i < NUM_EFFECTS; i++)
        if (w->effects & effect_names[i].bit)
            cli_json_string(j, effect_names[i].name);
    cli_json_array_end(j);
    cli_json_key_int(j, "triangles", w->triangles);
    cli_json_key_int(j, "vertices", w->vertices);
    cli_json_key_int(j, "degenerate", w->degenerate);
    cli_json_key_int(j, "duplicates", w->duplicates);
    cli_json_key_vec3(j, "bbox_min", w->bbox_min);
    cli_json_key_vec3(j, "bbox_max", w->bbox_max);
    cli_json_key_int(j, "nodes", w->nodes);
    cli_json_key_int(j, "leaves", w->leaves);
    cli_json_key_int(j, "max_level", w->max_level);
    cli_json_key_double(j, "resolution", w->resolution);
    cli_json_key_double(j, "world_size", w->world_size);
    cli_json_key_vec3(j, "world_min", w->world_min);
    cli_json_key(j, "bytes");
    cli_json_object_begin(j);
    cli_json_key_int(j, "nodes", w->bytes_nodes);
    cli_json_key_int(j, "leaf_lists", w->bytes_leaf_lists);
    cli_json_key_int(j, "triangles", w->bytes_triangles);
    cli_json_key_int(j, "effects", w->bytes_effects);
    cli_json_key_int(j, "total", w->bytes_total);
    cli_json_object_end(j);
    cli_json_key_int(j, "memory_bytes", w->memory_bytes);
    cli_json_key_int(j, "memory_budget", w->memory_budget);
    cli_json_key_double(j, "build_seconds", w->build_seconds);
    cli_json_key_double(j, "load_seconds", w->load_seconds);
    cli_json_key_int(j, "objects", w->objects);
    cli_json_key_int(j, "queries", w->queries);
    cli_json_key_string(j, "last_error", w->last_error);
    cli_json_key(j, "shapes");
    cli_json_array_begin(j);
    for (int i = 0; i < w->num_shapes && i < TRIOCT_MAX_SHAPES; i++)
        cli_json_string(j, w->shapes[i]);
    cli_json_array_end(j);
    cli_json_object_end(j);
}

static const char *vec3_text(trioct_vec3 v, char *buf, size_t len)
{
    char x[CLI_NUMBER_LEN], y[CLI_NUMBER_LEN], z[CLI_NUMBER_LEN];
    snprintf(buf, len, "(%s, %s, %s)", cli_format_double(v.x, x), cli_format_double(v.y, y),
             cli_format_double(v.z, z));
    return buf;
}

void cli_world_info_print(FILE *out, const trioct_world_info *w, const char *indent)
{
    char a[CLI_NUMBER_LEN], b[CLI_NUMBER_LEN], c[CLI_NUMBER_LEN], d[CLI_NUMBER_LEN],
        e[CLI_NUMBER_LEN];
    char v1[128], v2[128], eff[40];
    fprintf(out, "%sworld       %s (version %" PRId64 ", daemon %s)\n", indent, w->name,
            w->version, w->daemon);
    fprintf(out, "%ssource      %s\n", indent, w->source);
    fprintf(out, "%seffects     %s\n", indent, cli_effects_text(w->effects, eff));
    if (strcmp(w->accuracy, "seed") == 0)
        fprintf(out, "%saccuracy    seed (epsilon %s)\n", indent,
                cli_format_double(w->seed_epsilon, a));
    else
        fprintf(out, "%saccuracy    %s\n", indent, w->accuracy);
    fprintf(out,
            "%striangles   %" PRId64 " (%" PRId64 " vertices, %" PRId64 " degenerate, %" PRId64
            " duplicates)\n",
            indent, w->triangles, w->vertices, w->degenerate, w->duplicates);
    fprintf(out, "%sbounds      %s .. %s\n", indent, vec3_text(w->bbox_min, v1, sizeof v1),
            vec3_text(w->bbox_max, v2, sizeof v2));
    fprintf(out,
            "%soctree      %" PRId64 " nodes, %" PRId64
            " leaves, L_max %d, leaf side d %s, cube side D %s from %s\n",
            indent, w->nodes, w->leaves, w->max_level, cli_format_double(w->resolution, a),
            cli_format_double(w->world_size, b), vec3_text(w->world_min, v1, sizeof v1));
    fprintf(out, "%smemory      %s (nodes %s, leaf lists %s, triangles %s, effects %s)\n", indent,
            cli_format_bytes(w->bytes_total, a), cli_format_bytes(w->bytes_nodes, b),
            cli_format_bytes(w->bytes_leaf_lists, c), cli_format_bytes(w->bytes_triangles, d),
            cli_format_bytes(w->bytes_effects, e));
    if (w->memory_budget > 0)
        fprintf(out, "%sbudget      %s of %s (meshes and trees)\n", indent, cli_format_bytes(w->memory_bytes, a),
                cli_format_bytes(w->memory_budget, b));
    else
        fprintf(out, "%sbudget      %s (meshes and trees; no budget of its own)\n", indent,
                cli_format_bytes(w->memory_bytes, a));
    fprintf(out, "%smeshes      read in %.3f s\n", indent, w->load_seconds);
    fprintf(out, "%soctrees     built in %.3f s (after the meshes were read)\n", indent, w->build_seconds);
    fprintf(out, "%sobjects     %" PRId64 " (trioct objects %s lists them)\n", indent, w->objects, w->name);
    fprintf(out, "%squeries     %" PRId64 "\n", indent, w->queries);
    fprintf(out, "%sshapes      ", indent);
    for (int i = 0; i < w->num_shapes && i < TRIOCT_MAX_SHAPES; i++)
        fprintf(out, "%s%s", i ? " " : "", w->shapes[i]);
    fprintf(out, "%s\n", w->num_shapes > 0 ? "" : "none");
    if (w->last_error[0] != '\0')
        fprintf(out, "%slast error  %s\n", indent, w->last_error);
}

int cli_world_table_print(FILE *out, const trioct_world_info *w, size_t n, const char *indent)
{
    cli_table t;
    /* Numeric columns: version, triangles, memory. */
    cli_table_init(&t, 7, (1u << 2) | (1u << 3) | (1u << 4));
    cli_table_cell(&t, "WORLD");
    cli_table_cell(&t, "DAEMON");
    cli_table_cell(&t, "VERSION");
    cli_table_cell(&t, "TRIANGLES");
    cli_table_cell(&t, "MEMORY");
    cli_table_cell(&t, "ACCURACY");
    cli_table_cell(&t, "EFFECTS");
    for (size_t i = 0; i < n; i++) {
        char bytes[CLI_NUMBER_LEN], eff[40];
        cli_table_cell(&t, "%s", w[i].name);
        cli_table_cell(&t, "%s", w[i].daemon);
        if (w[i].version == 0) {
            /* A scene world whose build failed: not served, and why. */
            for (int c = 0; c < 4; c++)
                cli_table_cell(&t, "-");
            cli_table_cell(&t, "not loaded: %s", w[i].last_error);
            continue;
        }
        cli_table_cell(&t, "%" PRId64, w[i].version);
        cli_table_cell(&t, "%" PRId64, w[i].triangles);
        cli_table_cell(&t, "%s", cli_format_bytes(w[i].bytes_total, bytes));
        cli_table_cell(&t, "%s", w[i].accuracy);
        cli_table_cell(&t, "%s%s", cli_effects_text(w[i].effects, eff),
                       w[i].last_error[0] ? "  (last reload failed)" : "");
    }
    int rc = cli_table_print(&t, out, indent);
    cli_table_free(&t);
    return rc;
}

void cli_load_progress_text(const trioct_load_progress *p, char *buf, size_t len)
{
    int n = snprintf(buf, len, "world %s: %s, %d of %d file%s read, %" PRId64 " triangles, %.1f s", p->world, p->phase,
                     p->files_done, p->files_total, p->files_total == 1 ? "" : "s", p->triangles, p->elapsed_seconds);
    if (n >= 0 && (size_t)n < len && p->client_id != 0)
        snprintf(buf + n, len - (size_t)n, " (LOAD %" PRId64 " of client %" PRIx64 ")", p->request_id,
                 (uint64_t)p->client_id);
    else if (n >= 0 && (size_t)n < len)
        snprintf(buf + n, len - (size_t)n, " (the scene's)");
}

void cli_load_progress_json(cli_json *j, const trioct_load_progress *p)
{
    cli_json_object_begin(j);
    cli_json_key_string(j, "world", p->world);
    cli_json_key_int(j, "client_id", p->client_id);
    cli_json_key_int(j, "request_id", p->request_id);
    cli_json_key_string(j, "phase", p->phase);
    cli_json_key_int(j, "files_done", p->files_done);
    cli_json_key_int(j, "files_total", p->files_total);
    cli_json_key_int(j, "triangles", p->triangles);
    cli_json_key_double(j, "elapsed_seconds", p->elapsed_seconds);
    cli_json_object_end(j);
}
