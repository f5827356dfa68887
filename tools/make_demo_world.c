/* Writes the demo scene's meshes (scenes/demo.ini names them) into a directory: a terrain
 * yard with crates and boulders, a CAD-like cell of touching blocks, and a probe shape for
 * mesh queries. Generated, so the repository ships the generator, not the files. */
#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>

#include "support/meshgen.h"
#include "support/obj_write.h"

static int write_mesh(const char *dir, const char *name, mesh_data mesh)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    int rc = obj_write(path, &mesh);
    if (rc != 0)
        fprintf(stderr, "make_demo_world: cannot write %s: %s\n", path, strerror(errno));
    else
        printf("  %s: %zu triangles\n", path, mesh.triangle_count);
    mesh_data_free(&mesh);
    return rc;
}

static mesh_data yard_objects(void)
{
    mesh_data all = {0};
    /* Crates standing on the ground and boulders half sunk into it. */
    for (int i = 0; i < 6; i++) {
        double x = -30 + 12 * i, y = (i % 2) ? 8 : -10;
        mesh_data crate = meshgen_box((box3){{x, y, 0}, {x + 3, y + 2, 2.5}});
        mesh_data_append(&all, &crate);
        mesh_data_free(&crate);
    }
    for (int i = 0; i < 4; i++) {
        mesh_data boulder = meshgen_icosphere(vec3_make(-20 + 14 * i, 20 - 9 * i, 0.5), 1.5 + 0.5 * i, 3);
        mesh_data_append(&all, &boulder);
        mesh_data_free(&boulder);
    }
    return all;
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: make_demo_world DIR\n");
        return 2;
    }
    const char *dir = argv[1];
    if (mkdir(dir, 0755) != 0 && errno != EEXIST) {
        fprintf(stderr, "make_demo_world: cannot create %s: %s\n", dir, strerror(errno));
        return 1;
    }
    printf("make_demo_world: writing the demo meshes\n");
    int rc = 0;
    rc |= write_mesh(dir, "terrain.obj", meshgen_terrain(7, (box3){{-50, -50, -1}, {50, 50, 1}}, 96, 96));
    rc |= write_mesh(dir, "yard_objects.obj", yard_objects());
    rc |= write_mesh(dir, "cad_cell.obj", meshgen_blocks(11, 6, 6, 3, 0.25));
    rc |= write_mesh(dir, "probe.obj", meshgen_box((box3){{-0.5, -0.5, -0.5}, {0.5, 0.5, 0.5}}));
    rc |= write_mesh(dir, "gripper.obj", meshgen_torus(vec3_make(0, 0, 0), 0.4, 0.1, 16, 8));
    return rc == 0 ? 0 : 1;
}
