/* World info records (answers to worlds, info, load, unload and status) for people and as
 * JSON, in one place so every command shows a world the same way. */
#ifndef TRIOCT_CLI_WORLD_INFO_H
#define TRIOCT_CLI_WORLD_INFO_H

#include <stddef.h>
#include <stdio.h>

#include "cli_json.h"
#include "trioct.h"

/* "rays triangles meshes" (the served effects, space-separated; "none" for 0). */
const char *cli_effects_text(int effects, char buf[40]);

/* "starting", "ready", "reloading", "stopping" or "unknown". */
const char *cli_daemon_state_name(int state);

/* One JSON object with every field of the record (docs/cli.md lists them). */
void cli_world_info_json(cli_json *j, const trioct_world_info *w);

/* One world in detail: a block of "key  value" lines. */
void cli_world_info_print(FILE *out, const trioct_world_info *w, const char *indent);

/* Worlds one a line: name, daemon, version, triangles, memory, effects, accuracy. Returns
 * 0, or -1 when out of memory. */
int cli_world_table_print(FILE *out, const trioct_world_info *w, size_t n, const char *indent);

/* A build under way in words: "world W: reading meshes, 1 of 2 files read, N triangles,
 * 3.2 s (LOAD R of client C)". */
void cli_load_progress_text(const trioct_load_progress *p, char *buf, size_t len);
/* The same as a JSON object. */
void cli_load_progress_json(cli_json *j, const trioct_load_progress *p);

#endif
