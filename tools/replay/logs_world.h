/* The worlds the replay logs run against: meshes generated from fixed seeds and the scenes
 * naming them, written into the log directory so that it is self-contained:
 *
 *   scene.ini   [yard] terrain, crates and a ball, every effect, shapes probe and ring;
 *               [yard_rays] the terrain, rays only; [cell] blocks touching face to face,
 *               turned 90 degrees and moved, triangles and meshes; [spare] the crates, rays
 *               only, fast accuracy. Prefix TRIOCT, daemon replayd.
 *   busy.ini    the same with queue_depth = 4 (busy.lcmlog runs against it).
 *   garbage.obj, nan.obj: files a LOAD fails on.
 *
 * The geometry the logs aim at is described here too, so the requests hit something. */
#ifndef TRIOCT_LOGS_WORLD_H
#define TRIOCT_LOGS_WORLD_H

#include "geom/vec3.h"

/* The yard: terrain over [-8, 8]^2 within z in [-0.5, 0.5], the ball's centre and radius. */
#define LOGS_TERRAIN_HALF 8.0
#define LOGS_BALL_X 0.0
#define LOGS_BALL_Y 0.0
#define LOGS_BALL_Z 2.5
#define LOGS_BALL_R 1.5
/* The cell: blocks of LOGS_CELL_SIZE on a 3 x 3 x 2 grid, after the scene's transform:
 * x in [0.5, 2], y in [0, 1.5], z in [0, 1]. */
#define LOGS_CELL_SIZE 0.5
#define LOGS_CELL_LO_X 0.5
#define LOGS_CELL_HI_X 2.0
#define LOGS_CELL_LO_Y 0.0
#define LOGS_CELL_HI_Y 1.5
#define LOGS_CELL_HI_Z 1.0

/* Writes the meshes and scenes into dir. 0, or -1 with the reason printed. */
int logs_write_world(const char *dir);

#endif
