/* The check a solid object's mesh passes at load: closed and consistently oriented, decided
 * exactly. Vertices are the same vertex when their coordinates are equal as doubles (files
 * often repeat a vertex for every face that uses it); every undirected edge must then be
 * used by exactly two triangles, running it in opposite directions. A triangle with a
 * repeated vertex (zero area, two corners equal) is left out: its edges cancel in it, as
 * a -> b and b -> a. Other zero-area triangles (three distinct collinear corners) count
 * like any other (docs/engine.md, "Solid objects", says why parity stays exact).
 *
 * Hash tables, O(n) expected time; the scratch memory (solid_check_bytes) is taken from the
 * caller's room and account before it is allocated and given back at the end. */
#ifndef TRIOCT_WORLD_SOLID_CHECK_H
#define TRIOCT_WORLD_SOLID_CHECK_H

#include <stddef.h>

#include "../engine.h"
#include "mesh_data.h"

typedef enum solid_check_status {
    SOLID_CLOSED = 0,
    SOLID_OPEN_EDGE,        /* an edge only one triangle uses */
    SOLID_OVERUSED_EDGE,    /* an edge three or more triangles use */
    SOLID_MISORIENTED_EDGE, /* an edge two triangles run the same way */
    SOLID_BAD_INDEX,        /* a triangle names a vertex past the array */
    SOLID_NO_MEMORY,
    SOLID_OVER_BUDGET,      /* the scratch is more than room or the account allows */
} solid_check_status;

/* The first defective edge, met scanning the triangles in order. */
typedef struct solid_defect {
    vec3 from, to;   /* the edge as `triangle` runs it */
    size_t triangle; /* the first triangle (in mesh order) that uses the edge */
    size_t other;    /* SOLID_MISORIENTED_EDGE: the next one running it from -> to; else SIZE_MAX */
    size_t uses;     /* triangles using the edge */
} solid_defect;

/* The scratch a check of this mesh takes, in bytes. */
size_t solid_check_bytes(size_t vertex_count, size_t triangle_count);

/* Checks the mesh; on a defect fills *defect (may be NULL). room bounds the scratch
 * (SIZE_MAX: no bound); account, when not NULL, lends it for the check's duration. */
solid_check_status solid_check(const mesh_data *mesh, size_t room, memory_account *account, solid_defect *defect);

/* "edge (x y z) -> (x y z) is open: only <label> uses it" and the like, every coordinate
 * with the 17 digits that give its double back. label names defect->triangle ("triangle
 * 12", "floor.stl triangle 12"), other_label defect->other. */
void solid_defect_text(solid_check_status status, const solid_defect *defect, const char *label,
                       const char *other_label, char *buf, size_t len);

#endif
