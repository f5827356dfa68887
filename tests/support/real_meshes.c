#include "real_meshes.h"

#include "meshgen.h"
#include "world/mesh_load.h"

static const char *const PATHS[REAL_MESH_COUNT] = {
    [REAL_WUSON] = "/usr/share/assimp/models/PLY/Wuson.ply",
    [REAL_SPIDER] = "/usr/share/assimp/models/STL/Spider_binary.stl",
};
static const char *const KEYS[REAL_MESH_COUNT] = {[REAL_WUSON] = "wuson", [REAL_SPIDER] = "spider"};

const char *real_mesh_path(real_mesh which) { return PATHS[which]; }

const char *real_mesh_key(real_mesh which) { return KEYS[which]; }

int subdivisions_to_reach(size_t triangles, size_t limit)
{
    int times = 0;
    while (triangles > 0 && (triangles << (2 * (times + 1))) <= limit)
        times++;
    return times;
}

int real_mesh_load(real_mesh which, size_t limit, mesh_data *base, mesh_data *sub, int *times, char *err,
                   size_t err_len)
{
    *base = (mesh_data){0};
    if (mesh_load_file(PATHS[which], base, NULL, err, err_len) != 0)
        return -1;
    if (sub) {
        *times = subdivisions_to_reach(base->triangle_count, limit);
        *sub = meshgen_subdivide(base, *times);
    }
    return 0;
}
