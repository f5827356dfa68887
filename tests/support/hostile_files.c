#include "hostile_files.h"

#include <stdio.h>
#include <string.h>

int hostile_write_deep_collada(const char *path, size_t depth)
{
    FILE *f = fopen(path, "w");
    if (!f)
        return -1;
    fputs("<?xml version=\"1.0\"?>\n<COLLADA xmlns=\"http://www.collada.org/2005/11/COLLADASchema\" "
          "version=\"1.4.1\">\n<library_visual_scenes><visual_scene id=\"s\">\n", f);
    for (size_t i = 0; i < depth; i++)
        fputs("<node>", f);
    for (size_t i = 0; i < depth; i++)
        fputs("</node>", f);
    fputs("\n</visual_scene></library_visual_scenes>\n<scene><instance_visual_scene url=\"#s\"/></scene>\n"
          "</COLLADA>\n", f);
    return fclose(f) == 0 ? 0 : -1;
}

int hostile_write_lying_ply(const char *path)
{
    static const char header[] = "ply\nformat binary_little_endian 1.0\nelement vertex 268435456\n"
                                 "property float x\nproperty float y\nproperty float z\nelement face 1\n"
                                 "property list uchar int vertex_indices\nend_header\n";
    FILE *f = fopen(path, "wb");
    if (!f)
        return -1;
    static const char body[12] = {0};
    fwrite(header, 1, sizeof header - 1, f);
    fwrite(body, 1, sizeof body, f);
    return fclose(f) == 0 ? 0 : -1;
}
