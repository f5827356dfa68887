#include "logs_world.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "support/meshgen.h"
#include "support/obj_write.h"

static int write_mesh(const char *dir, const char *name, mesh_data mesh)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    int rc = mesh.triangle_count > 0 ? obj_write(path, &mesh) : -1;
    if (rc != 0)
        fprintf(stderr, "trioct-make-logs: cannot write %s: %s\n", path, strerror(errno));
    mesh_data_free(&mesh);
    return rc;
}

static int write_text(const char *dir, const char *name, const char *text)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    int rc = f != NULL && fputs(text, f) >= 0 ? 0 : -1;
    if (f != NULL && fclose(f) != 0)
        rc = -1;
    if (rc != 0)
        fprintf(stderr, "trioct-make-logs: cannot write %s: %s\n", path, strerror(errno));
    return rc;
}

static mesh_data crates(void)
{
    static const box3 boxes[] = {
        {{-6, -6, 0}, {-4, -4, 1.5}},
        {{3, -5, 0}, {5, -3, 2}},
        {{-5, 3, 0}, {-3, 5, 1}},
        {{4, 4, 0}, {6, 6, 2.5}},
    };
    mesh_data all = {0};
    for (size_t i = 0; i < sizeof boxes / sizeof boxes[0]; i++) {
        mesh_data b = meshgen_box(boxes[i]);
        mesh_data_append(&all, &b);
        mesh_data_free(&b);
    }
    return all;
}

static const char scene_head[] =
    "; The scene of the replay logs. Written by tools/replay/make_logs.c with the meshes\n"
    "; beside it; regenerate with `make logs`.\n"
    "[daemon]\n"
    "prefix = TRIOCT\n"
    "name = replayd\n"
    "; Set, so that messages naming it read the same on every machine.\n"
    "memory_budget = 1G\n";

static const char scene_worlds[] =
    "\n"
    "[yard]\n"
    "mesh = terrain.obj\n"
    "mesh = crates.obj\n"
    "mesh = ball.obj\n"
    "effects = rays triangles meshes distance\n"
    "shape.probe = probe.obj\n"
    "shape.ring = ring.obj\n"
    "\n"
    "[yard_rays]\n"
    "mesh = terrain.obj\n"
    "effects = rays\n"
    "\n"
    "[cell]\n"
    "mesh = blocks.obj\n"
    "rotate = 0 0 90\n"
    "translate = 2 0 0\n"
    "effects = triangles meshes\n"
    "shape.probe = probe.obj\n"
    "\n"
    "[spare]\n"
    "mesh = crates.obj\n"
    "accuracy = fast\n"
    "effects = rays\n"
    "\n"
    "[tight]\n"
    "mesh = terrain.obj\n"
    "memory_budget = 64K\n"
    "effects = rays\n"
    "\n"
    "[shop]\n"
    "object.floor = terrain.obj\n"
    "object.crate_a = crates.obj\n"
    "pose.crate_a = 0 0 0.5 1 0 0 0\n"
    "object.crate_b = crates.obj\n"
    "pose.crate_b = 0 0 4 0.7071067811865476 0 0 0.7071067811865476\n"
    "effects = rays triangles meshes distance\n"
    "shape.probe = probe.obj\n";

int logs_write_world(const char *dir)
{
    box3 ground = {{-LOGS_TERRAIN_HALF, -LOGS_TERRAIN_HALF, -0.5}, {LOGS_TERRAIN_HALF, LOGS_TERRAIN_HALF, 0.5}};
    int rc = 0;
    rc |= write_mesh(dir, "terrain.obj", meshgen_terrain(11, ground, 16, 16));
    rc |= write_mesh(dir, "crates.obj", crates());
    rc |= write_mesh(dir, "ball.obj", meshgen_icosphere(vec3_make(LOGS_BALL_X, LOGS_BALL_Y, LOGS_BALL_Z), LOGS_BALL_R, 2));
    rc |= write_mesh(dir, "blocks.obj", meshgen_blocks(7, 3, 3, 2, LOGS_CELL_SIZE));
    rc |= write_mesh(dir, "probe.obj", meshgen_box((box3){{-0.25, -0.25, -0.25}, {0.25, 0.25, 0.25}}));
    rc |= write_mesh(dir, "ring.obj", meshgen_torus(vec3_make(0, 0, 0), 0.6, 0.15, 12, 6));

    char scene[4096];
    snprintf(scene, sizeof scene, "%s%s", scene_head, scene_worlds);
    rc |= write_text(dir, "scene.ini", scene);
    snprintf(scene, sizeof scene,
             "%s; A queue of four: the rest of a burst is answered BUSY.\nqueue_depth = 4\n%s",
             scene_head, scene_worlds);
    rc |= write_text(dir, "busy.ini", scene);

    /* Files that exist and are no mesh: a LOAD of them fails. */
    rc |= write_text(dir, "garbage.obj", "this is not a mesh\n\x01\x02\x03 nor is this\n");
    rc |= write_text(dir, "nan.obj", "v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n");
    return rc ? -1 : 0;
}
